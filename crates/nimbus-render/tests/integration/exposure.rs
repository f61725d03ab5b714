//! Exposure: the GPU meter against its CPU reference, adaptation over time,
//! continuity of the sky as the sun crosses the horizon, and dithering that
//! keeps 8-bit gradients free of bands.

use nimbus_physics::photometry::luminance_cd_m2;
use nimbus_render::exposure::{METER_GRID, meter_pixel, metered_ev100};
use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::{AdapterPreference, Scene};

fn headless() -> HeadlessRenderer {
    HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

/// The embedded default scene with its cumulus shaded by the `fitted`
/// model: these tests sweep the sun, and the default `volume` model would
/// trace a sun cube per cloud for each new sun direction (~7 s each), which
/// the exposure does not depend on.
fn default_scene() -> Scene {
    use nimbus_physics::cumulus::shading::{CumulusShading, CumulusShadingModel};
    let mut scene = Scene::embedded_default();
    if let Some(cumulus) = &mut scene.cumulus {
        cumulus.shading = CumulusShading::of_model(CumulusShadingModel::Fitted);
    }
    scene
}

fn auto_scene(elevation_deg: f64) -> Scene {
    let mut scene = default_scene();
    scene.terrain.resolution = 64;
    scene.camera.auto_exposure = true;
    scene.camera.exposure_compensation_ev = 0.0;
    scene.sun.azimuth_deg = Some(140.0);
    scene.sun.elevation_deg = Some(elevation_deg);
    scene
}

#[test]
fn gpu_meter_matches_the_cpu_reference() {
    let mut h = headless();
    let (w, ht) = (96, 54);
    for elevation in [40.0, 3.0, -4.0] {
        let scene = auto_scene(elevation);
        let image = h.render_hdr(&scene, w, ht, 0.0).expect("render");
        let state = h.exposure_state().expect("state");
        let samples: Vec<[f64; 3]> = (0..METER_GRID * METER_GRID)
            .map(|k| {
                let (x, y) = meter_pixel(k % METER_GRID, k / METER_GRID, w, ht);
                image.pixels[(y * w + x) as usize].map(f64::from)
            })
            .collect();
        let cpu = metered_ev100(&samples);
        assert!(
            (state.ev100 as f64 - cpu).abs() < 0.02,
            "sun at {elevation}°: GPU EV {} vs CPU {cpu}",
            state.ev100
        );
    }
}

#[test]
fn manual_exposure_passes_through_and_compensation_brightens() {
    let mut h = headless();
    let mut scene = auto_scene(30.0);
    scene.camera.auto_exposure = false;
    scene.camera.exposure_ev100 = 13.25;
    h.render_frame(&scene, 32, 18, 0.0).expect("render");
    let state = h.exposure_state().expect("state");
    assert!(
        (state.ev100 - 13.25).abs() < 1e-4 && (state.tonemap_scale - 1.0).abs() < 1e-6,
        "{state:?}"
    );

    scene.camera.auto_exposure = true;
    h.render_frame(&scene, 32, 18, 0.0).expect("render");
    let metered = h.exposure_state().expect("state").ev100;
    scene.camera.exposure_compensation_ev = 1.5;
    h.render_frame(&scene, 32, 18, 0.0).expect("render");
    let compensated = h.exposure_state().expect("state").ev100;
    assert!(
        (metered - compensated - 1.5).abs() < 1e-3,
        "{metered} vs {compensated}"
    );
}

#[test]
fn automatic_exposure_adapts_with_the_time_constant() {
    // A bright frame at t = 0, then a twilight frame at t = 0.5 s with τ = 1 s:
    // the exposure moves 1 − e^{−0.5} = 39.3 % of the way to the new target.
    let mut h = headless();
    let bright = auto_scene(40.0);
    h.render_frame(&bright, 48, 27, 0.0).expect("render");
    let start = h.exposure_state().expect("state").ev100 as f64;
    let dark = auto_scene(-3.0);
    let mut fresh = headless();
    fresh.render_frame(&dark, 48, 27, 0.5).expect("render");
    let target = fresh.exposure_state().expect("state").ev100 as f64;
    h.render_frame(&dark, 48, 27, 0.5).expect("render");
    let adapted = h.exposure_state().expect("state").ev100 as f64;
    let expected = start + (target - start) * (1.0 - (-0.5f64).exp());
    assert!(
        target < start - 3.0,
        "twilight should need much more exposure: {start} → {target}"
    );
    assert!(
        (adapted - expected).abs() < 0.02,
        "adapted {adapted}, expected {expected}"
    );
}

#[test]
fn sky_is_continuous_and_finite_as_the_sun_crosses_the_horizon() {
    // Manual exposure, looking away from the sun: from +4° to −6° the mean
    // sky luminance must be finite and fall monotonically, by at most a factor
    // 2.5 per 0.5° (twilight skies dim by about a decade per 2°), and its
    // logarithmic rate may change by at most 0.25 between frames: no jumps.
    let mut h = headless();
    let mut previous: Option<f64> = None;
    let mut previous_step: Option<f64> = None;
    for step in 0..=20 {
        let elevation = 4.0 - 0.5 * step as f64;
        let mut scene = default_scene();
        scene.terrain.resolution = 32;
        scene.camera.position_m = [0.0, 2000.0, 0.0];
        scene.camera.look_at_m = None;
        scene.camera.yaw_deg = Some(90.0);
        scene.camera.pitch_deg = Some(45.0);
        scene.sun.azimuth_deg = Some(270.0);
        scene.sun.elevation_deg = Some(elevation);
        let image = h.render_hdr(&scene, 32, 18, 0.0).expect("render");
        assert!(
            image
                .pixels
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0),
            "non-finite radiance at {elevation}°"
        );
        let mean = image
            .pixels
            .iter()
            .map(|p| luminance_cd_m2(p.map(f64::from)))
            .sum::<f64>()
            / image.pixels.len() as f64;
        assert!(mean > 0.0, "black sky at {elevation}°");
        if let Some(prev) = previous {
            let ratio = prev / mean;
            assert!(
                (1.0..2.5).contains(&ratio),
                "sun {elevation}°: mean luminance {prev:.4} → {mean:.4} cd/m² (×{ratio:.3})"
            );
            let step = ratio.ln();
            if let Some(last) = previous_step {
                assert!(
                    (step - last).abs() < 0.25,
                    "sun {elevation}°: the sky dims at a jumping rate ({last:.3} then {step:.3} per frame)"
                );
            }
            previous_step = Some(step);
        }
        previous = Some(mean);
    }
}

#[test]
fn dithering_keeps_sky_gradients_free_of_bands() {
    // A clear sky filling the frame: down each column the 8-bit values change
    // by less than one code per few pixels, which without dithering shows as
    // bands (runs of equal values). With dithering the runs are short.
    let mut scene = Scene::embedded_default();
    scene.stratus = None;
    scene.terrain.resolution = 32;
    scene.camera.position_m = [0.0, 1000.0, 0.0];
    scene.camera.look_at_m = None;
    scene.camera.yaw_deg = Some(0.0);
    scene.camera.pitch_deg = Some(60.0);
    scene.camera.fov_deg = 20.0;
    let (w, ht) = (64, 256);
    let image = headless().render_rgba8(&scene, w, ht, 0.0).expect("render");
    let green = |x: u32, y: u32| image.pixels[((y * w + x) * 4 + 1) as usize] as i32;
    let (mut runs, mut total) = (0u32, 0u32);
    for x in 0..w {
        let mut run = 1;
        for y in 1..ht {
            if green(x, y) == green(x, y - 1) {
                run += 1;
            } else {
                runs += 1;
                total += run;
                run = 1;
            }
        }
        runs += 1;
        total += run;
    }
    let span = (0..w)
        .map(|x| (green(x, 0) - green(x, ht - 1)).abs())
        .max()
        .unwrap_or(0);
    let undithered_run = ht as f64 / span.max(1) as f64;
    let mean_run = total as f64 / runs as f64;
    assert!(
        undithered_run > 6.0,
        "gradient too steep to test banding: {span} codes over {ht} px"
    );
    assert!(
        mean_run < 3.0,
        "mean run of equal 8-bit values {mean_run:.2} px (an undithered gradient would give {undithered_run:.1})"
    );
}
