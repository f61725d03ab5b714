// import passes/atmosphere/bindings.wgsl
// Sky-view LUT (Hillaire 2020, §5.3): sky radiance around the camera over
// (azimuth from the sun, view zenith), 32 quadratic steps per texel; stored
// in W·sr⁻¹·m⁻² (times the solar irradiance).

@group(1) @binding(8) var sky_view_out: texture_storage_2d<rgba16float, write>;

const SKY_VIEW_STEPS: u32 = 32u;

// The sun in the observer's local frame, at azimuth 0.
fn local_sun() -> vec3<f32> {
    let mu_s = clamp(frame.sun_direction.y, -1.0, 1.0);
    return vec3<f32>(sqrt(max(1.0 - mu_s * mu_s, 0.0)), mu_s, 0.0);
}

@compute @workgroup_size(8, 8)
fn sky_view_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (any(vec2<f32>(id.xy) >= SKY_VIEW_LUT_SIZE)) {
        return;
    }
    let r = observer_radius(atmosphere, frame.camera_position_m.y);
    let x = unit_from_sub_uv((vec2<f32>(id.xy) + 0.5) / SKY_VIEW_LUT_SIZE, SKY_VIEW_LUT_SIZE);
    let angles = sky_view_angles_from_unit(atmosphere, r, x);
    let sin_z = sin(angles.x);
    let cos_z = cos(angles.x);
    let sin_az = sqrt(max(1.0 - angles.y * angles.y, 0.0));
    let view = vec3<f32>(sin_z * angles.y, cos_z, sin_z * sin_az);
    let length_m = distance_to_boundary(atmosphere, r, cos_z);
    let result = scatter_along(transmittance_lut, multiple_scattering_lut, lut_sampler, atmosphere, r, view,
        local_sun(), length_m, SKY_VIEW_STEPS);
    textureStore(sky_view_out, id.xy, vec4<f32>(result.luminance * atmosphere.sun_irradiance_top, 1.0));
}
