//! The air under a cloud layer: what it scatters towards the eye.
//!
//! Clear air scatters the sun's light once (the aureole around the sun, the
//! blue of distant hills) and the sky's light again (Hillaire 2020's
//! Ψ_ms σ_s). Under an overcast neither is there: the sun reaches the air
//! only through the layer (its directional transmittance T_C, the layer's
//! shadow), and the sky's light is replaced by the layer's diffuse light
//! from above and the ground's from below. The air scatters that field by
//! its own phase functions, Rayleigh for the molecules and Cornette–Shanks
//! for the aerosols, so along a path of air with the weights of
//! [`super::AirPath`] (W_X = ∫ σ_X T ds) the light scattered in is
//!
//! L = T_C L_sun + Σ_X W_X S_X(d),
//! S_X(d) = (E↓/π)(a₀ M₀ˣ(d_y) + a₁ M₁ˣ(d_y)) + (E↑/π)(1 − M₀ˣ(d_y)),
//!
//! for a field of irradiance E↓ from above with the angular shape a₀ + a₁μ
//! (the escape function of a deck's base, (3/7)(1 + 2μ), or a uniform sky)
//! and E↑ from a Lambertian ground, M_k the phase function's hemisphere
//! moments around the view direction d (as for the rain's mist,
//! [`crate::rain::mist_light`], which derives them).
//!
//! The moments: Rayleigh's in closed form (the azimuthal mean of
//! (ω·d)² is ω_y² d_y² + (1 − ω_y²)(1 − d_y²)/2), M₀ = ½ and
//! M₁ = 3(5 + d_y²)/64; Cornette–Shanks's at the stratified quantiles of the
//! Henyey–Greenstein distribution of the same g, each weighted by the ratio
//! of the two phase functions, (3/2)(1 + cos²Θ)/(2 + g²) (importance
//! sampling; the weights normalised to their sum).

use crate::rain::mist_light::{circle_above_horizon, hg_inverse_cdf_cos};

/// Number of quantiles of cos Θ the shaders use for the aerosols' moments.
pub const AEROSOL_MOMENT_SAMPLES: usize = 24;

/// The hemisphere moments (M₀, M₁) of the Rayleigh phase function around
/// a direction of vertical component `d_y` (closed form; module notes).
pub fn rayleigh_hemisphere_moments(d_y: f64) -> (f64, f64) {
    let d2 = d_y.clamp(-1.0, 1.0).powi(2);
    // M₁ changes sign with the view's vertical direction only through d²:
    // Rayleigh scattering is symmetric front to back.
    (0.5, 3.0 * (5.0 + d2) / 64.0)
}

/// The hemisphere moments (M₀, M₁) of the Cornette–Shanks phase function of
/// asymmetry `g` around a direction of vertical component `d_y`, with
/// `samples` weighted quantiles of Henyey–Greenstein (module notes).
pub fn cornette_shanks_hemisphere_moments(g: f64, d_y: f64, samples: usize) -> (f64, f64) {
    let n = samples.max(1);
    let d_y = d_y.clamp(-1.0, 1.0);
    let (mut m0, mut m1, mut total) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let cos_theta = hg_inverse_cdf_cos(g, (i as f64 + 0.5) / n as f64);
        let weight = 1.5 * (1.0 + cos_theta * cos_theta) / (2.0 + g * g);
        let (f0, f1) = circle_above_horizon(cos_theta, d_y);
        m0 += weight * f0;
        m1 += weight * f1;
        total += weight;
    }
    (m0 / total, m1 / total)
}

/// The source S(d) of a two-hemisphere diffuse field for a phase function
/// of hemisphere moments `moments` (sr⁻¹ · sr: the radiance scattered per
/// unit scattering weight), W·sr⁻¹·m⁻²: irradiance `down_w_m2` from above
/// of angular shape `shape_above` (radiance (E↓/π)(a₀ + a₁ ω_y)),
/// `up_w_m2` from a Lambertian ground below.
pub fn source_from_moments(
    moments: (f64, f64),
    down_w_m2: f64,
    shape_above: [f64; 2],
    up_w_m2: f64,
) -> f64 {
    let (m0, m1) = moments;
    down_w_m2 / std::f64::consts::PI * (shape_above[0] * m0 + shape_above[1] * m1)
        + up_w_m2 / std::f64::consts::PI * (1.0 - m0)
}

/// The air's weights for a diffuse field, per channel (dimensionless):
/// with a field of irradiance E↓ from above of angular shape (a₀, a₁) and
/// E↑ from the ground, the light scattered in is
/// (E↓/π)(a₀ A₀ + a₁ A₁) + (E↑/π)(W − A₀) ([`diffuse_inscatter`]).
/// The atmosphere pass stores them per froxel, so that the drawing passes
/// need no phase-function moments per pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiffuseWeights {
    /// A₀ = Σ_X W_X M₀ˣ: the weight of the light from above.
    pub above: [f64; 3],
    /// A₁ = Σ_X W_X M₁ˣ: its weight by the arrival's vertical cosine.
    pub above_cosine: [f64; 3],
    /// W = Σ_X W_X: all the scattering weight.
    pub total: [f64; 3],
}

/// The [`DiffuseWeights`] of the air of `path` for a view of vertical
/// component `d_y`, aerosols of asymmetry `g`.
pub fn diffuse_weights(path: &super::AirPath, g: f64, d_y: f64) -> DiffuseWeights {
    let rayleigh = rayleigh_hemisphere_moments(d_y);
    let aerosol = cornette_shanks_hemisphere_moments(g, d_y, AEROSOL_MOMENT_SAMPLES);
    let (wr, wm) = (path.rayleigh_weight, path.mie_weight);
    DiffuseWeights {
        above: [0, 1, 2].map(|c| wr[c] * rayleigh.0 + wm[c] * aerosol.0),
        above_cosine: [0, 1, 2].map(|c| wr[c] * rayleigh.1 + wm[c] * aerosol.1),
        total: [0, 1, 2].map(|c| wr[c] + wm[c]),
    }
}

/// The light the air scatters towards the eye from a diffuse field (per
/// channel, W·sr⁻¹·m⁻²): Σ_X W_X S_X(d) of the module notes, from the
/// air's [`DiffuseWeights`].
pub fn diffuse_inscatter(
    weights: &DiffuseWeights,
    down_w_m2: [f64; 3],
    shape_above: [f64; 2],
    up_w_m2: [f64; 3],
) -> [f64; 3] {
    let pi = std::f64::consts::PI;
    [0, 1, 2].map(|c| {
        down_w_m2[c] / pi
            * (shape_above[0] * weights.above[c] + shape_above[1] * weights.above_cosine[c])
            + up_w_m2[c] / pi * (weights.total[c] - weights.above[c])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atmosphere::{cornette_shanks_phase, rayleigh_phase};
    use crate::rain::mist_light::{ESCAPE_FUNCTION, UNIFORM_SKY};

    use crate::rain::mist_light::tests::brute_force_moments as brute_force;

    /// Rayleigh's closed form and the weighted quantiles of
    /// Cornette–Shanks (the atmosphere's aerosol g = 0.8, a milder one, and
    /// g = 0, which is Rayleigh) match brute-force integration over the
    /// sphere within 1 % of M₀ and 0.005 of M₁, at every elevation.
    #[test]
    fn moments_match_brute_force() {
        for d_y in [-0.9, -0.3, 0.0, 0.1, 0.5, 0.97] {
            let (m0, m1) = rayleigh_hemisphere_moments(d_y);
            let (b0, b1) = brute_force(rayleigh_phase, d_y);
            assert!(
                (m0 - b0).abs() < 0.005 && (m1 - b1).abs() < 0.002,
                "Rayleigh, d_y {d_y}: ({m0:.4}, {m1:.4}) against ({b0:.4}, {b1:.4})"
            );
            for g in [0.8, 0.5, 0.0] {
                let (m0, m1) = cornette_shanks_hemisphere_moments(g, d_y, AEROSOL_MOMENT_SAMPLES);
                let (b0, b1) = brute_force(|c| cornette_shanks_phase(c, g), d_y);
                assert!(
                    (m0 - b0).abs() < 0.01 * b0.max(0.5) && (m1 - b1).abs() < 0.005,
                    "Cornette–Shanks g {g}, d_y {d_y}: ({m0:.4}, {m1:.4}) against ({b0:.4}, {b1:.4})"
                );
            }
        }
    }

    /// A uniform field of radiance L from everywhere is scattered as L by
    /// either phase function; under a deck (the escape function's shape,
    /// a dark ground) the air towards the horizon is darker than looking
    /// up, and the forward-peaked aerosols more so than the molecules.
    #[test]
    fn the_diffuse_source_has_the_right_limits() {
        let pi = std::f64::consts::PI;
        let path = crate::atmosphere::AirPath {
            rayleigh_weight: [0.3, 0.2, 0.1],
            mie_weight: [0.05, 0.05, 0.05],
            ..Default::default()
        };
        let weights = diffuse_weights(&path, 0.8, 0.2);
        let uniform = diffuse_inscatter(&weights, [2.0 * pi; 3], UNIFORM_SKY, [2.0 * pi; 3]);
        for (c, value) in uniform.iter().enumerate() {
            let expected = 2.0 * (path.rayleigh_weight[c] + path.mie_weight[c]);
            assert!(
                (value - expected).abs() < 1e-3 * expected,
                "{c}: {value} vs {expected}"
            );
        }
        let source = |moments| source_from_moments(moments, pi, ESCAPE_FUNCTION, 0.1 * pi);
        let rayleigh = |d_y| source(rayleigh_hemisphere_moments(d_y));
        let aerosol = |d_y| source(cornette_shanks_hemisphere_moments(0.8, d_y, 24));
        assert!(rayleigh(0.0) < rayleigh(1.0) && aerosol(0.0) < aerosol(1.0));
        assert!(aerosol(1.0) / aerosol(0.0) > rayleigh(1.0) / rayleigh(0.0));
        // The weights give what the two phase functions give apart.
        let d_y = 0.3;
        let (down, up) = ([3.0, 2.0, 1.0], [0.3, 0.2, 0.1]);
        let by_weights =
            diffuse_inscatter(&diffuse_weights(&path, 0.8, d_y), down, ESCAPE_FUNCTION, up);
        for c in 0..3 {
            let apart = path.rayleigh_weight[c]
                * source_from_moments(
                    rayleigh_hemisphere_moments(d_y),
                    down[c],
                    ESCAPE_FUNCTION,
                    up[c],
                )
                + path.mie_weight[c]
                    * source_from_moments(
                        cornette_shanks_hemisphere_moments(0.8, d_y, AEROSOL_MOMENT_SAMPLES),
                        down[c],
                        ESCAPE_FUNCTION,
                        up[c],
                    );
            assert!(
                (by_weights[c] - apart).abs() < 1e-12 * apart.abs().max(1.0),
                "{c}"
            );
        }
    }
}
