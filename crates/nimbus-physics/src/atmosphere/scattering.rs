//! The scattering integrals of Hillaire (2020), computed on the CPU exactly
//! as the GPU passes compute them: the same LUT parametrisations, the same
//! sample directions and positions, the same energy-conserving integration
//! of each step (Hillaire 2016, "Physically Based Sky, Atmosphere and Cloud
//! Rendering in Frostbite", §5.6.3: ∫ S e^{−σ_t t} dt over a step with
//! constant coefficients is S (1 − e^{−σ_t Δt}) / σ_t).
//!
//! Everything is per unit solar irradiance at the top of the atmosphere.

use super::lut::*;
use super::{AtmosphereParams, cornette_shanks_phase, rayleigh_phase};
use rayon::prelude::*;

/// Number of directions over the sphere in the multiple-scattering integral.
pub const MULTIPLE_SCATTERING_DIRECTIONS: u32 = 64;
/// Ray-march steps per direction in the multiple-scattering integral.
pub const MULTIPLE_SCATTERING_STEPS: u32 = 20;
/// Ray-march steps of a sky-view texel.
pub const SKY_VIEW_STEPS: u32 = 32;
/// Ray-march steps of an aerial-perspective froxel.
pub const AERIAL_PERSPECTIVE_STEPS: u32 = 16;
/// Simpson intervals of a transmittance-LUT texel.
pub const TRANSMITTANCE_STEPS: u32 = 256;

/// Isotropic phase function, sr⁻¹.
pub const ISOTROPIC_PHASE: f64 = 1.0 / (4.0 * std::f64::consts::PI);

/// Light scattered along a segment of air towards its start, and its
/// parts (per RGB channel, per unit solar irradiance at the top of the
/// atmosphere where a radiance).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AirPath {
    /// All the light scattered in: [`AirPath::sun_single`] plus the
    /// multiple scattering Ψ_ms σ_s of the clear sky's light.
    pub luminance: [f64; 3],
    /// Transmittance of the segment.
    pub transmittance: [f64; 3],
    /// The sun's single scattering, the part a cloud layer's shadow dims.
    pub sun_single: [f64; 3],
    /// ∫ σ_R(s) T(s) ds, dimensionless: the weight by which the molecules
    /// scatter a light field's Rayleigh-phase-weighted radiance to the start.
    pub rayleigh_weight: [f64; 3],
    /// ∫ σ_M(s) T(s) ds, dimensionless: the aerosols' weight, likewise.
    pub mie_weight: [f64; 3],
}

/// Direction `index` of `count` directions spread uniformly over the unit
/// sphere (spherical Fibonacci lattice; Keinert et al., "Spherical Fibonacci
/// Mapping", SIGGRAPH Asia 2015), +Y up.
pub fn fibonacci_sphere(index: u32, count: u32) -> [f64; 3] {
    let golden_angle = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let y = 1.0 - (2.0 * index as f64 + 1.0) / count as f64;
    let radius = (1.0 - y * y).max(0.0).sqrt();
    let phi = golden_angle * index as f64;
    [radius * phi.cos(), y, radius * phi.sin()]
}

/// A 2D table of RGB values over unit coordinates, sampled bilinearly with
/// clamp-to-edge like a GPU texture read through the sub-UV mapping.
#[derive(Clone, Debug)]
pub struct Table2d {
    /// Width and height in texels.
    pub size: [u32; 2],
    /// Texels, row-major.
    pub texels: Vec<[f64; 3]>,
}

impl Table2d {
    /// Builds a table by evaluating `f(x, y)` at the unit coordinates of each texel centre.
    pub fn build(size: [u32; 2], f: impl Fn(f64, f64) -> [f64; 3] + Sync) -> Self {
        let texels = (0..size[0] * size[1])
            .into_par_iter()
            .map(|k| {
                f(
                    unit_of_texel(k % size[0], size[0]),
                    unit_of_texel(k / size[0], size[1]),
                )
            })
            .collect();
        Self { size, texels }
    }

    /// Bilinear sample at unit coordinates (x, y).
    pub fn sample(&self, x: f64, y: f64) -> [f64; 3] {
        let [w, h] = self.size;
        let fx =
            (sub_uv_from_unit(x.clamp(0.0, 1.0), w) * w as f64 - 0.5).clamp(0.0, (w - 1) as f64);
        let fy =
            (sub_uv_from_unit(y.clamp(0.0, 1.0), h) * h as f64 - 0.5).clamp(0.0, (h - 1) as f64);
        let (i0, j0) = (fx.floor() as u32, fy.floor() as u32);
        let (i1, j1) = ((i0 + 1).min(w - 1), (j0 + 1).min(h - 1));
        let (tx, ty) = (fx - i0 as f64, fy - j0 as f64);
        let at = |i: u32, j: u32| self.texels[(j * w + i) as usize];
        let (a, b, c, d) = (at(i0, j0), at(i1, j0), at(i0, j1), at(i1, j1));
        [0, 1, 2].map(|k| {
            (a[k] * (1.0 - tx) + b[k] * tx) * (1.0 - ty) + (c[k] * (1.0 - tx) + d[k] * tx) * ty
        })
    }
}

/// The CPU twins of the GPU's transmittance and multiple-scattering LUTs.
#[derive(Clone, Debug)]
pub struct AtmosphereTables {
    /// The atmosphere.
    pub params: AtmosphereParams,
    /// Transmittance to the top of the atmosphere over (x_μ, x_r).
    pub transmittance: Table2d,
    /// Ψ_ms over (x_μs, x_h).
    pub multiple_scattering: Table2d,
}

impl AtmosphereTables {
    /// Computes both tables.
    pub fn new(params: &AtmosphereParams) -> Self {
        let p = params.clone();
        let transmittance = Table2d::build(TRANSMITTANCE_LUT_SIZE, |x, y| {
            let (r, mu) = p.transmittance_r_mu_from_unit(x, y);
            p.optical_depth(
                r,
                mu,
                p.distance_to_top(r, mu),
                TRANSMITTANCE_STEPS as usize,
            )
            .map(|t| (-t).exp())
        });
        let mut tables = Self {
            params: p.clone(),
            transmittance,
            multiple_scattering: Table2d {
                size: [1, 1],
                texels: vec![[0.0; 3]],
            },
        };
        let ms = Table2d::build(MULTIPLE_SCATTERING_LUT_SIZE, |x, y| {
            let (r, mu_s) = p.multiple_scattering_r_mu_s_from_unit(x, y);
            tables.multiple_scattering_psi(r, mu_s)
        });
        tables.multiple_scattering = ms;
        tables
    }

    /// Transmittance from radius r towards μ to space, from the LUT; zero
    /// where the planet blocks the ray (its shadow).
    pub fn sun_transmittance(&self, r: f64, mu_s: f64) -> [f64; 3] {
        if self.params.ray_hits_ground(r, mu_s) {
            return [0.0; 3];
        }
        let (x, y) = self.params.transmittance_unit_from_r_mu(r, mu_s);
        self.transmittance.sample(x, y)
    }

    /// Ψ_ms at radius r for a sun at cosine zenith μ_s, from the LUT.
    pub fn multiple_scattering(&self, r: f64, mu_s: f64) -> [f64; 3] {
        let (x, y) = self.params.multiple_scattering_unit_from_r_mu_s(r, mu_s);
        self.multiple_scattering.sample(x, y)
    }

    /// Hillaire 2020, eqs. 5–10: second-order luminance L₂ and transfer f_ms
    /// integrated over the sphere of directions at (r, μ_s) with an isotropic
    /// phase function, including light reflected once by a Lambertian ground;
    /// Ψ_ms = L₂ / (1 − f_ms) sums the geometric series of higher orders.
    pub fn multiple_scattering_psi(&self, r: f64, mu_s: f64) -> [f64; 3] {
        let p = &self.params;
        let sun = [(1.0 - mu_s * mu_s).max(0.0).sqrt(), mu_s, 0.0];
        let n = MULTIPLE_SCATTERING_DIRECTIONS;
        let (mut l2, mut f_ms) = ([0.0; 3], [0.0; 3]);
        for k in 0..n {
            let dir = fibonacci_sphere(k, n);
            let mu = dir[1];
            let ground = p.ray_hits_ground(r, mu);
            let length = p.distance_to_boundary(r, mu);
            let dt = length / MULTIPLE_SCATTERING_STEPS as f64;
            let mut throughput = [1.0; 3];
            for i in 0..MULTIPLE_SCATTERING_STEPS {
                let t = (i as f64 + 0.5) * dt;
                let (sample_r, sample_mu_s) = along(r, dir, t, sun);
                let h = sample_r - p.bottom_radius_m;
                let extinction = p.extinction_per_m(h);
                let (rayleigh, mie) = p.scattering_per_m(h);
                let sun_t = self.sun_transmittance(sample_r, sample_mu_s);
                for c in 0..3 {
                    let scattering = rayleigh[c] + mie[c];
                    let step_t = (-extinction[c] * dt).exp();
                    let integral = if extinction[c] > 0.0 {
                        (1.0 - step_t) / extinction[c]
                    } else {
                        dt
                    };
                    l2[c] += throughput[c] * scattering * sun_t[c] * ISOTROPIC_PHASE * integral
                        / n as f64;
                    f_ms[c] += throughput[c] * scattering * integral / n as f64;
                    throughput[c] *= step_t;
                }
            }
            if ground {
                let (ground_r, ground_mu_s) = along(r, dir, length, sun);
                let sun_t = self.sun_transmittance(ground_r, ground_mu_s);
                for c in 0..3 {
                    let reflected =
                        sun_t[c] * ground_mu_s.max(0.0) * p.ground_albedo[c] / std::f64::consts::PI;
                    l2[c] += throughput[c] * reflected / n as f64;
                }
            }
        }
        [0, 1, 2].map(|c| l2[c] / (1.0 - f_ms[c]).max(1e-6))
    }

    /// Luminance scattered towards an observer at radius r looking along
    /// `view` (unit, local frame with +Y up at the observer) over `length`
    /// metres, with the sun in unit direction `sun`; and the transmittance of
    /// that segment. Single scattering with Rayleigh and Cornette–Shanks
    /// phases plus Ψ_ms σ_s multiple scattering; samples placed
    /// quadratically, denser near the observer.
    pub fn scatter_along(
        &self,
        r: f64,
        view: [f64; 3],
        sun: [f64; 3],
        length: f64,
        steps: u32,
    ) -> ([f64; 3], [f64; 3]) {
        let path = self.air_path(r, view, sun, length, steps);
        (path.luminance, path.transmittance)
    }

    /// [`Self::scatter_along`] with its parts: the sun's single scattering
    /// and the scattering weights of the two constituents, which a light
    /// field other than the clear sky's (an overcast's, under a cloud layer)
    /// multiplies.
    pub fn air_path(
        &self,
        r: f64,
        view: [f64; 3],
        sun: [f64; 3],
        length: f64,
        steps: u32,
    ) -> AirPath {
        let p = &self.params;
        let cos_theta = view[0] * sun[0] + view[1] * sun[1] + view[2] * sun[2];
        let phase_r = rayleigh_phase(cos_theta);
        let phase_m = cornette_shanks_phase(cos_theta, p.aerosol_asymmetry);
        let mut path = AirPath {
            transmittance: [1.0; 3],
            ..AirPath::default()
        };
        let mut t_previous = 0.0;
        for i in 0..steps {
            // Step i covers [length (i/N)², length ((i+1)/N)²], sampled at its midpoint.
            let t_next = length * ((i + 1) as f64 / steps as f64).powi(2);
            let dt = t_next - t_previous;
            let t = 0.5 * (t_previous + t_next);
            t_previous = t_next;
            let (sample_r, sample_mu_s) = along(r, view, t, sun);
            let h = sample_r - p.bottom_radius_m;
            let extinction = p.extinction_per_m(h);
            let (rayleigh, mie) = p.scattering_per_m(h);
            let sun_t = self.sun_transmittance(sample_r, sample_mu_s);
            let ms = self.multiple_scattering(sample_r, sample_mu_s);
            for c in 0..3 {
                let single = sun_t[c] * (rayleigh[c] * phase_r + mie[c] * phase_m);
                let source = single + ms[c] * (rayleigh[c] + mie[c]);
                let step_t = (-extinction[c] * dt).exp();
                let integral = if extinction[c] > 0.0 {
                    (1.0 - step_t) / extinction[c]
                } else {
                    dt
                };
                let weight = path.transmittance[c] * integral;
                path.luminance[c] += weight * source;
                path.sun_single[c] += weight * single;
                path.rayleigh_weight[c] += weight * rayleigh[c];
                path.mie_weight[c] += weight * mie[c];
                path.transmittance[c] *= step_t;
            }
        }
        path
    }

    /// Sky luminance seen from radius r at view zenith angle `zenith` (rad)
    /// and azimuth from the sun with cosine `cos_azimuth`, for a sun at
    /// cosine zenith μ_s: the sky-view LUT's integral (to the ground or space).
    pub fn sky_view_luminance(&self, r: f64, zenith: f64, cos_azimuth: f64, mu_s: f64) -> [f64; 3] {
        let (sin_z, cos_z) = zenith.sin_cos();
        let sin_az = (1.0 - cos_azimuth * cos_azimuth).max(0.0).sqrt();
        let view = [sin_z * cos_azimuth, cos_z, sin_z * sin_az];
        let sun = [(1.0 - mu_s * mu_s).max(0.0).sqrt(), mu_s, 0.0];
        let length = self.params.distance_to_boundary(r, cos_z);
        self.scatter_along(r, view, sun, length, SKY_VIEW_STEPS).0
    }
}

/// Radius and sun cosine at distance t from an observer at radius r along
/// `dir` (local frame, +Y up at the observer), with the sun in direction `sun`.
fn along(r: f64, dir: [f64; 3], t: f64, sun: [f64; 3]) -> (f64, f64) {
    let position = [dir[0] * t, r + dir[1] * t, dir[2] * t];
    let radius =
        (position[0] * position[0] + position[1] * position[1] + position[2] * position[2]).sqrt();
    let mu_s = (position[0] * sun[0] + position[1] * sun[1] + position[2] * sun[2]) / radius;
    (radius, mu_s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::OnceLock;

    fn tables() -> &'static AtmosphereTables {
        static TABLES: OnceLock<AtmosphereTables> = OnceLock::new();
        TABLES.get_or_init(|| AtmosphereTables::new(&AtmosphereParams::default()))
    }

    #[test]
    fn fibonacci_directions_are_unit_and_balanced() {
        let mut mean = [0.0; 3];
        for k in 0..64 {
            let d = fibonacci_sphere(k, 64);
            assert!(((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 1.0).abs() < 1e-12);
            for c in 0..3 {
                mean[c] += d[c] / 64.0;
            }
        }
        assert!(mean.iter().all(|m| m.abs() < 0.03), "{mean:?}");
    }

    #[test]
    fn transmittance_table_matches_the_exact_integral() {
        let t = tables();
        let p = &t.params;
        for h in [0.0, 500.0, 3000.0, 12_000.0, 40_000.0] {
            for mu in [1.0, 0.5, 0.2, 0.05, 0.01] {
                let r = p.bottom_radius_m + h;
                let exact = p.transmittance_to_top(r, mu);
                let table = t.sun_transmittance(r, mu);
                for c in 0..3 {
                    assert!(
                        (table[c] - exact[c]).abs() < 0.01 * exact[c] + 1e-4,
                        "h {h} μ {mu}: {table:?} vs {exact:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn multiple_scattering_is_positive_bluish_and_vanishes_in_the_night() {
        let t = tables();
        let r = t.params.bottom_radius_m + 100.0;
        let day = t.multiple_scattering(r, 0.7);
        assert!(day.iter().all(|v| *v > 0.0) && day[2] > day[0], "{day:?}");
        // Hillaire 2020, fig. 6: Ψ_ms is a small fraction of the single-scattered light; f_ms < 1.
        assert!(day.iter().all(|v| *v < 0.5), "{day:?}");
        let night = t.multiple_scattering(r, -0.6);
        assert!(night.iter().all(|v| *v < 1e-4 * day[2]), "{night:?}");
    }

    #[test]
    fn sky_view_discretisation_converges() {
        // The 32 quadratic steps of the sky view agree with a 1024-step march within 3 %.
        let t = tables();
        let r = t.params.bottom_radius_m + 200.0;
        for (zenith_deg, cos_az, mu_s) in [
            (0.0, 1.0, 0.8),
            (60.0, 0.0, 0.5),
            (88.0, 1.0, 0.1),
            (85.0, -1.0, 0.3),
        ] {
            let zenith: f64 = f64::to_radians(zenith_deg);
            let (sin_z, cos_z) = zenith.sin_cos();
            let sin_az = (1.0f64 - cos_az * cos_az).max(0.0).sqrt();
            let view = [sin_z * cos_az, cos_z, sin_z * sin_az];
            let sun = [(1.0f64 - mu_s * mu_s).sqrt(), mu_s, 0.0];
            let length = t.params.distance_to_boundary(r, cos_z);
            let coarse = t.scatter_along(r, view, sun, length, SKY_VIEW_STEPS).0;
            let fine = t.scatter_along(r, view, sun, length, 1024).0;
            for c in 0..3 {
                assert!(
                    (coarse[c] - fine[c]).abs() < 0.03 * fine[c],
                    "zenith {zenith_deg}: {coarse:?} vs {fine:?}"
                );
            }
        }
    }

    #[test]
    fn daylight_sky_is_blue_overhead_and_the_sunset_sky_is_redder_near_the_sun() {
        let t = tables();
        let r = t.params.bottom_radius_m + 10.0;
        let noon_zenith = t.sky_view_luminance(r, 0.0, 1.0, 0.9);
        assert!(
            noon_zenith[2] > noon_zenith[1] && noon_zenith[1] > noon_zenith[0],
            "{noon_zenith:?}"
        );
        // The setting sun itself is reddened: red passes best, blue worst.
        let sun = t.sun_transmittance(r, 0.02);
        assert!(
            sun[0] > sun[1] && sun[1] > sun[2] && sun[2] < 0.3 * sun[0],
            "{sun:?}"
        );
        let sunset_near_sun = t.sky_view_luminance(r, 88f64.to_radians(), 1.0, 0.02);
        let ratio = sunset_near_sun[0] / sunset_near_sun[2];
        assert!(
            ratio > noon_zenith[0] / noon_zenith[2] * 2.0,
            "{sunset_near_sun:?}"
        );
    }

    #[test]
    fn clear_sky_diffuse_illuminance_is_close_to_cie_measurements() {
        // Sky irradiance on the ground, E_d = ∫ L cos θ dω, compared with the
        // CIE clear-sky relation E_d = 0.8 + 15.5 (sin h)^0.5 klx (Krochmann &
        // Seidl 1974, as used in CIE 110-1994) at solar elevation h, with the
        // sun's extraterrestrial illuminance 133.8 klx. With the default
        // aerosol optical depth 0.1 the model gives 11.2, 16.1 and 18.6 klx at
        // 20°, 40° and 60° (14–22 % above the relation): within 25 %.
        let t = tables();
        let r = t.params.bottom_radius_m + 1.0;
        for elevation in [20.0f64, 40.0, 60.0] {
            let mu_s = elevation.to_radians().sin();
            let (nz, na) = (48, 24);
            let mut e = 0.0;
            for i in 0..nz {
                let zenith = (i as f64 + 0.5) / nz as f64 * std::f64::consts::FRAC_PI_2;
                for j in 0..na {
                    let az = (j as f64 + 0.5) / na as f64 * std::f64::consts::PI;
                    let l = t.sky_view_luminance(r, zenith, az.cos(), mu_s);
                    let y = 0.2126 * l[0] + 0.7152 * l[1] + 0.0722 * l[2];
                    // Both halves of the azimuth range (symmetric about the sun).
                    e += 2.0
                        * y
                        * zenith.cos()
                        * zenith.sin()
                        * (std::f64::consts::FRAC_PI_2 / nz as f64)
                        * (std::f64::consts::PI / na as f64);
                }
            }
            let lux = e * 133_800.0;
            let reference = 1000.0 * (0.8 + 15.5 * elevation.to_radians().sin().sqrt());
            assert!(
                (lux / reference - 1.0).abs() < 0.25,
                "h {elevation}°: {lux:.0} lx vs {reference:.0} lx"
            );
        }
    }
}
