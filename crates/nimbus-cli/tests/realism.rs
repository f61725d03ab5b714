//! The ground-truth tooling end to end: EXR layers read back by the `exr`
//! crate, the equirectangular panorama's seam, `nimbus compare`, and the
//! Mitsuba export's files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn nimbus(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nimbus"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run nimbus")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nimbus-realism-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "nimbus failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Channels by name of an EXR's first layer.
fn channels(path: &Path) -> (usize, usize, std::collections::BTreeMap<String, Vec<f32>>) {
    let image = exr::prelude::read_all_flat_layers_from_file(path).expect("readable EXR");
    let layer = &image.layer_data[0];
    let map = layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    (layer.size.width(), layer.size.height(), map)
}

#[test]
fn exr_layers_are_read_back_with_their_names() {
    let dir = temp_dir("layers");
    let scene = scenes_dir().join("cumulus-front-lit.toml");
    let out = nimbus(
        &["render", scene.to_str().expect("path"), "-o", "c.exr", "--width", "64", "--height", "36"],
        &dir,
    );
    assert_success(&out);
    let (w, h, c) = channels(&dir.join("c.exr"));
    assert_eq!((w, h), (64, 36));
    let names: Vec<&str> = c.keys().map(String::as_str).collect();
    for name in ["R", "G", "B", "Z", "cloud.A", "sky.R", "sky.G", "sky.B"] {
        assert!(names.contains(&name), "{name} missing from {names:?}");
    }
    let opacity = &c["cloud.A"];
    assert!(opacity.iter().all(|a| (0.0..=1.0).contains(a)));
    // The cumulus covers some pixels fully and leaves the sky clear.
    let cloudy = opacity.iter().filter(|a| **a > 0.9).count();
    let clear = opacity.iter().filter(|a| **a < 0.01).count();
    assert!(cloudy > 10 && clear > w * h / 2, "cloudy {cloudy}, clear {clear}");
    // Where the cloud is opaque, the image is the cloud, not the sky; where
    // there is none, the image is the sky layer.
    let (r, sky) = (&c["R"], &c["sky.R"]);
    for i in 0..w * h {
        if opacity[i] < 0.001 && c["Z"][i] >= 1e9 {
            assert!((r[i] - sky[i]).abs() <= 0.02 * sky[i] + 1e-3, "pixel {i}: {} vs {}", r[i], sky[i]);
        }
    }
    // Z: the sky is at 1e10 m; the cumulus body and the sea are nearer.
    let z = &c["Z"];
    assert!(z.iter().all(|d| *d > 0.0));
    assert!(z.iter().any(|d| *d >= 1e9) && z.iter().any(|d| *d < 1e5));
}

#[test]
fn the_equirectangular_panorama_has_no_seam() {
    let dir = temp_dir("pano");
    let scene = "[camera]\nposition_m = [0.0, 300.0, 0.0]\nprojection = \"equirectangular\"\n\n[sun]\nazimuth_deg = 120.0\nelevation_deg = 30.0\n";
    std::fs::write(dir.join("pano.toml"), scene).expect("scene");
    let out = nimbus(
        &["render", "pano.toml", "-o", "pano.exr", "--width", "128", "--height", "64"],
        &dir,
    );
    assert_success(&out);
    let (w, h, c) = channels(&dir.join("pano.exr"));
    assert_eq!((w, h), (128, 64));
    let g = &c["G"];
    // Across longitude ±180° (last column → first) the change is no larger
    // than between neighbouring columns elsewhere in the row.
    for y in 4..h - 4 {
        let row = &g[y * w..(y + 1) * w];
        let seam = (row[0] - row[w - 1]).abs();
        let typical = (1..w).map(|x| (row[x] - row[x - 1]).abs()).fold(0.0f32, f32::max);
        assert!(seam <= typical * 1.5 + 1e-4, "row {y}: seam {seam}, largest step {typical}");
    }
    // The zenith row is nearly uniform (the pole is one point).
    let top = &g[..w];
    let mean = top.iter().sum::<f32>() / w as f32;
    assert!(top.iter().all(|v| (v - mean).abs() < 0.05 * mean), "{top:?}");
    // The upper half is sky (brighter than black), the lower half at the horizon is sea or land.
    assert!(mean > 0.0);
}

#[test]
fn compare_reports_zero_for_identical_images_and_writes_the_report() {
    let dir = temp_dir("compare");
    let scene = scenes_dir().join("cumulus-front-lit.toml");
    assert_success(&nimbus(
        &["render", scene.to_str().expect("path"), "-o", "a.exr", "--width", "48", "--height", "27"],
        &dir,
    ));
    let out = nimbus(&["compare", "a.exr", "a.exr", "--json", "--out", "r.png"], &dir);
    assert_success(&out);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON document");
    assert_eq!(json["hdr_flip_mean"], 0.0);
    assert_eq!(json["mean_luminance_ratio"], 1.0);
    assert!(json["pixels"].as_u64().expect("pixels") > 0);
    let report = image::open(dir.join("r.png")).expect("report");
    assert_eq!((report.width(), report.height()), (3 * 48 + 8, 27));
    // A wrong file is one line naming it.
    std::fs::write(dir.join("bad.exr"), b"not an exr").expect("write");
    let out = nimbus(&["compare", "a.exr", "bad.exr"], &dir);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("bad.exr") && stderr.contains("OpenEXR"), "{stderr}");
}
