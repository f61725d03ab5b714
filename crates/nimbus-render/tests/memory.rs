//! Memory over many frames: a renderer that draws rain, cumulus and a
//! stratus layer frame after frame holds its memory flat once warm. Its own
//! test binary, alone in its process, so that no other test's allocations
//! move the resident size it reads.

use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::{AdapterPreference, Scene};

/// Frames rendered before the resident size is first read: the pipelines'
/// first use, the terrain, shapes and tables, the rain's buffers.
const WARM_UP_FRAMES: u32 = 10;
/// Frames rendered after it.
const MEASURED_FRAMES: u32 = 200;
/// Largest growth allowed over the measured frames, bytes.
const MAX_GROWTH_BYTES: u64 = 20 << 20;

/// The process's resident size, bytes (`VmRSS` of `/proc/self/status`).
fn resident_bytes() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    let line = status
        .lines()
        .find(|line| line.starts_with("VmRSS:"))
        .expect("a VmRSS line");
    let kib: u64 = line["VmRSS:".len()..]
        .split_whitespace()
        .next()
        .and_then(|kib| kib.parse().ok())
        .expect("VmRSS in kB");
    kib * 1024
}

/// The default scene (terrain, cumulus, stratus, rain with its mist and
/// zones, wind) without its keyframes: the weather holds steady while the
/// wind carries the clouds and the rain falls, so nothing has a reason to
/// grow. A coarse terrain and a smaller rain box (about 0.2 M drops
/// instead of 1.6 M) keep the frames short.
fn steady_weather() -> Scene {
    let mut scene = Scene::embedded_default();
    scene.keyframes.clear();
    scene.terrain.resolution = 64;
    if let Some(rain) = &mut scene.rain {
        rain.box_radius_m = 2.5;
    }
    scene
}

#[test]
fn memory_stays_flat_over_two_hundred_frames_of_rain_cumulus_and_stratus() {
    if !cfg!(target_os = "linux") {
        // The resident size is read from /proc.
        return;
    }
    let mut h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let scene = steady_weather();
    let (width, height) = (64, 36);
    let frame_s = 1.0 / 24.0;
    for frame in 0..WARM_UP_FRAMES {
        h.render_rgba8(&scene, width, height, frame as f32 * frame_s)
            .expect("frame");
    }
    let (clouds, drawn) = h.renderer.cumulus().cloud_counts();
    assert!(clouds > 0 && drawn > 0, "cumulus drawn: {clouds} / {drawn}");
    assert!(h.renderer.rain().enabled(), "rain simulated");
    let warm = resident_bytes();
    let mut largest = warm;
    for frame in WARM_UP_FRAMES..WARM_UP_FRAMES + MEASURED_FRAMES {
        h.render_rgba8(&scene, width, height, frame as f32 * frame_s)
            .expect("frame");
        largest = largest.max(resident_bytes());
    }
    let growth = largest.saturating_sub(warm);
    eprintln!(
        "resident after {WARM_UP_FRAMES} frames {:.1} MB, largest over the next {MEASURED_FRAMES} {:.1} MB ({} on {})",
        warm as f64 / 1e6,
        largest as f64 / 1e6,
        h.gpu.adapter_info.driver_info,
        h.gpu.adapter_info.name,
    );
    assert!(
        growth <= MAX_GROWTH_BYTES,
        "the resident size grew by {:.1} MB over {MEASURED_FRAMES} frames (at most {:.1} MB)",
        growth as f64 / 1e6,
        MAX_GROWTH_BYTES as f64 / 1e6
    );
}
