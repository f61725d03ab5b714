// import shader/atmosphere.wgsl
// The atmosphere pass's group 1, declared once for its five compute steps:
// the atmosphere's parameters, the LUT sampler and the LUTs that later steps
// read (bindings 0–4). Each step declares only its output, at binding 8.
// A step's bind group layout holds just the bindings its entry point uses
// (AtmospherePass::new), so a LUT is never bound while it is written.

@group(1) @binding(0) var<uniform> atmosphere: Atmosphere;
@group(1) @binding(1) var lut_sampler: sampler;
@group(1) @binding(2) var transmittance_lut: texture_2d<f32>;
@group(1) @binding(3) var multiple_scattering_lut: texture_2d<f32>;
@group(1) @binding(4) var sky_view_lut: texture_2d<f32>;
