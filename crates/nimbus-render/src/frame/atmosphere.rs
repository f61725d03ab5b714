//! What the whole frame reads of the atmosphere besides its lookup
//! textures: the lighting inputs the atmosphere's lighting pass writes (sun,
//! sky and ground irradiance, the environment's spherical harmonics,
//! exposure) and the sun's irradiance above the atmosphere.

use bytemuck::{Pod, Zeroable};
use nimbus_physics::photometry::MAX_LUMINOUS_EFFICACY_LM_PER_W;
use nimbus_physics::sky::SOLAR_ILLUMINANCE_CONSTANT_LUX;

/// Solar irradiance at the top of the atmosphere per RGB channel, W·m⁻²:
/// the luminous solar constant (Darula et al. 2005) in nimbus's
/// luminous-equivalent RGB, taken white.
pub fn solar_irradiance_top() -> [f32; 3] {
    [(SOLAR_ILLUMINANCE_CONSTANT_LUX / MAX_LUMINOUS_EFFICACY_LM_PER_W) as f32; 3]
}

/// GPU layout of WGSL `Lighting` (see `shader/lighting_types.wgsl`): the
/// lighting inputs of the cloud, terrain and rain passes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightingUniform {
    /// Environment radiance as order-2 real SH (RGB in xyz), W·sr⁻¹·m⁻².
    pub sh: [[f32; 4]; 9],
    /// C_sky: sky irradiance on an upward surface at the camera, W·m⁻².
    pub sky_irradiance_up: [f32; 4],
    /// C_sun: direct solar irradiance at the camera's altitude, W·m⁻².
    pub sun_irradiance: [f32; 4],
    /// C_ground: radiance of the ground lit by sun and sky, W·sr⁻¹·m⁻².
    pub ground_radiance: [f32; 4],
    /// x: pre-exposure of the drawing passes; y: incident-light EV100 at the camera.
    pub exposure: [f32; 4],
}
