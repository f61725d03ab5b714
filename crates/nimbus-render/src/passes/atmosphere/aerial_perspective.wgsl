// import passes/atmosphere/bindings.wgsl
// import shader/hemisphere_moments.wgsl
// Aerial-perspective volume (Hillaire 2020, §5.4): for each froxel of the
// camera frustum, the light scattered towards the camera between it and the
// camera (RGB, W·sr⁻¹·m⁻²) and the mean transmittance (A). Depth slices are
// quadratic in distance up to 128 km; each froxel marches 16 steps.

@group(1) @binding(8) var aerial_perspective_out: texture_storage_3d<rgba16float, write>;
// Its parts (AtmosphereLookups::aerial_perspective_parts), with which the
// drawing passes light the air under a cloud layer by the layer's light
// instead of the clear sky's: the sun's single scattering (W·sr⁻¹·m⁻²) and
// the air's weights for a diffuse field, A₀, A₁ and W
// (nimbus_physics::atmosphere::under_layer::DiffuseWeights; dimensionless),
// packed as (sun, W.r), (A₀, W.g), (A₁, W.b).
@group(1) @binding(9) var aerial_perspective_sun_out: texture_storage_3d<rgba16float, write>;
@group(1) @binding(10) var aerial_perspective_above_out: texture_storage_3d<rgba16float, write>;
@group(1) @binding(11) var aerial_perspective_above_cosine_out: texture_storage_3d<rgba16float, write>;

const AERIAL_PERSPECTIVE_STEPS: u32 = 16u;

@compute @workgroup_size(4, 4, 4)
fn aerial_perspective_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (any(vec3<f32>(id) >= AERIAL_PERSPECTIVE_SIZE)) {
        return;
    }
    let uv = (vec2<f32>(id.xy) + 0.5) / AERIAL_PERSPECTIVE_SIZE.xy;
    let view = view_ray_world(vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0));
    let w = (f32(id.z) + 0.5) / AERIAL_PERSPECTIVE_SIZE.z;
    let distance_m = AERIAL_PERSPECTIVE_MAX_DISTANCE_M * w * w;
    let r = observer_radius(atmosphere, frame.camera_position_m.y);
    let result = scatter_along(transmittance_lut, multiple_scattering_lut, lut_sampler, atmosphere, r, view,
        frame.sun_direction, distance_m, AERIAL_PERSPECTIVE_STEPS);
    let transmittance = dot(result.transmittance, vec3<f32>(1.0 / 3.0));
    // Scale 0 (`camera.aerial_perspective = false`): no air in front of
    // anything, as in a path tracer whose sky is an environment map.
    let scale = atmosphere.aerial_perspective_scale;
    textureStore(aerial_perspective_out, id, vec4<f32>(
        result.luminance * atmosphere.sun_irradiance_top * scale, mix(1.0, transmittance, scale)));
    let rayleigh = rayleigh_hemisphere_moments(view.y);
    let aerosol = cornette_shanks_hemisphere_moments(atmosphere.mie_asymmetry, view.y);
    let total = (result.rayleigh_weight + result.mie_weight) * scale;
    let above = (result.rayleigh_weight * rayleigh.x + result.mie_weight * aerosol.x) * scale;
    let above_cosine = (result.rayleigh_weight * rayleigh.y + result.mie_weight * aerosol.y) * scale;
    textureStore(aerial_perspective_sun_out, id,
        vec4<f32>(result.sun_single * atmosphere.sun_irradiance_top * scale, total.r));
    textureStore(aerial_perspective_above_out, id, vec4<f32>(above, total.g));
    textureStore(aerial_perspective_above_cosine_out, id, vec4<f32>(above_cosine, total.b));
}
