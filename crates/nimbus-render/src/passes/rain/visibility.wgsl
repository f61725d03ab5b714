// import passes/rain/rain_types.wgsl
// Which drops to draw: those in the rain (alive or leaving) whose streak
// meets the view frustum, listed in the order of their indices, the list's
// length the instance count of the streaks' indirect draw. Each buffer of
// drops has its own list and draw (the list holds indices into that buffer).
//
// The list is a stable stream compaction in three dispatches (Blelloch,
// "Prefix sums and their applications", 1990; Harris, Sengupta & Owens,
// "Parallel prefix sum (scan) with CUDA", GPU Gems 3 ch. 39, 2007), so that
// the streaks are drawn, and blended, in the same order in every run:
// 1. `mark`: a drop in view sets its bit in its workgroup's 8 words (an
//    atomic OR, which is commutative; the words are cleared before the
//    pass);
// 2. `scan`: one workgroup counts each workgroup's bits and turns the
//    counts into each workgroup's first place in the list (an exclusive
//    prefix sum), and writes the total;
// 3. `scatter`: a drop in view goes to its workgroup's first place plus the
//    number of drops in view before it in the workgroup (bits counted).
// Every step is exact integer arithmetic whose result does not depend on
// the order the invocations run in (an atomicAdd per drop, as before, gave
// the drops' order in the list, and with it the blending, to the
// scheduler). No step has a barrier but the scan's, which lavapipe pays
// for. CPU twin: nimbus_render::rain::visible_list.

@group(1) @binding(1) var<storage, read> drops: array<Drop>;
@group(1) @binding(2) var<storage, read_write> visible: array<u32>;
// vertex_count, instance_count, first_vertex, first_instance.
@group(1) @binding(3) var<storage, read_write> draw_args: array<u32, 4>;
@group(1) @binding(4) var<uniform> segment: RainSegment;
// Per workgroup of drops: GROUP_WORDS words, a bit per drop in view
// (zero before `mark`).
@group(1) @binding(5) var<storage, read_write> group_masks: array<atomic<u32>>;
// Per workgroup of drops: its first place in the list.
@group(1) @binding(6) var<storage, read_write> group_offsets: array<u32>;

// Invocations per workgroup (the pass's WORKGROUP_SIZE) and the mask's
// words per workgroup.
const GROUP_SIZE: u32 = 256u;
const GROUP_WORDS: u32 = 8u;

var<workgroup> chunk_sums: array<u32, 256>;

// Whether a sphere meets the frustum of `clip_from_world` (reverse-Z,
// infinite far plane): the planes of Gribb & Hartmann (2001) from the rows.
fn sphere_in_view(centre: vec3<f32>, radius: f32) -> bool {
    let m = transpose(frame.clip_from_world);
    let planes = array<vec4<f32>, 5>(m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] - m[2]);
    for (var i = 0u; i < 5u; i++) {
        let p = planes[i];
        if (dot(p.xyz, centre) + p.w < -radius * length(p.xyz)) {
            return false;
        }
    }
    return true;
}

// The streak of a drop: from its position back along its motion relative
// to the camera during the exposure.
fn streak_tail(drop: Drop) -> vec3<f32> {
    return drop.position_m - (drop.velocity_m_s - rain.camera_velocity.xyz) * rain.zones.w;
}

// Drops of this buffer simulated this frame.
fn dispatched_drops() -> u32 {
    let first = min(segment.range.x, rain.counts.x);
    return min(segment.range.y, rain.counts.x - first);
}

fn in_view(index: u32) -> bool {
    if (index >= dispatched_drops()) {
        return false;
    }
    let drop = drops[index];
    if (drop.state != DROP_ALIVE && drop.state != DROP_LEAVING) {
        return false;
    }
    let tail = streak_tail(drop);
    let centre = 0.5 * (drop.position_m + tail);
    let radius = 0.5 * length(drop.position_m - tail) + 0.01;
    return sphere_in_view(centre, radius);
}

@compute @workgroup_size(256)
fn mark(@builtin(global_invocation_id) global: vec3<u32>) {
    let index = global.x;
    if (in_view(index)) {
        // Word index / 32 is word (index % 256) / 32 of workgroup index / 256.
        atomicOr(&group_masks[index / 32u], 1u << (index % 32u));
    }
}

// Drops in view in workgroup g of drops.
fn group_count(g: u32) -> u32 {
    var count = 0u;
    for (var k = 0u; k < GROUP_WORDS; k++) {
        count += countOneBits(atomicLoad(&group_masks[g * GROUP_WORDS + k]));
    }
    return count;
}

// One workgroup: invocation i sums the counts of a run of consecutive
// workgroups, the 256 sums are scanned in workgroup memory (Hillis &
// Steele 1986), and each invocation walks its run again writing offsets.
@compute @workgroup_size(256)
fn scan(@builtin(local_invocation_index) local: u32) {
    let groups = (dispatched_drops() + GROUP_SIZE - 1u) / GROUP_SIZE;
    let per_invocation = (groups + GROUP_SIZE - 1u) / GROUP_SIZE;
    let start = min(local * per_invocation, groups);
    let end = min(start + per_invocation, groups);
    var sum = 0u;
    for (var g = start; g < end; g++) {
        sum += group_count(g);
    }
    chunk_sums[local] = sum;
    workgroupBarrier();
    for (var stride = 1u; stride < GROUP_SIZE; stride *= 2u) {
        var before = 0u;
        if (local >= stride) {
            before = chunk_sums[local - stride];
        }
        workgroupBarrier();
        chunk_sums[local] += before;
        workgroupBarrier();
    }
    var offset = chunk_sums[local] - sum;
    for (var g = start; g < end; g++) {
        group_offsets[g] = offset;
        offset += group_count(g);
    }
    if (local == GROUP_SIZE - 1u) {
        draw_args[1] = chunk_sums[local];
    }
}

@compute @workgroup_size(256)
fn scatter(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let words = group.x * GROUP_WORDS;
    let word = local / 32u;
    let bit = local % 32u;
    let mask = atomicLoad(&group_masks[words + word]);
    if ((mask & (1u << bit)) == 0u) {
        return;
    }
    var before = countOneBits(mask & ((1u << bit) - 1u));
    for (var k = 0u; k < word; k++) {
        before += countOneBits(atomicLoad(&group_masks[words + k]));
    }
    visible[group_offsets[group.x] + before] = group.x * GROUP_SIZE + local;
}
