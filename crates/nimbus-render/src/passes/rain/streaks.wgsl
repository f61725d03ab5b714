// import shader/cloud_layer_lookup.wgsl
// import passes/rain/rain_types.wgsl
// Rain streaks and splashes (Blanchard 2023, §4.2.4–4.2.5; Garg & Nayar,
// "Photorealistic rendering of rain streaks", SIGGRAPH 2006; Rousseau et
// al. 2006).
//
// A drop is seen as the streak it draws during the exposure time: a
// camera-facing quad from its position back along its velocity relative to
// the camera, so the length is speed × exposure whatever the frame rate.
// The quad is at least `camera_velocity.w` pixels wide so drops falling
// towards the camera do not vanish (the seed's "cross" artefact), and its
// opacity conserves the drop's projected area: a drop of projected
// diameter D covers (π/4)·D² pixel·exposures, spread over the quad's
// w·(L + w) pixels (Garg & Nayar: a streak pixel sees the drop only for the
// fraction of the exposure it takes to cross it, D/(v·T)).
//
// A drop's radiance is what it refracts and reflects, averaged over its
// disc (nimbus_physics::rain::drop_optics): light refracted straight
// through, deviated by up to 82.8° and so showing the environment behind
// it within Rousseau et al.'s (2006) 165°, turned over, weighted by
// (1 − R)²; and light reflected with the Fresnel reflectance R of each
// point's incidence, weak at the centre and total at the grazing rim. The
// paths turn the view direction about its own axis, so the average is a
// zonal convolution: the environment's SH bands scaled by k₀, k₁, k₂, and
// the sun, a direction, weighted by the tabulated kernel K(cos γ). Against
// dark ground the drops gather the bright sky and show; against the bright
// sky they barely do.

@group(1) @binding(1) var<storage, read> drops: array<Drop>;
@group(1) @binding(2) var<storage, read> visible: array<u32>;
@group(1) @binding(3) var<storage, read> splashes: array<Splash>;
@group(1) @binding(4) var scene_depth: texture_depth_2d;

// Splash droplets drawn per impact, and how long they fly, s.
const SPLASH_DROPLETS: u32 = 4u;
const SPLASH_LIFETIME_S: f32 = 0.2;

struct StreakVarying {
    @builtin(position) clip_position: vec4<f32>,
    // −1 to 1 across the streak.
    @location(0) across: f32,
    @location(1) @interpolate(flat) head_m: vec3<f32>,
    @location(2) @interpolate(flat) alpha: f32,
}

fn hash_unit(key: u32) -> f32 {
    return (f32(pcg_hash(key) >> 8u) + 0.5) * (1.0 / 16777216.0);
}

// Clip-space corners of the streak from `head` to `tail` (world) for a drop
// of `diameter_m`. Returns the vertex `corner` (0–5, two triangles).
fn streak_vertex(head: vec3<f32>, tail_in: vec3<f32>, diameter_m: f32, corner: u32) -> StreakVarying {
    var out: StreakVarying;
    out.head_m = head;
    var a = frame.clip_from_world * vec4<f32>(head, 1.0);
    var b = frame.clip_from_world * vec4<f32>(tail_in, 1.0);
    // Keep both ends just beyond the near plane, where reverse-Z depth z/w
    // is 1: clip the segment where w − z, linear along it, falls to 5 % of w
    // (for a perspective view, 1.05 near-plane distances).
    let a_in = a.w - a.z - 0.05 * a.w;
    let b_in = b.w - b.z - 0.05 * b.w;
    if (a_in < 0.0 && b_in < 0.0) {
        out.clip_position = vec4<f32>(2.0, 2.0, 2.0, 1.0);
        out.alpha = 0.0;
        return out;
    }
    if (a_in < 0.0) {
        a = mix(a, b, a_in / (a_in - b_in));
    }
    if (b_in < 0.0) {
        b = mix(b, a, b_in / (b_in - a_in));
    }
    let half_px = 0.5 * frame.viewport_size_px;
    let a_px = a.xy / a.w * half_px;
    let b_px = b.xy / b.w * half_px;
    var along = b_px - a_px;
    let length_px = length(along);
    along = select(vec2<f32>(0.0, 1.0), along / max(length_px, 1e-6), length_px > 1e-3);
    let side = vec2<f32>(-along.y, along.x);
    let distance_m = max(eye_distance_m(head), 1e-3);
    let diameter_px = diameter_m / pixel_footprint_m(distance_m);
    let width_px = max(diameter_px, rain.camera_velocity.w);
    out.alpha = min(1.0, 0.25 * PI * diameter_px * diameter_px / (width_px * (length_px + width_px)));
    // Corners: (end, side) for two triangles.
    let ends = array<u32, 6>(0u, 0u, 1u, 0u, 1u, 1u);
    let sides = array<f32, 6>(-1.0, 1.0, -1.0, 1.0, 1.0, -1.0);
    let end = ends[corner];
    let s = sides[corner];
    let base = select(a, b, end == 1u);
    let cap = select(-1.0, 1.0, end == 1u);
    let offset_px = side * (s * 0.5 * width_px) + along * (cap * 0.5 * width_px);
    out.clip_position = vec4<f32>(base.xy + offset_px / half_px * base.w, base.z, base.w);
    out.across = s;
    return out;
}

@vertex
fn streak_vertex_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> StreakVarying {
    let drop = drops[visible[instance]];
    let tail = drop.position_m - (drop.velocity_m_s - rain.camera_velocity.xyz) * rain.zones.w;
    return streak_vertex(drop.position_m, tail, drop.diameter_mm * 1e-3, vertex);
}

// A splash: droplets thrown from the impact point on ballistic paths, at a
// fraction of the impact speed (crown splashes eject secondary droplets at
// roughly 0.1–0.5 of it; Yarin, "Drop impact dynamics", Annu. Rev. Fluid
// Mech. 38, 2006), each drawn as a short streak like a drop.
@vertex
fn splash_vertex_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> StreakVarying {
    let slot = instance / SPLASH_DROPLETS;
    let droplet = instance % SPLASH_DROPLETS;
    let splash = splashes[slot];
    let age = frame.time_s - splash.position_time.w;
    let impact_speed = length(splash.velocity_diameter.xyz);
    var hidden: StreakVarying;
    hidden.clip_position = vec4<f32>(2.0, 2.0, 2.0, 1.0);
    hidden.alpha = 0.0;
    if (age < 0.0 || age > SPLASH_LIFETIME_S || impact_speed <= 0.0) {
        return hidden;
    }
    let key = instance * 3u + 0x9e37u;
    let speed = impact_speed * (0.15 + 0.25 * hash_unit(key));
    let elevation = radians(40.0 + 35.0 * hash_unit(key + 1u));
    let azimuth = 2.0 * PI * hash_unit(key + 2u);
    let v0 = vec3<f32>(cos(elevation) * cos(azimuth), sin(elevation), cos(elevation) * sin(azimuth)) * speed;
    let g = vec3<f32>(0.0, -GRAVITY_M_S2, 0.0);
    let origin = splash.position_time.xyz + vec3<f32>(0.0, 0.002, 0.0);
    let head = origin + v0 * age + 0.5 * g * age * age;
    let t0 = max(age - rain.zones.w, 0.0);
    let tail = origin + v0 * t0 + 0.5 * g * t0 * t0;
    if (head.y < origin.y) {
        return hidden;
    }
    return streak_vertex(head, tail, splash.velocity_diameter.w * 0.2e-3, vertex);
}

// The drop's kernel K(cos γ), sr⁻¹, linear between the bins' centres
// (DropTransfer::kernel_at).
fn drop_kernel(cos_gamma: f32) -> f32 {
    let x = (clamp(cos_gamma, -1.0, 1.0) + 1.0) * 32.0 - 0.5;
    let i = u32(clamp(floor(x), 0.0, 62.0));
    let f = clamp(x - f32(i), 0.0, 1.0);
    let a = rain.drop_kernel[i / 4u][i % 4u];
    let b = rain.drop_kernel[(i + 1u) / 4u][(i + 1u) % 4u];
    return mix(a, b, f);
}

// Radiance of a drop at `p`, pre-exposed: the sky (or the overcast's
// radiosity under a stratus layer) and the sun through and off the drop.
fn drop_radiance(p: vec3<f32>) -> vec3<f32> {
    let v = -to_eye_world(p);
    let sky = stratus_ground_irradiance(p, v, sh_convolved(lighting, v, rain.drop_sh_weights.xyz));
    let sun = lighting.sun_irradiance.xyz * stratus_sun_transmittance(p) * drop_kernel(dot(v, frame.sun_direction));
    return (sky + sun) * pre_exposure();
}

@fragment
fn streak_fragment(in: StreakVarying) -> @location(0) vec4<f32> {
    // A soft profile across (mean 1 over the width) and a soft fade where
    // the streak meets a surface (0.3 m).
    let profile = 1.5 * (1.0 - in.across * in.across);
    let scene = view_depth_m(textureLoad(scene_depth, vec2<i32>(in.clip_position.xy), 0));
    let own = view_depth_m(in.clip_position.z);
    let fade = clamp((scene - own) / 0.3, 0.0, 1.0);
    let alpha = clamp(in.alpha * profile * fade, 0.0, 1.0);
    let radiance = min(drop_radiance(in.head_m), vec3<f32>(frame.max_pre_exposed));
    return vec4<f32>(radiance * alpha, alpha);
}
