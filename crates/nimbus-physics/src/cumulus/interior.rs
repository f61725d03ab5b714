//! The light inside a cumulus, precomputed per shape, and the fog a camera
//! inside the cloud sees: the in-cloud view of the camera-anywhere issue.
//!
//! **What is precomputed.** Φ(x, s): the fluence (W m⁻²) at a point x
//! inside the cloud of the light scattered at least once, per unit
//! irradiance of a collimated beam arriving from direction s (towards its
//! source), dimensionless. Like the surface transfer of [`super::transport`]
//! (precomputed radiance transfer, Sloan, Kautz & Snyder 2002) it is kept as
//! its projection on the nine real spherical harmonics of order ≤ 2 over s,
//! Φ_k(x) = ∫ Φ(x, s) Y_k(s) ds, on a coarse grid of cells over the cloud's
//! box: the sun's scattered fluence is E_sun Σ_k Φ_k Y_k(l), the sky's
//! Σ_k Φ_k L_k. Same tracer, same medium (the extinction grid the
//! path-traced references render, σ scaled by δ-M's 1 − f), same droplets.
//!
//! **Estimator.** Photons arrive as in [`super::transport::trace_transfer`]
//! (uniform directions, uniform over the disk facing each across the
//! bounding sphere) and cross the medium by delta tracking. The tentative
//! collisions of delta tracking are a Poisson process of rate σ_max along
//! the path, so each stands for 1/σ_max metres of it: adding w Y_k(s)/σ_max
//! to the cell holding every tentative collision made after the first real
//! one is an unbiased track-length estimate of the scattered light's path
//! length in the cell (Spanier & Gelbard 1969, ch. 3; the "collision
//! estimator with null collisions"). Fluence is path length per volume:
//! Φ_k = 4π A_disk / N × Σ w Y_k / σ_max / V_cell.
//!
//! **What stays analytic** (real-time shader): the unscattered sunlight,
//! single scattered along the view through the peak-removed phase function
//! with the shadow map's transmittance, as the transport model does on the
//! cloud's surface.
//!
//! **The fog** ([`march_fog`], twin of nimbus-render's
//! `passes/cumulus/in_cloud.wgsl`): the radiance along a view ray from the
//! camera, L = Σ_i T_i J_i/σ_i (1 − e^{−σ_i Δ}) + T L_behind over steps of
//! constant σ and source, with the source per unit length
//! J = σ [P_S(Θ) E_sun T_sun + (E_sun Φ_sun + Φ_env)/(4π)], the scattered
//! light's fluence sent towards the camera as if isotropic except for the
//! sun's forward-scattered part (below).
//!
//! **The sun's forward-scattered light** ([`forward_orders_lobe`]). Near a
//! sunlit face most of the sun's scattered light still travels close to the
//! beam: the droplets scatter forwards (g* ≈ 0.74 with the peak removed),
//! and isotropic it made the fog as bright looking away from the sun as
//! towards it (docs/REALISM.md, "In-cloud views"). In the forward
//! (small-angle) picture, light that has crossed an optical depth τ along
//! the beam has scattered n times with Poisson probability τⁿe^{−τ}/n!, and
//! after n Henyey–Greenstein scatterings its directions follow HG(gⁿ) (the
//! Legendre moments of convolved phase functions multiply, gˡ for HG:
//! Funk–Hecke); scattered once more towards the camera, HG(gⁿ⁺¹). That
//! light cannot exceed what left the beam, 1 − e^{−τ} per unit irradiance
//! (all of it, were none to escape sideways), so the source takes
//! min(Φ_sun, 1 − T_sun) with that lobe and the rest of Φ_sun isotropic.
//! The same idea as the "octaves" of multiple scattering with a shrinking
//! g in production volume renderers (Wrenninge, Kulla & Lundqvist 2013,
//! "Oz: the great and volumetric"), here with the orders' weights from the
//! beam's optical depth and no free parameter.
//!
//! Units: metres, m⁻¹; Φ_k dimensionless; radiances in W sr⁻¹ m⁻² per
//! channel.

use super::transport::{Medium, Scattering, inside, ray_box, tangents, uniform_direction};
use super::volume::{ExtinctionGrid, trilinear};
use crate::sh;
use crate::transport::phase_model::PhaseModel;
use crate::transport::rng::Rng;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Photons per random stream (streams keyed by (seed, batch)).
const BATCH_PHOTONS: u64 = 2048;

/// What [`trace_interior`] traces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InteriorSettings {
    /// Photons traced (rounded up to whole batches of 2048).
    pub photons: u64,
    /// Cells along the box's longest side (the others in proportion, at
    /// least 2).
    pub cells_longest: usize,
    /// Seed of the random streams.
    pub seed: u64,
}

/// Φ_k on the cells of a box (see the module notes): cell (i, j, k) spans
/// origin + (i, j, k) × extent/dims, its value held at its centre.
#[derive(Clone, Debug, PartialEq)]
pub struct InteriorTransfer {
    /// Minimum corner, m (the medium's frame).
    pub origin_m: DVec3,
    /// Size of the box, m.
    pub extent_m: DVec3,
    /// Cells along x, y, z.
    pub dims: [usize; 3],
    /// Φ_0 … Φ_8 per cell, dimensionless: x fastest, then y, then z.
    pub coefficients: Vec<[f64; 9]>,
    /// Photons traced.
    pub photons: u64,
}

impl InteriorTransfer {
    fn index(&self, [i, j, k]: [usize; 3]) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Side of a cell along each axis, m.
    pub fn cell_m(&self) -> DVec3 {
        self.extent_m
            / DVec3::new(
                self.dims[0] as f64,
                self.dims[1] as f64,
                self.dims[2] as f64,
            )
    }

    /// Φ_k of cell (i, j, k).
    pub fn cell(&self, cell: [usize; 3]) -> [f64; 9] {
        self.coefficients[self.index(cell)]
    }

    /// Φ_k at `p_m`, trilinear between cell centres and clamped to the edge
    /// cells (a GPU's linear filter with clamp-to-edge addressing).
    pub fn at(&self, p_m: DVec3) -> [f64; 9] {
        trilinear(self.dims, (p_m - self.origin_m) / self.cell_m(), |c| {
            self.cell(c)
        })
    }
}

/// Per-worker sums.
struct Tally {
    sums: Vec<[f64; 9]>,
}

/// Traces Φ_k of `medium` on a grid of cells over its box (see the module
/// notes). Parallel (rayon); the result does not depend on the thread
/// count. Memory: 72 bytes per cell per worker.
pub fn trace_interior(
    medium: &impl Medium,
    scattering: &Scattering,
    settings: &InteriorSettings,
) -> InteriorTransfer {
    let bounds = medium.bounds_m();
    let (lo, hi) = bounds;
    let extent = (hi - lo).max(DVec3::splat(1e-6));
    let longest = extent.max_element();
    let n = settings.cells_longest.max(2) as f64;
    let dims: [usize; 3] =
        std::array::from_fn(|a| ((extent[a] / longest * n).ceil() as usize).max(2));
    let cells = dims.iter().product::<usize>();
    let cell = extent / DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * extent.length() * 1.001;
    let disk_area_m2 = PI * radius * radius;
    let batches = settings.photons.div_ceil(BATCH_PHOTONS).max(1);
    let workers = rayon::current_num_threads().max(1) as u64;
    let majorant = medium.majorant_per_m();
    let cell_of = |p: DVec3| -> usize {
        let u = (p - lo) / cell;
        let i: [usize; 3] = std::array::from_fn(|a| (u[a].max(0.0) as usize).min(dims[a] - 1));
        (i[2] * dims[1] + i[1]) * dims[0] + i[0]
    };
    let tally = (0..workers)
        .into_par_iter()
        .map(|worker| {
            let mut tally = Tally {
                sums: vec![[0.0; 9]; cells],
            };
            if majorant <= 0.0 {
                return tally;
            }
            for batch in (worker..batches).step_by(workers as usize) {
                let mut rng = Rng::new(settings.seed, batch);
                for _ in 0..BATCH_PHOTONS {
                    let to_light = uniform_direction(&mut rng);
                    let (t, b) = tangents(to_light);
                    let r = radius * rng.uniform().sqrt();
                    let phi = std::f64::consts::TAU * rng.uniform();
                    let start = centre + to_light * radius + (t * phi.cos() + b * phi.sin()) * r;
                    let y = sh::basis(to_light.to_array());
                    let Some((near, _)) = ray_box(start, -to_light, bounds) else {
                        continue;
                    };
                    let mut x = start - to_light * near;
                    let mut d = -to_light;
                    let mut order = 0u32;
                    let mut weight = 1.0;
                    loop {
                        x += d * (-rng.uniform_open0().ln() / majorant);
                        if !inside(x, bounds) {
                            break;
                        }
                        if order >= 1 {
                            let sum = &mut tally.sums[cell_of(x)];
                            for k in 0..9 {
                                sum[k] += weight * y[k];
                            }
                        }
                        if rng.uniform() * majorant < medium.extinction_per_m(x) {
                            order += 1;
                            if order > scattering.max_orders {
                                break;
                            }
                            weight *= scattering.single_scattering_albedo;
                            let cos_t = scattering.phase.sample_cos(rng.uniform());
                            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                            let phi = std::f64::consts::TAU * rng.uniform();
                            d = DVec3::from_array(crate::optics::sampling::rotate(
                                d.to_array(),
                                cos_t,
                                sin_t,
                                phi,
                            ))
                            .normalize();
                        }
                    }
                }
            }
            tally
        })
        .reduce(
            || Tally {
                sums: vec![[0.0; 9]; cells],
            },
            |mut a, b| {
                for (x, y) in a.sums.iter_mut().zip(&b.sums) {
                    for k in 0..9 {
                        x[k] += y[k];
                    }
                }
                a
            },
        );
    let photons = batches * BATCH_PHOTONS;
    let volume = cell.x * cell.y * cell.z;
    let scale = if majorant > 0.0 {
        4.0 * PI * disk_area_m2 / photons as f64 / majorant / volume
    } else {
        0.0
    };
    InteriorTransfer {
        origin_m: lo,
        extent_m: extent,
        dims,
        coefficients: tally.sums.iter().map(|s| s.map(|v| v * scale)).collect(),
        photons,
    }
}

/// `grid` averaged over blocks of b³ cells (b the smallest that brings
/// every axis to at most `max_per_axis` cells), the box kept: the coarse
/// extinction a GPU holds for the in-cloud march. The grid itself when it
/// fits.
pub fn downsample(grid: &ExtinctionGrid, max_per_axis: usize) -> ExtinctionGrid {
    let max = max_per_axis.max(1);
    let b = grid
        .dims
        .iter()
        .map(|&n| n.div_ceil(max))
        .max()
        .unwrap_or(1)
        .max(1);
    if b == 1 {
        return grid.clone();
    }
    let dims: [usize; 3] = std::array::from_fn(|a| grid.dims[a].div_ceil(b));
    let mut values_per_m = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let mut sum = 0.0f64;
                for dk in 0..b {
                    for dj in 0..b {
                        for di in 0..b {
                            sum +=
                                f64::from(grid.value_per_m([i * b + di, j * b + dj, k * b + dk]));
                        }
                    }
                }
                values_per_m.push((sum / (b * b * b) as f64) as f32);
            }
        }
    }
    ExtinctionGrid {
        origin_m: grid.origin_m,
        cell_m: grid.cell_m * b as f64,
        dims,
        values_per_m,
        coarsened: true,
    }
}

/// The light of one step of the fog's march: what the shader reads there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FogLight {
    /// σ* = (1 − f) σ, the δ-M extinction, m⁻¹.
    pub extinction_per_m: f64,
    /// The sky's scattered fluence Σ_k Φ_k L_k, W m⁻² (RGB).
    pub environment_fluence: [f64; 3],
    /// The sun's scattered fluence per unit irradiance Σ_k Φ_k Y_k(l).
    pub sun_fluence: f64,
    /// The direct sunbeam's transmittance T_sun = e^{−τ} to the point
    /// (through the cloud's own grid and the shadow map's other clouds).
    pub sun_transmittance: f64,
}

/// What is constant along a ray of the fog.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FogRay {
    /// Sun's irradiance E_sun = π C_s at the cloud (through the stratus
    /// layer), W m⁻² (RGB).
    pub sun_irradiance: [f64; 3],
    /// P_S(Θ) between the sun and the view, sr⁻¹ (RGB).
    pub phase: [f64; 3],
    /// Where the march starts and ends along the ray, m.
    pub span_m: [f64; 2],
    /// Steps.
    pub steps: u32,
    /// cos of the angle between the view ray and the direction to the sun.
    pub cos_view_sun: f64,
    /// Asymmetry g* of the peak-removed phase function.
    pub asymmetry: f64,
}

/// Orders of [`forward_orders_lobe`] summed; the rest is taken as
/// isotropic (its Poisson weight is below 1e-6 for τ ≤ 4, and HG(g¹⁷) is
/// within 3 % of isotropic for g ≤ 0.75).
pub const FORWARD_ORDERS: u32 = 16;

/// The angular distribution (per unit solid angle, relative to isotropic:
/// its mean over the sphere is 1) of the sun's light scattered towards a
/// direction at cosine `cos_theta` to the beam's travel, at an optical
/// depth `optical_depth` along the beam, in the forward picture of the
/// module notes: Σ_{n≥1} w_n 4π HG(g^{n+1}, cos θ), w_n = τⁿe^{−τ}/(n!(1 −
/// e^{−τ})) the orders of the light that left the beam. Twin of WGSL
/// `forward_orders_lobe` (nimbus-render's `shader/diffusion.wgsl`).
pub fn forward_orders_lobe(optical_depth: f64, cos_theta: f64, asymmetry: f64) -> f64 {
    let tau = optical_depth.max(0.0);
    // HG(g, cos θ) relative to isotropic.
    let hg4pi = |g: f64| 4.0 * PI * PhaseModel::HenyeyGreenstein { g }.value(cos_theta);
    // w_n ∝ τⁿ/n!, whose sum over n ≥ 1 is e^τ − 1: the series itself
    // below τ = 1 (the terms beyond the 16th are below 1e-14 there, and the
    // shader's e^τ − 1 cancels in f32).
    let (mut term, mut g, mut series, mut sum) = (1.0, asymmetry, 0.0, 0.0);
    for n in 1..=FORWARD_ORDERS {
        term *= tau / f64::from(n);
        g *= asymmetry;
        series += term;
        sum += term * hg4pi(g);
    }
    if series <= 0.0 {
        return hg4pi(asymmetry * asymmetry);
    }
    let normalisation = if tau < 1.0 { series } else { tau.exp() - 1.0 };
    sum / normalisation + (1.0 - series / normalisation).max(0.0)
}

/// Radiance and transmittance of the fog along a ray (see the module
/// notes): steps of constant σ and source between t_i = t₀ + (t₁ − t₀)(i/N)²
/// (fine near the camera, where it crosses the cloud's edge), `light(t)`
/// read at the middle of each step. Twin of `in_cloud_march` in
/// nimbus-render's `passes/cumulus/in_cloud.wgsl`.
pub fn march_fog(ray: &FogRay, light: impl Fn(f64) -> FogLight) -> ([f64; 3], f64) {
    let steps = ray.steps.max(1);
    let [t0, t1] = ray.span_m;
    let span = (t1 - t0).max(0.0);
    let mut radiance = [0.0; 3];
    let mut transmittance = 1.0;
    for i in 0..steps {
        let a = f64::from(i) / f64::from(steps);
        let b = f64::from(i + 1) / f64::from(steps);
        let dt = span * (b * b - a * a);
        let p = light(t0 + span * 0.5 * (a * a + b * b));
        let sigma = p.extinction_per_m.max(0.0);
        let step_t = (-sigma * dt).exp();
        let tau = -p.sun_transmittance.max(1e-8).ln();
        let forward = p.sun_fluence.min(1.0 - p.sun_transmittance).max(0.0);
        let lobe = forward_orders_lobe(tau, ray.cos_view_sun, ray.asymmetry);
        let sun_fluence = p.sun_fluence - forward + forward * lobe;
        for (c, r) in radiance.iter_mut().enumerate() {
            let source = ray.phase[c] * ray.sun_irradiance[c] * p.sun_transmittance
                + (ray.sun_irradiance[c] * sun_fluence + p.environment_fluence[c]) / (4.0 * PI);
            *r += transmittance * source * (1.0 - step_t);
        }
        transmittance *= step_t;
    }
    (radiance, transmittance)
}

#[cfg(test)]
mod tests;
