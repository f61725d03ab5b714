// import shader/cloud_layer_lookup.wgsl
// import shader/cloud_shadow_lookup.wgsl
// import shader/diffusion.wgsl
// import shader/fullscreen.wgsl
// Stratus layer pass: the layer drawn as a displaced grid over the
// thickness window (built on the GPU from the field: no CPU upload per
// frame), the surface facing the camera only (the top seen from above, the
// base from below), shaded per pixel with the analytic model of Bouthors,
// Neyret & Lefebvre 2006, §4 and §6, and blended over the sky and terrain
// with alpha = 1 − τ(H_v). CPU reference of the radiance:
// nimbus_physics::transport::stratus::StratusModel::radiance. Needs
// common.wgsl, the atmosphere lookups, shader/cloud_layer_field.wgsl and
// shader/cloud_layer_lookup.wgsl.

// Smallest cosine used for grazing directions (89.9°).
const MIN_MU: f32 = 1.745e-3;

// Farthest the view ray is marched inside the layer, in feature sizes (the
// largest cells' wavelength): far beyond any cell's optical depth of a few
// hundred.
const STRATUS_VIEW_RANGE_FEATURES: f32 = 2.0;

struct LayerVarying {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) position_m: vec3<f32>,
    // +1 for the top face, −1 for the base.
    @location(1) @interpolate(flat) face: f32,
}

// The face nearer the camera: +1 the top, −1 the base. (A camera level with
// the layer sees it through `level_fragment` instead.)
fn layer_face() -> f32 {
    return select(-1.0, 1.0, frame.camera_position_m.y > stratus.window.x);
}

@vertex
fn layer_vertex(@builtin(vertex_index) index: u32) -> LayerVarying {
    let n = stratus.flags.w;
    let ij = vec2<u32>(index % n, index / n);
    let xz = stratus.window.zw + (vec2<f32>(ij) + 0.5) * (stratus.window.y / f32(n));
    let h = textureLoad(stratus_thickness, vec2<i32>(ij), 0).r;
    let face = layer_face();
    let position = vec3<f32>(xz.x, stratus.window.x + 0.5 * face * h, xz.y);
    var out: LayerVarying;
    out.face = face;
    out.clip_position = frame.clip_from_world * vec4<f32>(position, 1.0);
    out.position_m = position;
    return out;
}

// (e^{−a/μ_v} − e^{−a/μ_l}) / (μ_v − μ_l), finite as μ_v → μ_l (twin of
// nimbus_physics::transport::stratus::exp_difference_quotient).
fn exp_difference_quotient(a: vec3<f32>, mu_v: f32, mu_l: f32) -> vec3<f32> {
    let z = a * (mu_v - mu_l) / (mu_v * mu_l);
    if (abs(mu_v - mu_l) * max(a.x, max(a.y, a.z)) > 0.5 * mu_v * mu_l) {
        return (exp(-a / mu_v) - exp(-a / mu_l)) / (mu_v - mu_l);
    }
    // (e^z − 1)/z to z³: relative error below 2e-4 for |z| ≤ 0.5.
    let ratio = 1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0));
    return exp(-a / mu_l) * ratio * a / (mu_v * mu_l);
}

// ((1 + a/μ_v) e^{−a/μ_v} − (1 + a/μ_l) e^{−a/μ_l}) / (μ_v − μ_l), finite as
// μ_v → μ_l, where it tends to (a²/μ³) e^{−a/μ}.
fn poisson2_difference_quotient(a: vec3<f32>, mu_v: f32, mu_l: f32) -> vec3<f32> {
    if (abs(mu_v - mu_l) < 1e-3 * mu_l) {
        let mu = 0.5 * (mu_v + mu_l);
        return a * a / (mu * mu * mu) * exp(-a / mu);
    }
    let gv = (1.0 + a / mu_v) * exp(-a / mu_v);
    let gl = (1.0 + a / mu_l) * exp(-a / mu_l);
    return (gv - gl) / (mu_v - mu_l);
}

// I_0F per unit beam flux: the forward peak convolved with itself once per
// peak event on the path (Poisson, mean P_f κ H_v), with n ≥ 2 as the
// small-angle Gaussian of n times the peak's mean square angle.
fn forward_peak_radiance(h: f32, mu_v: f32, theta: f32) -> vec3<f32> {
    // Beyond 0.6 rad even 60 convolved peaks have fallen below 1 % of their
    // centre; skip the series.
    if (theta > 0.6) {
        return vec3<f32>(0.0);
    }
    let kappa = stratus.extinction.rgb;
    let p_f = stratus.forward_fraction.rgb;
    let path = h / mu_v;
    let survival = exp(-(1.0 - p_f) * kappa * path);
    let mean = p_f * kappa * path;
    let s2 = max(stratus.forward_spread.rgb, vec3<f32>(1e-8));
    var poisson = exp(-mean);
    var sum = vec3<f32>(0.0);
    let m = max(mean.x, max(mean.y, mean.z));
    let last = min(u32(ceil(m + 10.0 * sqrt(m) + 10.0)), 64u);
    for (var k = 1u; k <= last; k = k + 1u) {
        poisson = poisson * mean / f32(k);
        var peak: vec3<f32>;
        if (k == 1u) {
            peak = stratus_forward_peak(theta);
        } else {
            let variance = f32(k) * s2;
            peak = exp(-theta * theta / variance) / (PI * variance);
        }
        sum += poisson * peak;
    }
    return survival * sum;
}

@fragment
fn layer_fragment(in: LayerVarying) -> @location(0) vec4<f32> {
    // The field itself, per pixel: the window's texels (tens of metres)
    // would show as jagged edges on nearby cells; the mesh only carries the
    // coarse relief.
    let h = layer_thickness_m(stratus, in.position_m.xz);
    if (h <= 0.05) {
        discard;
    }
    // Faded out as the in-layer march takes over (in_layer.wgsl).
    return shade_layer(in.position_m, in.face, h, false) * (1.0 - stratus.slab_r_beta.z);
}

// A camera level with the layer sees the cells' sides, mostly near their
// thin rims, where the slab of the rim's h (or of the marched path's
// vertical extent, small for level rays) reflects too little. The light
// seen there comes from a few mean free paths into the cell along the ray:
// the point is shaded as the slab of the thickness found that deep.
const LEVEL_VIEW_DEPTH_MFP: f32 = 2.0;

struct LevelOutput {
    @location(0) color: vec4<f32>,
    // The entry point's depth, for the depth test against the terrain.
    @builtin(frag_depth) depth: f32,
}

// The layer seen by a camera level with it (within half the thickest cell
// of the mid-plane, plus 50 m): its tops and bases are edge-on there, and a
// ray at eye level runs between them through the cells, so drawing the two
// faces showed a band of clear sky through the layer's middle. Each pixel
// marches its ray to where it first enters the layer (within the window)
// and shades that point as the face it lies on.
@fragment
fn level_fragment(in: FullscreenOutput) -> LevelOutput {
    let direction = view_ray_world(in.clip_xy);
    let camera = view_ray_origin_world(in.clip_xy);
    // Out of the layer's height range the ray meets nothing more.
    let mid = stratus.window.x;
    let half = 0.5 * stratus.shape.w;
    let leave_m = select(
        1e9,
        (select(mid - half, mid + half, direction.y > 0.0) - camera.y) / direction.y,
        abs(direction.y) > 1e-6,
    );
    let range_m = max(min(leave_m, 0.5 * stratus.window.y), 0.0);
    let entry_m = stratus_view_entry_m(camera, direction, 0.0, range_m);
    if (entry_m < 0.0) {
        discard;
    }
    // From inside a cell (distance 0), the point 1 m ahead.
    let position_m = camera + direction * max(entry_m, 1.0);
    let face = select(-1.0, 1.0, position_m.y > mid);
    // The entry lies on the window's surface |y − y_mid| = h/2; the fine
    // field there may be thinner, but discarding would open the band again.
    let h = max(layer_thickness_m(stratus, position_m.xz), max(2.0 * abs(position_m.y - mid), 1.0));
    var out: LevelOutput;
    // Faded out as the in-layer march takes over (in_layer.wgsl).
    out.color = shade_layer(position_m, face, h, true) * (1.0 - stratus.slab_r_beta.z);
    let clip = frame.clip_from_world * vec4<f32>(position_m, 1.0);
    out.depth = clamp(clip.z / clip.w, 0.0, 1.0);
    return out;
}

// The layer's radiance and opacity at `position_m` on the face `face` (+1
// the top, −1 the base) where its thickness is `h`, seen by a camera level
// with the layer when `level`, pre-exposed, alpha premultiplied.
fn shade_layer(position_m: vec3<f32>, face: f32, h: f32, level: bool) -> vec4<f32> {
    let xz = position_m.xz;
    // The local slab normal, from the thickness gradient: both faces are
    // mid ± h/2, so the slab's upward normal is (−½ ∂h/∂x, 1, −½ ∂h/∂z).
    // Forward differences over a quarter of the finest octave's wavelength.
    let step_m = 0.25 / (stratus.shape.x * exp2(f32(stratus.flags.y - 1u)));
    let dh_dx = (layer_thickness_m(stratus, xz + vec2<f32>(step_m, 0.0)) - h) / step_m;
    let dh_dz = (layer_thickness_m(stratus, xz + vec2<f32>(0.0, step_m)) - h) / step_m;
    let up = normalize(vec3<f32>(-0.5 * dh_dx, 1.0, -0.5 * dh_dz));

    let v = to_eye_world(position_m);
    let l = frame.sun_direction;
    // (The fine-scale normals may turn away from the camera on the coarse
    // mesh without the ray leaving the cloud: nothing is discarded.)
    // The slab is seen from above on its top face, from below on its base.
    let viewer_above = face > 0.0;
    let sun_above = l.y > 0.0;
    // Orders 0–2 are local events: cosines to the local normal. Orders 3+
    // and the diffuse sources are global: cosines to the vertical (§6).
    // The sun's cosine to the lit face's outward normal, clamped at 0: where
    // a fine bump of that face turns away from the sun, the bump itself
    // stands between them (its single and double scattering vanish; the
    // global orders still light it). The absolute value used before lit the
    // far slope again as if the sun shone on it, leaving a thin dark line
    // where the normal crossed the terminator: the contour lines of issue 25
    // on stratus-sunset-plane.
    let mu_v = max(abs(dot(up, v)), MIN_MU);
    let mu_l = max(select(-1.0, 1.0, sun_above) * dot(up, l), MIN_MU);
    let marched = stratus.model.x == 1u;
    let mu_l_vertical = max(abs(l.y), MIN_MU);
    let theta = acos(clamp(dot(-l, v), -1.0, 1.0));

    // The cloud's thickness along the view ray, marched through the layer
    // from this entry point (the window carries the coarse relief; the fine
    // octaves' difference here rides along as an offset). Bouthors 2006
    // shades every point as a slab, H_v = h/μ_v, and notes (§8) that this
    // misses the clouds' sides: a ray entering a cell by its thin edge
    // crosses its thick middle. The march is compared with the horizontal
    // slab of the local thickness (path h/|v_y|): where it finds more cloud,
    // the point is shaded as the thicker slab h_view = path |v_y| would be;
    // elsewhere the paper's slab stands, with its fine normals (comparing in
    // the vertical keeps their bumps from reading as changes of thickness)
    // and its opaque silhouettes, which carry the silver lining. The
    // opacity takes the longer of the marched path and the slab's H_v.
    // (With stratus.model = "bnl2006" the paper's slab stands everywhere.)
    let offset_m = h - stratus_thickness_at(xz);
    var h_view = h;
    var opacity_path_m = h / mu_v;
    if (marched) {
        let entry_m = vec3<f32>(xz.x, stratus.window.x + 0.5 * face * h, xz.y);
        let direction = -v;
        let mu_v_vertical = max(abs(direction.y), MIN_MU);
        let range_m = min(
            (stratus.shape.w + abs(offset_m)) / mu_v_vertical,
            STRATUS_VIEW_RANGE_FEATURES / stratus.shape.x,
        );
        let path_m = stratus_view_path_m(entry_m, direction, offset_m, range_m);
        h_view = max(h, path_m * mu_v_vertical);
        opacity_path_m = max(path_m, h_view / mu_v);
        if (level) {
            let depth_m = min(path_m, LEVEL_VIEW_DEPTH_MFP / (stratus.extinction.y * (1.0 - stratus.forward_fraction.y)));
            h_view = max(h_view, stratus_thickness_at(xz + direction.xz * depth_m));
        }
    }

    let kappa = stratus.extinction.rgb;
    let kappa_s = (1.0 - stratus.forward_fraction.rgb) * kappa;
    let p_s = stratus_peak_removed(theta);
    let p2 = stratus_double(theta);
    let fluxes = slab_fluxes(stratus, h_view, mu_l_vertical);

    // Sun light on the lit face. The model's radiances are per unit
    // incident flux on that face: for orders 0–2 the flux through the local
    // surface, for 3+ the flux through the horizontal slab.
    let lit_face_m = vec3<f32>(position_m.x, stratus.window.x + select(-0.5, 0.5, sun_above) * h, position_m.z);
    // Cumulus between the sun and the layer shade it.
    let sun = sun_irradiance_at(lit_face_m) * cloud_shadow_transmittance(lit_face_m);
    // Other cells between the sun and the lit face shade it (the paper
    // lights every point as the top of its own slab): the cloud the sun
    // ray crosses, marched up to where it leaves the layer's height range,
    // is taken as a slab of the same slant path under the same sun. The
    // direct sun that feeds orders 0–2 is its directional transmittance
    // T_C (the cast shadow); the light of orders 3+ seen on the lit face
    // its diffuse T_ms, for light diffuses along the layer under a shadow.
    // Seen through the layer, orders 3+ have diffused across its thickness,
    // wider than the shadows' detail: left unshaded there (shading them per
    // pixel drew the window's texels as sharp facets on the base). Under a
    // sun 5° high a cell 200 m above its neighbours shades 2 km of them.
    var sun_direct = sun;
    var sun_diffuse = sun;
    if (marched) {
        let top_or_base_m = stratus.window.x + select(-0.5, 0.5, sun_above) * stratus.shape.w;
        let sun_range_m = min(
            abs(top_or_base_m - lit_face_m.y) / mu_l_vertical,
            STRATUS_VIEW_RANGE_FEATURES / stratus.shape.x,
        );
        let h_sun = stratus_cloud_along_ray_m(lit_face_m, l, offset_m, sun_range_m) * mu_l_vertical;
        sun_direct = sun * slab_directional_transmittance(stratus, h_sun, mu_l_vertical);
        if (viewer_above == sun_above) {
            sun_diffuse = sun * slab_t_ms(stratus, h_sun);
        }
    }

    // The transmitted orders 3+ and diffuse light leave the slab darkened
    // towards its plane, by the escape function u(μ) = (3/7)(1 + 2μ) of the
    // vertical cosine (nimbus_physics::transport::stratus::DiffuseExit,
    // tested against the Monte-Carlo slab), not isotropically as the
    // paper's I₃₊ = T₃₊/π (the reflected ones by their traced shape,
    // below). Not on a level view (the
    // camera within the layer's height range looking along it), which sees
    // the cells' sides rather than a slab's face; nor with
    // stratus.model = "bnl2006".
    var exit_weight = 1.0;
    if (marched && !level) {
        exit_weight = escape_function(abs(v.y));
    }
    var local_orders: vec3<f32>;
    var global_orders: vec3<f32>;
    if (viewer_above == sun_above) {
        // Reflection (§4.3–4.5).
        let a = kappa_s * h_view * (1.0 / mu_l + 1.0 / mu_v);
        let geometry = 1.0 / (mu_v + mu_l);
        let single = p_s * geometry * (1.0 - exp(-a));
        let double = 0.5 * p2 * geometry * (1.0 - (1.0 + a) * exp(-a));
        local_orders = single + double;
        // The reflected orders 3+ leave by the shape traced in the
        // Monte-Carlo slab (thrown forward under a low sun), not
        // isotropically as the paper's R₃₊/π; not on a level view, nor with
        // stratus.model = "bnl2006".
        var reflected_shape = 1.0;
        if (marched && !level) {
            let sun_h = length(l.xz);
            let view_h = length(v.xz);
            var cos_phi = 1.0;
            if (sun_h > 1e-4 && view_h > 1e-4) {
                cos_phi = clamp(dot(l.xz, v.xz) / (sun_h * view_h), -1.0, 1.0);
            }
            reflected_shape = stratus_reflected_shape(
                degrees(acos(mu_l_vertical)),
                degrees(acos(clamp(abs(v.y), 0.0, 1.0))),
                degrees(acos(cos_phi)),
            );
        }
        global_orders = vec3<f32>(reflected_shape * fluxes.r3plus / PI);
    } else {
        // Transmission, with the forward peak I_0F (§4.2).
        let a = kappa_s * h_view;
        let peak = forward_peak_radiance(h_view, mu_v, theta) / mu_l;
        let single = p_s * exp_difference_quotient(a, mu_v, mu_l);
        let double = 0.5 * p2 * poisson2_difference_quotient(a, mu_v, mu_l);
        local_orders = peak + single + double;
        global_orders = exit_weight * fluxes.t3plus / PI;
    }
    let sun_light = sun_direct * local_orders * mu_l + sun_diffuse * global_orders * select(0.0, mu_l_vertical, l.y != 0.0);

    // Sky above the layer and the ground's light below it (R_C from the
    // radiosity), both diffuse, carried by T_ms and R_ms (§4.6). The part
    // of the diffuse transmittance that is unscattered (2E₃(κH) ≈
    // e^{−1.66 κH}, the diffusivity approximation) is the background seen
    // through the layer, which blending already adds.
    let sky_above = lighting.sky_irradiance_up.xyz;
    let ground_below = stratus_radiosity_sample(false, xz);
    let unscattered = exp(-1.66 * kappa * h_view);
    let transmitted = max(vec3<f32>(fluxes.transmittance) - unscattered, vec3<f32>(0.0));
    var diffuse: vec3<f32>;
    if (viewer_above) {
        diffuse = fluxes.reflectance * sky_above + exit_weight * transmitted * ground_below;
    } else {
        diffuse = exit_weight * transmitted * sky_above + fluxes.reflectance * ground_below;
    }
    let radiance = sun_light + diffuse / PI;

    // Opacity 1 − τ(H_v) (§4.6) with the marched H_v, faded out over the window's outer fifth so
    // that its edge never shows.
    let fade = stratus_window_fade(xz);
    let alpha = (1.0 - exp(-kappa.y * opacity_path_m)) * fade;
    let ap = stratus_aerial_perspective(position_m);
    let seen = radiance * fade * ap.a + ap.rgb * alpha;
    return vec4<f32>(min(seen * pre_exposure(), vec3<f32>(frame.max_pre_exposed)), alpha);
}
