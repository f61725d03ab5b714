// import shader/cloud_layer_lookup.wgsl
// import shader/cloud_shadow_lookup.wgsl
// import shader/diffusion.wgsl
// import shader/fullscreen.wgsl
// The camera within the stratus layer's height range (or within
// IN_LAYER_HANDOVER_M of it, where the faces hand over): the layer drawn
// as the volume it stands for, |y − y_mid| < h(x, z)/2, marched from the
// camera through the thickness field to the first opaque surface or out of
// the height range, and blended over everything (premultiplied, weighted by
// stratus.slab_r_beta.z, the faces drawn with the rest).
//
// The light scattered towards the camera at a point of a cell: the direct
// sun's single scattering through the peak-removed phase function P_S,
// attenuated by e^{−κ_s d/μ₀} from the lit face (κ_s = (1 − P_f) κ, the
// δ-M extinction the layer model uses; d the depth below the cell's top,
// or the sun ray's path through cloud times μ₀ where shorter: the cells'
// sunlit sides), plus the diffuse light of the column as a conservative
// slab in the diffusion approximation at that depth, lit by the sun's beam,
// the sky from above and the ground's radiosity from below, as Eddington's
// radiance (Φ − μ Φ')/(4π): the fluence's isotropic part and the net
// flux's, so that looking up into an overcast is brighter than looking
// level (twin: nimbus_physics::transport::diffusion; the same slab and the
// same inputs as the faces' shading, layer.wgsl).

@group(1) @binding(0) var in_layer_depth: texture_depth_2d;

const IN_LAYER_STEPS: u32 = 48u;
const IN_LAYER_SEGMENTS: u32 = 4u;
// The droplets' asymmetry g (nimbus_physics::cumulus::shading::CLOUD_ASYMMETRY,
// the cumulus shadow's two-stream): the transport extinction (1 − g) κ.
const IN_LAYER_ASYMMETRY: f32 = 0.85;
// The fine octaves at the camera are carried along the ray over this
// distance (m), then the window's coarse relief alone: where the camera
// crosses a face the march and the faces agree.
const IN_LAYER_DETAIL_M: f32 = 400.0;

// Twin of diffusion::collimated_fluence.
fn in_layer_collimated(t_in: f32, total_in: f32, mu0: f32) -> f32 {
    if (mu0 <= 0.0) {
        return 0.0;
    }
    let total = max(total_in, 0.0);
    let t = clamp(t_in, 0.0, total);
    let ab = in_layer_collimated_coefficients(total, mu0);
    return max(ab.x + ab.y * t - 3.0 * mu0 * mu0 * exp(-t / mu0), 0.0);
}

// Twin of diffusion::collimated_coefficients: (A, B) of the beam's solution.
fn in_layer_collimated_coefficients(total: f32, mu0: f32) -> vec2<f32> {
    let e = exp(-total / mu0);
    let b = -(3.0 * mu0 * mu0 * (1.0 - e) + 2.0 * mu0 * (1.0 + e)) / (total + 4.0 / 3.0);
    return vec2<f32>(3.0 * mu0 * mu0 + 2.0 * mu0 + 2.0 / 3.0 * b, b);
}

// Twin of diffusion::diffuse_fluence.
fn in_layer_diffuse(t_in: f32, total_in: f32, top: vec3<f32>, base: vec3<f32>) -> vec3<f32> {
    let total = max(total_in, 0.0);
    let t = clamp(t_in, 0.0, total);
    let b = 4.0 * (base - top) / (total + 4.0 / 3.0);
    let a = 4.0 * top + 2.0 / 3.0 * b;
    return max(a + b * t, vec3<f32>(0.0));
}

// Twin of diffusion::collimated_fluence_gradient: dΦ/dt per unit irradiance.
fn in_layer_collimated_gradient(t_in: f32, total_in: f32, mu0: f32) -> f32 {
    if (mu0 <= 0.0) {
        return 0.0;
    }
    let total = max(total_in, 0.0);
    let t = clamp(t_in, 0.0, total);
    return in_layer_collimated_coefficients(total, mu0).y + 3.0 * mu0 * exp(-t / mu0);
}

// Twin of diffusion::diffuse_fluence_gradient.
fn in_layer_diffuse_gradient(total_in: f32, top: vec3<f32>, base: vec3<f32>) -> vec3<f32> {
    return 4.0 * (base - top) / (max(total_in, 0.0) + 4.0 / 3.0);
}

// Steps of the march towards the sun from a step of the view's march.
const IN_LAYER_SUN_STEPS: u32 = 6u;
// The sun's paths are marched at every this many steps of the view's.
const IN_LAYER_SUN_EVERY: u32 = 4u;

// Length of cloud (m) on the ray from `p` along `l` until it leaves the
// layer's height range (at most two feature sizes): the cells' sides
// facing a low sun are lit through their sides, not only from their tops.
// The window's coarse relief; steps growing quadratically.
fn in_layer_sun_path_m(p: vec3<f32>, l: vec3<f32>) -> f32 {
    let mid = stratus.window.x;
    let half = 0.5 * stratus.shape.w;
    let exit_y = select(mid - half, mid + half, l.y > 0.0);
    var range = 2.0 / stratus.shape.x;
    if (abs(l.y) > 1e-4) {
        range = min(range, max((exit_y - p.y) / l.y, 0.0));
    }
    var inside = 0.0;
    for (var i = 0u; i < IN_LAYER_SUN_STEPS; i += 1u) {
        let a = f32(i) / f32(IN_LAYER_SUN_STEPS);
        let b = f32(i + 1u) / f32(IN_LAYER_SUN_STEPS);
        let q = p + l * (range * 0.5 * (a * a + b * b));
        let h = stratus_thickness_at(q.xz);
        if (abs(q.y - mid) < 0.5 * h) {
            inside += range * (b * b - a * a);
        }
    }
    return inside;
}

struct InLayerLight {
    // The sun's normal irradiance through the cumulus' shadows (rgb).
    sun: vec3<f32>,
    // The ground's light entering the base (radiosity), W m⁻².
    ground: vec3<f32>,
}

fn in_layer_light(p: vec3<f32>) -> InLayerLight {
    var out: InLayerLight;
    out.sun = sun_irradiance_at(p) * cloud_shadow_transmittance(p);
    out.ground = stratus_radiosity_sample(false, p.xz);
    return out;
}

@fragment
fn in_layer_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    let weight = stratus.slab_r_beta.z;
    if (weight <= 0.0 || !stratus_enabled()) {
        return vec4<f32>(0.0);
    }
    let direction = view_ray_world(in.clip_xy);
    let origin = view_ray_origin_world(in.clip_xy);
    let depth = textureLoad(in_layer_depth, vec2<i32>(in.position.xy), 0);
    var end_m = 0.5 * stratus.window.y;
    if (depth > 0.0) {
        end_m = min(end_m, length(world_at_depth(in.clip_xy, depth) - origin));
    }
    // The ray's span within the layer's height range.
    let mid = stratus.window.x;
    let half = 0.5 * stratus.shape.w;
    var t0 = 0.0;
    var t1 = end_m;
    if (abs(direction.y) > 1e-6) {
        let a = (mid - half - origin.y) / direction.y;
        let b = (mid + half - origin.y) / direction.y;
        t0 = max(min(a, b), 0.0);
        t1 = min(max(a, b), end_m);
    } else if (abs(origin.y - mid) > half) {
        return vec4<f32>(0.0);
    }
    if (t1 <= t0) {
        return vec4<f32>(0.0);
    }
    let l = frame.sun_direction;
    let sun_above = l.y > 0.0;
    let mu0 = max(abs(l.y), 0.02);
    let kappa = stratus.extinction.y;
    let kappa_s = (1.0 - stratus.forward_fraction.y) * kappa;
    let kappa_t = (1.0 - IN_LAYER_ASYMMETRY) * kappa;
    let phase = stratus_peak_removed(acos(clamp(dot(l, direction), -1.0, 1.0)));
    let sky = lighting.sky_irradiance_up.xyz;
    let detail_m = layer_thickness_m(stratus, origin.xz) - stratus_thickness_at(origin.xz);
    // The lights, at the middles of four quarters of the ray, held over
    // each (texture lookups in the loop are what costs on llvmpipe).
    var lights: array<InLayerLight, IN_LAYER_SEGMENTS>;
    let span = t1 - t0;
    for (var k = 0u; k < IN_LAYER_SEGMENTS; k += 1u) {
        let f = (f32(k) + 0.5) / f32(IN_LAYER_SEGMENTS);
        lights[k] = in_layer_light(origin + direction * (t0 + span * f * f * f));
    }
    var radiance = vec3<f32>(0.0);
    var transmittance = 1.0;
    var weighted = vec3<f32>(0.0);
    var total_weight = 0.0;
    var sun_paths = vec2<f32>(0.0);
    var have_sun_paths = false;
    for (var i = 0u; i < IN_LAYER_STEPS; i += 1u) {
        // Steps at t₀ + span (i/N)³: the first ~0.2 m long over a span of
        // 20 km, so that the camera crossing a face moves a few steps, not
        // the first one (quadratic steps made a one-frame step there).
        let a = f32(i) / f32(IN_LAYER_STEPS);
        let b = f32(i + 1u) / f32(IN_LAYER_STEPS);
        let dt = span * (b * b * b - a * a * a);
        let t = t0 + span * 0.5 * (a * a * a + b * b * b);
        let p = origin + direction * t;
        let fade = stratus_window_fade(p.xz);
        let h = max(stratus_thickness_at(p.xz) + detail_m * saturate(1.0 - t / IN_LAYER_DETAIL_M), 0.0);
        let below_top = mid + 0.5 * h - p.y;
        let above_base = p.y - (mid - 0.5 * h);
        if (below_top <= 0.0 || above_base <= 0.0 || fade <= 0.0) {
            continue;
        }
        let light = lights[min(i * IN_LAYER_SEGMENTS / IN_LAYER_STEPS, IN_LAYER_SEGMENTS - 1u)];
        // The sun enters a cell by its top (depth below it, cosine μ₀) or,
        // low, by the side facing it (the sun ray's path through cloud
        // shorter than the top's slant depth; the side's cosine √(1 − μ₀²)):
        // the point is in a slab across that face as thick as the cloud's
        // chord along the sun through it (towards and away from the sun).
        let lit_depth_m = select(above_base, below_top, sun_above);
        // The diffuse part's depth axis points down: the light reaching the
        // camera travels along −direction, at cosine direction.y to it.
        var diffuse = eddington_radiance(in_layer_diffuse(kappa_t * below_top, kappa_t * h, sky, light.ground),
            in_layer_diffuse_gradient(kappa_t * h, sky, light.ground), direction.y);
        var direct = vec3<f32>(0.0);
        if (l.y > 0.0) {
            // The sun ray's paths (towards and away from the sun), marched
            // at every fourth step and held over the next three (the
            // in-layer pass cost 2.7 s a frame at 640×360 on llvmpipe
            // marching them at every step, 1.0 s this way).
            if (i % IN_LAYER_SUN_EVERY == 0u || !have_sun_paths) {
                sun_paths = vec2<f32>(in_layer_sun_path_m(p, l), in_layer_sun_path_m(p, -l));
                have_sun_paths = true;
            }
            let top_path_m = lit_depth_m / mu0;
            let path_m = min(sun_paths.x, top_path_m);
            let chord_m = path_m + sun_paths.y;
            let side_lit = path_m < 0.9 * top_path_m;
            let mu_face = select(mu0, sqrt(max(1.0 - mu0 * mu0, 0.0)), side_lit);
            // The beam's depth axis: into the lit face, down from the top,
            // up from the base, or away from the sun through a side.
            var axis = vec3<f32>(0.0, select(1.0, -1.0, sun_above), 0.0);
            if (side_lit) {
                axis = -normalize(vec3<f32>(l.x, 0.0, l.z) + vec3<f32>(1e-6, 0.0, 0.0));
            }
            let depth = kappa_t * path_m * mu_face;
            let thickness = kappa_t * chord_m * mu_face;
            diffuse += light.sun * eddington_radiance(vec3<f32>(in_layer_collimated(depth, thickness, mu_face)),
                vec3<f32>(in_layer_collimated_gradient(depth, thickness, mu_face)), dot(-direction, axis));
            direct = light.sun * exp(-kappa_s * path_m);
        }
        let source = phase * direct + diffuse;
        let opacity = (1.0 - exp(-kappa_s * dt)) * fade;
        let scattered = transmittance * opacity;
        radiance += scattered * source;
        weighted += scattered * p;
        total_weight += scattered;
        transmittance *= 1.0 - opacity;
    }
    let alpha = 1.0 - transmittance;
    if (alpha <= 0.0) {
        return vec4<f32>(0.0);
    }
    // The air in front of the light, at its mean depth: α f(L/α).
    let mean_m = weighted / max(total_weight, 1e-6);
    let ap = stratus_aerial_perspective(mean_m);
    let seen = radiance * ap.a + ap.rgb * alpha;
    return vec4<f32>(min(seen * pre_exposure(), vec3<f32>(frame.max_pre_exposed)) * weight, alpha * weight);
}
