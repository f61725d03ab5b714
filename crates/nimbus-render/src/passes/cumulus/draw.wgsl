// import passes/cumulus/cumulus.wgsl
// import shader/cloud_shadow_lookup.wgsl
// import shader/terrain_shadow_lookup.wgsl
// The camera's view of the cumulus (see cumulus.wgsl). Needs cumulus.wgsl
// shader/cloud_shadow_lookup.wgsl and shader/terrain_shadow_lookup.wgsl.

@vertex
fn cumulus_vertex(v: CumulusVertex, i: CumulusInstance, t: CumulusTransferVertex) -> CumulusVarying {
    var out = cumulus_varying(v, i);
    out.clip_position = frame.clip_from_world * vec4<f32>(out.world_m, 1.0);
    if (cumulus_transport_on()) {
        let transfer = cumulus_transfer_at(t, i);
        out.transfer_c_b = transfer.c_b;
        out.transfer_diagonal_xy = transfer.diagonal_xy;
        out.transfer_yz_xz = transfer.yz_xz;
    }
    return out;
}

// The direct beam's transmittance through the cores the shadow map holds,
// from the two-stream diffuse transmittance T_d = 1/(1 + ¾(1 − g) σ Δ) it
// gives (cloud_shadow_texel): e^{−σ* Δ}, σ* = (1 − f) σ the δ-M extinction.
fn cumulus_direct_transmittance(diffuse: f32) -> f32 {
    let optical_depth = (1.0 / max(diffuse, 1e-6) - 1.0) / (0.75 * (1.0 - cloud_shadow.params.z));
    return exp(-optical_depth * cumulus.transport.z);
}

struct CumulusShaded {
    // Pre-exposed radiance seen by the camera (through the air), not premultiplied.
    radiance: vec3<f32>,
    opacity: f32,
}

fn cumulus_evaluate(in: CumulusVarying) -> CumulusShaded {
    var h = 0.5;
    var gradient = vec3<f32>(0.0);
    if (cumulus_term_on(CUMULUS_BUMP)) {
        h = cumulus_bump_height(in.noise_position);
        gradient = cumulus_bump_gradient(in.noise_position, h);
    }
    let p = cumulus_point(in, h, gradient);
    let o = to_eye_world(in.world_m);
    let l = frame.sun_direction;
    let terms = cumulus_shade_terms(p, o, l);
    // The stratus layer's shadow and the terrain's (a cloud behind a ridge).
    let layer_shadow = stratus_sun_transmittance(in.world_m) * terrain_sun_visibility(in.world_m);
    var shadow = layer_shadow;
    var forward_shadow = shadow;
    // The single scattering of the transport model needs the direct beam's
    // transmittance, not the shadow's diffuse one.
    var direct = layer_shadow;
    var forward_direct = layer_shadow;
    if (cumulus_term_on(CUMULUS_SHADOW)) {
        // The forward-scattered light crosses the blob's chord behind the
        // point: it is shadowed where it enters, at the chord's far end (on
        // a back-lit rim, the sun-facing side), not at the point.
        let chord_m = 2.0 * p.blob_radius_m * saturate(dot(p.normal, o));
        let at_point = cloud_shadow_transmittance(in.world_m);
        let at_entry = cloud_shadow_transmittance(in.world_m - o * chord_m);
        shadow *= at_point;
        forward_shadow *= at_entry;
        direct *= cumulus_direct_transmittance(at_point);
        forward_direct *= cumulus_direct_transmittance(at_entry);
    }
    let sun = cumulus_sun_radiance(in.world_m.y);
    // Under a stratus layer the environment is its light (the layer's R_G
    // from above, the ground's R_C from below), not the clear sky's.
    let clear_environment = clouds_lighting(lighting);
    let clouds_environment = stratus_layered_lighting(clear_environment, stratus_under_light(clear_environment, in.world_m));
    let environment = sh_irradiance(clouds_environment, terms.smoothed_normal);
    var radiance: vec3<f32>;
    if (cumulus_transport_on()) {
        var transfer: CumulusTransfer;
        transfer.c_b = in.transfer_c_b;
        transfer.diagonal_xy = in.transfer_diagonal_xy;
        transfer.yz_xz = in.transfer_yz_xz;
        let environment_transfer = cumulus_transfer_environment(transfer, clouds_environment);
        // S_{l−1}'s normal: its blobs (~125 m) are the first above the
        // transport mean free path (~90 m).
        radiance = cumulus_transport_radiance(terms, p.base_normals[0], transfer, o, l, environment_transfer, sun, layer_shadow, direct, forward_direct, forward_shadow);
    } else {
        radiance = cumulus_radiance(terms, environment / PI, sun, shadow, forward_shadow);
    }
    var out: CumulusShaded;
    out.radiance = to_target(stratus_apply_aerial_perspective(radiance, in.world_m)).rgb;
    // An instance the in-cloud march takes over fades out (in_cloud.wgsl).
    out.opacity = cumulus_opacity(terms) * (1.0 - in.fade);
    return out;
}

// The body: opaque fragments, depth written.
@fragment
fn cumulus_opaque_fragment(in: CumulusVarying) -> @location(0) vec4<f32> {
    let shaded = cumulus_evaluate(in);
    if (shaded.opacity < CUMULUS_OPAQUE_ALPHA) {
        discard;
    }
    return vec4<f32>(shaded.radiance, 1.0);
}

struct CumulusFringeOutput {
    // Σ w α C and Σ w α (additive).
    @location(0) accumulation: vec4<f32>,
    // Π (1 − α) (multiplicative).
    @location(1) revealage: vec4<f32>,
}

// The fringes: weighted blended OIT (McGuire & Bavoil 2013), the weight
// favouring nearer fragments (their eq. 7 shape, in kilometres) and bounded
// so half floats cannot overflow.
@fragment
fn cumulus_fringe_fragment(in: CumulusVarying) -> CumulusFringeOutput {
    let shaded = cumulus_evaluate(in);
    let a = shaded.opacity;
    if (a >= CUMULUS_OPAQUE_ALPHA || a < 1.0 / 1024.0) {
        discard;
    }
    let distance_km = eye_distance_m(in.world_m) * 1e-3;
    let weight = a * clamp(1.0 / (1e-3 + pow(distance_km / 5.0, 3.0)), 1e-2, 1e2);
    var out: CumulusFringeOutput;
    let colour = min(shaded.radiance, vec3<f32>(frame.max_pre_exposed * 1e-2));
    out.accumulation = vec4<f32>(colour * weight, weight);
    out.revealage = vec4<f32>(a);
    return out;
}
