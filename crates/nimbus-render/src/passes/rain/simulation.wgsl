// import passes/rain/random.wgsl
// import passes/rain/wind.wgsl
// import passes/rain/zones.wgsl
// import passes/rain/rain_box.wgsl
// The rain simulation: one invocation per drop per fixed step, the GPU twin
// of nimbus_physics::rain::simulation::step_drop (same random numbers, same
// formulas, f32). See that module for the model: semi-implicit drag on the
// velocity relative to the wind, recycling by flux on the upstream boundary
// of the rain box, ids against the Marshall–Palmer count, ghosts under
// cover, splashes appended to a ring on a hit.
//
// The splashes of a step are appended in the order of the drops' ids, so
// that the ring (which splash is in which slot, which are overwritten when
// it wraps, and the droplets each slot throws) is the same in every run:
// `simulate` marks the drops that splashed, a bit per drop in 8 words per
// workgroup (an atomic OR, which is commutative), and `place_splashes`, one
// workgroup dispatched after it, counts the bits in runs of workgroups,
// scans the counts, writes each splash at the ring's head plus the
// splashes before it and clears the bits (an atomicAdd per splash, as
// before, gave the slots to the scheduler). `simulate` has no barrier
// (lavapipe pays for one in so long a shader).
// CPU twin of the placement: nimbus_render::rain::splash_slots.

@group(1) @binding(2) var<storage, read_write> drops: array<Drop>;
@group(1) @binding(5) var occlusion_map: texture_depth_2d;
@group(1) @binding(6) var<storage, read_write> splashes: array<Splash>;
// Splashes written so far (the ring's head).
@group(1) @binding(7) var<storage, read_write> splash_head: u32;
// The drops' buffer's place among all drops (ids are global: they key the
// random numbers and the count against Marshall–Palmer).
@group(1) @binding(8) var<uniform> segment: RainSegment;
// Per workgroup of drops: GROUP_WORDS words, a bit per drop that splashed
// in this step (zero before the step: cleared before the frame's first
// and by `place_splashes`).
@group(1) @binding(9) var<storage, read_write> splash_masks: array<atomic<u32>>;

// Invocations per workgroup (the pass's WORKGROUP_SIZE) and the mask's
// words per workgroup.
const GROUP_SIZE: u32 = 256u;
const GROUP_WORDS: u32 = 8u;

var<workgroup> run_sums: array<u32, 256>;
var<workgroup> ring_head: u32;

// ---- Intensity, counts and cover (nimbus_physics::rain::zones, dsd, simulation).

fn local_intensity(p: vec3<f32>) -> f32 {
    if (p.y > rain.drops.w) {
        return 0.0;
    }
    return rain.drops.x * zone_factor(p.x, p.z);
}

fn slope_per_mm(intensity: f32) -> f32 {
    return 4.1 * pow(intensity, -0.21);
}

fn target_count(intensity: f32) -> u32 {
    if (intensity <= 0.0) {
        return 0u;
    }
    let slope = slope_per_mm(intensity);
    let n = 8000.0 / slope * exp(-slope * rain.drops.y) * rain.box_size.w;
    return u32(min(floor(n), f32(rain.counts.y)));
}

fn is_active(id: u32, p: vec3<f32>) -> bool {
    return id < target_count(local_intensity(p));
}

// Whether `p` is under cover: behind the first surface the rain meets in
// the rain shadow map.
fn occlusion_depth(p: vec3<f32>) -> vec2<f32> {
    // x: p's depth along the rain; y: the cover's depth there (1 = none).
    let clip = rain.occlusion_from_world * vec4<f32>(p, 1.0);
    let uv = vec2<f32>(clip.x * 0.5 + 0.5, 0.5 - clip.y * 0.5);
    if (any(uv < vec2<f32>(0.0)) || any(uv >= vec2<f32>(1.0))) {
        return vec2<f32>(clip.z, 1.0);
    }
    let size = vec2<f32>(textureDimensions(occlusion_map));
    let texel = vec2<i32>(uv * size);
    return vec2<f32>(clip.z, textureLoad(occlusion_map, texel, 0));
}

const OCCLUSION_BIAS: f32 = 2e-4;

fn is_covered(p: vec3<f32>) -> bool {
    if (rain.flags.z == 0u) {
        return false;
    }
    let d = occlusion_depth(p);
    return d.x > d.y + OCCLUSION_BIAS;
}

fn sample_diameter(id: u32) -> f32 {
    return diameter_from(uniform_random(id, rain_step.index.x, SALT_DIAMETER));
}

fn diameter_from(u: f32) -> f32 {
    let slope = slope_per_mm(max(rain.drops.x, 1e-6));
    return min(rain.drops.y - log(u) / slope, rain.drops.z);
}

// ---- The step.

fn entry_state(id: u32, p: vec3<f32>) -> u32 {
    if (!is_active(id, p)) {
        return DROP_DEAD;
    }
    if (is_covered(p)) {
        return DROP_GHOST;
    }
    return DROP_ALIVE;
}

fn terminal_velocity(d_mm: f32, p: vec3<f32>) -> vec3<f32> {
    return wind_at(p, rain_step.box_center.w) - vec3<f32>(0.0, terminal_speed_m_s(d_mm), 0.0);
}

fn initial_drop(id: u32) -> Drop {
    let s = rain_step.index.x;
    let u = vec3<f32>(
        uniform_random(id, s, SALT_INSIDE),
        uniform_random(id, s, SALT_INSIDE + 1u),
        uniform_random(id, s, SALT_INSIDE + 2u),
    );
    let p = sample_inside(u);
    let d = sample_diameter(id);
    return Drop(p, d, terminal_velocity(d, p), entry_state(id, p));
}

// The diameter of a drop crossing into the box, weighted by its flux
// N(D)·|u(D)| (nimbus_physics::rain::simulation::entering_diameter_mm).
fn entering_diameter(id: u32) -> f32 {
    let s = rain_step.index.x;
    let relative_wind = rain.wind_mean.xyz - rain_step.box_velocity.xyz;
    let bound = length(relative_wind) + terminal_speed_m_s(rain.drops.z);
    var d = rain.drops.y;
    for (var k = 0u; k < ENTRY_TRIES; k++) {
        d = diameter_from(uniform_random(id, s, SALT_ENTRY_DIAMETER + k));
        let speed = length(relative_wind - vec3<f32>(0.0, terminal_speed_m_s(d), 0.0));
        if (uniform_random(id, s, SALT_ENTRY_ACCEPT + k) * bound <= speed) {
            break;
        }
    }
    return d;
}

fn entering_drop(id: u32) -> Drop {
    let s = rain_step.index.x;
    let d = entering_diameter(id);
    let mean_velocity = rain.wind_mean.xyz - vec3<f32>(0.0, terminal_speed_m_s(d), 0.0);
    let u = vec4<f32>(
        uniform_random(id, s, SALT_INFLOW),
        uniform_random(id, s, SALT_INFLOW + 1u),
        uniform_random(id, s, SALT_INFLOW + 2u),
        uniform_random(id, s, SALT_INFLOW + 3u),
    );
    let dead = Drop(rain_step.box_center.xyz, d, mean_velocity, DROP_DEAD);
    let entry = sample_inflow(mean_velocity, u, rain_step.box_velocity.w);
    if (entry.w == 0.0 || !box_contains(entry.xyz)) {
        return dead;
    }
    return Drop(entry.xyz, d, terminal_velocity(d, entry.xyz), entry_state(id, entry.xyz));
}

// Whether a splash at `position` is kept: only near the camera, where its
// droplets can be seen.
fn splash_wanted(position: vec3<f32>) -> bool {
    return rain.flags.w != 0u && rain.flags.y != 0u && distance(position, rain_step.box_center.xyz) <= rain.mist.z;
}

// Where the segment from `x` to `x_next` goes under cover, as a fraction
// of it: the segment's depth along the rain runs linearly from start to
// end, the cover's is the end texel's.
fn cover_crossing(x: vec3<f32>, x_next: vec3<f32>) -> f32 {
    let end = occlusion_depth(x_next);
    let start = occlusion_depth(x).x;
    return clamp((end.y - start) / max(end.x - start, 1e-9), 0.0, 1.0);
}

// A drop after a step, and whether it splashed (and the splash is kept).
struct Stepped {
    drop: Drop,
    splashed: bool,
}

fn step_drop(id: u32, drop: Drop) -> Stepped {
    if (drop.state == DROP_LEAVING) {
        return Stepped(entering_drop(id), false);
    }
    if (drop.state == DROP_DEAD) {
        let d = sample_diameter(id);
        let velocity = rain.wind_mean.xyz - vec3<f32>(0.0, terminal_speed_m_s(d), 0.0);
        let rate = inflow_rate(velocity) / rain.box_size.w;
        if (uniform_random(id, rain_step.index.x, SALT_REVIVE) < rain_step.box_velocity.w * rate) {
            return Stepped(entering_drop(id), false);
        }
        return Stepped(drop, false);
    }
    let dt = rain_step.box_velocity.w;
    let x = drop.position_m;
    let v = drop.velocity_m_s;
    let wind = wind_at(x, rain_step.box_center.w);
    let v_t = terminal_speed_m_s(drop.diameter_mm);
    let k = GRAVITY_M_S2 / (v_t * v_t) * length(v - wind);
    let gravity = vec3<f32>(0.0, -GRAVITY_M_S2, 0.0);
    let v_next = (v + (gravity + wind * k) * dt) / (1.0 + dt * k);
    let x_next = x + v_next * dt;
    var moved = Drop(x_next, drop.diameter_mm, v_next, drop.state);
    if (!box_contains(x_next)) {
        moved.state = DROP_LEAVING;
        return Stepped(moved, false);
    }
    if (drop.state == DROP_ALIVE && rain.flags.z != 0u) {
        let end = occlusion_depth(x_next);
        if (end.x > end.y + OCCLUSION_BIAS) {
            // It splashes where the segment crosses the cover's depth, seen
            // along the rain.
            let t = cover_crossing(x, x_next);
            moved.state = DROP_GHOST;
            return Stepped(moved, splash_wanted(x + (x_next - x) * t));
        }
    }
    return Stepped(moved, false);
}

// The splash of a drop that splashed in this step, from the drop after the
// step: its start x = x' − v'·dt (x' = x + v'·dt; the start is recovered to
// within an ulp of x', well under a millimetre), the crossing as in the
// step.
fn splash_of(drop: Drop) -> Splash {
    let x_next = drop.position_m;
    let x = x_next - drop.velocity_m_s * rain_step.box_velocity.w;
    let t = cover_crossing(x, x_next);
    return Splash(
        vec4<f32>(x + (x_next - x) * t, rain_step.box_center.w),
        vec4<f32>(drop.velocity_m_s, drop.diameter_mm),
    );
}

@compute @workgroup_size(256)
fn simulate(@builtin(global_invocation_id) global: vec3<u32>) {
    let slot = global.x;
    let id = segment.range.x + slot;
    if (slot >= segment.range.y || id >= rain.counts.x) {
        return;
    }
    if (rain_step.index.y != 0u) {
        drops[slot] = initial_drop(id);
        return;
    }
    let stepped = step_drop(id, drops[slot]);
    drops[slot] = stepped.drop;
    if (stepped.splashed) {
        // Word slot / 32 is word (slot % 256) / 32 of workgroup slot / 256.
        atomicOr(&splash_masks[slot / 32u], 1u << (slot % 32u));
    }
}

// Splashes marked by the step's workgroups of this buffer, g in [start, end).
fn marked_splashes(start: u32, end: u32) -> u32 {
    var count = 0u;
    for (var g = start; g < end; g++) {
        for (var k = 0u; k < GROUP_WORDS; k++) {
            count += countOneBits(atomicLoad(&splash_masks[g * GROUP_WORDS + k]));
        }
    }
    return count;
}

// One workgroup, after `simulate` for the same step and buffer: invocation
// i takes a run of consecutive workgroups of drops, the runs' counts are
// scanned in workgroup memory (Hillis & Steele 1986), and each invocation
// writes its run's splashes in the order of the drops, clearing the bits
// for the next step.
@compute @workgroup_size(256)
fn place_splashes(@builtin(local_invocation_index) local: u32) {
    if (local == 0u) {
        ring_head = splash_head;
    }
    let first = min(segment.range.x, rain.counts.x);
    let groups = (min(segment.range.y, rain.counts.x - first) + GROUP_SIZE - 1u) / GROUP_SIZE;
    let per_invocation = (groups + GROUP_SIZE - 1u) / GROUP_SIZE;
    let start = min(local * per_invocation, groups);
    let end = min(start + per_invocation, groups);
    let count = marked_splashes(start, end);
    run_sums[local] = count;
    workgroupBarrier();
    for (var stride = 1u; stride < GROUP_SIZE; stride *= 2u) {
        var before = 0u;
        if (local >= stride) {
            before = run_sums[local - stride];
        }
        workgroupBarrier();
        run_sums[local] += before;
        workgroupBarrier();
    }
    let capacity = max(rain.flags.y, 1u);
    var place = ring_head + run_sums[local] - count;
    for (var g = start; g < end; g++) {
        for (var k = 0u; k < GROUP_WORDS; k++) {
            var mask = atomicExchange(&splash_masks[g * GROUP_WORDS + k], 0u);
            while (mask != 0u) {
                let bit = firstTrailingBit(mask);
                mask &= mask - 1u;
                let slot = g * GROUP_SIZE + k * 32u + bit;
                splashes[place % capacity] = splash_of(drops[slot]);
                place += 1u;
            }
        }
    }
    if (local == GROUP_SIZE - 1u) {
        // The head was read into workgroup memory before the scan's barriers.
        splash_head = ring_head + run_sums[local];
    }
}
