// import shader/cloud_layer_lookup.wgsl
// import passes/rain/rain_types.wgsl
// import passes/rain/zones.wgsl
// import shader/hemisphere_moments.wgsl
// import passes/rain/mist_slab.wgsl
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
// The light scattered in is the diffuse field's, seen through the mist's
// forward-peaked phase function (raindrops diffract: Henyey–Greenstein
// g = 0.85 stands in for their geometric-optics phase function; van de
// Hulst 1957, §12–13), plus the sun's single scattering with it, shadowed
// by the stratus layer at each point of the ray (so only the air under the
// layer's gaps glows in the sun). Under a layer the diffuse field is the
// column's: the air from the ground to the deck's base is a scattering
// slab, solved once by adding–doubling in the physics crate
// (nimbus_physics::rain::mist_slab) and read from its table
// (passes/rain/mist_slab.wgsl): the deck's light (R_G, the radiosity's
// irradiance on the ground, leaving the deck by the escape function or
// uniformly for a volume deck), the base's and the ground's reflections,
// and the sun through the layer's gaps, averaged around the camera
// (mist_column_sun). A thick mist is as bright just below the horizon as
// just above; the two hemispheres of a Lambertian ground and the deck made
// it too dark sideways (docs/REALISM.md, "The rain mist as a slab").
// stratus.model = "bnl2006" keeps the field's mean radiance (the source
// function of a conservative medium in an isotropic field). Under a clear
// sky, the environment's SH from above and below.
//
// The droplets' forward lobe goes on with the view (δ-M, Wiscombe 1977):
// a fraction f = g² of what the mist scatters leaves within about 20° of
// its way, so that a background that varies slowly over that width (the
// deck, its bright cells towards the horizon, the far terrain) reaches
// the eye as if unscattered. The march attenuates by (1 − f)β; the
// diffuse field's source keeps the whole phase function (δ-M's source
// over a field smooth at the lobe's width); the sun's single scattering
// keeps it too (Nakajima & Tanaka 1988's TMS correction: the exact phase
// function for the once-scattered sun in the scaled medium), its beam
// dimmed by the δ-M mist above each point as by the layer
// (docs/REALISM.md, "The rain mist's forward lobe"). Drawn over everything
// with blending dst·T + src.

@group(1) @binding(2) var scene_depth: texture_depth_2d;

const MIST_STEPS: u32 = 32u;
const MIST_MAX_DISTANCE_M: f32 = 30000.0;
const MIST_PHASE_G: f32 = 0.85;
// δ-M's forward fraction f = g² of the mist's phase function, left in the
// eye's ray and in the sun's beam
// (nimbus_physics::rain::mist_light::MIST_FORWARD_FRACTION).
const MIST_FORWARD_FRACTION: f32 = MIST_PHASE_G * MIST_PHASE_G;
// Asymmetry of the cloud droplets for the deck's diffuse reflectance from
// below (nimbus_physics::cumulus::shading::CLOUD_ASYMMETRY).
const MIST_DECK_ASYMMETRY: f32 = 0.85;
// The layer's shadow is evaluated at four points of the ray (the middles of
// its quarters of steps) before the march and held over each quarter:
// texture lookups inside the march's loop cost llvmpipe about twice the
// whole pass, and the shadow varies over the cells' size, while the steps
// grow geometrically.
const MIST_SHADOW_SEGMENTS: u32 = 4u;

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

// The diffuse light field at `position_m` scattered towards an eye looking
// along `direction`, W·sr⁻¹·m⁻² (see the file's notes): under a clear sky
// (E↓/π)M₀ + (E↑/π)(1 − M₀) for irradiance E↓ from above and E↑ from below,
// M₀ the phase function's hemisphere moment around the direction; under a
// layer the column slab's source, `sun_through_layer` the sun's light
// through the layer on the column (mist_column_sun).
fn mist_ambient_radiance(position_m: vec3<f32>, direction: vec3<f32>, sun_through_layer: vec3<f32>) -> vec3<f32> {
    if (!stratus_enabled() || position_m.y >= stratus.window.x) {
        // The clear sky above, the sunlit ground below (the environment's SH).
        let up = vec3<f32>(0.0, 1.0, 0.0);
        let m = hg_hemisphere_moments(MIST_PHASE_G, direction.y);
        return (sh_irradiance(lighting, up) * m.x + sh_irradiance(lighting, -up) * (1.0 - m.x)) / PI;
    }
    let clear_column = stratus_radiosity_sample(true, position_m.xz);
    if (stratus.model.x == 0u) {
        let rho = atmosphere.near_ground_albedo;
        let sun_on_ground = sun_irradiance_at(position_m) * max(frame.sun_direction.y, 0.0)
            * mist_sun_shadow(position_m);
        // stratus.model = "bnl2006": the field's mean radiance.
        return (clear_column + rho * (clear_column + sun_on_ground)) / (2.0 * PI);
    }
    // The column between the ground and the deck's base is a scattering
    // slab: its light at this height, seen along `direction`, from the
    // adding–doubling table (passes/rain/mist_slab.wgsl). The deck sends
    // its light in its own shape (stratus_deck_light_shape: the escape
    // function for the faces, uniform where the layer is drawn as a
    // volume); the slab turns it into its own field, continuous across
    // the horizon, and couples base and ground. The column stands on the
    // ground under the camera.
    let intensity = rain.drops.x * zone_factor(position_m.x, position_m.z);
    let beta = rain_extinction(intensity, 0.0, rain.drops.z);
    let column_m = max(rain.drops.w - rain.mist_ground.x, 0.0);
    let column_tau = beta * column_m;
    let height = 1.0 - clamp(rain.drops.w - position_m.y, 0.0, column_m) / max(column_m, 1e-3);
    let deck_reflectance = mist_deck_reflectance(
        stratus.extinction.y * stratus_thickness_at(position_m.xz), MIST_DECK_ASYMMETRY);
    // The sun through the layer (`sun_through_layer`, mist_column_sun: its
    // mean around the camera) enters the column; what the column scatters,
    // 1 − e^(−(1 − g²)τ/μ₀) (δ-M: the forward peak, a fraction g² of the
    // phase function, goes on with the beam; Wiscombe 1977), enters the
    // slab diffusely; the rest reaches the ground as a beam.
    let unscattered = exp(-(1.0 - MIST_FORWARD_FRACTION) * column_tau / max(frame.sun_direction.y, 0.05));
    // The ground under the column, its albedo around the camera (the
    // frame's near-ground albedo is the whole terrain's).
    let local_rho = rain.mist_ground.yzw;
    return mist_slab_source(column_tau, height, direction.y, local_rho, deck_reflectance,
        stratus.model.y == 1u, clear_column, sun_through_layer * (1.0 - unscattered),
        local_rho * sun_through_layer * unscattered);
}

// Samples of the disc over which the column's sun through the layer is
// averaged (mist_column_sun).
const MIST_GAP_SAMPLES: u32 = 16u;

// The sun's light through the layer on the mist's column at `position_m`,
// W/m² on a horizontal surface: the mist scatters it sideways over its
// transport length 1/((1 − g)β) (1.5 km in heavy rain), so the column takes
// the layer's shadow averaged over a disc of that radius (held between
// 200 m and 3 km), not the shadow at the camera: a sunflower pattern of
// MIST_GAP_SAMPLES points of equal area. It depends on the camera alone:
// the vertex shader evaluates it once and hands it to every pixel.
fn mist_column_sun(position_m: vec3<f32>) -> vec3<f32> {
    let l = frame.sun_direction;
    if (!stratus_enabled() || position_m.y >= stratus.window.x || l.y <= 0.0) {
        return vec3<f32>(0.0);
    }
    let intensity = rain.drops.x * zone_factor(position_m.x, position_m.z);
    let beta = rain_extinction(intensity, 0.0, rain.drops.z);
    let radius = clamp(1.0 / max((1.0 - MIST_PHASE_G) * beta, 1e-6), 200.0, 3000.0);
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < MIST_GAP_SAMPLES; k++) {
        let r = radius * sqrt((f32(k) + 0.5) / f32(MIST_GAP_SAMPLES));
        // The golden angle, rad.
        let a = 2.3999632 * f32(k);
        sum += mist_sun_shadow(position_m + vec3<f32>(r * cos(a), 0.0, r * sin(a)));
    }
    return sun_irradiance_at(position_m) * l.y * sum / f32(MIST_GAP_SAMPLES);
}

// The layer's shadow on the mist at `position_m`: its directional
// transmittance T_C where the sun's ray from there crosses the layer. The
// crossing is held inside the thickness window: beyond it the thickness
// would come from the procedural field itself, a dozen noise octaves per
// lookup, and the mist that far is seen through the nearer mist.
fn mist_sun_shadow(position_m: vec3<f32>) -> vec3<f32> {
    let l = frame.sun_direction;
    if (!stratus_enabled() || l.y <= 0.0 || position_m.y >= stratus.window.x) {
        return vec3<f32>(1.0);
    }
    let half_texel = 0.5 * stratus.window.y / f32(stratus.flags.w);
    let low = stratus.window.zw + half_texel;
    let high = stratus.window.zw + stratus.window.y - half_texel;
    let h = stratus_thickness_at(clamp(stratus_sun_crossing(position_m), low, high));
    return slab_directional_transmittance(stratus, h, l.y);
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
    // mist_column_sun at the camera (the view's centre: an orthographic
    // view's rays start across the screen), the same at every vertex.
    @location(1) @interpolate(flat) column_sun: vec3<f32>,
}

@vertex
fn mist_vertex(@builtin(vertex_index) vertex: u32) -> MistVarying {
    let uv = vec2<f32>(f32((vertex << 1u) & 2u), f32(vertex & 2u));
    var out: MistVarying;
    out.clip_xy = uv * 2.0 - 1.0;
    out.clip_position = vec4<f32>(out.clip_xy, 0.0, 1.0);
    out.column_sun = mist_column_sun(view_ray_origin_world(vec2<f32>(0.0)));
    return out;
}

@fragment
fn mist_fragment(in: MistVarying) -> @location(0) vec4<f32> {
    let direction = view_ray_world(in.clip_xy);
    let depth = textureLoad(scene_depth, vec2<i32>(in.clip_position.xy), 0);
    let origin = view_ray_origin_world(in.clip_xy);
    // Distance to the surface (reverse-Z: depth 0 is the far plane).
    var end_m = MIST_MAX_DISTANCE_M;
    if (depth > 0.0) {
        end_m = min(length(world_at_depth(in.clip_xy, depth) - origin), MIST_MAX_DISTANCE_M);
    }
    // Stop where the ray rises above the ceiling.
    if (direction.y > 1e-4 && origin.y < rain.drops.w) {
        end_m = min(end_m, (rain.drops.w - origin.y) / direction.y);
    }
    if (origin.y >= rain.drops.w && direction.y >= 0.0) {
        return vec4<f32>(0.0);
    }
    let box_m = rain.mist.x;
    let layer_m = rain.mist.y;
    // Geometric steps: fine near the camera, long far away.
    let ratio = pow(max(end_m, 1.0), 1.0 / f32(MIST_STEPS));
    // Transmittance from the camera to the current step, of the extinction
    // (1 − f)β: the forward part f of the scattering stays in the ray.
    var transmittance = 1.0;
    // ∫ β(s) T(0, s) T_C(s) T_M(s) ds: the sunlit extinction seen along the
    // ray, T_C the layer's directional transmittance of the sun at each
    // point, T_M the δ-M mist's between the point and the rain's ceiling.
    let sun_mu = max(frame.sun_direction.y, 0.05);
    var sunlit = vec3<f32>(0.0);
    let steps_per_segment = MIST_STEPS / MIST_SHADOW_SEGMENTS;
    var shadows: array<vec3<f32>, MIST_SHADOW_SEGMENTS>;
    shadows[0] = mist_sun_shadow(origin + direction * min(pow(ratio, 4.5), end_m));
    shadows[1] = mist_sun_shadow(origin + direction * min(pow(ratio, 12.5), end_m));
    shadows[2] = mist_sun_shadow(origin + direction * min(pow(ratio, 20.5), end_m));
    shadows[3] = mist_sun_shadow(origin + direction * min(pow(ratio, 28.5), end_m));
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
            let scaled_beta = (1.0 - MIST_FORWARD_FRACTION) * beta;
            let step_tau = scaled_beta * (s - previous);
            let shadow = shadows[min((i - 1u) / steps_per_segment, MIST_SHADOW_SEGMENTS - 1u)];
            let beam = exp(-scaled_beta * max(rain.drops.w - p.y, 0.0) / sun_mu);
            // Exact for constant β over the step: T(0, s₀)·(1 − e^(−Δτ)), Δτ
            // the scaled step's (β ds = that over 1 − f, taken once below).
            let step_transmittance = exp(-step_tau);
            sunlit += transmittance * (1.0 - step_transmittance) * shadow * beam;
            transmittance *= step_transmittance;
        }
        previous = s;
        if (s >= end_m) {
            break;
        }
    }
    let g = MIST_PHASE_G;
    let mu = dot(direction, frame.sun_direction);
    let phase = (1.0 - g * g) / (4.0 * PI * pow(1.0 + g * g - 2.0 * g * mu, 1.5));
    let radiance = mist_ambient_radiance(origin, direction, in.column_sun) * (1.0 - transmittance)
        + lighting.sun_irradiance.xyz * phase * sunlit / (1.0 - MIST_FORWARD_FRACTION);
    let inscattered = min(radiance * pre_exposure(), vec3<f32>(frame.max_pre_exposed));
    // Premultiplied over: the frame behind is seen through the transmittance
    // (alpha is the mist's coverage, 1 − T).
    return vec4<f32>(inscattered, 1.0 - transmittance);
}
