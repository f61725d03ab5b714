//! nimbus's sky, clouds and rain in a Bevy game.
//!
//! Add [`NimbusPlugin`], put the weather in the [`NimbusWeather`] resource
//! (nimbus's scene settings: sun or date and place, stratus, cumulus, wind,
//! rain, keyframes; edits apply the next frame), mark one 3D camera with
//! [`NimbusCamera`] and one directional light with [`NimbusSun`]:
//!
//! ```no_run
//! use bevy::prelude::*;
//! use nimbus_bevy::{NimbusCamera, NimbusPlugin, NimbusSun, NimbusWeather};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, NimbusPlugin::default()))
//!     .insert_resource(NimbusWeather::default())
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn((Camera3d::default(), NimbusCamera, Transform::from_xyz(0.0, 2.0, 10.0)));
//!         commands.spawn(NimbusSun::default());
//!     })
//!     .run();
//! ```
//!
//! What the plugin does each frame:
//!
//! - the sun of the weather (after the atmosphere: direction, illuminance
//!   and colour) drives the [`NimbusSun`]'s `DirectionalLight` and Bevy's
//!   `GlobalAmbientLight` (the clear sky's irradiance), so Bevy's PBR
//!   meshes are lit as nimbus lights its sky ([`sun`]);
//! - nimbus's clouds shadow the Bevy meshes: their transmittance of the
//!   sun, baked each frame through nimbus's lighting include into the
//!   [`NimbusSun`]'s light texture ([`cloud_shadows`]);
//! - the Bevy meshes stop nimbus's rain (their triangles become nimbus's
//!   occluders; [`NoRainOcclusion`] leaves a mesh out) ([`occluders`]);
//! - in the camera's `Core3d` schedule, nimbus's lighting step (atmosphere
//!   lookups, cloud shadow map, rain simulation) runs between the prepass
//!   and the main pass, and sky, cumulus, stratus, rain and mist are
//!   composited into the camera's HDR target by Bevy's depth after the
//!   opaque pass and before the transparent one ([`render`]).
//!
//! nimbus's own terrain is off by default (the game has its ground):
//! [`NimbusWeather::default`] sets `ground.terrain = false`.
//!
//! Unsupported, each said once in the log and never drawn wrong: MSAA on
//! the nimbus camera (the plugin turns it off when [`NimbusCamera`] is
//! added; turned back on, nimbus stops drawing with an error), more than one
//! [`NimbusCamera`] (only the one of lowest `order` gets the weather, a
//! warning names the others), a camera without `Hdr` (required by
//! [`NimbusCamera`]), orthographic projections, and cloud shadows on a
//! device without binding arrays (Bevy's light textures need them; see
//! [`cloud_shadows`]). See docs/bevy.md.

pub mod cloud_shadows;
pub mod demo;
pub mod occluders;
pub mod render;
pub mod sun;

use bevy::app::{App, Plugin, PostUpdate};
use bevy::camera::{Camera3d, Exposure, Hdr};
use bevy::ecs::prelude::*;
use bevy::log::info;
use bevy::render::render_resource::TextureUsages;
use bevy::render::view::Msaa;
use bevy::time::Time;
use bevy::transform::TransformSystems;
use nimbus_render::{Precompute, Scene, SceneError};

pub use cloud_shadows::{NimbusCloudShadowTexture, NimbusCloudShadows};
pub use nimbus_render;
pub use occluders::{NimbusOccluders, NoRainOcclusion};
pub use sun::{NimbusSun, SunLight};

/// nimbus in a Bevy app: the weather's sun on Bevy's directional light,
/// the sky, clouds, rain and air composited into the [`NimbusCamera`]'s
/// HDR target, Bevy's meshes stopping the rain.
#[derive(Clone, Debug)]
pub struct NimbusPlugin {
    /// Where nimbus's precomputation (cumulus shapes, optics tables) runs:
    /// on worker threads (the default: frames never wait, the clouds
    /// appear when ready) or inside the frame (every frame complete; for
    /// tests and offline renders).
    pub precompute: Precompute,
    /// Write per-pass GPU timestamps (the [`NimbusPassTimes`] resource of
    /// the render world) where the device supports them.
    pub timestamps: bool,
}

impl Default for NimbusPlugin {
    fn default() -> Self {
        Self {
            precompute: Precompute::Background,
            timestamps: false,
        }
    }
}

pub use render::NimbusPassTimes;

/// System sets of the main world's `PostUpdate`, in this order.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NimbusSystems {
    /// The weather at this frame's time ([`NimbusFrame`]); before transform
    /// propagation.
    Weather,
    /// The sun's directional light, the ambient light, and the tile of
    /// the sun's cloud shadow texture around the camera; before transform
    /// propagation.
    Sun,
    /// The meshes' triangles for the rain; after transform propagation.
    Occluders,
}

impl Plugin for NimbusPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<NimbusWeather>()
            .init_resource::<NimbusFrame>()
            .init_resource::<NimbusOccluders>()
            .init_resource::<sun::SunState>()
            .init_resource::<NimbusCloudShadows>()
            .configure_sets(
                PostUpdate,
                (NimbusSystems::Weather, NimbusSystems::Sun)
                    .chain()
                    .before(TransformSystems::Propagate),
            )
            .configure_sets(
                PostUpdate,
                NimbusSystems::Occluders.after(TransformSystems::Propagate),
            )
            .add_systems(
                PostUpdate,
                (
                    (configure_cameras, update_frame)
                        .chain()
                        .in_set(NimbusSystems::Weather),
                    (sun::drive_sun, cloud_shadows::place_cloud_shadows)
                        .chain()
                        .in_set(NimbusSystems::Sun),
                    occluders::gather_occluders.in_set(NimbusSystems::Occluders),
                ),
            );
        render::build(app, self);
    }

    fn finish(&self, app: &mut App) {
        // The light texture is an image asset (Bevy's ImagePlugin is in by now).
        if app
            .world()
            .contains_resource::<bevy::asset::Assets<bevy::image::Image>>()
        {
            app.init_resource::<NimbusCloudShadowTexture>();
        } else {
            app.world_mut().resource_mut::<NimbusCloudShadows>().enabled = false;
        }
        render::finish(app, self);
    }
}

/// The weather: nimbus's scene settings, in a resource. Every key of a
/// nimbus scene file is here (`scene.sun`, `scene.stratus`,
/// `scene.cumulus`, `scene.wind`, `scene.rain`, `scene.keyframes`, ...);
/// change them and the next frame shows it. The scene's camera is not used
/// (the [`NimbusCamera`]'s pose and projection are), except its
/// `aerial_perspective` switch and its height for the sun's light.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct NimbusWeather {
    /// nimbus's scene settings (see docs/scene-file.md).
    pub scene: Scene,
    /// The weather's clock, seconds: the time of the keyframes and of the
    /// clouds' drift. `None`: Bevy's `Time::elapsed`.
    pub time_s: Option<f64>,
}

/// The weather of [`NimbusWeather::default`]: the sun 35° up in the
/// south-west, fair-weather cumulus, a thin broken stratus layer, a light
/// breeze, no rain; no terrain of nimbus's (the game's ground stands in).
pub const DEFAULT_WEATHER_TOML: &str = r#"
[camera]
position_m = [0.0, 2.0, 0.0]

[sun]
azimuth_deg = 215.0
elevation_deg = 35.0

[ground]
terrain = false

[stratus]
base_m = 1800.0
thickness_m = 250.0
coverage = 0.25

[cumulus]
coverage = 0.2
base_m = 700.0

[wind]
speed_m_s = 5.0
from_deg = 250.0
"#;

impl Default for NimbusWeather {
    /// [`DEFAULT_WEATHER_TOML`].
    fn default() -> Self {
        // The text is the crate's own and is checked by its tests.
        Self::from_toml(DEFAULT_WEATHER_TOML, "NimbusWeather::default")
            .unwrap_or_else(|e| unreachable!("the default weather: {e}"))
    }
}

impl NimbusWeather {
    /// The weather of a nimbus scene file's text (`file` names it in
    /// errors), with its terrain off unless the text sets
    /// `[ground] terrain = true`. Errors are nimbus's one-line scene errors.
    pub fn from_toml(text: &str, file: &str) -> Result<Self, SceneError> {
        let mut scene = Scene::from_toml_str(text, file)?;
        if !text_sets_terrain(text) {
            scene.ground.terrain = false;
        }
        Ok(Self {
            scene,
            time_s: None,
        })
    }
}

/// Whether a scene file's text sets `ground.terrain` itself.
fn text_sets_terrain(text: &str) -> bool {
    text.parse::<toml::Table>().is_ok_and(|table| {
        table
            .get("ground")
            .and_then(|ground| ground.get("terrain"))
            .is_some()
    })
}

/// Marks the camera nimbus draws on: sky, clouds, rain and air go into its
/// HDR target by its depth. Requires `Hdr`; turns the camera's MSAA off,
/// makes its depth texture readable and, unless it has an `Exposure` of its
/// own, gives it [`DAYLIGHT_EXPOSURE`] when added. One per app.
#[derive(Component, Clone, Copy, Debug, Default)]
#[require(Camera3d, Hdr)]
pub struct NimbusCamera;

/// The weather at this frame's time: [`NimbusWeather`]'s scene with its
/// keyframes applied ([`Scene::at_time`]), the time, and the camera's
/// height. Read it rather than the resource to see what is drawn.
#[derive(Resource, Clone, Debug, Default)]
pub struct NimbusFrame {
    /// The scene at `time_s`, keyframes applied.
    pub scene: Option<Scene>,
    /// The weather's clock, seconds.
    pub time_s: f64,
}

/// The exposure a [`NimbusCamera`] gets when it has none of its own (or
/// Bevy's default, EV100 9.7, made for indoor scenes, which washes a
/// daylight sky out to white): EV100 14, daylight under some cloud.
pub const DAYLIGHT_EXPOSURE: Exposure = Exposure { ev100: 14.0 };

/// Cameras that have just become [`NimbusCamera`]s.
type NewCameraQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static mut Camera3d,
        Option<&'static Msaa>,
        Option<&'static Exposure>,
    ),
    Added<NimbusCamera>,
>;

/// Turns MSAA off, adds `TEXTURE_BINDING` to the depth texture's usages
/// (nimbus reads Bevy's depth) and gives a daylight exposure where the
/// camera has Bevy's default, for each camera that becomes a [`NimbusCamera`].
fn configure_cameras(mut commands: Commands, mut cameras: NewCameraQuery) {
    for (entity, mut camera, msaa, exposure) in &mut cameras {
        if exposure.is_none_or(|e| e.ev100 == Exposure::default().ev100) {
            info!(
                "nimbus: camera {entity}: exposure EV100 {} for daylight (Bevy's default, {}, is \
                 for indoor scenes; give the camera an Exposure to keep yours)",
                DAYLIGHT_EXPOSURE.ev100,
                Exposure::default().ev100
            );
            commands.entity(entity).insert(DAYLIGHT_EXPOSURE);
        }
        camera.depth_texture_usages.0 |= TextureUsages::TEXTURE_BINDING.bits();
        if msaa != Some(&Msaa::Off) {
            info!(
                "nimbus: camera {entity}: MSAA turned off (nimbus composites by a single-sample depth)"
            );
            commands.entity(entity).insert(Msaa::Off);
        }
    }
}

/// [`NimbusFrame`] from [`NimbusWeather`] and the clock.
fn update_frame(weather: Res<NimbusWeather>, time: Res<Time>, mut frame: ResMut<NimbusFrame>) {
    let time_s = weather
        .time_s
        .unwrap_or_else(|| time.elapsed_secs_f64())
        .clamp(0.0, 1e7);
    let keyframed = !weather.scene.keyframes.is_empty();
    if !weather.is_changed() && !keyframed && frame.scene.is_some() {
        frame.bypass_change_detection().time_s = time_s;
        return;
    }
    let scene = if keyframed {
        weather.scene.at_time(time_s)
    } else {
        weather.scene.clone()
    };
    if frame.scene.as_ref() != Some(&scene) {
        frame.scene = Some(scene);
    }
    frame.bypass_change_detection().time_s = time_s;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in weathers parse, keep nimbus's terrain off, and a scene
    /// text that asks for the terrain keeps it.
    #[test]
    fn weathers_parse_without_terrain() {
        let default = NimbusWeather::default();
        assert!(!default.scene.ground.terrain);
        assert!(default.scene.cumulus.is_some());
        let demo = demo::weather();
        assert!(!demo.scene.ground.terrain);
        assert_eq!(demo.scene.keyframes.len(), 4);
        let plain = NimbusWeather::from_toml(
            "[sun]\nazimuth_deg = 90.0\nelevation_deg = 10.0\n",
            "t.toml",
        )
        .expect("angles given");
        assert!(!plain.scene.ground.terrain);
        let with =
            NimbusWeather::from_toml("[ground]\nterrain = true\n", "t.toml").expect("terrain on");
        assert!(with.scene.ground.terrain);
        let bad = NimbusWeather::from_toml(
            "[sun]\nazimuth_deg = 90.0\nelevation_deg = 100.0\n",
            "bad.toml",
        )
        .expect_err("elevation 100°");
        assert!(bad.to_string().contains("bad.toml"), "{bad}");
    }
}
