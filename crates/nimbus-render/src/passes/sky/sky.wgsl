// import shader/atmosphere_lookup.wgsl
// import shader/fullscreen.wgsl
// import shader/open_water.wgsl
// Sky pass: sky radiance from the sky-view LUT, the limb-darkened solar disk
// seen through the atmosphere, and the open sea at the water level below the
// horizon, beyond the terrain's edge: shaded as the terrain's water is
// (shader/open_water.wgsl: the sky and the stratus layer's base reflected,
// the sun through the clouds' shadows, the air in front lit by the light
// that is there).

struct SkyPassParams {
    // Height of the open sea, m.
    water_level_m: f32,
    // Limb-darkening coefficient u of the linear law I(μ) = I(1) (1 − u (1 − μ)).
    limb_darkening_u: f32,
    // Half the side of the square, centred on the origin, that the terrain
    // pass covers, m (0: no relief drawn).
    terrain_half_extent_m: f32,
    _padding: f32,
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
        if (max(abs(sea_point.x), abs(sea_point.z)) < params.terrain_half_extent_m) {
            // The terrain drawn next covers this (its own water included)
            // once its mesh is ready: a plain sea until then, without the
            // clouds' shadows and the air under the layer.
            let plain = water_radiance(sea_point, params.water_albedo.rgb, vec3<f32>(1.0));
            return to_target(apply_aerial_perspective(plain, sea_point));
        }
        // The stratus layer's shadow as far as the layer is drawn (its
        // window, faded at the edge): beyond, the sea is the open sea
        // under a clear sky that the camera sees there (and that the
        // references have), its glitter path unshadowed.
        let layer_shadow = mix(vec3<f32>(1.0), stratus_sun_transmittance(sea_point), stratus_window_fade(sea_point.xz));
        let sun_visibility = cloud_shadow_transmittance(sea_point) * layer_shadow;
        let sea = water_radiance(sea_point, params.water_albedo.rgb, sun_visibility);
        return lit_surface_output(sea, sea_point);
    }
    return to_target(sky_radiance(direction) + solar_disk(direction));
}
