//! Lorenz–Mie scattering by a homogeneous sphere.
//!
//! References: Bohren & Huffman, *Absorption and Scattering of Light by
//! Small Particles* (1983), §4.4 and appendix A (BHMIE): the coefficients
//! a_n, b_n from the logarithmic derivative D_n(mx) and the Riccati–Bessel
//! functions ψ_n, ξ_n (eqs. 4.88), efficiencies (eqs. 4.61, 4.62), asymmetry
//! parameter (eq. 4.79), amplitudes S1, S2 (eq. 4.74) with the angular
//! functions π_n, τ_n (eq. 4.47); Wiscombe, "Improved Mie scattering
//! algorithms", Applied Optics 19, 1980: the series length
//! N = x + 4.05 x^{1/3} + 2 and D_n by downward recurrence started well above
//! max(N, |mx|), stable for every size parameter and refractive index.
//!
//! Symbols: x = 2π r n_medium / λ the size parameter, m = n + ik the
//! refractive index relative to the medium (k ≥ 0 absorbs), θ the scattering
//! angle. Efficiencies are cross sections over πr²; the backscattering
//! efficiency is the radar one, Q_b = |Σ (2n+1)(−1)ⁿ (a_n − b_n)|² / x²
//! (Bohren & Huffman eq. 4.82), i.e. 4π dσ/dΩ(180°) / πr².

use num_complex::Complex64;

/// Largest size parameter accepted (the series then has about 20 000 terms).
pub const MAX_SIZE_PARAMETER: f64 = 100_000.0;

/// The Mie coefficients of one sphere and the efficiencies they give.
#[derive(Clone, Debug)]
pub struct MieCoefficients {
    /// Size parameter x.
    pub size_parameter: f64,
    /// Relative refractive index m.
    pub refractive_index: Complex64,
    /// a_n for n = 1..=N.
    pub a: Vec<Complex64>,
    /// b_n for n = 1..=N.
    pub b: Vec<Complex64>,
}

/// Efficiencies and asymmetry parameter of a sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MieEfficiencies {
    /// Extinction efficiency.
    pub q_ext: f64,
    /// Scattering efficiency.
    pub q_sca: f64,
    /// Absorption efficiency, Q_ext − Q_sca.
    pub q_abs: f64,
    /// Radar backscattering efficiency.
    pub q_back: f64,
    /// Asymmetry parameter g = ⟨cos θ⟩.
    pub g: f64,
}

/// Number of terms of the series for size parameter x (Wiscombe 1980, eq. 30).
pub fn series_length(x: f64) -> usize {
    (x + 4.05 * x.cbrt() + 2.0).ceil() as usize
}

impl MieCoefficients {
    /// Computes a_n, b_n for size parameter `x` > 0 and refractive index `m`.
    #[allow(clippy::needless_range_loop)] // n is the order in every formula.
    pub fn new(x: f64, m: Complex64) -> Self {
        let n_max = series_length(x);
        let mx = m * x;
        // Downward recurrence of D_n(mx) = ψ'_n(mx)/ψ_n(mx) (BH eq. 4.89),
        // started at zero well above the series length (Wiscombe 1980).
        // The start must lie past the transition region around n ≈ |mx|, whose
        // width grows as |mx|^{1/3} (as the series length's margin does), for
        // the start error to be damped: a fixed +15 (BHMIE) leaves 3e-4 errors
        // in Q_ext at x = 1000, m = 1.5.
        let n_start =
            n_max.max(mx.norm().ceil() as usize) + 16 + (8.0 * mx.norm().cbrt()).ceil() as usize;
        let mut d = vec![Complex64::new(0.0, 0.0); n_start + 1];
        for n in (1..=n_start).rev() {
            let n_over_mx = n as f64 / mx;
            d[n - 1] = n_over_mx - 1.0 / (d[n] + n_over_mx);
        }
        // Upward recurrence of ψ_n(x) and χ_n(x) (BH eq. 4.89); ξ_n = ψ_n − iχ_n.
        // It is accurate up to the series length (Wiscombe 1980, §III).
        let (mut psi_prev2, mut psi_prev) = (x.cos(), x.sin());
        let (mut chi_prev2, mut chi_prev) = (-x.sin(), x.cos());
        let mut xi_prev = Complex64::new(psi_prev, -chi_prev);
        let mut a = Vec::with_capacity(n_max);
        let mut b = Vec::with_capacity(n_max);
        for n in 1..=n_max {
            let nf = n as f64;
            let psi = (2.0 * nf - 1.0) / x * psi_prev - psi_prev2;
            let chi = (2.0 * nf - 1.0) / x * chi_prev - chi_prev2;
            let xi = Complex64::new(psi, -chi);
            let da = d[n] / m + nf / x;
            let db = d[n] * m + nf / x;
            a.push((da * psi - psi_prev) / (da * xi - xi_prev));
            b.push((db * psi - psi_prev) / (db * xi - xi_prev));
            (psi_prev2, psi_prev) = (psi_prev, psi);
            (chi_prev2, chi_prev) = (chi_prev, chi);
            xi_prev = xi;
        }
        Self {
            size_parameter: x,
            refractive_index: m,
            a,
            b,
        }
    }

    /// Efficiencies and asymmetry parameter (BH eqs. 4.61, 4.62, 4.79, 4.82).
    pub fn efficiencies(&self) -> MieEfficiencies {
        let x2 = self.size_parameter * self.size_parameter;
        let (mut ext, mut sca, mut g_sum) = (0.0, 0.0, 0.0);
        let mut back = Complex64::new(0.0, 0.0);
        let n_max = self.a.len();
        for i in 0..n_max {
            let n = (i + 1) as f64;
            let (a, b) = (self.a[i], self.b[i]);
            ext += (2.0 * n + 1.0) * (a + b).re;
            sca += (2.0 * n + 1.0) * (a.norm_sqr() + b.norm_sqr());
            let sign = if (i + 1) % 2 == 0 { 1.0 } else { -1.0 };
            back += (2.0 * n + 1.0) * sign * (a - b);
            g_sum += (2.0 * n + 1.0) / (n * (n + 1.0)) * (a * b.conj()).re;
            if i + 1 < n_max {
                let (a1, b1) = (self.a[i + 1], self.b[i + 1]);
                g_sum += n * (n + 2.0) / (n + 1.0) * (a * a1.conj() + b * b1.conj()).re;
            }
        }
        let q_ext = 2.0 / x2 * ext;
        let q_sca = 2.0 / x2 * sca;
        MieEfficiencies {
            q_ext,
            q_sca,
            q_abs: q_ext - q_sca,
            q_back: back.norm_sqr() / x2,
            g: if sca > 0.0 { 2.0 * g_sum / sca } else { 0.0 },
        }
    }

    /// Amplitudes S1(θ), S2(θ) at the cosines `mu` of the scattering angles
    /// (BH eq. 4.74).
    pub fn amplitudes(&self, mu: &[f64]) -> Vec<(Complex64, Complex64)> {
        mu.iter()
            .map(|&cos_theta| amplitudes_at(&self.a, &self.b, cos_theta))
            .collect()
    }

    /// Phase function p(θ) = (|S1|² + |S2|²) / (2π x² Q_sca) in sr⁻¹ at the
    /// cosines `mu`, normalised to 1 over the sphere.
    pub fn phase_function(&self, mu: &[f64]) -> Vec<f64> {
        let q_sca = self.efficiencies().q_sca;
        let norm = 2.0 * std::f64::consts::PI * self.size_parameter * self.size_parameter * q_sca;
        self.amplitudes(mu)
            .iter()
            .map(|(s1, s2)| (s1.norm_sqr() + s2.norm_sqr()) / norm)
            .collect()
    }
}

/// S1, S2 at one angle by upward recurrence of π_n, τ_n (BH eq. 4.47).
fn amplitudes_at(a: &[Complex64], b: &[Complex64], mu: f64) -> (Complex64, Complex64) {
    let (mut pi_prev, mut pi) = (0.0, 1.0);
    let mut s1 = Complex64::new(0.0, 0.0);
    let mut s2 = Complex64::new(0.0, 0.0);
    for i in 0..a.len() {
        let n = (i + 1) as f64;
        let tau = n * mu * pi - (n + 1.0) * pi_prev;
        let factor = (2.0 * n + 1.0) / (n * (n + 1.0));
        s1 += factor * (a[i] * pi + b[i] * tau);
        s2 += factor * (a[i] * tau + b[i] * pi);
        let pi_next = ((2.0 * n + 1.0) * mu * pi - (n + 1.0) * pi_prev) / n;
        (pi_prev, pi) = (pi, pi_next);
    }
    (s1, s2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg_mu(step_deg: f64, count: usize) -> Vec<f64> {
        (0..count)
            .map(|k| (k as f64 * step_deg).to_radians().cos())
            .collect()
    }

    /// S11 = (|S1|² + |S2|²) / 2, Wiscombe's tabulated quantity.
    fn s11(c: &MieCoefficients, mu: &[f64]) -> Vec<f64> {
        c.amplitudes(mu)
            .iter()
            .map(|(s1, s2)| 0.5 * (s1.norm_sqr() + s2.norm_sqr()))
            .collect()
    }

    #[test]
    #[allow(clippy::approx_constant)] // 0.785390 is a tabulated value, not π/4.
    fn bohren_huffman_appendix_a_water_droplet_case() {
        // BH appendix A: radius 0.525 µm, λ = 0.6328 µm, m = 1.55: Q_ext =
        // Q_sca = 3.10543, Q_back = 2.92534, g = 0.63314, and S11 normalised
        // to its forward value at 0°, 9°, 18°, … (first values of the table).
        let x = 2.0 * std::f64::consts::PI * 0.525 / 0.6328;
        let c = MieCoefficients::new(x, Complex64::new(1.55, 0.0));
        let e = c.efficiencies();
        assert!((e.q_ext - 3.10543).abs() < 1e-5, "{e:?}");
        assert!((e.q_sca - 3.10543).abs() < 1e-5, "{e:?}");
        let mu = deg_mu(9.0, 21);
        let s = s11(&c, &mu);
        let table = [
            1.0, 0.785390, 0.356897, 0.0766119, 0.0355355, 0.0701845, 0.0574313, 0.0219660,
            0.0125959,
        ];
        for (k, expected) in table.iter().enumerate() {
            assert!(
                (s[k] / s[0] - expected).abs() < 2e-6,
                "angle {}°: {} vs {expected}",
                9 * k,
                s[k] / s[0]
            );
        }
        assert!((e.q_back - 2.92534).abs() < 1e-5, "{e:?}");
        assert!((e.g - 0.63314).abs() < 1e-5, "{e:?}");
    }

    #[test]
    fn wiscombe_1979_test_cases() {
        // Wiscombe, NCAR/TN-140+STR (1979), appendix: Q_ext, Q_sca, g and
        // S11 at 0° and 180° for m = 1.5 and 1.5 + 0.1i.
        let cases = [
            (
                10.0, 0.0, 2.881999, 2.881999, 0.742913, 0.520856e4, 0.423766e2,
            ),
            (
                100.0, 0.0, 2.094388, 2.094388, 0.818246, 0.275508e8, 0.434048e4,
            ),
            (
                1000.0,
                0.0,
                2.013945,
                2.013945,
                0.827882,
                0.253568e12,
                0.257577e7,
            ),
            (
                5000.0,
                0.0,
                2.008650,
                2.008650,
                0.829592,
                0.157609e15,
                0.237786e9,
            ),
            (
                10.0, 0.1, 2.459791, 1.235144, 0.922350, 0.379171e4, 0.231818e1,
            ),
            (
                100.0, 0.1, 2.089822, 1.132134, 0.950392, 0.273645e8, 0.103837e3,
            ),
            (
                1000.0,
                0.1,
                2.019703,
                1.106932,
                0.950880,
                0.255002e12,
                0.103834e5,
            ),
            (
                5000.0,
                0.1,
                2.006775,
                1.099193,
                0.950650,
                0.157315e15,
                0.259585e6,
            ),
        ];
        for (x, k, q_ext, q_sca, g, s11_0, s11_180) in cases {
            let c = MieCoefficients::new(x, Complex64::new(1.5, k));
            let e = c.efficiencies();
            assert!(
                (e.q_ext - q_ext).abs() < 1e-6,
                "x {x} k {k}: Q_ext {}",
                e.q_ext
            );
            assert!(
                (e.q_sca - q_sca).abs() < 1e-6,
                "x {x} k {k}: Q_sca {}",
                e.q_sca
            );
            assert!((e.g - g).abs() < 1e-6, "x {x} k {k}: g {}", e.g);
            let s = s11(&c, &[1.0, -1.0]);
            assert!(
                (s[0] / s11_0 - 1.0).abs() < 1e-5,
                "x {x} k {k}: S11(0) {}",
                s[0]
            );
            assert!(
                (s[1] / s11_180 - 1.0).abs() < 1e-5,
                "x {x} k {k}: S11(180) {}",
                s[1]
            );
        }
    }

    #[test]
    fn wiscombe_1979_full_angular_tables() {
        // S11 every 5° from 0° to 180° (Wiscombe 1979, appendix), to 1e-5.
        let tables: [(f64, f64, [f64; 37]); 2] = [
            (
                10.0,
                0.0,
                [
                    0.520856e4, 0.428132e4, 0.234775e4, 0.818121e3, 0.149547e3, 0.139195e2,
                    0.768071e2, 0.128393e3, 0.789487e2, 0.293697e2, 0.518546e2, 0.631908e2,
                    0.341567e2, 0.256714e2, 0.320167e2, 0.235919e2, 0.194168e2, 0.184988e2,
                    0.917521e1, 0.963035e1, 0.136986e2, 0.485859e1, 0.280440e1, 0.853248e1,
                    0.439826e1, 0.570995e1, 0.113872e2, 0.304142e1, 0.675713e1, 0.242055e2,
                    0.159589e2, 0.161562e2, 0.582167e2, 0.679231e2, 0.286866e2, 0.249122e2,
                    0.423766e2,
                ],
            ),
            (
                100.0,
                0.1,
                [
                    0.273645e8, 0.911574e5, 0.130172e5, 0.314304e4, 0.121824e4, 0.911319e3,
                    0.801673e3, 0.629347e3, 0.465786e3, 0.370932e3, 0.317391e3, 0.269848e3,
                    0.230451e3, 0.202758e3, 0.180401e3, 0.162813e3, 0.149203e3, 0.138475e3,
                    0.130113e3, 0.123599e3, 0.118559e3, 0.114659e3, 0.111687e3, 0.109437e3,
                    0.107749e3, 0.106503e3, 0.105600e3, 0.104961e3, 0.104521e3, 0.104229e3,
                    0.104044e3, 0.103935e3, 0.103877e3, 0.103850e3, 0.103840e3, 0.103837e3,
                    0.103837e3,
                ],
            ),
        ];
        for (x, k, table) in tables {
            let c = MieCoefficients::new(x, Complex64::new(1.5, k));
            let s = s11(&c, &deg_mu(5.0, 37));
            for (i, expected) in table.iter().enumerate() {
                assert!(
                    (s[i] / expected - 1.0).abs() < 1e-5,
                    "x {x} k {k} at {}°: {} vs {expected}",
                    5 * i,
                    s[i]
                );
            }
        }
    }

    #[test]
    fn wiscombe_miev0_test_cases_with_m_below_one() {
        // MIEV0 test cases 5–8 (Wiscombe, NCAR/TN-140 revised 1996): m = 0.75,
        // Q_sca, g and |S1(180°)|.
        let cases = [
            (0.099, 0.000007, 0.001448, (1.81756e-8f64).hypot(1.64810e-4)),
            (0.101, 0.000008, 0.001507, (2.04875e-8f64).hypot(1.74965e-4)),
            (10.0, 2.232265, 0.896473, (1.07857f64).hypot(3.60881e-2)),
            (1000.0, 1.997908, 0.844944, (1.70578e1f64).hypot(4.84251e2)),
        ];
        for (x, q_sca, g, s1_back) in cases {
            let c = MieCoefficients::new(x, Complex64::new(0.75, 0.0));
            let e = c.efficiencies();
            assert!((e.q_sca - q_sca).abs() < 1e-6, "x {x}: Q_sca {}", e.q_sca);
            assert!((e.g - g).abs() < 1e-6, "x {x}: g {}", e.g);
            let s1 = c.amplitudes(&[-1.0])[0].0.norm();
            assert!(
                (s1 / s1_back - 1.0).abs() < 1e-5,
                "x {x}: |S1(180°)| {s1} vs {s1_back}"
            );
        }
    }

    #[test]
    fn rayleigh_limit_for_small_spheres() {
        // x ≪ 1: Q_sca = (8/3) x⁴ |(m²−1)/(m²+2)|² (BH eq. 5.8), g → 0,
        // phase function → 3(1 + cos²θ)/(16π).
        let m = Complex64::new(1.33, 0.0);
        let x = 0.01;
        let e = MieCoefficients::new(x, m).efficiencies();
        let lorentz = ((m * m - 1.0) / (m * m + 2.0)).norm_sqr();
        let rayleigh = 8.0 / 3.0 * x.powi(4) * lorentz;
        assert!(
            (e.q_sca / rayleigh - 1.0).abs() < 1e-3,
            "{} vs {rayleigh}",
            e.q_sca
        );
        assert!(e.g.abs() < 1e-3);
        let c = MieCoefficients::new(x, m);
        for mu in [1.0, 0.5, 0.0, -0.7] {
            let p = c.phase_function(&[mu])[0];
            let expected = 3.0 * (1.0 + mu * mu) / (16.0 * std::f64::consts::PI);
            assert!(
                (p / expected - 1.0).abs() < 1e-3,
                "μ {mu}: {p} vs {expected}"
            );
        }
    }

    #[test]
    fn extinction_tends_to_two_for_large_spheres() {
        // The extinction paradox: Q_ext → 2 as x → ∞ (BH §4.4.1).
        let e = MieCoefficients::new(20_000.0, Complex64::new(1.33, 1e-8)).efficiencies();
        assert!((e.q_ext - 2.0).abs() < 0.01, "{}", e.q_ext);
    }

    #[test]
    fn phase_function_is_normalised_and_g_matches_its_first_moment() {
        // ∫ p dΩ = 1 and ∫ p cos θ dΩ = g, by Gauss–Legendre quadrature on μ.
        for (x, k) in [(0.5, 0.0), (5.0, 0.0), (30.0, 0.01), (120.0, 0.0)] {
            let c = MieCoefficients::new(x, Complex64::new(1.33, k));
            let (nodes, weights) = crate::optics::quadrature::gauss_legendre(2000);
            let p = c.phase_function(&nodes);
            let total: f64 = p.iter().zip(&weights).map(|(p, w)| p * w).sum::<f64>()
                * 2.0
                * std::f64::consts::PI;
            let first: f64 = p
                .iter()
                .zip(&weights)
                .zip(&nodes)
                .map(|((p, w), mu)| p * w * mu)
                .sum::<f64>()
                * 2.0
                * std::f64::consts::PI;
            assert!((total - 1.0).abs() < 1e-5, "x {x}: ∫p dΩ = {total}");
            assert!(
                (first - c.efficiencies().g).abs() < 1e-5,
                "x {x}: {first} vs g {}",
                c.efficiencies().g
            );
        }
    }
}
