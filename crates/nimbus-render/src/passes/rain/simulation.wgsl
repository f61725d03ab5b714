// import passes/rain/rain_types.wgsl
// The rain simulation: one invocation per drop per fixed step, the GPU twin
// of nimbus_physics::rain::simulation::step_drop (same random numbers, same
// formulas, f32). See that module for the model: semi-implicit drag on the
// velocity relative to the wind, recycling by flux on the upstream boundary
// of the rain box, ids against the Marshall–Palmer count, ghosts under
// cover, splashes appended to a ring on a hit.

@group(1) @binding(0) var<uniform> rain: Rain;
@group(1) @binding(1) var<uniform> rain_step: RainStep;
@group(1) @binding(2) var<storage, read_write> drops: array<Drop>;
@group(1) @binding(3) var<storage, read> wind_grid: array<vec4<f32>>;
@group(1) @binding(4) var<storage, read> zone_factors: array<f32>;
@group(1) @binding(5) var occlusion_map: texture_depth_2d;
@group(1) @binding(6) var<storage, read_write> splashes: array<Splash>;
// x: splashes written so far (the ring's head).
@group(1) @binding(7) var<storage, read_write> splash_head: atomic<u32>;
// The drops' buffer's place among all drops (ids are global: they key the
// random numbers and the count against Marshall–Palmer).
@group(1) @binding(8) var<uniform> segment: RainSegment;

// ---- Random numbers (nimbus_physics::rain::random).

fn uniform_random(id: u32, step_index: u32, salt: u32) -> f32 {
    let h = pcg_hash(id ^ pcg_hash(step_index ^ pcg_hash(salt)));
    return (f32(h >> 8u) + 0.5) * (1.0 / 16777216.0);
}

const SALT_INSIDE: u32 = 0u;
const SALT_DIAMETER: u32 = 3u;
const SALT_INFLOW: u32 = 4u;
const SALT_REVIVE: u32 = 8u;
const SALT_ENTRY_DIAMETER: u32 = 16u;
const SALT_ENTRY_ACCEPT: u32 = 32u;
const ENTRY_TRIES: u32 = 16u;

// ---- Wind (nimbus_physics::rain::wind).

fn gust_profile(behind_m: f32, width_m: f32) -> f32 {
    if (behind_m <= 0.0) {
        return 0.0;
    }
    let s = behind_m / max(width_m, 1e-3);
    return s * exp(1.0 - s);
}

fn primitive_wind(p: WindPrimitive, x: vec3<f32>, t: f32) -> vec3<f32> {
    let kind = u32(p.center.w);
    let c = p.center.xyz + p.drift.xyz * t;
    let d = x - c;
    let speed = p.axis.w;
    let radius = p.drift.w;
    let r_core = max(radius, 1e-3);
    if (kind == 0u) {
        var fade = 1.0;
        if (radius > 0.0) {
            let q = min(dot(d, d) / (radius * radius), 1.0);
            fade = (1.0 - q) * (1.0 - q);
        }
        return p.axis.xyz * (speed * fade);
    }
    if (kind == 1u) {
        let r = length(d);
        if (r < 1e-6) {
            return vec3<f32>(0.0);
        }
        var s = speed * (r_core / r) * (r_core / r);
        if (r < r_core) {
            s = speed * r / r_core;
        }
        return d * (s / r);
    }
    if (kind == 2u) {
        let radial = d - p.axis.xyz * dot(d, p.axis.xyz);
        let rho = length(radial);
        if (rho < 1e-6) {
            return vec3<f32>(0.0);
        }
        var s = speed * r_core / rho;
        if (rho < r_core) {
            s = speed * rho / r_core;
        }
        return cross(p.axis.xyz, radial) * (s / rho);
    }
    let period = max(p.gust.x, 1e-3);
    let run_m = p.gust.y * period;
    let phase = t / period;
    let front_m = (phase - floor(phase)) * run_m - 0.5 * run_m;
    let behind = front_m - dot(d, p.axis.xyz);
    let g = gust_profile(behind, radius) + gust_profile(behind + run_m, radius);
    return p.axis.xyz * (speed * g);
}

fn wind_grid_at(i: i32, j: i32, k: i32) -> vec3<f32> {
    let n = vec3<i32>(rain.wind_grid.xyz);
    let wrap = ((vec3<i32>(i, j, k) % n) + n) % n;
    return wind_grid[u32(wrap.x + n.x * (wrap.y + n.y * wrap.z))].xyz;
}

// Trilinear sample relative to the grid's point (0, 0, 0), wrapping around.
fn wind_grid_sample(p: vec3<f32>) -> vec3<f32> {
    let g = p / rain.wind_mean.w;
    let base = floor(g);
    let f = g - base;
    let i = i32(base.x);
    let j = i32(base.y);
    let k = i32(base.z);
    let x00 = mix(wind_grid_at(i, j, k), wind_grid_at(i + 1, j, k), f.x);
    let x10 = mix(wind_grid_at(i, j + 1, k), wind_grid_at(i + 1, j + 1, k), f.x);
    let x01 = mix(wind_grid_at(i, j, k + 1), wind_grid_at(i + 1, j, k + 1), f.x);
    let x11 = mix(wind_grid_at(i, j + 1, k + 1), wind_grid_at(i + 1, j + 1, k + 1), f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
}

fn wind_at(p: vec3<f32>, t: f32) -> vec3<f32> {
    var w = rain.wind_mean.xyz;
    if (rain.counts.w > 0u) {
        var q = p - rain.wind_grid_origin.xyz;
        if (rain.wind_grid.w == 1u) {
            q -= rain.wind_mean.xyz * t;
        }
        w += wind_grid_sample(q);
    }
    for (var i = 0u; i < min(rain.counts.z, 16u); i++) {
        w += primitive_wind(rain.primitives[i], p, t);
    }
    return w;
}

// ---- Intensity and zones (nimbus_physics::rain::zones, dsd).

fn zone_factor(x: f32, z: f32) -> f32 {
    let n = i32(rain.flags.x);
    let gx = (x - rain.zones.x) / rain.zones.z - 0.5;
    let gz = (z - rain.zones.y) / rain.zones.z - 0.5;
    let fx = floor(gx);
    let fz = floor(gz);
    let tx = gx - fx;
    let tz = gz - fz;
    let i = i32(fx);
    let j = i32(fz);
    let i0 = clamp(i, 0, n - 1);
    let i1 = clamp(i + 1, 0, n - 1);
    let j0 = clamp(j, 0, n - 1);
    let j1 = clamp(j + 1, 0, n - 1);
    let a00 = zone_factors[u32(i0 + n * j0)];
    let a10 = zone_factors[u32(i1 + n * j0)];
    let a01 = zone_factors[u32(i0 + n * j1)];
    let a11 = zone_factors[u32(i1 + n * j1)];
    let a = a00 + (a10 - a00) * tx;
    let b = a01 + (a11 - a01) * tx;
    return a + (b - a) * tz;
}

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

// ---- The rain box (nimbus_physics::rain::rain_box).

fn box_shape() -> u32 {
    return u32(rain.box_right.w);
}

fn box_contains(p: vec3<f32>) -> bool {
    let d = p - rain_step.box_center.xyz;
    let shape = box_shape();
    if (shape == 0u) {
        return dot(d, d) <= rain.box_size.x * rain.box_size.x;
    }
    if (shape == 1u) {
        return all(abs(d) <= rain.box_size.xyz);
    }
    let z = dot(d, rain.box_forward.xyz);
    return z >= rain.box_up.w && z <= rain.box_forward.w
        && abs(dot(d, rain.box_right.xyz)) <= z * rain.box_size.x * rain.box_size.y
        && abs(dot(d, rain.box_up.xyz)) <= z * rain.box_size.x;
}

fn box_corner(i: u32) -> vec3<f32> {
    let c = rain_step.box_center.xyz;
    let sx = select(-1.0, 1.0, (i & 1u) != 0u);
    let sy = select(-1.0, 1.0, (i & 2u) != 0u);
    let sz = select(-1.0, 1.0, (i & 4u) != 0u);
    if (box_shape() == 1u) {
        return c + vec3<f32>(sx, sy, sz) * rain.box_size.xyz;
    }
    let z = select(rain.box_up.w, rain.box_forward.w, (i & 4u) != 0u);
    return c + rain.box_right.xyz * (sx * z * rain.box_size.x * rain.box_size.y)
        + rain.box_up.xyz * (sy * z * rain.box_size.x) + rain.box_forward.xyz * z;
}

struct Face {
    a: vec3<f32>,
    b: vec3<f32>,
    c: vec3<f32>,
    d: vec3<f32>,
    normal: vec3<f32>,
}

fn box_face(f: u32, middle: vec3<f32>) -> Face {
    var q: vec4<u32>;
    switch f {
        case 0u: { q = vec4<u32>(0u, 2u, 6u, 4u); }
        case 1u: { q = vec4<u32>(1u, 5u, 7u, 3u); }
        case 2u: { q = vec4<u32>(0u, 4u, 5u, 1u); }
        case 3u: { q = vec4<u32>(2u, 3u, 7u, 6u); }
        case 4u: { q = vec4<u32>(0u, 1u, 3u, 2u); }
        default: { q = vec4<u32>(4u, 6u, 7u, 5u); }
    }
    var face: Face;
    face.a = box_corner(q.x);
    face.b = box_corner(q.y);
    face.c = box_corner(q.z);
    face.d = box_corner(q.w);
    var n = cross(face.c - face.a, face.d - face.b);
    let len = length(n);
    n = select(vec3<f32>(0.0), n / len, len > 0.0);
    let centroid = (face.a + face.b + face.c + face.d) * 0.25;
    if (dot(n, centroid - middle) < 0.0) {
        n = -n;
    }
    face.normal = n;
    return face;
}

fn triangle_area(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    return 0.5 * length(cross(b - a, c - a));
}

fn face_area(face: Face) -> f32 {
    return triangle_area(face.a, face.b, face.c) + triangle_area(face.a, face.c, face.d);
}

fn face_sample(face: Face, u0: f32, u1: f32, u2: f32) -> vec3<f32> {
    let first = triangle_area(face.a, face.b, face.c);
    let total = first + triangle_area(face.a, face.c, face.d);
    var p = face.a;
    var q = face.b;
    var r = face.c;
    if (u0 * total >= first) {
        q = face.c;
        r = face.d;
    }
    var s = u1;
    var t = u2;
    if (s + t > 1.0) {
        s = 1.0 - s;
        t = 1.0 - t;
    }
    return p + (q - p) * s + (r - p) * t;
}

fn boundary_velocity(p: vec3<f32>) -> vec3<f32> {
    return rain_step.box_velocity.xyz + cross(rain.box_angular_velocity.xyz, p - rain_step.box_center.xyz);
}

fn box_middle() -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < 8u; i++) {
        sum += box_corner(i);
    }
    return sum / 8.0;
}

fn inflow_rate(velocity: vec3<f32>) -> f32 {
    if (box_shape() == 0u) {
        let r = rain.box_size.x;
        return PI * r * r * length(velocity - rain_step.box_velocity.xyz);
    }
    let middle = box_middle();
    var total = 0.0;
    for (var f = 0u; f < 6u; f++) {
        let face = box_face(f, middle);
        let centroid = (face.a + face.b + face.c + face.d) * 0.25;
        let relative = velocity - boundary_velocity(centroid);
        total += face_area(face) * max(-dot(face.normal, relative), 0.0);
    }
    return total;
}

fn orthonormal_basis(n: vec3<f32>) -> mat2x3<f32> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return mat2x3<f32>(
        vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        vec3<f32>(b, sign + n.y * n.y * a, -n.y),
    );
}

// x, y, z: the entry point; w: 1 when something flows in.
fn sample_inflow(velocity: vec3<f32>, u: vec4<f32>, dt: f32) -> vec4<f32> {
    if (box_shape() == 0u) {
        let relative = velocity - rain_step.box_velocity.xyz;
        let speed = length(relative);
        if (speed < 1e-6) {
            return vec4<f32>(0.0);
        }
        let flow = relative / speed;
        let t = orthonormal_basis(flow);
        let radius = rain.box_size.x;
        let r = radius * sqrt(u.x);
        let phi = 2.0 * PI * u.y;
        let disc = t[0] * (r * cos(phi)) + t[1] * (r * sin(phi));
        let depth = sqrt(max(radius * radius - r * r, 0.0));
        return vec4<f32>(rain_step.box_center.xyz + disc - flow * depth + relative * (u.w * dt), 1.0);
    }
    let middle = box_middle();
    var weights: array<f32, 6>;
    var total = 0.0;
    for (var f = 0u; f < 6u; f++) {
        let face = box_face(f, middle);
        let centroid = (face.a + face.b + face.c + face.d) * 0.25;
        let relative = velocity - boundary_velocity(centroid);
        weights[f] = face_area(face) * max(-dot(face.normal, relative), 0.0);
        total += weights[f];
    }
    if (total <= 0.0) {
        return vec4<f32>(0.0);
    }
    let target_weight = u.x * total;
    var cumulative = 0.0;
    var chosen = 6u;
    var within = 0.5;
    for (var f = 0u; f < 6u; f++) {
        if (weights[f] <= 0.0) {
            continue;
        }
        chosen = f;
        if (target_weight <= cumulative + weights[f]) {
            within = clamp((target_weight - cumulative) / weights[f], 0.0, 1.0);
            break;
        }
        cumulative += weights[f];
        within = 0.5;
    }
    let face = box_face(chosen, middle);
    let centroid = (face.a + face.b + face.c + face.d) * 0.25;
    let relative = velocity - boundary_velocity(centroid);
    return vec4<f32>(face_sample(face, within, u.y, u.z) + relative * (u.w * dt), 1.0);
}

fn sample_inside(u: vec3<f32>) -> vec3<f32> {
    let c = rain_step.box_center.xyz;
    let shape = box_shape();
    if (shape == 0u) {
        let z = 1.0 - 2.0 * u.x;
        let ring = sqrt(max(1.0 - z * z, 0.0));
        let phi = 2.0 * PI * u.y;
        let r = rain.box_size.x * pow(u.z, 1.0 / 3.0);
        return c + vec3<f32>(ring * cos(phi), z, ring * sin(phi)) * r;
    }
    if (shape == 1u) {
        return c + (u * 2.0 - vec3<f32>(1.0)) * rain.box_size.xyz;
    }
    let n3 = pow(rain.box_up.w, 3.0);
    let f3 = pow(rain.box_forward.w, 3.0);
    let z = pow(n3 + u.z * (f3 - n3), 1.0 / 3.0);
    return c + rain.box_right.xyz * ((2.0 * u.x - 1.0) * z * rain.box_size.x * rain.box_size.y)
        + rain.box_up.xyz * ((2.0 * u.y - 1.0) * z * rain.box_size.x) + rain.box_forward.xyz * z;
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
