//! Complex refractive index of liquid water in the visible and near infrared.
//!
//! - Real part: Daimon & Masumura, "Measurement of the refractive index of
//!   distilled water from the near-infrared region to the ultraviolet
//!   region", Applied Optics 46, 3811 (2007): four-term Sellmeier fit at
//!   20 °C, n² − 1 = Σ Bᵢ λ² / (λ² − Cᵢ), λ in µm, valid 182–1129 nm. It is
//!   the index relative to vacuum; nimbus uses it as the droplets' index
//!   relative to air, neglecting air's 1.00028 (a 3e-4 change in m).
//! - Imaginary part: k = a λ / (4π) from the absorption coefficient a of pure
//!   water of Pope & Fry, "Absorption spectrum (380–700 nm) of pure water. II.
//!   Integrating cavity measurements", Applied Optics 36, 8710 (1997),
//!   sampled every 20 nm and interpolated log-linearly; outside 380–720 nm it
//!   is held at the end values (k stays below 1e-7: it changes cloud-droplet
//!   efficiencies by less than 1e-5).

use num_complex::Complex64;

/// Wavelengths (nm) the index is defined for.
pub const VALID_WAVELENGTH_NM: (f64, f64) = (200.0, 1100.0);

const SELLMEIER_B: [f64; 4] = [
    5.684027565e-1,
    1.726177391e-1,
    2.086189578e-2,
    1.130748688e-1,
];
const SELLMEIER_C_UM2: [f64; 4] = [
    5.101829712e-3,
    1.821153936e-2,
    2.620722293e-2,
    1.069792721e1,
];

/// Pope & Fry (1997) absorption of pure water, (wavelength nm, a m⁻¹).
const POPE_FRY_ABSORPTION: [(f64, f64); 18] = [
    (380.0, 0.01137),
    (400.0, 0.00663),
    (420.0, 0.00454),
    (440.0, 0.00635),
    (460.0, 0.00981),
    (480.0, 0.01500),
    (500.0, 0.0204),
    (520.0, 0.0396),
    (540.0, 0.0527),
    (560.0, 0.0708),
    (580.0, 0.1050),
    (600.0, 0.2224),
    (620.0, 0.2755),
    (640.0, 0.3112),
    (660.0, 0.4100),
    (680.0, 0.4650),
    (700.0, 0.6500),
    (720.0, 1.1690),
];

/// Real part of water's index at a vacuum wavelength in nm (20 °C).
pub fn water_real_index(wavelength_nm: f64) -> f64 {
    let l2 = (wavelength_nm * 1e-3).powi(2);
    let sum: f64 = SELLMEIER_B
        .iter()
        .zip(SELLMEIER_C_UM2)
        .map(|(b, c)| b * l2 / (l2 - c))
        .sum();
    (1.0 + sum).sqrt()
}

/// Absorption coefficient of pure water, m⁻¹ (Pope & Fry 1997, clamped outside 380–720 nm).
pub fn water_absorption_per_m(wavelength_nm: f64) -> f64 {
    let table = &POPE_FRY_ABSORPTION;
    let wl = wavelength_nm.clamp(table[0].0, table[table.len() - 1].0);
    let i = table
        .iter()
        .position(|(w, _)| *w >= wl)
        .unwrap_or(table.len() - 1)
        .max(1);
    let ((w0, a0), (w1, a1)) = (table[i - 1], table[i]);
    let t = (wl - w0) / (w1 - w0);
    (a0.ln() + t * (a1.ln() - a0.ln())).exp()
}

/// Complex index n + ik of liquid water at a vacuum wavelength in nm.
pub fn water_refractive_index(wavelength_nm: f64) -> Complex64 {
    let k =
        water_absorption_per_m(wavelength_nm) * wavelength_nm * 1e-9 / (4.0 * std::f64::consts::PI);
    Complex64::new(water_real_index(wavelength_nm), k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_index_matches_reference_values() {
        // Sodium D line at 20 °C: n = 1.33299 relative to air (IAPWS R9-97;
        // CRC Handbook), i.e. 1.33299 × n_air (1.000277) = 1.33336 relative to
        // vacuum, which is what Daimon & Masumura fit.
        assert!(
            (water_real_index(589.29) - 1.33336).abs() < 3e-5,
            "{}",
            water_real_index(589.29)
        );
        // Dispersion: blue above red (Daimon & Masumura 2007, table 3: 1.3432 at 404.7 nm, 1.3306 at 706.5 nm).
        assert!(
            (water_real_index(404.66) - 1.3432).abs() < 3e-4,
            "{}",
            water_real_index(404.66)
        );
        assert!(
            (water_real_index(706.52) - 1.3306).abs() < 3e-4,
            "{}",
            water_real_index(706.52)
        );
    }

    #[test]
    fn imaginary_index_is_tiny_and_grows_to_the_red() {
        let blue = water_refractive_index(440.0).im;
        let red = water_refractive_index(680.0).im;
        assert!(
            blue > 0.0 && blue < 1e-9 && red > 1e-8 && red < 5e-8,
            "{blue} {red}"
        );
        // The table point itself: a(680 nm) = 0.465 m⁻¹ (Pope & Fry 1997).
        assert!((water_absorption_per_m(680.0) - 0.465).abs() < 1e-9);
    }
}
