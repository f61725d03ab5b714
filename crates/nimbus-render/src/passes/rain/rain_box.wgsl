// import passes/rain/random.wgsl
// import passes/rain/rain_types.wgsl
// The rain box around the camera, the GPU twin of
// nimbus_physics::rain::rain_box: its shape (sphere, axis-aligned box or
// the view frustum), its faces, the flux of drops through its upstream
// boundary and the sampling of where they enter or start.

// The step's box: its centre and velocity at this step, the step's index
// (binding 1 of the simulation's group 1, one dynamic offset per step).
@group(1) @binding(1) var<uniform> rain_step: RainStep;

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

