//! The phenomenological cumulus shader of Bouthors (2004, ch. 5, final
//! formulas §5.10, eqs 5.31–5.43) after Neyret (2000), evaluated on the CPU:
//! the reference the GPU pass (`nimbus-render`'s `cumulus/cumulus.wgsl`) is
//! tested against, term by term.
//!
//! Per surface point P of the cloud's mesh, with O the unit direction
//! towards the observer and L towards the sun:
//!
//! - **Ambient** α_a C_c: C_c is the radiance of the environment (sky above,
//!   ground below, brighter horizon) seen by the smoothed normal, from the
//!   sky model's irradiance, E_env(N′)/π (Neyret §4.1).
//! - **Smoothed normal** N′ = normalize(Σ_j w_j N + (1 − w_j) N_{l−j}),
//!   w_j = saturate(α_w δ_j) (eq 5.34): near a furrow of S_{l−j} the normal
//!   leans towards that surface's, so blobs merge without visible creases.
//!   δ_j is the distance to S_{l−j} over the mean blob radius of level l−j
//!   (the paper's d_{l−j} in units of its level, so one α serves all scales).
//! - **Bump** N_b = normalize(N′ + α_b B) (eq 5.35), B the tangential part
//!   of the gradient of a solid noise height h ∈ [0, 1] whose octaves follow
//!   the hierarchy: lacunarity 1/ratio, the first octave a level below the
//!   mesh's (§6.2.1: no stretched texture, the shape's own lacunarity).
//! - **Lambert** L = saturate(N_b · L) (eq 5.41).
//! - **Light traps** F = F⁻ + F⁺ (eqs 5.37–5.39): F⁻ = Σ_j saturate(1 − α_d δ_j)
//!   saturate(N_{l−j} · L), F⁺ = saturate(α_h − h) saturate(N′ · L); or
//!   Neyret's (2000, §4.3) estimate I_mean arctan(k(1 − h_s))/arctan(k) with
//!   I_mean the Lambert law of the underlying surface and h_s the height of P
//!   on its blob along that surface's normal.
//! - **Density** (eqs 5.31–5.32): the amount of cloud crossed behind P along
//!   the view, on the blob through P taken as a sphere of radius R whose
//!   density rises linearly from 0 at its surface to 1 at depth r (the corona
//!   thickness). The paper approximates the integral by the chord length
//!   2R N·O times the deepest density; nimbus integrates the linear profile
//!   along the chord exactly ([`chord_density_integral_m`]), as ch. 6.2.2
//!   asks. The paper's chord ends at the back of the blob, though the cloud
//!   goes on behind it: a last-level blob of 45 m alone gives τ ≈ 5, a
//!   see-through body. nimbus adds the chords through the lower levels'
//!   surfaces, each taken as a sphere of its level's mean radius with the
//!   normal N_{l−j} (all vanish together at the cloud's silhouette). The
//!   optical depth is τ = α_ρ (1 − α_b h) q, and ρ = saturate(τ).
//! - **Forward scattering** T (eq 5.40 corrected): after Neyret (§4.2 and
//!   appendix A) the cumulated forward lobe is a Gaussian whose variance
//!   grows in proportion to the droplets crossed, approximated by a cosine
//!   power: cos θ^{α_g/ρ}, θ the angle between the sun's light (−L) and the
//!   view (O). Eq 5.40 as printed, cos(−O·L)·α_g/ρ², is the cosine of a dot
//!   product times a factor, not a power: it is read as the power it
//!   describes, with Neyret's variance ∝ ρ rather than Bouthors' σ = ρ.
//!   The amplitude is the appendix's shader: saturate(Trans (1 − ρ)² lobe),
//!   so the lobe fades into the core.
//! - **Opacity** A: eq 5.43 (A = ρ max(T, 1)) is the stop-gap the author
//!   wanted replaced. nimbus uses the transmittance of the chord:
//!   A = 1 − e^{−τ}. It falls off smoothly across the corona and does not
//!   need T's help to show the silver lining.
//! - **Shadow** E: the fraction of sunlight reaching P through the cores of
//!   the clouds between it and the sun. Only the core casts (the paper's
//!   ρ ≥ 1 rule, here τ ≥ 1 seen from the sun); instead of the paper's
//!   binary test the depth of core crossed, Δ, gives the two-stream
//!   diffuse transmittance of a conservative slab, 1 / (1 + ¾ (1 − g) α_ρ Δ)
//!   (e.g. Bohren & Clothiaux 2006, §6.1 and eq. 6.32; g = 0.85 for cloud
//!   droplets), filtered over the shadow map's texels (soft shadows). The
//!   forward-scattered light T is shadowed where it enters the corona, at
//!   the far end of the blob's chord behind P: on a back-lit rim that end
//!   faces the sun, though P itself lies behind the cloud from the sun.
//! - **Colour** I = α_a C_c + E C_s (α_f F + α_l L) + E_f C_s α_t T
//!   (eq 5.42; E_f the shadow where the forward light enters, below).
//!
//! Two terms extend the paper's model (the realism issue's requirement 2;
//! both off in [`CumulusShadingModel::Bouthors2004`]):
//!
//! - **Diffusion through the cores** D = 1, weighted α_δ and shadowed by E:
//!   the sunlight that enters a cloud is scattered hundreds of times
//!   (τ ≈ 75 across a 1 km core) and leaves it everywhere, its flux at depth
//!   Δ behind the sunlit face falling as the two-stream diffuse
//!   transmittance 1/(1 + ¾(1 − g) α_ρ Δ) (Bohren & Clothiaux 2006, §6.1),
//!   which is what E already is. So the faces turned from the sun and the
//!   bases glow with the light diffused through the cloud, instead of only
//!   the sky's (Bouthors 2004 leaves them to the ambient and light-trap
//!   terms, and a path-traced cloud is 1.5× brighter there).
//! - **Forward peak** P = π F(θ, τ), weighted α_p (physically 1) and
//!   shadowed by E_f: the droplets' diffraction peak, scattered several
//!   times within itself along the chord of optical depth τ behind the point
//!   and seen at θ from the sun, from the Mie phase function in the
//!   small-angle approximation ([`super::forward_peak`]). This is the silver
//!   lining: a rim of τ ≈ 1–5 seen 4° from the sun is brighter than the sun's
//!   direct reflection, which Neyret's saturated lobe T cannot make.
//!
//! With them I = α_a C_c + E C_s (α_f F + α_l L + α_δ D)
//! + E_f C_s (α_t T + α_p P).
//!
//! Units: lengths in metres; C_c and C_s are radiances (W·sr⁻¹·m⁻² per RGB
//! channel): the environment's and the sun's irradiance over π, so that
//! I = 1 is a white Lambertian surface facing the sun.

use super::forward_peak::ForwardPeakTable;
use glam::DVec3;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// How the light traps are estimated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LightTrapModel {
    /// Bouthors (2004) eqs 5.37–5.38: distances to every lower level's
    /// surface and the bump height.
    #[default]
    Furrows,
    /// Neyret (2000, §4.3): the mean illumination of the underlying surface
    /// times arctan(k(1 − h))/arctan(k).
    Arctan,
}

/// Which set of weights the shader starts from (`cumulus.shading.model`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CumulusShadingModel {
    /// The weights fitted by least squares to path-traced references of the
    /// realism suite (`tools/reference/fit_cumulus.py`, docs/REALISM.md):
    /// the paper's terms plus D and P, Lambert and the lobe T at 0.
    Fitted,
    /// Bouthors (2004) as published: the paper's weights, without the
    /// extensions D and P, to reproduce the paper's images.
    Bouthors2004,
    /// Light transport precomputed per shape ([`super::transport`]): the
    /// multiply scattered light of a Monte-Carlo tracer through the cloud's
    /// volume, single scattering through the droplets' phase function and
    /// the forward peak P analytic. The phenomenological weights are the
    /// fitted model's and shade the clouds only until the transfer is
    /// computed (seconds, on a worker thread).
    Transport,
    /// The cloud as the participating medium its mesh stands for: each
    /// cumulus in view (the nearest [`MAX_MARCHED_CLOUDS`]) marched through
    /// its extinction grid and lit by the light precomputed inside it — the
    /// sky's scattered fluence per shape ([`super::interior`]) and the sun's
    /// directional fluence traced for the cloud and the sun's direction
    /// (the sun cube), with single scattering through the shadowed beam —
    /// the march the camera uses inside a cloud, from outside too. Clouds
    /// beyond the nearest are shaded as by [`Self::Transport`]; until a
    /// cloud's sun cube is traced (seconds, on a worker thread) its sun
    /// light is taken isotropic. The default: the nearest to the
    /// path-traced references on the realism suite (docs/REALISM.md).
    #[default]
    Volume,
}

/// How many cumulus the [`CumulusShadingModel::Volume`] model marches
/// (the nearest to the camera in view); the others are shaded as by the
/// transport model. Each holds a light atlas and a sun cube (~3 MB) on the
/// GPU and costs a march over the pixels its box covers.
pub const MAX_MARCHED_CLOUDS: usize = 12;

/// The shader's parameters. Each model has its own defaults
/// ([`CumulusShading::bouthors2004`], [`CumulusShading::fitted`]); a scene
/// file's keys override the chosen model's. The paper's defaults are
/// Bouthors (2004), appendix B, where the appendix gives them (α_a, α_l, α_f, α_t, α_g, α_ρ, r and Trans), in
/// metres: the appendix's corona r = 1500 scene units is Neyret's 10 m, so
/// its α_ρ = 0.0005 per unit is 0.075 m⁻¹ (close to the extinction
/// coefficient of a cumulus core: LWC 0.5 g·m⁻³, r_e 10 µm → 0.075 m⁻¹).
/// The others are not legible in the appendix; their defaults were chosen
/// by looking at the golden images and are documented in docs/cumulus.md.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
// The scene file's schema is the file form's (schemars follows `from` when
// describing deserialisation), with this description.
#[serde(from = "CumulusShadingFile")]
#[schemars(
    description = "The cumulus shader's parameters (`[cumulus.shading]`, Bouthors 2004, ch. 5; \
                   docs/cumulus.md). Every key is optional: a missing one takes the value of \
                   the chosen `model` (the defaults shown are the `volume` model's: the `fitted` \
                   model's weights, which shade the clouds beyond the marched ones, with the \
                   physical forward peak)."
)]
pub struct CumulusShading {
    /// The model whose defaults the other fields started from.
    pub model: CumulusShadingModel,
    /// α_a, weight of the ambient (environment) light.
    pub ambient: f64,
    /// α_l, weight of the Lambert term.
    pub lambert: f64,
    /// α_f (the appendix's alpha_s), weight of the light traps.
    pub light_traps: f64,
    /// α_t, weight of the forward scattering in the corona.
    pub transmission: f64,
    /// α_g, width of the forward lobe (exponent α_g/ρ).
    pub forward_width: f64,
    /// Trans, gain of the forward lobe before saturation.
    pub transmission_gain: f64,
    /// α_ρ, extinction of the core, m⁻¹.
    pub density_per_m: f64,
    /// r, thickness of the corona, m.
    pub corona_thickness_m: f64,
    /// α_b, amplitude of the bump and of its modulation of the density.
    pub bump: f64,
    /// α_w, normal smoothing: the lower level's normal dominates within
    /// 1/α_w of a mean blob radius from its surface.
    pub normal_smoothing: f64,
    /// α_d, width of the light traps: F⁻ fades out at 1/α_d of a mean blob
    /// radius from the lower level's surface.
    pub trap_width: f64,
    /// α_h, bump heights below which the finest furrows trap light.
    pub trap_height: f64,
    /// Light-trap estimate.
    pub trap_model: LightTrapModel,
    /// Neyret's k in arctan(k(1 − h))/arctan(k) (4).
    pub trap_sharpness: f64,
    /// Octaves of the bump noise (the levels below the mesh's simulated).
    pub bump_octaves: u32,
    /// α_δ, weight of the light diffused through the cores to the faces
    /// turned from the sun (an extension of the paper's model, see D above).
    pub diffusion: f64,
    /// α_p, weight of the small-angle multiple forward scattering through
    /// the chord (the silver lining; an extension, see P above). 1 is the
    /// physical value.
    pub forward_peak: f64,
}

impl Default for CumulusShading {
    /// The default model's ([`CumulusShadingModel::Volume`]).
    fn default() -> Self {
        Self::of_model(CumulusShadingModel::default())
    }
}

impl CumulusShading {
    /// The weights of a model.
    pub fn of_model(model: CumulusShadingModel) -> Self {
        match model {
            CumulusShadingModel::Fitted => Self::fitted(),
            CumulusShadingModel::Bouthors2004 => Self::bouthors2004(),
            CumulusShadingModel::Transport | CumulusShadingModel::Volume => Self {
                model,
                forward_peak: 1.0,
                ..Self::fitted()
            },
        }
    }

    /// The fitted model: non-negative least squares of α_a, α_l, α_f, α_δ,
    /// α_p against the path-traced references of cumulus-front-lit,
    /// -back-lit and -field (4×4-pixel blocks, no air, α_t held at 0: the
    /// physical peak P replaces Neyret's lobe), cumulus-from-below and
    /// -sunset held out (docs/REALISM.md). Lambert comes out at 0: with the
    /// core's diffusion D the sunlit side's brightness follows the light's
    /// depth in the cloud, not the blobs' normals, whose radii (45 m) are
    /// below the transport mean free path 1/(α_ρ (1 − g)) ≈ 90 m over which
    /// a real cloud smooths its lighting. α_p comes out at 1.07, the
    /// physical 1 within the fit's scatter (0.98–1.05 on other fits).
    pub fn fitted() -> Self {
        Self {
            model: CumulusShadingModel::Fitted,
            ambient: 1.18,
            lambert: 0.0,
            light_traps: 0.02,
            transmission: 0.0,
            diffusion: 0.32,
            forward_peak: 1.10,
            ..Self::bouthors2004()
        }
    }

    /// Bouthors (2004) as published (the extensions off).
    pub fn bouthors2004() -> Self {
        Self {
            model: CumulusShadingModel::Bouthors2004,
            ambient: 0.75,
            lambert: 0.35,
            light_traps: 0.3,
            transmission: 2.0,
            forward_width: 1.0,
            transmission_gain: 8.0,
            density_per_m: 0.075,
            corona_thickness_m: 10.0,
            bump: 0.25,
            normal_smoothing: 4.0,
            trap_width: 2.0,
            trap_height: 0.35,
            trap_model: LightTrapModel::Furrows,
            trap_sharpness: 4.0,
            bump_octaves: 3,
            diffusion: 0.0,
            forward_peak: 0.0,
        }
    }
}

/// The scene file's form of [`CumulusShading`]: every key optional, the
/// missing ones taken from the chosen model. Its fields' doc comments are
/// the descriptions of `[cumulus.shading]`'s keys in the scene schema.
#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct CumulusShadingFile {
    /// The model: `volume` (default: each cloud in view marched as the
    /// medium its mesh stands for, lit by light precomputed inside it),
    /// `fitted` (the phenomenological shader with weights fitted to the
    /// path-traced references), `bouthors2004` (the paper as published) or
    /// `transport` (light transport precomputed per shape; the fitted
    /// weights until it is ready). The missing keys take its weights.
    model: Option<CumulusShadingModel>,
    /// α_a, weight of the ambient (environment) light.
    ambient: Option<f64>,
    /// α_l, weight of the Lambert term.
    lambert: Option<f64>,
    /// α_f (the appendix's alpha_s), weight of the light traps.
    light_traps: Option<f64>,
    /// α_t, weight of the forward scattering in the corona.
    transmission: Option<f64>,
    /// α_g, width of the forward lobe (exponent α_g/ρ).
    forward_width: Option<f64>,
    /// Trans, gain of the forward lobe before saturation.
    transmission_gain: Option<f64>,
    /// α_ρ, extinction of the core, m⁻¹.
    density_per_m: Option<f64>,
    /// r, thickness of the corona, m.
    corona_thickness_m: Option<f64>,
    /// α_b, amplitude of the bump and of its modulation of the density.
    bump: Option<f64>,
    /// α_w, normal smoothing: the lower level's normal dominates within
    /// 1/α_w of a mean blob radius from its surface.
    normal_smoothing: Option<f64>,
    /// α_d, width of the light traps: F⁻ fades out at 1/α_d of a mean blob
    /// radius from the lower level's surface.
    trap_width: Option<f64>,
    /// α_h, bump heights below which the finest furrows trap light.
    trap_height: Option<f64>,
    /// Light-trap estimate: `furrows` (Bouthors 2004) or `arctan` (Neyret 2000).
    trap_model: Option<LightTrapModel>,
    /// Neyret's k in arctan(k(1 − h))/arctan(k).
    trap_sharpness: Option<f64>,
    /// Octaves of the bump noise (the levels below the mesh's simulated).
    bump_octaves: Option<u32>,
    /// α_δ, weight of the light diffused through the cores to the faces
    /// turned from the sun (an extension of the paper's model).
    diffusion: Option<f64>,
    /// α_p, weight of the small-angle multiple forward scattering through
    /// the chord (the silver lining; an extension). 1 is the physical value.
    forward_peak: Option<f64>,
}

impl From<CumulusShadingFile> for CumulusShading {
    fn from(file: CumulusShadingFile) -> Self {
        let model = file.model.unwrap_or_default();
        let base = Self::of_model(model);
        Self {
            model,
            ambient: file.ambient.unwrap_or(base.ambient),
            lambert: file.lambert.unwrap_or(base.lambert),
            light_traps: file.light_traps.unwrap_or(base.light_traps),
            transmission: file.transmission.unwrap_or(base.transmission),
            forward_width: file.forward_width.unwrap_or(base.forward_width),
            transmission_gain: file.transmission_gain.unwrap_or(base.transmission_gain),
            density_per_m: file.density_per_m.unwrap_or(base.density_per_m),
            corona_thickness_m: file.corona_thickness_m.unwrap_or(base.corona_thickness_m),
            bump: file.bump.unwrap_or(base.bump),
            normal_smoothing: file.normal_smoothing.unwrap_or(base.normal_smoothing),
            trap_width: file.trap_width.unwrap_or(base.trap_width),
            trap_height: file.trap_height.unwrap_or(base.trap_height),
            trap_model: file.trap_model.unwrap_or(base.trap_model),
            trap_sharpness: file.trap_sharpness.unwrap_or(base.trap_sharpness),
            bump_octaves: file.bump_octaves.unwrap_or(base.bump_octaves),
            diffusion: file.diffusion.unwrap_or(base.diffusion),
            forward_peak: file.forward_peak.unwrap_or(base.forward_peak),
        }
    }
}

/// Which terms are on: for the term-by-term figure (Bouthors 2004,
/// figs 5.2–5.13). All on by default.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ShadingTerms {
    /// Ambient light.
    pub ambient: bool,
    /// Bump (and the bump's modulation of the density).
    pub bump: bool,
    /// Light traps.
    pub light_traps: bool,
    /// Corona: transparency and forward scattering.
    pub corona: bool,
    /// Shadows.
    pub shadow: bool,
}

impl Default for ShadingTerms {
    fn default() -> Self {
        Self {
            ambient: true,
            bump: true,
            light_traps: true,
            corona: true,
            shadow: true,
        }
    }
}

impl ShadingTerms {
    /// Packs the flags into bits (ambient 1, bump 2, light traps 4, corona 8,
    /// shadow 16), the GPU uniform's encoding.
    pub fn bits(&self) -> u32 {
        u32::from(self.ambient)
            | u32::from(self.bump) << 1
            | u32::from(self.light_traps) << 2
            | u32::from(self.corona) << 3
            | u32::from(self.shadow) << 4
    }
}

/// Forward-difference step of the bump's gradient, in noise coordinates.
pub const BUMP_STEP: f64 = 0.05;

/// Seed of the bump noise's first octave (octave k adds 7919 k).
const BUMP_SEED: u32 = 0x5eed;

/// Bump height h ∈ [0, 1] at noise coordinates `x`: ½ + ½ Σ_k g^k n(x λ^k) /
/// Σ_k g^k with g = 1/λ, n the 3-D gradient noise
/// ([`crate::noise::gradient_noise_3d`]): the octaves of the levels below
/// the mesh's, each λ times smaller and fainter (λ = 3 for the paper's
/// radius ratio). CPU twin of `cumulus_bump_height`.
pub fn bump_height(x: DVec3, lacunarity: f64, octaves: u32) -> f64 {
    let (mut sum, mut norm, mut amplitude, mut frequency) = (0.0, 0.0, 1.0, 1.0);
    for k in 0..octaves {
        let p = x * frequency;
        sum += amplitude
            * crate::noise::gradient_noise_3d(p.x, p.y, p.z, BUMP_SEED.wrapping_add(k * 7919));
        norm += amplitude;
        amplitude /= lacunarity;
        frequency *= lacunarity;
    }
    if norm <= 0.0 {
        return 0.5;
    }
    (0.5 + 0.5 * sum / norm).clamp(0.0, 1.0)
}

/// h and its gradient by forward differences of [`BUMP_STEP`].
pub fn bump_height_and_gradient(x: DVec3, lacunarity: f64, octaves: u32) -> (f64, DVec3) {
    let h = bump_height(x, lacunarity, octaves);
    let d = |e: DVec3| (bump_height(x + e * BUMP_STEP, lacunarity, octaves) - h) / BUMP_STEP;
    (h, DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z)))
}

/// Asymmetry parameter of cloud droplets in the visible (Hansen & Travis
/// 1974, fig. 12), for the two-stream transmittance of the shadow.
pub const CLOUD_ASYMMETRY: f64 = 0.85;

/// ∫ρ ds along the chord at impact parameter `impact_m` through a sphere of
/// radius `radius_m` whose density is saturate((R − s)/r), s the distance
/// to the centre and r = `corona_m`: the cloud crossed, in metres of core.
///
/// With R_c = max(R − r, 0), t_R = √(R² − b²) and t_c = √(R_c² − b²) (0 when
/// b ≥ R_c), and ∫√(b² + t²) dt = ½[t√(b² + t²) + b² ln(t + √(b² + t²))]:
/// q = 2 [t_c + (R (t_R − t_c) − ½(t_R R − t_c s_c) − ½ b² ln((t_R + R)/(t_c + s_c)))/r],
/// s_c = max(R_c, b). Exact; r → 0 gives the chord 2 t_R.
pub fn chord_density_integral_m(impact_m: f64, radius_m: f64, corona_m: f64) -> f64 {
    let (b, big_r) = (impact_m.abs(), radius_m.max(0.0));
    if b >= big_r {
        return 0.0;
    }
    let t_r = (big_r * big_r - b * b).sqrt();
    let r = corona_m.max(1e-9);
    let core = (big_r - r).max(0.0);
    let (t_c, s_c) = if b < core {
        ((core * core - b * b).sqrt(), core)
    } else {
        (0.0, b)
    };
    let log_term = if b > 0.0 {
        b * b * ((t_r + big_r) / (t_c + s_c)).ln()
    } else {
        0.0
    };
    let shell = big_r * (t_r - t_c) - 0.5 * (t_r * big_r - t_c * s_c) - 0.5 * log_term;
    2.0 * (t_c + shell / r)
}

/// Two-stream transmittance of a conservative scattering slab of optical
/// depth τ with asymmetry g: 1 / (1 + ¾ (1 − g) τ).
pub fn two_stream_transmittance(optical_depth: f64, asymmetry: f64) -> f64 {
    1.0 / (1.0 + 0.75 * (1.0 - asymmetry) * optical_depth.max(0.0))
}

/// What the shader reads at a surface point (world space, unit vectors).
#[derive(Clone, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Interpolated surface normal N (unit).
    pub normal: DVec3,
    /// Normals of S_{l−1}, S_{l−2}, … at the point (unit).
    pub base_normals: Vec<DVec3>,
    /// δ_j: distances to S_{l−j} over that level's mean blob radius.
    pub base_distances: Vec<f64>,
    /// Mean blob radius of S_{l−1}, S_{l−2}, …, m.
    pub base_radii_m: Vec<f64>,
    /// Radius of the point's blob, m.
    pub blob_radius_m: f64,
    /// Unit vector from the blob's centre to the point.
    pub blob_up: DVec3,
    /// Bump height h ∈ [0, 1] at the point.
    pub bump_height: f64,
    /// Gradient of h with respect to the noise coordinates (position over
    /// the first bump octave's wavelength): B before its projection on the
    /// tangent plane.
    pub bump_gradient: DVec3,
}

/// The light at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight<'a> {
    /// Unit vector towards the observer, O.
    pub to_observer: DVec3,
    /// Unit vector towards the sun, L.
    pub to_sun: DVec3,
    /// C_s: the sun's irradiance over π, RGB.
    pub sun_radiance: [f64; 3],
    /// E_env(n)/π for a normal n: the environment's radiance seen by n.
    pub ambient_radiance: [f64; 3],
    /// E: the shadow transmittance at the point.
    pub shadow: f64,
    /// E where the forward-scattered light enters the corona: at the far
    /// end of the blob's chord behind the point, 2R (N·O) away along −O.
    pub forward_shadow: f64,
    /// The droplets' small-angle forward scattering F(θ, τ), for the term
    /// P (none: P = 0).
    pub forward_peak: Option<&'a ForwardPeakTable>,
}

/// Result of the shader.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shaded {
    /// I, RGB radiance (not premultiplied).
    pub radiance: [f64; 3],
    /// A, opacity.
    pub opacity: f64,
    /// Optical depth of the chord τ.
    pub optical_depth: f64,
    /// Forward-scattering term T.
    pub forward: f64,
    /// Light-trap term F.
    pub light_traps: f64,
    /// Lambert term L.
    pub lambert: f64,
    /// Diffusion term D.
    pub diffusion: f64,
    /// Forward-peak term P = π F(θ, τ) per channel.
    pub forward_peak: [f64; 3],
    /// Smoothed normal N′.
    pub smoothed_normal: DVec3,
}

fn saturate(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}

/// The smoothed normal N′ (eq 5.34).
pub fn smoothed_normal(point: &SurfacePoint, shading: &CumulusShading) -> DVec3 {
    let mut sum = DVec3::ZERO;
    for (n_j, d_j) in point.base_normals.iter().zip(&point.base_distances) {
        let w = saturate(shading.normal_smoothing * d_j);
        sum += w * point.normal + (1.0 - w) * *n_j;
    }
    if point.base_normals.is_empty() {
        sum = point.normal;
    }
    sum.normalize_or(point.normal)
}

/// Chord integral through a sphere of radius `radius_m` entered where its
/// unit normal is `normal`, seen along `to_observer`.
fn sphere_chord_m(normal: DVec3, to_observer: DVec3, radius_m: f64, corona_m: f64) -> f64 {
    let c = saturate(normal.dot(to_observer));
    chord_density_integral_m(radius_m * (1.0 - c * c).sqrt(), radius_m, corona_m)
}

/// Optical depth τ of the cloud behind a point seen along `to_observer`
/// (eqs 5.31–5.32 with the exact chord integral, through the point's blob
/// and the lower levels' surfaces).
pub fn optical_depth(
    point: &SurfacePoint,
    to_observer: DVec3,
    shading: &CumulusShading,
    bump_on: bool,
) -> f64 {
    let r = shading.corona_thickness_m;
    let mut q = sphere_chord_m(point.normal, to_observer, point.blob_radius_m, r);
    for (n_j, r_j) in point.base_normals.iter().zip(&point.base_radii_m) {
        q += sphere_chord_m(*n_j, to_observer, *r_j, r);
    }
    let modulation = if bump_on {
        1.0 - shading.bump * point.bump_height
    } else {
        1.0
    };
    shading.density_per_m * modulation * q
}

/// Evaluates the shader (the CPU twin of `cumulus_shade` in
/// `cumulus/cumulus.wgsl`).
pub fn shade(
    point: &SurfacePoint,
    light: &PointLight,
    shading: &CumulusShading,
    terms: ShadingTerms,
) -> Shaded {
    let (o, l) = (light.to_observer, light.to_sun);
    let n_smooth = smoothed_normal(point, shading);
    let n_bump = if terms.bump {
        let g = point.bump_gradient;
        let tangential = g - g.dot(n_smooth) * n_smooth;
        (n_smooth - shading.bump * tangential).normalize_or(n_smooth)
    } else {
        n_smooth
    };
    let lambert = saturate(n_bump.dot(l));
    let light_traps = if terms.light_traps {
        match shading.trap_model {
            LightTrapModel::Furrows => {
                let lower: f64 = point
                    .base_normals
                    .iter()
                    .zip(&point.base_distances)
                    .map(|(n_j, d_j)| {
                        saturate(1.0 - shading.trap_width * d_j) * saturate(n_j.dot(l))
                    })
                    .sum();
                let h = if terms.bump { point.bump_height } else { 1.0 };
                lower + saturate(shading.trap_height - h) * saturate(n_smooth.dot(l))
            }
            LightTrapModel::Arctan => {
                let under = point.base_normals.first().copied().unwrap_or(point.normal);
                let height = saturate(under.dot(point.blob_up));
                let k = shading.trap_sharpness;
                saturate(under.dot(l)) * (k * (1.0 - height)).atan() / k.atan()
            }
        }
    } else {
        0.0
    };
    let (optical_depth, forward) = if terms.corona {
        let tau = optical_depth(point, o, shading, terms.bump);
        let rho = saturate(tau).max(1e-4);
        let cos_theta = saturate(-o.dot(l));
        let lobe = cos_theta.powf(shading.forward_width / rho);
        let forward = saturate(shading.transmission_gain * (1.0 - rho).powi(2) * lobe);
        (tau, forward)
    } else {
        (f64::INFINITY, 0.0)
    };
    let forward_peak = match (terms.corona, light.forward_peak) {
        (true, Some(table)) => {
            let angle = (-o.dot(l)).clamp(-1.0, 1.0).acos();
            table
                .at(angle, optical_depth)
                .map(|f| std::f64::consts::PI * f)
        }
        _ => [0.0; 3],
    };
    let diffusion = 1.0;
    let shadow = if terms.shadow { light.shadow } else { 1.0 };
    let forward_shadow = if terms.shadow {
        light.forward_shadow
    } else {
        1.0
    };
    let ambient = if terms.ambient { shading.ambient } else { 0.0 };
    // Light reflected and diffused at the point is shadowed there; light
    // scattered forwards through the chord where it enters the chord.
    let direct = shading.light_traps * light_traps
        + shading.lambert * lambert
        + shading.diffusion * diffusion;
    let radiance = std::array::from_fn(|c| {
        let through = shading.transmission * forward + shading.forward_peak * forward_peak[c];
        ambient * light.ambient_radiance[c]
            + light.sun_radiance[c] * (shadow * direct + forward_shadow * through)
    });
    Shaded {
        radiance,
        opacity: 1.0 - (-optical_depth).exp(),
        optical_depth,
        forward,
        light_traps,
        lambert,
        diffusion,
        forward_peak,
        smoothed_normal: n_smooth,
    }
}

/// Whether a point seen from the sun belongs to the core that casts
/// shadows (τ ≥ 1 along the sun's ray; Bouthors 2004, §5.8: ρ > 1).
pub fn casts_shadow(point: &SurfacePoint, to_sun: DVec3, shading: &CumulusShading) -> bool {
    optical_depth(point, to_sun, shading, false) >= 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numeric_chord(b: f64, big_r: f64, r: f64) -> f64 {
        let t_r = (big_r * big_r - b * b).max(0.0).sqrt();
        let n = 200_000;
        let h = 2.0 * t_r / n as f64;
        (0..n)
            .map(|i| {
                let t = -t_r + (i as f64 + 0.5) * h;
                let s = (b * b + t * t).sqrt();
                saturate((big_r - s) / r) * h
            })
            .sum()
    }

    #[test]
    fn chord_integral_matches_quadrature_and_its_limits() {
        for &(b, big_r, r) in &[
            (0.0, 45.0, 10.0),
            (20.0, 45.0, 10.0),
            (36.0, 45.0, 10.0),
            (44.0, 45.0, 10.0),
            (5.0, 8.0, 10.0),
            (0.0, 8.0, 10.0),
            (300.0, 400.0, 1.0),
        ] {
            let exact = chord_density_integral_m(b, big_r, r);
            let numeric = numeric_chord(b, big_r, r);
            assert!(
                (exact - numeric).abs() < 1e-6 * big_r,
                "b {b} R {big_r} r {r}: {exact} vs {numeric}"
            );
        }
        // A thin corona: the chord itself. Through the centre with no core
        // (R ≤ r): ∫(R − |t|)/r dt = R²/r.
        assert!((chord_density_integral_m(30.0, 50.0, 1e-7) - 80.0).abs() < 1e-3);
        assert!((chord_density_integral_m(0.0, 8.0, 10.0) - 6.4).abs() < 1e-9);
        assert_eq!(chord_density_integral_m(50.0, 45.0, 10.0), 0.0);
    }

    fn front_lit_point() -> (SurfacePoint, PointLight<'static>) {
        let point = SurfacePoint {
            normal: DVec3::Z,
            base_normals: vec![DVec3::Z, DVec3::Y],
            base_distances: vec![0.5, 0.8],
            base_radii_m: vec![125.0, 400.0],
            blob_radius_m: 45.0,
            blob_up: DVec3::Z,
            bump_height: 0.5,
            bump_gradient: DVec3::ZERO,
        };
        let light = PointLight {
            to_observer: DVec3::Z,
            to_sun: DVec3::new(0.0, 0.6, 0.8),
            sun_radiance: [1.0; 3],
            ambient_radiance: [0.2, 0.25, 0.3],
            shadow: 1.0,
            forward_shadow: 1.0,
            forward_peak: None,
        };
        (point, light)
    }

    #[test]
    fn front_lit_core_is_opaque_and_white_silhouette_transparent() {
        let shading = CumulusShading::bouthors2004();
        let (mut point, light) = front_lit_point();
        let core = shade(&point, &light, &shading, ShadingTerms::default());
        assert!(core.opacity > 0.999, "{core:?}");
        assert!(core.lambert > 0.7 && core.forward == 0.0);
        // The blob alone is not opaque: the lower levels make the body so.
        let blob_only = SurfacePoint {
            base_normals: vec![],
            ..point.clone()
        };
        let tau = optical_depth(&blob_only, light.to_observer, &shading, true);
        assert!(tau > 4.0 && tau < 6.0, "{tau}");
        // At the cloud's silhouette (every normal ⟂ O) the chord vanishes.
        point.normal = DVec3::X;
        point.base_normals = vec![DVec3::X, DVec3::Y];
        let edge = shade(&point, &light, &shading, ShadingTerms::default());
        assert!(edge.opacity < 1e-9, "{edge:?}");
    }

    #[test]
    fn back_lit_corona_glows_and_core_does_not() {
        let shading = CumulusShading::bouthors2004();
        let (mut point, mut light) = front_lit_point();
        light.to_sun = -DVec3::Z;
        let core = shade(&point, &light, &shading, ShadingTerms::default());
        assert_eq!(core.forward, 0.0, "ρ = 1: no forward lobe in the core");
        // Near the silhouette: thin corona, T saturates, A small but non-zero.
        let c: f64 = 0.4;
        point.normal = DVec3::new((1.0 - c * c).sqrt(), 0.0, c);
        point.base_normals = vec![DVec3::new(0.0, 1.0, 0.0), DVec3::Y];
        let rim = shade(&point, &light, &shading, ShadingTerms::default());
        assert!(rim.forward > 0.9, "{rim:?}");
        assert!(rim.opacity > 0.05 && rim.opacity < 0.9, "{rim:?}");
        // Turning the sun 90° away kills the lobe.
        light.to_sun = DVec3::Y;
        let side = shade(&point, &light, &shading, ShadingTerms::default());
        assert!(side.forward < 1e-6);
    }

    #[test]
    fn every_term_can_be_switched_off() {
        let shading = CumulusShading::bouthors2004();
        let (point, light) = front_lit_point();
        let none = ShadingTerms {
            ambient: false,
            bump: false,
            light_traps: false,
            corona: false,
            shadow: false,
        };
        let lambert_only = shade(&point, &light, &shading, none);
        let expected = shading.lambert * lambert_only.lambert;
        assert!((lambert_only.radiance[0] - expected).abs() < 1e-12);
        assert_eq!(lambert_only.opacity, 1.0);
        let with_ambient = shade(
            &point,
            &light,
            &shading,
            ShadingTerms {
                ambient: true,
                ..none
            },
        );
        assert!((with_ambient.radiance[2] - expected - 0.75 * 0.3).abs() < 1e-12);
        let shadowed = shade(
            &point,
            &PointLight {
                shadow: 0.2,
                ..light
            },
            &shading,
            ShadingTerms::default(),
        );
        let lit = shade(&point, &light, &shading, ShadingTerms::default());
        assert!(shadowed.radiance[0] < lit.radiance[0]);
    }

    #[test]
    fn shadows_follow_the_two_stream_law() {
        assert_eq!(two_stream_transmittance(0.0, 0.85), 1.0);
        // 500 m of core at 0.075 m⁻¹: τ = 37.5, T = 1/(1 + 0.75·0.15·37.5) ≈ 0.19,
        // the order of the 10–30 % measured under small cumulus.
        let t = two_stream_transmittance(37.5, CLOUD_ASYMMETRY);
        assert!((t - 0.1916).abs() < 1e-3, "{t}");
        let shading = CumulusShading::bouthors2004();
        let (mut point, _) = front_lit_point();
        assert!(casts_shadow(&point, DVec3::Z, &shading));
        point.normal = DVec3::X;
        point.base_normals = vec![DVec3::X, DVec3::X];
        assert!(!casts_shadow(&point, DVec3::Z, &shading));
    }

    #[test]
    fn smoothing_leans_to_the_lower_level_near_its_surface() {
        let shading = CumulusShading::bouthors2004();
        let (mut point, _) = front_lit_point();
        point.base_normals = vec![DVec3::Y];
        point.base_distances = vec![0.0];
        assert!((smoothed_normal(&point, &shading) - DVec3::Y).length() < 1e-12);
        point.base_distances = vec![1.0];
        assert!((smoothed_normal(&point, &shading) - DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn the_model_picks_the_defaults_and_keys_override_them() {
        let parse = |text: &str| -> CumulusShading { toml::from_str(text).expect("valid shading") };
        assert_eq!(
            parse(""),
            CumulusShading::of_model(CumulusShadingModel::Volume)
        );
        assert_eq!(parse("model = \"fitted\""), CumulusShading::fitted());
        assert_eq!(
            parse("model = \"bouthors2004\""),
            CumulusShading::bouthors2004()
        );
        let mixed = parse("model = \"bouthors2004\"\ndiffusion = 0.2");
        assert_eq!(mixed.diffusion, 0.2);
        assert_eq!(mixed.ambient, CumulusShading::bouthors2004().ambient);
        assert!(toml::from_str::<CumulusShading>("model = \"neyret\"").is_err());
        assert!(toml::from_str::<CumulusShading>("ambiant = 1.0").is_err());
        // What is written reads back the same.
        let written = toml::to_string(&mixed).expect("serialisable");
        assert_eq!(parse(&written), mixed);
    }

    #[test]
    fn the_cores_diffuse_light_to_the_faces_turned_from_the_sun() {
        // A face turned from the sun: Lambert and the paper's terms give it
        // nothing of the sun; D gives it α_δ C_s E, E the light that crossed
        // the core to it.
        let shading = CumulusShading::fitted();
        let (point, mut light) = front_lit_point();
        light.to_sun = -DVec3::Z;
        let none = ShadingTerms {
            ambient: false,
            ..ShadingTerms::default()
        };
        for e in [1.0, 0.3, 0.05] {
            let shaded = shade(&point, &PointLight { shadow: e, ..light }, &shading, none);
            assert_eq!(shaded.lambert, 0.0);
            let expected = shading.diffusion * e + shading.light_traps * shaded.light_traps * e;
            assert!((shaded.radiance[1] - expected).abs() < 1e-12, "{shaded:?}");
        }
        let paper = shade(&point, &light, &CumulusShading::bouthors2004(), none);
        assert!(paper.radiance[1] < 1e-12, "{paper:?}");
    }

    #[test]
    fn a_thin_rim_near_the_sun_glows_with_the_forward_peak() {
        // A rim of τ ≈ 2 seen 3° from the sun: P = π F(θ, τ) from the
        // table, weighted α_p and shadowed where the light enters the chord.
        let table = ForwardPeakTable::gaussian([1f64.to_radians(); 3], [0.5; 3]);
        let shading = CumulusShading::fitted();
        let o = DVec3::Z;
        // The point on the rim where the chord behind it reaches τ ≈ 2.
        let mut point = SurfacePoint {
            normal: DVec3::Y,
            base_normals: vec![],
            base_distances: vec![],
            base_radii_m: vec![],
            blob_radius_m: 45.0,
            blob_up: DVec3::Y,
            bump_height: 0.5,
            bump_gradient: DVec3::ZERO,
        };
        for step in 1..100 {
            let c = f64::from(step) * 0.01;
            point.normal = DVec3::new(0.0, (1.0 - c * c).sqrt(), c);
            if optical_depth(&point, o, &shading, true) > 1.5 {
                break;
            }
        }
        let l = DVec3::new(0.0, 3f64.to_radians().sin(), -(3f64.to_radians().cos()));
        let tau = optical_depth(&point, o, &shading, true);
        assert!(tau > 0.5 && tau < 5.0, "τ {tau}");
        let light = PointLight {
            to_observer: o,
            to_sun: l,
            sun_radiance: [1.0; 3],
            ambient_radiance: [0.0; 3],
            shadow: 0.1,
            forward_shadow: 1.0,
            forward_peak: Some(&table),
        };
        let terms = ShadingTerms {
            ambient: false,
            ..ShadingTerms::default()
        };
        let lit = shade(&point, &light, &shading, terms);
        let f = table.at(3f64.to_radians(), tau)[1];
        assert!((lit.forward_peak[1] - std::f64::consts::PI * f).abs() < 1e-12);
        // Brighter than a white surface facing the sun (I = 1).
        assert!(lit.radiance[1] > 1.0, "{lit:?}");
        let entered_shadowed = shade(
            &point,
            &PointLight {
                forward_shadow: 0.0,
                ..light
            },
            &shading,
            terms,
        );
        assert!(entered_shadowed.radiance[1] < 0.1 * lit.radiance[1]);
    }
}
