// import shader/atmosphere_lookup.wgsl
// import shader/cloud_layer_lookup.wgsl
// import shader/cloud_shadow_lookup.wgsl
// Lambertian surfaces lit by the sun through the atmosphere and by the
// environment (the clear sky's spherical harmonics; under a stratus layer the
// radiosity's R_G, Bouthors et al. 2006, §5). Shared by the terrain and the
// static objects. Needs common.wgsl, the atmosphere lookups and
// shader/cloud_layer_lookup.wgsl.

// Radiance of a Lambertian surface of albedo `albedo` with unit normal `n` at `position_m`.
// `sun_visibility` is the fraction of the sun's light reaching the point.
fn lambert_radiance(albedo: vec3<f32>, position_m: vec3<f32>, n: vec3<f32>, sun_visibility: vec3<f32>) -> vec3<f32> {
    let direct = sun_irradiance_at(position_m) * max(dot(n, frame.sun_direction), 0.0) * sun_visibility;
    let environment = stratus_ground_irradiance(position_m, n, sh_irradiance(lighting, n));
    return albedo / PI * (direct + environment);
}
