//! The analytic model of light transport through a stratiform cloud layer
//! (Bouthors, Neyret & Lefebvre 2006, "Real-time realistic illumination and
//! shading of stratiform clouds", §4 and appendices A–B), formula by formula.
//!
//! The layer is a homogeneous slab of thickness H (m) lit by the sun at
//! zenith θ_l, seen in direction V. Radiances here are per unit incident flux
//! on the slab's top (the paper's are per unit beam flux: they are divided by
//! μ_l), in sr⁻¹; phase functions are normalised to 1 over the sphere (the
//! paper's P is 4π times ours, and its formulas are written for ours).
//!
//! Reconstructions of formulas that the text extraction garbled or that are
//! misprinted, each re-derived:
//!
//! - The angle θ_vl. The paper's P(θ_vl) is the phase function at the
//!   scattering angle Θ between the sun's beam and the view, cos Θ = −L·V
//!   with L towards the sun and V towards the viewer: the glory (Θ = 180°) is
//!   where V = L, the forward peak (Θ = 0) where V = −L.
//! - §4.3, I₁. Integrating s(l/μ_l) P τ(l/μ_v) dl/μ_v gives
//!   P μ_l/(μ_v + μ_l) (1 − τ(H_l + H_v)) without the leading κ of the printed
//!   result (κ cancels between s and the integral; with it the result would
//!   have units of m⁻¹). Transmission: P μ_l/(μ_v − μ_l) (τ(H_v) − τ(H_l)),
//!   positive for either sign of μ_v − μ_l, and P (κH/μ) τ(H/μ) in the limit
//!   μ_v = μ_l, which [`exp_difference_quotient`] evaluates without 0/0.
//! - §4.4, I₂. The printed κ² P² (…) is dimensionally inconsistent with I₁.
//!   Under the paper's approximation (the doubly scattered paths follow the
//!   singly scattered "green" path, the two deflections composing into P²),
//!   a second event may occur anywhere along that path of optical length
//!   T(l); each unordered pair of events is counted once, so the integrand of
//!   I₁ gains a factor T(l)/2 and P becomes P² (the Poisson probability of
//!   two events rather than one). This gives
//!   I₂ʳ = ½ P² μ_l/(μ_v + μ_l) (1 − (1 + a) e^{−a}), a = κH(1/μ_l + 1/μ_v), and
//!   I₂ᵗ = ½ P² μ_l/(μ_v − μ_l) ((1 + A_v) e^{−A_v} − (1 + A_l) e^{−A_l}),
//!   A = κH/μ, with the right thin-slab limit (∝ (κH)²) and I₂/I₁ → T/2 along
//!   a straight path.
//! - §4.2, I_0F. "P_F(θ)^{κH_v}" is the forward peak convolved with itself
//!   as many times as there are forward events on the path. Events of the
//!   peak are Poisson with mean m = P_f κ H_v (κ the unmodified extinction),
//!   and no S event happens with probability τ_S(H_v), so
//!   I_0F = τ_S(H_v) Σ_{n≥1} (mⁿ e^{−m}/n!) P_F^{*n}(Θ): n = 1 is the tabulated
//!   peak, n ≥ 2 the small-angle Gaussian with n times its mean square angle
//!   (the convolution of narrow peaks on the sphere adds their variances).
//! - §4.5, I₃₊. The printed R₃₊ μ_l/(4π μ_v) does not return R₃₊ when
//!   integrated over the hemisphere (it returns R₃₊/2 per unit top flux);
//!   "diffuse" is taken as Lambertian: I₃₊ = R₃₊/π per unit top flux, so the
//!   flux of each order matches the 1-D model ([`DiffuseExit::Lambertian`]).
//!
//! Beyond the paper: light that has diffused through many scattering events
//! does not leave a thick slab isotropically but darkened towards the slab's
//! plane, as Chandrasekhar's H-function of conservative scattering (1960,
//! *Radiative Transfer*, ch. V), which the escape function
//! u(μ) = (3/7)(1 + 2μ) follows to a few per cent; u is normalised to unit
//! flux (∫₀¹ u(μ) 2μ dμ = 1), so the transmitted I₃₊ = u(μ_v) T₃₊/π keeps
//! each order's flux ([`DiffuseExit::EscapeFunction`]). nimbus's Monte-Carlo
//! slab with the droplets' phase function shows it (tests/stratus_escape.rs:
//! a 500 m slab under a 45° sun transmits orders 3+ within 9 % of
//! u(μ_v) T₃₊/π at every angle, from 0.139 sr⁻¹ towards the nadir to 0.044
//! at 2.5° below its plane, where the Lambertian 0.103 is 26 % under and
//! 134 % over). The reflected orders 3+ are not diffused enough for it: the
//! first few of them dominate and keep the sun's geometry, and the
//! Lambertian R₃₊/π holds within 10 % up to 70° from the normal (the escape
//! function is 40 % over at the zenith), too bright only at grazing angles
//! (+68 % at 87.5°). Under a low sun they are thrown forward, up to 5 ×
//! R₃₊/π towards grazing views facing the sun: [`DiffuseExit::EscapeAndTracedReflection`]
//! sends them by the shape traced in nimbus's Monte-Carlo slab
//! ([`super::reflected_exit`]).
//! - Appendix A, T_2b. The printed ¼ r² (1 + (2Hκ_c − 1) τ_c(2H)) τ_c(3H) does
//!   not vanish as H² for thin slabs. Integrating the printed double integral
//!   gives ¼ r² τ_c(H) (2κ_c H − 1 + τ_c(2H)), which does.
//! - Appendix A, R₁: the garbled "α^t" is r: R₁ = ½ r (1 − τ_c(2H)).
//!
//! §4.1: P_S is the phase function with the forward peak (Θ < θ_f) removed
//! and renormalised (the paper's "if θ < θ_f" means θ ≥ θ_f; see
//! [`crate::optics::phase`]), κ_S = (1 − P_f) κ; orders 1, 2 use P_S, κ_S.

use crate::optics::phase::PhaseTable;

/// One row of the appendix B table: the 1-D model's parameters at one sun
/// zenith angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OneDimensionalParams {
    /// Sun zenith angle θ_l, degrees.
    pub sun_zenith_deg: f64,
    /// Asymptote b of the thin-slab correction of T_ms.
    pub b: f64,
    /// Rate c of the thin-slab correction, m⁻¹.
    pub c: f64,
    /// Extinction κ_c of the 1-D column, m⁻¹.
    pub kappa_c: f64,
    /// Transmissive scattering coefficient t.
    pub t: f64,
    /// Reflective scattering coefficient r.
    pub r: f64,
}

/// The 1-D model's parameters over sun zenith angles, with β = T_ms(1 m).
#[derive(Clone, Debug, PartialEq)]
pub struct OneDimensionalTable {
    /// β, the transmittance of a 1 m slab by multiple scattering.
    pub beta: f64,
    /// Rows in ascending sun zenith angle.
    pub rows: Vec<OneDimensionalParams>,
}

impl OneDimensionalTable {
    /// Bouthors et al. (2006), appendix B, for N₀ = 300 cm⁻³, γ = 2,
    /// r_e = 7 µm, all ten rows (the 90° row, for grazing sun, cannot come
    /// from a slab simulation and looks set by hand; it is kept as printed).
    pub fn bouthors_2006() -> Self {
        let rows = [
            (0.0, 1.1796, 0.0138, 0.0265, 0.8389, 0.0547),
            (10.0, 1.1293, 0.0154, 0.0262, 0.8412, 0.0547),
            (20.0, 1.1382, 0.0131, 0.0272, 0.8334, 0.0552),
            (30.0, 1.0953, 0.0049, 0.0294, 0.8208, 0.0564),
            (40.0, 0.9808, 0.0012, 0.0326, 0.8010, 0.0603),
            (50.0, 0.9077, 0.0047, 0.0379, 0.7774, 0.0705),
            (60.0, 0.7987, 0.0207, 0.0471, 0.7506, 0.0984),
            (70.0, 0.6629, 0.0133, 0.0616, 0.7165, 0.1700),
            (80.0, 0.5043, 0.0280, 0.0700, 0.7149, 0.3554),
            (90.0, 0.3021, 0.0783, 0.0700, 0.1000, 0.9500),
        ]
        .map(
            |(sun_zenith_deg, b, c, kappa_c, t, r)| OneDimensionalParams {
                sun_zenith_deg,
                b,
                c,
                kappa_c,
                t,
                r,
            },
        );
        Self {
            beta: 0.9961,
            rows: rows.to_vec(),
        }
    }

    /// The parameters at a sun zenith angle, linear between rows and held
    /// constant beyond the first and last.
    pub fn at(&self, sun_zenith_deg: f64) -> OneDimensionalParams {
        let rows = &self.rows;
        if rows.len() == 1 {
            return rows[0];
        }
        let x = sun_zenith_deg.clamp(rows[0].sun_zenith_deg, rows[rows.len() - 1].sun_zenith_deg);
        let i = rows
            .partition_point(|r| r.sun_zenith_deg <= x)
            .clamp(1, rows.len() - 1);
        let (a, b) = (rows[i - 1], rows[i]);
        let f = (x - a.sun_zenith_deg) / (b.sun_zenith_deg - a.sun_zenith_deg);
        let lerp = |p: f64, q: f64| p + f * (q - p);
        OneDimensionalParams {
            sun_zenith_deg: x,
            b: lerp(a.b, b.b),
            c: lerp(a.c, b.c),
            kappa_c: lerp(a.kappa_c, b.kappa_c),
            t: lerp(a.t, b.t),
            r: lerp(a.r, b.r),
        }
    }
}

/// Transmittances and reflectances of the 1-D model (appendix A) for a slab
/// of thickness H (m), per unit incident flux on the top.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlabFluxes {
    /// T_ms: total transmittance (direct included).
    pub transmittance: f64,
    /// R_ms = 1 − T_ms.
    pub reflectance: f64,
    /// T₀ = τ(H_l), the direct beam (unmodified extinction).
    pub t0: f64,
    /// T₁.
    pub t1: f64,
    /// T₂ = T_2a + T_2b.
    pub t2: f64,
    /// T₃₊ = T_ms − T₀ − T₁ − T₂ (not below 0).
    pub t3plus: f64,
    /// R₁.
    pub r1: f64,
    /// R₂.
    pub r2: f64,
    /// R₃₊ = R_ms − R₁ − R₂ (not below 0).
    pub r3plus: f64,
}

/// The 1-D model's closed forms (appendix A).
pub mod one_dimensional {
    use super::OneDimensionalParams;

    /// T_ms(H) = (b + (1 − b) e^{−cH}) β / (H − (H − 1) β), H in metres.
    pub fn t_ms(p: &OneDimensionalParams, beta: f64, thickness_m: f64) -> f64 {
        let h = thickness_m;
        let isotropic = beta / (h - (h - 1.0) * beta);
        ((p.b + (1.0 - p.b) * (-p.c * h).exp()) * isotropic).clamp(0.0, 1.0)
    }

    /// T₁(H) = t κ_c H e^{−κ_c H}.
    pub fn t1(p: &OneDimensionalParams, h: f64) -> f64 {
        p.t * p.kappa_c * h * (-p.kappa_c * h).exp()
    }

    /// R₁(H) = ½ r (1 − e^{−2κ_c H}).
    pub fn r1(p: &OneDimensionalParams, h: f64) -> f64 {
        -0.5 * p.r * (-2.0 * p.kappa_c * h).exp_m1()
    }

    /// T_2a(H) = ½ (κ_c t H)² e^{−κ_c H}: two forward events.
    pub fn t2a(p: &OneDimensionalParams, h: f64) -> f64 {
        0.5 * (p.kappa_c * p.t * h).powi(2) * (-p.kappa_c * h).exp()
    }

    /// T_2b(H) = ¼ r² e^{−κ_c H} (2κ_c H − 1 + e^{−2κ_c H}): two backward
    /// events (reconstructed, see the module notes).
    pub fn t2b(p: &OneDimensionalParams, h: f64) -> f64 {
        let x = 2.0 * p.kappa_c * h;
        // 2κH − 1 + e^{−2κH} = x + expm1(−x), accurate for small x.
        0.25 * p.r * p.r * (-p.kappa_c * h).exp() * (x + (-x).exp_m1())
    }

    /// R₂(H) = ½ r t (1 − (1 + 2κ_c H) e^{−2κ_c H}).
    pub fn r2(p: &OneDimensionalParams, h: f64) -> f64 {
        let x = 2.0 * p.kappa_c * h;
        // 1 − (1 + x) e^{−x}, accurate for small x.
        0.5 * p.r * p.t * (-(-x).exp_m1() - x * (-x).exp())
    }
}

/// Optical inputs of the model for one wavelength band.
#[derive(Clone, Debug)]
pub struct StratusOptics {
    /// Unmodified extinction κ, m⁻¹.
    pub extinction_per_m: f64,
    /// Forward-peak weight P_f (0 when the peak is not split off).
    pub forward_fraction: f64,
    /// P_S, sr⁻¹.
    pub peak_removed: PhaseTable,
    /// P_F, sr⁻¹ (unused when `forward_fraction` is 0).
    pub forward_peak: PhaseTable,
    /// P² of P_S, sr⁻¹.
    pub double: PhaseTable,
    /// Mean square angle of P_F, rad².
    pub forward_peak_mean_square_rad2: f64,
}

impl StratusOptics {
    /// Derives the model's inputs from a phase function `phase` (any
    /// normalisation), the unmodified extinction and the half-angle θ_f of the
    /// forward peak (0 keeps the whole phase function as P_S).
    pub fn from_phase(phase: &PhaseTable, extinction_per_m: f64, forward_peak_deg: f64) -> Self {
        let norm = phase.integral();
        let phase = PhaseTable::new(
            phase.angles_deg.clone(),
            phase.values.iter().map(|v| v / norm).collect(),
        );
        let (forward_fraction, peak_removed, forward_peak) = if forward_peak_deg > 0.0 {
            (
                phase.forward_fraction(forward_peak_deg),
                phase.peak_removed(forward_peak_deg),
                phase.forward_peak(forward_peak_deg),
            )
        } else {
            (0.0, phase.clone(), phase.clone())
        };
        let double = peak_removed.self_convolution(361, 120);
        let weighted = PhaseTable::new(
            forward_peak.angles_deg.clone(),
            forward_peak
                .angles_deg
                .iter()
                .zip(&forward_peak.values)
                .map(|(a, v)| v * a.to_radians().powi(2))
                .collect(),
        );
        let forward_peak_mean_square_rad2 =
            weighted.integral() / forward_peak.integral().max(1e-300);
        Self {
            extinction_per_m,
            forward_fraction,
            peak_removed,
            forward_peak,
            double,
            forward_peak_mean_square_rad2,
        }
    }

    /// κ_S = (1 − P_f) κ, m⁻¹.
    pub fn modified_extinction_per_m(&self) -> f64 {
        (1.0 - self.forward_fraction) * self.extinction_per_m
    }
}

/// Radiance of each order, per unit incident flux on the top, sr⁻¹.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlabRadiance {
    /// I₀_F (transmission only; the direct beam I₀d is a delta, reported as a flux).
    pub order0: f64,
    /// I₁.
    pub order1: f64,
    /// I₂.
    pub order2: f64,
    /// I₃₊.
    pub order3plus: f64,
    /// The sum.
    pub total: f64,
}

/// How the diffuse orders (3+) leave the slab (see the module notes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DiffuseExit {
    /// Isotropically, I₃₊ = R₃₊/π (Bouthors et al. 2006, §4.5).
    #[default]
    Lambertian,
    /// Transmitted orders 3+ by the escape function, I₃₊ = u(μ) T₃₊/π with
    /// u(μ) = (3/7)(1 + 2μ) (Chandrasekhar's H-function of conservative
    /// scattering, normalised); reflected ones Lambertian.
    EscapeFunction,
    /// Transmitted orders 3+ by the escape function; reflected ones by the
    /// shape traced in nimbus's Monte-Carlo slab, I₃₊ = A(θ_l, θ_v, φ)
    /// R₃₊/π ([`super::reflected_exit`]): thrown forward under a low sun.
    /// What `stratus.model = "marched"` draws.
    EscapeAndTracedReflection,
}

impl DiffuseExit {
    /// The factor on the transmitted T₃₊/π towards a direction at cosine
    /// `mu` to the slab's normal (dimensionless; its flux-weighted mean over
    /// the hemisphere is 1).
    pub fn weight(self, mu: f64) -> f64 {
        match self {
            Self::Lambertian => 1.0,
            Self::EscapeFunction | Self::EscapeAndTracedReflection => escape_function(mu),
        }
    }

    /// The factor on the reflected R₃₊/π towards a viewer at
    /// `view_zenith_deg` and `relative_azimuth_deg` from the sun's azimuth
    /// (0: the sun behind the viewer) under the sun at `sun_zenith_deg`
    /// (dimensionless; its flux-weighted mean over the hemisphere is 1).
    pub fn reflected_weight(
        self,
        sun_zenith_deg: f64,
        view_zenith_deg: f64,
        relative_azimuth_deg: f64,
    ) -> f64 {
        match self {
            Self::Lambertian | Self::EscapeFunction => 1.0,
            Self::EscapeAndTracedReflection => super::reflected_exit::reflected_shape(
                sun_zenith_deg,
                view_zenith_deg,
                relative_azimuth_deg,
            ),
        }
    }
}

/// The escape function u(μ) = (3/7)(1 + 2μ), μ clamped to [0, 1]:
/// ∫₀¹ u(μ) 2μ dμ = 1.
pub fn escape_function(mu: f64) -> f64 {
    3.0 / 7.0 * (1.0 + 2.0 * mu.clamp(0.0, 1.0))
}

/// The analytic stratiform model for one wavelength band.
#[derive(Clone, Debug)]
pub struct StratusModel {
    /// Phase functions and extinction.
    pub optics: StratusOptics,
    /// The 1-D model's parameters.
    pub table: OneDimensionalTable,
    /// How orders 3+ leave the slab.
    pub diffuse_exit: DiffuseExit,
}

/// (e^{−a/μ_v} − e^{−a/μ_l}) / (μ_v − μ_l), finite as μ_v → μ_l, where it
/// tends to (a/μ²) e^{−a/μ}.
pub fn exp_difference_quotient(a: f64, mu_v: f64, mu_l: f64) -> f64 {
    // e^{−a/μ_l} (e^{z} − 1)/(μ_v − μ_l) with z = a (μ_v − μ_l)/(μ_v μ_l).
    // Away from the limit the direct difference has no cancellation (and
    // the factored form would overflow for grazing μ).
    let z = a * (mu_v - mu_l) / (mu_v * mu_l);
    if z.abs() > 0.5 {
        return ((-a / mu_v).exp() - (-a / mu_l).exp()) / (mu_v - mu_l);
    }
    let ratio = if z.abs() < 1e-8 {
        1.0 + 0.5 * z
    } else {
        z.exp_m1() / z
    };
    (-a / mu_l).exp() * ratio * a / (mu_v * mu_l)
}

/// ((1 + a/μ_v) e^{−a/μ_v} − (1 + a/μ_l) e^{−a/μ_l}) / (μ_v − μ_l), finite
/// as μ_v → μ_l, where it tends to (a²/μ³) e^{−a/μ}.
fn poisson2_difference_quotient(a: f64, mu_v: f64, mu_l: f64) -> f64 {
    let g = |mu: f64| (1.0 + a / mu) * (-a / mu).exp();
    let limit = |mu: f64| a * a / (mu * mu * mu) * (-a / mu).exp();
    if (mu_v - mu_l).abs() < 1e-6 * mu_l {
        limit(0.5 * (mu_v + mu_l))
    } else {
        (g(mu_v) - g(mu_l)) / (mu_v - mu_l)
    }
}

/// Smallest cosine used for grazing directions (89.9°): keeps H/μ finite.
const MIN_MU: f64 = 1.745e-3;

impl StratusModel {
    /// The model with the paper's 1-D parameters and its Lambertian orders 3+.
    pub fn new(optics: StratusOptics) -> Self {
        Self {
            optics,
            table: OneDimensionalTable::bouthors_2006(),
            diffuse_exit: DiffuseExit::Lambertian,
        }
    }

    /// The same model with orders 3+ leaving as `diffuse_exit` says.
    pub fn with_diffuse_exit(mut self, diffuse_exit: DiffuseExit) -> Self {
        self.diffuse_exit = diffuse_exit;
        self
    }

    /// The 1-D model's fluxes for a slab of `thickness_m` under the sun at
    /// `sun_zenith_deg`.
    pub fn fluxes(&self, thickness_m: f64, sun_zenith_deg: f64) -> SlabFluxes {
        let p = self.table.at(sun_zenith_deg);
        let h = thickness_m.max(0.0);
        let mu_l = sun_zenith_deg.to_radians().cos().max(MIN_MU);
        let transmittance = one_dimensional::t_ms(&p, self.table.beta, h);
        let reflectance = 1.0 - transmittance;
        let t0 = (-self.optics.extinction_per_m * h / mu_l).exp();
        let t1 = one_dimensional::t1(&p, h);
        let t2 = one_dimensional::t2a(&p, h) + one_dimensional::t2b(&p, h);
        let r1 = one_dimensional::r1(&p, h);
        let r2 = one_dimensional::r2(&p, h);
        SlabFluxes {
            transmittance,
            reflectance,
            t0,
            t1,
            t2,
            t3plus: (transmittance - t0 - t1 - t2).max(0.0),
            r1,
            r2,
            r3plus: (reflectance - r1 - r2).max(0.0),
        }
    }

    /// The radiance towards `view` (zenith < 90°: reflected, > 90°:
    /// transmitted) of a slab of `thickness_m` under the sun at
    /// `sun_zenith_deg`, per unit incident flux on the top.
    pub fn radiance(
        &self,
        thickness_m: f64,
        sun_zenith_deg: f64,
        view: super::monte_carlo::ViewDirection,
    ) -> SlabRadiance {
        let h = thickness_m.max(0.0);
        let mu_l = sun_zenith_deg.to_radians().cos().max(MIN_MU);
        let mu_v = view.mu().max(MIN_MU);
        let cos_theta = super::monte_carlo::scattering_cosine(sun_zenith_deg, view);
        let theta_deg = cos_theta.clamp(-1.0, 1.0).acos().to_degrees();
        let o = &self.optics;
        let kappa_s = o.modified_extinction_per_m();
        let p_s = o.peak_removed.at(theta_deg);
        let p2 = o.double.at(theta_deg);
        let fluxes = self.fluxes(h, sun_zenith_deg);
        // The paper's radiances are per unit beam flux; dividing by μ_l makes
        // them per unit flux on the top.
        let (order0, order1, order2, order3plus) = if view.is_reflection() {
            let a = kappa_s * h * (1.0 / mu_l + 1.0 / mu_v);
            let geometry = 1.0 / (mu_v + mu_l);
            let single = -(-a).exp_m1();
            let double = -(-a).exp_m1() - a * (-a).exp();
            (
                0.0,
                p_s * geometry * single,
                0.5 * p2 * geometry * double,
                self.diffuse_exit.reflected_weight(
                    sun_zenith_deg,
                    view.zenith_deg,
                    view.relative_azimuth_deg,
                ) * fluxes.r3plus
                    / std::f64::consts::PI,
            )
        } else {
            let a = kappa_s * h;
            (
                self.forward_peak_radiance(h, mu_v, theta_deg) / mu_l,
                p_s * exp_difference_quotient(a, mu_v, mu_l),
                0.5 * p2 * poisson2_difference_quotient(a, mu_v, mu_l),
                self.diffuse_exit.weight(mu_v) * fluxes.t3plus / std::f64::consts::PI,
            )
        };
        SlabRadiance {
            order0,
            order1,
            order2,
            order3plus,
            total: order0 + order1 + order2 + order3plus,
        }
    }

    /// I_0F per unit beam flux (see the module notes).
    fn forward_peak_radiance(&self, h: f64, mu_v: f64, theta_deg: f64) -> f64 {
        let o = &self.optics;
        if o.forward_fraction <= 0.0 {
            return 0.0;
        }
        let path = h / mu_v;
        let survival = (-o.modified_extinction_per_m() * path).exp();
        let mean = o.forward_fraction * o.extinction_per_m * path;
        let theta = theta_deg.to_radians();
        let s2 = o.forward_peak_mean_square_rad2;
        let mut poisson = (-mean).exp(); // n = 0
        let mut sum = 0.0;
        let last = (mean + 10.0 * mean.sqrt() + 10.0).ceil() as usize;
        for n in 1..=last {
            poisson *= mean / n as f64;
            let peak = if n == 1 {
                o.forward_peak.at(theta_deg)
            } else {
                let variance = n as f64 * s2;
                (-theta * theta / variance).exp() / (std::f64::consts::PI * variance)
            };
            sum += poisson * peak;
        }
        survival * sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::monte_carlo::ViewDirection;

    /// The closed forms of appendix A equal numerical integration of the
    /// double integrals they come from.
    #[test]
    fn one_dimensional_closed_forms_match_quadrature() {
        let p = OneDimensionalTable::bouthors_2006().at(30.0);
        let (k, t, r) = (p.kappa_c, p.t, p.r);
        let s = |x: f64| k * (-k * x).exp();
        let tau = |x: f64| (-k * x).exp();
        for h in [5.0, 50.0, 400.0] {
            let n = 2000;
            let midpoints = |a: f64, b: f64, f: &dyn Fn(f64) -> f64| {
                let dx = (b - a) / n as f64;
                (0..n).map(|i| f(a + (i as f64 + 0.5) * dx)).sum::<f64>() * dx
            };
            let t1 = midpoints(0.0, h, &|l| s(l) * t * tau(h - l));
            let r1 = midpoints(0.0, h, &|l| s(l) * r * tau(l));
            let t2a = midpoints(0.0, h, &|l| {
                s(l) * t * midpoints(0.0, h - l, &|kk| s(kk) * t * tau(h - l - kk))
            });
            let t2b = midpoints(0.0, h, &|kk| {
                s(kk) * r * midpoints(0.0, kk, &|l| s(kk - l) * r * tau(h - l))
            });
            let r2 = 2.0
                * midpoints(0.0, h, &|l| {
                    s(l) * r * midpoints(0.0, l, &|kk| s(l - kk) * t * tau(kk))
                });
            for (name, closed, numeric) in [
                ("T1", one_dimensional::t1(&p, h), t1),
                ("R1", one_dimensional::r1(&p, h), r1),
                ("T2a", one_dimensional::t2a(&p, h), t2a),
                ("T2b", one_dimensional::t2b(&p, h), t2b),
                ("R2", one_dimensional::r2(&p, h), r2),
            ] {
                assert!(
                    (closed - numeric).abs() <= 1e-5 * numeric.abs().max(1e-3),
                    "{name} H={h}: {closed} vs {numeric}"
                );
            }
        }
        // T_ms doubles as the paper derives: T(2H) = T(H) / (2 − T(H)) for b = 1.
        let iso = OneDimensionalParams { b: 1.0, ..p };
        let beta = 0.9961;
        let t = one_dimensional::t_ms(&iso, beta, 100.0);
        let t2 = one_dimensional::t_ms(&iso, beta, 200.0);
        assert!((t2 - t / (2.0 - t)).abs() < 1e-12);
    }

    #[test]
    fn singular_and_grazing_geometries_stay_finite() {
        let hg = PhaseTable::from_fn(1801, |deg| {
            let c = deg.to_radians().cos();
            let g: f64 = 0.85;
            (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * c).powf(1.5))
        });
        let model = StratusModel::new(StratusOptics::from_phase(&hg, 0.0368, 5.0));
        for sun in [0.0, 45.0, 89.999, 90.0] {
            for zenith in [0.0, 45.0, 89.999, 90.0, 90.001, 134.0, 135.0, 136.0, 180.0] {
                for phi in [0.0, 180.0] {
                    let view = ViewDirection {
                        zenith_deg: zenith,
                        relative_azimuth_deg: phi,
                    };
                    for h in [0.0, 1.0, 100.0, 5000.0] {
                        let i = model.radiance(h, sun, view);
                        assert!(
                            i.total.is_finite() && i.total >= 0.0,
                            "sun {sun} view {zenith}/{phi} H {h}: {i:?}"
                        );
                    }
                }
            }
        }
        // The transmitted single scattering is continuous through μ_v = μ_l.
        let at = |z: f64| {
            model
                .radiance(
                    50.0,
                    45.0,
                    ViewDirection {
                        zenith_deg: z,
                        relative_azimuth_deg: 90.0,
                    },
                )
                .order1
        };
        let (below, on, above) = (at(134.999), at(135.0), at(135.001));
        assert!((below - on).abs() < 1e-4 * on && (above - on).abs() < 1e-4 * on);
    }

    #[test]
    fn difference_quotient_matches_its_limit_and_direct_evaluation() {
        let (a, mu_l): (f64, f64) = (2.0, 0.6);
        for mu_v in [0.3f64, 0.59, 0.6 + 1e-9, 0.9] {
            let direct = ((-a / mu_v).exp() - (-a / mu_l).exp()) / (mu_v - mu_l);
            let stable = exp_difference_quotient(a, mu_v, mu_l);
            assert!((stable - direct).abs() < 1e-6 * direct.abs(), "{mu_v}");
        }
        let limit = a / (mu_l * mu_l) * (-a / mu_l).exp();
        assert!((exp_difference_quotient(a, mu_l, mu_l) - limit).abs() < 1e-12);
    }
}
