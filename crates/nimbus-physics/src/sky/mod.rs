//! The sun: its position from date, time and place (NREL SPA), its
//! direction, disk and extraterrestrial illuminance, and simple
//! clear-sky beam attenuation (air mass, Rayleigh and aerosol optical depth)
//! used to cross-check the atmosphere model. The sky itself is
//! [`crate::atmosphere`].

mod spa;
mod spa_tables;
mod sun;
mod time;

pub use spa::{
    Observer, SolarPosition, delta_t_s, julian_day, solar_position, solar_position_with_delta_t,
};
pub use time::UtcDateTime;

pub use sun::{
    SOLAR_DISK_ANGULAR_RADIUS_RAD, SOLAR_ILLUMINANCE_CONSTANT_LUX, aerosol_optical_depth,
    rayleigh_optical_depth, relative_air_mass, sun_direction,
};
