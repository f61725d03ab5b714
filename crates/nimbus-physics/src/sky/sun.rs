//! Sun direction, the solar constant and disk, and the textbook air-mass
//! model of the direct beam (used to cross-check the atmosphere model).
//!
//! Direction: nimbus's world frame (+Y up, east = +X, north = −Z), azimuth
//! measured clockwise from north, elevation above the horizon.
//!
//! Direct beam: Beer–Lambert with Rayleigh and aerosol optical depths times
//! the relative air mass:
//! - extraterrestrial illuminance E₀ = 133.8 klx (Darula, Kittler & Gueymard,
//!   "Reference luminous solar constant and solar luminance for illuminance
//!   calculations", Solar Energy 79, 2005);
//! - Rayleigh optical depth τ_R(λ) = 0.008735 λ^−4.08, λ in µm (Leckner,
//!   Solar Energy 20, 1978);
//! - aerosol optical depth τ_a(λ) = β λ^−α with α = 1.3 and
//!   β = 0.04608 T − 0.04586 from the turbidity T (Preetham, Shirley & Smits,
//!   "A Practical Analytic Model for Daylight", SIGGRAPH 1999, appendix A.2);
//! - relative air mass m(θ) = 1 / (cos θ + 0.50572 (96.07995° − θ)^−1.6364),
//!   θ the zenith angle in degrees (Kasten & Young, Applied Optics 28, 1989).

/// Extraterrestrial solar illuminance at one astronomical unit, lx (Darula et al. 2005).
pub const SOLAR_ILLUMINANCE_CONSTANT_LUX: f64 = 133_800.0;

/// Mean angular radius of the solar disk seen from Earth, rad (0.2666°).
pub const SOLAR_DISK_ANGULAR_RADIUS_RAD: f64 = 4.653e-3;

/// Unit vector towards the sun from azimuth (clockwise from north) and
/// elevation above the horizon, both in degrees.
pub fn sun_direction(azimuth_deg: f64, elevation_deg: f64) -> [f64; 3] {
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    [el.cos() * az.sin(), el.sin(), -el.cos() * az.cos()]
}

/// Relative optical air mass for a zenith angle in degrees (Kasten & Young 1989);
/// valid up to and slightly past the horizon, clamped at 96°.
pub fn relative_air_mass(zenith_deg: f64) -> f64 {
    let z = zenith_deg.clamp(0.0, 96.0);
    1.0 / (z.to_radians().cos() + 0.50572 * (96.07995 - z).powf(-1.6364))
}

/// Rayleigh optical depth of the whole atmosphere at sea level, λ in µm (Leckner 1978).
pub fn rayleigh_optical_depth(wavelength_um: f64) -> f64 {
    0.008735 * wavelength_um.powf(-4.08)
}

/// Aerosol optical depth for Preetham's turbidity T (≥ 1) at λ in µm.
pub fn aerosol_optical_depth(turbidity: f64, wavelength_um: f64) -> f64 {
    let beta = (0.04608 * turbidity - 0.04586).max(0.0);
    beta * wavelength_um.powf(-1.3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direction_follows_the_world_convention() {
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
        assert!(close(sun_direction(0.0, 0.0), [0.0, 0.0, -1.0])); // north = −Z
        assert!(close(sun_direction(90.0, 0.0), [1.0, 0.0, 0.0])); // east = +X
        assert!(close(sun_direction(123.0, 90.0), [0.0, 1.0, 0.0])); // zenith = +Y
    }

    #[test]
    fn air_mass_matches_kasten_young_table() {
        // Near the zenith the plane-parallel limit m = 1 / cos θ holds; at the
        // horizon Kasten & Young (1989) give m(90°) = 37.92 (their table 1: 38.0868
        // for the older 1966 formula, 37.92 for the 1989 revision).
        for (z, m) in [
            (0.0, 1.0),
            (30.0, 1.0 / 30f64.to_radians().cos()),
            (60.0, 2.0),
            (90.0, 37.92),
        ] {
            assert!(
                (relative_air_mass(z) - m).abs() / m < 4e-3,
                "m({z}) = {}",
                relative_air_mass(z)
            );
        }
    }

    #[test]
    fn rayleigh_optical_depth_matches_bucholtz() {
        // Bucholtz, Applied Optics 34, 1995, table 5 (US standard atmosphere):
        // τ_R(0.55 µm) = 0.0973, τ_R(0.44 µm) = 0.2372, τ_R(0.70 µm) = 0.0362.
        for (wl, tau) in [(0.55, 0.0973), (0.44, 0.2372), (0.70, 0.0362)] {
            let got = rayleigh_optical_depth(wl);
            assert!(
                (got - tau).abs() / tau < 0.06,
                "τ_R({wl}) = {got}, expected {tau}"
            );
        }
    }

    #[test]
    fn atmosphere_beam_transmittance_agrees_with_the_air_mass_model() {
        // The spherical atmosphere's transmittance towards the sun against the
        // Beer–Lambert air-mass model with the same optical depths (Kasten &
        // Young air mass, ozone omitted from both): within 2 % down to 10°.
        use crate::atmosphere::AtmosphereParams;
        let p = AtmosphereParams {
            ozone_absorption_per_m: [0.0; 3],
            ..AtmosphereParams::default()
        };
        let r = p.bottom_radius_m;
        for elevation in [90.0f64, 60.0, 30.0, 10.0] {
            let mu = elevation.to_radians().sin();
            let t = p.transmittance_to_top(r, mu);
            let m = relative_air_mass(90.0 - elevation);
            for (c, t_c) in t.iter().enumerate() {
                let tau = p.rayleigh_scattering_per_m[c] * p.rayleigh_scale_height_m
                    + p.aerosol_extinction_per_m()[c] * p.aerosol_scale_height_m;
                let model = (-tau * m).exp();
                assert!(
                    (t_c / model - 1.0).abs() < 0.02,
                    "elevation {elevation}°, channel {c}: {t_c} vs {model}"
                );
            }
        }
    }
}
