// Ground–cloud radiosity (Bouthors et al. 2006, §5): MIP pyramids of the
// emitted light and the ring-integral gather. The CPU reference is
// nimbus_physics::radiosity; the layout of a pyramid buffer is its levels
// 0..=3 one after the other, row-major, one vec4 (RGB, unused) per texel.

struct RadiosityStep {
    // Texels per side of the level written (downsample) or of level 0
    // (gather).
    size: u32,
    // Offsets in texels of the source and destination levels (downsample).
    source_offset: u32,
    destination_offset: u32,
    // 1 for the initial gather, whose emitted light adds the ground's own
    // direct and sky light (`extra`), else 0.
    initial: u32,
    // Offsets of levels 1 and 3 in the emitter's pyramid (gather).
    level1_offset: u32,
    level3_offset: u32,
    _padding0: u32,
    _padding1: u32,
}

// Ring weights v1, v2, v3 of MIP levels 0, 1, 3 (§5.3).
const RING_WEIGHTS = vec3<f32>(0.4, 0.387, 0.213);

@group(0) @binding(0) var<uniform> step: RadiosityStep;
@group(0) @binding(1) var<storage, read_write> source_pyramid: array<vec4<f32>>;

// Box 2×2 mean of the source level into the destination level.
@compute @workgroup_size(8, 8)
fn downsample(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= step.size || id.y >= step.size) {
        return;
    }
    let source_size = 2u * step.size;
    let base = step.source_offset + 2u * id.y * source_size + 2u * id.x;
    let sum = source_pyramid[base] + source_pyramid[base + 1u]
        + source_pyramid[base + source_size] + source_pyramid[base + source_size + 1u];
    source_pyramid[step.destination_offset + id.y * step.size + id.x] = 0.25 * sum;
}

@group(1) @binding(0) var<storage, read> reflectance: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> extra: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> received: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> emitted: array<vec4<f32>>;

// Bilinear sample of a pyramid level of `level_size` texels per side at
// texture coordinates uv, texel centres at (i + ½)/size, clamped to the edge
// (the same convention as the CPU reference and a clamp-to-edge sampler).
fn sample_level(offset: u32, level_size: u32, uv: vec2<f32>) -> vec4<f32> {
    let p = uv * f32(level_size) - 0.5;
    let p0 = floor(p);
    let f = p - p0;
    let last = i32(level_size) - 1;
    let i0 = clamp(i32(p0.x), 0, last);
    let i1 = clamp(i32(p0.x) + 1, 0, last);
    let j0 = clamp(i32(p0.y), 0, last);
    let j1 = clamp(i32(p0.y) + 1, 0, last);
    let row0 = offset + u32(j0) * level_size;
    let row1 = offset + u32(j1) * level_size;
    let a = source_pyramid[row0 + u32(i0)];
    let b = source_pyramid[row0 + u32(i1)];
    let c = source_pyramid[row1 + u32(i0)];
    let d = source_pyramid[row1 + u32(i1)];
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

// The ring integral of the emitter's pyramid at each receiver texel:
// received += E; emitted = ρ (extra·initial + E), written as level 0 of the
// receiver's pyramid.
@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = step.size;
    if (id.x >= n || id.y >= n) {
        return;
    }
    let uv = (vec2<f32>(id.xy) + 0.5) / f32(n);
    let e = RING_WEIGHTS.x * source_pyramid[id.y * n + id.x]
        + RING_WEIGHTS.y * sample_level(step.level1_offset, n / 2u, uv)
        + RING_WEIGHTS.z * sample_level(step.level3_offset, n / 8u, uv);
    let i = id.y * n + id.x;
    received[i] = received[i] + e;
    emitted[i] = reflectance[i] * (f32(step.initial) * extra[i] + e);
}
