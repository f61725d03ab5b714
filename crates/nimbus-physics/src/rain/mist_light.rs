//! The diffuse light that rain mist scatters towards the eye.
//!
//! Rain mist scatters with a forward-peaked phase function (Henyey–Greenstein
//! g = 0.85 in nimbus, standing in for the drops' diffraction peak; van de
//! Hulst 1957, §12–13): what it sends towards an eye looking along `d` is
//! mostly the light arriving from around `d`, not the mean of the field.
//! Under a cloud layer that field is far from uniform: the deck overhead is
//! bright, its light towards the horizon darkened by the escape function
//! u(μ) = (3/7)(1 + 2μ) ([`crate::transport::stratus::DiffuseExit`]), the
//! ground below dark. The source of the mist's single scattering of that
//! field, for an eye looking along a direction of vertical component `d_y`:
//!
//! S(d) = ∫ L(ω) p(ω·d) dω
//!      = (E↓/π) Σ_k a_k M_k(d_y) + (E↑/π) (1 − M₀(d_y)),
//!
//! with L(ω) = (E↓/π) Σ_k a_k ω_yᵏ from above (a = (1, 0) for a uniform sky,
//! (3/7, 6/7) for the escape function) and E↑/π from below (a Lambertian
//! ground), and the hemisphere moments of the phase function
//! M_k(d_y) = ∫_{ω_y > 0} ω_yᵏ p(ω·d) dω, k = 0, 1 (sr⁻¹ · sr: dimensionless).
//!
//! The moments reduce to one integral over the scattering angle Θ: around
//! `d`, the directions at angle Θ make a circle on which
//! ω_y = a + b cos φ, a = cos Θ d_y, b = sin Θ √(1 − d_y²); the part with
//! ω_y > 0 is |φ| < φ₀, cos φ₀ = −a/b, so the circle contributes φ₀/π to M₀
//! and (a φ₀ + b sin φ₀)/π to M₁. The remaining integral over Θ is taken at
//! stratified quantiles of the HG distribution of cos Θ (its inverse CDF),
//! so that the peak is sampled where the phase function puts its weight:
//! [`hg_hemisphere_moments`], which the mist shader evaluates per pixel with
//! the same quantiles (`passes/rain/mist.wgsl`).

/// δ-M's forward fraction f = g² of the mist's Henyey–Greenstein phase
/// function (g = 0.85; Wiscombe 1977, J. Atmos. Sci. 34, 1408; Joseph et
/// al. 1976): the part of what the mist scatters that leaves within about
/// 20° of its way. The mist shader (`passes/rain/mist.wgsl`) leaves it in
/// the eye's ray and in the sun's beam: along the view it attenuates by
/// (1 − f)β, so that a background smooth at the lobe's width (the deck's
/// bright cells towards the horizon, the far terrain) reaches the eye
/// as if unscattered; the diffuse field's source and the sun's single
/// scattering keep the whole phase function (the latter Nakajima & Tanaka
/// 1988's TMS correction, J. Quant. Spectrosc. Radiat. Transfer 40, 51).
/// Dimensionless.
pub const MIST_FORWARD_FRACTION: f64 =
    super::mist_slab::MIST_SLAB_ASYMMETRY * super::mist_slab::MIST_SLAB_ASYMMETRY;

/// Number of quantiles of cos Θ the shader uses (and the CPU twin by default).
pub const MIST_MOMENT_SAMPLES: usize = 24;

/// cos Θ of the Henyey–Greenstein distribution at cumulative probability
/// `xi` in [0, 1] (the inverse CDF; isotropic for |g| < 1e-3).
pub fn hg_inverse_cdf_cos(g: f64, xi: f64) -> f64 {
    if g.abs() < 1e-3 {
        return 1.0 - 2.0 * xi;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

/// The circle at scattering angle Θ (cosine `cos_theta`) around a direction
/// of vertical component `d_y`: its fraction above the horizon and the mean
/// of max(ω_y, 0) over it.
pub fn circle_above_horizon(cos_theta: f64, d_y: f64) -> (f64, f64) {
    let a = cos_theta * d_y;
    let b = (1.0 - cos_theta * cos_theta).max(0.0).sqrt() * (1.0 - d_y * d_y).max(0.0).sqrt();
    if b <= 1e-12 {
        return if a > 0.0 { (1.0, a) } else { (0.0, 0.0) };
    }
    let phi0 = (-a / b).clamp(-1.0, 1.0).acos();
    (
        phi0 / std::f64::consts::PI,
        (a * phi0 + b * phi0.sin()) / std::f64::consts::PI,
    )
}

/// The hemisphere moments (M₀, M₁) of the Henyey–Greenstein phase function
/// of asymmetry `g` around a direction of vertical component `d_y`: the
/// fraction of the scattered light that comes from above the horizon, and
/// that fraction weighted by the vertical cosine of its arrival
/// (see the module notes), with `samples` stratified quantiles.
pub fn hg_hemisphere_moments(g: f64, d_y: f64, samples: usize) -> (f64, f64) {
    let n = samples.max(1);
    let d_y = d_y.clamp(-1.0, 1.0);
    let (mut m0, mut m1) = (0.0, 0.0);
    for i in 0..n {
        let xi = (i as f64 + 0.5) / n as f64;
        let (f0, f1) = circle_above_horizon(hg_inverse_cdf_cos(g, xi), d_y);
        m0 += f0;
        m1 += f1;
    }
    (m0 / n as f64, m1 / n as f64)
}

/// The source S(d) of single scattering of a two-hemisphere diffuse field
/// (see the module notes), W·sr⁻¹·m⁻² per channel: irradiance `down_w_m2`
/// from above with angular shape coefficients `shape_above` (radiance
/// (E↓/π)(a₀ + a₁ ω_y)), `up_w_m2` from a Lambertian ground below.
pub fn diffuse_source(
    g: f64,
    d_y: f64,
    down_w_m2: f64,
    shape_above: [f64; 2],
    up_w_m2: f64,
    samples: usize,
) -> f64 {
    let (m0, m1) = hg_hemisphere_moments(g, d_y, samples);
    down_w_m2 / std::f64::consts::PI * (shape_above[0] * m0 + shape_above[1] * m1)
        + up_w_m2 / std::f64::consts::PI * (1.0 - m0)
}

/// The angular shape (a₀, a₁) of a uniform sky.
pub const UNIFORM_SKY: [f64; 2] = [1.0, 0.0];
/// The angular shape (a₀, a₁) of light leaving a cloud deck's base by the
/// escape function (3/7)(1 + 2μ).
pub const ESCAPE_FUNCTION: [f64; 2] = [3.0 / 7.0, 6.0 / 7.0];

/// Eddington's two-stream coefficient γ₁ = γ₂ = ¾(1 − g) of a conservative
/// medium of asymmetry g (Meador & Weaver 1980, table 1; for ω = 1 the
/// δ-Eddington scaling leaves γτ unchanged).
fn eddington_gamma(asymmetry: f64) -> f64 {
    0.75 * (1.0 - asymmetry)
}

/// The diffuse reflectance of a cloud deck's base for light from below: a
/// conservative slab of optical depth `optical_depth` and asymmetry
/// `asymmetry` in Eddington's two-stream approximation, 1 − 1/(1 + γτ)
/// (the complement of [`crate::cumulus::shading::two_stream_transmittance`]).
pub fn deck_diffuse_reflectance(optical_depth: f64, asymmetry: f64) -> f64 {
    1.0 - crate::cumulus::shading::two_stream_transmittance(optical_depth, asymmetry)
}

/// The diffuse light in a rain mist that fills the air from the ground to a
/// cloud deck's base: the downward and upward fluxes `[F↓, F↑]` at optical
/// depth `depth_optical_depth` below the deck, relative to the downward flux
/// E the same column has without the mist.
///
/// Without mist the ground gets E (under a layer the radiosity's R_G: the
/// deck's own light and the ground–cloud inter-reflections) and sends ρE
/// back up: `[1, ρ]` at every height. Raindrops hardly absorb in the
/// visible, so a mist of vertical optical depth τ_m (`column_optical_depth`,
/// ground to base) diffuses that light without losing it. In Eddington's
/// two-stream equations for a conservative medium (γ from
/// `asymmetry`: γ = ¾(1 − g)) the net flux F = F↓ − F↑ is the
/// same at every depth and F↓ falls linearly, F↓(τ) = E₀ − γFτ, E₀ the
/// flux entering at the base. The ground, of albedo ρ (`ground_albedo`),
/// absorbs F = (1 − ρ)F↓(τ_m), so F↓(τ_m) = aE₀ with
/// a = 1/(1 + γ(1 − ρ)τ_m); the mist sends E₀ − F back up, more than the
/// ground alone, and the deck's base (diffuse reflectance R_c,
/// `deck_reflectance`, e.g. [`deck_diffuse_reflectance`]) returns R_c of
/// it: E₀ = E_t + R_c(E₀ − F), E_t the deck's own light. Relative to the
/// column without mist, E = E_t/(1 − R_c ρ):
///
/// F↓(τ)/E = s (1 − γ(1 − ρ)aτ), F↑(τ)/E = s (1 − γ(1 − ρ)aτ − (1 − ρ)a),
/// s = (1 − R_c ρ)/(1 − R_c (1 − (1 − ρ)a)).
///
/// So a thick mist darkens the air near the ground (heavy rain's τ_m ≈ 3.7:
/// 0.88 of the clear column's light at the ground under a deck of R_c 0.6
/// over a ground of 0.1) and lightens it near the base. The ground and the
/// base are taken as Lambertian and the fluxes as hemispherically
/// isotropic between them, as the ground–cloud radiosity takes them
/// (Bouthors et al. 2006, §5). The mist's fluxes agree with the
/// adding–doubling slab's; the angular shapes the shader once gave them
/// did not (the slab's own field replaced them: [`super::mist_slab`]), and
/// the function stays as the closed-form two-stream check of the slab.
pub fn diffuse_fluxes_in_mist(
    column_optical_depth: f64,
    depth_optical_depth: f64,
    asymmetry: f64,
    ground_albedo: f64,
    deck_reflectance: f64,
) -> [f64; 2] {
    let gamma = eddington_gamma(asymmetry);
    let rho = ground_albedo.clamp(0.0, 1.0);
    let deck = deck_reflectance.clamp(0.0, 1.0);
    let column = column_optical_depth.max(0.0);
    let depth = depth_optical_depth.clamp(0.0, column);
    let absorbed = 1.0 - rho;
    let a = 1.0 / (1.0 + gamma * absorbed * column);
    let scale = (1.0 - deck * rho) / (1.0 - deck * (1.0 - absorbed * a)).max(1e-9);
    let down = scale * (1.0 - gamma * absorbed * a * depth);
    [down, down - scale * absorbed * a]
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Without mist the column keeps its light, `[1, ρ]` at every depth;
    /// with it the net flux is the same at every depth, the ground takes
    /// (1 − ρ) of what reaches it, and the light falls from the base to the
    /// ground.
    #[test]
    fn mist_diffuses_the_columns_light_without_losing_it() {
        for rho in [0.0, 0.1, 0.8] {
            let [down, up] = diffuse_fluxes_in_mist(0.0, 0.0, 0.85, rho, 0.6);
            assert!((down - 1.0).abs() < 1e-12 && (up - rho).abs() < 1e-12);
        }
        let (column, g, rho, deck) = (3.7, 0.85, 0.1, 0.6);
        let net = |t: f64| {
            let [d, u] = diffuse_fluxes_in_mist(column, t, g, rho, deck);
            d - u
        };
        let [bottom_down, bottom_up] = diffuse_fluxes_in_mist(column, column, g, rho, deck);
        assert!((bottom_up - rho * bottom_down).abs() < 1e-12);
        for t in [0.0, 1.0, 2.5, column] {
            assert!((net(t) - (1.0 - rho) * bottom_down).abs() < 1e-12);
        }
        let top = diffuse_fluxes_in_mist(column, 0.0, g, rho, deck)[0];
        assert!(top > 1.0 && bottom_down < 1.0, "{top} {bottom_down}");
        // Flux into the column from above minus what leaves it upward is
        // what the ground absorbs: nothing is lost in the mist.
        let [top_down, top_up] = diffuse_fluxes_in_mist(column, 0.0, g, rho, deck);
        assert!((top_down - top_up - (1.0 - rho) * bottom_down).abs() < 1e-12);
    }

    /// Against the adding–doubling reference: a Henyey–Greenstein mist slab
    /// (its diffuse reflectance and transmittance averaged over a
    /// cosine-weighted hemisphere of incidence) between a Lambertian ground
    /// and a Lambertian deck base, composed by flux adding. The two-stream
    /// light at the ground is within 5 % of it up to heavy rain's optical
    /// depth and beyond.
    #[test]
    fn the_mists_light_at_the_ground_follows_the_adding_doubling_reference() {
        use crate::transport::adding_doubling::{DoublingSettings, slab_fluxes};
        use crate::transport::phase_model::PhaseModel;
        let g = 0.85;
        let phase = PhaseModel::HenyeyGreenstein { g };
        // Gauss–Legendre nodes on μ₀ ∈ (0, 1) for ∫ 2μ₀ f(μ₀) dμ₀.
        let nodes: [(f64, f64); 7] = [
            (0.025_446_043_828_620_8, 0.064_742_483_084_434_8),
            (0.129_234_407_200_302_8, 0.139_852_695_744_638_3),
            (0.297_077_424_311_301_4, 0.190_915_025_252_559_5),
            (0.5, 0.208_979_591_836_734_7),
            (0.702_922_575_688_698_6, 0.190_915_025_252_559_5),
            (0.870_765_592_799_697_2, 0.139_852_695_744_638_3),
            (0.974_553_956_171_379_2, 0.064_742_483_084_434_8),
        ];
        for (column, rho, deck) in [
            (1.0, 0.1, 0.6),
            (3.7, 0.1, 0.6),
            (3.7, 0.3, 0.5),
            (8.0, 0.1, 0.7),
        ] {
            let (mut r_d, mut t_d) = (0.0, 0.0);
            for (mu, w) in nodes {
                let f = slab_fluxes(
                    column,
                    1.0,
                    &phase,
                    mu.acos().to_degrees(),
                    DoublingSettings::default(),
                );
                r_d += 2.0 * mu * w * f.reflectance;
                t_d += 2.0 * mu * w * f.transmittance;
            }
            // Deck's own light 1; E₀ = 1 + R_c F↑(top).
            let system_up = r_d + t_d * t_d * rho / (1.0 - rho * r_d);
            let entering = 1.0 / (1.0 - deck * system_up);
            let ground_down = t_d * entering / (1.0 - rho * r_d);
            let reference = ground_down * (1.0 - deck * rho);
            let [model, _] = diffuse_fluxes_in_mist(column, column, g, rho, deck);
            assert!(
                (model / reference - 1.0).abs() < 0.05,
                "τ_m {column} ρ {rho} R_c {deck}: two-stream {model:.4}, adding–doubling {reference:.4}"
            );
        }
    }

    /// Henyey–Greenstein, normalised to 1 over the sphere.
    fn hg(g: f64, cos_theta: f64) -> f64 {
        (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * cos_theta).powf(1.5))
    }

    /// The moments (M₀, M₁) of a phase function of cos Θ (normalised to 1
    /// over the sphere) around a direction of vertical component `d_y`, by
    /// brute force: a fine grid over the sphere of arrival directions
    /// (1200 × 2400 cells, uniform in ω_y and azimuth).
    pub(crate) fn brute_force_moments(phase: impl Fn(f64) -> f64, d_y: f64) -> (f64, f64) {
        let d = [(1.0 - d_y * d_y).max(0.0).sqrt(), d_y, 0.0];
        let (nu, nphi) = (1200, 2400);
        let cell = (1.0 / nu as f64) * (2.0 * std::f64::consts::PI / nphi as f64);
        let (mut m0, mut m1) = (0.0, 0.0);
        for i in 0..nu {
            let wy = (i as f64 + 0.5) / nu as f64;
            let r = (1.0 - wy * wy).sqrt();
            for j in 0..nphi {
                let phi = (j as f64 + 0.5) * 2.0 * std::f64::consts::PI / nphi as f64;
                let p = phase(r * phi.cos() * d[0] + wy * d[1]) * cell;
                m0 += p;
                m1 += p * wy;
            }
        }
        (m0, m1)
    }

    fn brute_force(g: f64, d_y: f64) -> (f64, f64) {
        brute_force_moments(|c| hg(g, c), d_y)
    }

    /// The shader's 24 quantiles match brute-force integration over the
    /// sphere to 1 % of M₀ (and 0.005 absolute) for the mist's g = 0.85,
    /// a milder g and isotropic scattering, at every elevation.
    #[test]
    fn quantile_moments_match_brute_force() {
        for g in [0.85, 0.5, 0.0] {
            for d_y in [-0.9, -0.3, -0.05, 0.0, 0.1, 0.4, 0.95] {
                let (m0, m1) = hg_hemisphere_moments(g, d_y, MIST_MOMENT_SAMPLES);
                let (b0, b1) = brute_force(g, d_y);
                assert!(
                    (m0 - b0).abs() < 0.01 * b0.max(0.5) && (m1 - b1).abs() < 0.005,
                    "g {g}, d_y {d_y}: quantiles ({m0:.4}, {m1:.4}), brute force ({b0:.4}, {b1:.4})"
                );
            }
        }
    }

    /// Limits: isotropic scattering sees half the sphere above the horizon
    /// (M₀ = ½, M₁ = ¼), whatever the direction; g = 0.85 looking straight
    /// up takes 96 % of its light from above (its tail reaches past 90°:
    /// M₀ = (1 − g²)/(2g)·(1/(1 − g) − 1/√(1 + g²)) = 0.964, the HG
    /// distribution's mass at cos Θ > 0), straight down the rest, 3.6 %; a uniform field of
    /// radiance L from everywhere gives S = L.
    #[test]
    fn moments_have_the_right_limits() {
        for d_y in [-0.7, 0.0, 0.6] {
            let (m0, m1) = hg_hemisphere_moments(0.0, d_y, 4000);
            assert!(
                (m0 - 0.5).abs() < 1e-3 && (m1 - 0.25).abs() < 1e-3,
                "{m0} {m1}"
            );
        }
        let g: f64 = 0.85;
        let above = (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 - g) - 1.0 / (1.0 + g * g).sqrt());
        let below = 1.0 - above;
        let (up0, up1) = hg_hemisphere_moments(g, 1.0, 4000);
        assert!(
            (up0 - (1.0 - below)).abs() < 1e-3 && up1 > 0.8,
            "{up0} {up1}, below {below}"
        );
        let (down0, _) = hg_hemisphere_moments(g, -1.0, 4000);
        assert!((down0 - below).abs() < 1e-3, "{down0}, below {below}");
        let e = std::f64::consts::PI * 3.0;
        for d_y in [-0.5, 0.0, 0.5] {
            let s = diffuse_source(0.85, d_y, e, UNIFORM_SKY, e, 64);
            assert!((s - 3.0).abs() < 1e-9, "{s}");
        }
    }

    /// The escape function's shape carries the same flux as a uniform sky
    /// (∫ (a₀ + a₁ μ) μ dω = π for both), and towards the horizon the mist
    /// under a deck is darker than the field's mean radiance: with the
    /// ground at albedo 0.1, (E↓ + E↑)/(2π) overestimates it by half.
    #[test]
    fn under_a_deck_the_horizon_mist_is_darker_than_the_mean() {
        let flux = |a: [f64; 2]| a[0] * 0.5 + a[1] / 3.0;
        assert!((flux(ESCAPE_FUNCTION) - flux(UNIFORM_SKY)).abs() < 1e-12);
        let down = std::f64::consts::PI;
        let up = 0.1 * down;
        let mean = (down + up) / (2.0 * std::f64::consts::PI);
        let horizon = diffuse_source(0.85, 0.0, down, ESCAPE_FUNCTION, up, MIST_MOMENT_SAMPLES);
        assert!(horizon < 0.75 * mean, "horizon {horizon}, mean {mean}");
        let zenith = diffuse_source(0.85, 1.0, down, ESCAPE_FUNCTION, up, MIST_MOMENT_SAMPLES);
        assert!(zenith > 1.1 * mean, "zenith {zenith}, mean {mean}");
    }
}
