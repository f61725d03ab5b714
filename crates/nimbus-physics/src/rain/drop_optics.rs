//! What a falling drop shows: the light it refracts and reflects, averaged
//! over its disc (a drop is a pixel or less, or a streak of its motion).
//!
//! A spherical drop of refractive index n seen along the view direction v
//! is hit at impact parameter b ∈ [0, 1] (in radii; the disc is covered
//! uniformly in b²). At incidence θᵢ = asin b:
//! - a share R(θᵢ) is reflected (Fresnel, unpolarised): the camera sees the
//!   environment in the direction reflect(v, normal), at γ = π − 2θᵢ from v,
//!   towards the camera at the drop's centre and forward at its rim;
//! - a share (1 − R)² passes straight through (two refractions, θₜ = asin(b/n)
//!   inside) and is deviated by D = 2(θᵢ − θₜ) towards the axis: the drop
//!   shows the environment behind it turned over, within D(1) = 82.8° of v
//!   for water, a field of 165.6° (Rousseau et al., "Realistic real-time
//!   rain rendering", Computers & Graphics 30(4), 2006, §3: "about 165°");
//! - the rest (≈ 4 %: internal reflections, the rainbows' light) is left out.
//!
//! Every path turns v by an angle γ about v's axis, uniformly in azimuth, so
//! the disc-averaged radiance is a zonal convolution of the environment:
//! L̄(v) = ∫ K(w·v) L(w) dw. For an environment in spherical harmonics, band
//! l is scaled by k_l = ∫₀¹ [R P_l(cos γ_r) + (1 − R)² P_l(cos D)] d(b²)
//! (Funk–Hecke); for the sun, a direction, K itself is needed, tabulated
//! over cos γ. The renderer applies both to the sky's SH and the sun.

use crate::optics::phase::legendre_values;

/// Refractive index of water for visible light (at 20 °C, 589 nm: 1.333;
/// Hale & Querry, Applied Optics 12(3), 1973).
pub const WATER_REFRACTIVE_INDEX: f64 = 1.333;

/// Bins of [`DropTransfer::kernel_per_sr`] over cos γ ∈ [−1, 1].
pub const KERNEL_BINS: usize = 64;

/// Fresnel reflectance of unpolarised light at incidence `cos_i` on a
/// surface from a medium of index 1 into one of index `n` (Born & Wolf,
/// *Principles of Optics*, §1.5.2).
pub fn fresnel_reflectance(cos_i: f64, n: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t2 = (1.0 - cos_i * cos_i) / (n * n);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let r_s = (cos_i - n * cos_t) / (cos_i + n * cos_t);
    let r_p = (n * cos_i - cos_t) / (n * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// A drop's transfer of the light around it to the camera, averaged over
/// its disc (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct DropTransfer {
    /// k₀, k₁, k₂: the scale of each spherical-harmonic band of the
    /// environment's radiance, around the view direction.
    pub band_weights: [f64; 3],
    /// K(cos γ), sr⁻¹, in [`KERNEL_BINS`] bins uniform in cos γ from −1 to 1
    /// (each the bin's mean): radiance seen per unit of irradiance from a
    /// direction at γ from the view direction (the sun).
    pub kernel_per_sr: Vec<f64>,
    /// Share of the disc's light that is reflected, ∫R d(b²).
    pub reflected: f64,
    /// Share that is refracted straight through, ∫(1 − R)² d(b²).
    pub transmitted: f64,
    /// Largest deviation of the light refracted through, rad.
    pub max_deviation_rad: f64,
}

impl DropTransfer {
    /// The transfer of a sphere of refractive index `n` (≥ 1), by the
    /// midpoint rule over b² with `samples` points.
    pub fn sphere(n: f64, samples: usize) -> Self {
        let samples = samples.max(1);
        let mut band_weights = [0.0; 3];
        let mut kernel_mass = vec![0.0; KERNEL_BINS];
        let (mut reflected, mut transmitted) = (0.0, 0.0);
        let weight = 1.0 / samples as f64;
        let bin = |mu: f64| (((mu + 1.0) * 0.5 * KERNEL_BINS as f64) as usize).min(KERNEL_BINS - 1);
        for i in 0..samples {
            let b = ((i as f64 + 0.5) * weight).sqrt();
            let theta_i = b.asin();
            let theta_t = (b / n).asin();
            let r = fresnel_reflectance(theta_i.cos(), n);
            let t = (1.0 - r) * (1.0 - r);
            let mu_reflected = -(2.0 * theta_i).cos();
            let mu_transmitted = (2.0 * (theta_i - theta_t)).cos();
            let (mut p_reflected, mut p_transmitted) = ([0.0; 3], [0.0; 3]);
            legendre_values(mu_reflected, &mut p_reflected);
            legendre_values(mu_transmitted, &mut p_transmitted);
            for (l, k) in band_weights.iter_mut().enumerate() {
                *k += weight * (r * p_reflected[l] + t * p_transmitted[l]);
            }
            kernel_mass[bin(mu_reflected)] += weight * r;
            kernel_mass[bin(mu_transmitted)] += weight * t;
            reflected += weight * r;
            transmitted += weight * t;
        }
        // Mass per bin over the bin's solid angle, 2π·Δμ.
        let bin_sr = 2.0 * std::f64::consts::PI * 2.0 / KERNEL_BINS as f64;
        Self {
            band_weights,
            kernel_per_sr: kernel_mass.iter().map(|m| m / bin_sr).collect(),
            reflected,
            transmitted,
            max_deviation_rad: 2.0 * (std::f64::consts::FRAC_PI_2 - (1.0 / n).asin()),
        }
    }

    /// The transfer of a water drop.
    pub fn water() -> Self {
        Self::sphere(WATER_REFRACTIVE_INDEX, 1 << 16)
    }

    /// K at `cos_gamma`, sr⁻¹, linear between bin centres.
    pub fn kernel_at(&self, cos_gamma: f64) -> f64 {
        let x = (cos_gamma.clamp(-1.0, 1.0) + 1.0) * 0.5 * KERNEL_BINS as f64 - 0.5;
        let i = x.floor().clamp(0.0, KERNEL_BINS as f64 - 2.0) as usize;
        let f = (x - i as f64).clamp(0.0, 1.0);
        self.kernel_per_sr[i] * (1.0 - f) + self.kernel_per_sr[i + 1] * f
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// P_l(x), l ≤ 2.
    fn legendre(l: usize, x: f64) -> f64 {
        let mut p = [0.0; 3];
        legendre_values(x, &mut p);
        p[l]
    }

    #[test]
    fn fresnel_matches_normal_incidence_and_grazing_limits() {
        // ((n − 1)/(n + 1))² at normal incidence: 0.0204 for water.
        let n = WATER_REFRACTIVE_INDEX;
        let normal = ((n - 1.0) / (n + 1.0)).powi(2);
        assert!((fresnel_reflectance(1.0, n) - normal).abs() < 1e-12);
        assert!((fresnel_reflectance(0.0, n) - 1.0).abs() < 1e-12);
        // Brewster's angle: the p-polarised part vanishes, R = R_s/2.
        let brewster = n.atan();
        let r = fresnel_reflectance(brewster.cos(), n);
        let cos_t = (1.0 - brewster.sin().powi(2) / (n * n)).sqrt();
        let r_s = ((brewster.cos() - n * cos_t) / (brewster.cos() + n * cos_t)).powi(2);
        assert!((r - 0.5 * r_s).abs() < 1e-12);
    }

    #[test]
    fn a_water_drop_reflects_its_diffuse_fresnel_share_and_refracts_within_165_degrees() {
        let drop = DropTransfer::water();
        println!(
            "reflected {:.4}, transmitted {:.4}, band weights {:?}",
            drop.reflected, drop.transmitted, drop.band_weights
        );
        // The disc average of R is the cosine-weighted hemispherical
        // reflectance of water: 0.066 for n = 1.333 (Lekner & Dorf,
        // "Why some things are darker when wet", Applied Optics 27(7),
        // 1988: 0.066 for n = 1.33; the renderer's former constant).
        assert!(
            (drop.reflected - 0.066).abs() < 1.5e-3,
            "{}",
            drop.reflected
        );
        // Refracted straight through: what is not reflected at either
        // surface; the rest (a few per cent) is internally reflected.
        assert!(drop.transmitted > 0.88 && drop.transmitted < 1.0 - drop.reflected);
        // Rousseau et al. 2006: the drop shows about 165° of the scene.
        let field_deg = 2.0 * drop.max_deviation_rad.to_degrees();
        assert!((field_deg - 165.6).abs() < 0.1, "{field_deg}");
        // Beyond that field only reflected light is seen: the kernel's mass
        // there (bins wholly beyond) is at most the reflected share.
        let bin_sr = 4.0 * PI / KERNEL_BINS as f64;
        let edge = drop.max_deviation_rad.cos();
        let beyond: f64 = (0..KERNEL_BINS)
            .filter(|&i| -1.0 + 2.0 * (i as f64 + 1.0) / KERNEL_BINS as f64 <= edge)
            .map(|i| drop.kernel_per_sr[i] * bin_sr)
            .sum();
        assert!(beyond > 0.0 && beyond < drop.reflected, "{beyond}");
    }

    #[test]
    fn the_kernel_and_the_band_weights_agree() {
        let drop = DropTransfer::water();
        // Funk–Hecke: k_l = 2π ∫ K(μ) P_l(μ) dμ, from the table.
        let steps = 20_000;
        for l in 0..3 {
            let mut k = 0.0;
            for i in 0..steps {
                let mu = -1.0 + 2.0 * (i as f64 + 0.5) / steps as f64;
                k += 2.0 * PI * drop.kernel_at(mu) * legendre(l, mu) * 2.0 / steps as f64;
            }
            let tolerance = if l == 0 { 2e-3 } else { 0.03 };
            assert!(
                (k - drop.band_weights[l]).abs() < tolerance,
                "band {l}: {k} vs {}",
                drop.band_weights[l]
            );
        }
        // Band 0 is all the light the drop passes on.
        assert!((drop.band_weights[0] - drop.reflected - drop.transmitted).abs() < 1e-12);
    }

    #[test]
    fn a_drop_of_air_is_transparent() {
        // n = 1: nothing reflected, nothing deviated: every band passes.
        let drop = DropTransfer::sphere(1.0, 4096);
        assert!(drop.reflected.abs() < 1e-12);
        for k in drop.band_weights {
            assert!((k - 1.0).abs() < 1e-9, "{k}");
        }
        assert!(drop.max_deviation_rad.abs() < 1e-12);
    }

    #[test]
    fn the_band_weights_match_a_monte_carlo_average_over_the_disc() {
        // Independent of the midpoint rule: random impact points, each
        // path's direction built in 3-D and projected on P_l.
        use crate::rain::random::{pcg_hash, uniform};
        let n = WATER_REFRACTIVE_INDEX;
        let drop = DropTransfer::sphere(n, 1 << 14);
        let count = 200_000u32;
        let mut sums = [0.0f64; 3];
        for i in 0..count {
            let u = uniform(i, 7, 0) as f64;
            let phi = 2.0 * PI * uniform(pcg_hash(i), 7, 1) as f64;
            let b = u.sqrt();
            // View along −z; the hit point's offset in the (x, y) plane.
            let (ex, ey) = (phi.cos(), phi.sin());
            let cos_i = (1.0 - b * b).sqrt();
            let normal = [b * ex, b * ey, cos_i];
            let view = [0.0, 0.0, -1.0];
            let d = view[2] * normal[2];
            let reflected = [
                view[0] - 2.0 * d * normal[0],
                view[1] - 2.0 * d * normal[1],
                view[2] - 2.0 * d * normal[2],
            ];
            let deviation = 2.0 * (b.asin() - (b / n).asin());
            let transmitted_z = -deviation.cos();
            let r = fresnel_reflectance(cos_i, n);
            for (l, s) in sums.iter_mut().enumerate() {
                // cos γ = w · view = −w_z.
                *s += r * legendre(l, -reflected[2])
                    + (1.0 - r).powi(2) * legendre(l, -transmitted_z);
            }
        }
        for (l, sum) in sums.iter().enumerate() {
            let k = sum / count as f64;
            assert!(
                (k - drop.band_weights[l]).abs() < 4e-3,
                "band {l}: {k} vs {}",
                drop.band_weights[l]
            );
        }
    }
}
