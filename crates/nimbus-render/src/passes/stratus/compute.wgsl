// import shader/cloud_layer_field.wgsl
// Stratus compute: the thickness window (the field evaluated at each texel
// centre, every frame, so the layer animates without CPU uploads) and the
// inputs of the ground–cloud radiosity (Bouthors 2006, §5.1) over its grid.
// Needs common.wgsl, the atmosphere lookups and shader/cloud_layer_field.wgsl.

@group(1) @binding(0) var<uniform> stratus: Stratus;
@group(1) @binding(1) var thickness_out: texture_storage_2d<r32float, write>;
// The radiosity pass's buffers (one vec4 per texel, row-major).
@group(1) @binding(2) var<storage, read_write> cloud_reflectance: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> ground_extra: array<vec4<f32>>;
@group(1) @binding(4) var<storage, read_write> ground_received: array<vec4<f32>>;
@group(1) @binding(5) var<storage, read_write> cloud_received: array<vec4<f32>>;
@group(1) @binding(6) var<storage, read_write> cloud_emitted: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn thickness_field(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = stratus.flags.w;
    if (id.x >= n || id.y >= n) {
        return;
    }
    let xz = stratus.window.zw + (vec2<f32>(id.xy) + 0.5) * (stratus.window.y / f32(n));
    textureStore(thickness_out, vec2<i32>(id.xy), vec4<f32>(layer_thickness_m(stratus, xz), 0.0, 0.0, 0.0));
}

// Per radiosity texel: ρ_C = R_ms; S_C = T₃₊ F_sun + T_ms E_sky (the
// layer's diffuse light on its base); S_G^d = F_sun(ground) T_C at the sun
// ray's crossing of the mid-plane (the sun's light on the ground, shadowed);
// R_G = R_C = 0 before the first gather. F_sun is the sun's flux on a
// horizontal surface.
@compute @workgroup_size(8, 8)
fn radiosity_inputs(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = stratus.sizes.z;
    if (id.x >= n || id.y >= n) {
        return;
    }
    let i = id.y * n + id.x;
    let size_m = stratus.radiosity.z;
    let xz = stratus.radiosity.xy + (vec2<f32>(id.xy) + 0.5) * size_m;
    // The texel's mean thickness, from four samples.
    let q = 0.25 * size_m;
    let h = 0.25 * (layer_thickness_m(stratus, xz + vec2<f32>(-q, -q)) + layer_thickness_m(stratus, xz + vec2<f32>(q, -q))
        + layer_thickness_m(stratus, xz + vec2<f32>(-q, q)) + layer_thickness_m(stratus, xz + vec2<f32>(q, q)));
    let l = frame.sun_direction;
    let mu_l = max(l.y, 0.0);
    let fluxes = slab_fluxes(stratus, h, max(mu_l, 1.745e-3));
    let mid = stratus.window.x;
    let top = vec3<f32>(xz.x, mid + 0.5 * h, xz.y);
    let sun_on_top = sun_irradiance_at(top) * mu_l;
    let sky = lighting.sky_irradiance_up.xyz;
    cloud_reflectance[i] = vec4<f32>(vec3<f32>(fluxes.reflectance), 0.0);
    cloud_emitted[i] = vec4<f32>(fluxes.t3plus * sun_on_top + fluxes.transmittance * sky, 0.0);

    var direct = vec3<f32>(0.0);
    if (mu_l > 0.0) {
        let ground = vec3<f32>(xz.x, stratus.radiosity.w, xz.y);
        let crossing = ground.xz + l.xz * ((mid - ground.y) / max(l.y, 1e-3));
        let h_shadow = layer_thickness_m(stratus, crossing);
        direct = sun_irradiance_at(ground) * mu_l * slab_directional_transmittance(stratus, h_shadow, mu_l);
    }
    ground_extra[i] = vec4<f32>(direct, 0.0);
    ground_received[i] = vec4<f32>(0.0);
    cloud_received[i] = vec4<f32>(0.0);
}
