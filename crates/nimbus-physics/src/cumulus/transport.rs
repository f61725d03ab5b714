//! Light transport through a cumulus, precomputed per shape: the light that
//! the droplets scatter more than once, leaving each point of the cloud's
//! surface, for every direction of the incoming light (the realism issue's
//! "cumulus model that carries light by its depth in the cloud").
//!
//! **Why precomputed.** The phenomenological shader ([`super::shading`])
//! lights a surface point from its own normals and blobs; a real cumulus
//! (τ ≈ 75 across a core, single-scattering albedo ≈ 1) carries sunlight
//! hundreds of scattering events deep before it leaves, and the light at a
//! point depends on the whole shape around it, on the scale of the transport
//! mean free path 1/(σ (1 − g)) ≈ 90 m. A cloud field instances a few shapes
//! that only move, turn about the vertical and scale, so the transport is
//! precomputed once per shape (and scale) and looked up per pixel: the
//! precomputed radiance transfer of Sloan, Kautz & Snyder (2002, "Precomputed
//! radiance transfer for real-time rendering in dynamic, low-frequency
//! lighting environments", SIGGRAPH), here for a scattering volume's
//! multiply scattered light as in their §6 (interreflections and
//! subsurface transfer).
//!
//! **What is precomputed.** M(x, s): the radiant exitance at surface point x
//! of light scattered at least twice, per unit irradiance of a collimated
//! beam arriving from direction s (towards its source), dimensionless. Its
//! projection on the nine real spherical harmonics of order ≤ 2 over s,
//! T_k(x) = ∫ M(x, s) Y_k(s) ds ([`crate::sh::basis`]), is the transfer
//! vector: the sun's multiply scattered exitance is E_sun Σ_k T_k Y_k(l),
//! the sky's ∫ L(s) M(x, s) ds = Σ_k T_k L_k (the environment's SH). M is a
//! smooth function of s (about a clamped cosine towards the surface's
//! outside plus what diffuses through), which order 2 holds (Ramamoorthi &
//! Hanrahan 2001: 99 % of a clamped cosine's energy).
//!
//! **How.** A forward Monte-Carlo tracer: photons arrive uniformly over the
//! sphere of directions, each from a uniform point of the disk that faces it
//! across the grid's bounding sphere (so every direction carries the same
//! irradiance), cross the volume by delta tracking (Woodcock et al. 1965)
//! through the extinction grid the path-traced references render
//! ([`super::volume::ExtinctionGrid`]), scatter with the droplets' phase
//! function, its diffraction peak truncated (δ-M, Wiscombe 1977: the peak
//! below θ_f is left unscattered and σ scaled by 1 − f; the real-time
//! shader adds the peak analytically, [`super::forward_peak`]), and on
//! leaving after two or more scattering events deposit Y_k(s) on the
//! surface sample (a triangle's centroid) nearest to where they leave the
//! cloud, and T_k(x) = (4π A_disk / N) Σ deposits / Σ area over a kernel of
//! samples around x (a density estimate on the surface).
//!
//! **What stays analytic** (real-time shader): single scattering, which
//! follows the phase function and the view, and the forward peak (the
//! silver lining), both with the shadow map.
//!
//! Units: metres, m⁻¹ for extinction; T_k is dimensionless (exitance per
//! unit irradiance, projected on dimensionless Y_k over steradians).

use super::grid::PointGrid;
use super::volume::ExtinctionGrid;
use crate::optics::sampling::rotate;
use crate::sh;
use crate::transport::phase_model::PhaseModel;
use crate::transport::rng::Rng;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Photons per random stream: streams are keyed by (seed, batch), so the
/// result does not depend on the number of threads.
const BATCH_PHOTONS: u64 = 2048;

/// A medium crossed by the random walk: σ_t inside a box, 0 outside it.
pub trait Medium: Sync {
    /// σ_t at `p_m`, m⁻¹.
    fn extinction_per_m(&self, p_m: DVec3) -> f64;
    /// An upper bound of σ_t everywhere, m⁻¹.
    fn majorant_per_m(&self) -> f64;
    /// The box outside which σ_t = 0 (minimum and maximum corner, m).
    fn bounds_m(&self) -> (DVec3, DVec3);
    /// Step of the search for where a photon leaves the cloud, m.
    fn exit_step_m(&self) -> f64;
}

/// How the droplets scatter.
#[derive(Clone, Debug)]
pub struct Scattering {
    /// Single-scattering albedo ϖ.
    pub single_scattering_albedo: f64,
    /// The phase function (the peak-truncated one, with the medium's σ
    /// scaled to match).
    pub phase: PhaseModel,
    /// Scattering events after which a photon is dropped (its weight is
    /// then below ϖ^max; 0.3 % of photons in a 1 km core pass 2000).
    pub max_orders: u32,
}

/// Where and how a photon left the medium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Escape {
    /// Position of its last scattering event (its start if none), m.
    pub last_event_m: DVec3,
    /// Its direction of flight.
    pub direction: DVec3,
    /// Scattering events.
    pub order: u32,
    /// Its weight (ϖ^order).
    pub weight: f64,
}

/// Distances along a ray where it enters and leaves a box, if it does.
pub(crate) fn ray_box(
    origin: DVec3,
    direction: DVec3,
    (lo, hi): (DVec3, DVec3),
) -> Option<(f64, f64)> {
    let inverse = direction.recip();
    let a = (lo - origin) * inverse;
    let b = (hi - origin) * inverse;
    let near = a.min(b).max_element().max(0.0);
    let far = a.max(b).min_element();
    (near <= far).then_some((near, far))
}

pub(crate) fn inside(p: DVec3, (lo, hi): (DVec3, DVec3)) -> bool {
    p.cmpge(lo).all() && p.cmple(hi).all()
}

/// Follows one photon from `start_m` along `direction` (unit) until it
/// leaves the medium's box (at once, order 0, if it misses the box); `None`
/// if it is dropped after [`Scattering::max_orders`] events. Delta tracking: free flights drawn
/// with the majorant, a tentative collision real with probability σ/σ_max.
pub fn random_walk(
    medium: &impl Medium,
    scattering: &Scattering,
    start_m: DVec3,
    direction: DVec3,
    rng: &mut Rng,
) -> Option<Escape> {
    let bounds = medium.bounds_m();
    let Some((near, _)) = ray_box(start_m, direction, bounds) else {
        return Some(Escape {
            last_event_m: start_m,
            direction,
            order: 0,
            weight: 1.0,
        });
    };
    let majorant = medium.majorant_per_m();
    let mut x = start_m + direction * near;
    let mut last = x;
    let mut d = direction;
    let mut order = 0;
    let mut weight = 1.0;
    if majorant <= 0.0 {
        return Some(Escape {
            last_event_m: last,
            direction: d,
            order,
            weight,
        });
    }
    loop {
        x += d * (-rng.uniform_open0().ln() / majorant);
        if !inside(x, bounds) {
            return Some(Escape {
                last_event_m: last,
                direction: d,
                order,
                weight,
            });
        }
        if rng.uniform() * majorant < medium.extinction_per_m(x) {
            order += 1;
            if order > scattering.max_orders {
                return None;
            }
            weight *= scattering.single_scattering_albedo;
            last = x;
            let cos_t = scattering.phase.sample_cos(rng.uniform());
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let phi = std::f64::consts::TAU * rng.uniform();
            d = DVec3::from_array(rotate(d.to_array(), cos_t, sin_t, phi)).normalize();
        }
    }
}

/// The last point with σ_t > 0 on the ray from `from_m` along `direction`
/// (where the photon leaves the cloud's surface), searched in steps of
/// [`Medium::exit_step_m`]; `from_m` itself if there is none.
pub fn exit_point(medium: &impl Medium, from_m: DVec3, direction: DVec3) -> DVec3 {
    let bounds = medium.bounds_m();
    let Some((_, far)) = ray_box(from_m, direction, bounds) else {
        return from_m;
    };
    let step = medium.exit_step_m().max(1e-6);
    let mut last = from_m;
    let mut t = step;
    while t < far {
        let p = from_m + direction * t;
        if medium.extinction_per_m(p) > 0.0 {
            last = p;
        }
        t += step;
    }
    last
}

/// An [`ExtinctionGrid`] as a medium, σ_t scaled by a constant (δ-M's
/// 1 − f) and read trilinearly as the path tracer does.
#[derive(Clone, Debug)]
pub struct GridMedium<'a> {
    grid: &'a ExtinctionGrid,
    factor: f64,
    majorant_per_m: f64,
}

impl<'a> GridMedium<'a> {
    /// The grid's σ_t times `factor`.
    pub fn new(grid: &'a ExtinctionGrid, factor: f64) -> Self {
        let max = grid.values_per_m.iter().fold(0.0f32, |m, &v| m.max(v));
        Self {
            grid,
            factor,
            majorant_per_m: f64::from(max) * factor,
        }
    }
}

impl Medium for GridMedium<'_> {
    #[inline]
    fn extinction_per_m(&self, p_m: DVec3) -> f64 {
        let g = self.grid;
        let u = (p_m - g.origin_m) / g.cell_m - DVec3::splat(0.5);
        let base = u.floor();
        let t = u - base;
        let [nx, ny, nz] = g.dims;
        let clamp = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
        let (i0, j0, k0) = (clamp(base.x, nx), clamp(base.y, ny), clamp(base.z, nz));
        let (i1, j1, k1) = (
            clamp(base.x + 1.0, nx),
            clamp(base.y + 1.0, ny),
            clamp(base.z + 1.0, nz),
        );
        let v = |i: usize, j: usize, k: usize| f64::from(g.values_per_m[(k * ny + j) * nx + i]);
        let x0 = v(i0, j0, k0) + t.x * (v(i1, j0, k0) - v(i0, j0, k0));
        let x1 = v(i0, j1, k0) + t.x * (v(i1, j1, k0) - v(i0, j1, k0));
        let x2 = v(i0, j0, k1) + t.x * (v(i1, j0, k1) - v(i0, j0, k1));
        let x3 = v(i0, j1, k1) + t.x * (v(i1, j1, k1) - v(i0, j1, k1));
        let y0 = x0 + t.y * (x1 - x0);
        let y1 = x2 + t.y * (x3 - x2);
        (y0 + t.z * (y1 - y0)) * self.factor
    }

    fn majorant_per_m(&self) -> f64 {
        self.majorant_per_m
    }

    fn bounds_m(&self) -> (DVec3, DVec3) {
        (self.grid.origin_m, self.grid.max_corner_m())
    }

    fn exit_step_m(&self) -> f64 {
        0.5 * self.grid.cell_m
    }
}

/// What the transfer's precomputation traces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransferSettings {
    /// Photons traced (rounded up to whole batches of 2048).
    pub photons: u64,
    /// Radius of the density estimate's kernel on the surface, m; a photon
    /// is assigned to the nearest surface sample within it.
    pub kernel_radius_m: f64,
    /// Seed of the random streams.
    pub seed: u64,
    /// `None`: photons from every direction, deposits projected on the SH
    /// (T_k). `Some(s₀)`: every photon from s₀ (towards the light), and
    /// coefficient 0 holds the exitance M(x, s₀) itself, the others 0 (the
    /// reference T is checked against).
    pub to_light: Option<DVec3>,
}

/// T_k(x) on the surface (see the module notes): the surface sampled by its
/// triangles' centroids with their areas; each photon that leaves after
/// two or more events deposits Σ w Y_k(s) on the sample nearest to where it
/// left. Read at a point by a kernel over the samples within
/// [`TransferSettings::kernel_radius_m`], deposits over area: both live on
/// the surface, so where along the normal a photon left does not bias the
/// ratio (a volume kernel did, by 7–15 % on the slab).
#[derive(Clone, Debug)]
pub struct SurfaceTransfer {
    /// Surface samples (triangle centroids), m.
    pub samples_m: Vec<DVec3>,
    /// Their areas, m².
    pub area_m2: Vec<f64>,
    /// Their unit normals (the triangles' winding).
    pub normals: Vec<DVec3>,
    /// Σ w Y_k(s) per sample.
    pub deposits: Vec<[f64; 9]>,
    /// The kernel's radius, m.
    pub kernel_radius_m: f64,
    grid: PointGrid,
    /// 4π A_disk / N (A_disk / N for one direction), m²: turns deposits
    /// per area into T_k.
    pub normalisation_m2: f64,
    /// Photons traced.
    pub photons: u64,
    /// Scattering events, all photons.
    pub scattering_events: u64,
    /// Fraction of the photons that left after 0 (missed or crossed the
    /// cloud unscattered), 1 and ≥ 2 events.
    pub escaped_by_order: [f64; 3],
    /// Fraction of the photons dropped (after [`Scattering::max_orders`]);
    /// with `escaped_by_order` it sums to 1.
    pub dropped: f64,
    /// Fraction of the photons that left after ≥ 2 events with no surface
    /// sample within the kernel's radius of where they left (not deposited).
    pub unassigned: f64,
    /// Area of the bounding disk photons start on, m².
    pub disk_area_m2: f64,
}

impl SurfaceTransfer {
    /// T_k at `p_m` (a point of the surface): Σ w deposits over the
    /// surface's area within the kernel's radius projected on its mean
    /// plane, Σ w A |n·n̄| (n̄ the area-weighted mean normal), w = 1 − (d/r)²;
    /// that area at least a tenth of r² (where little surface is near, the
    /// ratio would be noise).
    ///
    /// Why projected: the exitance per unit of the *macroscopic* surface.
    /// Bumps smaller than the kernel (the last level's blobs, ≲ the
    /// transport mean free path) do not darken a volume: the light field
    /// leaving it is that of the smoothed surface, and a camera sees it on
    /// every facet of the bumps; dividing by their true area would darken
    /// the bumpy cloud by its roughness (1.5–2 on the generated shapes). On
    /// a flat surface both are the same (the slab test).
    pub fn at(&self, p_m: DVec3) -> [f64; 9] {
        let r = self.kernel_radius_m;
        let weight = |i: usize| 1.0 - self.samples_m[i].distance_squared(p_m) / (r * r);
        let mut mean_normal = DVec3::ZERO;
        self.grid.for_each_near(p_m, r, |i| {
            let i = i as usize;
            let w = weight(i);
            if w > 0.0 {
                mean_normal += w * self.area_m2[i] * self.normals[i];
            }
        });
        let mean_normal = mean_normal.normalize_or_zero();
        let (mut sum, mut area) = ([0.0; 9], 0.0);
        self.grid.for_each_near(p_m, r, |i| {
            let i = i as usize;
            let w = weight(i);
            if w > 0.0 {
                area += w * self.area_m2[i] * self.normals[i].dot(mean_normal).abs();
                for (s, d) in sum.iter_mut().zip(&self.deposits[i]) {
                    *s += w * d;
                }
            }
        });
        let area = area.max(0.1 * r * r);
        sum.map(|s| s * self.normalisation_m2 / area)
    }

    fn nearest(&self, p_m: DVec3) -> Option<usize> {
        let r2 = self.kernel_radius_m * self.kernel_radius_m;
        let mut best: Option<(usize, f64)> = None;
        self.grid.for_each_near(p_m, self.kernel_radius_m, |i| {
            let d = self.samples_m[i as usize].distance_squared(p_m);
            if d <= r2 && best.is_none_or(|(_, b)| d < b) {
                best = Some((i as usize, d));
            }
        });
        best.map(|(i, _)| i)
    }
}

/// Accumulators of one worker.
struct Tally {
    deposits: Vec<[f64; 9]>,
    events: u64,
    by_order: [u64; 3],
    dropped: u64,
    unassigned: u64,
}

impl Tally {
    fn new(samples: usize) -> Self {
        Self {
            deposits: vec![[0.0; 9]; samples],
            events: 0,
            by_order: [0; 3],
            dropped: 0,
            unassigned: 0,
        }
    }

    fn merge(mut self, other: Self) -> Self {
        for (a, b) in self.deposits.iter_mut().zip(&other.deposits) {
            for k in 0..9 {
                a[k] += b[k];
            }
        }
        self.events += other.events;
        for k in 0..3 {
            self.by_order[k] += other.by_order[k];
        }
        self.dropped += other.dropped;
        self.unassigned += other.unassigned;
        self
    }
}

/// A uniform direction on the sphere.
pub(crate) fn uniform_direction(rng: &mut Rng) -> DVec3 {
    let z = 1.0 - 2.0 * rng.uniform();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * rng.uniform();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Two unit vectors completing `n` to an orthonormal basis.
pub(crate) fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let t = DVec3::from_array(rotate(n.to_array(), 0.0, 1.0, 0.0));
    (t, n.cross(t))
}

/// Traces the transfer of `medium` to the surface `triangles` (three
/// vertices each, m, in the medium's frame). Parallel (rayon); memory:
/// 72 bytes per triangle per worker.
pub fn trace_transfer(
    medium: &impl Medium,
    scattering: &Scattering,
    triangles: &[[DVec3; 3]],
    settings: &TransferSettings,
) -> SurfaceTransfer {
    let (lo, hi) = medium.bounds_m();
    let radius_m = settings.kernel_radius_m.max(1e-3);
    let samples_m: Vec<DVec3> = triangles
        .iter()
        .map(|[a, b, c]| (*a + *b + *c) / 3.0)
        .collect();
    let area_m2: Vec<f64> = triangles
        .iter()
        .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
        .collect();
    let normals: Vec<DVec3> = triangles
        .iter()
        .map(|[a, b, c]| (*b - *a).cross(*c - *a).normalize_or_zero())
        .collect();
    let grid = PointGrid::new(radius_m, samples_m.iter().copied());
    let mut surface = SurfaceTransfer {
        deposits: Vec::new(),
        samples_m,
        area_m2,
        normals,
        kernel_radius_m: radius_m,
        grid,
        normalisation_m2: 0.0,
        photons: 0,
        scattering_events: 0,
        escaped_by_order: [0.0; 3],
        dropped: 0.0,
        unassigned: 0.0,
        disk_area_m2: 0.0,
    };
    let samples = surface.samples_m.len();
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length() * 1.001;
    let disk_area_m2 = PI * radius * radius;
    let batches = settings.photons.div_ceil(BATCH_PHOTONS).max(1);
    let workers = rayon::current_num_threads().max(1) as u64;
    let reader = &surface;
    let tally = (0..workers)
        .into_par_iter()
        .map(|worker| {
            let mut tally = Tally::new(samples);
            for batch in (worker..batches).step_by(workers as usize) {
                let mut rng = Rng::new(settings.seed, batch);
                for _ in 0..BATCH_PHOTONS {
                    let to_light = settings
                        .to_light
                        .map_or_else(|| uniform_direction(&mut rng), DVec3::normalize);
                    let (t, b) = tangents(to_light);
                    let r = radius * rng.uniform().sqrt();
                    let phi = std::f64::consts::TAU * rng.uniform();
                    let start = centre + to_light * radius + (t * phi.cos() + b * phi.sin()) * r;
                    let Some(escape) = random_walk(medium, scattering, start, -to_light, &mut rng)
                    else {
                        tally.dropped += 1;
                        continue;
                    };
                    tally.events += u64::from(escape.order);
                    tally.by_order[escape.order.min(2) as usize] += 1;
                    if escape.order < 2 {
                        continue;
                    }
                    let exit = exit_point(medium, escape.last_event_m, escape.direction);
                    let Some(nearest) = reader.nearest(exit) else {
                        tally.unassigned += 1;
                        continue;
                    };
                    let y = match settings.to_light {
                        None => sh::basis(to_light.to_array()),
                        Some(_) => [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                    };
                    let cell = &mut tally.deposits[nearest];
                    for k in 0..9 {
                        cell[k] += escape.weight * y[k];
                    }
                }
            }
            tally
        })
        .reduce(|| Tally::new(samples), Tally::merge);
    let photons = batches * BATCH_PHOTONS;
    let n = photons as f64;
    surface.deposits = tally.deposits;
    surface.normalisation_m2 = if settings.to_light.is_some() {
        disk_area_m2 / n
    } else {
        4.0 * PI * disk_area_m2 / n
    };
    surface.photons = photons;
    surface.scattering_events = tally.events;
    surface.escaped_by_order = tally.by_order.map(|c| c as f64 / n);
    surface.dropped = tally.dropped as f64 / n;
    surface.unassigned = tally.unassigned as f64 / n;
    surface.disk_area_m2 = disk_area_m2;
    surface
}

/// A real function of direction of order ≤ 2 written as
/// f(s) = c + b·s + sᵀ A s (A symmetric): the nine SH coefficients in a form
/// that turns with the cloud (b → R b, A → R A Rᵀ) and whose products
/// integrate in closed form over the sphere. The shader's twin is
/// `cumulus_transfer_*` in nimbus-render's `cumulus/shading.wgsl`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphericalQuadratic {
    /// c.
    pub constant: f64,
    /// b.
    pub linear: DVec3,
    /// A's A_xx, A_yy, A_zz, A_xy, A_yz, A_xz.
    pub quadratic: [f64; 6],
}

impl SphericalQuadratic {
    /// The function Σ_k c_k Y_k(s) ([`crate::sh::basis`]'s order and
    /// constants: 1, y, z, x, xy, yz, 3z² − 1, xz, x² − y²).
    pub fn from_sh(c: &[f64; 9]) -> Self {
        Self {
            constant: 0.282_095 * c[0] - 0.315_392 * c[6],
            linear: DVec3::new(0.488_603 * c[3], 0.488_603 * c[1], 0.488_603 * c[2]),
            quadratic: [
                0.546_274 * c[8],
                -0.546_274 * c[8],
                3.0 * 0.315_392 * c[6],
                0.5 * 1.092_548 * c[4],
                0.5 * 1.092_548 * c[5],
                0.5 * 1.092_548 * c[7],
            ],
        }
    }

    fn matrix(&self) -> [[f64; 3]; 3] {
        let [xx, yy, zz, xy, yz, xz] = self.quadratic;
        [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
    }

    /// f(s).
    pub fn value(&self, s: DVec3) -> f64 {
        let a = self.matrix();
        let v = s.to_array();
        let mut q = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                q += v[i] * a[i][j] * v[j];
            }
        }
        self.constant + self.linear.dot(s) + q
    }

    /// The function turned about +y by the yaw whose cosine and sine are
    /// given, as nimbus-render's `cumulus_rotate` turns a cloud:
    /// g(R s) = f(s), R v = (c x + s z, y, −s x + c z).
    pub fn yawed(&self, cos: f64, sin: f64) -> Self {
        let r = [[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]];
        let a = self.matrix();
        let mut ra = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    for l in 0..3 {
                        ra[i][j] += r[i][k] * a[k][l] * r[j][l];
                    }
                }
            }
        }
        let b = self.linear;
        Self {
            constant: self.constant,
            linear: DVec3::new(cos * b.x + sin * b.z, b.y, -sin * b.x + cos * b.z),
            quadratic: [ra[0][0], ra[1][1], ra[2][2], ra[0][1], ra[1][2], ra[0][2]],
        }
    }

    /// The nine SH coefficients of f ([`crate::sh::basis`]'s order): the
    /// inverse of [`Self::from_sh`], from the same moments as
    /// [`Self::product_integral`].
    pub fn to_sh(&self) -> [f64; 9] {
        let b = self.linear;
        let [xx, yy, zz, xy, yz, xz] = self.quadratic;
        let trace = xx + yy + zz;
        let (four_pi, third, fifteenth) = (4.0 * PI, 4.0 * PI / 3.0, 4.0 * PI / 15.0);
        [
            0.282_095 * (four_pi * self.constant + third * trace),
            0.488_603 * third * b.y,
            0.488_603 * third * b.z,
            0.488_603 * third * b.x,
            1.092_548 * 2.0 * fifteenth * xy,
            1.092_548 * 2.0 * fifteenth * yz,
            0.315_392 * fifteenth * (6.0 * zz - 2.0 * trace),
            1.092_548 * 2.0 * fifteenth * xz,
            0.546_274 * 2.0 * fifteenth * (xx - yy),
        ]
    }

    /// ∫ f g over the sphere, from the moments ∫ 1 = 4π, ∫ s_i s_j = 4π/3 δ_ij,
    /// ∫ s_i s_j s_k s_l = 4π/15 (δ_ij δ_kl + δ_ik δ_jl + δ_il δ_jk).
    pub fn product_integral(&self, other: &Self) -> f64 {
        let (a, b) = (self.matrix(), other.matrix());
        let trace = |m: &[[f64; 3]; 3]| m[0][0] + m[1][1] + m[2][2];
        let mut contraction = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                contraction += a[i][j] * b[i][j];
            }
        }
        4.0 * PI
            * (self.constant * other.constant
                + (self.constant * trace(&b) + other.constant * trace(&a)) / 3.0
                + self.linear.dot(other.linear) / 3.0
                + (trace(&a) * trace(&b) + 2.0 * contraction) / 15.0)
    }
}

/// S, single scattering of a homogeneous slab per unit ϖ P(Θ) E_sun
/// (radiance over irradiance times sr): the slab's optical depth along the
/// view is τ_v (the shader's chord τ), the sun at cos μ₀ from the outward
/// normal (negative: behind the face), the viewer at cos μ. Lit side
/// (Chandrasekhar 1960, §I.3; e.g. Liou 2002, eq. 6.3.7):
/// μ₀/(μ₀ + μ) (1 − e^{−τ_n (1/μ₀ + 1/μ)}), τ_n = τ_v μ; from behind:
/// μ₀′ (e^{−τ_n/μ₀′} − e^{−τ_n/μ})/(μ₀′ − μ), μ₀′ = −μ₀. Both tend to
/// 1 − e^{−τ_v} at the silhouette (μ → 0). Twin of WGSL
/// `cumulus_single_scattering`.
pub fn single_scattering_factor(mu0: f64, mu: f64, tau_view: f64) -> f64 {
    let mu = mu.max(1e-3);
    if mu0 > 1e-3 {
        return mu0 / (mu0 + mu) * (1.0 - (-tau_view * (1.0 + mu / mu0)).exp());
    }
    let back = (-mu0).max(1e-3);
    back * crate::transport::stratus::exp_difference_quotient(tau_view * mu, back, mu)
}

/// What the transport model's radiance at a surface point needs (world
/// frame, unit vectors, RGB radiances in W·sr⁻¹·m⁻²).
#[derive(Clone, Copy, Debug)]
pub struct TransportPoint {
    /// The smoothed normal N′ (single scattering's slab).
    pub normal: DVec3,
    /// The macroscopic surface's normal the multiply scattered light leaves
    /// about (the renderer's S_{l−1} normal).
    pub exit_normal: DVec3,
    /// Towards the observer.
    pub to_observer: DVec3,
    /// Towards the sun.
    pub to_sun: DVec3,
    /// τ of the chord behind the point along the view (shading's
    /// `optical_depth`), before δ-M.
    pub optical_depth: f64,
    /// δ-M's 1 − f.
    pub truncation: f64,
    /// The transfer, world frame.
    pub transfer: SphericalQuadratic,
    /// P_S(Θ) per channel at the point's scattering angle, sr⁻¹.
    pub phase: [f64; 3],
    /// C_s = E_sun/π.
    pub sun_radiance: [f64; 3],
    /// ∫ T L_env over the sphere (the environment's share of the exitance), W·m⁻².
    pub environment_exitance: [f64; 3],
    /// The sun's transmittance through the layer above (multiply scattered light).
    pub layer_shadow: [f64; 3],
    /// The direct beam's transmittance at the point and where the chord
    /// behind it enters.
    pub direct: [f64; 3],
    /// The same where the chord enters.
    pub forward_direct: [f64; 3],
    /// The forward peak's light, E_f α_p P (π F per channel times the weight and shadow).
    pub forward_peak: [f64; 3],
}

/// I of the transport model: π C_s E P_S(Θ) S, plus u(μ)/π times
/// (π C_s T(l) E_layer + ∫ T L_env), plus the forward peak (see the module
/// notes). Twin of WGSL `cumulus_transport_radiance`.
pub fn transport_radiance(p: &TransportPoint) -> [f64; 3] {
    let mu = p.normal.dot(p.to_observer).clamp(0.0, 1.0);
    let mu0 = p.normal.dot(p.to_sun);
    let single = single_scattering_factor(mu0, mu, p.optical_depth.min(1e4) * p.truncation);
    let lit = if mu0 > 0.0 {
        p.direct
    } else {
        p.forward_direct
    };
    let escape = crate::transport::stratus::escape_function(
        p.exit_normal.dot(p.to_observer).clamp(0.0, 1.0),
    );
    let sun_transfer = p.transfer.value(p.to_sun).max(0.0);
    std::array::from_fn(|c| {
        let single_radiance = PI * p.sun_radiance[c] * lit[c] * p.phase[c] * single;
        let multiple = PI * p.sun_radiance[c] * p.layer_shadow[c] * sun_transfer
            + p.environment_exitance[c].max(0.0);
        single_radiance + escape / PI * multiple + p.forward_peak[c]
    })
}

#[cfg(test)]
mod tests;
