//! The Marshall–Palmer drop-size distribution and what follows from it.
//!
//! Marshall & Palmer, "The distribution of raindrops with size", J. Meteor. 5,
//! 1948: N(D) = N₀·e^(−Λ·D) drops per m³ per mm of diameter, with
//! N₀ = 8000 m⁻³·mm⁻¹ and Λ = 4.1·I^(−0.21) mm⁻¹ for a rain intensity I in
//! mm/h. Blanchard (2023, §4.2.2) integrates it from the smallest simulated
//! diameter d_min to infinity for the number of drops per m³,
//! (N₀/Λ)·e^(−Λ·d_min), and samples diameters by inverting the exponential,
//! D = d_min − ln(U)/Λ, clamped to d_max (larger drops break up).
//!
//! Symbols: D diameter (mm), I intensity (mm/h), Λ slope (mm⁻¹).

/// Marshall–Palmer intercept N₀, drops per m³ per mm of diameter.
pub const MARSHALL_PALMER_N0_PER_M3_MM: f64 = 8000.0;

/// The slope Λ = 4.1·I^(−0.21) of the distribution, mm⁻¹ (Marshall & Palmer 1948).
/// Infinite (no drops) for I ≤ 0.
pub fn slope_per_mm(intensity_mm_h: f64) -> f64 {
    if intensity_mm_h > 0.0 {
        4.1 * intensity_mm_h.powf(-0.21)
    } else {
        f64::INFINITY
    }
}

/// Drops per m³ with a diameter of at least `d_min_mm`:
/// ∫_{d_min}^∞ N₀·e^(−Λ·D) dD = (N₀/Λ)·e^(−Λ·d_min) (Blanchard 2023, §4.2.2).
pub fn number_density_per_m3(intensity_mm_h: f64, d_min_mm: f64) -> f64 {
    let slope = slope_per_mm(intensity_mm_h);
    if !slope.is_finite() {
        return 0.0;
    }
    MARSHALL_PALMER_N0_PER_M3_MM / slope * (-slope * d_min_mm).exp()
}

/// A diameter drawn from the distribution above `d_min_mm` by inversion,
/// D = d_min − ln(u)/Λ, clamped to `d_max_mm`; `u` uniform in (0, 1), mm.
/// The GPU simulation evaluates the same expression in f32.
pub fn sample_diameter_mm(u: f64, intensity_mm_h: f64, d_min_mm: f64, d_max_mm: f64) -> f64 {
    let slope = slope_per_mm(intensity_mm_h.max(1e-6));
    (d_min_mm - u.ln() / slope).min(d_max_mm)
}

/// Mean diameter of the sampled drops (the clamped exponential), mm:
/// d_min + (1 − e^(−Λ·(d_max − d_min)))/Λ.
pub fn mean_sampled_diameter_mm(intensity_mm_h: f64, d_min_mm: f64, d_max_mm: f64) -> f64 {
    let slope = slope_per_mm(intensity_mm_h.max(1e-6));
    d_min_mm + (1.0 - (-slope * (d_max_mm - d_min_mm)).exp()) / slope
}

/// ∫_a^b D^k·e^(−Λ·D) dD for k = 2 or 3, closed form, mm^(k+1).
fn moment_integral(k: u32, slope: f64, a: f64, b: f64) -> f64 {
    // Antiderivative −e^(−ΛD)·Σ_{j=0}^{k} k!/(k−j)!·D^(k−j)/Λ^(j+1).
    let antiderivative = |d: f64| -> f64 {
        if !d.is_finite() {
            return 0.0;
        }
        let mut sum = 0.0;
        let mut factor = 1.0;
        for j in 0..=k {
            sum += factor * d.powi((k - j) as i32) / slope.powi(j as i32 + 1);
            factor *= (k - j) as f64;
        }
        -(-slope * d).exp() * sum
    };
    antiderivative(b) - antiderivative(a)
}

/// Extinction coefficient of the rain's drops with diameters in
/// [d_min, d_max], 1/m. Raindrops are thousands of wavelengths across, so
/// their extinction efficiency is 2 (the extinction paradox; van de Hulst,
/// *Light Scattering by Small Particles*, 1957, §8.22):
/// β = ∫ N(D)·2·πD²/4 dD.
pub fn extinction_per_m(intensity_mm_h: f64, d_min_mm: f64, d_max_mm: f64) -> f64 {
    let slope = slope_per_mm(intensity_mm_h);
    if !slope.is_finite() {
        return 0.0;
    }
    let mm2_to_m2 = 1e-6;
    MARSHALL_PALMER_N0_PER_M3_MM
        * std::f64::consts::FRAC_PI_2
        * moment_integral(2, slope, d_min_mm, d_max_mm)
        * mm2_to_m2
}

/// Rain rate carried by the distribution, mm/h: the water volume flux
/// ∫ N(D)·(π/6)·D³·v(D) dD with the fall speed `fall_speed_m_s(D_mm)`,
/// integrated numerically over [0, 8] mm. A consistency check of the
/// distribution against the intensity it was built from.
pub fn rain_rate_mm_h(intensity_mm_h: f64, fall_speed_m_s: impl Fn(f64) -> f64) -> f64 {
    let slope = slope_per_mm(intensity_mm_h);
    if !slope.is_finite() {
        return 0.0;
    }
    let steps = 4000;
    let h = 8.0 / steps as f64;
    let mut flux = 0.0; // mm³ per m³ · m/s
    for i in 0..steps {
        let d = (i as f64 + 0.5) * h;
        flux += MARSHALL_PALMER_N0_PER_M3_MM * (-slope * d).exp() * std::f64::consts::PI / 6.0
            * d.powi(3)
            * fall_speed_m_s(d)
            * h;
    }
    // mm³·m⁻³·m·s⁻¹ = 1e-9 m³ water per m² per s = 1e-6 mm/s.
    flux * 1e-6 * 3600.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_and_counts_follow_marshall_palmer() {
        // Λ(1 mm/h) = 4.1 mm⁻¹ and N(D > 0) = N₀/Λ (Marshall & Palmer 1948).
        assert!((slope_per_mm(1.0) - 4.1).abs() < 1e-12);
        assert!((number_density_per_m3(1.0, 0.0) - 8000.0 / 4.1).abs() < 1e-9);
        // More rain, more drops; no rain, none.
        assert!(number_density_per_m3(10.0, 0.5) > number_density_per_m3(1.0, 0.5));
        assert_eq!(number_density_per_m3(0.0, 0.5), 0.0);
    }

    #[test]
    fn sampled_diameters_have_the_analytic_mean() {
        let (i, d_min, d_max) = (10.0, 0.5, 6.0);
        let n = 200_000;
        let mean: f64 = (0..n)
            .map(|k| sample_diameter_mm((k as f64 + 0.5) / n as f64, i, d_min, d_max))
            .sum::<f64>()
            / n as f64;
        let expected = mean_sampled_diameter_mm(i, d_min, d_max);
        assert!(
            (mean - expected).abs() < 1e-3 * expected,
            "{mean} vs {expected}"
        );
    }

    #[test]
    fn moment_integrals_match_quadrature() {
        for k in [2, 3] {
            let (slope, a, b) = (2.3, 0.4, 5.0);
            let n = 100_000;
            let h = (b - a) / n as f64;
            let q: f64 = (0..n)
                .map(|i| {
                    let d = a + (i as f64 + 0.5) * h;
                    d.powi(k as i32) * (-slope * d).exp() * h
                })
                .sum();
            let exact = moment_integral(k, slope, a, b);
            assert!(
                (q - exact).abs() < 1e-8 * exact.abs().max(1.0),
                "k {k}: {q} vs {exact}"
            );
        }
    }

    #[test]
    fn visibility_in_rain_is_kilometres() {
        // Meteorological visibility 3.912/β (Koschmieder, 2 % contrast).
        // Measured visibilities in rain: about 10 km at 1 mm/h falling to
        // about 1–2 km at 25–50 mm/h (e.g. Atlas 1953, J. Meteor. 10; WMO
        // guide No. 8, 2018, §9). Marshall–Palmer drops of all sizes:
        let v1 = 3.912 / extinction_per_m(1.0, 0.0, 8.0);
        let v50 = 3.912 / extinction_per_m(50.0, 0.0, 8.0);
        assert!((4_000.0..20_000.0).contains(&v1), "{v1}");
        assert!((500.0..3_000.0).contains(&v50), "{v50}");
    }
}
