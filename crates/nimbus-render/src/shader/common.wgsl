// Shared declarations of every nimbus pass: constants, the frame uniform and
// its binding (group 0, binding 0). Composed in front of each pass's shader
// by `shader::compose`. Units: metres, radians, radiance in W·sr⁻¹·m⁻² per
// RGB channel (pre-exposed in render targets: multiplied by the frame's
// pre-exposure, see atmosphere_lookup.wgsl).

const PI: f32 = 3.14159265358979;

struct Frame {
    clip_from_world: mat4x4<f32>,
    world_from_clip: mat4x4<f32>,
    camera_position_m: vec3<f32>,
    time_s: f32,
    // Unit vector towards the sun.
    sun_direction: vec3<f32>,
    // Manual exposure: multiplies radiance (W·sr⁻¹·m⁻²) to give exposed values.
    exposure_scale: f32,
    viewport_size_px: vec2<f32>,
    // Angle subtended by one pixel at the image centre, rad.
    pixel_angle_rad: f32,
    sun_cos_angular_radius: f32,
    // Largest value written to the half-float HDR target.
    max_pre_exposed: f32,
    // 1: automatic exposure from the metered average luminance.
    auto_exposure: u32,
    // Added to the metered exposure value, EV (positive is brighter).
    exposure_compensation_ev: f32,
    // Time constant of the eye/camera adaptation in animations, s (0: instant).
    adaptation_time_s: f32,
}

@group(0) @binding(0) var<uniform> frame: Frame;

// World-space unit view ray through a clip-space position (x, y in [-1, 1]).
fn view_ray_world(clip_xy: vec2<f32>) -> vec3<f32> {
    // Reverse-Z: depth 1 is the near plane, so this point is finite.
    let near = frame.world_from_clip * vec4<f32>(clip_xy, 1.0, 1.0);
    return normalize(near.xyz / near.w - frame.camera_position_m);
}
