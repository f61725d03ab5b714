//! The light a cumulus rim lets through around the sun: multiple scattering
//! within the droplets' diffraction peak, in the small-angle approximation
//! (Wells 1973; Zege, Ivanov & Katsev 1991, *Image Transfer Through a
//! Scattering Medium*, ch. 2; the same Gaussian-broadening picture that
//! Neyret 2000, §4.2, uses for the corona's forward lobe).
//!
//! Sunlight crossing a thin part of a cloud (a rim of optical depth τ seen
//! a few degrees from the sun) is scattered several times within the forward
//! peak (half the droplets' scattering lies within ~5°, diffraction), each
//! time by a small angle, and reaches the eye at the sum of those angles;
//! scattering outside the peak takes it away. With P_f the fraction of the
//! phase function within the peak's cone θ_f and p the peak normalised over
//! the plane of small angles (2π ∫ p θ dθ = 1), the radiance that left the
//! sun's direction and arrives at angle θ, per unit of the sun's irradiance,
//! is (sr⁻¹)
//!
//! F(θ, τ) = e^{−τ} (1/2π) ∫₀^∞ [e^{τ P_f p̂(k)} − 1] J₀(kθ) k dk,
//! p̂(k) = 2π ∫₀^{θ_f} p(θ) J₀(kθ) θ dθ,
//!
//! the Poisson sum Σ_{n≥1} e^{−τ} (τ P_f)ⁿ/n! p^{*n}(θ) over n scatterings
//! in the peak (p^{*n} the n-fold convolution, a product under the Hankel
//! transform). Its integral over directions is e^{−τ(1 − P_f)} − e^{−τ}: the
//! light scattered at least once, only in the peak. The single-scattering
//! term e^{−τ} τ P_f p(θ) is taken in θ directly so that the numerical
//! transform only carries the smooth remainder.
//!
//! The table holds F over θ ∈ [0, θ_max] on a quadratic grid (θ_i = θ_max
//! (i/(n−1))², fine near the sun) and τ ∈ [0, τ_max] uniformly, per RGB
//! channel (the peak's width scales with the wavelength: the corona's
//! colours). [`ForwardPeakTable::at`] is the CPU twin of the cumulus
//! shader's `cumulus_forward_peak` (bilinear in √θ and τ).
//!
//! Beside F the table holds its source by the last scattering,
//!
//! H(θ, τ) = P_f (p ∗ B_τ)(θ) = P_f e^{−τ} [p(θ) + (1/2π) ∫₀^∞ p̂(k) (e^{τ P_f p̂(k)} − 1) J₀(kθ) k dk],
//!
//! B_τ = e^{−τ} δ + F(·, τ) the sun's beam (unscattered and peak-scattered)
//! after an optical depth τ: the light a unit optical depth of cloud sends
//! towards θ from a beam that has crossed τ of it, per unit irradiance
//! (sr⁻¹). F(θ, τ) = ∫₀^τ e^{−(τ − τ′)} H(θ, τ′) dτ′ along a straight chord
//! (∂F/∂τ = H − F). A march along a view ray takes H at each point with the
//! optical depth the sun's own path has crossed to it, so that a rim whose
//! beam comes through the cloud's body behind it, not along the view's
//! chord, is lit as such ([`peak_along_ray`], twin of the volume march's
//! peak term).

use crate::optics::tables::CloudOpticsTables;

/// Largest angle from the sun the table covers, rad (16°): beyond it the
/// broadened peak carries less than 10⁻³ of its light for τ ≤ τ_max.
pub const ANGLE_MAX_RAD: f64 = 16.0 * std::f64::consts::PI / 180.0;
/// Largest optical depth the table covers: beyond it e^{−τ(1 − P_f)} < 10⁻⁵.
pub const DEPTH_MAX: f64 = 24.0;
/// Angles of the table (quadratic grid).
pub const ANGLES: usize = 64;
/// Optical depths of the table (uniform grid).
pub const DEPTHS: usize = 49;

/// F(θ, τ) per RGB channel, sr⁻¹ (see the module's documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct ForwardPeakTable {
    /// F, interleaved RGB, row-major: `values[3 (j ANGLES + i) + c]` at
    /// θ_i = θ_max (i/(ANGLES − 1))², τ_j = τ_max j/(DEPTHS − 1).
    pub values: Vec<f32>,
    /// H(θ, τ) on the same grid and layout (see the module's documentation).
    pub last_scattering: Vec<f32>,
    /// The forward fraction P_f per channel.
    pub forward_fraction: [f64; 3],
}

/// J₀ by libm (Sun's fdlibm algorithm).
fn bessel_j0(x: f64) -> f64 {
    libm::j0(x)
}

/// One channel's peak: p(θ) normalised over the plane (sr⁻¹) on a uniform
/// grid of `peak.len()` angles over [0, θ_f].
struct Peak {
    step_rad: f64,
    values: Vec<f64>,
}

impl Peak {
    fn new(values: impl Iterator<Item = f64>, cone_rad: f64) -> Self {
        let values: Vec<f64> = values.map(|v| v.max(0.0)).collect();
        let step_rad = cone_rad / (values.len() - 1) as f64;
        let mut peak = Self { step_rad, values };
        // Renormalise in the small-angle measure 2π θ dθ (the tables are
        // normalised with sin θ; they differ by < 0.2 % within 5°).
        let total = peak.plane_integral(|_| 1.0);
        for v in &mut peak.values {
            *v /= total;
        }
        peak
    }

    /// 2π ∫ p(θ) w(θ) θ dθ by the trapezoid rule.
    fn plane_integral(&self, w: impl Fn(f64) -> f64) -> f64 {
        let last = self.values.len() - 1;
        let sum: f64 = self
            .values
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let theta = i as f64 * self.step_rad;
                let end = if i == 0 || i == last { 0.5 } else { 1.0 };
                end * v * w(theta) * theta
            })
            .sum();
        2.0 * std::f64::consts::PI * sum * self.step_rad
    }

    fn at(&self, theta_rad: f64) -> f64 {
        let x = theta_rad / self.step_rad;
        let last = self.values.len() - 1;
        if x >= last as f64 {
            return 0.0;
        }
        let i = x.floor() as usize;
        let t = x - i as f64;
        self.values[i] * (1.0 - t) + self.values[i + 1] * t
    }
}

/// θ of the table's angle index `i`.
pub fn table_angle_rad(i: usize) -> f64 {
    let s = i as f64 / (ANGLES - 1) as f64;
    ANGLE_MAX_RAD * s * s
}

/// τ of the table's depth index `j`.
pub fn table_depth(j: usize) -> f64 {
    DEPTH_MAX * j as f64 / (DEPTHS - 1) as f64
}

impl ForwardPeakTable {
    /// The table of a cloud's optical tables (their forward peak P_F over
    /// 0–θ_f and the fraction P_f, per channel).
    pub fn from_optics(optics: &CloudOpticsTables) -> Self {
        let cone_rad = optics.params.forward_peak_deg.to_radians();
        let texels = optics.forward_peak.len() / 3;
        let peaks: [Peak; 3] = std::array::from_fn(|c| {
            Peak::new(
                (0..texels).map(|i| f64::from(optics.forward_peak[3 * i + c])),
                cone_rad,
            )
        });
        let fraction = optics.forward_fraction.map(f64::from);
        Self::compute(&peaks, fraction)
    }

    /// The table of a Gaussian peak of angular standard deviation
    /// `sigma_rad` per axis (per channel) holding the fraction `fraction` of
    /// the scattering, sampled like the optical tables' peak (256 angles over
    /// 0–5°). Its n-fold convolution is the Gaussian of variance n σ²: the
    /// analytic case the transforms are tested against.
    pub fn gaussian(sigma_rad: [f64; 3], fraction: [f64; 3]) -> Self {
        let cone_rad = 5f64.to_radians();
        let peaks = sigma_rad.map(|sigma| {
            Peak::new(
                (0..256).map(|i| {
                    let t = f64::from(i) * cone_rad / 255.0;
                    (-t * t / (2.0 * sigma * sigma)).exp()
                }),
                cone_rad,
            )
        });
        Self::compute(&peaks, fraction)
    }

    /// The values as RGBA texels (alpha 0), rows of [`ANGLES`] texels, one
    /// row per depth, F's [`DEPTHS`] rows then H's: what the cumulus
    /// shader's table holds ([`TABLE_ROWS`] rows).
    pub fn rgba_texels(&self) -> Vec<f32> {
        self.values
            .chunks_exact(3)
            .chain(self.last_scattering.chunks_exact(3))
            .flat_map(|rgb| [rgb[0], rgb[1], rgb[2], 0.0])
            .collect()
    }

    fn compute(peaks: &[Peak; 3], fraction: [f64; 3]) -> Self {
        // Hankel transforms on a uniform k grid; the peak's narrowest
        // feature (~0.5°) fades by k ≈ 10³ rad⁻¹, and the
        // multiple-scattering part goes as p̂², faster still.
        const K_MAX: f64 = 1500.0;
        const K_STEPS: usize = 1000;
        let dk = K_MAX / K_STEPS as f64;
        let ks: Vec<f64> = (0..=K_STEPS).map(|i| i as f64 * dk).collect();
        let mut values = vec![0.0f32; 3 * ANGLES * DEPTHS];
        let mut last_scattering = vec![0.0f32; 3 * ANGLES * DEPTHS];
        for (c, peak) in peaks.iter().enumerate() {
            // p̂(k), exact for the peak linear between its samples up to the
            // trapezoid rule's error (the samples are 0.02° apart).
            let transform: Vec<f64> = ks
                .iter()
                .map(|&k| peak.plane_integral(|theta| bessel_j0(k * theta)))
                .collect();
            for i in 0..ANGLES {
                let theta = table_angle_rad(i);
                let kernel: Vec<f64> = ks
                    .iter()
                    .enumerate()
                    .map(|(n, &k)| {
                        let end = if n == 0 || n == K_STEPS { 0.5 } else { 1.0 };
                        end * bessel_j0(k * theta) * k * dk / (2.0 * std::f64::consts::PI)
                    })
                    .collect();
                for j in 0..DEPTHS {
                    let tau = table_depth(j);
                    let a = tau * fraction[c];
                    // One pass over k for both tables, e^{a p̂} − 1 taken once:
                    // F's e^{a p̂} − 1 − a p̂ (two or more scatterings; the
                    // single one, a p(θ), taken directly) and H's
                    // p̂ (e^{a p̂} − 1) (one or more scatterings before the
                    // last; the last alone, p(θ), taken directly).
                    let (multiple, before) = transform.iter().zip(&kernel).fold(
                        (0.0f64, 0.0f64),
                        |(multiple, before), (&p, &w)| {
                            let x = a * p;
                            let grown = x.exp_m1();
                            (multiple + (grown - x) * w, before + p * grown * w)
                        },
                    );
                    let single = a * peak.at(theta);
                    let f = (-tau).exp() * (single + multiple);
                    values[3 * (j * ANGLES + i) + c] = f.max(0.0) as f32;
                    let h = fraction[c] * (-tau).exp() * (peak.at(theta) + before);
                    last_scattering[3 * (j * ANGLES + i) + c] = h.max(0.0) as f32;
                }
            }
        }
        Self {
            values,
            last_scattering,
            forward_fraction: fraction,
        }
    }

    /// F(θ, τ) per channel, sr⁻¹: bilinear in √θ (the grid's index) and τ;
    /// 0 beyond θ_max or τ_max. CPU twin of `cumulus_forward_peak`.
    pub fn at(&self, angle_rad: f64, depth: f64) -> [f64; 3] {
        Self::lookup(&self.values, angle_rad, depth)
    }

    /// H(θ, τ) per channel, sr⁻¹ per unit optical depth: as [`Self::at`].
    /// CPU twin of `cumulus_forward_peak_source`.
    pub fn last_scattering_at(&self, angle_rad: f64, depth: f64) -> [f64; 3] {
        Self::lookup(&self.last_scattering, angle_rad, depth)
    }

    fn lookup(values: &[f32], angle_rad: f64, depth: f64) -> [f64; 3] {
        if !(angle_rad < ANGLE_MAX_RAD && depth < DEPTH_MAX) || depth < 0.0 {
            return [0.0; 3];
        }
        let x = (angle_rad.max(0.0) / ANGLE_MAX_RAD).sqrt() * (ANGLES - 1) as f64;
        let y = depth / DEPTH_MAX * (DEPTHS - 1) as f64;
        let (i, j) = (
            (x.floor() as usize).min(ANGLES - 2),
            (y.floor() as usize).min(DEPTHS - 2),
        );
        let (tx, ty) = (x - i as f64, y - j as f64);
        std::array::from_fn(|c| {
            let v = |i: usize, j: usize| f64::from(values[3 * (j * ANGLES + i) + c]);
            let low = v(i, j) * (1.0 - tx) + v(i + 1, j) * tx;
            let high = v(i, j + 1) * (1.0 - tx) + v(i + 1, j + 1) * tx;
            low * (1.0 - ty) + high * ty
        })
    }
}

/// Rows of the shader's table: F's [`DEPTHS`], then H's.
pub const TABLE_ROWS: usize = 2 * DEPTHS;

/// One step of a view ray through a cloud, for [`peak_along_ray`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeakStep {
    /// The step's optical depth along the view, σ Δs (no δ-M).
    pub optical_depth: f64,
    /// The optical depth the sun's own path crosses to the step (no δ-M).
    pub sun_depth: f64,
}

/// The light the droplets' forward peak sends to the eye along a view ray,
/// per unit irradiance of the sun, per channel (sr⁻¹): Σ_i H(θ, τ_sun,i)
/// e^{−τ_i} Δτ_i, τ_i the view's optical depth from the eye to the step's
/// middle. Steps from the eye outwards. CPU twin of the volume march's
/// peak term (WGSL `in_cloud_march`).
pub fn peak_along_ray(table: &ForwardPeakTable, angle_rad: f64, steps: &[PeakStep]) -> [f64; 3] {
    let mut out = [0.0; 3];
    let mut depth = 0.0;
    for step in steps {
        let seen = (-(depth + 0.5 * step.optical_depth)).exp() * step.optical_depth;
        let h = table.last_scattering_at(angle_rad, step.sun_depth);
        for c in 0..3 {
            out[c] += seen * h[c];
        }
        depth += step.optical_depth;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gaussian_series(theta: f64, tau: f64, fraction: f64, sigma: f64) -> f64 {
        let a = tau * fraction;
        let mut term = 1.0;
        let mut sum = 0.0;
        for n in 1..80 {
            term *= a / n as f64;
            let var = n as f64 * sigma * sigma;
            sum += term * (-theta * theta / (2.0 * var)).exp() / (2.0 * std::f64::consts::PI * var);
        }
        (-tau).exp() * sum
    }

    #[test]
    fn a_gaussian_peak_broadens_as_the_poisson_sum_of_its_convolutions() {
        // Analytic limit: for a Gaussian peak p^{*n} is the Gaussian of
        // variance n σ², so F is a Poisson-weighted sum of Gaussians.
        let sigma = 0.8f64.to_radians();
        let table = ForwardPeakTable::gaussian([sigma; 3], [0.5; 3]);
        for &(theta_deg, tau) in &[(0.0, 1.0), (1.0, 2.0), (2.5, 6.0), (4.0, 10.0), (0.5, 0.5)] {
            let theta = f64::to_radians(theta_deg);
            let exact = gaussian_series(theta, tau, 0.5, sigma);
            let j = (tau / DEPTH_MAX * (DEPTHS - 1) as f64).round() as usize;
            let i = ((theta / ANGLE_MAX_RAD).sqrt() * (ANGLES - 1) as f64).round() as usize;
            let (theta_grid, tau_grid) = (table_angle_rad(i), table_depth(j));
            let exact_grid = gaussian_series(theta_grid, tau_grid, 0.5, sigma);
            let got = table.at(theta_grid, tau_grid)[1];
            assert!(
                (got - exact_grid).abs() <= 0.01 * exact_grid + 1e-4,
                "θ {theta_deg}° τ {tau}: {got} against {exact_grid} (off-grid {exact})"
            );
        }
    }

    /// A uniform chord of optical depth `tau` in `n` steps from the eye,
    /// the sun straight behind it: each step's sun path the rest of the
    /// chord beyond it, plus `extra` (cloud between the chord and the sun).
    fn uniform_chord(tau: f64, extra: f64, n: usize) -> Vec<PeakStep> {
        let step = tau / n as f64;
        (0..n)
            .map(|i| PeakStep {
                optical_depth: step,
                sun_depth: extra + tau - (i as f64 + 0.5) * step,
            })
            .collect()
    }

    #[test]
    fn the_last_scattering_integrates_to_the_chord_along_the_sun() {
        // A view ray straight along the sun's beam through a uniform chord
        // (the sun's path to each point the rest of the chord behind it):
        // the march of H is F of the whole chord (∂F/∂τ = H − F), which is
        // the mesh's term. (On the table's depths: between them F's
        // bilinear lookup is low by up to a fifth at τ < 0.5, where F grows
        // as τ e^{−τ}; H's lookup is near linear there.)
        let table = ForwardPeakTable::gaussian([0.6f64.to_radians(); 3], [0.45; 3]);
        for &(theta_deg, tau) in &[(0.5, 1.0), (1.5, 3.0), (3.0, 8.0), (0.2, 0.5)] {
            let theta = f64::to_radians(theta_deg);
            let marched = peak_along_ray(&table, theta, &uniform_chord(tau, 0.0, 400))[1];
            let chord = table.at(theta, tau)[1];
            assert!(
                (marched - chord).abs() <= 0.02 * chord + 1e-4,
                "θ {theta_deg}° τ {tau}: marched {marched} against F {chord}"
            );
        }
    }

    #[test]
    fn a_rim_lit_through_the_body_takes_less_of_the_peak() {
        // The same thin chord (τ = 0.3) whose sun comes through 4 more of
        // cloud (a rim with the body between it and the sun) sends
        // e^{−4(1 − P_f)}-ish less: the beam lost what it scattered out
        // of the peak and spread what it scattered within it.
        let table = ForwardPeakTable::gaussian([0.6f64.to_radians(); 3], [0.45; 3]);
        let theta = 1.0f64.to_radians();
        let chord = |extra: f64| peak_along_ray(&table, theta, &uniform_chord(0.3, extra, 50))[0];
        let (open, behind) = (chord(0.0), chord(4.0));
        assert!(behind < 0.3 * open, "{behind} against {open}");
        assert!(behind > 0.0);
    }

    #[test]
    fn the_light_in_the_peak_is_what_scattered_only_within_it() {
        // ∫ F dΩ = e^{−τ(1 − P_f)} − e^{−τ} (as long as the broadened peak
        // stays within the table's 16°).
        let sigma = 0.8f64.to_radians();
        let table = ForwardPeakTable::gaussian([sigma; 3], [0.47; 3]);
        for &tau in &[0.5, 2.0, 5.0, 10.0] {
            let n = 4000;
            let h = ANGLE_MAX_RAD / n as f64;
            let total: f64 = (0..n)
                .map(|i| {
                    let t = (i as f64 + 0.5) * h;
                    table.at(t, tau)[0] * 2.0 * std::f64::consts::PI * t * h
                })
                .sum();
            let expected = (-tau * (1.0 - 0.47)).exp() - (-tau).exp();
            assert!(
                (total - expected).abs() < 0.01 * expected,
                "τ {tau}: {total} against {expected}"
            );
        }
    }
}
