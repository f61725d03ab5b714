//! The sun: its direction, disk and extraterrestrial illuminance, and simple
//! clear-sky beam attenuation (air mass, Rayleigh and aerosol optical depth)
//! used to cross-check the atmosphere model. The sky itself is
//! [`crate::atmosphere`].

mod sun;

pub use sun::{
    SOLAR_DISK_ANGULAR_RADIUS_RAD, SOLAR_ILLUMINANCE_CONSTANT_LUX, aerosol_optical_depth,
    rayleigh_optical_depth, relative_air_mass, sun_direction,
};
