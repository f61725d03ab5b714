// import shader/atmosphere_lookup.wgsl
// import shader/cloud_layer_lookup.wgsl
// import shader/cloud_shadow_lookup.wgsl
// Opaque lit surfaces, shared by the terrain and the static objects so that
// both are shaded by the same code: Lambertian reflection of the sun through
// the atmosphere and the clouds (the stratus layer's directional
// transmittance T_C and the cumulus shadow map), of the environment (the
// clear sky's spherical harmonics; under a stratus layer the radiosity's R_G,
// Bouthors et al. 2006, §5), seen through the aerial perspective.

// Fraction of the sun's light that the clouds let through to `position_m`, per channel.
fn cloud_sun_visibility(position_m: vec3<f32>) -> vec3<f32> {
    return stratus_sun_transmittance(position_m) * cloud_shadow_transmittance(position_m);
}

// Radiance of a Lambertian surface of albedo `albedo` with unit normal `n` at `position_m`.
// `sun_visibility` is the fraction of the sun's light reaching the point.
fn lambert_radiance(albedo: vec3<f32>, position_m: vec3<f32>, n: vec3<f32>, sun_visibility: vec3<f32>) -> vec3<f32> {
    let direct = sun_irradiance_at(position_m) * max(dot(n, frame.sun_direction), 0.0) * sun_visibility;
    let environment = stratus_environment_irradiance(lighting, position_m, n);
    return albedo / PI * (direct + environment);
}

// What a surface writes to the HDR target: its radiance at `position_m`
// seen through the aerial perspective (and the stratus layer's), pre-exposed.
fn lit_surface_output(radiance: vec3<f32>, position_m: vec3<f32>) -> vec4<f32> {
    return to_target(stratus_apply_aerial_perspective(radiance, position_m));
}
