// import shader/atmosphere_lookup.wgsl
// import shader/fullscreen.wgsl
// import shader/water.wgsl
// Sky pass: sky radiance from the sky-view LUT, the limb-darkened solar disk
// seen through the atmosphere, and the open sea at the water level below the
// horizon, beyond the terrain's edge, seen through the aerial perspective.

struct SkyPassParams {
    // Height of the open sea, m.
    water_level_m: f32,
    // Limb-darkening coefficient u of the linear law I(μ) = I(1) (1 − u (1 − μ)).
    limb_darkening_u: f32,
    _padding: vec2<f32>,
    // Diffuse albedo of deep water.
    water_albedo: vec4<f32>,
}

@group(1) @binding(0) var<uniform> params: SkyPassParams;

fn solar_disk(direction: vec3<f32>) -> vec3<f32> {
    let cos_angle = dot(direction, frame.sun_direction);
    if (cos_angle < frame.sun_cos_angular_radius) {
        return vec3<f32>(0.0);
    }
    let radius = acos(frame.sun_cos_angular_radius);
    let r = acos(min(cos_angle, 1.0)) / radius;
    let mu = sqrt(max(1.0 - r * r, 0.0));
    let u = params.limb_darkening_u;
    let solid_angle = 2.0 * PI * (1.0 - frame.sun_cos_angular_radius);
    // The disk average of (1 − u (1 − μ)) is 1 − u / 3, so the disk still delivers sun_irradiance.
    return sun_irradiance_at(frame.camera_position_m) / solid_angle * (1.0 - u * (1.0 - mu)) / (1.0 - u / 3.0);
}

@fragment
fn sky_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    let direction = view_ray_world(in.clip_xy);
    let origin = view_ray_origin_world(in.clip_xy);
    let height = origin.y - params.water_level_m;
    if (direction.y < 0.0 && height > 0.0) {
        let distance = height / -direction.y;
        let sea_point = origin + direction * distance;
        let sea = water_radiance(sea_point, params.water_albedo.rgb, vec3<f32>(1.0));
        return to_target(apply_aerial_perspective(sea, sea_point));
    }
    return to_target(sky_radiance(direction) + solar_disk(direction));
}

// What the open sea beyond the terrain reflects: the clear sky (water.wgsl's hooks).
fn water_reflection_source(position_m: vec3<f32>, direction: vec3<f32>) -> vec3<f32> {
    return sky_radiance(direction);
}
fn water_sky_irradiance(position_m: vec3<f32>) -> vec3<f32> {
    return lighting.sky_irradiance_up.xyz;
}
