//! nimbus inside a caller's frame (issue 26): the caller's view in any
//! projection and depth convention, and `LinearHdr` output composited over
//! the caller's colour by its depth.

use glam::{DMat4, DVec3};
use nimbus_physics::terrain::AlbedoMap;
use nimbus_render::frame::Camera;
use nimbus_render::headless::{HeadlessRenderer, read_texture};
use nimbus_render::scene::GroundAlbedoMap;
use nimbus_render::targets::Target;
use nimbus_render::{
    AdapterPreference, DepthConvention, FrameTargets, Precompute, Projection, Renderer,
    RendererDescriptor, Scene, TargetLoad, View,
};

use crate::support::{self, DepthRect};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 36;

fn headless() -> HeadlessRenderer {
    HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter (lavapipe in CI)")
}

/// The default scene without its rain (whose drops two renderers would
/// simulate separately), with a fixed exposure.
fn scene() -> Scene {
    let mut scene = Scene::embedded_default();
    scene.rain = None;
    scene.keyframes.clear();
    scene.camera.auto_exposure = false;
    scene
}

/// A caller's HDR colour target filled with one value per pixel.
fn caller_colour(h: &HeadlessRenderer, pixels: &[[f32; 4]]) -> Target {
    let target = Target::new(
        &h.gpu.device,
        "caller colour",
        wgpu::TextureFormat::Rgba16Float,
        WIDTH,
        HEIGHT,
        wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
    );
    let halves: Vec<half::f16> = pixels
        .iter()
        .flatten()
        .map(|v| half::f16::from_f32(*v))
        .collect();
    write(h, &target.texture, bytemuck::cast_slice(&halves), 8);
    target
}

/// A caller's depth buffer cleared to `far_depth`, and when given, a wall
/// covering the lower half of the image at depth `wall_depth`.
fn caller_depth(h: &HeadlessRenderer, far_depth: f32, wall_depth: Option<f32>) -> Target {
    let wall = wall_depth.map(|depth| DepthRect {
        ndc: [-1.0, -1.0, 1.0, 0.0],
        depth,
    });
    support::caller_depth(h, WIDTH, HEIGHT, far_depth, wall)
}

fn write(h: &HeadlessRenderer, texture: &wgpu::Texture, bytes: &[u8], bytes_per_pixel: u32) {
    h.gpu.queue.write_texture(
        texture.as_image_copy(),
        bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(WIDTH * bytes_per_pixel),
            rows_per_image: None,
        },
        texture.size(),
    );
}

/// Renders `scene` seen by `view` in `LinearHdr` over the caller's targets
/// and returns the caller's colour afterwards.
fn render_linear(
    h: &HeadlessRenderer,
    renderer: &mut Renderer,
    scene: &Scene,
    view: &View,
    colour: &Target,
    depth: &Target,
) -> Vec<[f32; 4]> {
    renderer
        .prepare_view(scene, view, WIDTH, HEIGHT, 0.0)
        .expect("prepare");
    let mut encoder = h.gpu.device.create_command_encoder(&Default::default());
    renderer.encode(
        &mut encoder,
        &FrameTargets {
            output: &colour.view,
            depth: &depth.view,
            load: TargetLoad::Keep,
        },
    );
    h.gpu.queue.submit([encoder.finish()]);
    let bytes = read_texture(&h.gpu, &colour.texture, 8).expect("readback");
    let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
    halves
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]].map(half::f16::to_f32))
        .collect()
}

fn linear_renderer(h: &HeadlessRenderer) -> Renderer {
    Renderer::new(
        &h.gpu.device,
        &h.gpu.queue,
        &RendererDescriptor::linear_hdr(wgpu::TextureFormat::Rgba16Float)
            .with_precompute(Precompute::Blocking),
    )
}

/// The scene camera's view in the other depth convention with a finite
/// far plane: the caller's depth must be translated for anything to match.
fn standard_depth_view(scene: &Scene) -> View {
    let camera = Camera::from_settings(&scene.camera, WIDTH, HEIGHT);
    let mut view = View::from_camera(&camera);
    view.projection = Projection::Perspective {
        fov_y_rad: camera.fov_y_rad,
        aspect: camera.aspect,
        near_m: 0.5,
        far_m: Some(50_000.0),
    };
    view.depth = DepthConvention::Standard;
    view
}

fn relative_difference(a: [f32; 3], b: [f32; 3]) -> f32 {
    let scale = a.iter().chain(&b).fold(1e-3f32, |m, v| m.max(v.abs()));
    (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max) / scale
}

#[test]
fn linear_hdr_output_is_the_display_paths_radiance_before_tone_mapping() {
    let mut h = headless();
    let scene = scene();
    let display = h.render_hdr(&scene, WIDTH, HEIGHT, 0.0).expect("display");
    let pre_exposure = 1e-3;
    let mut renderer = linear_renderer(&h);
    renderer.set_pre_exposure(pre_exposure);
    let view = standard_depth_view(&scene);
    // The caller drew nothing: black, transparent, depth at its far plane (1).
    let colour = caller_colour(&h, &vec![[0.0; 4]; (WIDTH * HEIGHT) as usize]);
    let depth = caller_depth(&h, 1.0, None);
    let linear = render_linear(&h, &mut renderer, &scene, &view, &colour, &depth);
    let mut worst = 0.0f32;
    for (d, l) in display.pixels.iter().zip(&linear) {
        let radiance = [l[0], l[1], l[2]].map(|v| v / pre_exposure);
        worst = worst.max(relative_difference(*d, radiance));
    }
    // Half-float storage at two exposures: 2⁻¹⁰ relative each.
    assert!(worst < 4e-3, "largest relative difference {worst}");
}

#[test]
fn caller_surfaces_keep_their_colour_and_hide_the_sky() {
    let h = headless();
    let mut scene = scene();
    // No air in front of the caller's surfaces: they must come back untouched.
    scene.camera.aerial_perspective = false;
    let view = standard_depth_view(&scene);
    // The caller's wall 30 m ahead over the lower half of the image, its
    // depth in the standard convention; the upper half left at the far plane.
    let wall_depth = {
        let clip = view.caller_clip_from_view() * glam::DVec4::new(0.0, 0.0, -30.0, 1.0);
        (clip.z / clip.w) as f32
    };
    let wall = [0.25f32, 0.5, 0.75, 1.0];
    let lower = |i: usize| i / WIDTH as usize >= HEIGHT as usize / 2;
    let count = (WIDTH * HEIGHT) as usize;
    let colours: Vec<[f32; 4]> = (0..count)
        .map(|i| if lower(i) { wall } else { [0.0; 4] })
        .collect();
    let colour = caller_colour(&h, &colours);
    let depth = caller_depth(&h, 1.0, Some(wall_depth));
    let mut renderer = linear_renderer(&h);
    renderer.set_pre_exposure(1e-3);
    let out = render_linear(&h, &mut renderer, &scene, &view, &colour, &depth);
    for (i, p) in out.iter().enumerate() {
        if lower(i) {
            // Nothing of nimbus's lies nearer than 30 m here.
            assert_eq!(
                *p,
                wall.map(|v| half::f16::from_f32(v).to_f32()),
                "pixel {i}"
            );
        } else {
            // The sky (or clouds), opaque.
            assert!(p[0] > 0.0 && p[2] > 0.0 && p[3] == 1.0, "pixel {i}: {p:?}");
        }
    }

    // With the air: the wall is seen through it, slightly veiled but still itself.
    scene.camera.aerial_perspective = true;
    let colour = caller_colour(&h, &colours);
    let veiled = render_linear(&h, &mut renderer, &scene, &view, &colour, &depth);
    let i = count - WIDTH as usize / 2;
    let p = veiled[i];
    assert!(p != wall.map(|v| half::f16::from_f32(v).to_f32()), "{p:?}");
    for c in 0..3 {
        assert!((p[c] - wall[c]).abs() < 0.05 * wall[c], "{p:?}");
    }
}

#[test]
fn linear_hdr_refuses_a_display_format_with_one_line() {
    let h = headless();
    let mut renderer = Renderer::new(
        &h.gpu.device,
        &h.gpu.queue,
        &RendererDescriptor::linear_hdr(wgpu::TextureFormat::Rgba8Unorm),
    );
    let scene = scene();
    let view = standard_depth_view(&scene);
    let error = renderer
        .prepare_view(&scene, &view, WIDTH, HEIGHT, 0.0)
        .expect_err("refused")
        .to_string();
    assert!(
        error.contains("Rgba8Unorm") && error.contains("Rgba16Float"),
        "{error}"
    );
    assert!(!error.contains('\n'));
}

/// Renders with the Display path seen by `view` and returns radiance and
/// nimbus's depth.
fn render_view(h: &mut HeadlessRenderer, scene: &Scene, view: &View) -> (Vec<[f32; 3]>, Vec<f32>) {
    let (image, depth) = h
        .render_view(scene, view, WIDTH, HEIGHT, 0.0)
        .expect("render");
    (image.pixels, depth)
}

#[test]
fn a_view_from_above_matches_the_scene_cameras() {
    let mut h = headless();
    let mut scene = scene();
    // As steep as a scene file allows (−89°), heading east.
    scene.camera.position_m = [300.0, 2600.0, -200.0];
    scene.camera.look_at_m = None;
    scene.camera.yaw_deg = Some(90.0);
    scene.camera.pitch_deg = Some(-89.0);
    scene.camera.fov_deg = 70.0;
    let from_scene = h
        .render_hdr(&scene, WIDTH, HEIGHT, 0.0)
        .expect("scene camera");
    // The same view built by a caller from its own pose.
    let eye = DVec3::from_array(scene.camera.position_m);
    let forward = nimbus_render::frame::direction_from_yaw_pitch(90.0, -89.0);
    let up = (DVec3::Y - forward * forward.y).normalize();
    let view = View::perspective(
        eye,
        forward,
        up,
        70f64.to_radians(),
        f64::from(WIDTH) / f64::from(HEIGHT),
        0.5,
    );
    let (radiance, _) = render_view(&mut h, &scene, &view);
    let mut worst = 0.0f32;
    for (a, b) in from_scene.pixels.iter().zip(&radiance) {
        worst = worst.max(relative_difference(*a, *b));
    }
    assert!(worst < 1e-2, "largest relative difference {worst}");

    // Straight down, which a scene file cannot express: drawn, and close to
    // the −89° view at the image centre.
    let straight_down = View::perspective(
        eye,
        DVec3::NEG_Y,
        DVec3::X,
        70f64.to_radians(),
        f64::from(WIDTH) / f64::from(HEIGHT),
        0.5,
    );
    let (down, _) = render_view(&mut h, &scene, &straight_down);
    assert!(down.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    let centre = (HEIGHT / 2 * WIDTH + WIDTH / 2) as usize;
    assert!(relative_difference(down[centre], radiance[centre]) < 0.2);
}

#[test]
fn an_orthographic_view_from_above_sees_the_ground_everywhere_with_parallel_rays() {
    let mut h = headless();
    let mut scene = scene();
    scene.stratus = None;
    scene.cumulus = None;
    // A map of a 4 km × 2.25 km patch from 5 km up, north at the top.
    let view = View {
        world_from_view: DMat4::look_to_rh(
            DVec3::new(0.0, 5000.0, 0.0),
            DVec3::NEG_Y,
            DVec3::NEG_Z,
        )
        .inverse(),
        projection: Projection::Orthographic {
            height_m: 2250.0,
            aspect: f64::from(WIDTH) / f64::from(HEIGHT),
            near_m: 0.0,
            far_m: 10_000.0,
        },
        depth: DepthConvention::Reverse,
    };
    let (radiance, depth) = render_view(&mut h, &scene, &view);
    assert!(
        radiance
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
    // Every pixel is ground or water (no sky), and nimbus's orthographic
    // reverse-Z depth gives each one's height: 1 at the near plane (5 km up).
    for (i, d) in depth.iter().enumerate() {
        let height_m = 5000.0 - (1.0 - f64::from(*d)) * 10_000.0;
        assert!(
            (-1.0..1500.0).contains(&height_m),
            "pixel {i}: depth {d}, height {height_m}"
        );
    }
    // Parallel rays: open water (the same flat surface, same view angle)
    // looks the same wherever it is in the image, unlike in a wide perspective.
    let water: Vec<f32> = radiance
        .iter()
        .zip(&depth)
        .filter(|(_, d)| (5000.0 - (1.0 - f64::from(**d)) * 10_000.0).abs() < 0.5)
        .map(|(p, _)| p[1])
        .collect();
    if water.len() >= 2 {
        let (lo, hi) = water
            .iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        assert!(hi - lo <= 0.2 * hi, "water from {lo} to {hi}");
    }
}

#[test]
fn a_view_that_cannot_be_drawn_is_refused_with_one_line() {
    let mut h = headless();
    let scene = scene();
    let mut view = standard_depth_view(&scene);
    view.projection = Projection::Perspective {
        fov_y_rad: 1.0,
        aspect: 1.0,
        near_m: 10.0,
        far_m: Some(5.0),
    };
    let error = h
        .render_view(&scene, &view, WIDTH, HEIGHT, 0.0)
        .expect_err("refused")
        .to_string();
    assert!(error.contains("far_m = 5"), "{error}");
}

#[test]
fn without_terrain_nothing_is_drawn_below_and_the_flat_grounds_albedo_lights_the_layer() {
    let mut h = headless();
    let mut scene = scene();
    scene.cumulus = None;
    // Looking down from 150 m over the coast: the terrain fills the lower image.
    scene.camera.position_m = [-6500.0, 150.0, 2600.0];
    scene.camera.look_at_m = None;
    scene.camera.yaw_deg = Some(0.0);
    scene.camera.pitch_deg = Some(-30.0);
    let camera = Camera::from_settings(&scene.camera, WIDTH, HEIGHT);
    let (_, with_terrain) = render_view(&mut h, &scene, &View::from_camera(&camera));
    assert!(with_terrain.iter().filter(|d| **d > 0.0).count() > (WIDTH * HEIGHT / 2) as usize);
    scene.ground.terrain = false;
    let (radiance, without) = render_view(&mut h, &scene, &View::from_camera(&camera));
    assert!(
        without.iter().all(|d| *d == 0.0),
        "something was drawn at a depth"
    );
    assert!(radiance.iter().flatten().all(|v| v.is_finite()));

    // Under the layer, looking up: its base is brighter over a bright ground
    // (ground–cloud radiosity, Bouthors et al. 2006 §5), with no terrain drawn.
    scene.camera.pitch_deg = Some(40.0);
    let mean_luminance = |pixels: &[[f32; 3]]| {
        pixels
            .iter()
            .map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])
            .sum::<f32>()
            / pixels.len() as f32
    };
    let mut base = |albedo: f64| {
        scene.ground.albedo = [albedo; 3];
        let image = h.render_hdr(&scene, WIDTH, HEIGHT, 0.0).expect("render");
        mean_luminance(&image.pixels)
    };
    let (dark, bright) = (base(0.05), base(0.9));
    assert!(
        bright > 1.1 * dark,
        "base over albedo 0.9: {bright}, over 0.05: {dark}"
    );

    // The same through an albedo map (`ground.albedo_map`, given in code):
    // a uniform 0.9 map lights the base as the value 0.9 does, and a map
    // bright only far from here (its eastern eighth) as a dark ground does.
    scene.ground.albedo = [0.05; 3];
    let mut with_map = |texels: Vec<[f32; 3]>| {
        scene.ground.albedo_map = Some(GroundAlbedoMap::new(AlbedoMap {
            width: 8,
            height: 1,
            texels,
        }));
        let image = h.render_hdr(&scene, WIDTH, HEIGHT, 0.0).expect("render");
        mean_luminance(&image.pixels)
    };
    let uniform = with_map(vec![[0.9; 3]; 8]);
    let mut far_east = vec![[0.05; 3]; 8];
    far_east[7] = [0.9; 3];
    let far = with_map(far_east);
    assert!(
        (uniform - bright).abs() < 0.01 * bright,
        "uniform map {uniform} vs value {bright}"
    );
    assert!(
        far < dark + 0.2 * (bright - dark),
        "map bright far away {far}: dark ground {dark}, bright {bright}"
    );
    scene.ground.albedo_map = Some(GroundAlbedoMap::new(AlbedoMap {
        width: 2,
        height: 2,
        texels: vec![[0.5; 3]; 3],
    }));
    assert_eq!(
        scene.check().expect_err("3 texels for 2 × 2").to_string(),
        "scene: ground.albedo_map = 3 texels: width × height = 4"
    );
}

/// docs/embedding.md promises that a renderer can move to another thread.
#[test]
fn the_renderer_can_move_between_threads() {
    fn assert_send<T: Send>() {}
    assert_send::<Renderer>();
    assert_send::<View>();
}

/// The camera inside a cumulus (issue 44): the caller's surfaces are seen
/// through the cloud's fog in `LinearHdr` as on the display path: a wall
/// 60 m ahead in a core (visibility ~30 m after δ-M) is mostly hidden, one
/// 3 m ahead barely, and nimbus's alpha over it is the fog's opacity.
#[test]
fn a_caller_surface_inside_a_cloud_is_seen_through_its_fog() {
    let h = headless();
    let mut scene = Scene::from_toml_str(
        r#"
[camera]
position_m = [0.0, 1900.0, 0.0]
look_at_m = [1000.0, 1900.0, -500.0]
fov_deg = 60.0
aerial_perspective = false

[sun]
azimuth_deg = 165.0
elevation_deg = 35.0

[cumulus]
[[cumulus.clouds]]
position_m = [0.0, 1500.0, 0.0]
scale = 1.5
"#,
        "inside.toml",
    )
    .expect("scene");
    scene.camera.auto_exposure = false;
    let view = standard_depth_view(&scene);
    let wall_at = |distance_m: f64| {
        let clip = view.caller_clip_from_view() * glam::DVec4::new(0.0, 0.0, -distance_m, 1.0);
        (clip.z / clip.w) as f32
    };
    let wall = [0.25f32, 0.5, 0.75, 1.0];
    let lower = |i: usize| i / WIDTH as usize >= HEIGHT as usize / 2;
    let count = (WIDTH * HEIGHT) as usize;
    let colours: Vec<[f32; 4]> = (0..count)
        .map(|i| if lower(i) { wall } else { [0.0; 4] })
        .collect();
    let mut renderer = linear_renderer(&h);
    renderer.set_pre_exposure(1e-4);
    let veil = |distance_m: f64, renderer: &mut Renderer| -> f32 {
        let colour = caller_colour(&h, &colours);
        let depth = caller_depth(&h, 1.0, Some(wall_at(distance_m)));
        let out = render_linear(&h, renderer, &scene, &view, &colour, &depth);
        let i = count - WIDTH as usize / 2;
        relative_difference(
            [out[i][0], out[i][1], out[i][2]],
            [wall[0], wall[1], wall[2]],
        )
    };
    let near = veil(3.0, &mut renderer);
    let far = veil(60.0, &mut renderer);
    eprintln!("wall 3 m: {near:.3}, 60 m: {far:.3}");
    assert!(far > 0.5, "a wall 60 m into the cloud is veiled: {far}");
    assert!(near < 0.5 * far, "the nearer wall less: {near} vs {far}");
}
