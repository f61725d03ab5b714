// import shader/lit_surface.wgsl
// nimbus's lighting for the caller's own pipelines: its surfaces lit by the
// same sun, sky and clouds as nimbus's (docs/embedding.md, "Your world lit
// by nimbus's sky"). Composed by `nimbus_render::shader::lighting_include()`;
// append your shader after it. Bind groups of your pipeline:
//   0: nimbus's frame uniform        (FrameLayouts::frame)
//   1: yours                          (the one `pipeline_layout` takes)
//   2: nimbus's atmosphere lookups   (FrameLayouts::atmosphere)
//   3: nimbus's cloud lighting        (FrameLayouts::cloud_lighting): the
//      cumulus shadow map (bindings 0, 1), the stratus layer (2–6)
// `FrameLayouts::pipeline_layout` builds that layout and
// `FrameBindings::set_on` binds the groups. Record
// `Renderer::encode_lighting` before your draws so that they read this
// frame's shadows. The functions below are the stable interface; the
// others this file pulls in are nimbus's own and may change.

// Fraction of the sun's light that reaches world point `position_m` (m)
// through the clouds, per channel: the cumulus shadow map's two-stream
// transmittance times the stratus layer's directional transmittance.
fn nimbus_sun_visibility(position_m: vec3<f32>) -> vec3<f32> {
    return cloud_sun_visibility(position_m);
}

// Unit vector towards the sun, world space.
fn nimbus_sun_direction() -> vec3<f32> {
    return frame.sun_direction;
}

// The sun's irradiance on a surface facing it at `position_m` through the
// clear atmosphere, W·m⁻² per channel (multiply by
// `nimbus_sun_visibility` for the clouds' shadow).
fn nimbus_sun_irradiance(position_m: vec3<f32>) -> vec3<f32> {
    return sun_irradiance_at(position_m);
}

// Radiance leaving a Lambertian surface of linear `albedo` with unit
// normal `normal` at `position_m`: the sun through the atmosphere and the
// clouds, and the environment (the clear sky's spherical harmonics, or under
// a stratus layer its radiosity), W·sr⁻¹·m⁻² per channel. Neither
// pre-exposed nor seen through the air: in `OutputMode::LinearHdr` nimbus
// draws the aerial perspective over your pixels by their depth.
fn nimbus_lambert_radiance(albedo: vec3<f32>, position_m: vec3<f32>, normal: vec3<f32>) -> vec3<f32> {
    return lambert_radiance(albedo, position_m, normal, nimbus_sun_visibility(position_m));
}

// The pre-exposure nimbus writes with (`Renderer::set_pre_exposure` in
// `LinearHdr`): multiply your radiance by it to match nimbus's output.
fn nimbus_pre_exposure() -> f32 {
    return frame.exposure_scale;
}
