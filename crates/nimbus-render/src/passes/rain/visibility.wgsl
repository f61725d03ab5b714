// import passes/rain/rain_types.wgsl
// Which drops to draw: those in the rain (alive or leaving) whose streak
// meets the view frustum, appended to a list whose length is the instance
// count of the streaks' indirect draw. One atomic per workgroup keeps the
// global counter cold. Each buffer of drops has its own list and draw
// (the list holds indices into that buffer).

@group(1) @binding(1) var<storage, read> drops: array<Drop>;
@group(1) @binding(2) var<storage, read_write> visible: array<u32>;
// vertex_count, instance_count, first_vertex, first_instance.
@group(1) @binding(3) var<storage, read_write> draw_args: array<atomic<u32>, 4>;
@group(1) @binding(4) var<uniform> segment: RainSegment;

var<workgroup> workgroup_count: atomic<u32>;
var<workgroup> workgroup_base: u32;

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

@compute @workgroup_size(256)
fn cull(@builtin(global_invocation_id) global: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    if (local == 0u) {
        atomicStore(&workgroup_count, 0u);
    }
    workgroupBarrier();
    let index = global.x;
    var slot = 0xffffffffu;
    if (index < segment.range.y && segment.range.x + index < rain.counts.x) {
        let drop = drops[index];
        if (drop.state == DROP_ALIVE || drop.state == DROP_LEAVING) {
            let tail = streak_tail(drop);
            let centre = 0.5 * (drop.position_m + tail);
            let radius = 0.5 * length(drop.position_m - tail) + 0.01;
            if (sphere_in_view(centre, radius)) {
                slot = atomicAdd(&workgroup_count, 1u);
            }
        }
    }
    workgroupBarrier();
    if (local == 0u) {
        workgroup_base = atomicAdd(&draw_args[1], atomicLoad(&workgroup_count));
    }
    let base = workgroupUniformLoad(&workgroup_base);
    if (slot != 0xffffffffu) {
        visible[base + slot] = index;
    }
}
