//! GPU tests of the static objects: they are shaded exactly as the terrain
//! is (the same Lambert function, sun, cloud shadows and ambient light),
//! their faces are lit by the sun at the right angle, and the pass rebuilds
//! its geometry (and its occluder buffers) only when the objects change.
//!
//! These tests fail, never skip, when no adapter is found.

use glam::{DMat4, DVec4};
use nimbus_physics::photometry::srgb_decode;
use nimbus_physics::terrain;
use nimbus_render::atmosphere::solar_irradiance_top;
use nimbus_render::frame::Camera;
use nimbus_render::headless::{HdrImage, HeadlessRenderer};
use nimbus_render::scene::{CumulusSettings, SceneObject, StratusSettings};
use nimbus_render::{AdapterPreference, Scene};

fn headless() -> HeadlessRenderer {
    HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

/// A flat plain of one albedo everywhere (every surface class alike, the
/// sea far below), seen from 300 m straight down.
fn flat_scene(albedo: [f32; 3]) -> Scene {
    let mut scene = Scene::default();
    scene.terrain.height_scale_m = 0.0;
    scene.terrain.water_level_m = -500.0;
    scene.terrain.resolution = 64;
    let t = &mut scene.terrain.albedo;
    (t.sand, t.grass, t.rock, t.snow) = (albedo, albedo, albedo, albedo);
    scene.camera.position_m = [0.0, 300.0, 0.0];
    scene.camera.yaw_deg = Some(0.0);
    scene.camera.pitch_deg = Some(-89.0);
    scene.camera.fov_deg = 90.0;
    scene
}

/// The terrain's albedo where the ray of pixel (px, py) meets the plain
/// y = 0, filtered bilinearly after decoding, as the sampler does (the map
/// varies by ±15 % over ~100 m so that zones are not flat colour).
fn terrain_albedo_at_pixel(scene: &Scene, w: u32, h: u32, px: u32, py: u32) -> [f64; 3] {
    let camera = Camera::from_settings(&scene.camera, w, h);
    let world_from_clip: DMat4 = camera.clip_from_world().inverse();
    let x = (px as f64 + 0.5) / w as f64 * 2.0 - 1.0;
    let y = 1.0 - (py as f64 + 0.5) / h as f64 * 2.0;
    let near = world_from_clip * DVec4::new(x, y, 1.0, 1.0);
    let ray = (near.truncate() / near.w - camera.position_m).normalize();
    let hit = camera.position_m + ray * (-camera.position_m.y / ray.y);
    let t = terrain::generate(&scene.terrain);
    let albedo = t.albedo_rgba8();
    let (n, cell, half) = (
        t.vertices_per_side(),
        t.cell_size_m(),
        0.5 * scene.terrain.extent_m,
    );
    let (fx, fz) = ((hit.x + half) / cell, (hit.z + half) / cell);
    let (i0, j0) = (fx.floor() as usize, fz.floor() as usize);
    let (tx, tz) = (fx - i0 as f64, fz - j0 as f64);
    let texel = |i: usize, j: usize, k: usize| {
        srgb_decode(albedo[j.min(n - 1) * n + i.min(n - 1)][k] as f64 / 255.0)
    };
    [0, 1, 2].map(|k| {
        let a = texel(i0, j0, k) * (1.0 - tx) + texel(i0 + 1, j0, k) * tx;
        let b = texel(i0, j0 + 1, k) * (1.0 - tx) + texel(i0 + 1, j0 + 1, k) * tx;
        a * (1.0 - tz) + b * tz
    })
}

#[test]
fn objects_are_shaded_exactly_as_the_terrain_under_cloud_shadows() {
    // The same plain rendered bare and covered by a flat box whose top is
    // 1 mm above it (nearer, the cumulus shadow map's texels would be picked
    // differently at a few pixels), under broken stratus and cumulus whose
    // shadows vary over the view:
    // at each pixel the light received (the radiance less the aerial
    // perspective's in-scattering, measured on a black box, over the
    // albedo) must be the same on the box as on the terrain it hides.
    let grass = [0.07, 0.12, 0.04];
    let mut scene = flat_scene(grass);
    scene.sun.azimuth_deg = Some(150.0);
    scene.sun.elevation_deg = Some(40.0);
    let mut stratus = StratusSettings::default();
    stratus.base_m = 700.0;
    stratus.thickness_m = 300.0;
    stratus.coverage = 0.5;
    stratus.feature_size_m = 600.0;
    stratus.resolution = 128;
    scene.stratus = Some(stratus);
    let mut cumulus = CumulusSettings::default();
    cumulus.coverage = 0.3;
    cumulus.base_m = 500.0;
    cumulus.area_m = Some(4_000.0);
    scene.cumulus = Some(cumulus);
    let (w, h) = (48, 32);
    let mut gpu = headless();
    let bare = gpu.render_hdr(&scene, w, h, 0.0).expect("render");
    let albedo = [0.3, 0.3, 0.3];
    let mut covered_by = |albedo: [f64; 3]| {
        scene.objects = vec![SceneObject::new_box(
            [0.0, 0.0, 0.0],
            [3000.0, 0.002, 3000.0],
            0.0,
            albedo,
        )];
        gpu.render_hdr(&scene, w, h, 0.0).expect("render")
    };
    let covered = covered_by(albedo);
    let in_scattered = covered_by([0.0; 3]);
    let (mut darkest, mut brightest) = (f64::MAX, 0.0f64);
    let mut worst = 0.0f64;
    for py in 0..h {
        for px in 0..w {
            let k = (py * w + px) as usize;
            let rho = terrain_albedo_at_pixel(&scene, w, h, px, py);
            let received = |image: &HdrImage, c: usize, albedo: f64| {
                (image.pixels[k][c] - in_scattered.pixels[k][c]) as f64 / albedo
            };
            let terrain = [0, 1, 2].map(|c| received(&bare, c, rho[c]));
            let object = [0, 1, 2].map(|c| received(&covered, c, albedo[c]));
            let scale = terrain.iter().cloned().fold(1e-9, f64::max);
            for c in 0..3 {
                worst = worst.max((terrain[c] - object[c]).abs() / scale);
            }
            darkest = darkest.min(terrain[1]);
            brightest = brightest.max(terrain[1]);
        }
    }
    // The view must hold both shadowed and sunlit ground for the test to mean anything.
    assert!(
        brightest > 2.0 * darkest,
        "no cloud shadow in view: light received {darkest}..{brightest}"
    );
    // The CPU's filtering of the 8-bit albedo map against the GPU sampler's
    // reduced precision, and half-float targets: 2 %, as for the terrain.
    assert!(
        worst < 0.02,
        "worst relative object/terrain difference {worst}"
    );
}

#[test]
fn box_faces_receive_the_sun_at_their_angle() {
    // Under an empty atmosphere (no scattering or absorption, no ground
    // bounce) a face is lit by the sun alone: L = ρ/π · E₀ · cos θ. A wall
    // facing east, seen from the east, under a sun in the east 30° high:
    // cos θ = cos 30°. The same wall made by turning a box a quarter turn
    // anticlockwise (its +Z face then looks east) must look the same.
    // A black ground: nothing reflected onto the wall from below.
    let mut scene = flat_scene([0.0; 3]);
    scene.terrain.albedo.water = [0.0; 3];
    scene.atmosphere.rayleigh_scattering_per_m = [0.0; 3];
    scene.atmosphere.aerosol_optical_depth = 0.0;
    scene.atmosphere.ozone_absorption_per_m = [0.0; 3];
    scene.atmosphere.ground_albedo = [0.0; 3];
    scene.sun.azimuth_deg = Some(90.0);
    scene.sun.elevation_deg = Some(30.0);
    scene.camera.position_m = [200.0, 50.0, 0.0];
    scene.camera.yaw_deg = Some(270.0);
    scene.camera.pitch_deg = Some(0.0);
    scene.camera.fov_deg = 20.0;
    scene.camera.exposure_ev100 = 16.0;
    let albedo = [0.6, 0.4, 0.2];
    let irradiance = solar_irradiance_top();
    let cos_theta = 30f64.to_radians().cos();
    let (w, h) = (16, 16);
    let mut gpu = headless();
    for (size, yaw) in [([20.0, 100.0, 400.0], 0.0), ([400.0, 100.0, 20.0], 90.0)] {
        scene.objects = vec![SceneObject::new_box([0.0, 50.0, 0.0], size, yaw, albedo)];
        let image = gpu.render_hdr(&scene, w, h, 0.0).expect("render");
        for py in 6..10 {
            for px in 6..10 {
                let gpu_radiance = image.pixels[(py * w + px) as usize];
                for k in 0..3 {
                    let cpu = albedo[k] / std::f64::consts::PI * irradiance[k] as f64 * cos_theta;
                    let error = (gpu_radiance[k] as f64 - cpu).abs() / cpu;
                    assert!(
                        error < 0.01,
                        "yaw {yaw}: pixel ({px}, {py}) channel {k}: {} vs {cpu}",
                        gpu_radiance[k]
                    );
                }
            }
        }
    }
}

#[test]
fn the_objects_pass_rebuilds_only_when_the_objects_change() {
    let mut scene = flat_scene([0.2; 3]);
    let mut gpu = headless();
    gpu.render_frame(&scene, 32, 32, 0.0).expect("render");
    let objects = gpu.renderer.objects();
    assert!(objects.occluder_geometry().is_none() && objects.world_bounds_m().is_none());
    assert_eq!(objects.generation(), 0);
    // The terrain's occluders: its whole grid, position first.
    let terrain = gpu.renderer.terrain().occluder_geometry().expect("terrain");
    assert_eq!(terrain.index_count, 64 * 64 * 6);
    assert_eq!(terrain.vertex_stride, 32);

    scene.objects = vec![
        SceneObject::new_box([10.0, 1.0, -5.0], [2.0, 2.0, 4.0], 0.0, [0.5; 3]),
        SceneObject::new_box([-3.0, 0.5, 7.0], [1.0, 1.0, 1.0], 0.0, [0.5; 3]),
    ];
    gpu.render_frame(&scene, 32, 32, 0.0).expect("render");
    let objects = gpu.renderer.objects();
    let generation = objects.generation();
    assert!(generation > 0);
    let occluders = objects.occluder_geometry().expect("objects");
    assert_eq!((occluders.index_count, occluders.vertex_stride), (72, 36));
    assert_eq!(
        objects.world_bounds_m(),
        Some(([-3.5, 0.0, -7.0], [11.0, 2.0, 7.5]))
    );
    // Unchanged objects (the sun moved): nothing is rebuilt.
    scene.sun.elevation_deg = Some(10.0);
    scene.sun.azimuth_deg = Some(100.0);
    gpu.render_frame(&scene, 32, 32, 0.0).expect("render");
    assert_eq!(gpu.renderer.objects().generation(), generation);
    // A changed object: rebuilt.
    scene.objects[1].albedo = [0.1; 3];
    gpu.render_frame(&scene, 32, 32, 0.0).expect("render");
    let rebuilt = gpu.renderer.objects().generation();
    assert!(rebuilt > generation);
    // No objects: no buffers, and the change shows in the generation.
    scene.objects.clear();
    gpu.render_frame(&scene, 32, 32, 0.0).expect("render");
    let objects = gpu.renderer.objects();
    assert!(objects.occluder_geometry().is_none() && objects.generation() > rebuilt);
}

#[test]
fn a_glb_deleted_after_loading_fails_the_frame_with_a_typed_error() {
    // The scene validated with its file present; the file is gone when the
    // frame is prepared: an error naming the object and the path, no panic.
    let dir = std::env::temp_dir().join(format!("nimbus-objects-gpu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let shed =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/assets/shed.gltf");
    std::fs::copy(&shed, dir.join("shed.gltf")).expect("copy");
    let text = "[[objects]]\nkind = \"mesh\"\ngltf = \"shed.gltf\"\nposition_m = [0.0, 0.0, 0.0]\n";
    let scene =
        Scene::from_toml_str_in(text, "s.toml", Some(&dir)).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_file(dir.join("shed.gltf")).expect("remove");
    let err = headless()
        .render_frame(&scene, 16, 16, 0.0)
        .expect_err("file gone")
        .to_string();
    assert!(
        err.contains("objects[0].gltf = \"shed.gltf\": cannot read"),
        "{err}"
    );
}

#[test]
fn a_gltf_rewritten_after_loading_is_read_again() {
    // The viewer keeps its scene while the user re-exports a mesh: the
    // objects pass notices the file's new stamp and rebuilds.
    let dir = std::env::temp_dir().join(format!("nimbus-objects-reread-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let shed = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/assets/shed.gltf"),
    )
    .expect("shed");
    std::fs::write(dir.join("mesh.gltf"), &shed).expect("write");
    let text = "[[objects]]\nkind = \"mesh\"\ngltf = \"mesh.gltf\"\nposition_m = [0.0, 0.0, 0.0]\n";
    let scene =
        Scene::from_toml_str_in(text, "s.toml", Some(&dir)).unwrap_or_else(|e| panic!("{e}"));
    let mut gpu = headless();
    gpu.render_frame(&scene, 16, 16, 0.0).expect("render");
    let (generation, (_, high)) = {
        let objects = gpu.renderer.objects();
        (
            objects.generation(),
            objects.world_bounds_m().expect("bounds"),
        )
    };
    gpu.render_frame(&scene, 16, 16, 0.0).expect("render");
    assert_eq!(
        gpu.renderer.objects().generation(),
        generation,
        "unchanged file"
    );
    // The same shed, its root node scaled twice (a longer file).
    let doubled = shed.replacen("\"children\"", "\"scale\":[2.0,2.0,2.0],\"children\"", 1);
    assert_ne!(doubled, shed);
    std::fs::write(dir.join("mesh.gltf"), &doubled).expect("rewrite");
    gpu.render_frame(&scene, 16, 16, 0.0).expect("render");
    let objects = gpu.renderer.objects();
    assert!(objects.generation() > generation);
    let (_, doubled_high) = objects.world_bounds_m().expect("bounds");
    assert!(
        (doubled_high[1] - 2.0 * high[1]).abs() < 1e-4,
        "{doubled_high:?} vs {high:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
