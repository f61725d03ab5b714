//! Tabulated phase functions and what the stratiform model derives from
//! them (Bouthors, Neyret & Lefebvre 2006, §4.1 and §4.4).
//!
//! A [`PhaseTable`] holds p(θ) in sr⁻¹ on an ascending grid of scattering
//! angles from 0° to 180°, normalised to ∫ p dΩ = 1 (nimbus's convention;
//! Bouthors 2006 normalises to 4π, so its P equals 4π times these values).
//! Between grid points p is taken linear in θ.
//!
//! - Forward peak weight P_f = ∫_{θ<θ_f} p dΩ (51 % for θ_f = 5° in the paper).
//! - Peak-removed phase function P_S = p / (1 − P_f) for θ ≥ θ_f, 0 below.
//!   The paper's text reads "if θ < θ_f" for P_S, which would keep the peak
//!   it means to remove; the definition and its use (the peak folded into the
//!   extinction σ_S = (1 − P_f) σ) require θ ≥ θ_f.
//! - Forward peak P_F = p / P_f for θ < θ_f, 0 above.
//! - Self-convolution P²(γ) = ∫_{S²} p(ω_in·ω) p(ω·ω_out) dω with ω_in·ω_out = cos γ:
//!   the phase function of two successive scatterings, computed as a true
//!   convolution on the sphere (double integral over θ and the azimuth φ),
//!   not a 1-D convolution in θ.
//! - Legendre moments χ_l = ∫ p P_l(cos θ) dΩ (χ₀ = 1, χ₁ = g).

/// A phase function tabulated on scattering angles.
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseTable {
    /// Ascending scattering angles, degrees, from 0 to 180.
    pub angles_deg: Vec<f64>,
    /// p(θ), sr⁻¹.
    pub values: Vec<f64>,
}

impl PhaseTable {
    /// A table from angles (ascending, 0 to 180) and values.
    pub fn new(angles_deg: Vec<f64>, values: Vec<f64>) -> Self {
        Self { angles_deg, values }
    }

    /// Tabulates a function of the scattering angle (degrees) on `count` uniform angles.
    pub fn from_fn(count: usize, p: impl Fn(f64) -> f64) -> Self {
        let angles: Vec<f64> = (0..count)
            .map(|i| 180.0 * i as f64 / (count - 1) as f64)
            .collect();
        let values = angles.iter().map(|a| p(*a)).collect();
        Self {
            angles_deg: angles,
            values,
        }
    }

    /// p at an angle in degrees, linear interpolation in θ.
    pub fn at(&self, angle_deg: f64) -> f64 {
        let a = &self.angles_deg;
        let x = angle_deg.clamp(a[0], a[a.len() - 1]);
        let i = a.partition_point(|v| *v <= x).clamp(1, a.len() - 1);
        let t = (x - a[i - 1]) / (a[i] - a[i - 1]);
        self.values[i - 1] + t * (self.values[i] - self.values[i - 1])
    }

    /// ∫ over the cone θ₀ ≤ θ < θ₁ of p dΩ, exact for p linear in θ on each interval.
    pub fn integral_between(&self, theta0_deg: f64, theta1_deg: f64) -> f64 {
        let mut total = 0.0;
        for i in 1..self.angles_deg.len() {
            let (a0, a1) = (self.angles_deg[i - 1], self.angles_deg[i]);
            let (a, b) = (a0.max(theta0_deg), a1.min(theta1_deg));
            if b <= a || a1 <= a0 {
                continue;
            }
            // Interpolate within this interval (the table may hold a jump as
            // two points at one angle, so `at` is not used here).
            let value = |x: f64| {
                self.values[i - 1] + (x - a0) / (a1 - a0) * (self.values[i] - self.values[i - 1])
            };
            total += linear_cone_integral(a.to_radians(), b.to_radians(), value(a), value(b));
        }
        total
    }

    /// ∫ p dΩ over the sphere.
    pub fn integral(&self) -> f64 {
        self.integral_between(0.0, 180.0)
    }

    /// The forward-peak weight P_f for a cone of half-angle θ_f (degrees).
    pub fn forward_fraction(&self, theta_f_deg: f64) -> f64 {
        self.integral_between(0.0, theta_f_deg) / self.integral()
    }

    /// P_S: the peak below θ_f removed and the rest renormalised (see the module notes).
    pub fn peak_removed(&self, theta_f_deg: f64) -> Self {
        // Renormalise by the table's own integrals, so that P_S integrates to 1 exactly.
        let keep = self.integral_between(theta_f_deg, 180.0);
        self.split_at(theta_f_deg, |inside, v| if inside { 0.0 } else { v / keep })
    }

    /// P_F: the peak below θ_f alone, renormalised.
    pub fn forward_peak(&self, theta_f_deg: f64) -> Self {
        let peak = self.integral_between(0.0, theta_f_deg);
        self.split_at(theta_f_deg, |inside, v| if inside { v / peak } else { 0.0 })
    }

    /// A copy with a grid point at exactly θ_f (so the cut is sharp) and the
    /// values mapped by `f(θ < θ_f, value)`; at θ_f itself the outer side is kept.
    fn split_at(&self, theta_f_deg: f64, f: impl Fn(bool, f64) -> f64) -> Self {
        let mut angles = Vec::with_capacity(self.angles_deg.len() + 2);
        let mut values = Vec::with_capacity(self.angles_deg.len() + 2);
        for (i, (&a, &v)) in self.angles_deg.iter().zip(&self.values).enumerate() {
            let next_crosses = i + 1 < self.angles_deg.len()
                && a < theta_f_deg
                && self.angles_deg[i + 1] > theta_f_deg;
            if a == theta_f_deg && i > 0 {
                // A grid point on the cut: the limit from inside, then from outside.
                angles.push(a);
                values.push(f(true, v));
            }
            angles.push(a);
            values.push(f(a < theta_f_deg, v));
            if next_crosses {
                let at_cut = self.at(theta_f_deg);
                // Two points at θ_f: the limit from inside, then from outside.
                angles.push(theta_f_deg);
                values.push(f(true, at_cut));
                angles.push(theta_f_deg);
                values.push(f(false, at_cut));
            }
        }
        Self {
            angles_deg: angles,
            values,
        }
    }

    /// Legendre moments χ_0 … χ_{count−1}, χ_l = ∫ p P_l(cos θ) dΩ.
    pub fn legendre_moments(&self, count: usize) -> Vec<f64> {
        // Fine midpoint rule in θ on each table interval (8 sub-points).
        let mut moments = vec![0.0; count];
        let mut p_l = vec![0.0; count];
        for i in 1..self.angles_deg.len() {
            let (a, b) = (
                self.angles_deg[i - 1].to_radians(),
                self.angles_deg[i].to_radians(),
            );
            if b <= a {
                continue;
            }
            let steps = 8;
            let h = (b - a) / steps as f64;
            for s in 0..steps {
                let theta = a + (s as f64 + 0.5) * h;
                let weight =
                    2.0 * std::f64::consts::PI * theta.sin() * h * self.at(theta.to_degrees());
                legendre_values(theta.cos(), &mut p_l);
                for (m, p) in moments.iter_mut().zip(&p_l) {
                    *m += weight * p;
                }
            }
        }
        moments
    }

    /// The self-convolution P² on the sphere, tabulated at `output_count`
    /// uniform angles, integrating θ on the table's own grid (refined ×4) and
    /// the azimuth with `azimuth_steps` midpoint steps over [0, π] (the
    /// integrand is symmetric in φ).
    pub fn self_convolution(&self, output_count: usize, azimuth_steps: usize) -> Self {
        use rayon::prelude::*;
        // Integration nodes in θ' (midpoints of a refined table grid) with their solid-angle weights.
        let mut nodes = Vec::new();
        for i in 1..self.angles_deg.len() {
            let (a, b) = (
                self.angles_deg[i - 1].to_radians(),
                self.angles_deg[i].to_radians(),
            );
            if b <= a {
                continue;
            }
            let h = (b - a) / 4.0;
            for s in 0..4 {
                let theta = a + (s as f64 + 0.5) * h;
                let value = self.at(theta.to_degrees());
                if value > 0.0 {
                    nodes.push((theta.cos(), theta.sin(), value * theta.sin() * h));
                }
            }
        }
        let d_phi = std::f64::consts::PI / azimuth_steps as f64;
        let cos_phi: Vec<f64> = (0..azimuth_steps)
            .map(|k| ((k as f64 + 0.5) * d_phi).cos())
            .collect();
        let angles: Vec<f64> = (0..output_count)
            .map(|i| 180.0 * i as f64 / (output_count - 1) as f64)
            .collect();
        let values = angles
            .par_iter()
            .map(|gamma_deg| {
                let (sin_g, cos_g) = gamma_deg.to_radians().sin_cos();
                let mut total = 0.0;
                for &(cos_t, sin_t, w) in &nodes {
                    let mut ring = 0.0;
                    for c in &cos_phi {
                        let cos_second = (cos_g * cos_t + sin_g * sin_t * c).clamp(-1.0, 1.0);
                        ring += self.at(cos_second.acos().to_degrees());
                    }
                    // Both halves of the azimuth: 2 × ∫₀^π.
                    total += w * ring * 2.0 * d_phi;
                }
                total
            })
            .collect();
        Self {
            angles_deg: angles,
            values,
        }
    }
}

/// ∫_a^b 2π sin θ (pa + (pb − pa)(θ − a)/(b − a)) dθ, exactly.
fn linear_cone_integral(a: f64, b: f64, pa: f64, pb: f64) -> f64 {
    let slope = (pb - pa) / (b - a);
    // ∫ sin θ dθ = cos a − cos b; ∫ (θ − a) sin θ dθ = [sin θ − (θ − a) cos θ]_a^b.
    let constant = a.cos() - b.cos();
    let linear = (b.sin() - (b - a) * b.cos()) - a.sin();
    2.0 * std::f64::consts::PI * (pa * constant + slope * linear)
}

/// P_0(x) … P_{n−1}(x) by the three-term recurrence.
pub(crate) fn legendre_values(x: f64, out: &mut [f64]) {
    if out.is_empty() {
        return;
    }
    out[0] = 1.0;
    if out.len() > 1 {
        out[1] = x;
    }
    for l in 2..out.len() {
        let lf = l as f64;
        out[l] = ((2.0 * lf - 1.0) * x * out[l - 1] - (lf - 1.0) * out[l - 2]) / lf;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Henyey–Greenstein, per sr: the analytic test case (its Legendre
    /// moments are gˡ, and its self-convolution is HG with g², the
    /// Funk–Hecke theorem).
    fn hg(g: f64) -> impl Fn(f64) -> f64 {
        move |deg: f64| {
            let c = deg.to_radians().cos();
            (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * c).powf(1.5))
        }
    }

    #[test]
    fn integrals_and_legendre_moments_of_henyey_greenstein() {
        let table = PhaseTable::from_fn(3601, hg(0.7));
        assert!(
            (table.integral() - 1.0).abs() < 1e-5,
            "{}",
            table.integral()
        );
        let moments = table.legendre_moments(6);
        for (l, m) in moments.iter().enumerate() {
            assert!((m - 0.7f64.powi(l as i32)).abs() < 1e-4, "χ_{l} = {m}");
        }
    }

    #[test]
    fn peak_split_conserves_energy_and_cuts_sharply() {
        let table = PhaseTable::from_fn(3601, hg(0.9));
        let pf = table.forward_fraction(5.0);
        // HG's cone fraction is analytic: ∫₀^θf = (1−g²)/(2g) [1/√(1+g²−2gμ) ]_{μf}^{1}.
        let (g, mu_f) = (0.9f64, 5f64.to_radians().cos());
        let exact = (1.0 - g * g) / (2.0 * g)
            * (1.0 / (1.0 + g * g - 2.0 * g).sqrt() - 1.0 / (1.0 + g * g - 2.0 * g * mu_f).sqrt());
        assert!((pf - exact).abs() < 1e-4, "{pf} vs {exact}");
        let ps = table.peak_removed(5.0);
        let pfn = table.forward_peak(5.0);
        assert!(
            (ps.integral() - 1.0).abs() < 1e-6 && (pfn.integral() - 1.0).abs() < 1e-6,
            "{} {}",
            ps.integral(),
            pfn.integral()
        );
        assert_eq!(ps.at(4.99), 0.0);
        assert_eq!(pfn.at(5.01), 0.0);
        assert!((ps.at(90.0) / (table.at(90.0) / (1.0 - pf)) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn self_convolution_of_henyey_greenstein_is_henyey_greenstein_with_g_squared() {
        let table = PhaseTable::from_fn(721, hg(0.5));
        let p2 = table.self_convolution(37, 180);
        let expected = hg(0.25);
        for (a, v) in p2.angles_deg.iter().zip(&p2.values) {
            assert!(
                (v / expected(*a) - 1.0).abs() < 2e-3,
                "{a}°: {v} vs {}",
                expected(*a)
            );
        }
        assert!((p2.integral() - 1.0).abs() < 2e-3);
    }
}
