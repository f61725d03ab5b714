// The hemisphere moments of phase functions around a view direction: how
// much of the light a medium scatters towards an eye comes from above the
// horizon, and weighted by its arrival's vertical cosine. The rain's mist
// (Henyey–Greenstein; CPU twin nimbus_physics::rain::mist_light) and the
// air under a cloud layer (Rayleigh, Cornette–Shanks; CPU twin
// nimbus_physics::atmosphere::under_layer) scatter diffuse light with them.
// Self-contained: tests compose it with a kernel.

const MOMENTS_PI: f32 = 3.14159265358979;
const MOMENT_SAMPLES: u32 = 24u;

// cos Θ of the Henyey–Greenstein distribution at cumulative probability xi.
fn hg_inverse_cdf_cos(g: f32, xi: f32) -> f32 {
    if (abs(g) < 1e-3) {
        return 1.0 - 2.0 * xi;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
    return clamp((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0);
}

// (M₀, M₁): the fraction of the light scattered towards an eye looking
// along a direction of vertical component `d_y` that arrives from above
// the horizon, and that fraction weighted by its arrival's vertical cosine.
// Each quantile of cos Θ is a circle around the view direction, on which
// ω_y = a + b cos φ; its part above the horizon, |φ| < φ₀, is integrated
// in closed form.
fn hg_hemisphere_moments(g: f32, d_y: f32) -> vec2<f32> {
    let dy = clamp(d_y, -1.0, 1.0);
    var m = vec2<f32>(0.0);
    for (var i = 0u; i < MOMENT_SAMPLES; i++) {
        m += circle_above_horizon(hg_inverse_cdf_cos(g, (f32(i) + 0.5) / f32(MOMENT_SAMPLES)), dy);
    }
    return m / f32(MOMENT_SAMPLES);
}

// The part of the circle at scattering angle Θ (cosine c) around a
// direction of vertical component dy above the horizon: (its fraction,
// the mean of max(ω_y, 0) over it).
fn circle_above_horizon(c: f32, dy: f32) -> vec2<f32> {
    let a = c * dy;
    let b = sqrt(max(1.0 - c * c, 0.0)) * sqrt(max(1.0 - dy * dy, 0.0));
    if (b <= 1e-6) {
        return select(vec2<f32>(0.0), vec2<f32>(1.0, a), a > 0.0);
    }
    let phi0 = acos(clamp(-a / b, -1.0, 1.0));
    return vec2<f32>(phi0, a * phi0 + b * sin(phi0)) / MOMENTS_PI;
}

// (M₀, M₁) of the Cornette–Shanks phase function: the quantiles of
// Henyey–Greenstein of the same g, each weighted by the ratio of the two,
// (3/2)(1 + cos²Θ)/(2 + g²).
fn cornette_shanks_hemisphere_moments(g: f32, d_y: f32) -> vec2<f32> {
    let dy = clamp(d_y, -1.0, 1.0);
    var m = vec2<f32>(0.0);
    var total = 0.0;
    for (var i = 0u; i < MOMENT_SAMPLES; i++) {
        let c = hg_inverse_cdf_cos(g, (f32(i) + 0.5) / f32(MOMENT_SAMPLES));
        let weight = 1.5 * (1.0 + c * c) / (2.0 + g * g);
        m += weight * circle_above_horizon(c, dy);
        total += weight;
    }
    return m / total;
}

// (M₀, M₁) of the Rayleigh phase function, in closed form: ½ and
// 3(5 + d_y²)/64.
fn rayleigh_hemisphere_moments(d_y: f32) -> vec2<f32> {
    let d = clamp(d_y, -1.0, 1.0);
    return vec2<f32>(0.5, 3.0 * (5.0 + d * d) / 64.0);
}

// The diffuse reflectance of a cloud deck's base for light from below, a
// conservative slab of optical depth `tau` and asymmetry `g` in
// Eddington's two-stream approximation: 1 − 1/(1 + ¾(1 − g)τ). Twin of
// nimbus_physics::rain::mist_light::deck_diffuse_reflectance.
fn mist_deck_reflectance(tau: f32, g: f32) -> f32 {
    return 1.0 - 1.0 / (1.0 + 0.75 * (1.0 - g) * max(tau, 0.0));
}
