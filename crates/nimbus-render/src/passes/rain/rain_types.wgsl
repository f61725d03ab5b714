// import shader/common.wgsl
// The rain's shared declarations: the per-frame uniform, the drop and
// splash records, and the wind primitives' layout. Rust twins in
// rain/gpu_types.rs (layouts checked against naga by tests/shaders.rs).
// The uniform is binding 0 of group 1 in every rain shader (simulation,
// visibility, streaks, mist); each file declares the other bindings it reads.

struct WindPrimitive {
    // xyz: centre at t = 0, m; w: kind (0 uniform, 1 source, 2 vortex, 3 gust front).
    center: vec4<f32>,
    // xyz: unit axis; w: speed, m/s.
    axis: vec4<f32>,
    // xyz: drift of the centre, m/s; w: radius, m.
    drift: vec4<f32>,
    // x: gust period, s; y: gust front speed, m/s.
    gust: vec4<f32>,
}

struct Rain {
    // xyz: camera right; w: box shape (0 sphere, 1 axis-aligned box, 2 frustum).
    box_right: vec4<f32>,
    // xyz: camera up; w: frustum near distance, m.
    box_up: vec4<f32>,
    // xyz: camera forward; w: frustum far distance, m.
    box_forward: vec4<f32>,
    // Sphere: x radius, m; box: xyz half extents, m; frustum: x tan(fov_y/2), y aspect. w: volume, m³.
    box_size: vec4<f32>,
    // xyz: the camera's angular velocity, rad/s; w: the box's bounding radius, m.
    box_angular_velocity: vec4<f32>,
    // xyz: mean wind, m/s; w: wind grid spacing, m.
    wind_mean: vec4<f32>,
    // x: intensity, mm/h; y: smallest diameter, mm; z: largest, mm; w: ceiling (cloud base), m.
    drops: vec4<f32>,
    // x, y: zone map corner (x, z), m; z: zone texel, m; w: streak exposure time, s.
    zones: vec4<f32>,
    // x: drops dispatched; y: capacity; z: wind primitives; w: 1 with a wind grid.
    counts: vec4<u32>,
    // x: zone map texels per side; y: splash capacity; z: 1 with a rain shadow map; w: 1 with splashes.
    flags: vec4<u32>,
    // The rain shadow map's clip space from world (orthographic along the rain).
    occlusion_from_world: mat4x4<f32>,
    // xyz: camera velocity, m/s; w: smallest streak width, px.
    camera_velocity: vec4<f32>,
    // x: mist start (the box's radius), m; y: end of the first mist layer, m;
    // z: splashes are made within this distance of the camera, m; w: 1 with mist.
    mist: vec4<f32>,
    // x: the ground's height under the camera (the rendered surface's), m:
    // the bottom of the mist's column; yzw: the ground's mean albedo within
    // the mist's transport length of the camera.
    mist_ground: vec4<f32>,
    // xyz: the wind grid's points along x, y, z; w: 1 when the mean wind carries it.
    wind_grid: vec4<u32>,
    // xyz: world position of the wind grid's point (0, 0, 0) at time 0, m.
    wind_grid_origin: vec4<f32>,
    // xyz: a drop's scale of the environment's SH bands 0, 1, 2 about the
    // view direction (nimbus_physics::rain::drop_optics::DropTransfer).
    drop_sh_weights: vec4<f32>,
    // The drop's kernel K(cos γ), sr⁻¹, in 64 bins of cos γ from −1 to 1.
    drop_kernel: array<vec4<f32>, 16>,
    primitives: array<WindPrimitive, 16>,
}

// One buffer's share of the drops (devices bind a limited number of bytes
// per storage buffer, so millions of drops are split into several).
struct RainSegment {
    // x: id of the buffer's first drop; y: drops the buffer holds.
    range: vec4<u32>,
}

// One step of the simulation (bound with a dynamic offset per step).
struct RainStep {
    // xyz: box centre (the camera) at the end of the step, m; w: time at the end of the step, s.
    box_center: vec4<f32>,
    // xyz: box velocity, m/s; w: step length, s.
    box_velocity: vec4<f32>,
    // x: step index (keys the random numbers); y: 1 to place every drop anew.
    index: vec4<u32>,
}

struct Drop {
    position_m: vec3<f32>,
    diameter_mm: f32,
    velocity_m_s: vec3<f32>,
    // 0 dead, 1 alive, 2 leaving, 3 ghost (see nimbus_physics::rain::simulation).
    state: u32,
}

struct Splash {
    // xyz: impact point, m; w: time of impact, s.
    position_time: vec4<f32>,
    // xyz: the drop's velocity at impact, m/s; w: its diameter, mm.
    velocity_diameter: vec4<f32>,
}

const DROP_DEAD: u32 = 0u;
const DROP_ALIVE: u32 = 1u;
const DROP_LEAVING: u32 = 2u;
const DROP_GHOST: u32 = 3u;

const GRAVITY_M_S2: f32 = 9.80665;

// Terminal fall speed of a drop, m/s (nimbus_physics::rain::drag: Atlas et
// al. 1973 above 0.5 mm, linear below).
fn terminal_speed_m_s(d_mm: f32) -> f32 {
    if (d_mm >= 0.5) {
        return 9.65 - 10.3 * exp(-0.6 * d_mm);
    }
    return (9.65 - 10.3 * exp(-0.3)) * max(d_mm, 0.0) / 0.5;
}

// PCG hash of one 32-bit word (Jarzynski & Olano, "Hash Functions for GPU
// Rendering", JCGT 2020); nimbus_physics::rain::random::pcg_hash.
fn pcg_hash(input: u32) -> u32 {
    let state = input * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

@group(1) @binding(0) var<uniform> rain: Rain;
