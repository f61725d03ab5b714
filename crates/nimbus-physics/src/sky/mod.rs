//! The sun and the clear sky: sun direction and irradiance, and an analytic
//! sky-radiance model with its hemispherical irradiance.
//!
//! The analytic Preetham model here is the first sky of nimbus; the physically
//! based atmosphere (transmittance and multiple-scattering LUTs) will replace it.

mod preetham;
mod sun;

pub use preetham::{PerezCoefficients, PreethamSky};
pub use sun::{
    SOLAR_DISK_ANGULAR_RADIUS_RAD, SOLAR_ILLUMINANCE_CONSTANT_LUX, Sun, aerosol_optical_depth,
    rayleigh_optical_depth, relative_air_mass, sun_direction,
};

/// Representative wavelengths of the linear R, G and B channels, µm: the
/// values Bruneton's precomputed atmosphere uses for its RGB rendering.
pub const RGB_WAVELENGTHS_UM: [f64; 3] = [0.680, 0.550, 0.440];
