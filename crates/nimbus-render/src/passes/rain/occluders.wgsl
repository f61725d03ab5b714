// The rain shadow map (Blanchard 2023, §4.2.3): the scene's depth seen
// along the mean rain direction, orthographic, for the simulation to stop
// drops where they meet a surface. Depth only.

@group(0) @binding(0) var<uniform> occlusion_from_world: mat4x4<f32>;

@vertex
fn occluder_vertex(@location(0) position_m: vec3<f32>) -> @builtin(position) vec4<f32> {
    return occlusion_from_world * vec4<f32>(position_m, 1.0);
}
