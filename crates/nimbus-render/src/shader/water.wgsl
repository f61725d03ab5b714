// import shader/atmosphere_lookup.wgsl
// Shading of an open water surface: Fresnel reflection of the sky and the
// sun (a GGX microfacet lobe), and the diffuse light from under the surface.
// Needs common.wgsl and the atmosphere lookups (atmosphere_lookup.wgsl),
// and two functions from the including pass, which knows what lies above the
// water: `water_reflection_source(position_m, direction) -> vec3<f32>`, the
// radiance arriving at the surface from a direction above it, and
// `water_sky_irradiance(position_m) -> vec3<f32>`, the diffuse irradiance on
// the horizontal surface.

// Schlick's approximation with the normal-incidence reflectance of water, 0.02 (n = 1.33).
fn water_fresnel(cos_theta: f32) -> f32 {
    let m = 1.0 - clamp(cos_theta, 0.0, 1.0);
    return 0.02 + 0.98 * m * m * m * m * m;
}

// GGX / Trowbridge–Reitz normal distribution (Walter et al., EGSR 2007, eq. 33), per sr.
fn ggx_distribution(cos_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// GGX roughness of the sun's glint on water (a calm sea's glitter path a few
// degrees long). `nimbus export --mitsuba` gives the sea the same
// microfacet lobe (nimbus_render::shader::WATER_GGX_ALPHA, held equal to
// this by a test).
const WATER_GGX_ALPHA: f32 = 0.06;

// Small capillary ripples: a normal perturbation from a few travelling sine
// waves, so that the surface is smooth but not a perfect mirror. Each wave
// fades out where a pixel's footprint on the water covers half its
// wavelength, which would otherwise alias into moiré.
fn water_normal(position_m: vec3<f32>, footprint_m: f32) -> vec3<f32> {
    let p = position_m.xz;
    let t = frame.time_s;
    var slope = vec2<f32>(0.0);
    let dirs = array<vec2<f32>, 4>(
        vec2<f32>(0.8, 0.6), vec2<f32>(-0.6, 0.8), vec2<f32>(0.96, -0.28), vec2<f32>(-0.28, -0.96));
    let wavelengths = array<f32, 4>(9.0, 5.3, 3.1, 1.7);
    for (var k = 0u; k < 4u; k = k + 1u) {
        let kw = 2.0 * PI / wavelengths[k];
        // Deep-water dispersion ω = √(g k) sets the phase speed.
        let omega = sqrt(9.81 * kw);
        let resolved = clamp(1.0 - 2.0 * footprint_m / wavelengths[k], 0.0, 1.0);
        slope += dirs[k] * 0.025 * resolved * cos(kw * dot(dirs[k], p) - omega * t);
    }
    return normalize(vec3<f32>(-slope.x, 1.0, -slope.y));
}

// Radiance leaving the water surface at `position_m` towards the camera;
// `sun_visibility` is the fraction of the sun's light that reaches it (solar
// disk above the relief, through any cloud), per channel.
fn water_radiance(position_m: vec3<f32>, diffuse_albedo: vec3<f32>, sun_visibility: vec3<f32>) -> vec3<f32> {
    let to_eye = to_eye_world(position_m);
    // Length of a pixel's footprint along the view on a horizontal surface.
    let footprint_m = pixel_footprint_m(eye_distance_m(position_m)) / max(abs(to_eye.y), 0.02);
    let n = water_normal(position_m, footprint_m);
    let cos_v = max(dot(n, to_eye), 1e-3);
    let fresnel = water_fresnel(cos_v);
    var r = reflect(-to_eye, n);
    r.y = max(r.y, 0.0);
    let reflected_sky = water_reflection_source(position_m, normalize(r)) * fresnel;

    let l = frame.sun_direction;
    let cos_l = dot(n, l);
    var glint = vec3<f32>(0.0);
    if (cos_l > 0.0) {
        let h = normalize(l + to_eye);
        // Microfacet specular with the implicit (Kelemen) visibility 1 / (4 cos_l cos_v) ≈ 1 / (4 (l·h)²).
        let lh = max(dot(l, h), 1e-3);
        let d = ggx_distribution(max(dot(n, h), 0.0), WATER_GGX_ALPHA);
        glint = sun_irradiance_at(position_m) * sun_visibility * cos_l * d * water_fresnel(lh) / (4.0 * lh * lh);
    }
    let irradiance = sun_irradiance_at(position_m) * max(frame.sun_direction.y, 0.0) * sun_visibility
        + water_sky_irradiance(position_m);
    let body = diffuse_albedo / PI * irradiance * (1.0 - fresnel);
    return reflected_sky + glint + body;
}
