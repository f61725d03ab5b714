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

@group(1) @binding(2) var<storage, read_write> drops: array<Drop>;
@group(1) @binding(5) var occlusion_map: texture_depth_2d;
@group(1) @binding(6) var<storage, read_write> splashes: array<Splash>;
// x: splashes written so far (the ring's head).
@group(1) @binding(7) var<storage, read_write> splash_head: atomic<u32>;
// The drops' buffer's place among all drops (ids are global: they key the
// random numbers and the count against Marshall–Palmer).
@group(1) @binding(8) var<uniform> segment: RainSegment;

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

fn emit_splash(position: vec3<f32>, velocity: vec3<f32>, d_mm: f32) {
    // Only near the camera, where a splash's droplets can be seen.
    if (rain.flags.w == 0u || rain.flags.y == 0u || distance(position, rain_step.box_center.xyz) > rain.mist.z) {
        return;
    }
    let slot = atomicAdd(&splash_head, 1u) % rain.flags.y;
    splashes[slot] = Splash(vec4<f32>(position, rain_step.box_center.w), vec4<f32>(velocity, d_mm));
}

fn step_drop(id: u32, drop: Drop) -> Drop {
    if (drop.state == DROP_LEAVING) {
        return entering_drop(id);
    }
    if (drop.state == DROP_DEAD) {
        let d = sample_diameter(id);
        let velocity = rain.wind_mean.xyz - vec3<f32>(0.0, terminal_speed_m_s(d), 0.0);
        let rate = inflow_rate(velocity) / rain.box_size.w;
        if (uniform_random(id, rain_step.index.x, SALT_REVIVE) < rain_step.box_velocity.w * rate) {
            return entering_drop(id);
        }
        return drop;
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
        return moved;
    }
    if (drop.state == DROP_ALIVE && rain.flags.z != 0u) {
        let end = occlusion_depth(x_next);
        if (end.x > end.y + OCCLUSION_BIAS) {
            // The crossing of the segment with the cover's depth, seen
            // along the rain: the segment's depth runs linearly from start
            // to end, the cover's is the end texel's.
            let start = occlusion_depth(x).x;
            let t = clamp((end.y - start) / max(end.x - start, 1e-9), 0.0, 1.0);
            emit_splash(x + (x_next - x) * t, v_next, drop.diameter_mm);
            moved.state = DROP_GHOST;
        }
    }
    return moved;
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
    drops[slot] = step_drop(id, drops[slot]);
}
