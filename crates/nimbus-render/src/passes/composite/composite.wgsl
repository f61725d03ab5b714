// import shader/fullscreen.wgsl
// import shader/atmosphere_lookup.wgsl
// import shader/cloud_layer_lookup.wgsl
// The caller's frame in `LinearHdr` output (renderer::OutputMode): the
// caller's depth translated into nimbus's (reverse-Z, infinite far plane),
// the air between the eye and the caller's surfaces, and nimbus's layers
// composited over the caller's colour.
//
// nimbus's HDR target starts transparent (0, 0, 0, 0) in this mode; every
// pass then draws premultiplied "over" (alpha: the coverage of what lies
// behind, 1 − transmittance), opaque ones with alpha 1. What the target
// holds at the end is therefore the radiance L nimbus adds and the fraction
// α it hides of the caller's pixel: the export writes L + (1 − α)·caller,
// and leaves a pixel nimbus did not draw over exactly as it was (L = 0, α = 0).

struct CompositeParams {
    // nimbus's homogeneous clip position from the caller's (x, y, depth, 1).
    nimbus_clip_from_caller_clip: mat4x4<f32>,
    // x: the caller's far-plane depth (what it clears its depth buffer to).
    caller: vec4<f32>,
}

@group(1) @binding(0) var<uniform> composite: CompositeParams;
@group(1) @binding(1) var caller_depth: texture_depth_2d;
@group(1) @binding(2) var nimbus_depth: texture_depth_2d;
@group(1) @binding(3) var nimbus_colour: texture_2d<f32>;

// nimbus's depth of the caller's depth at a pixel: CPU twin
// `frame::View::nimbus_depth_from_caller_depth`.
fn nimbus_depth_from_caller(clip_xy: vec2<f32>, depth: f32) -> f32 {
    if (depth == composite.caller.x) {
        return 0.0;
    }
    let p = composite.nimbus_clip_from_caller_clip * vec4<f32>(clip_xy, depth, 1.0);
    return clamp(p.z / p.w, 0.0, 1.0);
}

@fragment
fn depth_import_fragment(in: FullscreenOutput) -> @builtin(frag_depth) f32 {
    let depth = textureLoad(caller_depth, vec2<i32>(in.position.xy), 0);
    return nimbus_depth_from_caller(in.clip_xy, depth);
}

// Aerial perspective over the caller's surfaces (the same lookup, with the
// stratus layer's shading of the air, as nimbus's own surfaces get): the
// in-scattered light, and 1 − the mean transmittance as coverage.
@fragment
fn aerial_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    let depth = textureLoad(nimbus_depth, vec2<i32>(in.position.xy), 0);
    if (depth <= 0.0) {
        discard;
    }
    let position_m = world_at_depth(in.clip_xy, depth);
    let ap = stratus_aerial_perspective(position_m);
    let inscattered = min(ap.rgb * pre_exposure(), vec3<f32>(frame.max_pre_exposed));
    return vec4<f32>(inscattered, 1.0 - ap.a);
}

// nimbus's layers over the caller's colour (blended premultiplied over).
@fragment
fn export_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    return textureLoad(nimbus_colour, vec2<i32>(in.position.xy), 0);
}
