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
//! Beside it, Φ^d_k: the same projection of the *direct* (unscattered)
//! fluence, ∫ T(x, s) Y_k(s) ds. The sky's single scattering towards a
//! camera is σ p L_sky T along every direction; taken as isotropic it is
//! Σ_k Φ^d_k L_k /(4π) per unit σ, and near a face — all a camera outside
//! the cloud sees — it is as large as the scattered light (half the sky
//! is open there; docs/REALISM.md, "The volume model"). The sun's direct
//! beam stays analytic (below), so the sun reads Φ_k alone. Taken
//! isotropic it also sent the light arriving sideways down to a camera
//! under a base: the march scatters it through the phase function instead
//! ([`SkyDirectKernel`]: T's orders ≤ 1 as a cap of open sky,
//! [`transmittance_cap`]).
//!
//! And F_k (k ≤ 3): the scattered light's net flux, ∫ Φ(x, s, ω) ω dω
//! projected on the harmonics of order ≤ 1 over s, the first moment of the
//! same tally (each path length weighed by its direction of travel). The
//! sky's scattered light towards the camera is then Eddington's
//! (Φ + 3 g* o·F)/(4π) rather than Φ/(4π): near a face the sky's light
//! flows out of the cloud, so the fog looking out through a shaded face is
//! dimmer than the isotropic fluence says, a face seen from outside
//! brighter (docs/REALISM.md, "The volume model").
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
//! J = σ [P_S(Θ) E_sun T_sun + (E_sun D_sun(−v) + Φ_env)/(4π)]: the sky's
//! scattered light sent towards the camera as if isotropic, the sun's by
//! its directional fluence D_sun towards the camera, traced for the sun's
//! own direction ([`SunCube`]). Until that is ready (a real-time caller's
//! first frames in a cloud, or after the sun has turned), D_sun is the
//! isotropic Φ_sun with the sun's forward-scattered part (below).
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
    /// Φ^d_0 … Φ^d_8, the direct fluence's, per cell (the same order).
    pub direct: Vec<[f64; 9]>,
    /// F_0 … F_3, the scattered light's net flux vectors (x, y, z, per unit
    /// irradiance, dimensionless) projected on the harmonics of order ≤ 1
    /// over the source's direction, per cell: the sky's is Σ_k F_k L_k.
    pub flux: Vec<[[f64; 3]; 4]>,
    /// Photons traced.
    pub photons: u64,
}

impl InteriorTransfer {
    fn index(&self, [i, j, k]: [usize; 3]) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Side of a cell along each axis, m.
    pub fn cell_m(&self) -> DVec3 {
        cell_size_m(self.extent_m, self.dims)
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

    /// Φ^d_k of cell (i, j, k).
    pub fn direct_cell(&self, cell: [usize; 3]) -> [f64; 9] {
        self.direct[self.index(cell)]
    }

    /// F_k of cell (i, j, k).
    pub fn flux_cell(&self, cell: [usize; 3]) -> [[f64; 3]; 4] {
        self.flux[self.index(cell)]
    }
}

/// Where the photons of [`trace_cells`] come from.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Launch {
    /// Uniform over the directions towards the source: the light of every
    /// sun direction at once, for a projection over them.
    Uniform,
    /// One collimated beam from the direction towards its source (unit).
    Beam(DVec3),
}

/// The cells of a box (see [`InteriorSettings::cells_longest`]): sizes and
/// counts.
fn cell_grid((lo, hi): (DVec3, DVec3), cells_longest: usize) -> (DVec3, [usize; 3], DVec3) {
    let extent = (hi - lo).max(DVec3::splat(1e-6));
    let longest = extent.max_element();
    let n = cells_longest.max(2) as f64;
    let dims: [usize; 3] =
        std::array::from_fn(|a| ((extent[a] / longest * n).ceil() as usize).max(2));
    (extent, dims, cell_size_m(extent, dims))
}

/// The size of a cell of a box of `extent_m` split into `dims` cells, m.
fn cell_size_m(extent_m: DVec3, dims: [usize; 3]) -> DVec3 {
    extent_m / DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64)
}

/// The scattered light's path length per cell, weighted: photons launched
/// by `launch` cross the medium by delta tracking, and every tentative
/// collision adds `weigh(s, d, order)` times its weight to its cell (see
/// the module notes): s the photon's source direction, d its direction of
/// travel, `order` its scatterings so far; the unscattered light (order 0)
/// only for [`Launch::Uniform`] (a beam's is the analytic direct beam's). Returns the sums scaled to per unit volume
/// and unit irradiance of the source (times 4π for [`Launch::Uniform`],
/// whose sources' directions have density 1/4π), the cells' grid and the
/// photons traced. Parallel (rayon); the result does not depend on the
/// thread count. Memory: 8N bytes per cell per worker.
fn trace_cells<const N: usize>(
    medium: &impl Medium,
    scattering: &Scattering,
    settings: &InteriorSettings,
    launch: Launch,
    weigh: impl Fn(DVec3, DVec3, u32) -> [f64; N] + Sync,
) -> (Vec<[f64; N]>, DVec3, [usize; 3], u64) {
    let bounds = medium.bounds_m();
    let (lo, hi) = bounds;
    let (extent, dims, cell) = cell_grid(bounds, settings.cells_longest);
    let cells = dims.iter().product::<usize>();
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
    let add = |mut a: Vec<[f64; N]>, b: Vec<[f64; N]>| {
        for (x, y) in a.iter_mut().zip(&b) {
            for k in 0..N {
                x[k] += y[k];
            }
        }
        a
    };
    let sums = (0..workers)
        .into_par_iter()
        .map(|worker| {
            let mut sums = vec![[0.0; N]; cells];
            if majorant <= 0.0 {
                return sums;
            }
            for batch in (worker..batches).step_by(workers as usize) {
                let mut rng = Rng::new(settings.seed, batch);
                for _ in 0..BATCH_PHOTONS {
                    let to_light = match launch {
                        Launch::Uniform => uniform_direction(&mut rng),
                        Launch::Beam(s) => s,
                    };
                    let (t, b) = tangents(to_light);
                    let r = radius * rng.uniform().sqrt();
                    let phi = std::f64::consts::TAU * rng.uniform();
                    let start = centre + to_light * radius + (t * phi.cos() + b * phi.sin()) * r;
                    let Some((near, _)) = ray_box(start, -to_light, bounds) else {
                        continue;
                    };
                    let mut x = start - to_light * near;
                    let mut d = -to_light;
                    let mut order = 0u32;
                    let mut weight = 1.0;
                    // The unscattered light's weight: the uniform launch
                    // may tally it (the direct fluence), a beam's is the
                    // analytic direct beam's and is not tallied.
                    let mut per_unit_weight = match launch {
                        Launch::Uniform => weigh(to_light, d, 0),
                        Launch::Beam(_) => [0.0; N],
                    };
                    let tally_direct = matches!(launch, Launch::Uniform);
                    loop {
                        x += d * (-rng.uniform_open0().ln() / majorant);
                        if !inside(x, bounds) {
                            break;
                        }
                        if order >= 1 || tally_direct {
                            let sum = &mut sums[cell_of(x)];
                            for k in 0..N {
                                sum[k] += weight * per_unit_weight[k];
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
                            per_unit_weight = weigh(to_light, d, order);
                        }
                    }
                }
            }
            sums
        })
        .reduce(|| vec![[0.0; N]; cells], add);
    let photons = batches * BATCH_PHOTONS;
    let volume = cell.x * cell.y * cell.z;
    let directions = match launch {
        Launch::Uniform => 4.0 * PI,
        Launch::Beam(_) => 1.0,
    };
    let scale = if majorant > 0.0 {
        directions * disk_area_m2 / photons as f64 / majorant / volume
    } else {
        0.0
    };
    let scaled = sums.iter().map(|s| s.map(|v| v * scale)).collect();
    (scaled, extent, dims, photons)
}

/// Traces Φ_k, Φ^d_k and F_k of `medium` on a grid of cells over its box
/// (see the module notes). Parallel (rayon); the result does not depend on
/// the thread count. Memory: 240 bytes per cell per worker.
pub fn trace_interior(
    medium: &impl Medium,
    scattering: &Scattering,
    settings: &InteriorSettings,
) -> InteriorTransfer {
    // 0..9: the scattered light's Y_k(s); 9..18: the direct's; 18..30: the
    // scattered light's Y_k(s) d (k ≤ 3, d's x, y, z).
    let (cells, extent_m, dims, photons) = trace_cells(
        medium,
        scattering,
        settings,
        Launch::Uniform,
        |s, d, order| {
            let y = sh::basis(s.to_array());
            let mut weights = [0.0; 30];
            if order == 0 {
                weights[9..18].copy_from_slice(&y);
            } else {
                weights[..9].copy_from_slice(&y);
                for k in 0..4 {
                    for a in 0..3 {
                        weights[18 + 3 * k + a] = y[k] * d[a];
                    }
                }
            }
            weights
        },
    );
    let split = |from: usize| -> Vec<[f64; 9]> {
        cells
            .iter()
            .map(|c| std::array::from_fn(|k| c[from + k]))
            .collect()
    };
    let flux = cells
        .iter()
        .map(|c| std::array::from_fn(|k| std::array::from_fn(|a| c[18 + 3 * k + a])))
        .collect();
    InteriorTransfer {
        origin_m: medium.bounds_m().0,
        extent_m,
        dims,
        coefficients: split(0),
        direct: split(9),
        flux,
        photons,
    }
}

/// The scattered light of one collimated beam arriving from `to_light`
/// (unit, towards the source), per cell: Σ over the scattered photons'
/// path length in the cell of `weigh(d)` (d the direction of travel), per
/// unit volume and unit normal irradiance of the beam. `weigh(d) = [1]` is
/// the fluence Φ(x, s) of the module notes for that one s; 4π p(Ω·d) the
/// light the droplets send towards Ω (the directional fluence). Parallel
/// (rayon); the result does not depend on the thread count. Returns the
/// cells (x fastest) and their box's size and counts (origin: the medium's
/// minimum corner).
pub fn trace_beam_cells<const N: usize>(
    medium: &impl Medium,
    scattering: &Scattering,
    settings: &InteriorSettings,
    to_light: DVec3,
    weigh: impl Fn(DVec3) -> [f64; N] + Sync,
) -> (Vec<[f64; N]>, DVec3, [usize; 3]) {
    let (cells, extent, dims, _) = trace_cells(
        medium,
        scattering,
        settings,
        Launch::Beam(to_light.normalize()),
        |_, d, _| weigh(d),
    );
    (cells, extent, dims)
}

/// The axes of an ambient cube, in the order of [`SunCube::cells`]: +x,
/// −x, +y, −y, +z, −z.
pub const CUBE_AXES: [[f64; 3]; 6] = [
    [1.0, 0.0, 0.0],
    [-1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, -1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
];

/// A value towards `direction` (unit) from its six values towards the axes
/// ([`CUBE_AXES`]): Σ_a Ω_a² D(±a), the side of each axis the direction's
/// (the ambient cube of Valve's Source engine; McTaggart 2004, "Half-Life
/// 2 / Valve Source Shading"). Exact along the axes and for a value the
/// same in every direction; its weights are positive, so it never goes
/// negative where the light is all one way, as harmonics do. Twin of
/// WGSL `ambient_cube` (nimbus-render's `shader/diffusion.wgsl`).
pub fn ambient_cube(values: &[f64; 6], direction: DVec3) -> f64 {
    let d2 = direction * direction;
    let side = |a: f64, positive: usize| if a >= 0.0 { positive } else { positive + 1 };
    d2.x * values[side(direction.x, 0)]
        + d2.y * values[side(direction.y, 2)]
        + d2.z * values[side(direction.z, 4)]
}

/// The sun's scattered light inside a cloud for one sun direction, resolved
/// in the direction it is sent: the directional fluence D(x, Ω) = 4π ∫
/// p(Ω·ω) L_s(x, ω) dω (W m⁻² per unit normal irradiance of the sun), so
/// that the source a march needs towards its camera is σ E_sun D(x, −v)/4π.
/// Stored per cell as an ambient cube ([`ambient_cube`]) and D along the
/// beam's travel, read by [`sun_cube_toward`].
///
/// Why per sun and not a projection over sun directions like Φ_k: near the
/// face a camera looks out through on the shaded side, the sun's scattered
/// light flows out of the cloud, and a droplet sends back towards the
/// camera 0.22–0.49 of the isotropic Φ/4π the march took (docs/REALISM.md,
/// "The shaded side of a cumulus"). That depends on the angle between the
/// sun and the view, and second-order harmonics over the sun's direction
/// smooth it away. For one sun the cube is within 4–21 % of the exact D
/// along those views (the isotropic Φ: 2–4.5×), 0.39 in mean |ln ratio|
/// over 26 directions and the cloud's lit cells (isotropic: 0.90; second-
/// and third-order harmonics of D: 0.96 and 0.45). What six directions
/// cannot hold is the peak of the light still travelling near the beam
/// (looking 18° from the sun inside a sunlit face the cube gave 0.73 of
/// the exact D): that is what D along the beam restores.
#[derive(Clone, Debug, PartialEq)]
pub struct SunCube {
    /// Minimum corner, m (the medium's frame).
    pub origin_m: DVec3,
    /// Size of the box, m.
    pub extent_m: DVec3,
    /// Cells along x, y, z.
    pub dims: [usize; 3],
    /// Per cell (x fastest): D towards +x, −x, +y, −y, +z, −z, D along the
    /// beam's travel (−`to_sun`), then the fluence Φ (dimensionless, per
    /// unit normal irradiance).
    pub cells: Vec<[f64; 8]>,
    /// The direction towards the sun it was traced for (unit, the medium's
    /// frame).
    pub to_sun: DVec3,
}

impl SunCube {
    /// The cell values at `p_m`, trilinear between cell centres and clamped
    /// to the edge cells.
    pub fn at(&self, p_m: DVec3) -> [f64; 8] {
        let cell = cell_size_m(self.extent_m, self.dims);
        trilinear(self.dims, (p_m - self.origin_m) / cell, |[i, j, k]| {
            self.cells[(k * self.dims[1] + j) * self.dims[0] + i]
        })
    }

    /// The cube's six values and the excess of D along the beam over the
    /// cube's reading there, from a cell's values (one of [`Self::cells`],
    /// or [`Self::at`] a point: the excess is linear in them): what
    /// [`sun_cube_toward`] reads.
    pub fn cube_and_excess(&self, values: &[f64; 8]) -> ([f64; 6], f64) {
        let cube = [
            values[0], values[1], values[2], values[3], values[4], values[5],
        ];
        (cube, values[6] - ambient_cube(&cube, -self.to_sun))
    }
}

/// The part of the forward lobe ([`forward_orders_lobe`]) at `direction`
/// that its own ambient cube does not hold: zero along the axes.
fn lobe_beyond_cube(
    direction: DVec3,
    beam_travel: DVec3,
    optical_depth: f64,
    asymmetry: f64,
) -> f64 {
    let lobe = |c: f64| forward_orders_lobe(optical_depth, c, asymmetry);
    let d2 = direction * direction;
    let side = |a: f64| if a >= 0.0 { 1.0 } else { -1.0 };
    lobe(direction.dot(beam_travel))
        - d2.x * lobe(side(direction.x) * beam_travel.x)
        - d2.y * lobe(side(direction.y) * beam_travel.y)
        - d2.z * lobe(side(direction.z) * beam_travel.z)
}

/// How the excess of D along the beam over the cube spreads to `toward`
/// (unit): as the forward lobe's own excess over its cube does (at the
/// beam's optical depth `optical_depth` to the point, the peak-removed
/// asymmetry `asymmetry`), relative to its value along the beam: 1 there, 0
/// on the axes (0 everywhere when the beam runs along an axis, where the
/// cube is exact). Clamped to [0, 1]: where the lobe falls below its cube
/// (towards the side and back) the excess is not spread, since there D is
/// a small remainder and a negative spread of the beam's excess made the
/// held-out view out through a shaded face 14 % too dark in patches
/// (docs/REALISM.md). Constant along a march's segment. Twin of WGSL
/// `sun_cube_excess_shape` (nimbus-render's `shader/diffusion.wgsl`).
pub fn sun_cube_excess_shape(
    toward: DVec3,
    beam_travel: DVec3,
    optical_depth: f64,
    asymmetry: f64,
) -> f64 {
    let at_beam = lobe_beyond_cube(beam_travel, beam_travel, optical_depth, asymmetry);
    if at_beam.abs() > 1e-3 {
        (lobe_beyond_cube(toward, beam_travel, optical_depth, asymmetry) / at_beam).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// D towards `toward` (unit) from a cell's [`SunCube`] values: the ambient
/// cube plus the excess of D along the beam over the cube there (`excess`)
/// times its [`sun_cube_excess_shape`] `shape`: exact on the axes and along
/// the beam, where the cube alone misses the light still travelling near
/// it. Never negative. Twin of WGSL `sun_cube_toward`.
pub fn sun_cube_toward(cube: &[f64; 6], excess: f64, toward: DVec3, shape: f64) -> f64 {
    (ambient_cube(cube, toward) + excess * shape).max(0.0)
}

/// Traces the [`SunCube`] of `medium` lit by the sun in direction `to_sun`
/// (unit, towards the sun): [`trace_beam_cells`] weighing each path by
/// 4π p(a·d) for the six axes a and the beam's travel, and by 1 for Φ.
/// Memory: 64 bytes per cell per worker.
pub fn trace_sun_cube(
    medium: &impl Medium,
    scattering: &Scattering,
    settings: &InteriorSettings,
    to_sun: DVec3,
) -> SunCube {
    let phase = &scattering.phase;
    let to_sun = to_sun.normalize();
    let (cells, extent_m, dims) = trace_beam_cells(medium, scattering, settings, to_sun, |d| {
        let mut out = [1.0; 8];
        for (o, a) in out.iter_mut().zip(CUBE_AXES) {
            *o = 4.0 * PI * phase.value(d.dot(DVec3::from_array(a)));
        }
        out[6] = 4.0 * PI * phase.value(-d.dot(to_sun));
        out
    });
    SunCube {
        origin_m: medium.bounds_m().0,
        extent_m,
        dims,
        cells,
        to_sun,
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
    /// The sun's directional fluence towards the camera D(x, −v) per unit
    /// irradiance, from the sun's own [`SunCube`], when one is ready: it
    /// replaces the isotropic `sun_fluence` with its forward lobe.
    pub sun_toward_camera: Option<f64>,
    /// o·F/Φ of the sky's scattered light (luminance): its net flux
    /// towards the camera over its fluence, so that its source is
    /// Φ (1 + 3 g* o·F/Φ)/(4π), Eddington's (at least 0).
    pub environment_flux_toward_camera: f64,
    /// The sky's direct light scattered towards the camera per unit σ*,
    /// W sr⁻¹ m⁻² (RGB): [`SkyDirectKernel::source`] of the cell's
    /// [`direct_transmittance`].
    pub sky_direct: [f64; 3],
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
        let sun_fluence = p.sun_toward_camera.unwrap_or_else(|| {
            let tau = -p.sun_transmittance.max(1e-8).ln();
            let forward = p.sun_fluence.min(1.0 - p.sun_transmittance).max(0.0);
            let lobe = forward_orders_lobe(tau, ray.cos_view_sun, ray.asymmetry);
            p.sun_fluence - forward + forward * lobe
        });
        for (c, r) in radiance.iter_mut().enumerate() {
            let environment = p.environment_fluence[c]
                * (1.0 + 3.0 * ray.asymmetry * p.environment_flux_toward_camera).max(0.0);
            let source = ray.phase[c] * ray.sun_irradiance[c] * p.sun_transmittance
                + (ray.sun_irradiance[c] * sun_fluence + environment) / (4.0 * PI);
            let source = source + p.sky_direct[c];
            *r += transmittance * source * (1.0 - step_t);
        }
        transmittance *= step_t;
    }
    (radiance, transmittance)
}

/// The 38-point rule of Lebedev (1975, "Values of the nodes and weights of
/// ninth to seventeenth order Gauss–Markov quadrature formulae invariant
/// under the octahedron group with inversion", USSR Comput. Math. Math.
/// Phys. 15(1)): the octahedron's 6 vertices (weight 1/105), the cube's 8
/// vertices (9/280) and 24 points (±p, ±q, 0) and their permutations
/// (1/35), weights summing to 1; exact for polynomials of degree ≤ 9 on
/// the sphere. Twin of WGSL `lebedev_38`.
pub fn lebedev_38() -> [(DVec3, f64); 38] {
    const P: f64 = 0.888_073_833_977_115;
    const Q: f64 = 0.459_700_843_380_983;
    let mut points = [(DVec3::ZERO, 0.0); 38];
    let mut n = 0;
    let mut push = |d: DVec3, w: f64| {
        points[n] = (d, w);
        n += 1;
    };
    for a in 0..3 {
        for sign in [1.0, -1.0] {
            let mut d = DVec3::ZERO;
            d[a] = sign;
            push(d, 1.0 / 105.0);
        }
    }
    let corner = 1.0 / 3f64.sqrt();
    for sx in [1.0, -1.0] {
        for sy in [1.0, -1.0] {
            for sz in [1.0, -1.0] {
                push(DVec3::new(sx, sy, sz) * corner, 9.0 / 280.0);
            }
        }
    }
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for (u, v) in [(P, Q), (Q, P)] {
            for su in [1.0, -1.0] {
                for sv in [1.0, -1.0] {
                    let mut d = DVec3::ZERO;
                    d[b] = su * u;
                    d[c] = sv * v;
                    push(d, 1.0 / 35.0);
                }
            }
        }
    }
    points
}

/// The Henyey–Greenstein phase function of asymmetry g truncated to its
/// Legendre orders l ≤ 3, sr⁻¹: Σ_l (2l + 1) gˡ P_l(μ)/(4π) (HG's moments
/// are gˡ). Against a function of order ≤ 3 over the sphere it integrates
/// exactly as the whole function does (Funk–Hecke).
fn phase_orders_3(asymmetry: f64, mu: f64) -> f64 {
    let mut legendre = [0.0; 4];
    crate::optics::phase::legendre_values(mu, &mut legendre);
    let sum: f64 = legendre
        .iter()
        .enumerate()
        .map(|(l, p)| (2 * l + 1) as f64 * asymmetry.powi(l as i32) * p)
        .sum();
    sum / (4.0 * PI)
}

/// The sky's light scattered once towards the camera, for one view: with
/// the direct transmittance from the sky to a point T(s) known by its mean
/// t̄ and first moment b (its projection on the harmonics of order ≤ 1,
/// [`direct_transmittance`]) and the sky's radiance L(s) (nine harmonics),
/// the source per unit σ* is ∫ L(s) T(s) p(−s·o) ds, o the direction
/// towards the camera and p the droplets' peak-removed phase function,
/// Henyey–Greenstein of its asymmetry g*. Where the sky's light crosses
/// little cloud from the sides and above but the camera looks up from
/// below, the droplets send little of it down: taken as isotropic (T's
/// fluence over 4π), the sky's direct light made the view from just under
/// a base 21 % too bright (docs/REALISM.md, "The volume model").
///
/// T itself is taken as the cap of open sky of [`transmittance_cap`] with
/// that mean and moment, not as the linear t̄ + b·s: inside a base T is ~1
/// from below and ~0 above, and the linear form is ½ at the horizon and
/// positive up to 42° above it, where the sky is brightest, and negative
/// overhead (docs/REALISM.md, "The sky's light under a base"). The cap's
/// orders ≤ 1 are the linear form's, so the source is the linear form's
/// (t̄ `mean` + b · `moment`, exact) plus the cap's orders 2 and 3 against
/// the kernel's (`order_2`, `order_3`; Funk–Hecke). Its orders 4 and 5,
/// the last the kernel holds, are dropped: a half-space's order 4 is zero
/// and its order 5 a sixteenth of its order 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SkyDirectKernel {
    /// ∫ L(s) p(−s·o) ds, W sr⁻¹ m⁻² (RGB).
    pub mean: [f64; 3],
    /// ∫ L(s) p(−s·o) s ds along x, y, z, W sr⁻¹ m⁻² (RGB each).
    pub moment: [[f64; 3]; 3],
    /// ∫ L(s) p(−s·o) Y_k(s) ds for the order-2 harmonics k = 4 … 8 of
    /// [`crate::sh::basis`], W sr⁻¹ m⁻² (RGB each).
    pub order_2: [[f64; 3]; 5],
    /// The same for the order-3 harmonics of [`order_3_basis`].
    pub order_3: [[f64; 3]; 7],
}

impl SkyDirectKernel {
    /// The kernel of the sky `sky` (the nine harmonics of its radiance,
    /// [`crate::sh`]), droplets of peak-removed asymmetry `asymmetry` and
    /// the direction `toward` the camera (unit: the light's travel after
    /// scattering). Only p's orders ≤ 3 are kept (the whole function's
    /// would add orders the cap's dropped ones meet), so the integrands are
    /// polynomials of degree ≤ 8: [`lebedev_38`] is exact. Twin of WGSL
    /// `sky_direct_kernel` (nimbus-render's `shader/diffusion.wgsl`).
    pub fn new(sky: &[[f64; 3]; 9], asymmetry: f64, toward: DVec3) -> Self {
        let mut kernel = Self::default();
        for (s, w) in lebedev_38() {
            let l = crate::sh::radiance(sky, s.to_array());
            let weight = 4.0 * PI * w * phase_orders_3(asymmetry, -s.dot(toward));
            let y2 = crate::sh::basis(s.to_array());
            let y3 = order_3_basis(s);
            for (c, l) in l.iter().enumerate() {
                kernel.mean[c] += weight * l;
                for a in 0..3 {
                    kernel.moment[a][c] += weight * l * s[a];
                }
                for (k, y) in kernel.order_2.iter_mut().zip(&y2[4..]) {
                    k[c] += weight * l * y;
                }
                for (k, y) in kernel.order_3.iter_mut().zip(&y3) {
                    k[c] += weight * l * y;
                }
            }
        }
        kernel
    }

    /// The source per unit σ*, W sr⁻¹ m⁻² (RGB), of a point whose direct
    /// transmittance has mean and first moment `transmittance` (t̄, b),
    /// at least 0.
    pub fn source(&self, (mean, gradient): (f64, DVec3)) -> [f64; 3] {
        let mut source: [f64; 3] = std::array::from_fn(|c| {
            mean * self.mean[c]
                + gradient.x * self.moment[0][c]
                + gradient.y * self.moment[1][c]
                + gradient.z * self.moment[2][c]
        });
        if let Some(cap) = transmittance_cap(mean, gradient) {
            let y2 = crate::sh::basis(cap.axis.to_array());
            let y3 = order_3_basis(cap.axis);
            let [_, _, order_2, order_3] = cap.orders();
            for (c, out) in source.iter_mut().enumerate() {
                let k2: f64 = (0..5).map(|k| self.order_2[k][c] * y2[4 + k]).sum();
                let k3: f64 = (0..7).map(|k| self.order_3[k][c] * y3[k]).sum();
                *out += cap.amplitude * (order_2 * k2 + order_3 * k3);
            }
        }
        // Orders ≤ 3 of a narrow cap turned from the sky's light can dip
        // below zero, which light cannot.
        source.map(|v| v.max(0.0))
    }
}

/// The seven real spherical harmonics of order 3 (orthonormal; their
/// constants as in Sloan 2008, "Stupid spherical harmonics tricks"), in
/// the order of WGSL `order_3_basis`.
pub fn order_3_basis(d: DVec3) -> [f64; 7] {
    let DVec3 { x, y, z } = d;
    [
        0.590_044 * y * (3.0 * x * x - y * y),
        2.890_611 * x * y * z,
        0.457_046 * y * (5.0 * z * z - 1.0),
        0.373_176 * z * (5.0 * z * z - 3.0),
        0.457_046 * x * (5.0 * z * z - 1.0),
        1.445_306 * z * (x * x - y * y),
        0.590_044 * x * (x * x - 3.0 * y * y),
    ]
}

/// A transmittance over directions that is A within a cap of half-angle
/// arccos μ₀ about n and 0 outside: a point that sees the sky through one
/// opening ([`transmittance_cap`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransmittanceCap {
    /// A.
    pub amplitude: f64,
    /// μ₀, the cosine of the cap's half-angle (−1: the whole sphere, 0: a
    /// half-space).
    pub cos_half_angle: f64,
    /// n (unit).
    pub axis: DVec3,
}

impl TransmittanceCap {
    /// T towards `s` (unit).
    pub fn at(&self, s: DVec3) -> f64 {
        if self.axis.dot(s) > self.cos_half_angle {
            self.amplitude
        } else {
            0.0
        }
    }

    /// λ_l = 2π ∫_{μ₀}^1 P_l(μ) dμ for l = 0 … 3, per unit amplitude
    /// (Funk–Hecke): 2π(1 − μ₀), π(1 − μ₀²), π μ₀(1 − μ₀²) and
    /// (π/4)(6μ₀² − 5μ₀⁴ − 1).
    pub fn orders(&self) -> [f64; 4] {
        let m = self.cos_half_angle;
        [
            2.0 * PI * (1.0 - m),
            PI * (1.0 - m * m),
            PI * m * (1.0 - m * m),
            0.25 * PI * (6.0 * m * m - 5.0 * m.powi(4) - 1.0),
        ]
    }
}

/// The largest ratio |b|/t̄ a cap takes (3 is a single direction's):
/// beyond it the cap is held at this width (μ₀ ≤ 0.93, 21°).
const CAP_MOMENT_RATIO_MAX: f64 = 2.9;

/// The cap ([`TransmittanceCap`]) whose mean over directions is `mean`
/// (t̄) and whose first moment 3⟨T s⟩ is `gradient` (b): the orders ≤ 1
/// of [`direct_transmittance`]. Its mean is A(1 − μ₀)/2 and its moment
/// 3A(1 − μ₀²)/4 along n, so r = |b|/t̄ = 3(1 + μ₀)/2: isotropic light
/// (r → 0) is the whole sphere, a half-space (r = 1.5, inside a flat base
/// or face) exactly itself, a narrow opening a narrow cap; no part of T is
/// negative or open in every direction. `None` where T has no direction
/// (b = 0) or no light (t̄ ≤ 0). Twin of WGSL `transmittance_cap`
/// (nimbus-render's `shader/diffusion.wgsl`).
pub fn transmittance_cap(mean: f64, gradient: DVec3) -> Option<TransmittanceCap> {
    let length = gradient.length();
    if mean <= 1e-9 || length <= 1e-9 {
        return None;
    }
    let ratio = (length / mean).min(CAP_MOMENT_RATIO_MAX);
    let cos_half_angle = 2.0 * ratio / 3.0 - 1.0;
    Some(TransmittanceCap {
        amplitude: 2.0 * mean / (1.0 - cos_half_angle),
        cos_half_angle,
        axis: gradient / length,
    })
}

/// The direct transmittance from the sky, T(s) ≈ t̄ + b·s, from its
/// projection Φ^d_k ([`InteriorTransfer::direct_cell`]): t̄ = Y₀ Φ^d_0 the
/// mean over directions, b from the order-1 harmonics.
pub fn direct_transmittance(direct: &[f64; 9]) -> (f64, DVec3) {
    (
        0.282_095 * direct[0],
        0.488_603 * DVec3::new(direct[3], direct[1], direct[2]),
    )
}

#[cfg(test)]
mod tests;
