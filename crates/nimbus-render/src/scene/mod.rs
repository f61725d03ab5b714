//! Scene files: the weather, camera, sun and terrain of one picture.
//!
//! A scene is a TOML file read with serde. Every section and key is
//! documented on the types below (and in `docs/scene-file.md`); unknown keys,
//! wrong types, NaN/inf and out-of-range values are rejected by
//! [`Scene::from_toml_str`] with a [`SceneError`] that names the file, the key,
//! the value and what is allowed.

mod animation;
pub mod gltf;
pub mod object_geometry;
mod objects;
mod rain;
mod schema;
mod validate;

pub use animation::{Keyframe, MAX_KEYFRAMES, evaluate_track};
pub use objects::{
    BOX_TRIANGLES, DEFAULT_OBJECT_ALBEDO, MAX_OBJECT_TRIANGLES, MAX_OBJECTS, ObjectKind,
    ObjectShape, SceneObject,
};
pub use rain::{
    MAX_RAIN_DROPS, RainAreaSettings, RainBoxKind, RainSettings, TurbulenceSettings,
    WindFieldSettings, WindPrimitiveKindSetting, WindPrimitiveSettings,
};
pub use schema::{SCHEMA_PATH, json_schema, json_schema_text};
pub use validate::{IN_CODE, MIN_FOV_DEG, SceneError};

use nimbus_physics::atmosphere::AtmosphereParams;
use nimbus_physics::cloud_layer::CloudLayerField;
use nimbus_physics::cumulus::shading::{CumulusShading, ShadingTerms};
use nimbus_physics::terrain::TerrainParams;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Largest scene file read, bytes. Real scenes are a few kilobytes (1024
/// objects fit in a fifth of this); the bound keeps the parser's memory
/// bounded too (about 50 bytes per byte of TOML at worst, so ~50 MB),
/// whatever counts of tables or array elements the file holds, before any
/// count is checked.
pub const MAX_SCENE_FILE_BYTES: u64 = 1024 * 1024;

/// The text of the embedded default scene. The file lives in this crate
/// (`src/scene/default.toml`), so that the published crate holds it;
/// `scenes/default.toml`, where users and the README find it beside the other
/// example scenes, is a symbolic link to it.
pub const DEFAULT_SCENE_TOML: &str = include_str!("default.toml");

pub use crate::core::limits::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE_PX};

/// Most clouds a cumulus field places (the cumulus pass's capacity).
pub const MAX_CLOUDS: usize = 400;

/// Largest terrain resolution (grid cells per side): the vertex buffer then
/// takes 134 MB, within every device's default 256 MiB buffer limit.
pub const MAX_TERRAIN_RESOLUTION: u32 = 2048;

/// A complete scene.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct Scene {
    /// Output image size.
    pub image: ImageSettings,
    /// The camera.
    pub camera: CameraSettings,
    /// The sun's position.
    pub sun: SunSettings,
    /// The clear atmosphere (Hillaire 2020 model).
    pub atmosphere: AtmosphereParams,
    /// The procedural terrain.
    pub terrain: TerrainParams,
    /// Whether the terrain is drawn, or the ground is a caller's (`[ground]`).
    pub ground: GroundSettings,
    /// Cumulus clouds: a field of them placed over the terrain.
    pub cumulus: Option<CumulusSettings>,
    /// Stratiform cloud layer.
    pub stratus: Option<StratusSettings>,
    /// Rain: particles around the camera, streaks, splashes and mist.
    pub rain: Option<RainSettings>,
    /// Wind: carries the stratiform layer and the rain.
    pub wind: Option<WindSettings>,
    /// Static objects (`[[objects]]`): boxes and glTF meshes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub objects: Vec<SceneObject>,
    /// Keyframed weather (`[[keyframes]]`, see [`Scene::at_time`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub keyframes: Vec<Keyframe>,
    /// Directory that relative paths in the scene (`objects[].gltf`) are
    /// resolved against ([`Scene::resolve_path`]): the scene file's
    /// directory for [`Scene::from_file`], `None` (the current directory)
    /// for scenes parsed from text. Not a key of the file.
    #[serde(skip)]
    pub base_dir: Option<PathBuf>,
}

/// Output image size (`[image]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct ImageSettings {
    /// Width in pixels, 1 to 16384.
    pub width: u32,
    /// Height in pixels, 1 to 16384.
    pub height: u32,
}

impl Default for ImageSettings {
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
        }
    }
}

/// The camera (`[camera]`): a pinhole at `position_m`, aimed either at
/// `look_at_m` or by `yaw_deg`/`pitch_deg` (not both).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct CameraSettings {
    /// Eye position in world metres (x east, y up, z south).
    pub position_m: [f64; 3],
    /// Point the camera looks at, world metres.
    pub look_at_m: Option<[f64; 3]>,
    /// Heading, degrees clockwise from north, in [−360, 360] (0 when neither
    /// this nor `look_at_m` is given).
    pub yaw_deg: Option<f64>,
    /// Elevation of the view axis above the horizon, degrees, in [−89, 89].
    pub pitch_deg: Option<f64>,
    /// Vertical field of view, degrees, in [0.01, 179].
    pub fov_deg: f64,
    /// Exposure value at ISO 100; higher is darker. 15 suits a sunlit scene.
    /// Used when `auto_exposure` is false.
    pub exposure_ev100: f64,
    /// Meter the exposure from the image's average luminance (ISO 2720
    /// reflected-light calibration K = 12.5) instead of `exposure_ev100`.
    pub auto_exposure: bool,
    /// Added to the metered exposure, EV, in [−10, 10]; positive is brighter.
    pub exposure_compensation_ev: f64,
    /// Time constant of the adaptation of automatic exposure in animations, s, in [0, 60].
    pub adaptation_time_s: f64,
    /// How the view is projected onto the image.
    pub projection: Projection,
    /// Draw the air between the camera and what it sees (Hillaire 2020's
    /// aerial perspective: haze over distant terrain, the aureole of sunlit
    /// air in front of a back-lit cloud). `false` leaves it out while the sky
    /// itself stays as it is: what a path tracer whose sky is an environment
    /// map at infinity renders (the realism suite's references).
    pub aerial_perspective: bool,
}

/// Projection of the camera (`camera.projection`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum Projection {
    /// A pinhole: `fov_deg` vertically, aimed by `look_at_m` or `yaw_deg`/`pitch_deg`.
    #[default]
    Perspective,
    /// The full sphere around `position_m` as a latitude–longitude image
    /// (an HDRI): y up, longitude 0 (north, −Z) at the image's centre, east
    /// to its right, the zenith along the top edge (see
    /// `frame::equirectangular_direction`). The view direction and
    /// `fov_deg` are ignored. Drawn as six cube faces resampled.
    Equirectangular,
}

/// What lies under the clouds (`[ground]`): the procedural terrain of
/// `[terrain]`, or, for a program that draws its own world, a flat ground of
/// one albedo that nimbus does not draw but that still lights the clouds
/// from below (the stratus layer's ground–cloud radiosity, the ground light).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct GroundSettings {
    /// `true`: the terrain is drawn, lit, stops the rain and reflects light
    /// to the clouds. `false`: nothing is drawn; the ground is flat at
    /// `height_m` with `albedo`, and the rain stops only on `[[objects]]`
    /// and the caller's occluders (`Renderer::set_occluders`).
    pub terrain: bool,
    /// Linear albedo of the flat ground when `terrain = false`, each in [0, 1].
    pub albedo: [f64; 3],
    /// Height of the flat ground when `terrain = false`, m, in [−10000, 10000].
    pub height_m: f64,
    /// The flat ground's albedo as a map over the terrain's square
    /// (`terrain.extent_m` around the origin) instead of `albedo`: set in
    /// code (not a scene-file key), e.g. from the caller's own ground
    /// textures. At most 4096 texels a side, each channel in [0, 1].
    #[serde(skip)]
    pub albedo_map: Option<GroundAlbedoMap>,
}

/// A shared albedo map of the flat ground ([`GroundSettings::albedo_map`]).
/// Two are equal when they are the same map (the same `Arc`), so that
/// comparing scenes every frame costs nothing: give a new one to change it.
#[derive(Clone, Debug)]
pub struct GroundAlbedoMap(Arc<nimbus_physics::terrain::AlbedoMap>);

impl GroundAlbedoMap {
    /// Shares `map`.
    pub fn new(map: nimbus_physics::terrain::AlbedoMap) -> Self {
        Self(Arc::new(map))
    }

    /// The map.
    pub fn map(&self) -> &nimbus_physics::terrain::AlbedoMap {
        &self.0
    }
}

impl PartialEq for GroundAlbedoMap {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Default for GroundSettings {
    fn default() -> Self {
        Self {
            terrain: true,
            // A mixed land surface's broadband albedo (grass 0.15–0.25,
            // forest 0.1–0.15, soil 0.1–0.2: Oke, Boundary Layer Climates, 1987, table 1.1).
            albedo: [0.15, 0.15, 0.15],
            height_m: 0.0,
            albedo_map: None,
        }
    }
}

impl Default for CameraSettings {
    fn default() -> Self {
        Self {
            position_m: [0.0, 200.0, 0.0],
            look_at_m: None,
            yaw_deg: None,
            pitch_deg: None,
            fov_deg: 60.0,
            exposure_ev100: 14.5,
            auto_exposure: false,
            exposure_compensation_ev: 0.0,
            adaptation_time_s: 1.0,
            projection: Projection::Perspective,
            aerial_perspective: true,
        }
    }
}

/// The sun's position (`[sun]`): either by angles (`azimuth_deg`,
/// `elevation_deg`) or by date, time and place (`time_utc`, `latitude_deg`,
/// `longitude_deg`, computed with the NREL SPA), not both. Without either,
/// azimuth 200° and elevation 30°.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct SunSettings {
    /// Azimuth, degrees clockwise from north, in [0, 360].
    pub azimuth_deg: Option<f64>,
    /// Elevation above the horizon, degrees, in [−90, 90].
    pub elevation_deg: Option<f64>,
    /// Date and time, ISO 8601 with a zone, e.g. "2026-06-21T12:00:00Z".
    pub time_utc: Option<String>,
    /// Latitude of the scene, degrees north, in [−90, 90].
    pub latitude_deg: Option<f64>,
    /// Longitude of the scene, degrees east, in [−180, 180].
    pub longitude_deg: Option<f64>,
}

/// Sun angles used when a scene gives neither angles nor time and place.
pub const DEFAULT_SUN_ANGLES_DEG: (f64, f64) = (200.0, 30.0);

impl SunSettings {
    /// Azimuth (clockwise from north) and elevation without refraction,
    /// degrees. Assumes a validated scene: an unparsable time falls back to
    /// the default angles.
    pub fn angles_deg(&self) -> (f64, f64) {
        if let (Some(time), Some(lat), Some(lon)) =
            (&self.time_utc, self.latitude_deg, self.longitude_deg)
            && let Ok(t) = nimbus_physics::sky::UtcDateTime::parse(time)
        {
            let p = nimbus_physics::sky::solar_position(
                &t,
                &nimbus_physics::sky::Observer::at(lat, lon),
            );
            return (p.azimuth_deg, p.elevation_deg());
        }
        (
            self.azimuth_deg.unwrap_or(DEFAULT_SUN_ANGLES_DEG.0),
            self.elevation_deg.unwrap_or(DEFAULT_SUN_ANGLES_DEG.1),
        )
    }

    /// Unit vector towards the sun, world frame.
    pub fn direction(&self) -> [f64; 3] {
        let (azimuth, elevation) = self.angles_deg();
        nimbus_physics::sky::sun_direction(azimuth, elevation)
    }
}

/// Cumulus clouds (`[cumulus]`): a field of clouds placed from a coverage
/// (or listed in `clouds`), each an instance of a few generated shapes,
/// shaded after Bouthors (2004, ch. 5). See docs/cumulus.md.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct CumulusSettings {
    /// Fraction of the area under the clouds' footprints, in [0, 1].
    pub coverage: f64,
    /// Height of the cloud bases, m, in [0, 10000].
    pub base_m: f64,
    /// Random seed of the cloud field's placement.
    pub seed: u64,
    /// Side of the square area the clouds are placed over, centred on the
    /// world origin, m; the terrain's extent when absent.
    pub area_m: Option<f64>,
    /// Range of the clouds' scales, in [0.1, 5].
    pub scale_range: [f64; 2],
    /// Number of shape variants, in [1, 8] (the first is the paper's cloud).
    pub variants: u32,
    /// Random seed of the shapes.
    pub shape_seed: u64,
    /// Levels of detail per shape, in [1, 5].
    pub levels_of_detail: u32,
    /// Clouds placed by hand; when given, they replace the placement from `coverage`.
    pub clouds: Vec<PlacedCloud>,
    /// The shader's parameters.
    pub shading: CumulusShading,
    /// The shader's terms, each on or off.
    pub terms: ShadingTerms,
}

impl Default for CumulusSettings {
    fn default() -> Self {
        Self {
            coverage: 0.3,
            base_m: 1500.0,
            seed: 1,
            area_m: None,
            scale_range: [0.5, 1.0],
            variants: 3,
            shape_seed: 1,
            levels_of_detail: 3,
            clouds: Vec::new(),
            shading: CumulusShading::default(),
            terms: ShadingTerms::default(),
        }
    }
}

/// One cloud placed by hand (`[[cumulus.clouds]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct PlacedCloud {
    /// Centre of the cloud's base, world m.
    pub position_m: [f64; 3],
    /// Rotation about the vertical, degrees, in [−360, 360].
    #[serde(default)]
    pub yaw_deg: f64,
    /// Scale of the shape, in [0.1, 5].
    #[serde(default = "unit_scale")]
    pub scale: f64,
    /// Index of the shape variant, below `cumulus.variants`.
    #[serde(default)]
    pub variant: u32,
}

impl PlacedCloud {
    /// A cloud of the first shape variant with its base centred at
    /// `position_m`, unrotated and unscaled; set the other fields after.
    pub fn new(position_m: [f64; 3]) -> Self {
        Self {
            position_m,
            yaw_deg: 0.0,
            scale: unit_scale(),
            variant: 0,
        }
    }
}

fn unit_scale() -> f64 {
    1.0
}

/// A stratiform cloud layer (`[stratus]`), rendered after Bouthors et al.
/// (2006): a thickness field over many kilometres, shaded with the analytic
/// slab model and lit by the ground through radiosity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct StratusSettings {
    /// Height of the lowest cloud base, m, in [0, 15000]. The layer's
    /// mid-plane is at `base_m + thickness_m / 2`; each cell extends half its
    /// thickness above and below it.
    pub base_m: f64,
    /// Thickness of the thickest cells, m, in [1, 2000] (Bouthors 2006: up to 500).
    pub thickness_m: f64,
    /// Fraction of the sky covered, in [0, 1].
    pub coverage: f64,
    /// Horizontal size of the largest cells, m, in [100, 100000].
    pub feature_size_m: f64,
    /// Octaves of detail in the cells' shape, 1 to 8.
    pub detail: u32,
    /// Random seed of the pattern.
    pub seed: u32,
    /// Time over which the largest cells change shape while they drift, s, in [10, 1e6].
    pub evolution_time_s: f64,
    /// Effective droplet radius r_e, µm, in [1, 50] (modified gamma DSD, γ = 2).
    pub effective_radius_um: f64,
    /// Droplet number concentration N₀, cm⁻³, in [1, 5000].
    pub droplet_concentration_cm3: f64,
    /// Side of the square of layer drawn around the camera, m, in [1000, 400000].
    pub extent_m: f64,
    /// Texels (and grid vertices) per side of the thickness field, 16 to 2048.
    pub resolution: u32,
    /// Ground–cloud radiosity iterations (each one ground → cloud → ground),
    /// 0 to 32 (Bouthors 2006: 2 suffice over country, 8 over snow).
    pub radiosity_iterations: u32,
    /// How the layer is shaded: marched as a volume from every camera
    /// (`volume`, the default), its surface shaded as a slab with the
    /// paths the slab misses marched (`marched`), or the paper's slab
    /// (`bnl2006`).
    pub model: StratusShadingModel,
}

/// How the layer's surface is shaded (`stratus.model`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StratusShadingModel {
    /// Bouthors et al. (2006) with the paths the slab misses marched
    /// through the thickness field: the view ray's (the cells' sides, §8 of
    /// the paper) and the sun ray's (cells shading each other under a low
    /// sun); the diffuse light (orders 3+, sky and ground) leaving by the
    /// escape function rather than isotropically
    /// (`nimbus_physics::transport::stratus::DiffuseExit`). docs/stratus.md
    /// and docs/REALISM.md give the gain. The default before `volume`: it
    /// costs less (docs/PERFORMANCE.md) and stays nearer the reference on
    /// `stratus-sunset-plane`'s grazing sun (docs/REALISM.md).
    Marched,
    /// Bouthors et al. (2006) as published: every point of the surface a
    /// horizontal slab of the local thickness, lit and seen through it
    /// alone, to reproduce the paper's images.
    Bnl2006,
    /// The layer drawn as the volume it stands for from every camera, not
    /// only from inside a cell: each pixel's ray marched through the
    /// thickness field from where it first enters a cell, lit by the
    /// cells' diffusion light (the in-layer march of docs/stratus.md), so
    /// that thin rims are thin, cells shade each other and light entering
    /// their sunlit sides reaches the camera. docs/REALISM.md gives the
    /// gain and docs/PERFORMANCE.md the cost. The default: nearer the
    /// path-traced references than `marched` on every scene of the realism
    /// suite with a deck but the sunset seen from a plane (docs/REALISM.md,
    /// "The stratus layer as a volume by default").
    #[default]
    Volume,
}

impl Default for StratusSettings {
    fn default() -> Self {
        Self {
            base_m: 1000.0,
            thickness_m: 400.0,
            coverage: 0.7,
            feature_size_m: 3000.0,
            detail: 5,
            seed: 1,
            evolution_time_s: 1800.0,
            effective_radius_um: 7.0,
            droplet_concentration_cm3: 300.0,
            extent_m: 40_000.0,
            resolution: 512,
            radiosity_iterations: 3,
            model: StratusShadingModel::default(),
        }
    }
}

/// Uniform wind (`[wind]`): carries the cloud layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct WindSettings {
    /// Wind speed, m/s, in [0, 100].
    pub speed_m_s: f64,
    /// Direction the wind blows from, degrees clockwise from north, in [0, 360].
    pub from_deg: f64,
    /// Frozen turbulence carried by the wind (gusts felt by the rain).
    pub turbulence: Option<TurbulenceSettings>,
    /// A wind field read from a file, felt by the rain (instead of `turbulence`).
    pub field: Option<WindFieldSettings>,
    /// Local flow primitives (uniform jets, sources and sinks, vortices, gust fronts).
    pub primitives: Vec<WindPrimitiveSettings>,
    /// The horizontal distance (x, z), m, the air has moved at the frame's
    /// time when the wind is keyframed (set by [`Scene::at_time`]); `None`:
    /// velocity × time. Not a key of the file.
    #[serde(skip)]
    pub drift_m: Option<[f64; 2]>,
}

impl Default for WindSettings {
    fn default() -> Self {
        Self {
            speed_m_s: 5.0,
            from_deg: 270.0,
            turbulence: None,
            field: None,
            primitives: Vec::new(),
            drift_m: None,
        }
    }
}

impl WindSettings {
    /// The horizontal wind velocity (x east, z south), m/s: blowing from
    /// `from_deg` (clockwise from north, north = −z).
    pub fn velocity_xz_m_s(&self) -> [f64; 2] {
        let from = self.from_deg.to_radians();
        // The unit vector towards where the wind comes from is (sin, −cos);
        // the air moves the other way.
        [-self.speed_m_s * from.sin(), self.speed_m_s * from.cos()]
    }
}

impl Scene {
    /// Parses and validates a scene from TOML text; `file` names the source in errors.
    /// Relative paths in it resolve against the current directory.
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, SceneError> {
        Self::from_toml_str_in(text, file, None)
    }

    /// Like [`Self::from_toml_str`], with relative paths in the scene
    /// resolved against `base_dir` (see [`Scene::base_dir`]).
    pub fn from_toml_str_in(
        text: &str,
        file: &str,
        base_dir: Option<&Path>,
    ) -> Result<Self, SceneError> {
        let deserializer =
            toml::de::Deserializer::parse(text).map_err(|e| SceneError::syntax(file, text, &e))?;
        let mut scene: Scene = serde_path_to_error::deserialize(deserializer)
            .map_err(|e| SceneError::from_path_error(file, text, e))?;
        scene.check_array_lengths(text, file)?;
        // `Path::parent` of a bare file name is the empty path: the current directory.
        scene.base_dir = base_dir
            .filter(|d| !d.as_os_str().is_empty())
            .map(Path::to_path_buf);
        scene.validate(file)?;
        Ok(scene)
    }

    /// Reads, parses and validates a scene file (a regular file of at most
    /// [`MAX_SCENE_FILE_BYTES`]).
    pub fn from_file(path: &std::path::Path) -> Result<Self, SceneError> {
        let file = path.display().to_string();
        let text =
            nimbus_physics::io::read_text_bounded(path, MAX_SCENE_FILE_BYTES).map_err(|e| {
                SceneError::Io {
                    file: file.clone(),
                    message: e.to_string(),
                }
            })?;
        Self::from_toml_str_in(&text, &file, path.parent())
    }

    /// The embedded default scene.
    pub fn embedded_default() -> Self {
        // The embedded file is checked by a unit test, so this cannot fail in a release.
        Self::from_toml_str(DEFAULT_SCENE_TOML, "<default scene>").unwrap_or_default()
    }
}

/// What is known of a file the scene refers to without reading it: its
/// modification time and length. Passes that read such a file (glTF meshes,
/// wind fields) keep the stamps of what they read and read again when a
/// stamp changes, so that a file rewritten while the viewer runs shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FileStamp {
    modified: Option<std::time::SystemTime>,
    bytes: u64,
}

impl FileStamp {
    /// The stamp of the file at `path`; `None` when it cannot be read.
    pub fn of(path: &Path) -> Option<Self> {
        let metadata = std::fs::metadata(path).ok()?;
        Some(Self {
            modified: metadata.modified().ok(),
            bytes: metadata.len(),
        })
    }
}

/// The thickness field of a scene's stratus layer, carried by its wind
/// (the CPU twin of `field.wgsl`; the rain zones read it too).
pub fn cloud_layer_field(scene: &Scene, settings: &StratusSettings) -> CloudLayerField {
    let wind = scene
        .wind
        .as_ref()
        .map_or([0.0, 0.0], |w| w.velocity_xz_m_s());
    CloudLayerField {
        max_thickness_m: settings.thickness_m,
        coverage: settings.coverage,
        feature_size_m: settings.feature_size_m,
        octaves: settings.detail,
        seed: settings.seed,
        wind_velocity_m_s: wind,
        evolution_time_s: settings.evolution_time_s,
    }
}

#[cfg(test)]
mod tests;
