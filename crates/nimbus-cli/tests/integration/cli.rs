//! Integration tests of the `nimbus` binary: exit codes, one-line errors,
//! outputs, and no partial files on failure.

use crate::support::*;
use std::path::Path;
use std::process::{Command, Output};

#[test]
fn help_is_available_for_every_subcommand() {
    let dir = temp_dir("cli", "help");
    for sub in [
        &["--help"][..],
        &["render", "--help"],
        &["animate", "--help"],
        &["view", "--help"],
        &["bench", "--help"],
        &["scene", "--help"],
        &["slab", "--help"],
        &["slab", "fit", "--help"],
        &["slab", "plot", "--help"],
        &["optics", "dsd", "--help"],
        &["cumulus", "--help"],
        &["rain", "terminal-velocity", "--help"],
        &["rain", "stats", "--help"],
    ] {
        let out = nimbus(sub, &dir);
        assert!(out.status.success(), "{sub:?}");
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("Usage"),
            "{sub:?}"
        );
    }
}

/// Rendered as on a headless machine (no display, no `XDG_RUNTIME_DIR`):
/// standard error holds nimbus's own lines only, no driver's or display
/// library's "error".
#[test]
fn render_writes_a_png_of_the_default_scene() {
    let dir = temp_dir("cli", "render-png");
    let out = crate::support::nimbus_without_display(
        &["render", "-o", "sky.png", "--width", "96", "--height", "54"],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let foreign: Vec<&str> = stderr
        .lines()
        .filter(|line| !line.starts_with("nimbus:"))
        .collect();
    assert!(foreign.is_empty(), "lines not nimbus's: {foreign:?}");
    assert!(!stderr.contains("error"), "{stderr}");
    let image = image::open(dir.join("sky.png")).expect("png").to_rgba8();
    assert_eq!(image.dimensions(), (96, 54));
    // Sky at the top is bluish and brighter than black; nothing else was left in the directory.
    let top = image.get_pixel(48, 2);
    assert!(top[2] > top[0] && top[2] > 60, "top pixel {top:?}");
    assert_eq!(files_in(&dir), vec!["sky.png"]);
}

#[test]
fn render_writes_a_linear_exr() {
    let dir = temp_dir("cli", "render-exr");
    let out = nimbus(
        &["render", "-o", "sky.exr", "--width", "40", "--height", "24"],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = exr::prelude::read_first_rgba_layer_from_file(
        dir.join("sky.exr"),
        |resolution, _| vec![[0f32; 3]; resolution.width() * resolution.height()],
        |pixels, position, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[position.y() * 40 + position.x()] = [r, g, b]
        },
    )
    .expect("exr");
    let pixels = image.layer_data.channel_data.pixels;
    // Linear radiance in W·sr⁻¹·m⁻²: a daylight sky is of order 1–100, not display values in [0, 1].
    let top = pixels[20];
    assert!(top[2] > 1.0 && top[2] < 1000.0, "sky radiance {top:?}");
    assert_eq!(files_in(&dir), vec!["sky.exr"]);
}

#[test]
fn bad_scene_values_fail_with_one_line_and_no_output() {
    let dir = temp_dir("cli", "bad-scene");
    let cases: [(&str, &[&str]); 5] = [
        (
            "[camera]\nfov_deg = 190\n",
            &["bad.toml: camera.fov_deg = 190: must be a finite number in [0.01, 179]"],
        ),
        (
            "[camera]\nfov = 60\n",
            &["bad.toml", "camera.fov", "unknown key", "fov_deg"],
        ),
        (
            "[image]\nwidth = \"big\"\n",
            &["bad.toml", "image.width", "line 2"],
        ),
        (
            "[sun]\nelevation_deg = nan\n",
            &["bad.toml", "sun.elevation_deg = NaN"],
        ),
        ("[camera\n", &["bad.toml", "line 1"]),
    ];
    for (text, fragments) in cases {
        std::fs::write(dir.join("bad.toml"), text).expect("write");
        let out = nimbus(&["render", "bad.toml", "-o", "out.png"], &dir);
        assert_fails_with(&out, fragments);
        assert_eq!(
            files_in(&dir),
            vec!["bad.toml"],
            "output left behind for {text:?}"
        );
    }
}

#[test]
fn bad_flags_fail_with_one_line() {
    let dir = temp_dir("cli", "bad-flags");
    assert_fails_with(
        &nimbus(&["render", "--width", "0"], &dir),
        &["--width", "0"],
    );
    assert_fails_with(
        &nimbus(&["render", "--height", "abc"], &dir),
        &["--height", "abc"],
    );
    assert_fails_with(
        &nimbus(&["render", "--adapter", "quantum"], &dir),
        &["quantum", "auto, hardware, software"],
    );
    assert_fails_with(
        &nimbus(&["render", "-o", "out.jpg"], &dir),
        &["out.jpg", ".png or .exr"],
    );
    assert_fails_with(
        &nimbus(&["render", "-o", "missing/out.png"], &dir),
        &["missing/out.png", "does not exist"],
    );
    assert_fails_with(
        &nimbus(&["render", "no-such-scene.toml"], &dir),
        &["no-such-scene.toml", "cannot read"],
    );
    assert_fails_with(&nimbus(&["bench", "--frames", "0"], &dir), &["--frames"]);
    assert_fails_with(&nimbus(&["render", "--bogus"], &dir), &["--bogus"]);
    assert_fails_with(
        &nimbus(&["render", "--width", "16384", "--height", "16384"], &dir),
        &["16384×16384", "at most"],
    );
    assert!(files_in(&dir).is_empty(), "left {:?}", files_in(&dir));
}

#[test]
fn a_failed_write_leaves_no_partial_file() {
    let dir = temp_dir("cli", "failed-write");
    // The output path is an existing directory: the rename fails after the image is encoded.
    std::fs::create_dir(dir.join("taken.png")).expect("dir");
    let out = nimbus(
        &[
            "render",
            "-o",
            "taken.png",
            "--width",
            "16",
            "--height",
            "16",
        ],
        &dir,
    );
    assert_fails_with(&out, &["taken.png"]);
    assert_eq!(files_in(&dir), vec!["taken.png"]);
    assert!(dir.join("taken.png").is_dir());
}

#[test]
fn scene_print_default_round_trips() {
    let dir = temp_dir("cli", "print-default");
    let out = nimbus(&["scene", "--print-default"], &dir);
    assert!(out.status.success());
    std::fs::write(dir.join("default.toml"), &out.stdout).expect("write");
    let check = nimbus(&["scene", "--check", "default.toml"], &dir);
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
}

/// `nimbus scene --schema` prints the shipped `schemas/scene.schema.json`
/// (whose freshness nimbus-render's `scene_schema` test checks).
#[test]
fn scene_schema_prints_the_shipped_schema() {
    let dir = temp_dir("cli", "schema");
    let out = nimbus(&["scene", "--schema"], &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let printed = String::from_utf8(out.stdout).expect("UTF-8");
    let shipped_path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas/scene.schema.json");
    let shipped = std::fs::read_to_string(&shipped_path).expect("schemas/scene.schema.json");
    assert!(
        printed == shipped.replace("\r\n", "\n"),
        "nimbus scene --schema differs from {}",
        shipped_path.display()
    );
    let schema: serde_json::Value = serde_json::from_str(&printed).expect("one JSON document");
    assert_eq!(schema["title"], "nimbus scene file");
}

#[test]
fn sun_reproduces_the_spa_worked_example_as_json() {
    // Reda & Andreas (2008), table A5.1: azimuth 194.34024°; the report's
    // zenith 50.11162° includes refraction at 820 mbar and 11 °C, the
    // geometric zenith is 50.12795°.
    let dir = temp_dir("cli", "sun");
    let out = nimbus(
        &[
            "sun",
            "--lat",
            "39.742476",
            "--lon",
            "-105.1786",
            "--time",
            "2003-10-17T12:30:30-07:00",
            "--elevation-m",
            "1830.14",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let azimuth = report["azimuth_deg"].as_f64().expect("azimuth");
    let zenith = report["zenith_deg"].as_f64().expect("zenith");
    assert!((azimuth - 194.34024).abs() < 1e-3, "{azimuth}");
    assert!((zenith - 50.12795).abs() < 1e-3, "{zenith}");
    assert_fails_with(
        &nimbus(
            &[
                "sun",
                "--lat",
                "91",
                "--lon",
                "0",
                "--time",
                "2026-06-21T12:00:00Z",
            ],
            &dir,
        ),
        &["--lat 91"],
    );
    assert_fails_with(
        &nimbus(
            &[
                "sun",
                "--lat",
                "0",
                "--lon",
                "0",
                "--time",
                "2026-06-21T12:00",
            ],
            &dir,
        ),
        &["--time", "ISO 8601"],
    );
    assert_fails_with(
        &nimbus(
            &["sun", "--lat", "0", "--time", "2026-06-21T12:00:00Z"],
            &dir,
        ),
        &["--lon"],
    );
}

#[test]
fn optics_mie_reproduces_bohren_and_huffman_as_json() {
    // Bohren & Huffman appendix A: r = 0.525 µm, λ = 632.8 nm, m = 1.55:
    // Q_ext = Q_sca = 3.10543, Q_back = 2.92534, g = 0.63314.
    let dir = temp_dir("cli", "optics-mie");
    let out = nimbus(
        &[
            "optics",
            "mie",
            "--radius-um",
            "0.525",
            "--wavelength-nm",
            "632.8",
            "--refractive-index",
            "1.55,0",
            "--angle-step-deg",
            "1",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    for (key, expected) in [
        ("q_ext", 3.10543),
        ("q_sca", 3.10543),
        ("q_back", 2.92534),
        ("g", 0.63314),
    ] {
        let v = r[key].as_f64().expect(key);
        assert!((v - expected).abs() < 1e-5, "{key} {v}");
    }
    let angles = r["angles_deg"].as_array().expect("angles");
    let phase = r["phase"].as_array().expect("phase");
    assert_eq!((angles.len(), phase.len()), (181, 181));
    // Water by default, and bad input is refused on one line.
    assert!(
        nimbus(
            &[
                "optics",
                "mie",
                "--radius-um",
                "5",
                "--wavelength-nm",
                "550",
                "--json"
            ],
            &dir
        )
        .status
        .success()
    );
    assert_fails_with(
        &nimbus(
            &[
                "optics",
                "mie",
                "--radius-um",
                "-1",
                "--wavelength-nm",
                "550",
            ],
            &dir,
        ),
        &["--radius-um -1"],
    );
    assert_fails_with(
        &nimbus(
            &[
                "optics",
                "mie",
                "--radius-um",
                "1",
                "--wavelength-nm",
                "5000",
            ],
            &dir,
        ),
        &["--wavelength-nm 5000"],
    );
    assert_fails_with(
        &nimbus(
            &[
                "optics",
                "mie",
                "--radius-um",
                "1",
                "--wavelength-nm",
                "550",
                "--refractive-index",
                "1.3",
            ],
            &dir,
        ),
        &["--refractive-index 1.3", "N,K"],
    );
}

#[test]
fn optics_dsd_writes_json_csv_and_plot() {
    let dir = temp_dir("cli", "optics-dsd");
    let out = nimbus(
        &[
            "optics",
            "dsd",
            "--wavelength-nm",
            "650,450",
            "--angle-step-deg",
            "5",
            "--tolerance",
            "0.01",
            "--json",
            "--csv",
            "phase.csv",
            "--plot",
            "phase.png",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let results = r["results"].as_array().expect("results");
    assert_eq!(results.len(), 2);
    for e in results {
        let kappa = e["extinction_per_m"].as_f64().expect("κ");
        let g = e["g"].as_f64().expect("g");
        let pf = e["forward_fraction_5deg"].as_f64().expect("P_f");
        assert!(
            (0.03..0.045).contains(&kappa) && (0.83..0.87).contains(&g) && (0.3..0.6).contains(&pf),
            "{e}"
        );
        assert_eq!(e["phase"].as_array().expect("phase").len(), 37);
    }
    let csv = std::fs::read_to_string(dir.join("phase.csv")).expect("csv");
    assert!(csv.starts_with("angle_deg,phase_per_sr_650nm,phase_per_sr_450nm"));
    assert_eq!(csv.lines().count(), 38);
    let plot = image::open(dir.join("phase.png")).expect("png");
    assert_eq!((plot.width(), plot.height()), (960, 540));
    assert_fails_with(
        &nimbus(&["optics", "dsd", "--gamma", "0"], &dir),
        &["--gamma 0"],
    );
    assert_fails_with(
        &nimbus(&["optics", "dsd", "--wavelength-nm", "550,abc"], &dir),
        &["--wavelength-nm"],
    );
}

#[test]
fn rain_sections_render() {
    let dir = temp_dir("cli", "reserved");
    std::fs::write(dir.join("rain.toml"), "[rain]\nintensity_mm_h = 4.0\n").expect("write");
    let out = nimbus(
        &[
            "render",
            "rain.toml",
            "-o",
            "rain.png",
            "--width",
            "16",
            "--height",
            "16",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Rain is rendered now: no section is reserved any more.
    assert!(
        !stderr_lines(&out)
            .iter()
            .any(|l| l.contains("not rendered by this version"))
    );
}

#[test]
fn bench_can_measure_every_atmosphere_pass() {
    let dir = temp_dir("cli", "bench-luts");
    let out = nimbus(
        &[
            "bench",
            "--frames",
            "3",
            "--width",
            "32",
            "--height",
            "18",
            "--update-luts",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    if report["timestamps_supported"] == true {
        // The default scene has no static objects, and its camera is in no
        // cloud: those passes do not run.
        let idle = [
            "objects",
            "stratus_in_layer",
            "cumulus_in_cloud_light",
            "cumulus_in_cloud",
        ];
        for pass in report["passes"]
            .as_array()
            .expect("passes")
            .iter()
            .filter(|p| !idle.iter().any(|name| p["name"] == *name))
        {
            assert_eq!(pass["frames"], 3, "{pass}");
            assert!(
                pass["median_ms"].as_f64().is_some_and(|t| t >= 0.0),
                "{pass}"
            );
        }
    }
}

#[test]
fn bench_prints_one_json_document_with_per_pass_times() {
    let dir = temp_dir("cli", "bench");
    let out = nimbus(
        &[
            "bench", "--frames", "5", "--width", "64", "--height", "36", "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("stdout is one JSON document");
    assert_eq!(report["width"], 64);
    assert_eq!(report["frames"], 5);
    // The default scene rains: the report says how many drops were drawn.
    assert!(
        report["rain_drops"].as_u64().is_some_and(|n| n > 1000),
        "{}",
        report["rain_drops"]
    );
    assert!(report["adapter"].as_str().is_some_and(|s| !s.is_empty()));
    assert!(
        report["frame_wall"]["median_ms"]
            .as_f64()
            .is_some_and(|t| t > 0.0)
    );
    // The render thread's CPU time per frame: prepare and encode, and their
    // sum, each with median ≤ p95 ≤ max.
    for key in ["cpu_prepare", "cpu_encode", "cpu_total"] {
        let stats = &report[key];
        let [median, p95, max] =
            ["median_ms", "p95_ms", "max_ms"].map(|k| stats[k].as_f64().expect("a time"));
        assert!(
            0.0 < median && median <= p95 && p95 <= max,
            "{key}: {stats}"
        );
    }
    let total = report["cpu_total"]["max_ms"].as_f64().expect("time");
    let parts = report["cpu_prepare"]["max_ms"].as_f64().expect("time")
        + report["cpu_encode"]["max_ms"].as_f64().expect("time");
    assert!(total <= parts + 1e-9, "{total} > {parts}");
    if report["timestamps_supported"] == true {
        let passes = report["passes"].as_array().expect("passes");
        let names: Vec<&str> = passes.iter().filter_map(|p| p["name"].as_str()).collect();
        assert_eq!(
            names,
            [
                "transmittance",
                "multiple_scattering",
                "sky_view",
                "aerial_perspective",
                "lighting",
                "stratus_lighting",
                "cumulus_shadow",
                "rain_simulation",
                "sky",
                "terrain",
                "objects",
                "cumulus",
                "cumulus_fringes",
                "stratus",
                "cumulus_composite",
                "rain_mist",
                "rain",
                "stratus_in_layer",
                "cumulus_in_cloud_light",
                "cumulus_in_cloud",
                "exposure",
                "tonemap"
            ]
        );
        // With a still camera and sun the atmosphere's passes ran only in the
        // warm-up frame, and so did the cloud shadow map (the clouds drift
        // with the wind, the map is kept under a translated transform), the
        // clouds' environment (taken again only once they have drifted
        // 100 m) and the marched clouds' light atlases; the drawing passes
        // (the volume model's marches among them) ran in every measured
        // frame.
        for pass in passes {
            let name = pass["name"].as_str().expect("name");
            let frames = pass["frames"].as_u64().expect("frames");
            let every_frame = [
                "stratus_lighting",
                "sky",
                "terrain",
                "cumulus",
                "cumulus_fringes",
                "stratus",
                "cumulus_composite",
                "cumulus_in_cloud",
                "rain_simulation",
                "rain_mist",
                "rain",
                "stratus_in_layer",
                "exposure",
                "tonemap",
            ];
            if !every_frame.contains(&name) {
                assert_eq!(frames, 0, "{pass}");
                assert!(pass.get("median_ms").is_none(), "{pass}");
                continue;
            }
            assert_eq!(frames, 5, "{pass}");
            let (median, p95) = (
                pass["median_ms"].as_f64().expect("median"),
                pass["p95_ms"].as_f64().expect("p95"),
            );
            assert!(median >= 0.0 && p95 >= median, "{pass}");
        }
    } else {
        assert!(
            report["note"]
                .as_str()
                .is_some_and(|n| n.contains("timestamp"))
        );
    }
}

#[test]
fn slab_prints_fluxes_and_radiance_for_both_methods() {
    let dir = temp_dir("cli", "slab");
    // DISORT test problem 3 (cdisort 2.1, case 3a): HG g = 0.75, τ = 1,
    // conservative, overhead sun: R = 0.07874, T = 0.92126.
    let out = nimbus(
        &[
            "slab",
            "--optical-depth",
            "1",
            "--sun-zenith-deg",
            "0",
            "--view-zenith-deg",
            "30",
            "--phase",
            "hg:0.75",
            "--method",
            "monte-carlo",
            "--photons",
            "200000",
            "--seed",
            "3",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let r = report["reflectance"].as_f64().expect("R");
    let t = report["transmittance"].as_f64().expect("T");
    let se = report["std_error"]["reflectance"].as_f64().expect("se");
    assert!((r - 0.07874).abs() < 4.0 * se + 2e-4, "{report}");
    assert!((r + t - 1.0).abs() < 1e-9);
    for key in ["order0", "order1", "order2", "order3plus", "total"] {
        assert!(report["radiance"][key].as_f64().is_some(), "{key}");
        assert!(
            report["std_error"]["radiance"][key].as_f64().is_some(),
            "{key}"
        );
    }
    // The analytic model for the paper's cloud (computes its Mie phase function).
    let out = nimbus(
        &[
            "slab",
            "--thickness-m",
            "100",
            "--sun-zenith-deg",
            "70",
            "--view-zenith-deg",
            "70",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert!((report["scattering_angle_deg"].as_f64().expect("angle") - 180.0).abs() < 1e-3);
    let total = report["radiance"]["total"].as_f64().expect("total");
    assert!(total > 0.0 && total.is_finite(), "{report}");
    assert_fails_with(
        &nimbus(
            &[
                "slab",
                "--optical-depth",
                "1",
                "--sun-zenith-deg",
                "95",
                "--view-zenith-deg",
                "0",
            ],
            &dir,
        ),
        &["--sun-zenith-deg 95"],
    );
    assert_fails_with(
        &nimbus(
            &[
                "slab",
                "--optical-depth",
                "1",
                "--sun-zenith-deg",
                "0",
                "--view-zenith-deg",
                "0",
                "--phase",
                "hg:2",
            ],
            &dir,
        ),
        &["'hg:2'", "--phase", "hg:G with −1 < G < 1"],
    );
    assert!(files_in(&dir).is_empty());
}

#[test]
fn slab_fit_writes_a_table_the_library_reads_and_plot_writes_png_and_csv() {
    let dir = temp_dir("cli", "slab-fit");
    let table = dir.join("table.toml");
    let out = nimbus(
        &[
            "slab",
            "fit",
            "--out",
            table.to_str().expect("utf-8"),
            "--photons",
            "8192",
            "--sun-zenith-deg",
            "0,60",
            "--thickness-m",
            "2,20,200,2000,5",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let loaded = nimbus_physics::transport::stratus::OneDimensionalTable::from_file(&table)
        .expect("the written table loads");
    assert_eq!(loaded.rows.len(), 2);
    assert!((loaded.beta - report["beta"].as_f64().expect("beta")).abs() < 1e-5);
    // β = T_ms(1 m) of the paper's droplets: the paper fitted 0.9961.
    assert!((0.99..0.999).contains(&loaded.beta), "β {}", loaded.beta);
    assert_eq!(report["paper"].as_array().expect("paper rows").len(), 10);

    let figure = dir.join("fig.png");
    let csv = dir.join("fig.csv");
    let out = nimbus(
        &[
            "slab",
            "plot",
            "--thickness-m",
            "100",
            "--sun-zenith-deg",
            "70",
            "--out",
            figure.to_str().expect("utf-8"),
            "--csv",
            csv.to_str().expect("utf-8"),
            "--photons",
            "4096",
            "--step-deg",
            "5",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = image::open(&figure).expect("png");
    assert_eq!((image.width(), image.height()), (1200, 640));
    let text = std::fs::read_to_string(&csv).expect("csv");
    // Header and view angles −85° … 85° in 5° steps.
    assert_eq!(text.lines().count(), 1 + 35);
    // The glory row (x = 70°, view = sun): scattering angle 180°.
    let glory = text
        .lines()
        .find(|l| l.starts_with("70,"))
        .expect("glory row");
    let scattering_angle: f64 = glory
        .split(',')
        .nth(3)
        .expect("column")
        .parse()
        .expect("number");
    assert!((scattering_angle - 180.0).abs() < 1e-3, "{glory}");

    let before = files_in(&dir);
    assert_fails_with(
        &nimbus(
            &[
                "slab",
                "plot",
                "--thickness-m",
                "-1",
                "--sun-zenith-deg",
                "70",
                "--out",
                "x.png",
            ],
            &dir,
        ),
        &["--thickness-m -1"],
    );
    assert_fails_with(
        &nimbus(
            &["slab", "fit", "--out", "t.toml", "--sun-zenith-deg", "0,95"],
            &dir,
        ),
        &["--sun-zenith-deg 0,95", "95"],
    );
    assert_eq!(files_in(&dir), before);
}

/// `nimbus cumulus` from a roots file: a .glb, the hierarchy JSON and a
/// preview PNG, a JSON report that says watertight, with counts per level.
#[test]
fn cumulus_writes_mesh_hierarchy_and_preview() {
    let dir = temp_dir("cli", "cumulus");
    std::fs::write(
        dir.join("roots.json"),
        r#"[{"centre_m": [0, 300, 0], "radius_m": 300, "flattening": 0.3},
            {"centre_m": [400, 200, 0], "radius_m": 250}]"#,
    )
    .expect("roots");
    let out = nimbus(
        &[
            "cumulus",
            "--roots",
            "roots.json",
            "--levels",
            "1",
            "--lods",
            "2",
            "-o",
            "cloud.glb",
            "--preview",
            "cloud.png",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON document");
    assert_eq!(report["watertight"], true);
    assert_eq!(report["levels"].as_array().map(Vec::len), Some(2));
    assert_eq!(report["levels"][0]["particles"], 2);
    assert!(report["levels"][1]["particles"].as_u64().unwrap_or(0) > 20);
    assert!(report["triangles"].as_u64().unwrap_or(0) > 1000);
    assert_eq!(report["lods"].as_array().map(Vec::len), Some(2));
    assert_eq!(
        files_in(&dir),
        [
            "cloud.glb",
            "cloud.hierarchy.json",
            "cloud.png",
            "roots.json"
        ]
    );
    let glb = std::fs::read(dir.join("cloud.glb")).expect("glb");
    assert_eq!(&glb[0..4], b"glTF");
    let hierarchy: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("cloud.hierarchy.json")).expect("json"))
            .expect("hierarchy");
    assert_eq!(hierarchy["levels"][0]["blobs"][1]["radius_m"], 250.0);
}

/// Bad cumulus input: one line naming the file or flag, the value and what
/// is allowed; nothing written.
#[test]
fn cumulus_bad_input_fails_with_one_line() {
    let dir = temp_dir("cli", "cumulus-bad");
    std::fs::write(
        dir.join("flat.json"),
        r#"[{"centre_m": [0, 0, 0], "radius_m": 300, "flattening": 2}]"#,
    )
    .expect("roots");
    std::fs::write(
        dir.join("typo.json"),
        r#"[{"centre": [0, 0, 0], "radius_m": 300}]"#,
    )
    .expect("roots");
    let cases: [(&[&str], &[&str]); 4] = [
        (
            &["cumulus", "--roots", "flat.json", "-o", "a.glb"],
            &["flat.json", "roots[0].flattening = 2", "0 to 1"],
        ),
        (
            &["cumulus", "--roots", "typo.json", "-o", "a.glb"],
            &["typo.json", "[0]", "centre"],
        ),
        (
            &["cumulus", "--root-count", "0", "-o", "a.glb"],
            &["--root-count 0", "1 to 200"],
        ),
        (&["cumulus", "-o", "a.obj"], &["a.obj", ".glb"]),
    ];
    for (args, fragments) in cases {
        assert_fails_with(&nimbus(args, &dir), fragments);
    }
    assert_eq!(files_in(&dir), ["flat.json", "typo.json"]);
}

fn json_stdout(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON document on stdout")
}

/// Gunn & Kinzer, J. Meteor. 6, 1949, Table 2: the fit within 5 % from 0.5
/// to 5 mm, the measured value beside it, null off the table.
#[test]
fn rain_terminal_velocity_matches_gunn_and_kinzer_1949_as_json() {
    let dir = temp_dir("cli", "rain-speed");
    let measured = [
        (0.5, 2.06),
        (1.0, 4.03),
        (2.0, 6.49),
        (3.0, 8.06),
        (4.0, 8.83),
        (5.0, 9.09),
    ];
    let rows = json_stdout(&nimbus(
        &[
            "rain",
            "terminal-velocity",
            "--diameter-mm",
            "0.5,1,2,3,4,5,2.5",
            "--json",
        ],
        &dir,
    ));
    let rows = rows.as_array().expect("array");
    assert_eq!(rows.len(), 7);
    for (row, (d, v)) in rows.iter().zip(measured) {
        assert_eq!(row["diameter_mm"], d);
        assert_eq!(row["gunn_kinzer_m_s"], v);
        let speed = row["speed_m_s"].as_f64().expect("speed");
        assert!((speed - v).abs() / v < 0.05, "{d} mm: {speed} vs {v}");
        let cd = row["drag_coefficient"].as_f64().expect("C_d");
        assert!((0.4..1.5).contains(&cd), "{d} mm: C_d {cd}");
    }
    assert!(rows[6]["gunn_kinzer_m_s"].is_null(), "{}", rows[6]);
}

fn rain_stats(args: &[&str], dir: &Path) -> serde_json::Value {
    let mut all = vec!["rain", "stats", "--json"];
    all.extend_from_slice(args);
    json_stdout(&nimbus(&all, dir))
}

/// The drop count in the box follows the Marshall–Palmer expectation
/// (Blanchard 2023, §4.2.2) at light and torrential rain, with no NaN.
#[test]
fn rain_stats_drop_counts_follow_marshall_palmer_at_1_and_100_mm_h() {
    let dir = temp_dir("cli", "rain-stats");
    for (intensity, radius) in [("1", "3"), ("100", "2")] {
        let r = rain_stats(
            &[
                "--intensity-mm-h",
                intensity,
                "--seconds",
                "1",
                "--box-radius-m",
                radius,
            ],
            &dir,
        );
        let error = r["relative_error"].as_f64().expect("relative_error");
        assert!(error.abs() < 0.03, "{intensity} mm/h: {r}");
        assert!(r["expected_drops"].as_f64().expect("expected") > 10_000.0);
        assert_eq!(r["non_finite_values"], 0, "{r}");
        assert_eq!(r["steps"], 120);
    }
}

/// Drag on the velocity relative to the air carries the drops with a steady wind.
#[test]
fn rain_stats_drops_move_with_the_wind() {
    let dir = temp_dir("cli", "rain-wind");
    let r = rain_stats(
        &[
            "--intensity-mm-h",
            "10",
            "--seconds",
            "1",
            "--box-radius-m",
            "2",
            "--wind-m-s",
            "8,0,0",
        ],
        &dir,
    );
    let v = &r["mean_horizontal_velocity_m_s"];
    let (x, z) = (v[0].as_f64().expect("x"), v[1].as_f64().expect("z"));
    assert!((x - 8.0).abs() < 0.16 && z.abs() < 0.16, "{r}");
    assert!(r["recycled_per_second"].as_f64().expect("recycled") > 0.0);
}

/// No rain: no drops, no division by zero; gusts and turbulence stay finite.
#[test]
fn rain_stats_handles_no_rain_and_gusts() {
    let dir = temp_dir("cli", "rain-edge");
    let r = rain_stats(&["--intensity-mm-h", "0", "--seconds", "0.5"], &dir);
    assert_eq!(r["simulated_drops"], 0);
    assert!(r["relative_error"].is_null(), "{r}");
    assert!(r["recycled_per_second"].is_null(), "{r}");
    let r = rain_stats(
        &[
            "--intensity-mm-h",
            "10",
            "--seconds",
            "3",
            "--box-radius-m",
            "1.5",
            "--wind-m-s",
            "5,0,-2",
            "--gusts",
        ],
        &dir,
    );
    assert_eq!(r["non_finite_values"], 0, "{r}");
    let error = r["relative_error"].as_f64().expect("relative_error");
    assert!(error.abs() < 0.05, "{r}");
}

#[test]
fn rain_bad_input_fails_with_one_line() {
    let dir = temp_dir("cli", "rain-bad");
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["rain", "terminal-velocity", "--diameter-mm", "-1"],
            &["--diameter-mm -1", "[0.01, 8]"],
        ),
        (
            &["rain", "terminal-velocity", "--diameter-mm", "1,abc"],
            &["--diameter-mm", "abc"],
        ),
        (
            &["rain", "stats", "--intensity-mm-h", "1000"],
            &["--intensity-mm-h 1000", "[0, 300]"],
        ),
        (
            &[
                "rain",
                "stats",
                "--intensity-mm-h",
                "5",
                "--wind-m-s",
                "NaN,0,0",
            ],
            &["--wind-m-s NaN,0,0", "finite"],
        ),
        (
            &[
                "rain",
                "stats",
                "--intensity-mm-h",
                "300",
                "--box-radius-m",
                "50",
            ],
            &["--intensity-mm-h 300", "at most 20000000"],
        ),
        (
            &[
                "rain",
                "stats",
                "--intensity-mm-h",
                "5",
                "--min-diameter-mm",
                "2",
                "--max-diameter-mm",
                "1",
            ],
            &["--max-diameter-mm 1", "--min-diameter-mm"],
        ),
    ];
    for (args, fragments) in cases {
        let out = nimbus(args, &dir);
        assert_fails_with(&out, fragments);
        assert!(out.stdout.is_empty(), "{args:?}");
    }
}

/// Runs `nimbus animate` with `args` at 64×36 into `dir/frames` and
/// returns the frames it wrote, decoded.
fn animate(dir: &Path, args: &[&str]) -> Vec<image::RgbaImage> {
    let mut all = vec!["animate", "--width", "64", "--height", "36", "-o", "frames"];
    all.extend_from_slice(args);
    let out = nimbus(&all, dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let frames = dir.join("frames");
    files_in(&frames)
        .iter()
        .map(|name| {
            assert!(
                name.starts_with("frame_") && name.ends_with(".png"),
                "{name}"
            );
            image::open(frames.join(name)).expect("png").to_rgba8()
        })
        .collect()
}

/// Mean absolute difference of two frames, 8-bit levels per channel.
fn mean_difference(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    let total: u64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| u64::from(x.abs_diff(*y)))
        .sum();
    total as f64 / a.as_raw().len() as f64
}

#[test]
fn animate_static_weather_does_not_flicker() {
    // Static camera and weather (no wind, no rain, no keyframes, a layer
    // that barely evolves, no water ripples): the frames are the same,
    // auto-exposure included, but for rounding. The layer still evolves by
    // a millionth of its evolution time per second, which can move a pixel
    // that sits on a rounding boundary by one level; flicker (exposure
    // hunting, noise reseeded per frame) would move many pixels by more.
    let dir = temp_dir("cli", "animate-static");
    std::fs::write(
        dir.join("still.toml"),
        "[camera]\nposition_m = [0.0, 900.0, 0.0]\nyaw_deg = 30.0\npitch_deg = 5.0\nauto_exposure = true\n\
         [sun]\nazimuth_deg = 200.0\nelevation_deg = 25.0\n\
         [terrain]\nwater_level_m = -5000.0\n\
         [stratus]\nbase_m = 1500.0\nthickness_m = 300.0\ncoverage = 0.5\nevolution_time_s = 1000000.0\n\
         [cumulus]\ncoverage = 0.1\nbase_m = 1200.0\n",
    )
    .expect("scene");
    let frames = animate(&dir, &["still.toml", "--seconds", "1", "--fps", "5"]);
    assert_eq!(frames.len(), 5);
    for pair in frames.windows(2) {
        let largest = pair[0]
            .as_raw()
            .iter()
            .zip(pair[1].as_raw())
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        assert!(largest <= 1, "a channel moved by {largest} levels");
        let mean = mean_difference(&pair[0], &pair[1]);
        assert!(mean < 1e-3, "mean difference {mean} levels");
    }
}

#[test]
fn animate_the_default_sunset_and_shower_smoothly() {
    // The default scene's keyframes: the sun sinks and the shower grows.
    // Frames change steadily: no frame stands out from the mean of its two
    // neighbours (a flicker) by more than the neighbours differ from each
    // other, and the last frame is darker than the first (the sunset).
    // Its cumulus shaded by the `fitted` model: the `volume` default traces
    // a sun cube per cloud for each of the six suns (72, minutes of CI on
    // two cores), and what is tested here is the animation, not the model
    // (whose own goldens, suite and flight test the default).
    let dir = temp_dir("cli", "animate-default");
    let default = nimbus(&["scene", "--print-default"], &dir);
    assert!(default.status.success());
    let mut scene = String::from_utf8(default.stdout).expect("UTF-8");
    scene.push_str("\n[cumulus.shading]\nmodel = \"fitted\"\n");
    std::fs::write(dir.join("sunset.toml"), scene).expect("scene");
    let frames = animate(&dir, &["sunset.toml", "--seconds", "10", "--fps", "0.6"]);
    assert_eq!(frames.len(), 6);
    for i in 1..frames.len() - 1 {
        let (a, b, c) = (&frames[i - 1], &frames[i], &frames[i + 1]);
        let midpoint: Vec<u8> = a
            .as_raw()
            .iter()
            .zip(c.as_raw())
            .map(|(x, y)| ((u16::from(*x) + u16::from(*y)) / 2) as u8)
            .collect();
        let midpoint = image::RgbaImage::from_raw(a.width(), a.height(), midpoint).expect("size");
        let flicker = mean_difference(b, &midpoint);
        let motion = mean_difference(a, c);
        assert!(
            flicker <= 0.5 * motion + 1.0,
            "frame {i}: flicker {flicker}, motion {motion}"
        );
    }
    let brightness = |f: &image::RgbaImage| f.as_raw().iter().map(|&v| f64::from(v)).sum::<f64>();
    assert!(brightness(&frames[5]) < brightness(&frames[0]));
}

#[test]
fn animate_bad_input_fails_with_one_line() {
    let dir = temp_dir("cli", "animate-bad");
    let out = nimbus(&["animate", "--seconds", "-1", "-o", "frames"], &dir);
    assert_fails_with(&out, &["--seconds", "-1"]);
    let out = nimbus(
        &["animate", "--seconds", "1", "--fps", "0", "-o", "frames"],
        &dir,
    );
    assert_fails_with(&out, &["--fps", "0"]);
    std::fs::write(dir.join("file"), "x").expect("file");
    let out = nimbus(&["animate", "--seconds", "1", "-o", "file"], &dir);
    assert_fails_with(&out, &["file", "not a directory"]);
    std::fs::write(
        dir.join("bad.toml"),
        "[[keyframes]]\ntime_s = 1.0\nrain_intensity_mm_h = 5.0\n",
    )
    .expect("scene");
    let out = nimbus(
        &["animate", "bad.toml", "--seconds", "1", "-o", "frames"],
        &dir,
    );
    assert_fails_with(
        &out,
        &["bad.toml", "keyframes[0].rain_intensity_mm_h", "[rain]"],
    );
    // Without ffmpeg on the PATH a video is refused before any work.
    let out = Command::new(env!("CARGO_BIN_EXE_nimbus"))
        .args(["animate", "--seconds", "1", "-o", "out.mp4"])
        .current_dir(&dir)
        .env("PATH", "/nonexistent")
        .output()
        .expect("run nimbus");
    assert_fails_with(&out, &["out.mp4", "ffmpeg is not on the PATH"]);
    assert_eq!(files_in(&dir), ["bad.toml", "file"]);
}

/// A reader that goes away (`nimbus optics dsd --json | head -c 10`) ends
/// nimbus quietly with success, as it does other Unix tools, instead of a
/// panic on the broken pipe.
#[test]
fn a_closed_standard_output_ends_quietly() {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_nimbus"))
        .args(["optics", "dsd", "--json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run nimbus");
    // Close the read end before nimbus writes (it computes for ~0.5 s first).
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "status {:?}: {stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
}
