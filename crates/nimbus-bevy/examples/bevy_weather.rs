//! A small Bevy world under nimbus's sky: a ground, a few buildings, a
//! shelter and a tree of boxes, with cumulus, a stratus deck rolling in and
//! rain starting after 20 s.
//!
//! Run: `cargo run --release -p nimbus-bevy --example bevy_weather`
//! (an X11 display; XWayland under Wayland).
//!
//! Keys: drag the mouse to look, W A S D to move, Q E down and up (Shift:
//! faster); 1 clear, 2 cumulus, 3 overcast and rain, 4 the scripted
//! weather again; T and G move the sun (time of day) forwards and back;
//! P prints nimbus's per-pass GPU times.

use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use nimbus_bevy::{NimbusCamera, NimbusFrame, NimbusPassTimes, NimbusPlugin, NimbusWeather, demo};

fn main() {
    App::new()
        .add_plugins((
            DefaultPlugins.set(WindowPlugin {
                primary_window: Some(Window {
                    title: "nimbus in Bevy".into(),
                    resolution: (1280, 720).into(),
                    ..default()
                }),
                ..default()
            }),
            NimbusPlugin {
                timestamps: true,
                ..default()
            },
        ))
        .insert_resource(demo::weather())
        .add_systems(Startup, setup)
        .add_systems(Update, (fly_camera, weather_keys))
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    demo::spawn_world(&mut commands, &mut meshes, &mut materials);
    info!("nimbus: drag to look, WASD QE to fly, 1-4 weather, T/G time of day, P pass times");
}

/// A fly camera: the mouse (left button held) turns it, W A S D Q E move it.
fn fly_camera(
    time: Res<Time>,
    keys: Res<ButtonInput<KeyCode>>,
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    mut cameras: Query<&mut Transform, With<NimbusCamera>>,
) {
    let Ok(mut transform) = cameras.single_mut() else {
        return;
    };
    if buttons.pressed(MouseButton::Left) && motion.delta != Vec2::ZERO {
        let (yaw, pitch, _) = transform.rotation.to_euler(EulerRot::YXZ);
        let yaw = yaw - motion.delta.x * 0.003;
        let pitch = (pitch - motion.delta.y * 0.003).clamp(-1.5, 1.5);
        transform.rotation = Quat::from_euler(EulerRot::YXZ, yaw, pitch, 0.0);
    }
    let mut step = Vec3::ZERO;
    for (key, direction) in [
        (KeyCode::KeyW, transform.forward().as_vec3()),
        (KeyCode::KeyS, transform.back().as_vec3()),
        (KeyCode::KeyA, transform.left().as_vec3()),
        (KeyCode::KeyD, transform.right().as_vec3()),
        (KeyCode::KeyE, Vec3::Y),
        (KeyCode::KeyQ, Vec3::NEG_Y),
    ] {
        if keys.pressed(key) {
            step += direction;
        }
    }
    let speed = if keys.pressed(KeyCode::ShiftLeft) {
        60.0
    } else {
        8.0
    };
    transform.translation += step.normalize_or_zero() * speed * time.delta_secs();
    transform.translation.y = transform.translation.y.max(0.3);
}

/// 1–4 pick the weather, T/G move the sun, P prints the pass times.
fn weather_keys(
    keys: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    frame: Res<NimbusFrame>,
    times: Res<NimbusPassTimes>,
    mut weather: ResMut<NimbusWeather>,
) {
    if keys.just_pressed(KeyCode::Digit4) {
        *weather = demo::weather();
        return;
    }
    // The other keys edit the weather as it is now, without its script.
    let now = || {
        let mut scene = frame.scene.clone().unwrap_or_else(|| weather.scene.clone());
        scene.keyframes.clear();
        scene
    };
    let mut edited = None;
    if keys.just_pressed(KeyCode::Digit1) {
        let mut scene = now();
        scene.cumulus = None;
        scene.stratus = None;
        if let Some(rain) = &mut scene.rain {
            rain.intensity_mm_h = 0.0;
        }
        edited = Some(scene);
    }
    if keys.just_pressed(KeyCode::Digit2) {
        let mut scene = now();
        scene.cumulus = demo::weather().scene.cumulus;
        scene.stratus = None;
        if let Some(rain) = &mut scene.rain {
            rain.intensity_mm_h = 0.0;
        }
        edited = Some(scene);
    }
    if keys.just_pressed(KeyCode::Digit3) {
        let mut scene = now();
        if let Some(stratus) = &mut scene.stratus {
            stratus.coverage = 0.9;
        } else {
            scene.stratus = demo::weather().scene.stratus;
        }
        if let Some(rain) = &mut scene.rain {
            rain.intensity_mm_h = 8.0;
        }
        edited = Some(scene);
    }
    let sun_step = if keys.pressed(KeyCode::KeyT) {
        1.0
    } else if keys.pressed(KeyCode::KeyG) {
        -1.0
    } else {
        0.0
    };
    if sun_step != 0.0 {
        let mut scene = edited.take().unwrap_or_else(now);
        // Along the sun's daily path, roughly: 20° of azimuth per 10° of elevation.
        let (azimuth, elevation) = scene.sun.angles_deg();
        let rate = 10.0 * time.delta_secs_f64();
        scene.sun.time_utc = None;
        scene.sun.azimuth_deg = Some((azimuth + 2.0 * rate * sun_step).rem_euclid(360.0));
        scene.sun.elevation_deg = Some((elevation - rate * sun_step).clamp(-10.0, 89.0));
        edited = Some(scene);
    }
    if let Some(scene) = edited {
        weather.scene = scene;
    }
    if keys.just_pressed(KeyCode::KeyP) {
        let list = times.latest();
        if list.is_empty() {
            info!("nimbus: no pass times (the device has no timestamp queries)");
        }
        for (pass, ms) in list {
            info!("nimbus pass {pass}: {ms:.3} ms");
        }
    }
}
