//! The world of the `bevy_weather` example and of the crate's golden test:
//! a ground, a few buildings, a shelter's roof on posts and a tree of
//! boxes, under cumulus, a stratus deck rolling in and rain starting.

use crate::{NimbusCamera, NimbusSun, NimbusWeather};
use bevy::asset::{Assets, Handle};
use bevy::camera::Camera3d;
use bevy::color::Color;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::ecs::prelude::*;
use bevy::math::Vec3;
use bevy::math::primitives::{Cuboid, Plane3d};
use bevy::mesh::{Mesh, Mesh3d, Meshable};
use bevy::pbr::{MeshMaterial3d, StandardMaterial};
use bevy::transform::components::Transform;

/// The weather of the example: the sun 35° up in the south-west, fair
/// weather cumulus over the town, a stratus deck rolling in over the first
/// minute (coverage 0.15 → 0.75) and rain starting after 20 s (0 → 8 mm/h
/// by 40 s), on a westerly wind. nimbus's terrain is off: the example's
/// ground stands in.
pub const WEATHER_TOML: &str = r#"
[camera]
position_m = [0.0, 2.0, 0.0]
aerial_perspective = true

[sun]
azimuth_deg = 215.0
elevation_deg = 35.0

[ground]
terrain = false
albedo = [0.10, 0.12, 0.07]

[stratus]
base_m = 1500.0
thickness_m = 300.0
coverage = 0.15
feature_size_m = 3000.0
seed = 5

[cumulus]
coverage = 0.3
base_m = 600.0
seed = 11

[wind]
speed_m_s = 6.0
from_deg = 250.0

[rain]
intensity_mm_h = 0.0
box_radius_m = 20.0

[[keyframes]]
time_s = 0.0
stratus_coverage = 0.15
rain_intensity_mm_h = 0.0

[[keyframes]]
time_s = 20.0
rain_intensity_mm_h = 0.0

[[keyframes]]
time_s = 40.0
rain_intensity_mm_h = 8.0

[[keyframes]]
time_s = 60.0
stratus_coverage = 0.75
rain_intensity_mm_h = 8.0
"#;

/// The example's weather ([`WEATHER_TOML`]).
pub fn weather() -> NimbusWeather {
    // The text is the crate's own and is checked by the tests.
    NimbusWeather::from_toml(WEATHER_TOML, "bevy_weather.toml")
        .unwrap_or_else(|e| unreachable!("the example's weather: {e}"))
}

/// The shelter's roof, world metres: x and z extent, height of its underside.
pub const ROOF_MIN: Vec3 = Vec3::new(-12.0, 3.0, 10.0);
/// The roof's far corner (its top at y = 3.2 m).
pub const ROOF_MAX: Vec3 = Vec3::new(-6.0, 3.2, 14.0);

/// The camera's default pose: standing 2 m up, looking at the town.
pub fn camera_transform() -> Transform {
    Transform::from_xyz(-4.0, 2.0, 22.0).looking_at(Vec3::new(4.0, 8.0, -20.0), Vec3::Y)
}

/// The camera bundle: nimbus's camera, ACES tone mapping (no LUT needed),
/// a daylight exposure.
pub fn camera() -> impl Bundle {
    (
        Camera3d::default(),
        NimbusCamera,
        Tonemapping::AcesFitted,
        crate::DAYLIGHT_EXPOSURE,
        camera_transform(),
    )
}

/// Spawns the world: ground, buildings, the shelter, the tree, the sun and
/// the camera.
pub fn spawn_world(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
) {
    let mut material = |r: f32, g: f32, b: f32| {
        materials.add(StandardMaterial {
            base_color: Color::linear_rgb(r, g, b),
            perceptual_roughness: 0.9,
            reflectance: 0.3,
            ..Default::default()
        })
    };
    let grass = material(0.10, 0.12, 0.07);
    let stone = material(0.55, 0.52, 0.48);
    let brick = material(0.45, 0.20, 0.15);
    let concrete = material(0.60, 0.60, 0.62);
    let wood = material(0.30, 0.25, 0.22);
    let bark = material(0.20, 0.13, 0.08);
    let leaves = material(0.05, 0.14, 0.04);

    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(4000.0, 4000.0))),
        MeshMaterial3d(grass),
        Transform::IDENTITY,
    ));
    let mut block =
        |commands: &mut Commands, min: Vec3, size: Vec3, material: Handle<StandardMaterial>| {
            commands.spawn((
                Mesh3d(meshes.add(Cuboid::from_size(size))),
                MeshMaterial3d(material),
                Transform::from_translation(min + size / 2.0),
            ));
        };
    // Buildings.
    block(
        commands,
        Vec3::new(-8.0, 0.0, -14.0),
        Vec3::new(4.0, 6.0, 4.0),
        stone,
    );
    block(
        commands,
        Vec3::new(6.0, 0.0, -24.0),
        Vec3::new(5.0, 10.0, 5.0),
        brick,
    );
    block(
        commands,
        Vec3::new(20.0, 0.0, -50.0),
        Vec3::new(8.0, 24.0, 8.0),
        concrete,
    );
    // The shelter: a roof on four posts.
    block(commands, ROOF_MIN, ROOF_MAX - ROOF_MIN, wood.clone());
    for (x, z) in [(-12.0, 10.0), (-6.3, 10.0), (-12.0, 13.7), (-6.3, 13.7)] {
        block(
            commands,
            Vec3::new(x, 0.0, z),
            Vec3::new(0.3, 3.0, 0.3),
            wood.clone(),
        );
    }
    // A tree of boxes.
    block(
        commands,
        Vec3::new(10.0, 0.0, -4.0),
        Vec3::new(0.6, 4.0, 0.6),
        bark,
    );
    block(
        commands,
        Vec3::new(8.3, 3.5, -5.7),
        Vec3::new(4.0, 2.5, 4.0),
        leaves.clone(),
    );
    block(
        commands,
        Vec3::new(9.0, 5.8, -5.0),
        Vec3::new(2.6, 1.6, 2.6),
        leaves,
    );

    commands.spawn(NimbusSun::default());
    commands.spawn(camera());
}
