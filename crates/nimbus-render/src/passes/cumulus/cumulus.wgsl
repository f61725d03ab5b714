// import passes/cumulus/shading.wgsl
// import shader/cloud_shadow_uniform.wgsl
// Cumulus pass: the clouds' meshes, instanced, shaded by the
// phenomenological shader (cumulus/shading.wgsl) and drawn in two parts:
// the opaque body (depth written) and the semi-transparent fringes, which
// go to weighted blended order-independent transparency (McGuire & Bavoil
// 2013) and are composited after the stratus layer (composite.wgsl). The
// shadow entry points draw the cores seen from the sun into the cloud
// shadow map. Needs common.wgsl, the atmosphere lookups, shader/cloud_layer_field.wgsl,
// shader/cloud_layer_lookup.wgsl, cumulus/shading.wgsl, shader/cloud_shadow_uniform.wgsl
// and (except the shadow module) shader/cloud_shadow_lookup.wgsl.

struct CumulusVertex {
    // Position (object space, m) and the blob's radius (m).
    @location(0) position_radius: vec4<f32>,
    // Normal and δ₁.
    @location(1) normal_d1: vec4<f32>,
    // Blob centre (object space, m) and δ₂.
    @location(2) centre_d2: vec4<f32>,
    // N₁ and δ₃.
    @location(3) n1_d3: vec4<f32>,
    @location(4) n2: vec4<f32>,
    @location(5) n3: vec4<f32>,
}

// The transport model's transfer at the vertex (transfer.rs,
// TransferVertex): CumulusTransfer at the smallest scale, then at the
// largest, object frame.
struct CumulusTransferVertex {
    @location(9) low_c_b: vec4<f32>,
    @location(10) low_diagonal_xy: vec4<f32>,
    @location(11) low_yz_xz: vec4<f32>,
    @location(12) high_c_b: vec4<f32>,
    @location(13) high_diagonal_xy: vec4<f32>,
    @location(14) high_yz_xz: vec4<f32>,
}

struct CumulusInstance {
    // World position of the variant's origin (its base centre), m, and scale.
    @location(6) offset_scale: vec4<f32>,
    // cos yaw, sin yaw, noise offset, fade (1: the in-cloud march draws
    // the instance, in_cloud.wgsl).
    @location(7) rotation_noise: vec4<f32>,
    // Mean radii of the lower levels, object-space m, and the bump's first
    // wavelength, object-space m.
    @location(8) radii_wavelength: vec4<f32>,
}

struct CumulusVarying {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) world_m: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) blob_centre_m: vec3<f32>,
    // Blob radius (m), δ₁, δ₂, δ₃.
    @location(3) radius_distances: vec4<f32>,
    @location(4) n1: vec3<f32>,
    @location(5) n2: vec3<f32>,
    @location(6) n3: vec3<f32>,
    // Lower levels' radii, m.
    @location(7) base_radii_m: vec3<f32>,
    // Bump noise coordinates (object space over the first wavelength).
    @location(8) noise_position: vec3<f32>,
    // The transport model's transfer at the cloud's scale, world frame
    // (CumulusTransfer; zero where the vertex stage has none).
    @location(9) transfer_c_b: vec4<f32>,
    @location(10) transfer_diagonal_xy: vec4<f32>,
    @location(11) transfer_yz_xz: vec4<f32>,
    // How far the in-cloud march has taken the instance over (0 none).
    @location(12) fade: f32,
}

fn cumulus_rotate(v: vec3<f32>, c: f32, s: f32) -> vec3<f32> {
    return vec3<f32>(c * v.x + s * v.z, v.y, -s * v.x + c * v.z);
}

fn cumulus_varying(v: CumulusVertex, i: CumulusInstance) -> CumulusVarying {
    let scale = i.offset_scale.w;
    let c = i.rotation_noise.x;
    let s = i.rotation_noise.y;
    let world_from_object = i.offset_scale.xyz;
    var out: CumulusVarying;
    out.world_m = world_from_object + cumulus_rotate(v.position_radius.xyz * scale, c, s);
    out.normal = cumulus_rotate(v.normal_d1.xyz, c, s);
    out.blob_centre_m = world_from_object + cumulus_rotate(v.centre_d2.xyz * scale, c, s);
    out.radius_distances = vec4<f32>(v.position_radius.w * scale, v.normal_d1.w, v.centre_d2.w, v.n1_d3.w);
    out.n1 = cumulus_rotate(v.n1_d3.xyz, c, s);
    out.n2 = cumulus_rotate(v.n2.xyz, c, s);
    out.n3 = cumulus_rotate(v.n3.xyz, c, s);
    out.base_radii_m = i.radii_wavelength.xyz * scale;
    out.noise_position = v.position_radius.xyz / i.radii_wavelength.w + vec3<f32>(i.rotation_noise.z);
    out.transfer_c_b = vec4<f32>(0.0);
    out.transfer_diagonal_xy = vec4<f32>(0.0);
    out.transfer_yz_xz = vec4<f32>(0.0);
    out.fade = i.rotation_noise.w;
    return out;
}

// The transfer at the instance's scale (linear in ln s between the two
// precomputed scales), turned with the cloud: b → R b, A → R A Rᵀ
// (SphericalQuadratic::yawed).
fn cumulus_transfer_at(t: CumulusTransferVertex, i: CumulusInstance) -> CumulusTransfer {
    let w = saturate((log(i.offset_scale.w) - cumulus.transport.x) * cumulus.transport.y);
    let c_b = mix(t.low_c_b, t.high_c_b, w);
    let d = mix(t.low_diagonal_xy, t.high_diagonal_xy, w);
    let o = mix(t.low_yz_xz, t.high_yz_xz, w);
    return cumulus_turned_transfer(c_b, d, o, i.rotation_noise.xy);
}

// A transfer of the shape's frame (c, b; A's diagonal and xy in `d`, its yz
// and xz in `o`) turned with a cloud of yaw cosine and sine `cos_sin`:
// b → R b, A → R A Rᵀ (SphericalQuadratic::yawed).
fn cumulus_turned_transfer(c_b: vec4<f32>, d: vec4<f32>, o: vec4<f32>, cos_sin: vec2<f32>) -> CumulusTransfer {
    let c = cos_sin.x;
    let s = cos_sin.y;
    // R's columns (cumulus_rotate: x' = c x + s z, z' = −s x + c z).
    let r = mat3x3<f32>(vec3<f32>(c, 0.0, -s), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(s, 0.0, c));
    let a = mat3x3<f32>(vec3<f32>(d.x, d.w, o.y), vec3<f32>(d.w, d.y, o.x), vec3<f32>(o.y, o.x, d.z));
    let turned = r * a * transpose(r);
    var out: CumulusTransfer;
    out.c_b = vec4<f32>(c_b.x, r * c_b.yzw);
    out.diagonal_xy = vec4<f32>(turned[0][0], turned[1][1], turned[2][2], turned[1][0]);
    out.yz_xz = vec4<f32>(turned[2][1], turned[2][0], 0.0, 0.0);
    return out;
}

fn cumulus_point(in: CumulusVarying, bump_height: f32, bump_gradient: vec3<f32>) -> CumulusPoint {
    var p: CumulusPoint;
    p.normal = normalize(in.normal);
    p.blob_radius_m = in.radius_distances.x;
    p.base_normals = array<vec3<f32>, 3>(normalize(in.n1), normalize(in.n2), normalize(in.n3));
    p.base_distances = in.radius_distances.yzw;
    p.base_radii_m = in.base_radii_m;
    let up = in.world_m - in.blob_centre_m;
    p.blob_up = up / max(length(up), 1e-3);
    p.bump_height = bump_height;
    p.bump_gradient = bump_gradient;
    return p;
}

@vertex
fn cumulus_shadow_vertex(v: CumulusVertex, i: CumulusInstance) -> CumulusVarying {
    var out = cumulus_varying(v, i);
    out.clip_position = cloud_shadow.clip_from_world * vec4<f32>(out.world_m, 1.0);
    return out;
}

// Only the core casts shadows (Bouthors 2004, §5.8): τ ≥ 1 along the sun's
// ray, seen from the sun for the faces towards it (the nearest layer) and
// from the other side for the faces away from it (the farthest layer).
@fragment
fn cumulus_shadow_fragment(in: CumulusVarying) {
    let p = cumulus_point(in, 0.0, vec3<f32>(0.0));
    let l = frame.sun_direction;
    let along = select(-l, l, dot(p.normal, l) >= 0.0);
    if (cumulus_optical_depth(p, along, false) < 1.0) {
        discard;
    }
}
