// The diffuse light the rain mist scatters towards the eye: the hemisphere
// moments of its Henyey–Greenstein phase function around the view
// direction (nimbus_physics::rain::mist_light, the CPU twin, tested
// against it and against brute-force integration). Self-contained.

const MIST_LIGHT_PI: f32 = 3.14159265358979;
const MIST_MOMENT_SAMPLES: u32 = 24u;

// cos Θ of the Henyey–Greenstein distribution at cumulative probability xi.
fn mist_hg_inverse_cdf_cos(g: f32, xi: f32) -> f32 {
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
fn mist_hemisphere_moments(g: f32, d_y: f32) -> vec2<f32> {
    let dy = clamp(d_y, -1.0, 1.0);
    let across = sqrt(max(1.0 - dy * dy, 0.0));
    var m = vec2<f32>(0.0);
    for (var i = 0u; i < MIST_MOMENT_SAMPLES; i++) {
        let c = mist_hg_inverse_cdf_cos(g, (f32(i) + 0.5) / f32(MIST_MOMENT_SAMPLES));
        let a = c * dy;
        let b = sqrt(max(1.0 - c * c, 0.0)) * across;
        if (b <= 1e-6) {
            if (a > 0.0) {
                m += vec2<f32>(1.0, a);
            }
            continue;
        }
        let phi0 = acos(clamp(-a / b, -1.0, 1.0));
        m += vec2<f32>(phi0, a * phi0 + b * sin(phi0)) / MIST_LIGHT_PI;
    }
    return m / f32(MIST_MOMENT_SAMPLES);
}
