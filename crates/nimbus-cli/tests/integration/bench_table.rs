//! `nimbus bench table`: benchmark reports (hand-written here, so no GPU is
//! needed) as one Markdown table, and one-line errors naming the file.

use crate::support::*;

/// A `nimbus bench --json` report of a GPU run (fields the table does not
/// use included, as the bench writes them).
const BENCH_REPORT: &str = r#"{
  "scene": "rain-bench-5m",
  "adapter": "NVIDIA H200",
  "backend": "Vulkan",
  "device_type": "DiscreteGpu",
  "driver": "NVIDIA 570.86.15",
  "width": 3840,
  "height": 2160,
  "frames": 120,
  "rain_drops": 5012345,
  "timestamps_supported": true,
  "passes": [
    { "name": "transmittance", "frames": 0 },
    { "name": "rain_simulation", "frames": 120, "median_ms": 0.8123, "p95_ms": 0.9, "max_ms": 1.2 },
    { "name": "sky", "frames": 120, "median_ms": 0.05, "p95_ms": 0.06, "max_ms": 0.07 },
    { "name": "terrain", "frames": 120, "median_ms": 1.234, "p95_ms": 1.3, "max_ms": 1.4 },
    { "name": "rain", "frames": 120, "median_ms": 2.5, "p95_ms": 2.7, "max_ms": 3.0 }
  ],
  "gpu_total": { "median_ms": 4.642, "p95_ms": 5.01, "max_ms": 6.0 },
  "frame_wall": { "median_ms": 6.25, "p95_ms": 7.0, "max_ms": 9.0 },
  "cpu_prepare": { "median_ms": 0.1, "p95_ms": 0.2, "max_ms": 0.3 },
  "cpu_encode": { "median_ms": 0.1, "p95_ms": 0.2, "max_ms": 0.3 },
  "cpu_total": { "median_ms": 0.2, "p95_ms": 0.4, "max_ms": 0.6 },
  "note": null
}"#;

/// A report without timestamps and without a scene name (as an older
/// version wrote it): the file's name stands in.
const WALL_ONLY_REPORT: &str = r#"{
  "adapter": "llvmpipe (LLVM 19.1.7, 256 bits)",
  "driver": "",
  "width": 1920,
  "height": 1080,
  "frames": 5,
  "timestamps_supported": false,
  "passes": [],
  "gpu_total": null,
  "frame_wall": { "median_ms": 1234.56, "p95_ms": 1300.0, "max_ms": 1400.0 }
}"#;

fn write(dir: &std::path::Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).expect("write a report");
}

#[test]
fn bench_table_prints_one_row_per_report_in_order() {
    let dir = temp_dir("bench-table", "rows");
    write(&dir, "a.json", BENCH_REPORT);
    write(&dir, "old-1920x1080.json", WALL_ONLY_REPORT);
    let out = nimbus(
        &[
            "bench",
            "table",
            "a.json",
            "old-1920x1080.json",
            "--passes",
            "rain_simulation,sky,rain,cumulus",
        ],
        &dir,
    );
    assert_success(&out);
    let stdout = String::from_utf8(out.stdout).expect("UTF-8");
    let table: Vec<&str> = stdout.lines().filter(|l| l.starts_with('|')).collect();
    assert_eq!(
        table,
        [
            "| scene | resolution | adapter | frames | drops | rain_simulation | sky | rain | cumulus | GPU total | wall |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
            "| rain-bench-5m | 3840×2160 | NVIDIA H200, NVIDIA 570.86.15 | 120 | 5.01 M | 0.812 | 0.050 | 2.50 | — | 4.64 / 5.01 | 6.25 |",
            "| old-1920x1080 | 1920×1080 | llvmpipe (LLVM 19.1.7, 256 bits) | 5 | — | — | — | — | — | — | 1234.6 |",
        ]
    );
    // A caption says what the figures are, before the table.
    assert!(stdout.starts_with("Per-pass GPU time"), "{stdout}");
}

#[test]
fn bench_table_default_and_all_columns() {
    let dir = temp_dir("bench-table", "columns");
    write(&dir, "a.json", BENCH_REPORT);
    let header = |args: &[&str]| -> String {
        let out = nimbus(args, &dir);
        assert_success(&out);
        String::from_utf8(out.stdout)
            .expect("UTF-8")
            .lines()
            .find(|l| l.starts_with("| scene"))
            .expect("a header row")
            .to_owned()
    };
    assert_eq!(
        header(&["bench", "table", "a.json"]),
        "| scene | resolution | adapter | frames | drops | rain_simulation | sky | terrain | cumulus | cumulus_fringes | stratus | rain_mist | rain | GPU total | wall |"
    );
    // `all`: the passes the reports measured, in frame order.
    assert_eq!(
        header(&["bench", "table", "a.json", "--passes", "all"]),
        "| scene | resolution | adapter | frames | drops | rain_simulation | sky | terrain | rain | GPU total | wall |"
    );
}

#[test]
fn bench_table_errors_are_one_line_naming_the_file() {
    let dir = temp_dir("bench-table", "errors");
    write(&dir, "good.json", BENCH_REPORT);
    write(&dir, "broken.json", "{ \"adapter\": ");
    write(
        &dir,
        "wrong.json",
        &BENCH_REPORT.replace("\"width\": 3840", "\"width\": \"wide\""),
    );
    write(
        &dir,
        "negative.json",
        &BENCH_REPORT.replace("\"median_ms\": 0.05", "\"median_ms\": -0.05"),
    );
    assert_fails_with(
        &nimbus(&["bench", "table", "good.json", "missing.json"], &dir),
        &["missing.json", "cannot read"],
    );
    assert_fails_with(
        &nimbus(&["bench", "table", "broken.json"], &dir),
        &["broken.json", "not a benchmark report"],
    );
    assert_fails_with(
        &nimbus(&["bench", "table", "wrong.json"], &dir),
        &["wrong.json", "width"],
    );
    assert_fails_with(
        &nimbus(&["bench", "table", "negative.json"], &dir),
        &["negative.json", "passes[2].median_ms = -0.05"],
    );
    // A directory, not a report.
    assert_fails_with(
        &nimbus(&["bench", "table", "."], &dir),
        &["not a regular file"],
    );
    assert_fails_with(
        &nimbus(
            &["bench", "table", "good.json", "--passes", "sky,skye"],
            &dir,
        ),
        &["--passes", "`skye` is not a pass"],
    );
    assert_fails_with(&nimbus(&["bench", "table"], &dir), &["REPORT.json"]);
    // Nothing was written beside the reports.
    assert_eq!(
        files_in(&dir),
        ["broken.json", "good.json", "negative.json", "wrong.json"]
    );
}

#[test]
fn bench_keeps_its_scene_argument_beside_the_table_subcommand() {
    let dir = temp_dir("bench-table", "help");
    for args in [&["bench", "table", "--help"][..], &["bench", "--help"]] {
        let out = nimbus(args, &dir);
        assert_success(&out);
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("Usage"),
            "{args:?}"
        );
    }
    // A scene path is still the benchmark's scene (here a missing one).
    assert_fails_with(
        &nimbus(&["bench", "no-such-scene.toml", "--frames", "1"], &dir),
        &["no-such-scene.toml"],
    );
}
