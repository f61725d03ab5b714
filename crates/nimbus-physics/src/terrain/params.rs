//! Terrain parameters as they appear in scene files (`[terrain]`).

use super::SurfaceClass;
use serde::{Deserialize, Serialize};

/// Parameters of the procedural terrain (scene-file section `[terrain]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TerrainParams {
    /// Side length of the square terrain, centred on the origin, m.
    pub extent_m: f64,
    /// Height scale of the relief, m: mountain tops reach about this height.
    pub height_scale_m: f64,
    /// Horizontal wavelength of the largest hills, m.
    pub feature_wavelength_m: f64,
    /// Random seed: the same seed gives the same terrain.
    pub seed: u64,
    /// Grid cells along one side of the heightfield.
    pub resolution: u32,
    /// Height of the water surface, m; ground below it is water.
    pub water_level_m: f64,
    /// Height band above the water level covered by sand, m.
    pub sand_band_m: f64,
    /// Height above which gentle slopes are snow-covered, m.
    pub snow_line_m: f64,
    /// Slope above which bare rock shows, degrees.
    pub rock_slope_deg: f64,
    /// Broadband albedo of each surface class.
    pub albedo: SurfaceAlbedos,
}

impl Default for TerrainParams {
    fn default() -> Self {
        Self {
            extent_m: 24_000.0,
            height_scale_m: 1_400.0,
            feature_wavelength_m: 6_000.0,
            seed: 7,
            resolution: 512,
            water_level_m: 0.0,
            sand_band_m: 12.0,
            snow_line_m: 900.0,
            rock_slope_deg: 32.0,
            albedo: SurfaceAlbedos::default(),
        }
    }
}

/// Linear Rec.709 albedo of each surface class (scene-file section
/// `[terrain.albedo]`), each channel in [0, 1].
///
/// Defaults are typical visible-band values: fresh snow 0.8–0.9, dry sand
/// 0.35–0.45, rock about 0.2, grass 0.1 in the visible (its broadband albedo of
/// about 0.25 is raised by the near infrared, which nimbus does not render),
/// and deep water's diffuse albedo of a few percent; the water surface's
/// specular reflection is added by the shader (Fresnel).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SurfaceAlbedos {
    /// Diffuse albedo under the water surface.
    pub water: [f32; 3],
    /// Sand albedo.
    pub sand: [f32; 3],
    /// Grass albedo.
    pub grass: [f32; 3],
    /// Bare rock albedo.
    pub rock: [f32; 3],
    /// Snow albedo.
    pub snow: [f32; 3],
}

impl Default for SurfaceAlbedos {
    fn default() -> Self {
        Self {
            water: [0.015, 0.03, 0.04],
            sand: [0.45, 0.38, 0.27],
            grass: [0.07, 0.12, 0.04],
            rock: [0.22, 0.20, 0.18],
            snow: [0.85, 0.87, 0.90],
        }
    }
}

impl SurfaceAlbedos {
    /// Albedo of a surface class.
    pub fn of(&self, class: SurfaceClass) -> [f32; 3] {
        match class {
            SurfaceClass::Water => self.water,
            SurfaceClass::Sand => self.sand,
            SurfaceClass::Grass => self.grass,
            SurfaceClass::Rock => self.rock,
            SurfaceClass::Snow => self.snow,
        }
    }

    /// The classes with their scene-file names, for validation messages.
    pub fn named(&self) -> [(&'static str, [f32; 3]); 5] {
        [
            ("water", self.water),
            ("sand", self.sand),
            ("grass", self.grass),
            ("rock", self.rock),
            ("snow", self.snow),
        ]
    }
}
