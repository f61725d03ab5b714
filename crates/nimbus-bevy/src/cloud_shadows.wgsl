// nimbus's cloud shadows baked for Bevy's meshes: each texel of Bevy's
// light texture on the nimbus sun (`DirectionalLightTexture`) gets the
// fraction of the sun's light that reaches the ground along its sun ray.
// Appended to `nimbus_render::shader::lighting_include()` (groups 0, 2, 3
// nimbus's; group 1 this pass's).

struct CloudShadowBake {
    // World from the sun light's local space: Bevy's `GlobalTransform` of
    // the light (rotation, translation, uniform scale = half the tile, m).
    world_from_light: mat4x4<f32>,
    // Altitude where the sun ray is sampled (m), texels per side, unused, unused.
    params: vec4<f32>,
    // The camera's position (m), for the ambient probe; w unused.
    camera_m: vec4<f32>,
}

@group(1) @binding(0) var<uniform> bake: CloudShadowBake;

@vertex
fn bake_vertex(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn bake_fragment(@builtin(position) pixel: vec4<f32>) -> @location(0) vec4<f32> {
    // Bevy samples a light texture at uv = local.xy * (-0.5, 0.5) + 0.5,
    // local = light_from_world * P (bevy_pbr's pbr_lighting.wgsl,
    // `directional_light`); this is its inverse (`bake_world_point` in
    // cloud_shadows.rs, tested against that formula).
    let uv = pixel.xy / bake.params.y;
    let local_xy = vec2<f32>((0.5 - uv.x) * 2.0, (uv.y - 0.5) * 2.0);
    let on_plane = (bake.world_from_light * vec4<f32>(local_xy, 0.0, 1.0)).xyz;
    let to_sun = nimbus_sun_direction();
    if (to_sun.y <= 1e-3) {
        // The sun at or below the horizon: Bevy's light is dark anyway.
        return vec4<f32>(1.0, 1.0, 1.0, 0.0);
    }
    // Every point of this sun ray maps to this texel; below the clouds they
    // all receive the same light: sample the ray at the altitude.
    let position_m = on_plane + to_sun * ((bake.params.x - on_plane.y) / to_sun.y);
    let visibility = nimbus_sun_visibility(position_m);
    // Bevy reads the red channel only: the visibility's luminance (Rec. 709),
    // grey for a viewer. Alpha 0: Bevy also lays the texture on its meshes
    // as a decal, which alpha 0 leaves without effect (cloud_shadows.rs).
    let luminance = dot(visibility, vec3<f32>(0.2126, 0.7152, 0.0722));
    return vec4<f32>(vec3<f32>(luminance), 0.0);
}

// The ambient probe: the irradiance on an upward surface at the camera that
// nimbus gives its own surfaces (the clear sky's, or under the stratus layer
// its radiosity: the deck's diffuse light, the sky through its gaps, the
// ground's light reflected back), rendered into one texel that the plugin
// reads back for Bevy's ambient light. Alpha: 1 under the layer, else 0.
@fragment
fn ambient_fragment() -> @location(0) vec4<f32> {
    let up = vec3<f32>(0.0, 1.0, 0.0);
    let p = bake.camera_m.xyz;
    let irradiance = stratus_ground_irradiance(p, up, sh_irradiance(lighting, up));
    let under = stratus_enabled() && p.y < stratus.window.x;
    return vec4<f32>(irradiance, select(0.0, 1.0, under));
}
