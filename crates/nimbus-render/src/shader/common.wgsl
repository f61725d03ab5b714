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
    // Unit view direction.
    view_forward: vec3<f32>,
    // Side of a pixel, m, for an orthographic view; 0 for a perspective one.
    orthographic_pixel_m: f32,
}

@group(0) @binding(0) var<uniform> frame: Frame;

fn is_orthographic() -> bool {
    return frame.orthographic_pixel_m > 0.0;
}

// World-space unit view ray through a clip-space position (x, y in [-1, 1]).
fn view_ray_world(clip_xy: vec2<f32>) -> vec3<f32> {
    if (is_orthographic()) {
        return frame.view_forward;
    }
    // Reverse-Z: depth 1 is the near plane, so this point is finite.
    let near = frame.world_from_clip * vec4<f32>(clip_xy, 1.0, 1.0);
    return normalize(near.xyz / near.w - frame.camera_position_m);
}

// Where the view ray through a clip-space position starts: the eye, or for
// an orthographic view the ray's point on the plane of the view's origin.
fn view_ray_origin_world(clip_xy: vec2<f32>) -> vec3<f32> {
    if (is_orthographic()) {
        let near = frame.world_from_clip * vec4<f32>(clip_xy, 1.0, 1.0);
        let on_near = near.xyz / near.w;
        return on_near - frame.view_forward * dot(on_near - frame.camera_position_m, frame.view_forward);
    }
    return frame.camera_position_m;
}

// Unit vector from a world point towards the eye (the reverse view
// direction for an orthographic view).
fn to_eye_world(position_m: vec3<f32>) -> vec3<f32> {
    if (is_orthographic()) {
        return -frame.view_forward;
    }
    return normalize(frame.camera_position_m - position_m);
}

// Distance from the eye to a world point, m (for an orthographic view, from
// the plane of the view's origin along the view direction).
fn eye_distance_m(position_m: vec3<f32>) -> f32 {
    if (is_orthographic()) {
        return max(dot(position_m - frame.camera_position_m, frame.view_forward), 0.0);
    }
    return length(position_m - frame.camera_position_m);
}

// World point seen at a clip-space position at a (nimbus, reverse-Z) depth.
fn world_at_depth(clip_xy: vec2<f32>, depth: f32) -> vec3<f32> {
    let p = frame.world_from_clip * vec4<f32>(clip_xy, max(depth, 1e-7), 1.0);
    return p.xyz / p.w;
}

// Distance along the view direction from the eye (for an orthographic view,
// from the plane of its origin) of a (nimbus, reverse-Z) depth, m.
fn view_depth_m(depth: f32) -> f32 {
    return dot(world_at_depth(vec2<f32>(0.0), depth) - frame.camera_position_m, frame.view_forward);
}

// Side of a pixel's footprint, m, at a distance from the eye, m, on a
// surface facing the eye.
fn pixel_footprint_m(distance_m: f32) -> f32 {
    if (is_orthographic()) {
        return frame.orthographic_pixel_m;
    }
    return distance_m * frame.pixel_angle_rad;
}

// The red channel of `t` at texel coordinates `p` (texel centres at
// integers) interpolated bilinearly, clamped at the edge texels of an
// `n` × `n` texture: the lookup of R32Float maps, which are not filterable.
fn load_bilinear_r(t: texture_2d<f32>, p: vec2<f32>, n: i32) -> f32 {
    let p0 = floor(p);
    let f = p - p0;
    let i0 = clamp(vec2<i32>(p0), vec2<i32>(0), vec2<i32>(n - 1));
    let i1 = clamp(vec2<i32>(p0) + 1, vec2<i32>(0), vec2<i32>(n - 1));
    let a = textureLoad(t, i0, 0).r;
    let b = textureLoad(t, vec2<i32>(i1.x, i0.y), 0).r;
    let c = textureLoad(t, vec2<i32>(i0.x, i1.y), 0).r;
    let d = textureLoad(t, i1, 0).r;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}
