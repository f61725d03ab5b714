//! GPU tests on whatever adapter is present (software Vulkan on machines
//! without a GPU): golden images, determinism, and each GPU algorithm
//! against its CPU reference.
//!
//! These tests fail, never skip, when no adapter is found; the message says
//! how to install the software driver.

use glam::{DMat4, DVec3, DVec4};
use nimbus_physics::photometry::{exposure_scale_from_ev100, srgb_decode, srgb_encode};
use nimbus_physics::terrain;
use nimbus_render::atmosphere::solar_irradiance_top;
use nimbus_render::frame::Camera;
use nimbus_render::headless::{GoldenDifference, HeadlessRenderer, Rgba8Image};
use nimbus_render::{AdapterPreference, Scene};
use std::path::PathBuf;

#[path = "../../examples/embed_world.rs"]
mod embed_world;

const GOLDEN_WIDTH: u32 = 160;
const GOLDEN_HEIGHT: u32 = 90;

fn headless() -> HeadlessRenderer {
    HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

fn scene_file(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"))
}

// ---------------------------------------------------------------- golden images

/// Perceptual comparison ([`GoldenDifference`]: CIE76 ΔE per pixel, mean at
/// most 1.5, at most 1 % of pixels over 10). On failure, writes the rendered image and a difference
/// image (ΔE × 10 as grey) under `target/golden-diff/`.
fn assert_matches_golden(name: &str, image: &Rgba8Image) {
    let golden_path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(format!("{name}.png"));
    let save = |path: &PathBuf, img: &Rgba8Image| {
        image::save_buffer(
            path,
            &img.pixels,
            img.width,
            img.height,
            image::ExtendedColorType::Rgba8,
        )
        .expect("write png");
    };
    if std::env::var_os("NIMBUS_BLESS").is_some() {
        save(&golden_path, image);
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
    assert_eq!(
        (golden.width(), golden.height()),
        (image.width, image.height),
        "{name}: size differs from the golden image"
    );
    let difference = GoldenDifference::between(golden.as_raw(), &image.pixels);
    let (deltas, mean, large) = (
        &difference.delta_e,
        difference.mean,
        difference.large_fraction,
    );
    if !difference.passes() {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/golden-diff");
        std::fs::create_dir_all(&dir).expect("diff dir");
        save(&dir.join(format!("{name}-actual.png")), image);
        let diff: Vec<u8> = deltas
            .iter()
            .flat_map(|d| {
                let v = (d * 10.0).min(255.0) as u8;
                [v, v, v, 255]
            })
            .collect();
        save(
            &dir.join(format!("{name}-diff.png")),
            &Rgba8Image {
                width: image.width,
                height: image.height,
                pixels: diff,
            },
        );
        panic!(
            "{name}: differs from {} (mean ΔE {mean:.2}, {:.2} % of pixels over ΔE 10); see {}",
            golden_path.display(),
            large * 100.0,
            dir.display()
        );
    }
}

/// The example of a program drawing its own world (issue 26): nimbus's sky,
/// clouds and rain composited in `LinearHdr` over the program's ground,
/// boxes and roof, which nimbus's WGSL include lights. Its golden image,
/// and the clouds' shadow reaching the program's ground through the include.
#[test]
fn golden_embedded_world_example() {
    let h = headless();
    let (device, queue) = (&h.gpu.device, &h.gpu.queue);
    let scene = Scene::from_toml_str(embed_world::WORLD_SCENE, "embed_world.toml").expect("scene");
    let (width, height) = (320, 180);
    let embed_world::WorldFrame {
        pixels, radiance, ..
    } = embed_world::render_world(device, queue, &scene, width, height, 10.0, 1, false)
        .expect("render");
    assert_matches_golden(
        "embed-world",
        &Rgba8Image {
            width,
            height,
            pixels,
        },
    );
    // The same world under a clear sky: the program's ground in the sun.
    let mut clear = scene.clone();
    clear.stratus = None;
    clear.cumulus = None;
    let clear_radiance =
        embed_world::render_world(device, queue, &clear, width, height, 10.0, 1, false)
            .expect("render")
            .radiance;
    // The bottom rows are the program's ground, near the camera.
    let ground = |image: &[[f32; 4]]| {
        let rows = &image[(width * (height - 10)) as usize..];
        rows.iter().map(|p| p[1]).sum::<f32>() / rows.len() as f32
    };
    let (shaded, sunlit) = (ground(&radiance), ground(&clear_radiance));
    assert!(
        shaded < 0.6 * sunlit,
        "ground under the clouds {shaded} vs in the sun {sunlit}: the include's shadow is missing"
    );
}

#[test]
fn golden_default_scene() {
    let image = headless()
        .render_rgba8(&Scene::embedded_default(), GOLDEN_WIDTH, GOLDEN_HEIGHT, 0.0)
        .expect("render");
    assert_matches_golden("default", &image);
}

/// One golden test per example scene: the sun high, low, setting and below
/// the horizon, and the view from 10 km.
macro_rules! golden_scene {
    ($test:ident, $file:literal) => {
        #[test]
        fn $test() {
            let scene = scene_file(concat!($file, ".toml"));
            let image = headless()
                .render_rgba8(&scene, GOLDEN_WIDTH, GOLDEN_HEIGHT, 0.0)
                .expect("render");
            assert_matches_golden($file, &image);
        }
    };
}

golden_scene!(golden_noon, "noon");
golden_scene!(golden_low_sun, "golden-hour");
golden_scene!(golden_sunset, "sunset");
golden_scene!(golden_twilight_sun_5_degrees_below_horizon, "twilight");
golden_scene!(golden_view_from_10_km, "high-altitude");
golden_scene!(golden_objects_shed, "objects-shed");

/// Golden images of the rain scenes at their own size (480×270; streaks are
/// thinner than a pixel at the small golden size), ten seconds in.
macro_rules! golden_rain_scene {
    ($test:ident, $file:literal) => {
        #[test]
        fn $test() {
            let scene = scene_file(concat!($file, ".toml"));
            let image = headless()
                .render_rgba8(&scene, scene.image.width, scene.image.height, 10.0)
                .expect("render");
            assert_matches_golden($file, &image);
        }
    };
}

golden_rain_scene!(golden_rain_drizzle, "rain-drizzle");
golden_rain_scene!(golden_rain_heavy, "rain-heavy");
golden_rain_scene!(golden_rain_strong_crosswind, "rain-crosswind");
golden_rain_scene!(golden_rain_around_a_roofed_shelter, "rain-shelter");
golden_rain_scene!(
    golden_rain_against_a_dark_background,
    "rain-dark-background"
);
golden_rain_scene!(
    golden_rain_against_a_bright_background,
    "rain-bright-background"
);

/// Golden images of the stratus scenes, at twice the size so that the glory,
/// fogbow and silver lining stay visible in them.
macro_rules! golden_stratus_scene {
    ($test:ident, $file:literal) => {
        #[test]
        fn $test() {
            let scene = scene_file(concat!($file, ".toml"));
            let image = headless()
                .render_rgba8(&scene, 2 * GOLDEN_WIDTH, 2 * GOLDEN_HEIGHT, 0.0)
                .expect("render");
            assert_matches_golden($file, &image);
        }
    };
}

golden_stratus_scene!(golden_stratus_from_the_ground_at_noon, "stratus-noon");
golden_stratus_scene!(
    golden_stratus_from_a_plane_at_sunset_pseudo_specular,
    "stratus-sunset-plane"
);
golden_stratus_scene!(golden_stratus_silver_lining, "stratus-silver-lining");
golden_stratus_scene!(golden_stratus_glory_and_fogbow, "stratus-glory");
golden_stratus_scene!(golden_stratus_over_the_sea, "stratus-sea");
golden_stratus_scene!(golden_stratus_over_snow, "stratus-snow");
golden_stratus_scene!(golden_stratus_seen_from_its_side, "stratus-side");
golden_stratus_scene!(golden_cumulus_front_lit, "cumulus-front-lit");
golden_stratus_scene!(golden_cumulus_back_lit_silver_lining, "cumulus-back-lit");
golden_stratus_scene!(golden_cumulus_at_sunset, "cumulus-sunset");
golden_stratus_scene!(golden_cumulus_from_below, "cumulus-from-below");
golden_stratus_scene!(golden_cumulus_field_over_terrain, "cumulus-field");

/// The cumulus shader term by term, like Bouthors (2004) figs 5.2–5.13:
/// Lambert; + ambient; + bump; + light traps; + corona (transparency and
/// forward scattering); + shadow, tiled left to right, top to bottom.
#[test]
fn golden_cumulus_terms_one_by_one() {
    use nimbus_physics::cumulus::shading::ShadingTerms;
    let base = scene_file("cumulus-terms.toml");
    let (w, h) = (2 * GOLDEN_WIDTH, 2 * GOLDEN_HEIGHT);
    let mut terms = ShadingTerms {
        ambient: false,
        bump: false,
        light_traps: false,
        corona: false,
        shadow: false,
    };
    let steps: [fn(&mut ShadingTerms); 6] = [
        |_| {},
        |t| t.ambient = true,
        |t| t.bump = true,
        |t| t.light_traps = true,
        |t| t.corona = true,
        |t| t.shadow = true,
    ];
    let mut renderer = headless();
    let mut tiles = Vec::new();
    for step in steps {
        step(&mut terms);
        let mut scene = base.clone();
        if let Some(cumulus) = scene.cumulus.as_mut() {
            cumulus.terms = terms;
        }
        tiles.push(renderer.render_rgba8(&scene, w, h, 0.0).expect("render"));
    }
    let mut montage = image::RgbaImage::new(3 * w, 2 * h);
    for (k, tile) in tiles.iter().enumerate() {
        let (x0, y0) = ((k as u32 % 3) * w, (k as u32 / 3) * h);
        for y in 0..h {
            for x in 0..w {
                let i = ((y * w + x) * 4) as usize;
                let p = &tile.pixels[i..i + 4];
                montage.put_pixel(x0 + x, y0 + y, image::Rgba([p[0], p[1], p[2], p[3]]));
            }
        }
    }
    let image = Rgba8Image {
        width: 3 * w,
        height: 2 * h,
        pixels: montage.into_raw(),
    };
    // Each term changes the picture.
    for pair in tiles.windows(2) {
        assert_ne!(pair[0].pixels, pair[1].pixels, "a term changed nothing");
    }
    assert_matches_golden("cumulus-terms", &image);
}

/// Rec.709 luminance of a linear radiance pixel (relative: no K_m).
fn luminance(p: &[f32; 3]) -> f64 {
    let [r, g, b] = nimbus_physics::photometry::REC709_LUMA;
    r * p[0] as f64 + g * p[1] as f64 + b * p[2] as f64
}

/// Mean luminance of the linear radiance in rows [top, bottom) of an image.
fn mean_luminance_rows(image: &nimbus_render::headless::HdrImage, top: u32, bottom: u32) -> f64 {
    let w = image.width as usize;
    let rows = &image.pixels[top as usize * w..bottom as usize * w];
    rows.iter().map(luminance).sum::<f64>() / rows.len() as f64
}

/// Ice blink and water sky (Bouthors 2006, §5): the same overcast layer's
/// base is much brighter over snow (albedo 0.85) than over the sea (about
/// 0.08), because of the light exchanged between ground and cloud. The
/// radiosity estimate: the base's ground-lit share grows as ρ_G / (1 − ρ_G R_ms).
#[test]
fn stratus_base_is_brighter_over_snow_than_over_the_sea() {
    let mut h = headless();
    let base = |h: &mut HeadlessRenderer, file: &str| {
        let image = h
            .render_hdr(&scene_file(file), 64, 36, 0.0)
            .expect("render");
        // The upper third of the frame is the cloud base.
        mean_luminance_rows(&image, 0, 12)
    };
    let snow = base(&mut h, "stratus-snow.toml");
    let sea = base(&mut h, "stratus-sea.toml");
    assert!(
        snow > 1.4 * sea,
        "cloud base over snow {snow}, over sea {sea}"
    );
}

/// Seen from above with the sun behind the camera, the antisolar point
/// (image centre) shows the glory, brighter than the cloud a few degrees
/// away, and the fogbow (scattering angle ≈ 145°) is brighter than the
/// cloud on either side of it.
#[test]
fn stratus_glory_and_fogbow_brighten_their_angles() {
    let mut scene = scene_file("stratus-glory.toml");
    // A view centred on the antisolar point, 1 pixel ≈ 0.5°.
    scene.camera.fov_deg = 90.0;
    let (w, hgt) = (180u32, 180u32);
    let image = headless().render_hdr(&scene, w, hgt, 0.0).expect("render");
    let camera = Camera::from_settings(&scene.camera, w, hgt);
    let antisolar = -DVec3::from_array(scene.sun.direction());
    // Mean luminance of the pixels whose ray is within [lo, hi) degrees of
    // the antisolar direction.
    let ring = |lo: f64, hi: f64| {
        let (mut sum, mut count) = (0.0, 0);
        for y in 0..hgt {
            for x in 0..w {
                let ray = pixel_ray(&camera, w, hgt, x, y);
                let angle = ray.dot(antisolar).clamp(-1.0, 1.0).acos().to_degrees();
                if angle >= lo && angle < hi {
                    sum += luminance(&image.pixels[(y * w + x) as usize]);
                    count += 1;
                }
            }
        }
        assert!(count > 0, "no pixel in [{lo}, {hi})");
        sum / count as f64
    };
    let (glory, beside) = (ring(0.0, 1.5), ring(6.0, 9.0));
    assert!(glory > 1.1 * beside, "glory {glory}, 6–9° away {beside}");
    // The fogbow is a bump of the radial profile, 33–36° from the centre
    // (Θ ≈ 145°, where this DSD's P_S peaks), above the line through the
    // profile 6° inside and outside it: the orders 3+ fall outwards under
    // it (their traced exit shape darkens the more grazing views), so the
    // bump is measured against that slope, not against each side.
    let (inside, fogbow, outside) = (ring(27.0, 30.0), ring(33.0, 36.0), ring(39.0, 42.0));
    assert!(
        fogbow > 1.015 * 0.5 * (inside + outside) && fogbow > outside,
        "fogbow {fogbow}, 6° inside {inside}, 6° outside {outside}"
    );
}

#[test]
fn rendering_twice_gives_identical_pixels() {
    let scene = scene_file("golden-hour.toml");
    let mut first = headless();
    let a = first.render_rgba8(&scene, 96, 64, 1.5).expect("render");
    let b = first.render_rgba8(&scene, 96, 64, 1.5).expect("render");
    let c = headless()
        .render_rgba8(&scene, 96, 64, 1.5)
        .expect("render");
    assert!(a == b, "the same renderer gave different pixels");
    assert!(a == c, "a second renderer gave different pixels");
}

#[test]
fn image_larger_than_the_device_allows_is_refused_before_allocating() {
    let mut h = headless();
    let max = h.gpu.device.limits().max_texture_dimension_2d;
    let err = h
        .render_rgba8(&Scene::default(), max + 1, 8, 0.0)
        .expect_err("too large");
    assert!(err.to_string().contains("must be in [1,"), "{err}");
}

// ---------------------------------------------------------------- CPU references

/// World-space unit ray through the centre of pixel (px, py).
fn pixel_ray(camera: &Camera, width: u32, height: u32, px: u32, py: u32) -> DVec3 {
    let world_from_clip: DMat4 = camera.clip_from_world().inverse();
    let x = (px as f64 + 0.5) / width as f64 * 2.0 - 1.0;
    let y = 1.0 - (py as f64 + 0.5) / height as f64 * 2.0;
    let near = world_from_clip * DVec4::new(x, y, 1.0, 1.0);
    (near.truncate() / near.w - camera.position_m).normalize()
}

fn relative_error(gpu: [f32; 3], cpu: [f64; 3]) -> f64 {
    let scale = cpu.iter().cloned().fold(0.0, f64::max).max(1e-6);
    (0..3)
        .map(|k| (gpu[k] as f64 - cpu[k]).abs() / scale)
        .fold(0.0, f64::max)
}

#[test]
fn gpu_terrain_shading_matches_the_cpu_lambert_reference() {
    // A flat, snow-covered plain seen from above under an empty atmosphere
    // (no scattering, absorption or ground bounce): every pixel is Lambertian
    // snow with its normal up, lit by the unattenuated sun alone, and there is
    // no aerial perspective.
    let mut scene = Scene::default();
    scene.atmosphere.rayleigh_scattering_per_m = [0.0; 3];
    scene.atmosphere.aerosol_optical_depth = 0.0;
    scene.atmosphere.ozone_absorption_per_m = [0.0; 3];
    scene.atmosphere.ground_albedo = [0.0; 3];
    scene.terrain.height_scale_m = 0.0;
    scene.terrain.water_level_m = -500.0;
    scene.terrain.snow_line_m = -1000.0;
    scene.terrain.resolution = 64;
    scene.camera.position_m = [100.0, 800.0, 300.0];
    scene.camera.yaw_deg = Some(30.0);
    scene.camera.pitch_deg = Some(-70.0);
    scene.camera.fov_deg = 40.0;
    scene.camera.exposure_ev100 = 16.0;
    let (w, h) = (48, 32);
    let image = headless().render_hdr(&scene, w, h, 0.0).expect("render");

    let terrain = terrain::generate(&scene.terrain);
    let albedo = terrain.albedo_rgba8();
    let n = terrain.vertices_per_side();
    let cell = terrain.cell_size_m();
    let half = 0.5 * scene.terrain.extent_m;
    let mu_s = scene.sun.direction()[1];
    let irradiance: Vec<f64> = solar_irradiance_top()
        .iter()
        .map(|e| *e as f64 * mu_s)
        .collect();
    let camera = Camera::from_settings(&scene.camera, w, h);
    let mut worst = 0.0f64;
    for py in 0..h {
        for px in 0..w {
            let ray = pixel_ray(&camera, w, h, px, py);
            let t = -camera.position_m.y / ray.y;
            let hit = camera.position_m + ray * t;
            // Bilinear filtering of the sRGB texture after decoding, as the sampler does.
            let (fx, fz) = ((hit.x + half) / cell, (hit.z + half) / cell);
            let (i0, j0) = (fx.floor() as usize, fz.floor() as usize);
            let (tx, tz) = (fx - i0 as f64, fz - j0 as f64);
            let texel = |i: usize, j: usize, k: usize| {
                srgb_decode(albedo[j.min(n - 1) * n + i.min(n - 1)][k] as f64 / 255.0)
            };
            let cpu: [f64; 3] = [0, 1, 2].map(|k| {
                let a = texel(i0, j0, k) * (1.0 - tx) + texel(i0 + 1, j0, k) * tx;
                let b = texel(i0, j0 + 1, k) * (1.0 - tx) + texel(i0 + 1, j0 + 1, k) * tx;
                let rho = a * (1.0 - tz) + b * tz;
                rho / std::f64::consts::PI * irradiance[k]
            });
            worst = worst.max(relative_error(image.pixels[(py * w + px) as usize], cpu));
        }
    }
    // 8-bit sRGB texels filtered at reduced precision by the sampler, half-float storage: 2 %.
    assert!(worst < 0.02, "worst relative terrain error {worst}");
}

#[test]
fn gpu_tone_mapping_matches_the_cpu_aces_reference() {
    // Manual exposure, so that the tone mapper's input is radiance × the scene's EV100 scale.
    let mut scene = Scene::embedded_default();
    scene.camera.auto_exposure = false;
    let mut h = headless();
    let (w, ht) = (64, 36);
    let hdr = h.render_hdr(&scene, w, ht, 0.0).expect("render hdr");
    let ldr = h.render_rgba8(&scene, w, ht, 0.0).expect("render ldr");
    let exposure = exposure_scale_from_ev100(scene.camera.exposure_ev100);
    let mut worst = 0.0f64;
    for (k, radiance) in hdr.pixels.iter().enumerate() {
        let exposed = radiance.map(|c| c as f64 * exposure);
        let mapped = nimbus_render::tonemap::aces_fitted_reference(exposed);
        for (channel, value) in mapped.iter().enumerate() {
            let cpu = srgb_encode(*value) * 255.0;
            let gpu = ldr.pixels[k * 4 + channel] as f64;
            worst = worst.max((cpu - gpu).abs());
        }
    }
    // ±1 code value of dither, ±0.5 of rounding, and half-float input.
    assert!(worst <= 2.0, "worst tone-mapping error {worst} code values");
}

/// A scene made in code is checked by `prepare` as a scene file is by its
/// loader: one line with the key, the value and what is allowed, and nothing
/// drawn; a valid scene then renders with the same renderer.
#[test]
fn prepare_rejects_a_scene_out_of_range_with_one_line() {
    let mut h = headless();
    let mut scene = Scene::default();
    scene.camera.fov_deg = 190.0;
    let error = h
        .render_hdr(&scene, 32, 18, 0.0)
        .expect_err("a field of view of 190° must be refused")
        .to_string();
    assert_eq!(
        error,
        "scene: camera.fov_deg = 190: must be a finite number in [0.01, 179]"
    );
    assert!(!error.contains('\n'));
    scene.camera.fov_deg = 60.0;
    scene.terrain.resolution = 64;
    h.render_hdr(&scene, 32, 18, 0.0).expect("valid scene");
}
