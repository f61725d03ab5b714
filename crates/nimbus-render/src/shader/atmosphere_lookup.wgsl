// import shader/common.wgsl
// import shader/atmosphere.wgsl
// import shader/lighting_types.wgsl
// Atmosphere lookups for the passes that draw (group 2): sky radiance from
// the sky-view LUT, the sun's transmittance and irradiance at a point, the
// aerial perspective between the camera and a point, and the lighting
// inputs. Needs common.wgsl, atmosphere.wgsl and lighting_types.wgsl.

@group(2) @binding(0) var<uniform> atmosphere: Atmosphere;
@group(2) @binding(1) var atmosphere_sampler: sampler;
@group(2) @binding(2) var transmittance_lut: texture_2d<f32>;
@group(2) @binding(3) var sky_view_lut: texture_2d<f32>;
@group(2) @binding(4) var aerial_perspective_volume: texture_3d<f32>;
@group(2) @binding(5) var<storage, read> lighting: Lighting;
// The aerial perspective's parts (AtmosphereLookups::aerial_perspective_parts).
@group(2) @binding(6) var aerial_perspective_sun: texture_3d<f32>;
@group(2) @binding(7) var aerial_perspective_above: texture_3d<f32>;
@group(2) @binding(8) var aerial_perspective_above_cosine: texture_3d<f32>;

// Sky radiance seen from the camera in a world direction, W·sr⁻¹·m⁻².
fn sky_radiance(direction: vec3<f32>) -> vec3<f32> {
    let r = observer_radius(atmosphere, frame.camera_position_m.y);
    return sky_view_lookup(sky_view_lut, atmosphere_sampler, atmosphere, r, direction, frame.sun_direction);
}

// Transmittance from a world point to the sun (zero in the planet's shadow).
fn sun_transmittance_at(position_m: vec3<f32>) -> vec3<f32> {
    let r = atmosphere.bottom_radius_m + max(position_m.y, 0.0);
    return sample_sun_transmittance(transmittance_lut, atmosphere_sampler, atmosphere, r, frame.sun_direction.y);
}

// Direct solar irradiance at a world point on a surface facing the sun, W·m⁻².
fn sun_irradiance_at(position_m: vec3<f32>) -> vec3<f32> {
    return atmosphere.sun_irradiance_top * sun_transmittance_at(position_m);
}

// Light scattered towards the camera between it and a world point (RGB,
// W·sr⁻¹·m⁻²) and the mean transmittance of that path (A), from the
// aerial-perspective volume.
fn aerial_perspective(position_m: vec3<f32>) -> vec4<f32> {
    let at = aerial_perspective_texel(position_m);
    let value = textureSampleLevel(aerial_perspective_volume, atmosphere_sampler, at.xyz, 0.0);
    return vec4<f32>(value.rgb * at.w, mix(1.0, value.a, at.w));
}

// Where a world point's path lies in the aerial-perspective volumes (xyz),
// and the fade (w) that takes the first slice to no air at the camera.
fn aerial_perspective_texel(position_m: vec3<f32>) -> vec4<f32> {
    let clip = frame.clip_from_world * vec4<f32>(position_m, 1.0);
    let ndc = clip.xy / max(clip.w, 1e-6);
    let uv = vec2<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
    let distance_m = eye_distance_m(position_m);
    let w = sqrt(clamp(distance_m / AERIAL_PERSPECTIVE_MAX_DISTANCE_M, 0.0, 1.0));
    let first_slice = 0.5 / AERIAL_PERSPECTIVE_SIZE.z;
    // Nearer than the first slice's centre, fade linearly to no effect at the camera.
    let fade = clamp(w / first_slice, 0.0, 1.0);
    return vec4<f32>(uv, max(w, first_slice), fade);
}

// The parts of the light the air scatters between the camera and a world
// point (AtmosphereTables::air_path): the sun's single scattering
// (W·sr⁻¹·m⁻²) and the air's weights for a diffuse field
// (nimbus_physics::atmosphere::under_layer::DiffuseWeights).
struct AirParts {
    sun_single: vec3<f32>,
    above: vec3<f32>,
    above_cosine: vec3<f32>,
    total: vec3<f32>,
}

fn aerial_perspective_parts(position_m: vec3<f32>) -> AirParts {
    let at = aerial_perspective_texel(position_m);
    let sun = textureSampleLevel(aerial_perspective_sun, atmosphere_sampler, at.xyz, 0.0) * at.w;
    let above = textureSampleLevel(aerial_perspective_above, atmosphere_sampler, at.xyz, 0.0) * at.w;
    let cosine = textureSampleLevel(aerial_perspective_above_cosine, atmosphere_sampler, at.xyz, 0.0) * at.w;
    return AirParts(sun.rgb, above.rgb, cosine.rgb, vec3<f32>(sun.a, above.a, cosine.a));
}

// Scale from radiance to this frame's HDR target values: the manual
// exposure, or with automatic exposure the incident-light estimate made by
// the lighting pass (the exposure pass then meters the frame and the tone
// mapper corrects by the ratio).
fn pre_exposure() -> f32 {
    return lighting.exposure.x;
}

// Pre-exposed radiance for the HDR target, kept finite in half float.
fn to_target(radiance: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(min(radiance * pre_exposure(), vec3<f32>(frame.max_pre_exposed)), 1.0);
}

// Radiance leaving a world point, as seen through the atmosphere from the camera.
fn apply_aerial_perspective(radiance: vec3<f32>, position_m: vec3<f32>) -> vec3<f32> {
    let ap = aerial_perspective(position_m);
    return radiance * ap.a + ap.rgb;
}
