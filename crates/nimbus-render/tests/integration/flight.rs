//! The camera anywhere (`scenes/flight-through.toml`): a flight from below a
//! cumulus, through it, and up through the stratus deck, rendered frame by
//! frame around every surface the camera crosses. Between consecutive
//! frames (1/24 s, ~4 m of flight) the image may change only as much as
//! the camera's motion moves it: no pop, flash or hard edge as the camera
//! enters or leaves a cloud.

use glam::DVec3;
use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::{AdapterPreference, Scene};
use std::path::Path;

const WIDTH: u32 = 80;
const HEIGHT: u32 = 45;
const FPS: f64 = 24.0;
/// Frames rendered either side of a crossing.
const HALF_WINDOW_FRAMES: i32 = 6;
/// Largest change of the mean display luminance (0–1) between consecutive
/// frames.
const MEAN_STEP: f64 = 0.03;
/// Largest change of one cell of the 8×8 thumbnail of display luminance
/// (0–1) between consecutive frames.
const THUMBNAIL_STEP: f64 = 0.08;

fn flight_scene() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/flight-through.toml");
    let mut scene = Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
    // A fixed exposure: the automatic one's adaptation would smooth a step.
    scene.camera.auto_exposure = false;
    scene.camera.exposure_ev100 = 12.5;
    scene
}

/// Whether `p` (the object frame) is inside the closed mesh: the parity of
/// the crossings of a ray along +x (Möller & Trumbore 1997).
fn inside_mesh(vertices: &[DVec3], indices: &[u32], p: DVec3) -> bool {
    let d = DVec3::new(1.0, 1e-4, 2e-4).normalize();
    let mut crossings = 0;
    for t in indices.chunks_exact(3) {
        let (a, b, c) = (
            vertices[t[0] as usize],
            vertices[t[1] as usize],
            vertices[t[2] as usize],
        );
        let (e1, e2) = (b - a, c - a);
        let q = d.cross(e2);
        let det = e1.dot(q);
        if det.abs() < 1e-12 {
            continue;
        }
        let s = (p - a) / det;
        let u = s.dot(q);
        let r = s.cross(e1);
        let v = d.dot(r);
        if u < 0.0 || v < 0.0 || u + v > 1.0 {
            continue;
        }
        if e2.dot(r) > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// Times (s) where the flight's camera enters or leaves a cumulus (its
/// coarsest mesh) or a stratus cell (|y − y_mid| < h/2 of the CPU field),
/// to 0.01 s, with what it crosses.
fn crossings(scene: &Scene) -> Vec<(f64, &'static str)> {
    let field = nimbus_render::cumulus::cumulus_field_at(scene, 0.0)
        .expect("the cumulus field")
        .expect("the scene has cumulus");
    let layer = scene
        .stratus
        .as_ref()
        .expect("the scene has a stratus deck");
    let stratus = nimbus_render::scene::cloud_layer_field(scene, layer);
    let mid = layer.base_m + 0.5 * layer.thickness_m;
    let meshes: Vec<(Vec<DVec3>, &[u32])> = field
        .shapes
        .iter()
        .map(|shape| {
            let lod = shape.lods.last().expect("a level of detail");
            let vertices = lod
                .vertices
                .iter()
                .map(|v| {
                    DVec3::from_array(
                        v.position_radius[..3]
                            .try_into()
                            .map(|a: [f32; 3]| a.map(f64::from))
                            .expect("xyz"),
                    )
                })
                .collect();
            (vertices, lod.indices.as_slice())
        })
        .collect();
    let state = |t: f64| -> (bool, bool) {
        let at = scene.at_time(t);
        let p = DVec3::from_array(at.camera.position_m);
        let in_cumulus = field.clouds.iter().any(|c| {
            let (s, co) = c.yaw_rad.sin_cos();
            let d = (p - c.base_centre_m) / c.scale;
            let object = DVec3::new(co * d.x - s * d.z, d.y, s * d.x + co * d.z);
            let (vertices, indices) = &meshes[c.variant];
            inside_mesh(vertices, indices, object)
        });
        let h = stratus.thickness_with_drift_m(p.x, p.z, at.cloud_drift_m(t), t);
        (in_cumulus, (p.y - mid).abs() < 0.5 * h)
    };
    let mut found = Vec::new();
    let end_s = scene.keyframes.last().map_or(0.0, |k| k.time_s);
    let step = 0.05;
    let mut previous = state(0.0);
    let mut t = step;
    while t <= end_s {
        let now = state(t);
        for (changed, what) in [
            (now.0 != previous.0, "cumulus"),
            (now.1 != previous.1, "stratus"),
        ] {
            if changed {
                // Bisect to 0.01 s.
                let (mut lo, mut hi) = (t - step, t);
                let pick = |s: (bool, bool)| if what == "cumulus" { s.0 } else { s.1 };
                let before = pick(previous);
                while hi - lo > 0.01 {
                    let m = 0.5 * (lo + hi);
                    if pick(state(m)) == before {
                        lo = m;
                    } else {
                        hi = m;
                    }
                }
                found.push((0.5 * (lo + hi), what));
            }
        }
        previous = now;
        t += step;
    }
    found
}

/// Mean display luminance and its 8×8 thumbnail (Rec. 709 weights on the
/// sRGB-encoded values, 0–1).
fn thumbnail(pixels: &[u8]) -> (f64, [f64; 64]) {
    let (w, h) = (WIDTH as usize, HEIGHT as usize);
    let mut cells = [0.0; 64];
    let mut counts = [0usize; 64];
    let mut sum = 0.0;
    for y in 0..h {
        for x in 0..w {
            let p = &pixels[4 * (y * w + x)..];
            let l =
                (0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]))
                    / 255.0;
            let cell = (y * 8 / h) * 8 + x * 8 / w;
            cells[cell] += l;
            counts[cell] += 1;
            sum += l;
        }
    }
    for (c, n) in cells.iter_mut().zip(counts) {
        *c /= n.max(1) as f64;
    }
    (sum / (w * h) as f64, cells)
}

#[test]
fn flight_through_is_continuous_across_every_surface() {
    let scene = flight_scene();
    let crossed = crossings(&scene);
    eprintln!("crossings: {crossed:?}");
    for what in ["cumulus", "stratus"] {
        assert!(
            crossed.iter().filter(|c| c.1 == what).count() >= 2,
            "the flight enters and leaves a {what}: {crossed:?}"
        );
    }
    let mut h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter (install Mesa's lavapipe): {e}"));
    let mut failures = Vec::new();
    for (t_cross, what) in &crossed {
        let mut previous: Option<(f64, [f64; 64])> = None;
        for k in -HALF_WINDOW_FRAMES..=HALF_WINDOW_FRAMES {
            let t = t_cross + f64::from(k) / FPS;
            let at = scene.at_time(t);
            let image = h
                .render_rgba8(&at, WIDTH, HEIGHT, t as f32)
                .unwrap_or_else(|e| panic!("frame at {t:.3} s: {e}"));
            let now = thumbnail(&image.pixels);
            if let Some((mean, cells)) = previous {
                let mean_step = (now.0 - mean).abs();
                let cell_step = cells
                    .iter()
                    .zip(&now.1)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                eprintln!(
                    "{what} at {t_cross:.2} s, frame {k}: mean {:.3} (step {mean_step:.4}), thumbnail step {cell_step:.4}",
                    now.0
                );
                if mean_step > MEAN_STEP || cell_step > THUMBNAIL_STEP {
                    failures.push(format!(
                        "{what} crossing at {t_cross:.2} s, frame {k}: mean step {mean_step:.4} (bound {MEAN_STEP}), thumbnail step {cell_step:.4} (bound {THUMBNAIL_STEP})"
                    ));
                }
            }
            previous = Some(now);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
