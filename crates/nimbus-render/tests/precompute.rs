//! No stalls (issue 26, requirement 5): under `Precompute::Background`
//! `prepare` returns at once on a scene whose cumulus shapes and optics
//! tables are not made yet, frames leave them out until they are ready, and
//! then draw exactly what a renderer that waited draws.
//!
//! Its own test binary: it points the process's on-disk cache at an empty
//! directory so that nothing is cached.

use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::{AdapterPreference, Precompute, Scene};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 36;

#[test]
fn prepare_does_not_wait_for_the_shapes_and_the_clouds_appear_once_they_are_made() {
    let cache = std::env::temp_dir().join(format!("nimbus-precompute-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    nimbus_render::cache::set_cache_dir(Some(cache.clone()));

    // The default scene (cumulus field under a stratocumulus layer) without
    // its rain, whose drops two renderers would simulate separately, and
    // with one cloud shape instead of three: what is asserted does not
    // depend on how many shapes are made, and each takes seconds.
    let mut scene = Scene::embedded_default();
    scene.rain = None;
    scene.keyframes.clear();
    scene.camera.auto_exposure = false;
    // The fitted model: the volume default adds a sun cube per cloud
    // (~7 s each) to wait for, which this test does not need.
    if let Some(cumulus) = &mut scene.cumulus {
        cumulus.variants = 1;
        cumulus.shading = nimbus_physics::cumulus::shading::CumulusShading::of_model(
            nimbus_physics::cumulus::shading::CumulusShadingModel::Fitted,
        );
    }

    let mut h = HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter");
    h.renderer.set_precompute(Precompute::Background);
    let first = h
        .render_hdr(&scene, WIDTH, HEIGHT, 0.0)
        .expect("first frame");
    let prepare_ms = h.last_frame_cpu_times().prepare_s * 1e3;
    eprintln!("first prepare: {prepare_ms:.2} ms");
    let pending = h.renderer.pending_work();
    assert!(
        pending.contains(&"cumulus shapes") && pending.contains(&"stratus optics"),
        "pending: {pending:?}"
    );
    assert!(
        prepare_ms < 50.0,
        "prepare took {prepare_ms:.1} ms with the shapes not yet made"
    );
    assert!(!h.renderer.cumulus().enabled() && !h.renderer.stratus().enabled());
    assert!(first.pixels.iter().flatten().all(|v| v.is_finite()));

    // A render loop keeps preparing; here it waits between frames.
    let mut frames = 1;
    while !h.renderer.is_ready() {
        assert!(frames < 6, "still pending: {:?}", h.renderer.pending_work());
        h.renderer.wait_for_precompute();
        h.render_hdr(&scene, WIDTH, HEIGHT, 0.0).expect("frame");
        frames += 1;
    }
    let later = h
        .render_hdr(&scene, WIDTH, HEIGHT, 0.0)
        .expect("ready frame");
    assert!(h.renderer.cumulus().enabled() && h.renderer.stratus().enabled());

    // The clouds appeared: the same frame as a renderer that blocked in prepare.
    let mut blocking = HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter");
    let reference = blocking
        .render_hdr(&scene, WIDTH, HEIGHT, 0.0)
        .expect("blocking frame");
    let largest = later
        .pixels
        .iter()
        .zip(&reference.pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].abs().max(1e-3)))
        .fold(0.0f32, f32::max);
    assert!(
        largest < 1e-4,
        "ready frame differs from the blocking one by {largest}"
    );
    let changed = first
        .pixels
        .iter()
        .zip(&later.pixels)
        .filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 0.05 * b[c].abs()))
        .count();
    assert!(
        changed > first.pixels.len() / 10,
        "only {changed} pixels changed once the clouds were ready"
    );
    let _ = std::fs::remove_dir_all(&cache);
}
