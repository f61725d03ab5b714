// import shader/cloud_layer_lookup.wgsl
// import passes/rain/rain_types.wgsl
// import passes/rain/zones.wgsl
// Rain mist (Blanchard 2023, §4.3, after Weber et al. 2015): beyond the
// rain box, drops are no longer drawn one by one; the rain there is a
// participating medium with the extinction of the same drops,
// β = ∫ N(D)·2·πD²/4 dD (nimbus_physics::rain::dsd::extinction_per_m),
// in two layers: from the box to the distance where the largest drops'
// streaks shrink below a pixel, with density moving with the wind (the
// seed's first layer, in which the last resolvable drops are folded), and
// beyond it, uniform (the second). Drops smaller than the simulated d_min
// are mist everywhere, the box included. No rain above the ceiling (the
// clouds' base) or outside the rain zones.
//
// The light scattered in is the environment's mean radiance (for a
// conservative medium lit by a diffuse field the source function equals
// the field's mean radiance) plus the sun's single scattering with a
// forward-peaked phase function (raindrops diffract: Henyey–Greenstein
// g = 0.85 stands in for their geometric-optics phase function; van de
// Hulst 1957, §12–13). Drawn over everything with blending
// dst·T + src.

@group(1) @binding(2) var scene_depth: texture_depth_2d;

const MIST_STEPS: u32 = 32u;
const MIST_MAX_DISTANCE_M: f32 = 30000.0;
const MIST_PHASE_G: f32 = 0.85;

// ∫_a^b D²·e^(−ΛD) dD, closed form (mm³).
fn second_moment(slope: f32, a: f32, b: f32) -> f32 {
    let fa = exp(-slope * a) * (a * a / slope + 2.0 * a / (slope * slope) + 2.0 / (slope * slope * slope));
    let fb = exp(-slope * b) * (b * b / slope + 2.0 * b / (slope * slope) + 2.0 / (slope * slope * slope));
    return fa - fb;
}

// Extinction of drops with diameters in [a, b] mm at an intensity, 1/m.
fn rain_extinction(intensity: f32, a: f32, b: f32) -> f32 {
    if (intensity <= 0.0) {
        return 0.0;
    }
    let slope = 4.1 * pow(intensity, -0.21);
    return 8000.0 * 0.5 * PI * second_moment(slope, a, b) * 1e-6;
}

// Cheap value noise for the first layer's wind-borne density.
fn mist_hash(p: vec3<i32>) -> f32 {
    var h = u32(p.x) * 73856093u ^ u32(p.y) * 19349663u ^ u32(p.z) * 83492791u;
    h = (h ^ (h >> 13u)) * 1274126177u;
    return f32(h & 0xffffu) / 65535.0;
}

fn mist_noise(p: vec3<f32>) -> f32 {
    let i = vec3<i32>(floor(p));
    let f = fract(p);
    let s = f * f * (3.0 - 2.0 * f);
    let x00 = mix(mist_hash(i), mist_hash(i + vec3<i32>(1, 0, 0)), s.x);
    let x10 = mix(mist_hash(i + vec3<i32>(0, 1, 0)), mist_hash(i + vec3<i32>(1, 1, 0)), s.x);
    let x01 = mix(mist_hash(i + vec3<i32>(0, 0, 1)), mist_hash(i + vec3<i32>(1, 0, 1)), s.x);
    let x11 = mix(mist_hash(i + vec3<i32>(0, 1, 1)), mist_hash(i + vec3<i32>(1, 1, 1)), s.x);
    return mix(mix(x00, x10, s.y), mix(x01, x11, s.y), s.z);
}

struct MistVarying {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) clip_xy: vec2<f32>,
}

@vertex
fn mist_vertex(@builtin(vertex_index) vertex: u32) -> MistVarying {
    let uv = vec2<f32>(f32((vertex << 1u) & 2u), f32(vertex & 2u));
    var out: MistVarying;
    out.clip_xy = uv * 2.0 - 1.0;
    out.clip_position = vec4<f32>(out.clip_xy, 0.0, 1.0);
    return out;
}

@fragment
fn mist_fragment(in: MistVarying) -> @location(0) vec4<f32> {
    let direction = view_ray_world(in.clip_xy);
    let depth = textureLoad(scene_depth, vec2<i32>(in.clip_position.xy), 0);
    // Distance to the surface (reverse-Z, infinite far: z_view = near/depth).
    var end_m = MIST_MAX_DISTANCE_M;
    if (depth > 0.0) {
        let forward = view_ray_world(vec2<f32>(0.0));
        end_m = min(0.5 / depth / max(dot(direction, forward), 1e-3), MIST_MAX_DISTANCE_M);
    }
    let origin = frame.camera_position_m;
    // Stop where the ray rises above the ceiling.
    if (direction.y > 1e-4 && origin.y < rain.drops.w) {
        end_m = min(end_m, (rain.drops.w - origin.y) / direction.y);
    }
    if (origin.y >= rain.drops.w && direction.y >= 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let box_m = rain.mist.x;
    let layer_m = rain.mist.y;
    // Geometric steps: fine near the camera, long far away.
    let ratio = pow(max(end_m, 1.0), 1.0 / f32(MIST_STEPS));
    var tau = 0.0;
    var previous = 0.0;
    for (var i = 1u; i <= MIST_STEPS; i++) {
        let s = min(pow(ratio, f32(i)), end_m);
        let mid = 0.5 * (previous + s);
        let p = origin + direction * mid;
        if (p.y <= rain.drops.w) {
            let intensity = rain.drops.x * zone_factor(p.x, p.z);
            // Sub-resolution drops everywhere; the simulated sizes beyond the box.
            var beta = rain_extinction(intensity, 0.0, rain.drops.y);
            if (mid > box_m) {
                var density = 1.0;
                if (mid < layer_m) {
                    let drift = p - rain.wind_mean.xyz * frame.time_s;
                    density = 0.5 + mist_noise(drift * 0.25);
                }
                beta += density * rain_extinction(intensity, rain.drops.y, rain.drops.z);
            }
            tau += beta * (s - previous);
        }
        previous = s;
        if (s >= end_m) {
            break;
        }
    }
    let transmittance = exp(-tau);
    let up = vec3<f32>(0.0, 1.0, 0.0);
    // Mean radiance of the field, (E↑ + E↓)/(2π) for uniform sky and ground hemispheres.
    let ambient = (stratus_ground_irradiance(origin, up, sh_irradiance(lighting, up))
        + stratus_ground_irradiance(origin, -up, sh_irradiance(lighting, -up))) / (2.0 * PI);
    let g = MIST_PHASE_G;
    let mu = dot(direction, frame.sun_direction);
    let phase = (1.0 - g * g) / (4.0 * PI * pow(1.0 + g * g - 2.0 * g * mu, 1.5));
    let sun = lighting.sun_irradiance.xyz * stratus_sun_transmittance(origin) * phase;
    let source = (ambient + sun) * pre_exposure();
    let inscattered = min(source * (1.0 - transmittance), vec3<f32>(frame.max_pre_exposed));
    return vec4<f32>(inscattered, transmittance);
}
