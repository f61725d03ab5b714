//! The thickness field of a stratiform cloud layer: where the layer is and
//! how thick, over many kilometres, animated by the wind.
//!
//! Bouthors et al. (2006, §6) drive their layer with a 512² height field of
//! cloud thickness (0–500 m) animated on the CPU with advected textures
//! (Neyret 2003). nimbus evaluates the field procedurally, on the GPU each
//! frame (`nimbus-render`'s `stratus/layer.wgsl` is the twin of
//! [`CloudLayerField::thickness_m`]) so that animation never waits for an
//! upload:
//!
//! - Shape: a fractal sum of 3-D gradient noise ([`crate::noise::fbm_3d`])
//!   over the horizontal position, thresholded so that the requested
//!   fraction of the sky is covered, with a rounded profile (steep edges,
//!   domed cells, as stratocumulus cells look from the side).
//! - Advection: the horizontal argument is x − W t for the wind W. For a
//!   uniform wind this is the exact solution of the advection equation
//!   ∂h/∂t + W·∇h = 0: the pattern is carried without stretching and never
//!   reset, which is the property advected textures are built for.
//! - Evolution: the noise's third coordinate is t / T_e, so cells also form,
//!   grow and dissolve while they drift (finer octaves faster, like smaller
//!   eddies), as in flow noise (Perlin & Neyret 2001); continuous in time,
//!   so no frame ever pops.
//!
//! Coverage: the fractal sum n is close to normal with standard deviation
//! σ₁ √(Σ a_k²) / Σ a_k (independent octaves of amplitude a_k, σ₁ the
//! standard deviation of one octave, measured); the cloud occupies n > n_c
//! with n_c = σ Φ⁻¹(1 − coverage). A test checks the covered fraction.

use crate::noise::{Fractal, fbm_3d};

/// Standard deviation of one octave of [`crate::noise::gradient_noise_3d`]
/// (measured over 4·10⁵ points: 0.2682).
pub const OCTAVE_STD_DEV: f64 = 0.2682;

/// Width of the ramp from the cloud's edge to its full thickness, in
/// standard deviations of the noise.
pub const EDGE_RAMP_STD_DEVS: f64 = 2.5;

/// Amplitude ratio between octaves.
const GAIN: f64 = 0.5;
/// Frequency ratio between octaves.
const LACUNARITY: f64 = 2.0;

/// The field's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudLayerField {
    /// Thickness of the thickest cells, m.
    pub max_thickness_m: f64,
    /// Fraction of the sky covered, in [0, 1].
    pub coverage: f64,
    /// Horizontal size of the largest cells (the first octave's wavelength), m.
    pub feature_size_m: f64,
    /// Octaves of detail (1–8).
    pub octaves: u32,
    /// Random seed.
    pub seed: u32,
    /// Horizontal wind velocity carrying the layer, (x east, z south), m/s.
    pub wind_velocity_m_s: [f64; 2],
    /// Time over which the largest cells change shape, s.
    pub evolution_time_s: f64,
}

/// The normal quantile Φ⁻¹(p) for p in (0, 1), by Acklam's rational
/// approximation (relative error below 1.2·10⁻⁹; P. J. Acklam, "An algorithm
/// for computing the inverse normal cumulative distribution function", 2003).
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

impl CloudLayerField {
    /// The fractal's parameters.
    pub fn fractal(&self) -> Fractal {
        Fractal {
            octaves: self.octaves.clamp(1, 8),
            lacunarity: LACUNARITY,
            gain: GAIN,
        }
    }

    /// Standard deviation of the normalised fractal sum.
    pub fn noise_std_dev(&self) -> f64 {
        let (mut sum, mut sum_sq, mut a) = (0.0, 0.0, 1.0);
        for _ in 0..self.fractal().octaves {
            sum += a;
            sum_sq += a * a;
            a *= GAIN;
        }
        OCTAVE_STD_DEV * sum_sq.sqrt() / sum
    }

    /// The noise value at the cloud's edge, n_c, and the ramp width to full
    /// thickness (both in noise units).
    pub fn threshold_and_ramp(&self) -> (f64, f64) {
        let sigma = self.noise_std_dev();
        let ramp = EDGE_RAMP_STD_DEVS * sigma;
        let coverage = self.coverage.clamp(0.0, 1.0);
        // Beyond ±6σ the quantile would be 0 or 1 to double precision; clear
        // and overcast skies are made exact instead.
        let threshold = if coverage <= 1e-9 {
            f64::INFINITY
        } else if coverage >= 1.0 - 1e-9 {
            f64::NEG_INFINITY
        } else {
            sigma * normal_quantile(1.0 - coverage)
        };
        (threshold, ramp)
    }

    /// The rounded thickness profile of a cell: 0 at its edge (d = 0), 1 at
    /// full thickness (d ≥ 1), rising steeply at the edge: 1 − (1 − d)².
    pub fn profile(d: f64) -> f64 {
        let d = d.clamp(0.0, 1.0);
        1.0 - (1.0 - d) * (1.0 - d)
    }

    /// Cloud thickness at world position (x, z), m, at time `time_s`, the
    /// layer carried by its constant wind.
    pub fn thickness_m(&self, x_m: f64, z_m: f64, time_s: f64) -> f64 {
        let drift = self.wind_velocity_m_s.map(|w| w * time_s);
        self.thickness_with_drift_m(x_m, z_m, drift, time_s)
    }

    /// Cloud thickness at world position (x, z), m, at time `time_s`, the
    /// layer moved by `drift_m` (x, z), m (the integral of a varying wind).
    pub fn thickness_with_drift_m(
        &self,
        x_m: f64,
        z_m: f64,
        drift_m: [f64; 2],
        time_s: f64,
    ) -> f64 {
        let (threshold, ramp) = self.threshold_and_ramp();
        if threshold == f64::NEG_INFINITY {
            return self.max_thickness_m;
        }
        if threshold == f64::INFINITY {
            return 0.0;
        }
        let scale = 1.0 / self.feature_size_m;
        let u = (x_m - drift_m[0]) * scale;
        let v = (z_m - drift_m[1]) * scale;
        let w = time_s / self.evolution_time_s;
        let n = fbm_3d(u, v, w, self.seed, self.fractal());
        self.max_thickness_m * Self::profile((n - threshold) / ramp)
    }
}

/// Steps of [`path_inside_layer_m`]'s march.
pub const VIEW_PATH_STEPS: u32 = 12;

/// Bisections that place the exit within the march's last step.
pub const VIEW_PATH_REFINEMENTS: u32 = 5;

/// Ratio between successive steps of [`path_inside_layer_m`]'s march.
pub const VIEW_PATH_STEP_GROWTH: f64 = 1.5;

/// Length, m, of the straight path from `start_m` (a point on the layer's
/// surface where the ray enters it) along the unit vector `direction` until
/// the ray first leaves the layer: the cloud's thickness along a view ray,
/// H_v.
///
/// Bouthors et al. (2006, §4) shade every point of the surface as a
/// horizontal slab, H_v = H/μ_v; their §8 notes that this ignores the
/// clouds' sides. Seen from the side or at grazing angles a cell is a
/// finite lens: a ray entering by its thin edge crosses its thick middle
/// (far more than H/μ_v with the edge's small H), and a ray skimming a dome
/// leaves it again after a short chord (far less than H/μ_v as μ_v → 0).
/// Marching the ray through the set |y − y_mid| < h(x, z)/2 gives the
/// right length in both cases and H/μ_v where the slab holds.
///
/// `thickness_m(x, z)` is the layer's thickness, `offset_m` is added to it
/// along the whole path (the renderer marches its coarse thickness window
/// and carries the fine octaves' difference at the entry point). The march
/// takes [`VIEW_PATH_STEPS`] steps growing by [`VIEW_PATH_STEP_GROWTH`] over
/// `max_length_m` (fine near the entry, where the length matters; coarse
/// far along, where the cloud is opaque anyway) and places the exit by
/// [`VIEW_PATH_REFINEMENTS`] bisections and a linear interpolation of the
/// signed distance to the surface, h/2 − |y − y_mid| (exact inside a
/// uniform slab, where it is linear). Returns
/// `max_length_m` if the ray is still inside at its end. The GPU twin is
/// `stratus_view_path_m` in `nimbus-render`'s `stratus/lookup.wgsl`.
pub fn path_inside_layer_m(
    thickness_m: impl Fn(f64, f64) -> f64,
    offset_m: f64,
    mid_plane_m: f64,
    start_m: [f64; 3],
    direction: [f64; 3],
    max_length_m: f64,
) -> f64 {
    let inside = signed_distance_along(&thickness_m, offset_m, mid_plane_m, start_m, direction);
    // The start is on the surface: inside by definition, whatever the
    // sampled field says there.
    let mut last = (0.0, inside(0.0).max(0.0));
    for s in step_ends(max_length_m, VIEW_PATH_STEPS, VIEW_PATH_STEP_GROWTH) {
        let next = (s, inside(s));
        if next.1 <= 0.0 {
            // The exit lies in this step.
            return place_crossing(&inside, last, next, true, VIEW_PATH_REFINEMENTS);
        }
        last = next;
    }
    max_length_m
}

/// Most steps of [`cloud_along_ray_m`]'s march.
pub const SUN_PATH_STEPS: u32 = 24;

/// Mean step length, m, that [`cloud_along_ray_m`] aims at: a path short
/// enough (a high sun's) takes fewer than [`SUN_PATH_STEPS`] steps, at least
/// two. Fine detail of 80 m (a 2.5 km feature's sixth octave) is resolved.
pub const SUN_PATH_MEAN_STEP_M: f64 = 60.0;

/// Ratio between successive steps of [`cloud_along_ray_m`]'s march.
pub const SUN_PATH_STEP_GROWTH: f64 = 1.1;

/// Total length, m, of cloud that the straight path from `start_m` along
/// the unit vector `direction` crosses within `max_length_m`, every cell on
/// the way counted: how much of the layer the sunlight reaching a point of
/// its lit face has come through.
///
/// Bouthors et al. (2006, §4) light every point of the surface as the top
/// of its own horizontal slab, so a cell's top is lit the same whether or
/// not a thicker cell stands between it and the sun. Under a low sun that
/// is the dominant structure of a real layer's top: cells 200 m higher than
/// their neighbours cast shadows 2 km long under a sun 5° high (and a top
/// seen from above lit wherever its fine normal faces the sun, dark only on
/// the thin line where it turns away, draws the "contour lines" of issue
/// 25). The renderer attenuates the direct sun by the layer's directional
/// transmittance T_C of this length, and the light of the higher orders by
/// its diffuse transmittance.
///
/// `thickness_m(x, z)` and `offset_m` are as in [`path_inside_layer_m`].
/// The march takes `max_length_m / `[`SUN_PATH_MEAN_STEP_M`] steps, from 2 to
/// [`SUN_PATH_STEPS`], growing by [`SUN_PATH_STEP_GROWTH`], and counts each step's part inside the layer
/// from the signed distance h/2 − |y − y_mid| at its two ends, linear
/// between them (exact for a uniform slab; a cell thinner than a step
/// between two samples outside it is missed). The GPU twin is
/// `stratus_cloud_along_ray_m` in `nimbus-render`'s
/// `shader/cloud_layer_lookup.wgsl`.
pub fn cloud_along_ray_m(
    thickness_m: impl Fn(f64, f64) -> f64,
    offset_m: f64,
    mid_plane_m: f64,
    start_m: [f64; 3],
    direction: [f64; 3],
    max_length_m: f64,
) -> f64 {
    let inside = signed_distance_along(&thickness_m, offset_m, mid_plane_m, start_m, direction);
    let steps = step_count(max_length_m, SUN_PATH_MEAN_STEP_M, 2, SUN_PATH_STEPS);
    let (mut s, mut g) = (0.0, inside(0.0));
    let mut length_m = 0.0;
    for next_s in step_ends(max_length_m, steps, SUN_PATH_STEP_GROWTH) {
        let next_g = inside(next_s);
        length_m += (next_s - s) * inside_fraction(g, next_g);
        (s, g) = (next_s, next_g);
    }
    length_m
}

/// Most steps of [`first_entry_m`]'s march.
pub const ENTRY_STEPS: u32 = 128;

/// Mean step length, m, that [`first_entry_m`] aims at: a ray that leaves
/// the layer's height range soon (steep, or from near its top or base)
/// takes fewer than [`ENTRY_STEPS`] steps, at least four.
pub const ENTRY_MEAN_STEP_M: f64 = 150.0;

/// Ratio between successive steps of [`first_entry_m`]'s march.
pub const ENTRY_STEP_GROWTH: f64 = 1.03;

/// Bisections that place the entry within the march's step.
pub const ENTRY_REFINEMENTS: u32 = 6;

/// Distance, m, along the unit vector `direction` from `start_m` (a camera)
/// to where the ray first enters the layer (each thickness plus `offset_m`)
/// within `max_length_m`; 0 if `start_m` is inside it, `None` if the ray
/// stays outside.
///
/// Seen from within the layer's height range, the cells' tops and bases
/// are both seen edge-on and a ray at eye level runs between them: drawn as
/// surfaces, the layer shows a band of clear sky through its middle where a
/// real layer (and the path-traced one of `stratus-side`) is a continuous
/// body. The renderer finds the surface each pixel's ray enters by this
/// march instead. Steps: `max_length_m / `[`ENTRY_MEAN_STEP_M`], from 4 to
/// [`ENTRY_STEPS`], growing by [`ENTRY_STEP_GROWTH`]
/// (fine near the camera, where cells are large on screen); the entry
/// bracketed is placed by [`ENTRY_REFINEMENTS`] bisections and a linear
/// interpolation of the signed distance. A cell thinner than a step
/// between two samples outside it is missed. The GPU twin is
/// `stratus_view_entry_m` in `nimbus-render`'s `shader/cloud_layer_lookup.wgsl`.
pub fn first_entry_m(
    thickness_m: impl Fn(f64, f64) -> f64,
    offset_m: f64,
    mid_plane_m: f64,
    start_m: [f64; 3],
    direction: [f64; 3],
    max_length_m: f64,
) -> Option<f64> {
    let inside = signed_distance_along(&thickness_m, offset_m, mid_plane_m, start_m, direction);
    let mut last = (0.0, inside(0.0));
    if last.1 > 0.0 {
        return Some(0.0);
    }
    let steps = step_count(max_length_m, ENTRY_MEAN_STEP_M, 4, ENTRY_STEPS);
    for s in step_ends(max_length_m, steps, ENTRY_STEP_GROWTH) {
        let next = (s, inside(s));
        if next.1 > 0.0 {
            return Some(place_crossing(
                &inside,
                last,
                next,
                false,
                ENTRY_REFINEMENTS,
            ));
        }
        last = next;
    }
    None
}

/// The outward unit normal of the layer's surface over (or under) the point
/// `position_m` near it: the top y = `mid_plane_m` + h/2 above the
/// mid-plane, the base y = `mid_plane_m` − h/2 below it, h's slope by
/// central differences over ±`half_step_m`: (−½∂h/∂x, ±1, −½∂h/∂z)
/// normalised (both faces are y_mid ± h/2). Where the in-layer march finds
/// the face a low sun enters a cell's side by. The GPU twin is
/// `stratus_surface_normal` in `nimbus-render`'s
/// `shader/cloud_layer_lookup.wgsl` (over one texel of its window).
pub fn surface_normal(
    thickness_m: impl Fn(f64, f64) -> f64,
    mid_plane_m: f64,
    position_m: [f64; 3],
    half_step_m: f64,
) -> [f64; 3] {
    let [x, y, z] = position_m;
    let slope_x =
        (thickness_m(x + half_step_m, z) - thickness_m(x - half_step_m, z)) / (2.0 * half_step_m);
    let slope_z =
        (thickness_m(x, z + half_step_m) - thickness_m(x, z - half_step_m)) / (2.0 * half_step_m);
    let up = if y >= mid_plane_m { 1.0 } else { -1.0 };
    let n = [-0.5 * slope_x, up, -0.5 * slope_z];
    let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|c| c / length)
}

/// The far ends of the steps of a march over `max_length_m`: `steps` steps,
/// each `growth` times the one before (fine near the start, coarse far
/// along), the last ending at `max_length_m`.
fn step_ends(max_length_m: f64, steps: u32, growth: f64) -> impl Iterator<Item = f64> {
    let first = max_length_m * (growth - 1.0) / (growth.powi(steps as i32) - 1.0);
    (0..steps).scan((0.0, first), move |(s, step), _| {
        *s = (*s + *step).min(max_length_m);
        *step *= growth;
        Some(*s)
    })
}

/// Steps of a march over `max_length_m` whose mean step aims at
/// `mean_step_m`, from `fewest` to `most`.
fn step_count(max_length_m: f64, mean_step_m: f64, fewest: u32, most: u32) -> u32 {
    (max_length_m / mean_step_m)
        .ceil()
        .clamp(f64::from(fewest), f64::from(most)) as u32
}

/// The signed distance inside the layer, h/2 − |y − y_mid| with `offset_m`
/// added to the thickness, at distance s along the ray from `start_m`:
/// positive inside, exact (linear) inside a uniform slab.
fn signed_distance_along<'a>(
    thickness_m: &'a impl Fn(f64, f64) -> f64,
    offset_m: f64,
    mid_plane_m: f64,
    start_m: [f64; 3],
    direction: [f64; 3],
) -> impl Fn(f64) -> f64 + 'a {
    move |s| {
        let x = start_m[0] + direction[0] * s;
        let y = start_m[1] + direction[1] * s;
        let z = start_m[2] + direction[2] * s;
        0.5 * (thickness_m(x, z) + offset_m) - (y - mid_plane_m).abs()
    }
}

/// Where the signed distance `inside` crosses 0 between `a` and `b` (each
/// a distance and its signed distance), `a` inside when `a_inside`: the
/// bracket bisected `refinements` times (robust where h = 0 makes the
/// distance vanish over a whole stretch of the mid-plane), then the
/// crossing interpolated linearly (at `a` when both ends are 0: the ray
/// runs along the surface).
fn place_crossing(
    inside: impl Fn(f64) -> f64,
    (mut a, mut ga): (f64, f64),
    (mut b, mut gb): (f64, f64),
    a_inside: bool,
    refinements: u32,
) -> f64 {
    for _ in 0..refinements {
        let c = 0.5 * (a + b);
        let gc = inside(c);
        if (gc > 0.0) == a_inside {
            (a, ga) = (c, gc);
        } else {
            (b, gb) = (c, gc);
        }
    }
    let fraction = if ga != gb { ga / (ga - gb) } else { 0.0 };
    a + (b - a) * fraction
}

/// The part of a step inside the layer, from the signed distances `g0`,
/// `g1` at its ends (positive inside), the distance taken linear between
/// them.
fn inside_fraction(g0: f64, g1: f64) -> f64 {
    match (g0 > 0.0, g1 > 0.0) {
        (true, true) => 1.0,
        (false, false) => 0.0,
        _ => g0.max(g1) / (g1 - g0).abs(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(coverage: f64, octaves: u32) -> CloudLayerField {
        CloudLayerField {
            max_thickness_m: 300.0,
            coverage,
            feature_size_m: 2000.0,
            octaves,
            seed: 9,
            wind_velocity_m_s: [8.0, -3.0],
            evolution_time_s: 900.0,
        }
    }

    #[test]
    fn cloud_along_ray_is_exact_in_a_uniform_slab_and_sums_every_cell() {
        // A uniform slab 200 m thick about y = 0: from its top, down at
        // μ = 0.4, the ray is inside for 200/0.4 m; from its top towards a
        // sun above, never.
        let slab = |_: f64, _: f64| 200.0;
        let mu: f64 = 0.4;
        let down = [(1.0 - mu * mu).sqrt(), -mu, 0.0];
        let through = cloud_along_ray_m(slab, 0.0, 0.0, [0.0, 100.0, 0.0], down, 2000.0);
        assert!((through - 500.0).abs() < 1e-9, "{through}");
        let up = [(1.0 - mu * mu).sqrt(), mu, 0.0];
        assert_eq!(
            cloud_along_ray_m(slab, 0.0, 0.0, [0.0, 100.0, 0.0], up, 2000.0),
            0.0
        );

        // Two cells of 300 m, cones whose thickness falls linearly to 0
        // 400 m from their axes at x = 800 m and x = 2000 m: a horizontal
        // ray 50 m above the mid-plane from x = 0 is inside both where
        // h > 100 m, 533 m of each, 1067 m in all; the first-exit march of
        // `path_inside_layer_m` would stop at the first.
        let cells = |x: f64, _: f64| {
            [800.0, 2000.0]
                .iter()
                .map(|c: &f64| 300.0 * (1.0 - (x - c).abs() / 400.0).max(0.0))
                .fold(0.0, f64::max)
        };
        let along = cloud_along_ray_m(cells, 0.0, 0.0, [0.0, 50.0, 0.0], [1.0, 0.0, 0.0], 2500.0);
        // The steps grow from 25 m to 250 m: each cell's edges are placed
        // by linear interpolation within a step, the apex's kink is not.
        assert!((along - 3200.0 / 3.0).abs() < 30.0, "{along}");
        assert!(along > 600.0, "both cells counted: {along}");
    }

    #[test]
    fn first_entry_finds_the_nearest_cell_and_nothing_in_clear_air() {
        // The cones of the test above, a ray at 50 m above the mid-plane
        // from x = 0: the first cone's h = 100 m contour is at x = 800 − 266.7.
        let cells = |x: f64, _: f64| {
            [800.0, 2000.0]
                .iter()
                .map(|c: &f64| 300.0 * (1.0 - (x - c).abs() / 400.0).max(0.0))
                .fold(0.0, f64::max)
        };
        let entry = first_entry_m(cells, 0.0, 0.0, [0.0, 50.0, 0.0], [1.0, 0.0, 0.0], 20_000.0)
            .expect("the ray enters the first cone");
        assert!((entry - (800.0 - 800.0 / 3.0)).abs() < 2.0, "{entry}");
        // The cone's top slopes 0.75 m/m: its face at x = 700 leans 20.6°
        // towards −x (normal ∝ (−0.375, 1, 0)); the base mirrors it.
        let top = surface_normal(cells, 0.0, [700.0, 10.0, 0.0], 5.0);
        let lean = 0.375 / (1.0f64 + 0.375 * 0.375).sqrt();
        assert!(
            (top[0] + lean).abs() < 1e-9 && top[1] > 0.9 && top[2] == 0.0,
            "{top:?}"
        );
        let base = surface_normal(cells, 0.0, [700.0, -10.0, 0.0], 5.0);
        assert!((base[0] + lean).abs() < 1e-9 && base[1] < -0.9, "{base:?}");
        // 40 m added to every thickness: h > 60 m from x = 800 − 320.
        let thicker = first_entry_m(
            cells,
            40.0,
            0.0,
            [0.0, 50.0, 0.0],
            [1.0, 0.0, 0.0],
            20_000.0,
        )
        .expect("the ray enters the first cone");
        assert!((thicker - 480.0).abs() < 2.0, "{thicker}");
        // From inside a cell: 0. Above every cell: never.
        assert_eq!(
            first_entry_m(cells, 0.0, 0.0, [800.0, 0.0, 0.0], [1.0, 0.0, 0.0], 5000.0),
            Some(0.0)
        );
        assert_eq!(
            first_entry_m(
                cells,
                0.0,
                0.0,
                [0.0, 200.0, 0.0],
                [1.0, 0.0, 0.0],
                20_000.0
            ),
            None
        );
    }

    #[test]
    fn normal_quantile_matches_tabulated_values() {
        // Abramowitz & Stegun, table 26.5.
        for (p, z) in [
            (0.5, 0.0),
            (0.841_344_746, 1.0),
            (0.975, 1.959_963_985),
            (0.001, -3.090_232_306),
            (1e-6, -4.753_424_309),
        ] {
            assert!((normal_quantile(p) - z).abs() < 1e-7, "{p}");
        }
    }

    /// The covered fraction of a large area is the requested coverage.
    #[test]
    fn covered_fraction_matches_the_coverage() {
        for octaves in [1, 4, 6] {
            for coverage in [0.2, 0.5, 0.8] {
                let f = field(coverage, octaves);
                let n = 200;
                let covered = (0..n * n)
                    .filter(|k| {
                        let (i, j) = ((k % n) as f64, (k / n) as f64);
                        f.thickness_m(i * 613.0, j * 587.0, 0.0) > 0.0
                    })
                    .count() as f64
                    / (n * n) as f64;
                assert!(
                    (covered - coverage).abs() < 0.05,
                    "octaves {octaves}: coverage {coverage} gives {covered}"
                );
            }
        }
        assert_eq!(field(0.0, 5).thickness_m(10.0, 20.0, 3.0), 0.0);
        assert_eq!(field(1.0, 5).thickness_m(10.0, 20.0, 3.0), 300.0);
    }

    /// Without evolution the pattern is exactly carried by the wind:
    /// h(x + W dt, t + dt) = h(x, t); with it, the carried pattern changes
    /// far less than the pattern at a fixed point.
    #[test]
    fn the_wind_carries_the_pattern_without_reset() {
        let frozen = CloudLayerField {
            evolution_time_s: 1e15,
            ..field(0.6, 5)
        };
        let f = field(0.6, 5);
        let dt = 10.0;
        let (mut frozen_carried, mut carried, mut fixed) = (0.0f64, 0.0, 0.0);
        for k in 0..2000 {
            let (x, z) = ((k % 50) as f64 * 97.0, (k / 50) as f64 * 101.0);
            let (xw, zw) = (
                x + f.wind_velocity_m_s[0] * dt,
                z + f.wind_velocity_m_s[1] * dt,
            );
            let now = f.thickness_m(x, z, 100.0);
            frozen_carried = frozen_carried.max(
                (frozen.thickness_m(xw, zw, 100.0 + dt) - frozen.thickness_m(x, z, 100.0)).abs(),
            );
            carried += (f.thickness_m(xw, zw, 100.0 + dt) - now).abs();
            fixed += (f.thickness_m(x, z, 100.0 + dt) - now).abs();
        }
        assert!(frozen_carried < 1e-6, "{frozen_carried} m");
        assert!(carried < 0.3 * fixed, "carried {carried}, fixed {fixed}");
        // Continuous in time: a frame's step changes nothing abruptly.
        let step = (f.thickness_m(1234.0, 567.0, 50.0) - f.thickness_m(1234.0, 567.0, 50.04)).abs();
        assert!(step < 0.5, "{step} m in 40 ms");
    }

    /// A uniform slab: the march gives H/μ_v, the paper's slab path, from
    /// either face and at any angle steeper than its range.
    #[test]
    fn path_through_a_uniform_slab_is_thickness_over_cosine() {
        let h = 300.0;
        let mid = 1500.0;
        for mu in [1.0, 0.7, 0.3, 0.1] {
            let sin = (1.0f64 - mu * mu).sqrt();
            // From the top face downwards, and from the base upwards.
            let down = path_inside_layer_m(
                |_, _| h,
                0.0,
                mid,
                [0.0, mid + 0.5 * h, 0.0],
                [sin, -mu, 0.0],
                2.0 * h / mu,
            );
            let up = path_inside_layer_m(
                |_, _| h,
                0.0,
                mid,
                [0.0, mid - 0.5 * h, 0.0],
                [0.0, mu, sin],
                2.0 * h / mu,
            );
            for path in [down, up] {
                assert!(
                    (path - h / mu).abs() < 1e-9 * h / mu,
                    "μ = {mu}: {path} vs {}",
                    h / mu
                );
            }
        }
    }

    /// A paraboloid lens h = H₀ (1 − r²/R²): a horizontal ray in its
    /// mid-plane entering at its edge crosses the whole diameter 2R (where
    /// the slab model, with the edge's H → 0, would see nothing), and a ray
    /// entering the top at distance a from the axis and leaving horizontally
    /// through the dome crosses the chord 2√(R² − a²)·… computed exactly.
    #[test]
    fn path_through_a_lens_follows_its_shape() {
        let (h0, radius, mid) = (400.0, 1000.0, 1500.0);
        let lens = |x: f64, z: f64| (h0 * (1.0 - (x * x + z * z) / (radius * radius))).max(0.0);
        // Along the mid-plane through the centre: the diameter.
        let across =
            path_inside_layer_m(lens, 0.0, mid, [-radius, mid, 0.0], [1.0, 0.0, 0.0], 5000.0);
        assert!((across - 2.0 * radius).abs() < 0.02 * radius, "{across}");
        // Off-centre at z = a in the mid-plane: the chord 2√(R² − a²).
        let a = 600.0;
        let chord = 2.0 * (radius * radius - a * a).sqrt();
        let start_x = -(radius * radius - a * a).sqrt();
        let off = path_inside_layer_m(lens, 0.0, mid, [start_x, mid, a], [1.0, 0.0, 0.0], 5000.0);
        assert!((off - chord).abs() < 0.02 * chord, "{off} vs {chord}");
        // Horizontally at height y above the mid-plane: inside while
        // h/2 > y, i.e. r² < R²(1 − 2y/H₀), a shorter chord.
        let y = 100.0;
        let r_y = radius * (1.0 - 2.0 * y / h0).sqrt();
        let high = path_inside_layer_m(
            lens,
            0.0,
            mid,
            [-r_y, mid + y, 0.0],
            [1.0, 0.0, 0.0],
            5000.0,
        );
        assert!(
            (high - 2.0 * r_y).abs() < 0.02 * r_y,
            "{high} vs {}",
            2.0 * r_y
        );
        // The slab model at the entry point would give H/μ_v = 0/0 there;
        // a ray that never meets cloud beyond its start has length 0.
        let miss = path_inside_layer_m(lens, 0.0, mid, [radius, mid, 0.0], [1.0, 0.0, 0.0], 5000.0);
        assert!(miss < 1.0, "{miss}");
    }

    /// The offset thickens the cloud along the whole path, and a ray still
    /// inside at the end of its range returns the range.
    #[test]
    fn path_offset_and_range() {
        let mid = 1000.0;
        let thin = path_inside_layer_m(
            |_, _| 100.0,
            100.0,
            mid,
            [0.0, mid + 100.0, 0.0],
            [0.0, -1.0, 0.0],
            1000.0,
        );
        assert!((thin - 200.0).abs() < 1e-9, "{thin}");
        let long = path_inside_layer_m(
            |_, _| 100.0,
            0.0,
            mid,
            [0.0, mid, 0.0],
            [1.0, 0.0, 0.0],
            3000.0,
        );
        assert_eq!(long, 3000.0);
    }
}
