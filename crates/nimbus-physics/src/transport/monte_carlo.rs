//! Monte-Carlo photon tracing through a homogeneous plane-parallel slab lit
//! by a collimated beam: the reference the analytic stratiform model is
//! validated and fitted against (Bouthors, Neyret & Lefebvre 2006, §4 and
//! Figs 6, 8, 9).
//!
//! The slab is traced in optical depth (unit extinction), depth z from 0 at
//! the top to τ at the bottom, with black boundaries. Photons enter at the
//! top along the sun's beam; free paths are drawn exactly, −ln u; at each
//! event the weight is multiplied by the single-scattering albedo ϖ and a new
//! direction is drawn from the phase function. Tallies, per scattering order
//! (0, 1, 2, 3+) and in total:
//!
//! - reflectance and transmittance: the fraction of the flux incident on the
//!   top that leaves through each side, and the direct transmittance
//!   (order 0 through the bottom);
//! - the radiance in one view direction, per unit incident flux on the top,
//!   by the local (next-event) estimate: every event adds
//!   w ϖ p(cos Θ_V) e^{−τ_exit} / |μ_v|, with τ_exit the optical path from the
//!   event to the boundary along the view direction (e.g. Marchuk et al.,
//!   "The Monte Carlo Methods in Atmospheric Optics", 1980, §2.4);
//! - the radiance binned in exit angle (from the normal on the exit side,
//!   uniform bins in θ) and relative azimuth (0° to 180°, folded by the
//!   symmetry of the sun's plane): the weight leaving through a bin divided by
//!   ∫ |μ| dΩ over the bin;
//! - optionally, the radiance inside the slab on one plane of depth,
//!   binned in the cosine of the light's travel to the downward normal
//!   (uniform bins over −1 to 1, all azimuths): the weight crossing the
//!   plane in a bin over |μ| (a crossing's contribution to the fluence),
//!   divided by the bin's solid angle; the unscattered beam is left out.
//!
//! Standard errors treat photons as independent samples. Photons run in
//! batches of [`BATCH_PHOTONS`], each with its own random stream keyed by
//! (seed, batch), and batches are summed in order, so the result depends on
//! the seed alone, not on the number of threads.
//!
//! Angle conventions (shared with the analytic model): the view direction
//! points from the slab to the viewer; its zenith angle is below 90° above
//! the slab (reflection) and above 90° below it (transmission); its relative
//! azimuth is measured from the sun's azimuth, so 0° with the sun behind the
//! viewer (the glory lies at θ_v = θ_sun, φ = 0°) and 180° opposite.

use super::phase_model::PhaseModel;
use super::rng::Rng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Photons per random stream and work unit.
pub const BATCH_PHOTONS: u64 = 4096;

/// Number of order classes: 0, 1, 2, 3+.
pub const ORDER_CLASSES: usize = 4;

/// A homogeneous slab.
#[derive(Clone, Debug)]
pub struct SlabMedium {
    /// Optical depth τ = κ H.
    pub optical_depth: f64,
    /// Single-scattering albedo ϖ in [0, 1].
    pub single_scattering_albedo: f64,
    /// The phase function.
    pub phase: PhaseModel,
}

/// A direction from the slab towards a viewer (see the module notes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewDirection {
    /// Zenith angle, degrees in [0, 180]: < 90 above the slab, > 90 below.
    pub zenith_deg: f64,
    /// Azimuth relative to the sun's, degrees.
    pub relative_azimuth_deg: f64,
}

impl ViewDirection {
    /// The unit vector in the tracer's frame (z down, the sun in the x–z
    /// plane on the −x side).
    pub fn vector(&self) -> [f64; 3] {
        let (st, ct) = self.zenith_deg.to_radians().sin_cos();
        let (sp, cp) = self.relative_azimuth_deg.to_radians().sin_cos();
        [-st * cp, st * sp, -ct]
    }

    /// Whether the viewer is above the slab (reflected light).
    pub fn is_reflection(&self) -> bool {
        self.zenith_deg < 90.0
    }

    /// |cos| of the angle between the view direction and the slab's normal.
    pub fn mu(&self) -> f64 {
        self.zenith_deg.to_radians().cos().abs()
    }
}

/// Cosine of the scattering angle from the sun's beam into the view
/// direction: cos Θ = −L·V with L towards the sun.
pub fn scattering_cosine(sun_zenith_deg: f64, view: ViewDirection) -> f64 {
    let incident = incident_direction(sun_zenith_deg);
    let v = view.vector();
    incident[0] * v[0] + incident[1] * v[1] + incident[2] * v[2]
}

/// The direction of the sun's beam in the tracer's frame (z down, the sun
/// on the −x side).
fn incident_direction(sun_zenith_deg: f64) -> [f64; 3] {
    let (st, ct) = sun_zenith_deg.to_radians().sin_cos();
    [st, 0.0, ct]
}

/// What to trace.
#[derive(Clone, Debug)]
pub struct TraceSettings {
    /// Number of photons (rounded up to whole batches).
    pub photons: u64,
    /// Seed of the random streams.
    pub seed: u64,
    /// Sun zenith angle, degrees in [0, 90).
    pub sun_zenith_deg: f64,
    /// Directions for local estimates of the radiance.
    pub views: Vec<ViewDirection>,
    /// Bins of exit angle from the normal, uniform in θ over 0–90°.
    pub zenith_bins: usize,
    /// Bins of relative azimuth over 0–180°.
    pub azimuth_bins: usize,
    /// An optical depth inside the slab (0 < z < τ) at which to tally the
    /// radiance crossing it ([`TraceResult::interior`]); `None`: no tally.
    pub interior_depth: Option<f64>,
    /// Bins of the cosine of the light's travel to the downward normal,
    /// uniform over −1 to 1, of the interior tally.
    pub interior_cosine_bins: usize,
}

impl Default for TraceSettings {
    fn default() -> Self {
        Self {
            photons: 1_000_000,
            seed: 1,
            sun_zenith_deg: 0.0,
            views: Vec::new(),
            zenith_bins: 18,
            azimuth_bins: 18,
            interior_depth: None,
            interior_cosine_bins: 20,
        }
    }
}

/// A Monte-Carlo estimate and its standard error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// The mean.
    pub value: f64,
    /// Its standard error.
    pub std_error: f64,
}

/// Per-order results: orders 0, 1, 2, 3+ and the total.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ByOrder {
    /// Order 0 (no scattering).
    pub order0: Estimate,
    /// Single scattering.
    pub order1: Estimate,
    /// Double scattering.
    pub order2: Estimate,
    /// Three or more scattering events.
    pub order3plus: Estimate,
    /// All orders.
    pub total: Estimate,
}

/// Binned radiance of one side, per order class, indexed
/// `[order][zenith][azimuth]`, per unit incident flux on the top.
#[derive(Clone, Debug, PartialEq)]
pub struct BinnedRadiance {
    /// Bins of exit angle from the normal over 0–90°.
    pub zenith_bins: usize,
    /// Bins of relative azimuth over 0–180°.
    pub azimuth_bins: usize,
    /// Radiance per order class (0, 1, 2, 3+), flattened
    /// `zenith * azimuth_bins + azimuth`.
    pub radiance: [Vec<f64>; ORDER_CLASSES],
}

/// The result of a trace.
#[derive(Clone, Debug)]
pub struct TraceResult {
    /// Photons traced.
    pub photons: u64,
    /// Scattering events.
    pub scattering_events: u64,
    /// Fraction of the incident flux leaving through the top.
    pub reflectance: ByOrder,
    /// Fraction of the incident flux leaving through the bottom (order 0
    /// is the direct beam).
    pub transmittance: ByOrder,
    /// Local estimates of the radiance in each requested view direction, per
    /// unit incident flux on the top, sr⁻¹ (order 0 is zero: the direct beam
    /// is a delta, reported as the direct transmittance).
    pub radiance: Vec<ByOrder>,
    /// Binned reflected radiance.
    pub reflected: BinnedRadiance,
    /// Binned transmitted radiance.
    pub transmitted: BinnedRadiance,
    /// Radiance inside the slab at [`TraceSettings::interior_depth`], per
    /// unit incident flux on the top, sr⁻¹, averaged over azimuth, in bins
    /// of the cosine of the light's travel to the downward normal from −1
    /// (travelling up) to 1 (down); empty without that depth.
    pub interior: Vec<Estimate>,
}

/// Running sums of a batch.
#[derive(Clone)]
struct Sums {
    events: u64,
    /// [side][order]: Σ w and Σ w² (side 0 top, 1 bottom).
    flux: [[f64; ORDER_CLASSES]; 2],
    flux_sq: [[f64; ORDER_CLASSES]; 2],
    /// Per view: [order] Σ x, Σ x², and Σ (Σ_orders x)² for the total.
    local: Vec<[f64; ORDER_CLASSES]>,
    local_sq: Vec<[f64; ORDER_CLASSES]>,
    local_total_sq: Vec<f64>,
    /// [side][order][bin] Σ w.
    bins: [[Vec<f64>; ORDER_CLASSES]; 2],
    /// Per interior cosine bin: Σ x and Σ x² over photons.
    interior: Vec<f64>,
    interior_sq: Vec<f64>,
}

impl Sums {
    fn new(views: usize, bins: usize, interior_bins: usize) -> Self {
        Self {
            events: 0,
            flux: [[0.0; ORDER_CLASSES]; 2],
            flux_sq: [[0.0; ORDER_CLASSES]; 2],
            local: vec![[0.0; ORDER_CLASSES]; views],
            local_sq: vec![[0.0; ORDER_CLASSES]; views],
            local_total_sq: vec![0.0; views],
            bins: std::array::from_fn(|_| std::array::from_fn(|_| vec![0.0; bins])),
            interior: vec![0.0; interior_bins],
            interior_sq: vec![0.0; interior_bins],
        }
    }

    fn add(&mut self, other: &Self) {
        self.events += other.events;
        for side in 0..2 {
            for k in 0..ORDER_CLASSES {
                self.flux[side][k] += other.flux[side][k];
                self.flux_sq[side][k] += other.flux_sq[side][k];
                for (a, b) in self.bins[side][k].iter_mut().zip(&other.bins[side][k]) {
                    *a += b;
                }
            }
        }
        for v in 0..self.local.len() {
            for k in 0..ORDER_CLASSES {
                self.local[v][k] += other.local[v][k];
                self.local_sq[v][k] += other.local_sq[v][k];
            }
            self.local_total_sq[v] += other.local_total_sq[v];
        }
        for (a, b) in self.interior.iter_mut().zip(&other.interior) {
            *a += b;
        }
        for (a, b) in self.interior_sq.iter_mut().zip(&other.interior_sq) {
            *a += b;
        }
    }
}

/// Mean and standard error of n samples from Σx and Σx².
fn estimate(sum: f64, sum_sq: f64, n: f64) -> Estimate {
    let mean = sum / n;
    let variance = ((sum_sq / n - mean * mean) * n / (n - 1.0).max(1.0)).max(0.0);
    Estimate {
        value: mean,
        std_error: (variance / n).sqrt(),
    }
}

/// Traces photons through the slab; `progress` receives the number of
/// photons done so far after each batch.
pub fn trace(
    medium: &SlabMedium,
    settings: &TraceSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> TraceResult {
    let batches = settings.photons.div_ceil(BATCH_PHOTONS).max(1);
    let photons = batches * BATCH_PHOTONS;
    let views: Vec<[f64; 3]> = settings.views.iter().map(|v| v.vector()).collect();
    let incident = incident_direction(settings.sun_zenith_deg);
    let bin_count = settings.zenith_bins * settings.azimuth_bins;
    let interior_bins = if settings.interior_depth.is_some() {
        settings.interior_cosine_bins.max(1)
    } else {
        0
    };
    let done = AtomicU64::new(0);
    let batch_sums: Vec<Sums> = (0..batches)
        .into_par_iter()
        .map(|batch| {
            let mut rng = Rng::new(settings.seed, batch);
            let mut sums = Sums::new(views.len(), bin_count, interior_bins);
            let mut local = vec![[0.0; ORDER_CLASSES]; views.len()];
            let mut crossings = vec![0.0; interior_bins];
            for _ in 0..BATCH_PHOTONS {
                trace_photon(
                    medium,
                    settings,
                    incident,
                    &views,
                    &mut rng,
                    &mut sums,
                    &mut local,
                    &mut crossings,
                );
            }
            progress(done.fetch_add(BATCH_PHOTONS, Ordering::Relaxed) + BATCH_PHOTONS);
            sums
        })
        .collect();
    let mut total = Sums::new(views.len(), bin_count, interior_bins);
    for sums in &batch_sums {
        total.add(sums);
    }
    finish(&total, photons, settings)
}

/// One photon's walk.
#[inline]
#[allow(clippy::too_many_arguments)]
fn trace_photon(
    medium: &SlabMedium,
    settings: &TraceSettings,
    incident: [f64; 3],
    views: &[[f64; 3]],
    rng: &mut Rng,
    sums: &mut Sums,
    local: &mut [[f64; ORDER_CLASSES]],
    crossings: &mut [f64],
) {
    let tau = medium.optical_depth;
    let albedo = medium.single_scattering_albedo;
    let mut direction = incident;
    let mut z = 0.0;
    let mut weight = 1.0;
    let mut order = 0usize;
    for l in local.iter_mut() {
        *l = [0.0; ORDER_CLASSES];
    }
    crossings.fill(0.0);
    loop {
        let path = -rng.uniform_open0().ln();
        let z_next = z + path * direction[2];
        if let Some(plane) = settings.interior_depth {
            // A scattered photon's flight crossing the plane (the exit
            // flights cross it before they leave).
            if order > 0 && (z - plane) * (z_next - plane) < 0.0 {
                let mu = direction[2];
                let n = crossings.len();
                let bin = (((mu + 1.0) * 0.5 * n as f64) as usize).min(n - 1);
                crossings[bin] += weight / mu.abs().max(1e-6);
            }
        }
        if z_next <= 0.0 || z_next >= tau {
            let side = usize::from(z_next >= tau);
            let class = order.min(ORDER_CLASSES - 1);
            sums.flux[side][class] += weight;
            sums.flux_sq[side][class] += weight * weight;
            if !sums.bins[side][class].is_empty() {
                let bin = exit_bin(direction, settings.zenith_bins, settings.azimuth_bins);
                sums.bins[side][class][bin] += weight;
            }
            break;
        }
        z = z_next;
        sums.events += 1;
        let class = (order + 1).min(ORDER_CLASSES - 1);
        for (view, l) in views.iter().zip(local.iter_mut()) {
            let exit = if view[2] < 0.0 { z } else { tau - z };
            let mu = view[2].abs().max(1e-9);
            let cos_theta =
                direction[0] * view[0] + direction[1] * view[1] + direction[2] * view[2];
            l[class] += weight * albedo * medium.phase.value(cos_theta) * (-exit / mu).exp() / mu;
        }
        order += 1;
        let Some(survived) = roulette(weight * albedo, rng) else {
            break;
        };
        weight = survived;
        direction = scattered_direction(&medium.phase, direction, rng);
    }
    for (v, l) in local.iter().enumerate() {
        let mut photon_total = 0.0;
        for (k, x) in l.iter().enumerate() {
            sums.local[v][k] += x;
            sums.local_sq[v][k] += x * x;
            photon_total += x;
        }
        sums.local_total_sq[v] += photon_total * photon_total;
    }
    for ((sum, sum_sq), x) in sums
        .interior
        .iter_mut()
        .zip(sums.interior_sq.iter_mut())
        .zip(crossings.iter())
    {
        *sum += x;
        *sum_sq += x * x;
    }
}

/// Russian roulette once a photon's weight is small (absorbing media
/// only): below 10⁻³ it survives one time in ten with ten times the
/// weight. The weight to carry on with, or `None` when the photon ends.
pub(crate) fn roulette(weight: f64, rng: &mut Rng) -> Option<f64> {
    if weight >= 1e-3 {
        Some(weight)
    } else if rng.uniform() < 0.1 {
        Some(weight * 10.0)
    } else {
        None
    }
}

/// A direction drawn from `phase` about `direction` (the cosine from the
/// phase function, the azimuth uniform).
pub(crate) fn scattered_direction(
    phase: &PhaseModel,
    direction: [f64; 3],
    rng: &mut Rng,
) -> [f64; 3] {
    let cos_theta = phase.sample_cos(rng.uniform());
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * rng.uniform();
    crate::optics::sampling::rotate(direction, cos_theta, sin_theta, phi)
}

/// The bin of an exit direction: angle from the normal on the exit side and
/// azimuth relative to the sun's, folded to 0–180°.
fn exit_bin(direction: [f64; 3], zenith_bins: usize, azimuth_bins: usize) -> usize {
    let theta = direction[2].abs().min(1.0).acos();
    let zenith =
        ((theta / std::f64::consts::FRAC_PI_2 * zenith_bins as f64) as usize).min(zenith_bins - 1);
    // The sun's azimuth is along −x; the exit direction's azimuth from it.
    let phi = direction[1].abs().atan2(-direction[0]);
    let azimuth =
        ((phi / std::f64::consts::PI * azimuth_bins as f64) as usize).min(azimuth_bins - 1);
    zenith * azimuth_bins + azimuth
}

fn finish(total: &Sums, photons: u64, settings: &TraceSettings) -> TraceResult {
    let n = photons as f64;
    let by_order = |side: usize| {
        let e = |k: usize| estimate(total.flux[side][k], total.flux_sq[side][k], n);
        let sum: f64 = total.flux[side].iter().sum();
        // A photon leaves once, in one order: Σ x² over orders is the total's.
        let sum_sq: f64 = total.flux_sq[side].iter().sum();
        ByOrder {
            order0: e(0),
            order1: e(1),
            order2: e(2),
            order3plus: e(3),
            total: estimate(sum, sum_sq, n),
        }
    };
    let radiance = (0..settings.views.len())
        .map(|v| {
            let e = |k: usize| estimate(total.local[v][k], total.local_sq[v][k], n);
            ByOrder {
                order0: e(0),
                order1: e(1),
                order2: e(2),
                order3plus: e(3),
                total: estimate(total.local[v].iter().sum(), total.local_total_sq[v], n),
            }
        })
        .collect();
    let binned = |side: usize| {
        let (nz, na) = (settings.zenith_bins, settings.azimuth_bins);
        let radiance = std::array::from_fn(|k| {
            let bins = &total.bins[side][k];
            (0..bins.len())
                .map(|i| {
                    let zi = i / na.max(1);
                    let (t0, t1) = (
                        std::f64::consts::FRAC_PI_2 * zi as f64 / nz as f64,
                        std::f64::consts::FRAC_PI_2 * (zi + 1) as f64 / nz as f64,
                    );
                    // ∫ μ dΩ over the bin, both azimuth halves (the fold).
                    let projected = 0.5
                        * (t1.sin().powi(2) - t0.sin().powi(2))
                        * 2.0
                        * (std::f64::consts::PI / na as f64);
                    bins[i] / (n * projected)
                })
                .collect()
        });
        BinnedRadiance {
            zenith_bins: nz,
            azimuth_bins: na,
            radiance,
        }
    };
    // Each cosine bin spans 2/n in μ and every azimuth: 4π/n sr.
    let interior_solid_angle = 4.0 * std::f64::consts::PI / total.interior.len().max(1) as f64;
    let interior = total
        .interior
        .iter()
        .zip(&total.interior_sq)
        .map(|(sum, sum_sq)| {
            let e = estimate(*sum, *sum_sq, n);
            Estimate {
                value: e.value / interior_solid_angle,
                std_error: e.std_error / interior_solid_angle,
            }
        })
        .collect();
    TraceResult {
        photons,
        scattering_events: total.events,
        reflectance: by_order(0),
        transmittance: by_order(1),
        radiance,
        reflected: binned(0),
        transmitted: binned(1),
        interior,
    }
}

/// Number of threads [`trace`] runs on (rayon's pool; `RAYON_NUM_THREADS`
/// sets it).
pub fn worker_threads() -> usize {
    rayon::current_num_threads()
}
