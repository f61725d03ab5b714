// import shader/cloud_layer_lookup.wgsl
// import shader/cloud_shadow_lookup.wgsl
// import shader/diffusion.wgsl
// import shader/fullscreen.wgsl
// The camera inside a cell of the stratus layer (or within
// IN_LAYER_HANDOVER_M of it, where the faces hand over), or anywhere with
// stratus.model = "volume": the layer drawn as the volume it stands for,
// |y − y_mid| < h(x, z)/2, marched from where the ray first enters a cell
// through the thickness field to the first opaque surface or out of the
// height range, and blended over what is behind it (premultiplied,
// weighted by stratus.slab_r_beta.z, the faces drawn with the rest).
//
// The light scattered towards the camera at a point of a cell: the direct
// sun's single scattering through the peak-removed phase function P_S,
// attenuated by e^{−κ_s d/μ₀} from the lit face (κ_s = (1 − P_f) κ, the
// δ-M extinction the layer model uses; d the depth below the cell's top,
// or the sun ray's path through cloud times μ₀ where shorter: the cells'
// sunlit sides), plus the diffuse light of the column as a conservative
// slab in the δ-Eddington approximation at that depth, lit by the sun's
// beam, the sky from above and the ground's radiosity from below, scattered
// towards the camera: the P1 field's source (Φ + 3 g* μ F)/(4π), the
// fluence's isotropic part and the net flux's through the peak-removed
// phase function's asymmetry g*, so that looking up into an overcast is
// brighter than looking level. (The march integrates the source along the
// ray: sending the field's radiance (Φ + 3 μ F)/(4π) instead counted the
// flux twice and made the view up 9 % too bright.) Plus the light the
// δ-Eddington beam holds beyond the unscattered one, in the forward orders'
// lobe (twins: nimbus_physics::transport::diffusion and cumulus::interior::
// forward_orders_lobe; the same slab and the same inputs as the faces'
// shading, layer.wgsl). Near a lit top, where the sun's light has not
// diffused, its scattered part is the source traced in a slab instead
// (stratus_interior_source, twin of transport::interior_source). Under a
// low sun other cells between the sun and a cell's lit top shade it, as
// they shade the faces (in_layer_top_shading_m).

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
// How far before the entry into the first cell the march starts (at most;
// a quarter of the entry's distance when nearer), m.
const IN_LAYER_ENTRY_LEAD_M: f32 = 50.0;

// The δ-Eddington beam rate ρ = 1 + g (diffusion::delta_eddington_beam_rate):
// the droplets' forward peak, f = g², stays in the sun's beam, the rest
// feeds the diffuse light (a camera inside the layer sees it; ρ = 1, every
// forward scattering left in the beam, gave 0.80–0.83 of the traced light
// looking up at an overcast's mid-plane).
const IN_LAYER_BEAM_RATE: f32 = 1.0 + IN_LAYER_ASYMMETRY;

// Twin of diffusion::collimated_fluence.
fn in_layer_collimated(t_in: f32, total_in: f32, mu0: f32, rate: f32) -> f32 {
    if (mu0 <= 0.0) {
        return 0.0;
    }
    let total = max(total_in, 0.0);
    let t = clamp(t_in, 0.0, total);
    let ab = in_layer_collimated_coefficients(total, mu0, rate);
    return max(ab.x + ab.y * t - 3.0 * mu0 * mu0 * exp(-rate * t / mu0), 0.0);
}

// Twin of diffusion::collimated_coefficients: (A, B) of the beam's solution.
fn in_layer_collimated_coefficients(total: f32, mu0: f32, rate: f32) -> vec2<f32> {
    let e = exp(-rate * total / mu0);
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

// Twin of diffusion::collimated_net_flux: the diffuse net flux into the
// slab per unit irradiance.
fn in_layer_collimated_net_flux(t_in: f32, total_in: f32, mu0: f32, rate: f32) -> f32 {
    if (mu0 <= 0.0) {
        return 0.0;
    }
    let total = max(total_in, 0.0);
    let t = clamp(t_in, 0.0, total);
    return -in_layer_collimated_coefficients(total, mu0, rate).y / 3.0 - mu0 * exp(-rate * t / mu0);
}

// Twin of diffusion::diffuse_net_flux (downwards).
fn in_layer_diffuse_net_flux(total_in: f32, top: vec3<f32>, base: vec3<f32>) -> vec3<f32> {
    return 4.0 * (top - base) / (3.0 * max(total_in, 0.0) + 4.0);
}

// The scattering optical depths below the top over which the traced source
// hands over to the P1 field.
const IN_LAYER_TABLE_HANDOVER: vec2<f32> = vec2<f32>(3.0, 4.5);

// Steps of the march towards the sun from a step of the view's march.
const IN_LAYER_SUN_STEPS: u32 = 6u;
// The sun's paths are marched at every this many steps of the view's and
// interpolated between (held, they made facets with straight edges).
const IN_LAYER_SUN_EVERY: u32 = 4u;

// Distance along the view ray of the middle of step `i` of the march: at
// t₀ + span (i/N)³ (the first ~0.2 m long over a span of 20 km, so that the
// camera crossing a face moves a few steps, not the first one; quadratic
// steps made a one-frame step there).
fn in_layer_step_m(i: u32, t0: f32, span: f32) -> f32 {
    let a = f32(i) / f32(IN_LAYER_STEPS);
    let b = f32(i + 1u) / f32(IN_LAYER_STEPS);
    return t0 + span * 0.5 * (a * a * a + b * b * b);
}

// Length of cloud (m) on the ray from `p` along `l` until it leaves the
// layer's height range (at most two feature sizes): the cells' sides
// facing a low sun are lit through their sides, not only from their tops.
// The window's coarse relief; steps growing quadratically, each counted
// by how deep its middle is in the cloud over a soft band as wide as the
// step's rise (a step in or out made the path, and the light, jump where
// a step's middle crossed a face: facets on the image). Where the window
// fades out the cloud thins (see the march), so a metre there counts as
// its fade's share of a metre.
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
        let step_m = range * (b * b - a * a);
        let band_m = max(step_m * (abs(l.y) + 0.1), 1.0);
        inside += step_m * stratus_window_fade(q.xz) * saturate((0.5 * h - abs(q.y - mid)) / band_m + 0.5);
    }
    return inside;
}

// The sun's diffuse light per unit normal irradiance scattered towards the
// camera at a point `path` (a transport optical depth along the beam) into
// a slab across the lit face as thick as the chord `chord` along the beam,
// the face at cosine `mu_face` to it, the light travelling at cosine
// `mu_view` to the depth axis: the P1 source (diffusion::eddington_source)
// of droplets of asymmetry `asymmetry`.
fn in_layer_beam_source(path: f32, chord: f32, mu_face: f32, mu_view: f32, asymmetry: f32) -> f32 {
    let depth = path * mu_face;
    let thickness = chord * mu_face;
    return eddington_source(vec3<f32>(in_layer_collimated(depth, thickness, mu_face, IN_LAYER_BEAM_RATE)),
        vec3<f32>(in_layer_collimated_net_flux(depth, thickness, mu_face, IN_LAYER_BEAM_RATE)), mu_view,
        asymmetry).x;
}

// The smallest cosine of the sun to a side's face: where the slope found
// at the sun's entry turns away from it (the field's texels), the face
// still takes a little light rather than none.
const IN_LAYER_MIN_FACE_COSINE: f32 = 0.05;

// Length of cloud (m) the sun's path from the top of the column at `p`
// crosses on its way out of the layer's height range (at most two feature
// sizes): the other cells that shade that column's lit top. The faces'
// march (stratus_cloud_along_ray_m, twin of
// nimbus_physics::cloud_layer::cloud_along_ray_m), whose first steps are
// tens of metres: the view's six coarse sun paths drew the shadows in
// contour lines.
fn in_layer_top_shading_m(p: vec3<f32>, l: vec3<f32>) -> f32 {
    let mid = stratus.window.x;
    let half = 0.5 * stratus.shape.w;
    let top = vec3<f32>(p.x, mid + 0.5 * stratus_thickness_at(p.xz), p.z);
    let range = min(max(mid + half - top.y, 0.0) / max(l.y, 1e-3), 2.0 / stratus.shape.x);
    return stratus_cloud_along_ray_m(top, l, 0.0, range);
}

// The sines of the sun's elevation over which the other cells' shadow on a
// top fades out (25° to 35°): above it no top rises into another column's
// sun path by enough to matter (the suite's decks under suns of 30–65°
// moved by under 0.001 with it), and the march, 70 % of the pass's cost on
// llvmpipe, is skipped (docs/PERFORMANCE.md).
const IN_LAYER_SHADING_FADE_SIN: vec2<f32> = vec2<f32>(0.42, 0.57);

// The sun's paths at `p` (in_layer_sun_path_m towards and away from the
// sun) and, where `shading_weight` is above 0, the other cells' shadow on
// its column's top (in_layer_top_shading_m; 0 otherwise, its march skipped).
fn in_layer_sun_paths(p: vec3<f32>, l: vec3<f32>, shading_weight: f32) -> vec3<f32> {
    var shading = 0.0;
    if (shading_weight > 0.0) {
        shading = in_layer_top_shading_m(p, l);
    }
    return vec3<f32>(in_layer_sun_path_m(p, l), in_layer_sun_path_m(p, -l), shading);
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
    // The fine octaves' difference at the camera, carried along the ray
    // over its first IN_LAYER_DETAIL_M.
    let detail_m = layer_thickness_m(stratus, origin.xz) - stratus_thickness_at(origin.xz);
    // The march starts where the ray first enters a cell (at once from
    // inside one), so that its fine first steps fall on the cell's surface
    // and not on the air before it: a camera between the cells, or outside
    // the layer with stratus.model = "volume", sees smooth silhouettes
    // (marched from the camera, the steps far along were tens to hundreds
    // of metres, in or out). The entry is searched with the fine octaves
    // added where they thicken the cells, so that none of the cloud they
    // make near the camera is skipped, and the march begins a little
    // before it.
    let entry_m = stratus_view_entry_m(origin + direction * t0, direction, max(detail_m, 0.0), t1 - t0);
    if (entry_m < 0.0) {
        return vec4<f32>(0.0);
    }
    t0 += max(entry_m - min(0.25 * entry_m, IN_LAYER_ENTRY_LEAD_M), 0.0);
    let l = frame.sun_direction;
    let sun_above = l.y > 0.0;
    let mu0 = max(abs(l.y), 0.02);
    let kappa = stratus.extinction.y;
    let kappa_s = (1.0 - stratus.forward_fraction.y) * kappa;
    let kappa_t = (1.0 - IN_LAYER_ASYMMETRY) * kappa;
    let cos_view_sun = clamp(dot(l, direction), -1.0, 1.0);
    let shading_weight = 1.0 - smoothstep(IN_LAYER_SHADING_FADE_SIN.x, IN_LAYER_SHADING_FADE_SIN.y, l.y);
    let phase = stratus_peak_removed(acos(cos_view_sun));
    // δ-M's peak-removed asymmetry g* = (g − f)/(1 − f), f the peak's
    // fraction: the forward orders' lobe scatters by the phase function
    // the direct beam's extinction κ_s goes with.
    let peak = stratus.forward_fraction.y;
    let asymmetry_star = (IN_LAYER_ASYMMETRY - peak) / max(1.0 - peak, 1e-3);
    let sky = lighting.sky_irradiance_up.xyz;
    // A camera above or below the layer's height range sees the diffuse
    // light leave the cells through their tops or bases: it leaves by the
    // exact escape function, not by P1's (2 + 3μ)/4, which is 6 % too
    // bright 70–80° from the normal and 19 % at 82.5° (the slab photon
    // tracer; docs/REALISM.md, "The light leaving the volume"); and the
    // sun's beam puts into the slab what the escape function of its cosine
    // says (reciprocity), where P1 put 10 % too much under a sun 14° high.
    // A camera level with the layer sees the cells' sides, and
    // one inside a cell the field itself: P1's, as the faces (layer.wgsl's
    // exit weight) do.
    let outside_the_layer = abs(origin.y - mid) > half;
    let exit_weight = select(1.0, escape_over_eddington(abs(direction.y)), outside_the_layer);
    // The beam's share through the top, the same at every step.
    let top_exit_weight = exit_weight * escape_over_eddington(mu0);
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
    // The traced source at its depth and thickness nodes for this ray's sun
    // and direction, read at the first step that needs it: per step, the
    // table's lookups were 31 % of the pass on llvmpipe near a lit top
    // (docs/PERFORMANCE.md).
    var traced_nodes: array<f32, 28>;
    var traced_read = false;
    // The sky's traced source at its depth and thickness nodes for this
    // ray's direction (per channel), read likewise.
    var sky_nodes: array<array<f32, 28>, 3>;
    var sky_read = false;
    let travel_xz = direction.xz / max(length(direction.xz), 1e-6);
    let beam_xz = l.xz / max(length(l.xz), 1e-6);
    let traced_azimuth_deg = degrees(acos(clamp(dot(travel_xz, beam_xz), -1.0, 1.0)));
    // The sun's paths at the last and the next step where they are marched.
    var sun_paths_last = vec3<f32>(0.0);
    var sun_paths_next = vec3<f32>(0.0);
    // The last step's signed distance inside a cell (m) and its distance.
    var last_inside_m = 0.0;
    var last_t = t0;
    for (var i = 0u; i < IN_LAYER_STEPS; i += 1u) {
        let a = f32(i) / f32(IN_LAYER_STEPS);
        let b = f32(i + 1u) / f32(IN_LAYER_STEPS);
        let dt = span * (b * b * b - a * a * a);
        let t = in_layer_step_m(i, t0, span);
        let p = origin + direction * t;
        // The sun's paths (towards and away from the sun) at every fourth
        // step, interpolated between (the in-layer pass cost 2.7 s a frame
        // at 640×360 on llvmpipe marching them at every step, 1.0 s this
        // way): marched here for the step four ahead, whether this one is
        // in cloud or not.
        if (l.y > 0.0 && i % IN_LAYER_SUN_EVERY == 0u) {
            if (i == 0u) {
                sun_paths_next = in_layer_sun_paths(p, l, shading_weight);
            }
            sun_paths_last = sun_paths_next;
            let q = origin + direction * in_layer_step_m(i + IN_LAYER_SUN_EVERY, t0, span);
            sun_paths_next = in_layer_sun_paths(q, l, shading_weight);
        }
        let fade = stratus_window_fade(p.xz);
        let h_here = max(stratus_thickness_at(p.xz) + detail_m * saturate(1.0 - t / IN_LAYER_DETAIL_M), 0.0);
        let inside_m = 0.5 * h_here - abs(p.y - mid);
        // The part of the step inside a cell, its signed distance inside
        // taken linear between this step's middle and the last's: counted
        // in or out whole, steps tens of metres long far along drew a cell's
        // silhouette in stairs.
        var inside = select(0.0, 1.0, inside_m > 0.0);
        if (i > 0u) {
            let slope = (inside_m - last_inside_m) / max(t - last_t, 1e-3);
            inside = inside_fraction(inside_m + slope * (t0 + span * a * a * a - t),
                inside_m + slope * (t0 + span * b * b * b - t));
        }
        last_inside_m = inside_m;
        last_t = t;
        if (inside <= 0.0 || fade <= 0.0) {
            continue;
        }
        // A step partly inside whose middle is not: shaded at the surface.
        // Over the window's outer fifth the cloud thins out: its extinction
        // is κ times the fade (as `nimbus export` writes the layer's
        // medium), so its depths and thickness below count as the fade's
        // share of their metres and the sun gets through a faded cell. The
        // fade taken as the opacity's alone shaded a faded cell as a dense
        // one seen through a veil: the layer's far band 1.25× the
        // reference's light under stratus-above-noon's high sun, 0.73×
        // under stratus-sunset-plane's low one (docs/REALISM.md, "The
        // window's edge thins the volume; the cells' lower halves").
        let h_geometric = max(h_here, 1.0);
        let below_top = clamp(mid + 0.5 * h_geometric - p.y, 0.0, h_geometric) * fade;
        let above_base = clamp(p.y - (mid - 0.5 * h_geometric), 0.0, h_geometric) * fade;
        let h = h_geometric * fade;
        let light = lights[min(i * IN_LAYER_SEGMENTS / IN_LAYER_STEPS, IN_LAYER_SEGMENTS - 1u)];
        // The sun enters a cell by its top (depth below it, cosine μ₀) or,
        // low, by the side facing it (the sun ray's path through cloud
        // shorter than the top's slant depth; the side's cosine from the
        // relief's slope where the path enters the cell):
        // the point is in a slab across that face as thick as the cloud's
        // chord along the sun through it (towards and away from the sun).
        let lit_depth_m = select(above_base, below_top, sun_above);
        // The diffuse part's depth axis points down: the light reaching the
        // camera travels along −direction, at cosine direction.y to it.
        var diffuse = exit_weight * eddington_source(
            in_layer_diffuse(kappa_t * below_top, kappa_t * h, sky, light.ground),
            in_layer_diffuse_net_flux(kappa_t * h, sky, light.ground), direction.y, asymmetry_star);
        // Near the top the sky's light has not diffused yet: it arrives
        // from every direction above, the bright horizon's at grazing
        // incidence, and the droplets' forward lobe carries it on at grazing
        // angles out of the top. There the sky's part of the source is the
        // field a diffuse sky makes in a slab as thick as the column
        // (transport::sky_source, by the sky's irradiance from four bands
        // of zenith angles), handing over to P1 as the sun's does: P1 lit
        // by the sky's irradiance and leaving by the escape function gave
        // a layer seen from above 0.58–0.82 of the path-traced sky light,
        // 0.48–0.69 at grazing views (docs/REALISM.md, "The sky's light on
        // a layer's top").
        let sky_depth_s = kappa_s * below_top;
        let sky_share = 1.0 - smoothstep(IN_LAYER_TABLE_HANDOVER.x, IN_LAYER_TABLE_HANDOVER.y, sky_depth_s);
        if (sky_share > 0.0) {
            if (!sky_read) {
                sky_nodes = stratus_sky_source_nodes(direction.y, lighting.sky_irradiance_bands);
                sky_read = true;
            }
            let sky_weights = stratus_interior_weights(sky_depth_s, kappa_s * h);
            let traced_sky = vec3<f32>(stratus_interior_weighted(sky_nodes[0], sky_weights),
                stratus_interior_weighted(sky_nodes[1], sky_weights),
                stratus_interior_weighted(sky_nodes[2], sky_weights));
            let diffuse_sky = exit_weight * eddington_source(
                in_layer_diffuse(kappa_t * below_top, kappa_t * h, sky, vec3<f32>(0.0)),
                in_layer_diffuse_net_flux(kappa_t * h, sky, vec3<f32>(0.0)), direction.y, asymmetry_star);
            diffuse += sky_share * (traced_sky - diffuse_sky);
        }
        var direct = vec3<f32>(0.0);
        if (l.y > 0.0) {
            let along = f32(i % IN_LAYER_SUN_EVERY) / f32(IN_LAYER_SUN_EVERY);
            let sun_paths = mix(sun_paths_last, sun_paths_next, along);
            let top_path_m = lit_depth_m / mu0;
            let path_m = min(sun_paths.x, top_path_m);
            let chord_m = path_m + sun_paths.y;
            // The beam's depth axes: into the lit face, down from the top
            // (up from the base), or away from the sun through a side; the
            // side's share grows as the sun's path falls below the top's
            // (a switch at one ratio made hard edges).
            let side_share = 1.0 - smoothstep(0.6, 0.95, path_m / max(top_path_m, 1e-3));
            let top_axis = vec3<f32>(0.0, select(1.0, -1.0, sun_above), 0.0);
            // The side's face: the cell's surface where the sun's path
            // enters it, its outward normal from the thickness field's
            // slope there (y = mid ± h/2: (−½∂h/∂x, ±1, −½∂h/∂z)). Taken as
            // a vertical wall facing the sun's azimuth, every side took the
            // irradiance of one facing the sun square on (cos e, 0.94 under
            // a 20° sun where the walls' mean is nearer 0.6): the layer's
            // sides seen from its mid-plane were 1.5× the reference's.
            var side_axis = vec3<f32>(0.0, -1.0, 0.0);
            var mu_side = mu0;
            if (side_share > 0.0) {
                let face = stratus_surface_normal(p + l * path_m);
                side_axis = -face;
                mu_side = clamp(dot(face, l), IN_LAYER_MIN_FACE_COSINE, 1.0);
            }
            let from_top = top_exit_weight * in_layer_beam_source(kappa_t * path_m, kappa_t * chord_m, mu0,
                dot(-direction, top_axis), asymmetry_star);
            // Through a side, the slab across the face is as thick as the
            // chord along the sun: in a cell's lower half the beam leaves
            // through the base a little way on, and that thin slab lets out
            // the diffuse light that the cell's body beside the point, lit
            // from above, holds in. The side's light is therefore at least
            // what the local column would hold as a horizontal slab under
            // the sun (the faces' slab, depth below the top and thickness
            // h): with the chord's slab alone the cells' lower halves seen
            // level from stratus-side's mid-plane were 0.52–0.66 of the
            // reference's light (docs/REALISM.md, "The window's edge thins
            // the volume; the cells' lower halves").
            let from_chord = exit_weight * escape_over_eddington(mu_side) * in_layer_beam_source(kappa_t * path_m,
                kappa_t * chord_m, mu_side, dot(-direction, side_axis), asymmetry_star);
            let from_column = top_exit_weight * in_layer_beam_source(kappa_t * below_top / mu0, kappa_t * h / mu0,
                mu0, dot(-direction, top_axis), asymmetry_star);
            let from_side = max(from_chord, from_column);
            // Other cells between the sun and this cell's lit top shade it,
            // as they shade the faces (layer.wgsl): the cloud the sun's path
            // crosses beyond this cell's top, taken as a slab of the same
            // slant path, lets through its directional transmittance T_C
            // to the beam and its diffuse T_ms to the light diffusing in
            // from the top.
            let shading_m = sun_paths.z * shading_weight;
            let shade_direct = slab_directional_transmittance(stratus, shading_m * mu0, mu0);
            let shade_diffuse = slab_t_ms(stratus, shading_m * mu0);
            // The light δ-Eddington's beam still holds beyond the
            // unscattered beam, scattered a few times within the droplets'
            // forward lobe: sent in the forward orders' lobe about the sun
            // (as the cumulus' in-cloud march sends the light its beam has
            // lost; without it, 0.72–0.96 of the traced light near the top
            // of a thin slab under a high sun; tests/slab_interior.rs).
            let unscattered = exp(-kappa_s * path_m);
            let forward = max(exp(-IN_LAYER_BEAM_RATE * kappa_t * path_m) - unscattered, 0.0);
            var lobe = 0.0;
            if (forward > 1e-4) {
                lobe = forward / (4.0 * PI) * forward_orders_lobe(kappa_s * path_m, cos_view_sun, asymmetry_star);
            }
            // Near the top, where the light has not diffused yet (P1 gave a
            // third of the traced light within 30° of a low sun's beam and
            // 2–3 × straight down on the far side), the traced source
            // (transport::interior_source) in a slab as thick as this
            // column along the beam (its chord times μ₀), handing over to P1
            // between 3 and 4.5 optical depths down. (The source of the
            // 12-deep slab scaled by the ratio of δ-Eddington's fluences in
            // the column and in that slab made a thin overcast seen from
            // below 0.62–0.73 of the path-traced light, and unscaled
            // 1.07–1.43: docs/REALISM.md, "A thin layer's light: the traced
            // source by the column's thickness".)
            var top_source = from_top + lobe;
            let depth_s = kappa_s * lit_depth_m;
            let table_share = 1.0 - smoothstep(IN_LAYER_TABLE_HANDOVER.x, IN_LAYER_TABLE_HANDOVER.y, depth_s);
            if (table_share > 0.0) {
                if (!traced_read) {
                    traced_nodes = stratus_interior_source_nodes(degrees(acos(mu0)), direction.y, traced_azimuth_deg);
                    traced_read = true;
                }
                let traced = stratus_interior_source_at(traced_nodes, depth_s, kappa_s * chord_m * mu0);
                top_source = mix(top_source, traced, table_share);
            }
            diffuse += light.sun * mix(top_source * shade_diffuse, from_side + lobe, side_share);
            direct = light.sun * unscattered * mix(shade_direct, vec3<f32>(1.0), side_share);
        }
        let source = phase * direct + diffuse;
        let opacity = 1.0 - exp(-kappa_s * dt * inside * fade);
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
