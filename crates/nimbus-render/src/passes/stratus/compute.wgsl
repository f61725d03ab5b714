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

// Steps of the sun's ray through the layer's height range.
const RADIOSITY_TILTED_STEPS: u32 = 8u;

// The thickness (m) of the tilted column through `start_m` along the sun
// `l` (l.y > 0): the cloud the beam crosses on its way through the layer's
// height range to `start_m`, times l.y, so that a slab of that thickness
// has the beam's optical path. The tilted independent column
// approximation (Várnai & Davies 1999, J. Atmos. Sci. 56; Wapler & Mayer
// 2008, J. Atmos. Sci. 65): vertical columns under a low sun let the beam
// through every gap and left dark the gaps behind the cells' sunlit sides,
// whose light the beam crosses. Each step counts the share of its rise
// inside a cell (a soft band, as the in-layer march's sun path does).
fn radiosity_tilted_thickness_m(start_m: vec3<f32>, l: vec3<f32>) -> f32 {
    let mid = stratus.window.x;
    let half = 0.5 * stratus.shape.w;
    let t_in = max((mid - half - start_m.y) / l.y, 0.0);
    let t_out = max((mid + half - start_m.y) / l.y, 0.0);
    let step_m = (t_out - t_in) / f32(RADIOSITY_TILTED_STEPS);
    let band_m = max(step_m * l.y, 1.0);
    var inside_m = 0.0;
    for (var k = 0u; k < RADIOSITY_TILTED_STEPS; k += 1u) {
        let q = start_m + l * (t_in + (f32(k) + 0.5) * step_m);
        let h = layer_thickness_m(stratus, q.xz);
        inside_m += step_m * saturate((0.5 * h - abs(q.y - mid)) / band_m + 0.5);
    }
    return inside_m * l.y;
}

// Per radiosity texel: ρ_C = R_ms; S_C = T₃₊ F_sun + T_ms E_sky (the
// layer's diffuse light on its base, the sun's part by the tilted column
// whose beam leaves the base there); S_G^d = F_sun(ground) T_C of the
// tilted column that reaches the ground (the sun's light on the ground,
// shadowed);
// R_G = R_C = 0 before the first gather. F_sun is the sun's flux on a
// horizontal surface. Each is the texel's mean over
// RADIOSITY_TEXEL_SAMPLES² points: the gather integrates the layer's
// exitance, so a texel takes the mean of its columns' fluxes, not the
// fluxes of their mean thickness. The slab's light is far from linear in
// the thickness (under the default scene's 22° sun a gap emits the sky's
// 17.5 W m⁻², a 350 m cell 23, a 100 m one 36), and a 2 km texel half gap,
// half thick cell took the bright middle's value: the light under the thick
// cells east of the default scene's mountains 30 W m⁻² where irradiance
// meters in its path-traced export read 21 (docs/REALISM.md, "The deck's
// light from the mean of its columns").
const RADIOSITY_TEXEL_SAMPLES: u32 = 4u;

@compute @workgroup_size(8, 8)
fn radiosity_inputs(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = stratus.sizes.z;
    if (id.x >= n || id.y >= n) {
        return;
    }
    let i = id.y * n + id.x;
    let size_m = stratus.radiosity.z;
    let xz = stratus.radiosity.xy + (vec2<f32>(id.xy) + 0.5) * size_m;
    let l = frame.sun_direction;
    let mu_l = max(l.y, 0.0);
    let mid = stratus.window.x;
    let sky = lighting.sky_irradiance_up.xyz;
    var reflectance = 0.0;
    var emitted = vec3<f32>(0.0);
    var direct = vec3<f32>(0.0);
    let half = 0.5 * stratus.shape.w;
    for (var k = 0u; k < RADIOSITY_TEXEL_SAMPLES * RADIOSITY_TEXEL_SAMPLES; k += 1u) {
        let cell = vec2<f32>(f32(k % RADIOSITY_TEXEL_SAMPLES), f32(k / RADIOSITY_TEXEL_SAMPLES));
        let column = xz + ((cell + 0.5) / f32(RADIOSITY_TEXEL_SAMPLES) - 0.5) * size_m;
        let h = layer_thickness_m(stratus, column);
        let fluxes = slab_fluxes(stratus, h, max(mu_l, 1.745e-3));
        reflectance += fluxes.reflectance;
        emitted += fluxes.transmittance * sky;
        if (mu_l > 0.0) {
            // The sun's light by the tilted column (see
            // radiosity_tilted_thickness_m): the column along the beam that
            // leaves the layer's lowest base below this point, and the one
            // that reaches the ground here.
            let h_sun = radiosity_tilted_thickness_m(vec3<f32>(column.x, mid - half, column.y), l);
            let sun_fluxes = slab_fluxes(stratus, h_sun, mu_l);
            let top = vec3<f32>(column.x, mid + 0.5 * h, column.y);
            emitted += sun_fluxes.t3plus * sun_irradiance_at(top) * mu_l;
            let ground = vec3<f32>(column.x, stratus.radiosity.w, column.y);
            let h_shadow = radiosity_tilted_thickness_m(ground, l);
            direct += sun_irradiance_at(ground) * mu_l * slab_directional_transmittance(stratus, h_shadow, mu_l);
        }
    }
    let samples = f32(RADIOSITY_TEXEL_SAMPLES * RADIOSITY_TEXEL_SAMPLES);
    cloud_reflectance[i] = vec4<f32>(vec3<f32>(reflectance / samples), 0.0);
    cloud_emitted[i] = vec4<f32>(emitted / samples, 0.0);
    ground_extra[i] = vec4<f32>(direct / samples, 0.0);
    ground_received[i] = vec4<f32>(0.0);
    cloud_received[i] = vec4<f32>(0.0);
}
