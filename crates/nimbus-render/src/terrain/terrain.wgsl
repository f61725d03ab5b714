// Terrain pass: the heightfield lit by the sun (Lambert) and the sky
// (isotropic sky view factor), with open water shaded by water.wgsl.
// Needs common.wgsl, sky_model.wgsl and water.wgsl.

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

// Mean albedo of the surroundings, for the light a tilted surface receives
// from the ground around it.
const SURROUNDING_ALBEDO: f32 = 0.15;

// Radiance of a Lambertian surface of albedo `albedo` with unit normal `n`.
fn lambert_radiance(albedo: vec3<f32>, n: vec3<f32>, sun_visibility: f32) -> vec3<f32> {
    let direct = frame.sun_irradiance * max(dot(n, frame.sun_direction), 0.0) * sun_visibility;
    // Isotropic sky: a surface tilted by θ sees the fraction (1 + cos θ) / 2 of the dome,
    // and the ground the rest (1 − cos θ) / 2.
    let sky = frame.sky_irradiance * (0.5 + 0.5 * n.y);
    let horizontal = frame.sun_irradiance * max(frame.sun_direction.y, 0.0) + frame.sky_irradiance;
    let ground = horizontal * SURROUNDING_ALBEDO * (0.5 - 0.5 * n.y);
    return albedo / PI * (direct + sky + ground);
}

@fragment
fn terrain_fragment(in: TerrainVarying) -> @location(0) vec4<f32> {
    let texel = textureSample(albedo_map, albedo_sampler, in.uv);
    let sun_visibility = textureSample(sun_visibility_map, albedo_sampler, in.uv).r;
    let n = normalize(in.normal);
    let land = lambert_radiance(texel.rgb, n, sun_visibility);
    // The water mask is filtered, so shorelines blend smoothly.
    let water = water_radiance(in.position_m, texel.rgb, sun_visibility);
    return to_target(mix(land, water, texel.a));
}
