// import shader/open_water.wgsl
// Terrain pass: the heightfield lit by the sun (Lambert, with terrain
// shadows) and by the environment (sky and ground, from the lighting
// inputs' spherical harmonics), with open water shaded by water.wgsl, seen
// through the aerial perspective. Under a stratus layer the sun is shadowed
// by the layer's directional transmittance T_C and the indirect light is the
// radiosity's R_G (Bouthors et al. 2006, §5); cumulus shade it through
// their shadow map. The land is shaded by shader/lit_surface.wgsl, the same
// code as the static objects.

// Group 1: the albedo map. RGB: linear albedo (sRGB-encoded storage);
// A: water mask (1 = water).
@group(1) @binding(0) var albedo_map: texture_2d<f32>;
@group(1) @binding(1) var albedo_sampler: sampler;
// Fraction of the solar disk visible from each vertex (terrain shadows),
// computed on the CPU by nimbus_physics::terrain::sun_visibility.
@group(1) @binding(2) var sun_visibility_map: texture_2d<f32>;

struct TerrainVertex {
    @location(0) position_m: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

struct TerrainVarying {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) position_m: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

@vertex
fn terrain_vertex(v: TerrainVertex) -> TerrainVarying {
    var out: TerrainVarying;
    out.clip_position = frame.clip_from_world * vec4<f32>(v.position_m, 1.0);
    out.position_m = v.position_m;
    out.normal = v.normal;
    out.uv = v.uv;
    return out;
}

@fragment
fn terrain_fragment(in: TerrainVarying) -> @location(0) vec4<f32> {
    let texel = textureSample(albedo_map, albedo_sampler, in.uv);
    let sun_visibility = textureSample(sun_visibility_map, albedo_sampler, in.uv).r
        * cloud_sun_visibility(in.position_m);
    let n = normalize(in.normal);
    let land = lambert_radiance(texel.rgb, in.position_m, n, sun_visibility);
    // The water mask is filtered, so shorelines blend smoothly.
    let water = water_radiance(in.position_m, texel.rgb, sun_visibility);
    return lit_surface_output(mix(land, water, texel.a), in.position_m);
}

