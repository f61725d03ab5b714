// import shader/lit_surface.wgsl
// Objects pass: the scene's static boxes and glTF meshes, baked into one
// world-space triangle list, shaded by the same code as the terrain
// (shader/lit_surface.wgsl): the sun through the atmosphere, the stratus
// layer's directional transmittance T_C and the cumulus shadow map, the
// sky's SH irradiance or the layer's radiosity as ambient light, seen
// through the aerial perspective.
//
// Not modelled (yet): the objects' shadows on the terrain and on each other,
// the terrain's shadow on them, and the occlusion of the sky by them.

struct ObjectVertex {
    @location(0) position_m: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
}

struct ObjectVarying {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) position_m: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
}

@vertex
fn objects_vertex(v: ObjectVertex) -> ObjectVarying {
    var out: ObjectVarying;
    out.clip_position = frame.clip_from_world * vec4<f32>(v.position_m, 1.0);
    out.position_m = v.position_m;
    out.normal = v.normal;
    out.albedo = v.albedo;
    return out;
}

@fragment
fn objects_fragment(in: ObjectVarying, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    // Back faces are drawn (meshes need not be closed: a roof may be a single
    // sheet) and lit as the side that is seen. Boxes and meshes are wound
    // counter-clockwise seen from outside, as glTF requires.
    let n = select(-1.0, 1.0, front_facing) * normalize(in.normal);
    let radiance = lambert_radiance(in.albedo, in.position_m, n, cloud_sun_visibility(in.position_m));
    return lit_surface_output(radiance, in.position_m);
}
