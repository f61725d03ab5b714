//! The rain and wind sections of a scene: `[rain]` (intensity, drop sizes,
//! the rain box, streaks, splashes, mist, where it rains) and the wind's
//! turbulence and flow primitives (`[wind.turbulence]`,
//! `[[wind.primitives]]`). See docs/scene-file.md and docs/rain.md.

use super::validate::{Checker, SceneError};
use super::{Scene, WindSettings};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Most drops a scene may ask for (32 bytes each on the GPU: 512 MiB).
pub const MAX_RAIN_DROPS: u64 = 16_000_000;

/// Shape of the rain box (`rain.box_shape`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum RainBoxKind {
    /// A ball of `box_radius_m` around the camera (turning costs nothing).
    #[default]
    Sphere,
    /// An axis-aligned cube of half side `box_radius_m`.
    Box,
    /// The view frustum out to `box_radius_m` (fewest drops).
    Frustum,
}

/// A circular rain area (`[[rain.areas]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct RainAreaSettings {
    /// Centre (x, z), world m.
    pub center_m: [f64; 2],
    /// Radius where the rain has stopped, m.
    pub radius_m: f64,
    /// Width of the soft edge inside the radius, m.
    #[serde(default = "default_edge_m")]
    pub edge_m: f64,
}

impl RainAreaSettings {
    /// An area of rain centred at `center_m` (x, z) of radius `radius_m`,
    /// with the file's default edge.
    pub fn new(center_m: [f64; 2], radius_m: f64) -> Self {
        Self {
            center_m,
            radius_m,
            edge_m: default_edge_m(),
        }
    }
}

fn default_edge_m() -> f64 {
    500.0
}

/// Rain (`[rain]`): GPU particles around the camera tied to the intensity
/// by Marshall–Palmer, streaks, splashes and mist (Blanchard 2023).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct RainSettings {
    /// Rain intensity where it rains fully, mm/h, in [0, 300].
    pub intensity_mm_h: f64,
    /// Smallest drop simulated as a particle, mm, in [0.1, 2] (smaller ones are mist).
    pub min_diameter_mm: f64,
    /// Largest drop (larger ones break up), mm, in (min_diameter_mm, 8].
    pub max_diameter_mm: f64,
    /// Shape of the rain box: "sphere", "box" or "frustum".
    pub box_shape: RainBoxKind,
    /// Radius of the sphere, half side of the box, or far distance of the frustum, m, in [1, 200].
    pub box_radius_m: f64,
    /// Most drops simulated, in [1, 16000000]; when the intensity asks for
    /// more, the count is capped and a warning printed.
    pub max_drops: u64,
    /// Exposure time of the camera: streaks are speed × this long, s, in [0.0005, 0.1].
    pub exposure_s: f64,
    /// Smallest width of a streak on screen, pixels, in [0.5, 4].
    pub min_streak_width_px: f64,
    /// Draw splashes where drops hit the scene.
    pub splashes: bool,
    /// Splashes are made within this distance of the camera, m, in [0, 100].
    pub splash_radius_m: f64,
    /// Continue the rain beyond the box as mist.
    pub mist: bool,
    /// No rain above this height, m; the lowest cloud base when absent.
    pub ceiling_m: Option<f64>,
    /// Rain only under the clouds: where the stratus layer is thicker than
    /// `cloud_threshold_m`, and under cumulus, with soft edges.
    pub under_clouds: bool,
    /// Stratus thickness above which it rains, m, in [0, 2000].
    pub cloud_threshold_m: f64,
    /// Areas where it rains (with soft edges); with neither these nor
    /// `under_clouds`, it rains everywhere.
    pub areas: Vec<RainAreaSettings>,
}

impl Default for RainSettings {
    fn default() -> Self {
        Self {
            intensity_mm_h: 5.0,
            min_diameter_mm: 0.5,
            max_diameter_mm: 6.0,
            box_shape: RainBoxKind::Sphere,
            box_radius_m: 10.0,
            max_drops: 4_000_000,
            exposure_s: 1.0 / 60.0,
            min_streak_width_px: 1.0,
            splashes: true,
            splash_radius_m: 4.0,
            mist: true,
            ceiling_m: None,
            under_clouds: false,
            cloud_threshold_m: 150.0,
            areas: Vec::new(),
        }
    }
}

/// Frozen turbulence carried by the wind (`[wind.turbulence]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct TurbulenceSettings {
    /// RMS speed of the gusts, m/s, in [0, 30].
    pub rms_speed_m_s: f64,
    /// Size of the periodic tile of turbulence (largest eddies ~¼ of it), m, in [4, 10000].
    pub tile_m: f64,
    /// Random seed.
    pub seed: u32,
}

impl Default for TurbulenceSettings {
    fn default() -> Self {
        Self {
            rms_speed_m_s: 2.0,
            tile_m: 64.0,
            seed: 1,
        }
    }
}

/// A wind field read from a file (`[wind.field]`): a periodic grid of
/// velocities added to the mean wind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct WindFieldSettings {
    /// Path of a NumPy `.npy` file, relative to the scene file: float32 or
    /// float64, shape (nz, ny, nx, 3), the velocity (x, y, z) in m/s at each
    /// grid point, x fastest (see `WindGrid::from_npy`).
    pub file: String,
    /// Spacing of the grid points, m, in [0.1, 10000].
    pub cell_m: f64,
    /// World position of grid point (0, 0, 0), m; the grid repeats beyond
    /// its extent.
    #[serde(default)]
    pub origin_m: [f64; 3],
    /// Whether the field moves with the mean wind (frozen turbulence) or
    /// stays fixed to the ground (flow around terrain and buildings).
    #[serde(default)]
    pub carried: bool,
}

impl WindFieldSettings {
    /// A field read from the `.npy` file at `file` (relative to the scene
    /// file), `cell_m` metres between grid points, its origin at the world's,
    /// fixed to the ground (not carried by the mean wind).
    pub fn new(file: impl Into<String>, cell_m: f64) -> Self {
        Self {
            file: file.into(),
            cell_m,
            origin_m: [0.0; 3],
            carried: false,
        }
    }

    /// Reads the grid from `path` (the file, resolved against the scene).
    pub fn load(
        &self,
        path: &std::path::Path,
    ) -> Result<nimbus_physics::rain::wind::WindGrid, String> {
        let bytes =
            nimbus_physics::io::read_bounded(path, nimbus_physics::rain::wind::MAX_WIND_NPY_BYTES)
                .map_err(|e| e.to_string())?;
        let o = self.origin_m;
        nimbus_physics::rain::wind::WindGrid::from_npy(
            &bytes,
            self.cell_m as f32,
            glam::Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32),
            self.carried,
        )
        .map_err(|e| e.to_string())
    }
}

/// Kind of a wind primitive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum WindPrimitiveKindSetting {
    /// Uniform flow (a jet when `radius_m` > 0).
    Uniform,
    /// Radial outflow (negative speed: a sink).
    Source,
    /// Rotation about an axis (Rankine vortex).
    Vortex,
    /// Gust fronts crossing the scene.
    GustFront,
}

/// A wind primitive (`[[wind.primitives]]`), after Wejchert & Haumann (1991).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct WindPrimitiveSettings {
    /// "uniform", "source", "vortex" or "gust_front".
    pub kind: WindPrimitiveKindSetting,
    /// Centre at time 0, world m.
    #[serde(default)]
    pub center_m: [f64; 3],
    /// Velocity of the centre, m/s.
    #[serde(default)]
    pub drift_m_s: [f64; 3],
    /// Flow direction, vortex axis or gust direction (normalised), default up.
    #[serde(default = "default_axis")]
    pub axis: [f64; 3],
    /// Speed, m/s, in [−100, 100]: flow speed, outflow at the core's edge,
    /// tangential speed at the core's edge, or the gusts' peak.
    pub speed_m_s: f64,
    /// Radius, m, in [0, 10000]: the jet's, the core's, or the gusts' width.
    #[serde(default = "default_primitive_radius_m")]
    pub radius_m: f64,
    /// Gust fronts: time between fronts, s, in [1, 3600].
    #[serde(default = "default_period_s")]
    pub period_s: f64,
    /// Gust fronts: their speed, m/s, in [0, 100].
    #[serde(default = "default_front_speed_m_s")]
    pub front_speed_m_s: f64,
}

impl WindPrimitiveSettings {
    /// A primitive of `kind` and `speed_m_s` at the origin, not drifting,
    /// with the file's defaults for the rest (axis up, radius 10 m, gust
    /// fronts every 30 s at 10 m/s); set the other fields after.
    pub fn new(kind: WindPrimitiveKindSetting, speed_m_s: f64) -> Self {
        Self {
            kind,
            center_m: [0.0; 3],
            drift_m_s: [0.0; 3],
            axis: default_axis(),
            speed_m_s,
            radius_m: default_primitive_radius_m(),
            period_s: default_period_s(),
            front_speed_m_s: default_front_speed_m_s(),
        }
    }
}

fn default_axis() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_primitive_radius_m() -> f64 {
    10.0
}
fn default_period_s() -> f64 {
    30.0
}
fn default_front_speed_m_s() -> f64 {
    10.0
}

impl Scene {
    /// The wind field of the physics crate: the mean wind, the turbulence or
    /// the field read from its file, and the primitives; none without
    /// `[wind]`. An error names the file that no longer reads (the scene's
    /// validation read it once).
    pub fn wind_field(&self) -> Result<nimbus_physics::rain::wind::WindField, String> {
        let Some(wind) = &self.wind else {
            return Ok(Default::default());
        };
        let mut field = wind.field_without_file();
        if let Some(settings) = &wind.field {
            let path = self.resolve_path(&settings.file);
            field.grid = Some(
                settings
                    .load(&path)
                    .map_err(|e| format!("wind.field.file {}: {e}", path.display()))?,
            );
        }
        Ok(field)
    }
}

impl WindSettings {
    /// The wind field of the physics crate without a `[wind.field]` file:
    /// the mean wind, turbulence and primitives (see [`Scene::wind_field`]).
    pub fn field_without_file(&self) -> nimbus_physics::rain::wind::WindField {
        use nimbus_physics::rain::wind::{WindField, WindGrid};
        WindField {
            grid: self
                .turbulence
                .as_ref()
                .map(|t| WindGrid::turbulence(32, t.tile_m as f32, t.rms_speed_m_s as f32, t.seed)),
            ..self.field_without_grid()
        }
    }

    /// The mean wind and the primitives, without a grid (cheap: what
    /// changes from frame to frame when the wind is keyframed).
    pub fn field_without_grid(&self) -> nimbus_physics::rain::wind::WindField {
        use nimbus_physics::rain::wind::{WindField, WindPrimitive, WindPrimitiveKind};
        let [x, z] = self.velocity_xz_m_s();
        let vec3 = |v: [f64; 3]| glam::Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
        WindField {
            mean_m_s: glam::Vec3::new(x as f32, 0.0, z as f32),
            grid: None,
            primitives: self
                .primitives
                .iter()
                .map(|p| WindPrimitive {
                    kind: match p.kind {
                        WindPrimitiveKindSetting::Uniform => WindPrimitiveKind::Uniform,
                        WindPrimitiveKindSetting::Source => WindPrimitiveKind::Source,
                        WindPrimitiveKindSetting::Vortex => WindPrimitiveKind::Vortex,
                        WindPrimitiveKindSetting::GustFront => WindPrimitiveKind::GustFront,
                    },
                    center_m: vec3(p.center_m),
                    drift_m_s: vec3(p.drift_m_s),
                    axis: vec3(p.axis).normalize_or(glam::Vec3::Y),
                    speed_m_s: p.speed_m_s as f32,
                    radius_m: p.radius_m as f32,
                    period_s: p.period_s as f32,
                    front_speed_m_s: p.front_speed_m_s as f32,
                })
                .collect(),
        }
    }
}

impl Scene {
    /// The height above which it does not rain: `rain.ceiling_m`, else the
    /// lowest cloud base, else none (infinite).
    pub fn rain_ceiling_m(&self) -> f64 {
        if let Some(ceiling) = self.rain.as_ref().and_then(|r| r.ceiling_m) {
            return ceiling;
        }
        let bases = [
            self.stratus.as_ref().map(|s| s.base_m),
            self.cumulus.as_ref().map(|c| c.base_m),
        ];
        bases.into_iter().flatten().fold(f64::INFINITY, f64::min)
    }

    pub(super) fn validate_rain(&self, c: &Checker<'_>) -> Result<(), SceneError> {
        if let Some(rain) = &self.rain {
            c.closed("rain.intensity_mm_h", rain.intensity_mm_h, 0.0, 300.0)?;
            c.closed("rain.min_diameter_mm", rain.min_diameter_mm, 0.1, 2.0)?;
            c.closed("rain.max_diameter_mm", rain.max_diameter_mm, 0.1, 8.0)?;
            if rain.max_diameter_mm <= rain.min_diameter_mm {
                return Err(c.invalid(
                    "rain.max_diameter_mm",
                    rain.max_diameter_mm,
                    format!(
                        "must be larger than rain.min_diameter_mm = {}",
                        rain.min_diameter_mm
                    ),
                ));
            }
            c.closed("rain.box_radius_m", rain.box_radius_m, 1.0, 200.0)?;
            c.integer("rain.max_drops", rain.max_drops, 1, MAX_RAIN_DROPS)?;
            c.closed("rain.exposure_s", rain.exposure_s, 0.0005, 0.1)?;
            c.closed(
                "rain.min_streak_width_px",
                rain.min_streak_width_px,
                0.5,
                4.0,
            )?;
            c.closed("rain.splash_radius_m", rain.splash_radius_m, 0.0, 100.0)?;
            if let Some(ceiling) = rain.ceiling_m {
                c.closed("rain.ceiling_m", ceiling, -1_000.0, 20_000.0)?;
            }
            c.closed(
                "rain.cloud_threshold_m",
                rain.cloud_threshold_m,
                0.0,
                2_000.0,
            )?;
            if rain.areas.len() > 64 {
                return Err(c.invalid("rain.areas", rain.areas.len(), "at most 64 areas"));
            }
            for (i, area) in rain.areas.iter().enumerate() {
                c.vector(
                    &format!("rain.areas[{i}].center_m"),
                    &area.center_m,
                    -1e6,
                    1e6,
                )?;
                c.closed(
                    &format!("rain.areas[{i}].radius_m"),
                    area.radius_m,
                    1.0,
                    1e6,
                )?;
                c.closed(
                    &format!("rain.areas[{i}].edge_m"),
                    area.edge_m,
                    0.0,
                    area.radius_m,
                )?;
            }
        }
        if let Some(wind) = &self.wind {
            if let Some(t) = &wind.turbulence {
                c.closed("wind.turbulence.rms_speed_m_s", t.rms_speed_m_s, 0.0, 30.0)?;
                c.closed("wind.turbulence.tile_m", t.tile_m, 4.0, 10_000.0)?;
            }
            if let Some(f) = &wind.field {
                if wind.turbulence.is_some() {
                    return Err(c.invalid(
                        "wind.field",
                        "a table",
                        "cannot be used with [wind.turbulence]: the rain has one velocity grid",
                    ));
                }
                c.closed("wind.field.cell_m", f.cell_m, 0.1, 10_000.0)?;
                c.vector("wind.field.origin_m", &f.origin_m, -1e6, 1e6)?;
                if !f.file.to_ascii_lowercase().ends_with(".npy") {
                    return Err(c.invalid(
                        "wind.field.file",
                        format!("{:?}", f.file),
                        "must be the path of a NumPy .npy file",
                    ));
                }
                // Read it now, so that a bad file fails the scene's loading.
                if c.read_files {
                    f.load(&self.resolve_path(&f.file)).map_err(|e| {
                        c.invalid(
                        "wind.field.file",
                        format!("{:?}", f.file),
                        format!(
                            "must be a float32 or float64 .npy array of shape (nz, ny, nx, 3): {e}"
                        ),
                    )
                    })?;
                }
            }
            if wind.primitives.len() > nimbus_physics::rain::wind::MAX_WIND_PRIMITIVES {
                return Err(c.invalid(
                    "wind.primitives",
                    wind.primitives.len(),
                    format!(
                        "at most {} primitives",
                        nimbus_physics::rain::wind::MAX_WIND_PRIMITIVES
                    ),
                ));
            }
            for (i, p) in wind.primitives.iter().enumerate() {
                let key = |k: &str| format!("wind.primitives[{i}].{k}");
                c.vector(&key("center_m"), &p.center_m, -1e6, 1e6)?;
                c.vector(&key("drift_m_s"), &p.drift_m_s, -100.0, 100.0)?;
                c.vector(&key("axis"), &p.axis, -1.0, 1.0)?;
                if p.axis.iter().map(|a| a * a).sum::<f64>() < 1e-6 {
                    return Err(c.invalid(
                        &key("axis"),
                        format!("{:?}", p.axis),
                        "must not be zero",
                    ));
                }
                c.closed(&key("speed_m_s"), p.speed_m_s, -100.0, 100.0)?;
                c.closed(&key("radius_m"), p.radius_m, 0.0, 10_000.0)?;
                c.closed(&key("period_s"), p.period_s, 1.0, 3_600.0)?;
                c.closed(&key("front_speed_m_s"), p.front_speed_m_s, 0.0, 100.0)?;
            }
        }
        Ok(())
    }
}
