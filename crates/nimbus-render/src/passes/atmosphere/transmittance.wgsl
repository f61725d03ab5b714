// import passes/atmosphere/bindings.wgsl
// Transmittance LUT (Bruneton 2017 parametrisation): transmittance from
// (r, μ) to the top of the atmosphere by Simpson's rule with 256 intervals;
// mirrors AtmosphereParams::optical_depth.

@group(1) @binding(8) var transmittance_out: texture_storage_2d<rgba16float, write>;

const TRANSMITTANCE_STEPS: u32 = 256u;

@compute @workgroup_size(8, 8)
fn transmittance_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (any(vec2<f32>(id.xy) >= TRANSMITTANCE_LUT_SIZE)) {
        return;
    }
    let x = unit_from_sub_uv((vec2<f32>(id.xy) + 0.5) / TRANSMITTANCE_LUT_SIZE, TRANSMITTANCE_LUT_SIZE);
    let rm = transmittance_r_mu_from_unit(atmosphere, x);
    let length_m = distance_to_top(atmosphere, rm.x, rm.y);
    let dt = length_m / f32(TRANSMITTANCE_STEPS);
    var tau = vec3<f32>(0.0);
    for (var i = 0u; i <= TRANSMITTANCE_STEPS; i = i + 1u) {
        var weight = 2.0;
        if (i == 0u || i == TRANSMITTANCE_STEPS) {
            weight = 1.0;
        } else if (i % 2u == 1u) {
            weight = 4.0;
        }
        tau += weight * extinction_at(atmosphere, altitude_along(atmosphere, rm.x, rm.y, f32(i) * dt));
    }
    textureStore(transmittance_out, id.xy, vec4<f32>(exp(-tau * dt / 3.0), 1.0));
}
