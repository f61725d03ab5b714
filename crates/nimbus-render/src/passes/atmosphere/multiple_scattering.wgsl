// import passes/atmosphere/bindings.wgsl
// Multiple-scattering LUT Ψ_ms(r, μ_s): Hillaire 2020, eqs. 5–10, with 64
// Fibonacci directions and 20 steps each; mirrors
// AtmosphereTables::multiple_scattering_psi.

@group(1) @binding(8) var multiple_scattering_out: texture_storage_2d<rgba16float, write>;

const DIRECTIONS: u32 = 64u;
const STEPS: u32 = 20u;
const ISOTROPIC_PHASE: f32 = 0.0795774715459477;

fn fibonacci_sphere(index: u32, count: u32) -> vec3<f32> {
    let golden_angle = ATMOSPHERE_PI * (3.0 - sqrt(5.0));
    let y = 1.0 - (2.0 * f32(index) + 1.0) / f32(count);
    let radius = sqrt(max(1.0 - y * y, 0.0));
    let phi = golden_angle * f32(index);
    return vec3<f32>(radius * cos(phi), y, radius * sin(phi));
}

@compute @workgroup_size(8, 8)
fn multiple_scattering_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (any(vec2<f32>(id.xy) >= MULTIPLE_SCATTERING_LUT_SIZE)) {
        return;
    }
    let x = unit_from_sub_uv((vec2<f32>(id.xy) + 0.5) / MULTIPLE_SCATTERING_LUT_SIZE, MULTIPLE_SCATTERING_LUT_SIZE);
    let r = atmosphere.bottom_radius_m + x.y * (atmosphere.top_radius_m - atmosphere.bottom_radius_m);
    let mu_s = 2.0 * x.x - 1.0;
    let sun = vec3<f32>(sqrt(max(1.0 - mu_s * mu_s, 0.0)), mu_s, 0.0);
    var l2 = vec3<f32>(0.0);
    var f_ms = vec3<f32>(0.0);
    let n = f32(DIRECTIONS);
    for (var k = 0u; k < DIRECTIONS; k = k + 1u) {
        let dir = fibonacci_sphere(k, DIRECTIONS);
        let ground = ray_hits_ground(atmosphere, r, dir.y);
        let length_m = distance_to_boundary(atmosphere, r, dir.y);
        let dt = length_m / f32(STEPS);
        var throughput = vec3<f32>(1.0);
        for (var i = 0u; i < STEPS; i = i + 1u) {
            let t = (f32(i) + 0.5) * dt;
            let rm = radius_and_mu_s_along(r, dir, t, sun);
            let h = rm.x - atmosphere.bottom_radius_m;
            let extinction = extinction_at(atmosphere, h);
            let scattering = rayleigh_scattering_at(atmosphere, h) + mie_scattering_at(atmosphere, h);
            let sun_t = sample_sun_transmittance(transmittance_lut, lut_sampler, atmosphere, rm.x, rm.y);
            let step_t = exp(-extinction * dt);
            let integral = select(vec3<f32>(dt), (1.0 - step_t) / extinction, extinction > vec3<f32>(0.0));
            l2 += throughput * scattering * sun_t * ISOTROPIC_PHASE * integral / n;
            f_ms += throughput * scattering * integral / n;
            throughput *= step_t;
        }
        if (ground) {
            let rm = radius_and_mu_s_along(r, dir, length_m, sun);
            let sun_t = sample_sun_transmittance(transmittance_lut, lut_sampler, atmosphere, rm.x, rm.y);
            l2 += throughput * sun_t * max(rm.y, 0.0) * atmosphere.ground_albedo / ATMOSPHERE_PI / n;
        }
    }
    let psi = l2 / max(1.0 - f_ms, vec3<f32>(1e-6));
    textureStore(multiple_scattering_out, id.xy, vec4<f32>(psi, 1.0));
}
