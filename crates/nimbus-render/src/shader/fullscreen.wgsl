// A triangle that covers the whole viewport, for full-screen passes.

struct FullscreenOutput {
    @builtin(position) position: vec4<f32>,
    // Clip-space x, y in [-1, 1] (y up).
    @location(0) clip_xy: vec2<f32>,
}

@vertex
fn fullscreen_vertex(@builtin(vertex_index) index: u32) -> FullscreenOutput {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    let clip_xy = uv * 2.0 - 1.0;
    var out: FullscreenOutput;
    // Depth 0 is the far plane under reverse-Z.
    out.position = vec4<f32>(clip_xy, 0.0, 1.0);
    out.clip_xy = clip_xy;
    return out;
}
