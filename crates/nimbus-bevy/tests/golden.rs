//! The example's world rendered by Bevy with nimbus, headless, on whatever
//! adapter is present (software Vulkan, lavapipe, on machines without a
//! GPU): Bevy driven from outside (`App::update`, no window, no pipelined
//! rendering) with synchronous pipeline compilation, into an image read
//! back from Bevy's render world.
//!
//! Asserted: the golden image; that Bevy's meshes hide the clouds behind
//! them (the tall building's pixels are the same with and without clouds
//! while the sky above it is not); that no rain falls under the shelter's
//! roof, a Bevy mesh (nimbus's drops read back), while it rains beside it;
//! that nimbus's clouds shadow Bevy's meshes (the sun's light texture,
//! read back, holds the cumulus' shadows; under an overcast the sunlit
//! ground and tower darken, and they come back when the shadows are off).

use bevy::app::PluginsState;
use bevy::asset::RenderAssetUsages;
use bevy::camera::{CameraProjection, PerspectiveProjection, RenderTarget};
use bevy::image::Image;
use bevy::log::LogPlugin;
use bevy::prelude::*;
use bevy::render::pipelined_rendering::PipelinedRenderingPlugin;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::texture::GpuImage;
use bevy::render::{RenderApp, RenderPlugin};
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;
use nimbus_bevy::cloud_shadows::CLOUD_SHADOW_TEXELS;
use nimbus_bevy::render::NimbusRenderer;
use nimbus_bevy::{
    NimbusCamera, NimbusCloudShadowTexture, NimbusCloudShadows, NimbusPlugin, NimbusWeather, demo,
};
use nimbus_render::Precompute;
use nimbus_render::headless::GoldenDifference;
use nimbus_render::rain::DropGpu;
use std::path::PathBuf;

const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;

/// The app: Bevy's default plugins without a window, the event loop or
/// pipelined rendering, pipelines compiled synchronously, nimbus with
/// its precomputation inside the frame.
fn app() -> (App, Handle<Image>) {
    // A clear failure where there is no adapter (Bevy's own is a panic
    // deep in its renderer's start).
    if let Err(e) = nimbus_render::GpuContext::new(nimbus_render::AdapterPreference::Auto) {
        panic!("the Bevy golden test needs a GPU adapter: {e}");
    }
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                close_when_requested: false,
                ..default()
            })
            .set(RenderPlugin {
                synchronous_pipeline_compilation: true,
                ..default()
            })
            .disable::<WinitPlugin>()
            .disable::<PipelinedRenderingPlugin>()
            .disable::<LogPlugin>(),
        NimbusPlugin {
            precompute: Precompute::Blocking,
            timestamps: false,
        },
    ));
    let mut weather = demo::weather();
    // Little wind: the dry ground under the roof is then right under it.
    if let Some(wind) = &mut weather.scene.wind {
        wind.speed_m_s = 1.0;
    }
    // Enough drops to count, few enough for a software rasteriser.
    if let Some(rain) = &mut weather.scene.rain {
        rain.max_drops = 300_000;
    }
    weather.time_s = Some(45.0);
    app.insert_resource(weather);

    let mut image = Image::new_fill(
        Extent3d {
            width: WIDTH,
            height: HEIGHT,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        &[0, 0, 0, 255],
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    );
    image.texture_descriptor.usage =
        TextureUsages::TEXTURE_BINDING | TextureUsages::COPY_SRC | TextureUsages::RENDER_ATTACHMENT;
    let handle = app.world_mut().resource_mut::<Assets<Image>>().add(image);
    let target = handle.clone();
    app.add_systems(
        Startup,
        move |mut commands: Commands,
              mut meshes: ResMut<Assets<Mesh>>,
              mut materials: ResMut<Assets<StandardMaterial>>| {
            demo::spawn_world(&mut commands, &mut meshes, &mut materials);
            // The example's camera, into the image.
            commands.queue({
                let target = target.clone();
                move |world: &mut World| {
                    let mut cameras = world.query_filtered::<Entity, With<NimbusCamera>>();
                    let cameras: Vec<Entity> = cameras.iter(world).collect();
                    for camera in cameras {
                        world
                            .entity_mut(camera)
                            .insert(RenderTarget::Image(target.clone().into()));
                    }
                }
            });
        },
    );
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    app.finish();
    app.cleanup();
    (app, handle)
}

/// Runs `frames` frames, the weather's clock moving at 30 frames a second
/// from `start_s`.
fn run(app: &mut App, start_s: f64, frames: u32) {
    for frame in 0..frames {
        app.world_mut().resource_mut::<NimbusWeather>().time_s =
            Some(start_s + f64::from(frame) / 30.0);
        app.update();
    }
}

/// The texels of an image asset of `width` × `height` and `texel_bytes`
/// a texel, rows packed, read back from the render world.
fn read_texels(
    app: &mut App,
    handle: &Handle<Image>,
    width: u32,
    height: u32,
    texel_bytes: u32,
) -> Vec<u8> {
    let world = app.sub_app(RenderApp).world();
    let images = world.resource::<RenderAssets<GpuImage>>();
    let gpu_image = images.get(handle).expect("the image on the GPU");
    let device = world.resource::<RenderDevice>().wgpu_device().clone();
    let queue: &wgpu::Queue = world.resource::<RenderQueue>();
    let packed = width * texel_bytes;
    let row = packed.div_ceil(256) * 256;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("golden readback"),
        size: u64::from(row * height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        gpu_image.texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([encoder.finish()]);
    let bytes = nimbus_render::binding::read_mapped(&device, &staging).expect("readback");
    bytes
        .chunks(row as usize)
        .flat_map(|r| r[..packed as usize].to_vec())
        .collect()
}

/// The image's pixels (sRGB, RGBA8), read back from the render world.
fn read_image(app: &mut App, handle: &Handle<Image>) -> Vec<u8> {
    read_texels(app, handle, WIDTH, HEIGHT, 4)
}

/// The cloud shadow light texture's red channel (the sun's visibility,
/// what Bevy's light texture reads), read back from the render world.
fn read_cloud_shadows(app: &mut App) -> Vec<f32> {
    let handle = app.world().resource::<NimbusCloudShadowTexture>().0.clone();
    // Rgba16Float: 8 bytes a texel.
    let bytes = read_texels(app, &handle, CLOUD_SHADOW_TEXELS, CLOUD_SHADOW_TEXELS, 8);
    bytes
        .chunks(8)
        .map(|h| half::f16::from_le_bytes([h[0], h[1]]).to_f32())
        .collect()
}

/// The cloud shadow texture as a grey PNG (for looking at).
fn save_visibility_png(path: &PathBuf, visibility: &[f32]) {
    let n = CLOUD_SHADOW_TEXELS;
    let grey: Vec<u8> = visibility
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).expect("directory");
    }
    image::save_buffer(path, &grey, n, n, image::ExtendedColorType::L8).expect("write png");
}

/// Mean linear RGB of an sRGB image over a rectangle.
fn mean_rgb(pixels: &[u8], min: UVec2, max: UVec2) -> [f64; 3] {
    let mut sum = [0.0; 3];
    let mut n = 0.0;
    for y in min.y..=max.y {
        for x in min.x..=max.x {
            let i = ((y * WIDTH + x) * 4) as usize;
            for (k, s) in sum.iter_mut().enumerate() {
                *s += nimbus_physics::photometry::srgb_decode(f64::from(pixels[i + k]) / 255.0);
            }
            n += 1.0;
        }
    }
    sum.map(|s| s / n)
}

/// Mean linear luminance (Rec. 709) of an sRGB image over a rectangle.
fn mean_luminance(pixels: &[u8], min: UVec2, max: UVec2) -> f64 {
    let [r, g, b] = mean_rgb(pixels, min, max);
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// nimbus's rain drops alive inside the box `lo`..`hi` (world metres).
fn drops_in(app: &mut App, lo: Vec3, hi: Vec3) -> usize {
    let world = app.sub_app(RenderApp).world();
    let renderer = world.resource::<NimbusRenderer>().lock();
    let device = world.resource::<RenderDevice>().wgpu_device().clone();
    let queue: &wgpu::Queue = world.resource::<RenderQueue>();
    let mut left = renderer.rain().dispatched_drops() as usize;
    let mut count = 0;
    for (buffer, held) in renderer.rain().drops_buffers() {
        let n = left.min(held as usize);
        left -= n;
        if n == 0 {
            continue;
        }
        let size = (n * std::mem::size_of::<DropGpu>()) as u64;
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("drops readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        queue.submit([encoder.finish()]);
        let bytes = nimbus_render::binding::read_mapped(&device, &staging).expect("drops");
        let drops: Vec<DropGpu> = bytemuck::pod_collect_to_vec(&bytes);
        count += drops
            .iter()
            .filter(|d| {
                let p = Vec3::from_array(d.position_m);
                d.state == 1 && p.cmpge(lo).all() && p.cmple(hi).all()
            })
            .count();
    }
    count
}

/// The screen rectangle (pixels, inclusive) well inside the tall
/// building's silhouette: its front face, shrunk by a margin.
fn building_rect() -> (UVec2, UVec2) {
    let projection = PerspectiveProjection {
        aspect_ratio: WIDTH as f32 / HEIGHT as f32,
        ..default()
    };
    let clip_from_world =
        projection.get_clip_from_view() * demo::camera_transform().to_matrix().inverse();
    // The concrete tower: x 20..28, y 0..24, z −50..−42; its face towards
    // the camera (z = −42), from 12 m up (above the buildings in front).
    let corners = [
        Vec3::new(20.5, 12.0, -42.0),
        Vec3::new(27.5, 12.0, -42.0),
        Vec3::new(20.5, 23.5, -42.0),
        Vec3::new(27.5, 23.5, -42.0),
    ];
    let pixels: Vec<Vec2> = corners
        .iter()
        .map(|c| {
            let clip = clip_from_world * c.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            Vec2::new(
                (ndc.x * 0.5 + 0.5) * WIDTH as f32,
                (0.5 - ndc.y * 0.5) * HEIGHT as f32,
            )
        })
        .collect();
    let min = pixels.iter().fold(Vec2::MAX, |a, p| a.min(*p));
    let max = pixels.iter().fold(Vec2::MIN, |a, p| a.max(*p));
    ((min + 1.5).as_uvec2(), (max - 1.5).as_uvec2())
}

/// Mean absolute difference of two sRGB images over a rectangle, 0–255.
fn mean_difference(a: &[u8], b: &[u8], min: UVec2, max: UVec2) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for y in min.y..=max.y {
        for x in min.x..=max.x {
            let i = ((y * WIDTH + x) * 4) as usize;
            for c in 0..3 {
                sum += (f64::from(a[i + c]) - f64::from(b[i + c])).abs();
                n += 1.0;
            }
        }
    }
    sum / n
}

fn save_png(path: &PathBuf, pixels: &[u8]) {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).expect("directory");
    }
    image::save_buffer(path, pixels, WIDTH, HEIGHT, image::ExtendedColorType::Rgba8)
        .expect("write png");
}

/// The golden image (the render crate's [`GoldenDifference`]: CIE76 ΔE, mean
/// at most 1.5, at most 1 % of pixels over 10; `NIMBUS_BLESS=1` rewrites it).
fn assert_matches_golden(pixels: &[u8]) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    let golden_path = dir.join("bevy-weather.png");
    if std::env::var_os("NIMBUS_BLESS").is_some() {
        save_png(&golden_path, pixels);
        return;
    }
    let golden = image::open(&golden_path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (run with NIMBUS_BLESS=1 to create it)",
                golden_path.display()
            )
        })
        .to_rgba8();
    assert_eq!((golden.width(), golden.height()), (WIDTH, HEIGHT));
    let difference = GoldenDifference::between(golden.as_raw(), pixels);
    let (mean, large) = (difference.mean, difference.large_fraction);
    if !difference.passes() {
        let out = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/golden-diff");
        save_png(&out.join("bevy-weather-actual.png"), pixels);
        panic!(
            "bevy-weather: differs from {} (mean ΔE {mean:.2}, {:.2} % of pixels over ΔE 10); see {}",
            golden_path.display(),
            large * 100.0,
            out.display()
        );
    }
}

#[test]
fn golden_bevy_weather_world() {
    let (mut app, image) = app();
    let out = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/bevy-golden");

    // The scripted weather 45 s in: cumulus, the stratus deck most of the
    // way in, 8 mm/h of rain.
    run(&mut app, 45.0, 8);
    let full = read_image(&mut app, &image);
    save_png(&out.join("full.png"), &full);

    // No drop under the roof (away from its edges), drops beside it.
    let (lo, hi) = (demo::ROOF_MIN, demo::ROOF_MAX);
    let under = drops_in(
        &mut app,
        Vec3::new(lo.x + 0.8, 0.3, lo.z + 0.8),
        Vec3::new(hi.x - 0.8, lo.y - 0.3, hi.z - 0.8),
    );
    let beside = drops_in(
        &mut app,
        Vec3::new(lo.x + 0.8, 0.3, hi.z + 2.0),
        Vec3::new(hi.x - 0.8, lo.y - 0.3, hi.z + 2.0 + (hi.z - lo.z) - 1.6),
    );
    assert_eq!(
        under, 0,
        "{under} drops under the shelter's roof ({beside} beside it)"
    );
    assert!(
        beside > 20,
        "{beside} drops beside the shelter: is it raining?"
    );

    // Without rain, with and without clouds: Bevy's tower hides the clouds
    // (its lighting kept the same: no cloud shadows for this comparison).
    let mut scene = app.world().resource::<NimbusWeather>().scene.clone();
    scene.rain = None;
    scene.keyframes.clear();
    scene.stratus.as_mut().expect("stratus").coverage = 0.6;
    // Cumulus alone: their shadows are in the sun's light texture, shadowed
    // texels and sunlit ones.
    let mut cumulus_only = scene.clone();
    cumulus_only.stratus = None;
    app.world_mut().resource_mut::<NimbusWeather>().scene = cumulus_only;
    run(&mut app, 45.0, 4);
    let visibility = read_cloud_shadows(&mut app);
    save_visibility_png(&out.join("cloud-shadows.png"), &visibility);
    let shadowed = visibility.iter().filter(|v| **v < 0.5).count() as f64;
    let sunlit = visibility.iter().filter(|v| **v > 0.95).count() as f64;
    let texels = visibility.len() as f64;
    assert!(
        visibility.iter().all(|v| (0.0..=1.0001).contains(v))
            && shadowed > 0.01 * texels
            && sunlit > 0.05 * texels,
        "cumulus shadow texture: {:.1} % of texels under 0.5, {:.1} % over 0.95 (from {} to {})",
        100.0 * shadowed / texels,
        100.0 * sunlit / texels,
        visibility.iter().fold(f32::MAX, |a, v| a.min(*v)),
        visibility.iter().fold(f32::MIN, |a, v| a.max(*v))
    );

    app.world_mut().resource_mut::<NimbusCloudShadows>().enabled = false;
    app.world_mut().resource_mut::<NimbusWeather>().scene = scene.clone();
    run(&mut app, 45.0, 4);
    let cloudy = read_image(&mut app, &image);
    let mut clear_scene = scene.clone();
    clear_scene.stratus = None;
    clear_scene.cumulus = None;
    app.world_mut().resource_mut::<NimbusWeather>().scene = clear_scene;
    run(&mut app, 45.0, 4);
    let clear = read_image(&mut app, &image);
    save_png(&out.join("cloudy.png"), &cloudy);
    save_png(&out.join("clear.png"), &clear);
    let (min, max) = building_rect();
    assert!(
        min.x < max.x && min.y < max.y && max.x < WIDTH && max.y < HEIGHT,
        "tower at {min}..{max}"
    );
    let on_tower = mean_difference(&cloudy, &clear, min, max);
    // The sky above the tower, up to the top of the image.
    let sky_max = UVec2::new(max.x, min.y.saturating_sub(6));
    let sky_min = UVec2::new(min.x, 0);
    let in_sky = mean_difference(&cloudy, &clear, sky_min, sky_max);
    assert!(
        on_tower < 2.0 && in_sky > 8.0,
        "clouds over Bevy's tower: it differs by {on_tower:.2} with and without clouds, the sky above it by {in_sky:.2}"
    );

    // Under an overcast the sun is hidden: with cloud shadows, Bevy's sunlit
    // tower and ground darken; without, they are lit as under a clear sky.
    let stratus = scene.stratus.as_mut().expect("stratus");
    stratus.coverage = 1.0;
    stratus.thickness_m = 500.0;
    scene.cumulus = None;
    app.world_mut().resource_mut::<NimbusWeather>().scene = scene;
    run(&mut app, 45.0, 4);
    let unshadowed = read_image(&mut app, &image);
    app.world_mut().resource_mut::<NimbusCloudShadows>().enabled = true;
    run(&mut app, 45.0, 4);
    let overcast = read_image(&mut app, &image);
    save_png(&out.join("overcast.png"), &overcast);
    save_png(&out.join("overcast-unshadowed.png"), &unshadowed);
    let overcast_visibility = read_cloud_shadows(&mut app);
    let mean_visibility = overcast_visibility
        .iter()
        .map(|v| f64::from(*v))
        .sum::<f64>()
        / texels;
    let ground = (
        UVec2::new(0, HEIGHT - HEIGHT / 6),
        UVec2::new(WIDTH - 1, HEIGHT - 1),
    );
    // Darker: the direct sun is gone, Bevy's ambient light remains (the
    // clear sky's, blue: docs/bevy.md). Not tinted red as a decal of the
    // light texture would (see `cloud_shadows::CLOUD_SHADOW_FORMAT`).
    for (what, (lo, hi)) in [("tower", (min, max)), ("ground", ground)] {
        let ratio = mean_luminance(&overcast, lo, hi) / mean_luminance(&unshadowed, lo, hi);
        let [shadowed_rgb, lit_rgb] = [&overcast, &unshadowed].map(|p| mean_rgb(p, lo, hi));
        let redness = |rgb: [f64; 3]| rgb[0] / rgb[1].max(1e-6);
        assert!(
            (0.01..0.75).contains(&ratio) && redness(shadowed_rgb) <= redness(lit_rgb) + 0.05,
            "the overcast's shadow on Bevy's {what}: luminance {ratio:.3} of the unshadowed, \
             linear RGB {shadowed_rgb:?} against {lit_rgb:?} (sun visibility {mean_visibility:.3} \
             on average)"
        );
    }
    assert!(
        mean_visibility < 0.3,
        "overcast sun visibility {mean_visibility:.3}"
    );

    assert_matches_golden(&full);
}
