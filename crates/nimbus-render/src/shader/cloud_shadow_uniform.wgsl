// import shader/common.wgsl
// The cloud shadow map's transform and parameters (group 3, binding 0 in
// every pass that reads or draws the map; frame/cloud_lighting.rs).

struct CloudShadow {
    // Shadow-map clip space from world space: orthographic along the sun's
    // light; x, y in [−1, 1], z in [0, 1] across the clouds' depth range.
    clip_from_world: mat4x4<f32>,
    // Depth range, m; core extinction α_ρ, m⁻¹; asymmetry g; texels per side.
    params: vec4<f32>,
    // 1 when the map holds clouds, filter radius in texels, unused, unused.
    flags: vec4<u32>,
}

@group(3) @binding(0) var<uniform> cloud_shadow: CloudShadow;
