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
//!
//! Measuring and pictures (docs/bevy.md): `--frames N` runs N frames of the
//! scripted weather from 45 s in and exits, printing the mean per-pass GPU
//! times and frame time of the last half; `--screenshot PATH` saves the
//! window's last frame as a PNG.

use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use nimbus_bevy::{NimbusCamera, NimbusFrame, NimbusPassTimes, NimbusPlugin, NimbusWeather, demo};
use std::collections::BTreeMap;
use std::time::Instant;

/// `--frames N` and `--screenshot PATH`.
#[derive(Resource, Clone, Debug, Default)]
struct Measure {
    frames: Option<u32>,
    screenshot: Option<String>,
}

impl Measure {
    fn from_args() -> Result<Self, String> {
        let mut measure = Self::default();
        let mut args = std::env::args().skip(1);
        while let Some(arg) = args.next() {
            match arg.as_str() {
                "--frames" => {
                    let value = args.next().ok_or("--frames: give a number of frames")?;
                    let frames = value
                        .parse::<u32>()
                        .ok()
                        .filter(|n| (2..=100_000).contains(n))
                        .ok_or(format!(
                            "--frames {value}: must be a whole number from 2 to 100000"
                        ))?;
                    measure.frames = Some(frames);
                }
                "--screenshot" => {
                    let path = args.next().ok_or("--screenshot: give a PNG path")?;
                    if !path.to_lowercase().ends_with(".png") {
                        return Err(format!("--screenshot {path}: must end in .png"));
                    }
                    measure.screenshot = Some(path);
                }
                other => {
                    return Err(format!(
                        "{other}: unknown argument (--frames N, --screenshot PATH)"
                    ));
                }
            }
        }
        if measure.screenshot.is_some() && measure.frames.is_none() {
            measure.frames = Some(30);
        }
        Ok(measure)
    }
}

fn main() -> AppExit {
    let measure = match Measure::from_args() {
        Ok(m) => m,
        Err(e) => {
            eprintln!("bevy_weather: {e}");
            return AppExit::from_code(2);
        }
    };
    let mut weather = demo::weather();
    if measure.frames.is_some() {
        // The scripted weather 45 s in, at 30 frames a second.
        weather.time_s = Some(45.0);
    }
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
        .insert_resource(weather)
        .insert_resource(measure)
        .add_systems(Startup, setup)
        .add_systems(Update, (fly_camera, weather_keys, measure_frames))
        .run()
}

/// With `--frames`: advances the weather's clock, sums the pass times of
/// the last half of the frames, takes the screenshot and exits.
#[allow(clippy::too_many_arguments)]
fn measure_frames(
    mut commands: Commands,
    measure: Res<Measure>,
    times: Res<NimbusPassTimes>,
    mut weather: ResMut<NimbusWeather>,
    mut frame: Local<u32>,
    mut sums: Local<BTreeMap<&'static str, (f64, u32)>>,
    mut started: Local<Option<Instant>>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(frames) = measure.frames else {
        return;
    };
    *frame += 1;
    weather.time_s = Some(45.0 + f64::from(*frame) / 30.0);
    if *frame == frames / 2 {
        *started = Some(Instant::now());
    }
    if *frame > frames / 2 {
        for (pass, ms) in times.latest() {
            let entry = sums.entry(pass).or_default();
            entry.0 += ms;
            entry.1 += 1;
        }
    }
    if *frame == frames
        && let Some(path) = measure.screenshot.clone()
    {
        commands
            .spawn(Screenshot::primary_window())
            .observe(move |captured: On<ScreenshotCaptured>| save_png(&captured.image, &path));
    }
    if *frame == frames + 3 {
        let measured = frames - frames / 2;
        if let Some(start) = *started {
            let ms = start.elapsed().as_secs_f64() * 1000.0 / f64::from(measured);
            println!("frame (wall clock, whole app): {ms:.1} ms over {measured} frames");
        }
        let mut total = 0.0;
        for (pass, (sum, n)) in sums.iter() {
            let mean = sum / f64::from(*n);
            total += mean;
            println!("nimbus pass {pass}: {mean:.3} ms");
        }
        if sums.is_empty() {
            println!("no pass times (the device has no timestamp queries)");
        } else {
            println!("nimbus passes in all: {total:.3} ms");
        }
        exit.write(AppExit::Success);
    }
}

/// Writes a captured window image (8-bit, BGRA or RGBA) as a PNG.
fn save_png(image: &Image, path: &str) {
    use bevy::render::render_resource::TextureFormat;
    let (Some(data), size) = (&image.data, image.size()) else {
        error!("screenshot: no pixels");
        return;
    };
    let rgba: Vec<u8> = match image.texture_descriptor.format {
        TextureFormat::Bgra8Unorm | TextureFormat::Bgra8UnormSrgb => data
            .chunks(4)
            .flat_map(|p| [p[2], p[1], p[0], 255])
            .collect(),
        TextureFormat::Rgba8Unorm | TextureFormat::Rgba8UnormSrgb => data
            .chunks(4)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        other => {
            error!("screenshot: format {other:?} not written");
            return;
        }
    };
    match image::save_buffer(path, &rgba, size.x, size.y, image::ExtendedColorType::Rgba8) {
        Ok(()) => println!("wrote {path} ({}×{})", size.x, size.y),
        Err(e) => error!("screenshot {path}: {e}"),
    }
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
