//! Parameters of the atmosphere (scene-file section `[atmosphere]`).
//!
//! Defaults are the Earth atmosphere of Hillaire (2020, §4 and table 1, after
//! Bruneton 2017): Rayleigh scattering at the channel wavelengths 680, 550 and
//! 440 nm with an 8 km scale height, ozone absorption in a tent profile
//! centred at 25 km, and aerosols with a 1.2 km scale height; nimbus gives
//! the aerosol amount as a vertical optical depth at 550 nm with an Ångström
//! exponent, which users know from sun photometers (AERONET), instead of
//! Hillaire's fixed Mie coefficients.

use serde::{Deserialize, Serialize};

/// Parameters of a planetary atmosphere. Lengths in metres, coefficients per metre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AtmosphereParams {
    /// Radius of the planet's surface (sea level), m.
    pub bottom_radius_m: f64,
    /// Radius of the top of the atmosphere, m.
    pub top_radius_m: f64,
    /// Rayleigh scattering coefficient at sea level per RGB channel, m⁻¹.
    pub rayleigh_scattering_per_m: [f64; 3],
    /// Scale height of the air density, m.
    pub rayleigh_scale_height_m: f64,
    /// Vertical aerosol optical depth at 550 nm (0.05 very clean, 0.1 clear, 0.3 hazy).
    pub aerosol_optical_depth: f64,
    /// Ångström exponent of the aerosol extinction (1.3 continental, 0.5 maritime).
    pub aerosol_angstrom_exponent: f64,
    /// Single-scattering albedo of the aerosols (scattering over extinction).
    pub aerosol_single_scattering_albedo: f64,
    /// Scale height of the aerosol density, m.
    pub aerosol_scale_height_m: f64,
    /// Asymmetry parameter g of the aerosol phase function (Cornette–Shanks).
    pub aerosol_asymmetry: f64,
    /// Ozone absorption coefficient at the layer's peak per RGB channel, m⁻¹.
    pub ozone_absorption_per_m: [f64; 3],
    /// Altitude of the ozone peak, m.
    pub ozone_peak_altitude_m: f64,
    /// Half width of the ozone tent profile, m.
    pub ozone_half_width_m: f64,
    /// Mean albedo of the ground seen by the atmosphere's multiple scattering.
    pub ground_albedo: [f64; 3],
}

impl Default for AtmosphereParams {
    fn default() -> Self {
        Self {
            bottom_radius_m: 6_360_000.0,
            top_radius_m: 6_460_000.0,
            rayleigh_scattering_per_m: [5.802e-6, 13.558e-6, 33.1e-6],
            rayleigh_scale_height_m: 8_000.0,
            aerosol_optical_depth: 0.1,
            aerosol_angstrom_exponent: 1.3,
            aerosol_single_scattering_albedo: 0.9,
            aerosol_scale_height_m: 1_200.0,
            aerosol_asymmetry: 0.8,
            ozone_absorption_per_m: [0.650e-6, 1.881e-6, 0.085e-6],
            ozone_peak_altitude_m: 25_000.0,
            ozone_half_width_m: 15_000.0,
            ground_albedo: [0.3, 0.3, 0.3],
        }
    }
}

impl AtmosphereParams {
    /// Aerosol extinction coefficient at sea level per RGB channel, m⁻¹:
    /// the optical depth spread over the exponential profile (τ = β₀ H) and
    /// scaled to each channel's wavelength by the Ångström law.
    pub fn aerosol_extinction_per_m(&self) -> [f64; 3] {
        let beta_550 = self.aerosol_optical_depth / self.aerosol_scale_height_m;
        super::RGB_WAVELENGTHS_UM
            .map(|wl| beta_550 * (wl / 0.55).powf(-self.aerosol_angstrom_exponent))
    }

    /// Aerosol scattering coefficient at sea level per RGB channel, m⁻¹.
    pub fn aerosol_scattering_per_m(&self) -> [f64; 3] {
        self.aerosol_extinction_per_m()
            .map(|e| e * self.aerosol_single_scattering_albedo)
    }
}
