//! The GPU rain simulation against its CPU reference
//! (nimbus_physics::rain::simulation), and its occlusion.

use nimbus_physics::rain::simulation::{Drop, DropState, StepInputs, step_drop};
use nimbus_render::frame::Camera;
use nimbus_render::gpu::AdapterPreference;
use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::rain::{
    DropGpu, SPLASH_CAPACITY, rain_box, rain_params, rain_zones, splash_slots, streak_in_view,
    visible_list,
};

use nimbus_render::scene::Scene;

use crate::support::{self, DepthRect};
use glam::{DMat4, DVec3};
use nimbus_render::{DepthConvention, OccluderDepth, Projection, View};

fn headless() -> HeadlessRenderer {
    HeadlessRenderer::new(AdapterPreference::Auto).unwrap_or_else(|e| {
        panic!("{e}: install a Vulkan driver (e.g. Debian's mesa-vulkan-drivers) to run GPU tests")
    })
}

/// The dispatched drops, in order of their ids, from every drops' buffer.
fn read_drops(h: &HeadlessRenderer) -> Vec<DropGpu> {
    let mut left = h.renderer.rain().dispatched_drops() as usize;
    let mut drops = Vec::with_capacity(left);
    for (buffer, held) in h.renderer.rain().drops_buffers() {
        let count = left.min(held as usize);
        drops.extend(
            h.read_buffer_elements::<DropGpu>(buffer, count)
                .expect("drops"),
        );
        left -= count;
    }
    assert_eq!(left, 0, "the buffers hold fewer drops than dispatched");
    drops
}

fn to_cpu(d: &DropGpu) -> Drop {
    Drop {
        position_m: d.position_m.into(),
        diameter_mm: d.diameter_mm,
        velocity_m_s: d.velocity_m_s.into(),
        state: DropState::from_u32(d.state),
    }
}

/// A rainy scene high above the terrain (nothing to hit), with gusty
/// wind: turbulence, a vortex and a gust front.
const GUSTY_RAIN: &str = r#"
[camera]
position_m = [0.0, 3000.0, 0.0]
yaw_deg = 30.0
[rain]
intensity_mm_h = 20.0
box_radius_m = 4.0
[wind]
speed_m_s = 6.0
from_deg = 250.0
[wind.turbulence]
rms_speed_m_s = 2.5
tile_m = 48.0
[[wind.primitives]]
kind = "vortex"
center_m = [1.0, 3000.0, -2.0]
axis = [0.0, 1.0, 0.0]
speed_m_s = 6.0
radius_m = 2.0
[[wind.primitives]]
kind = "gust_front"
axis = [1.0, 0.0, 0.0]
speed_m_s = 7.0
radius_m = 10.0
period_s = 6.0
front_speed_m_s = 12.0
"#;

#[test]
fn gpu_steps_match_the_cpu_reference() {
    let scene = Scene::from_toml_str(GUSTY_RAIN, "gusty.toml").expect("scene");
    gpu_steps_match_the_cpu_reference_in(&scene, None);
}

/// Millions of drops do not fit in one storage binding on most devices and
/// are split over several buffers; drops split over buffers of 4096 step
/// exactly as in one (their ids, which key the random numbers, run on
/// across the buffers).
#[test]
fn gpu_steps_match_the_cpu_reference_with_the_drops_split_over_buffers() {
    let scene = Scene::from_toml_str(GUSTY_RAIN, "gusty.toml").expect("scene");
    gpu_steps_match_the_cpu_reference_in(&scene, Some(4096));
}

/// The picture does not depend on how the drops are split over buffers:
/// the same drops are listed and drawn, only in another order.
#[test]
fn drops_split_over_buffers_draw_the_same_picture() {
    let mut scene = Scene::from_toml_str(GUSTY_RAIN, "gusty.toml").expect("scene");
    // Without mist, what the rain adds to the picture is the streaks.
    if let Some(rain) = scene.rain.as_mut() {
        rain.mist = false;
    }
    let mut dry_scene = scene.clone();
    dry_scene.rain = None;
    let mut h = headless();
    let time_s = |frame: u32| 20.0 + frame as f32 / 30.0;
    let mut render = |scene: &Scene, cap: Option<u32>| {
        h.renderer.rain_mut().set_drops_per_buffer_cap(cap);
        for frame in 0..3 {
            h.render_frame(scene, 160, 90, time_s(frame))
                .expect("frame");
        }
        let image = h.render_hdr(scene, 160, 90, time_s(3)).expect("image");
        (image.pixels, h.renderer.rain().drops_buffers().len())
    };
    let (whole, one) = render(&scene, None);
    let (split, several) = render(&scene, Some(2048));
    let (dry, _) = render(&dry_scene, None);
    assert_eq!(one, 1);
    assert!(several >= 4, "{several} buffers");
    // Summed over the image: the radiance the streaks add, and the
    // difference between the two splits.
    let total = |a: &[[f32; 3]], b: &[[f32; 3]]| -> f64 {
        a.iter()
            .zip(b)
            .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).abs() as f64).sum::<f64>())
            .sum()
    };
    let streaks = total(&whole, &dry);
    let difference = total(&whole, &split);
    println!("streaks add {streaks:.4e}; the splits differ by {difference:.4e}");
    assert!(streaks > 0.0);
    // The visibility lists and the splashes' ring keep the drops' order, and
    // the buffers are drawn in the order of their ids: the same streaks and
    // splashes blended in the same order, the same bits. (A buffer left out
    // or drawn twice would differ by a quarter of the streaks' sum.)
    assert_eq!(difference, 0.0, "the splits differ ({streaks} of streaks)");
}

/// A rainy scene high above the terrain in a wind field read from a file,
/// fixed to the ground: a shear and an updraft that vary along x, y and z
/// over a few metres, so that the drops in the box feel every axis of it.
#[test]
fn gpu_steps_match_the_cpu_reference_in_a_wind_field_from_a_file() {
    let dir = std::env::temp_dir().join(format!("nimbus-rain-field-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("field.npy");
    let cells = [6u32, 5, 4];
    write_wind_field(&file, cells);
    let scene = wind_field_scene(&file);
    let field = scene.wind_field().expect("wind field");
    assert_eq!(field.grid.as_ref().map(|g| g.cells), Some(cells));
    gpu_steps_match_the_cpu_reference_in(&scene, None);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The viewer keeps its scene while the user rewrites the wind field's
/// file: the rain notices the file's new stamp, reads it and starts anew.
#[test]
fn a_wind_field_file_rewritten_while_it_rains_is_read_again() {
    let dir = std::env::temp_dir().join(format!("nimbus-rain-reread-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("field.npy");
    write_wind_field(&file, [6, 5, 4]);
    let scene = wind_field_scene(&file);
    let mut h = headless();
    h.render_frame(&scene, 32, 18, 20.0).expect("first frame");
    assert!(placed_anew(&h));
    h.render_frame(&scene, 32, 18, 20.0 + 1.0 / 60.0)
        .expect("second frame");
    assert!(!placed_anew(&h), "the same file: the rain goes on");
    write_wind_field(&file, [4, 4, 4]);
    h.render_frame(&scene, 32, 18, 20.0 + 2.0 / 60.0)
        .expect("third frame");
    assert!(placed_anew(&h), "a rewritten file: the rain starts anew");
    // A file that no longer reads fails the frame with one line naming it.
    std::fs::write(&file, b"not a NumPy file").expect("spoil");
    let error = h
        .render_frame(&scene, 32, 18, 20.0 + 3.0 / 60.0)
        .expect_err("spoilt file")
        .to_string();
    assert!(
        error.contains("wind.field.file") && error.contains("field.npy"),
        "{error}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes a wind field of `cells` points that varies along every axis: a
/// shear and an updraft that vary over a few metres, so that the drops in a
/// 4 m box feel every axis of it.
fn write_wind_field(file: &std::path::Path, cells: [u32; 3]) {
    use nimbus_physics::rain::wind::WindGrid;
    let mut velocities_m_s = Vec::new();
    for z in 0..cells[2] {
        for y in 0..cells[1] {
            for x in 0..cells[0] {
                let (x, y, z) = (x as f32, y as f32, z as f32);
                velocities_m_s.push([
                    3.0 * (0.9 * y).sin(),
                    1.5 * (1.1 * x).cos(),
                    -2.0 + 0.7 * z,
                    0.0,
                ]);
            }
        }
    }
    let grid = WindGrid {
        cells,
        cell_m: 1.5,
        origin_m: glam::Vec3::ZERO,
        carried: false,
        velocities_m_s,
    };
    std::fs::write(file, grid.to_npy()).expect("field file");
}

/// Rain high above the terrain in the wind field of `file`, fixed to the ground.
fn wind_field_scene(file: &std::path::Path) -> Scene {
    let text = format!(
        "[camera]\nposition_m = [0.0, 3000.0, 0.0]\nyaw_deg = 30.0\n\
         [rain]\nintensity_mm_h = 20.0\nbox_radius_m = 4.0\n\
         [wind]\nspeed_m_s = 4.0\nfrom_deg = 200.0\n\
         [wind.field]\nfile = {:?}\ncell_m = 1.5\norigin_m = [0.5, 2998.0, -1.0]\n",
        file.display().to_string()
    );
    Scene::from_toml_str(&text, "field.toml").expect("scene")
}

fn gpu_steps_match_the_cpu_reference_in(scene: &Scene, drops_per_buffer: Option<u32>) {
    let mut h = headless();
    h.renderer
        .rain_mut()
        .set_drops_per_buffer_cap(drops_per_buffer);
    let (width, height) = (64, 36);
    let t0 = 20.0f32;
    h.render_frame(scene, width, height, t0)
        .expect("first frame");
    let before = read_drops(&h);
    assert!(before.len() > 10_000, "{} drops", before.len());
    if let Some(cap) = drops_per_buffer {
        let buffers = h.renderer.rain().drops_buffers();
        assert!(buffers.len() >= 3, "{} buffers", buffers.len());
        assert!(buffers.iter().all(|&(_, held)| held <= cap));
    }
    // The next frame, one and a half steps later, runs one or two steps.
    h.render_frame(scene, width, height, t0 + 1.5 * nimbus_render::rain::STEP_S)
        .expect("second frame");
    let after = read_drops(&h);
    let steps = h.renderer.rain().planned_steps().to_vec();
    assert!((1..=2).contains(&steps.len()), "{} steps", steps.len());
    let settings = scene.rain.clone().expect("rain");
    let camera = Camera::from_settings(&scene.camera, width, height);
    let wind = scene.wind_field().expect("wind");
    let zones = rain_zones(scene, &settings, t0 as f64, &[]);
    let inputs: Vec<StepInputs<'_>> = steps
        .iter()
        .map(|step| {
            let mut b = rain_box(&settings, &camera);
            b.center_m =
                glam::Vec3::new(step.box_center[0], step.box_center[1], step.box_center[2]);
            b.velocity_m_s = glam::Vec3::new(
                step.box_velocity[0],
                step.box_velocity[1],
                step.box_velocity[2],
            );
            StepInputs {
                params: rain_params(scene, &settings),
                rain_box: b,
                wind: &wind,
                zones: &zones,
                time_s: step.box_center[3],
                step: step.index[0],
                dt_s: step.box_velocity[3],
                ground_height_m: f32::NEG_INFINITY,
            }
        })
        .collect();
    let (mut mismatched, mut worst_position, mut worst_velocity) = (0usize, 0.0f32, 0.0f32);
    let mut states = [0usize; 4];
    for (id, (gpu_before, gpu_after)) in before.iter().zip(&after).enumerate() {
        let cpu = inputs.iter().fold(to_cpu(gpu_before), |drop, step| {
            step_drop(id as u32, drop, step).0
        });
        let gpu = to_cpu(gpu_after);
        states[gpu_after.state.min(3) as usize] += 1;
        if cpu.state != gpu.state {
            mismatched += 1;
            continue;
        }
        if cpu.state == DropState::Dead {
            continue;
        }
        worst_position = worst_position.max((cpu.position_m - gpu.position_m).length());
        worst_velocity = worst_velocity.max((cpu.velocity_m_s - gpu.velocity_m_s).length());
    }
    println!(
        "states {states:?}, mismatched {mismatched}, worst Δx {worst_position} m, Δv {worst_velocity} m/s"
    );
    // Every state is exercised: alive, leaving (crossing out), dead (above
    // the count or waiting to re-enter).
    assert!(states[1] > 1000 && states[2] > 0, "{states:?}");
    // f32 transcendental functions differ by a few ulps between CPU and
    // GPU; a drop exactly on the box's edge or a count threshold may go
    // either way.
    assert!(
        mismatched * 1000 <= before.len(),
        "{mismatched} of {} states differ",
        before.len()
    );
    assert!(worst_position < 1e-3, "{worst_position} m");
    assert!(worst_velocity < 1e-3, "{worst_velocity} m/s");
}

/// Drops in the region `[lo, hi]`, alive.
fn alive_in(drops: &[DropGpu], lo: [f32; 3], hi: [f32; 3]) -> usize {
    drops
        .iter()
        .filter(|d| {
            d.state == 1 && (0..3).all(|k| d.position_m[k] >= lo[k] && d.position_m[k] <= hi[k])
        })
        .count()
}

/// Drops of the shelter tests' rain box (the scene's own cap is 4 M): the
/// 10 m box then holds about 48 drops per m³, some 600 in each 13 m³
/// region counted below, where the assertions need tens (none under the
/// roof, more than 50 in the open); the GPU simulates and reads back a
/// twentieth of the drops.
const SHELTER_TEST_DROPS: u64 = 200_000;

#[test]
fn no_rain_falls_under_the_shelters_roof() {
    let mut h = headless();
    let path = std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/rain-shelter.toml"
    ));
    let mut scene = Scene::from_file(path).expect("scene");
    scene.rain.as_mut().expect("rain").max_drops = SHELTER_TEST_DROPS;
    // A few frames of rain (what is asserted is the drops, not the
    // picture: a small one).
    for frame in 0..4 {
        h.render_frame(&scene, 32, 18, 10.0 + frame as f32 / 30.0)
            .expect("frame");
    }
    let drops = read_drops(&h);
    // Under the roof (6 m × 4 m, underside 31.8 m, the ground at 28.8 m),
    // away from its edges where the slanting rain reaches in.
    let under = alive_in(&drops, [-5301.0, 29.8, 998.8], [-5298.0, 31.6, 1001.2]);
    // The same volume in the open, between the camera and the shelter.
    let open = alive_in(&drops, [-5301.0, 29.8, 1004.0], [-5298.0, 31.6, 1006.4]);
    assert_eq!(
        under, 0,
        "{under} drops under the roof ({open} in the open)"
    );
    assert!(open > 50, "{open} drops in the open");
}

/// Whether the last frame placed every drop anew.
fn placed_anew(h: &HeadlessRenderer) -> bool {
    h.renderer
        .rain()
        .planned_steps()
        .first()
        .is_some_and(|step| step.index[1] == 1)
}

/// Changing the intensity while it rains never makes drops pop in or out
/// (§4.2.2): no restart, the drops of the last frame go on where they were
/// (even when a higher count grows the buffers), and the count follows the
/// intensity gradually, drops dying or reviving only at the box's boundary.
#[test]
fn changing_the_intensity_keeps_the_drops() {
    let mut scene = Scene::from_toml_str(GUSTY_RAIN, "gusty.toml").expect("scene");
    let set_intensity = |scene: &mut Scene, i: f64| {
        scene.rain.as_mut().expect("rain").intensity_mm_h = i;
    };
    set_intensity(&mut scene, 1.0);
    let mut h = headless();
    let frame = |k: u32| 20.0 + k as f32 / 60.0;
    for k in 0..3 {
        h.render_frame(&scene, 32, 18, frame(k)).expect("frame");
    }
    let before = read_drops(&h);
    let buffers_before: u32 = h.renderer.rain().drops_buffers().iter().map(|b| b.1).sum();
    // Fifty times the intensity: several times the drops, larger buffers.
    set_intensity(&mut scene, 50.0);
    h.render_frame(&scene, 32, 18, frame(3)).expect("frame");
    assert!(!placed_anew(&h), "a new intensity restarted the rain");
    let buffers_after: u32 = h.renderer.rain().drops_buffers().iter().map(|b| b.1).sum();
    assert!(
        buffers_after > buffers_before,
        "{buffers_after} vs {buffers_before}"
    );
    let after = read_drops(&h);
    let alive = |drops: &[DropGpu]| drops.iter().filter(|d| d.state == 1).count();
    // The drops of the last frame moved by one frame's fall, no more.
    let (mut kept, mut was_alive) = (0usize, 0usize);
    for (a, b) in before.iter().zip(&after) {
        if a.state == 1 {
            was_alive += 1;
            let moved = (0..3)
                .map(|k| (a.position_m[k] - b.position_m[k]).powi(2))
                .sum::<f32>()
                .sqrt();
            kept += usize::from(b.state == 1 && moved < 0.5);
        }
    }
    println!(
        "alive {} → {}; {kept} of {was_alive} kept their place",
        alive(&before),
        alive(&after)
    );
    assert!(
        kept as f64 >= 0.95 * was_alive as f64,
        "{kept} of {was_alive}"
    );
    // The count rises at the rain's pace, not at once.
    assert!(
        (alive(&after) as f64) < 1.2 * alive(&before) as f64,
        "{} → {}",
        alive(&before),
        alive(&after)
    );
    // Falling back: no restart, and the drops die only as they leave.
    set_intensity(&mut scene, 1.0);
    let before = after;
    h.render_frame(&scene, 32, 18, frame(4)).expect("frame");
    assert!(!placed_anew(&h));
    let after = read_drops(&h);
    assert!(
        alive(&after) as f64 > 0.9 * alive(&before) as f64,
        "{} → {}",
        alive(&before),
        alive(&after)
    );
}

/// Keyframed wind changes the wind at every frame: the rain goes on.
#[test]
fn keyframed_wind_does_not_restart_the_rain() {
    let text = format!(
        "{GUSTY_RAIN}\n[[keyframes]]\ntime_s = 0.0\nwind_speed_m_s = 2.0\n\
         [[keyframes]]\ntime_s = 60.0\nwind_speed_m_s = 12.0\n"
    );
    let scene = Scene::from_toml_str(&text, "keyed.toml").expect("scene");
    let mut h = headless();
    let mut means = Vec::new();
    for k in 0..4 {
        let t = 20.0 + k as f64 / 30.0;
        h.render_frame(&scene.at_time(t), 32, 18, t as f32)
            .expect("frame");
        assert_eq!(placed_anew(&h), k == 0, "frame {k}");
        means.push(scene.at_time(t).wind_field().expect("wind").mean_m_s);
    }
    assert!(means[3].length() > means[0].length());
}

/// Rain under drifting stratus: the zone map follows the layer.
#[test]
fn rain_zones_follow_the_drifting_clouds() {
    let text = "[camera]\nposition_m = [0.0, 300.0, 0.0]\n\
                [stratus]\nbase_m = 900.0\nthickness_m = 400.0\ncoverage = 0.5\n\
                [rain]\nintensity_mm_h = 5.0\nbox_radius_m = 3.0\nunder_clouds = true\n\
                [wind]\nspeed_m_s = 15.0\nfrom_deg = 270.0\n";
    let scene = Scene::from_toml_str(text, "zones.toml").expect("scene");
    let settings = scene.rain.clone().expect("rain");
    let mut h = headless();
    h.render_frame(&scene, 32, 18, 10.0).expect("frame");
    let first = h.renderer.rain().zones().expect("zones").clone();
    assert_eq!(first, rain_zones(&scene, &settings, 10.0, &[]));
    // A minute later the layer has moved 900 m: the map with it, the rain
    // not restarted (the camera stayed, time went on).
    h.render_frame(&scene, 32, 18, 70.0).expect("frame");
    assert!(!placed_anew(&h));
    let later = h.renderer.rain().zones().expect("zones").clone();
    assert_ne!(later, first);
    assert_eq!(later, rain_zones(&scene, &settings, 70.0, &[]));
    let raining =
        |z: &nimbus_physics::rain::zones::RainZones| z.factors.iter().filter(|&&f| f > 0.5).count();
    assert!(raining(&first) > 100 && raining(&first) < first.factors.len() - 100);
}

/// The caller's geometry stops the rain as `[[objects]]` do: the shelter
/// scene without its objects rains under where the roof was, and with the
/// roof given as the caller's two triangles (`Renderer::set_occluders`) no
/// drop falls there; malformed input is a one-line error.
#[test]
fn the_callers_occluders_stop_the_rain() {
    let path = std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/rain-shelter.toml"
    ));
    let mut scene = Scene::from_file(path).expect("scene");
    scene.objects.clear();
    scene.rain.as_mut().expect("rain").max_drops = SHELTER_TEST_DROPS;
    let under_the_roof = |h: &mut HeadlessRenderer| {
        // What is asserted is the drops, not the picture: a small one.
        for frame in 0..4 {
            h.render_frame(&scene, 32, 18, 10.0 + frame as f32 / 30.0)
                .expect("frame");
        }
        let drops = read_drops(h);
        (
            alive_in(&drops, [-5301.0, 29.8, 998.8], [-5298.0, 31.6, 1001.2]),
            alive_in(&drops, [-5301.0, 29.8, 1004.0], [-5298.0, 31.6, 1006.4]),
        )
    };
    let (bare, _) = under_the_roof(&mut headless());
    assert!(bare > 20, "{bare} drops where the roof was, without it");

    let mut h = headless();
    // The roof of scenes/rain-shelter.toml: 6 m × 4 m around (−5300, 1000), 31.81 m up.
    let y = 31.81;
    let roof = [
        [-5303.0, y, 998.0],
        [-5297.0, y, 998.0],
        [-5297.0, y, 1002.0],
        [-5303.0, y, 1002.0],
    ];
    h.renderer
        .set_occluders(&roof, &[0, 1, 2, 0, 2, 3])
        .expect("two triangles");
    let (under, open) = under_the_roof(&mut h);
    assert_eq!(
        under, 0,
        "{under} drops under the caller's roof ({open} in the open)"
    );
    assert!(open > 50, "{open} drops in the open");

    let error = h
        .renderer
        .set_occluders(&roof, &[0, 1, 7])
        .expect_err("index 7 of 4");
    assert_eq!(
        error.to_string(),
        "occluders: index 2 is 7: must be less than the 4 positions"
    );

    // The same roof as the caller's depth buffer seen from above
    // (`Renderer::set_occluder_depth`): a 40 m orthographic map from 100 m
    // up, standard depth, the roof drawn into it and nothing else.
    let mut h = headless();
    let above = View {
        world_from_view: DMat4::look_to_rh(
            DVec3::new(-5300.0, 100.0, 1000.0),
            DVec3::NEG_Y,
            DVec3::NEG_Z,
        )
        .inverse(),
        projection: Projection::Orthographic {
            height_m: 40.0,
            aspect: 1.0,
            near_m: 0.0,
            far_m: 200.0,
        },
        depth: DepthConvention::Standard,
    };
    let clip_from_world = above.caller_clip_from_view() * above.view_from_world();
    let ndc = |p: [f64; 3]| clip_from_world.project_point3(DVec3::from_array(p));
    let (a, b) = (ndc(roof[0].map(f64::from)), ndc(roof[2].map(f64::from)));
    let depth_map = support::caller_depth(
        &h,
        256,
        256,
        1.0,
        Some(DepthRect {
            ndc: [
                a.x.min(b.x) as f32,
                a.y.min(b.y) as f32,
                a.x.max(b.x) as f32,
                a.y.max(b.y) as f32,
            ],
            depth: a.z as f32,
        }),
    );
    h.renderer
        .set_occluder_depth(Some(OccluderDepth {
            depth: &depth_map.view,
            width: 256,
            height: 256,
            view: above,
        }))
        .expect("a depth from above");
    let (under, open) = under_the_roof(&mut h);
    assert_eq!(
        under, 0,
        "{under} drops under the roof of the caller's depth ({open} in the open)"
    );
    assert!(open > 50, "{open} drops in the open");
    let error = h
        .renderer
        .set_occluder_depth(Some(OccluderDepth {
            depth: &depth_map.view,
            width: 1,
            height: 256,
            view: above,
        }))
        .expect_err("one texel wide");
    assert_eq!(
        error.to_string(),
        "occluders: depth from above of 1 × 256 texels: must be at least 2 × 2"
    );
}

/// The rain scenes with golden images (`tests/integration/gpu.rs`).
const RAIN_GOLDEN_SCENES: [&str; 6] = [
    "rain-drizzle",
    "rain-heavy",
    "rain-crosswind",
    "rain-shelter",
    "rain-dark-background",
    "rain-bright-background",
];

fn scene_file(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(format!("{name}.toml"));
    Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Issue 28: the rain's picture is the same in every run. Two renderers
/// render each rain scene with a golden image in the same order at 64×36
/// and give the same bits of HDR radiance in the scene's first frame (the
/// drops placed anew, as time runs back to the scene's start, and stepped,
/// as the golden images are) and in the next (the rain going on). Before
/// the visibility list and the splashes' ring were filled in the drops'
/// order (they were filled by atomics, in the order the GPU ran the
/// invocations), 3–319 of the 2304 pixels differed between two runs on
/// llvmpipe in every scene but the bright background (where the streaks
/// barely show). (Two renderers for all the scenes rather than two per
/// scene: the same comparison, without ten more devices, pipelines and
/// terrains to build.)
#[test]
fn every_rain_golden_scene_renders_the_same_pixels_in_every_run() {
    let (width, height) = (64, 36);
    let times_s = [10.0, 10.0 + 1.0 / 30.0];
    let render = |h: &mut HeadlessRenderer, scene: &Scene| -> Vec<Vec<[f32; 3]>> {
        times_s
            .iter()
            .map(|&t| {
                let image = h.render_hdr(scene, width, height, t).expect("render");
                assert!(
                    t > times_s[0] || placed_anew(h),
                    "the scene's first frame places the drops anew"
                );
                image.pixels
            })
            .collect()
    };
    let (mut one, mut other) = (headless(), headless());
    let mut differences = Vec::new();
    for name in RAIN_GOLDEN_SCENES {
        let scene = scene_file(name);
        let (first, second) = (render(&mut one, &scene), render(&mut other, &scene));
        for (frame, (a, b)) in first.iter().zip(&second).enumerate() {
            let differing = a
                .iter()
                .zip(b)
                .filter(|(p, q)| p.map(f32::to_bits) != q.map(f32::to_bits))
                .count();
            if differing > 0 {
                differences.push(format!(
                    "{name} frame {frame}: {differing} of {} pixels",
                    a.len()
                ));
            }
        }
    }
    assert!(
        differences.is_empty(),
        "two runs differ: {}",
        differences.join("; ")
    );
}

/// The visibility list of each drops' buffer against its CPU twin
/// (`nimbus_render::rain::visible_list` over `streak_in_view`): the drops
/// whose streaks are in view, in increasing order, with the instance count
/// of the streaks' draw their number. The drops are split over buffers of
/// 4096 (a scan over runs of several workgroups would need 65 536 drops
/// per buffer; `visible_list`'s unit tests cover those with the same
/// arithmetic).
#[test]
fn the_visibility_lists_hold_the_drops_in_view_in_order() {
    let scene = Scene::from_toml_str(GUSTY_RAIN, "gusty.toml").expect("scene");
    let mut h = headless();
    h.renderer.rain_mut().set_drops_per_buffer_cap(Some(4096));
    let (width, height) = (64, 36);
    h.render_frame(&scene, width, height, 20.0).expect("frame");
    let drops = read_drops(&h);
    let settings = scene.rain.clone().expect("rain");
    let camera = Camera::from_settings(&scene.camera, width, height);
    let clip_from_world = View::from_camera(&camera)
        .nimbus_clip_from_world()
        .as_mat4();
    // The first frame starts the rain: the box has not moved.
    let in_view: Vec<bool> = drops
        .iter()
        .map(|d| {
            streak_in_view(
                d,
                clip_from_world,
                glam::Vec3::ZERO,
                settings.exposure_s as f32,
            )
        })
        .collect();
    let rain = h.renderer.rain();
    let args_buffer = rain.draw_arguments().expect("draw arguments");
    let lists = rain.visible_lists();
    let args: Vec<u32> = h
        .read_buffer_elements(args_buffer, (args_buffer.size() / 4) as usize)
        .expect("draw arguments");
    let (mut listed, mut mismatched, mut first) = (0usize, 0usize, 0usize);
    for ((visible, offset), (_, held)) in lists.iter().zip(rain.drops_buffers()) {
        let dispatched = drops.len().saturating_sub(first).min(held as usize);
        let count = args[*offset as usize / 4 + 1] as usize;
        assert_eq!(args[*offset as usize / 4], 6, "vertices per streak");
        let gpu: Vec<u32> = if count == 0 {
            Vec::new()
        } else {
            h.read_buffer_elements(visible, count).expect("list")
        };
        assert!(
            gpu.windows(2).all(|w| w[0] < w[1]),
            "a list out of the drops' order"
        );
        assert!(gpu.iter().all(|&i| (i as usize) < dispatched));
        let cpu = visible_list(&in_view[first..first + dispatched]);
        // f32 rounding may put a drop on the frustum's edge either way.
        let (gpu_set, cpu_set): (
            std::collections::BTreeSet<u32>,
            std::collections::BTreeSet<u32>,
        ) = (gpu.iter().copied().collect(), cpu.iter().copied().collect());
        mismatched += gpu_set.symmetric_difference(&cpu_set).count();
        listed += gpu.len();
        first += dispatched;
    }
    println!(
        "{listed} drops listed over {} buffers, {mismatched} differ from the CPU's",
        lists.len()
    );
    assert!(lists.len() >= 3, "{} buffers", lists.len());
    assert!(listed > 1000, "{listed} drops in view");
    assert!(mismatched * 1000 <= listed, "{mismatched} of {listed}");
}

/// Distance from `p` to the segment from `a` to `b`.
fn distance_to_segment(p: glam::Vec3, a: glam::Vec3, b: glam::Vec3) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
    (a + ab * t - p).length()
}

/// One step's splashes in the ring against the CPU twin of their placement
/// (`nimbus_render::rain::splash_slots`): the drops that hit cover in the
/// step (alive before, ghosts after) near the camera, in increasing order
/// of their ids over every drops' buffer, in the slots from the ring's head
/// on, each with its drop's velocity and diameter, the step's time, and a
/// point on the drop's path in the step. (Thousands of buffers would cost
/// lavapipe gigabytes of recorded commands: the test keeps to tens.)
#[test]
fn a_steps_splashes_fill_the_ring_in_the_order_of_the_drops() {
    let mut scene = scene_file("rain-shelter");
    // 150 000 drops in a 6 m box (of the 4 M the scene asks for in 10 m):
    // 19 buffers of 8192, a few hundred splashes a step near the camera.
    if let Some(rain) = scene.rain.as_mut() {
        rain.box_radius_m = 6.0;
        rain.max_drops = 150_000;
    }
    let settings = scene.rain.clone().expect("rain");
    let mut h = headless();
    h.renderer.rain_mut().set_drops_per_buffer_cap(Some(8192));
    let (width, height) = (64, 36);
    let t0 = 10.0f32;
    h.render_frame(&scene, width, height, t0)
        .expect("first frame");
    let before = read_drops(&h);
    let head = |h: &HeadlessRenderer| -> u32 {
        let (_, head) = h.renderer.rain().splash_ring().expect("ring");
        h.read_buffer(head).expect("head")
    };
    let head_before = head(&h);
    h.render_frame(
        &scene,
        width,
        height,
        t0 + 1.5 * nimbus_render::rain::STEP_S,
    )
    .expect("second frame");
    let steps = h.renderer.rain().planned_steps().to_vec();
    assert_eq!(steps.len(), 1, "one step");
    let step = steps[0];
    let after = read_drops(&h);
    let head_after = head(&h);
    let (ring_buffer, _) = h.renderer.rain().splash_ring().expect("ring");
    let ring: Vec<[f32; 8]> = h
        .read_buffer_elements(ring_buffer, SPLASH_CAPACITY as usize)
        .expect("ring");
    let centre = glam::Vec3::from_slice(&step.box_center[..3]);
    let dt = step.box_velocity[3];
    let radius = settings.splash_radius_m as f32;
    // The drops that hit cover in the step, each with its path in the step,
    // and whether its splash is surely near enough to be kept (the GPU
    // decides on the exact point of impact).
    let hits: Vec<(usize, glam::Vec3, glam::Vec3, bool)> = before
        .iter()
        .zip(&after)
        .enumerate()
        .filter(|(_, (b, a))| b.state == 1 && a.state == 3)
        .map(|(id, (_, a))| {
            let end = glam::Vec3::from(a.position_m);
            let start = end - glam::Vec3::from(a.velocity_m_s) * dt;
            let far = (start - centre).length().max((end - centre).length());
            (id, start, end, far < radius - 2e-3)
        })
        .filter(|&(_, start, end, _)| distance_to_segment(centre, start, end) <= radius + 2e-3)
        .collect();
    // Match the ring's new splashes to the hits, in order.
    let written = head_after.wrapping_sub(head_before) as usize;
    let mut splashed = vec![false; after.len()];
    let mut candidates = hits.iter();
    for k in 0..written {
        let record = ring[(head_before as usize + k) % SPLASH_CAPACITY as usize];
        let (id, start, end, _) = candidates
            .by_ref()
            .find(|(id, _, _, sure)| {
                let a = &after[*id];
                let matches = record[4..7] == a.velocity_m_s && record[7] == a.diameter_mm;
                assert!(
                    matches || !sure,
                    "splash {k}: drop {id}'s is missing or out of order"
                );
                matches
            })
            .unwrap_or_else(|| panic!("splash {k} matches no later hit"));
        let point = glam::Vec3::from_slice(&record[..3]);
        assert!(
            distance_to_segment(point, *start, *end) < 2e-3,
            "splash {k} of drop {id} at {point}, off its path {start} → {end}"
        );
        assert_eq!(record[3], step.box_center[3], "splash {k}'s time");
        splashed[*id] = true;
    }
    assert!(
        candidates.all(|(_, _, _, sure)| !sure),
        "a hit near the camera left no splash"
    );
    let (slots, new_head) = splash_slots(head_before, SPLASH_CAPACITY, &splashed);
    assert_eq!(new_head, head_after);
    for (id, slot) in slots {
        let record = ring[slot as usize];
        assert_eq!(record[4..7], after[id as usize].velocity_m_s, "drop {id}");
    }
    println!(
        "{written} splashes in the step ({} hits near the camera), head {head_before} → {head_after}",
        hits.len()
    );
    assert!(written > 20, "{written} splashes");
    assert!(h.renderer.rain().drops_buffers().len() >= 3);
}

/// A test kernel around the hemisphere moments: one (g, d_y) in; out the
/// (M₀, M₁) of Henyey–Greenstein and Cornette–Shanks of that g, and of
/// Rayleigh, and the deck's reflectance at optical depth 10(d_y + 1) and
/// asymmetry g.
const MOMENTS_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> moment_cases: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> moments: array<f32>;

@compute @workgroup_size(64)
fn moments_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&moment_cases)) {
        return;
    }
    let g = moment_cases[id.x].x;
    let d_y = moment_cases[id.x].y;
    let hg = hg_hemisphere_moments(g, d_y);
    let cs = cornette_shanks_hemisphere_moments(g, d_y);
    let rayleigh = rayleigh_hemisphere_moments(d_y);
    let base = mist_deck_reflectance(10.0 * (d_y + 1.0), g);
    let out = array<f32, 7>(hg.x, hg.y, cs.x, cs.y, rayleigh.x, rayleigh.y, base);
    for (var k = 0u; k < 7u; k++) {
        moments[7u * id.x + k] = out[k];
    }
}
";

/// The shaders' hemisphere moments of the mist's phase function and of the
/// air's equal the CPU twins' (`nimbus_physics::rain::mist_light` and
/// `nimbus_physics::atmosphere::under_layer`, themselves tested against
/// brute-force integration) at every elevation; so does the deck's
/// reflectance from below (`mist_deck_reflectance`).
#[test]
fn gpu_hemisphere_moments_match_the_cpu_twins() {
    use nimbus_physics::atmosphere::under_layer::{
        AEROSOL_MOMENT_SAMPLES, cornette_shanks_hemisphere_moments, rayleigh_hemisphere_moments,
    };
    use nimbus_physics::rain::mist_light::{
        MIST_MOMENT_SAMPLES, deck_diffuse_reflectance, hg_hemisphere_moments,
    };
    let h = headless();
    let cases: Vec<[f32; 2]> = [0.85f32, 0.8, 0.5, 0.0]
        .iter()
        .flat_map(|&g| (0..=40).map(move |k| [g, -1.0 + k as f32 / 20.0]))
        .collect();
    let source = nimbus_render::shader::HEMISPHERE_MOMENTS.source.to_owned() + MOMENTS_KERNEL;
    let gpu: Vec<f32> = crate::common::run_kernel(
        &h,
        &crate::common::Kernel {
            label: "hemisphere moments test",
            source: &source,
            entry: "moments_kernel",
            input: bytemuck::cast_slice(&cases),
            input_stride: 8,
            count: cases.len(),
            outputs_per_item: 7,
            extra: &[],
        },
    );
    for (case, m) in cases.iter().zip(gpu.chunks(7)) {
        let (g, d_y) = (f64::from(case[0]), f64::from(case[1]));
        let cpu = [
            hg_hemisphere_moments(g, d_y, MIST_MOMENT_SAMPLES),
            cornette_shanks_hemisphere_moments(g, d_y, AEROSOL_MOMENT_SAMPLES),
            rayleigh_hemisphere_moments(d_y),
        ];
        for (k, (name, (m0, m1))) in ["Henyey–Greenstein", "Cornette–Shanks", "Rayleigh"]
            .iter()
            .zip(cpu)
            .enumerate()
        {
            let (g0, g1) = (f64::from(m[2 * k]), f64::from(m[2 * k + 1]));
            assert!(
                (g0 - m0).abs() < 2e-4 && (g1 - m1).abs() < 2e-4,
                "{name}, g {g}, d_y {d_y}: GPU ({g0}, {g1}), CPU ({m0}, {m1})"
            );
        }
        let base = deck_diffuse_reflectance(10.0 * f64::from(case[1] + 1.0), g);
        assert!(
            (f64::from(m[6]) - base).abs() < 1e-5,
            "deck reflectance, g {g}, d_y {d_y}: GPU {}, CPU {base}",
            m[6]
        );
    }
}

/// A test kernel around the mist slab's source: one case (column optical
/// depth, height, view's vertical component, deck reflectance) in, the
/// source out for a ground of albedo (0.05, 0.3, 0.8), R_G (1, 2, 3), the
/// sun scattered in the column (0.5, 0.4, 0.3) and the sunlit ground's
/// exitance (0.1, 0.2, 0.3), the deck's light by the escape function for
/// even cases and uniform for odd ones.
const MIST_SLAB_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> slab_cases: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> slab_sources: array<f32>;

@compute @workgroup_size(64)
fn mist_slab_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&slab_cases)) {
        return;
    }
    let c = slab_cases[id.x];
    let s = mist_slab_source(c.x, c.y, c.z, vec3<f32>(0.05, 0.3, 0.8), c.w, (id.x & 1u) == 1u,
        vec3<f32>(1.0, 2.0, 3.0), vec3<f32>(0.5, 0.4, 0.3), vec3<f32>(0.1, 0.2, 0.3));
    slab_sources[3u * id.x] = s.x;
    slab_sources[3u * id.x + 1u] = s.y;
    slab_sources[3u * id.x + 2u] = s.z;
}
";

/// The mist shader's light from the slab's table (`mist_slab_source`,
/// passes/rain/mist_slab.wgsl) equals its CPU twin
/// (`nimbus_physics::rain::mist_slab::diffuse_source_in_mist`) over the
/// table's range and beyond it, between nodes and on them.
#[test]
fn gpu_mist_slab_source_matches_the_cpu_twin() {
    use nimbus_physics::rain::mist_slab::{
        DeckEmission, MIST_SLAB_TABLE, MistColumn, diffuse_source_in_mist,
    };
    use wgpu::util::DeviceExt;
    let h = headless();
    let device = &h.gpu.device;
    let mut cases: Vec<[f32; 4]> = Vec::new();
    for (i, tau) in [0.0f32, 0.05, 0.7, 3.86, 9.3, 16.0, 30.0]
        .iter()
        .enumerate()
    {
        for (j, height) in [0.0f32, 0.03, 0.41, 1.0].iter().enumerate() {
            for k in 0..=20 {
                let view_y = -1.0 + k as f32 / 10.0 + 0.013 * (i + j) as f32;
                cases.push([*tau, *height, view_y.min(1.0), 0.3 + 0.1 * j as f32]);
            }
        }
    }
    let table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("mist slab test table"),
        contents: bytemuck::cast_slice(&MIST_SLAB_TABLE),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("mist slab test"),
        entries: &[nimbus_render::binding::buffer_entry(
            5,
            wgpu::BufferBindingType::Storage { read_only: true },
            4,
            wgpu::ShaderStages::COMPUTE,
        )],
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("mist slab test"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 5,
            resource: table.as_entire_binding(),
        }],
    });
    let source = nimbus_render::rain::MIST_SLAB_WGSL.source.to_owned() + MIST_SLAB_KERNEL;
    let gpu: Vec<f32> = crate::common::run_kernel(
        &h,
        &crate::common::Kernel {
            label: "mist slab test",
            source: &source,
            entry: "mist_slab_kernel",
            input: bytemuck::cast_slice(&cases),
            input_stride: 16,
            count: cases.len(),
            outputs_per_item: 3,
            extra: &[crate::common::ExtraGroup {
                index: 1,
                layout: &layout,
                group: &group,
            }],
        },
    );
    let (rho, clear, sun, ground) = (
        [0.05, 0.3, 0.8],
        [1.0, 2.0, 3.0],
        [0.5, 0.4, 0.3],
        [0.1, 0.2, 0.3],
    );
    for (index, (case, s)) in cases.iter().zip(gpu.chunks(3)).enumerate() {
        for channel in 0..3 {
            let column = MistColumn {
                column_optical_depth: f64::from(case[0]),
                height_fraction: f64::from(case[1]),
                ground_albedo: rho[channel],
                deck_reflectance: f64::from(case[3]),
                emission: if index % 2 == 1 {
                    DeckEmission::Uniform
                } else {
                    DeckEmission::EscapeFunction
                },
                clear_column_w_m2: clear[channel],
                scattered_sun_w_m2: sun[channel],
                sunlit_ground_exitance_w_m2: ground[channel],
            };
            let cpu = diffuse_source_in_mist(&MIST_SLAB_TABLE, &column, f64::from(case[2]));
            let g = f64::from(s[channel]);
            assert!(
                (g - cpu).abs() < 1e-5 + 2e-5 * cpu.abs(),
                "case {case:?}, channel {channel}: GPU {g}, CPU {cpu}"
            );
        }
    }
}
