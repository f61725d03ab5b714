// The caller's depth buffer of its world seen from above, as rain cover:
// drawn into the rain shadow map (occluders.wgsl's target) as a height
// field, one vertex per sampled texel, each moved to the world point the
// caller's depth holds there and seen along the rain. Texels at the
// caller's far plane (nothing drawn) are holes: a triangle touching one is
// discarded. What is under an overhang counts as solid (a depth buffer
// holds the first surface only).

@group(0) @binding(0) var<uniform> occlusion_from_world: mat4x4<f32>;

struct DepthOccluder {
    // World space from the caller's clip space (the inverse of its
    // projection times view).
    world_from_clip: mat4x4<f32>,
    // Vertices per side (x, y), texels between vertices, unused.
    grid: vec4<u32>,
    // The caller's depth at its far plane (what it clears to), and at its
    // near plane; two unused.
    depths: vec4<f32>,
}

@group(1) @binding(0) var<uniform> occluder: DepthOccluder;
@group(1) @binding(1) var caller_depth: texture_depth_2d;

struct OccluderVertex {
    @builtin(position) clip: vec4<f32>,
    // 1 on a surface, 0 at a hole.
    @location(0) surface: f32,
}

@vertex
fn depth_occluder_vertex(@builtin(vertex_index) index: u32) -> OccluderVertex {
    // Two triangles per cell of the grid: corners (0,0) (1,0) (1,1), (0,0) (1,1) (0,1).
    let cells_x = occluder.grid.x - 1u;
    let cell = index / 6u;
    let corner = index % 6u;
    let corner_x = select(0u, 1u, corner == 1u || corner == 2u || corner == 4u);
    let corner_y = select(0u, 1u, corner == 2u || corner == 4u || corner == 5u);
    let grid = vec2<u32>(cell % cells_x + corner_x, cell / cells_x + corner_y);
    let size = textureDimensions(caller_depth);
    let texel = min(grid * occluder.grid.z, size - vec2<u32>(1u));
    let depth = textureLoad(caller_depth, vec2<i32>(texel), 0);
    let hole = depth == occluder.depths.x;
    // A hole's vertex still needs a finite position: its ray's near point.
    let z = select(depth, occluder.depths.y, hole);
    let uv = (vec2<f32>(texel) + 0.5) / vec2<f32>(size);
    let ndc = vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    let world = occluder.world_from_clip * vec4<f32>(ndc, z, 1.0);
    var out: OccluderVertex;
    out.clip = occlusion_from_world * vec4<f32>(world.xyz / world.w, 1.0);
    out.surface = select(1.0, 0.0, hole);
    return out;
}

@fragment
fn depth_occluder_fragment(in: OccluderVertex) {
    // Below 1 somewhere inside a triangle that touches a hole.
    if (in.surface < 0.999) {
        discard;
    }
}
