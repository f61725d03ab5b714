//! Scene parsing and validation: every error path names the file, the key,
//! the value and what is allowed, on one line.

use super::*;

fn error_of(text: &str) -> String {
    let err = Scene::from_toml_str(text, "scene.toml").expect_err("scene should be rejected");
    let message = err.to_string();
    assert!(!message.contains('\n'), "error spans lines: {message}");
    assert!(
        message.starts_with("scene.toml: "),
        "error does not name the file: {message}"
    );
    message
}

#[test]
fn embedded_default_scene_parses_and_validates() {
    let scene = Scene::from_toml_str(DEFAULT_SCENE_TOML, "default.toml").expect("default scene");
    assert_eq!(scene, Scene::embedded_default());
}

/// `scenes/default.toml`, the example users open, is the embedded scene (a
/// symbolic link to `src/scene/default.toml`; this catches a checkout that
/// made it a copy, e.g. without symbolic links, and an edit of one alone).
#[test]
fn example_default_scene_is_the_embedded_one() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/default.toml");
    let text = std::fs::read_to_string(path).expect("scenes/default.toml");
    assert!(
        text == DEFAULT_SCENE_TOML,
        "scenes/default.toml differs from crates/nimbus-render/src/scene/default.toml \
         (the embedded default scene): make it a symbolic link to that file"
    );
}

#[test]
fn example_scenes_parse() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).expect("scenes directory") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "toml") {
            Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
            count += 1;
        }
    }
    assert!(count >= 3, "expected a few example scenes, found {count}");
}

#[test]
fn empty_file_gives_the_built_in_defaults() {
    assert_eq!(
        Scene::from_toml_str("", "empty.toml").expect("empty scene"),
        Scene::default()
    );
}

#[test]
fn out_of_range_field_of_view_is_reported_as_documented() {
    assert_eq!(
        error_of("[camera]\nfov_deg = 190"),
        "scene.toml: camera.fov_deg = 190: must be a finite number in [0.01, 179]"
    );
    assert_eq!(
        error_of("[camera]\nfov_deg = 0"),
        "scene.toml: camera.fov_deg = 0: must be a finite number in [0.01, 179]"
    );
    // Inside the old open range (0, 179), but no usable picture (every
    // pixel was the sun's radiance): refused.
    assert_eq!(
        error_of("[camera]\nfov_deg = 1e-200"),
        "scene.toml: camera.fov_deg = 1e-200: must be a finite number in [0.01, 179]"
    );
}

#[test]
fn nan_and_infinity_are_rejected() {
    let m = error_of("[sun]\nelevation_deg = nan");
    assert!(
        m.contains("sun.elevation_deg = NaN") && m.contains("[-90, 90]"),
        "{m}"
    );
    let m = error_of("[terrain]\nextent_m = inf");
    assert!(m.contains("terrain.extent_m = inf"), "{m}");
    let m = error_of("[camera]\nposition_m = [0.0, -inf, 0.0]");
    assert!(
        m.contains("camera.position_m") && m.contains("finite"),
        "{m}"
    );
}

#[test]
fn unknown_keys_are_rejected_with_the_allowed_ones() {
    let m = error_of("[camera]\nfov = 60");
    assert!(
        m.contains("camera.fov") && m.contains("unknown key") && m.contains("fov_deg"),
        "{m}"
    );
    let m = error_of("colour = 1");
    assert!(
        m.contains("colour") && m.contains("unknown key") && m.contains("camera"),
        "{m}"
    );
    let m = error_of("[terrain.albedo]\nlava = [1.0, 0.0, 0.0]");
    assert!(
        m.contains("terrain.albedo.lava") && m.contains("snow"),
        "{m}"
    );
    let m = error_of("[clouds]\n");
    assert!(m.contains("clouds") && m.contains("unknown key"), "{m}");
}

#[test]
fn wrong_types_are_rejected_with_the_line() {
    let m = error_of("[image]\nwidth = \"wide\"");
    assert!(m.contains("image.width") && m.contains("line 2"), "{m}");
    let m = error_of("[image]\nwidth = -5");
    assert!(m.contains("image.width"), "{m}");
    let m = error_of("[camera]\nposition_m = [1.0, 2.0]");
    assert!(m.contains("camera.position_m"), "{m}");
}

#[test]
fn stratus_model_is_the_volume_by_default_and_the_faces_or_the_paper_on_request() {
    let scene = Scene::from_toml_str("[stratus]\n", "scene.toml").expect("scene");
    assert_eq!(
        scene.stratus.expect("stratus").model,
        StratusShadingModel::Volume
    );
    let scene =
        Scene::from_toml_str("[stratus]\nmodel = \"marched\"", "scene.toml").expect("scene");
    assert_eq!(
        scene.stratus.expect("stratus").model,
        StratusShadingModel::Marched
    );
    let scene =
        Scene::from_toml_str("[stratus]\nmodel = \"bnl2006\"", "scene.toml").expect("scene");
    assert_eq!(
        scene.stratus.expect("stratus").model,
        StratusShadingModel::Bnl2006
    );
    let scene = Scene::from_toml_str("[stratus]\nmodel = \"volume\"", "scene.toml").expect("scene");
    assert_eq!(
        scene.stratus.expect("stratus").model,
        StratusShadingModel::Volume
    );
    let m = error_of("[stratus]\nmodel = \"bnl2007\"");
    assert!(
        m.contains("stratus.model")
            && m.contains("bnl2007")
            && m.contains("marched")
            && m.contains("volume")
            && m.contains("line 2"),
        "{m}"
    );
}

#[test]
fn arrays_of_the_wrong_length_are_rejected_with_both_lengths() {
    let m = error_of("[camera]\nposition_m = [0.0, 5000.0, 0.0, 7.0]");
    assert!(
        m.contains("camera.position_m")
            && m.contains("4 values; expected 3")
            && m.contains("line 2"),
        "{m}"
    );
    let m = error_of("[rain]\n[[rain.areas]]\ncenter_m = [1.0, 2.0, 3.0]\nradius_m = 500.0");
    assert!(
        m.contains("rain.areas[0].center_m") && m.contains("3 values; expected 2"),
        "{m}"
    );
    // Lists keep the length given, and every example scene passes.
    Scene::from_toml_str(
        "[[rain.areas]]\ncenter_m = [1.0, 2.0]\nradius_m = 500.0\n[[rain.areas]]\ncenter_m = [9.0, 2.0]\nradius_m = 600.0",
        "scene.toml",
    )
    .expect("two areas");
}

#[test]
fn syntax_errors_name_the_line() {
    let m = error_of("[camera]\nfov_deg = = 3\n");
    assert!(m.contains("line 2"), "{m}");
}

#[test]
fn every_range_is_checked() {
    let cases = [
        ("[image]\nwidth = 0", "image.width = 0"),
        ("[image]\nheight = 20000", "image.height = 20000"),
        ("[camera]\npitch_deg = 95", "camera.pitch_deg = 95"),
        ("[camera]\nyaw_deg = 400", "camera.yaw_deg = 400"),
        (
            "[camera]\nexposure_ev100 = 40",
            "camera.exposure_ev100 = 40",
        ),
        (
            "[camera]\nposition_m = [0.0, 2e7, 0.0]",
            "camera.position_m",
        ),
        ("[sun]\nazimuth_deg = -1", "sun.azimuth_deg = -1"),
        ("[sun]\nelevation_deg = 91", "sun.elevation_deg = 91"),
        (
            "[atmosphere]\naerosol_optical_depth = -0.1",
            "atmosphere.aerosol_optical_depth = -0.1",
        ),
        (
            "[atmosphere]\naerosol_asymmetry = 1.0",
            "atmosphere.aerosol_asymmetry = 1",
        ),
        (
            "[atmosphere]\ntop_radius_m = 6000000.0",
            "atmosphere.top_radius_m = 6000000",
        ),
        (
            "[atmosphere]\nbottom_radius_m = 10.0",
            "atmosphere.bottom_radius_m = 10",
        ),
        (
            "[atmosphere]\nground_albedo = [0.3, 0.3, 1.5]",
            "atmosphere.ground_albedo",
        ),
        (
            "[atmosphere]\nrayleigh_scale_height_m = 0",
            "atmosphere.rayleigh_scale_height_m = 0",
        ),
        ("[terrain]\nextent_m = 10", "terrain.extent_m = 10"),
        (
            "[terrain]\nheight_scale_m = -1",
            "terrain.height_scale_m = -1",
        ),
        (
            "[terrain]\nfeature_wavelength_m = 1",
            "terrain.feature_wavelength_m = 1",
        ),
        ("[terrain]\nresolution = 8", "terrain.resolution = 8"),
        (
            "[terrain]\nresolution = 100000",
            "terrain.resolution = 100000",
        ),
        ("[terrain]\nresolution = 4096", "terrain.resolution = 4096"),
        (
            "[image]\nwidth = 16384\nheight = 16384",
            "image = 16384×16384",
        ),
        ("[terrain]\nwater_level_m = 1e9", "terrain.water_level_m"),
        ("[terrain]\nsand_band_m = -3", "terrain.sand_band_m = -3"),
        ("[terrain]\nsnow_line_m = 1e6", "terrain.snow_line_m"),
        (
            "[terrain]\nrock_slope_deg = 120",
            "terrain.rock_slope_deg = 120",
        ),
        (
            "[terrain.albedo]\nsnow = [1.2, 0.9, 0.9]",
            "terrain.albedo.snow",
        ),
        ("[cumulus]\ncoverage = 2", "cumulus.coverage = 2"),
        ("[cumulus]\nbase_m = -5", "cumulus.base_m = -5"),
        ("[stratus]\nthickness_m = 0", "stratus.thickness_m = 0"),
        ("[stratus]\nbase_m = 20000", "stratus.base_m = 20000"),
        ("[stratus]\ncoverage = 1.5", "stratus.coverage = 1.5"),
        ("[stratus]\ndetail = 0", "stratus.detail = 0"),
        ("[stratus]\nresolution = 4096", "stratus.resolution = 4096"),
        (
            "[stratus]\nradiosity_iterations = 100",
            "stratus.radiosity_iterations = 100",
        ),
        (
            "[stratus]\neffective_radius_um = 0.1",
            "stratus.effective_radius_um = 0.1",
        ),
        ("[rain]\nintensity_mm_h = 500", "rain.intensity_mm_h = 500"),
        ("[wind]\nspeed_m_s = -1", "wind.speed_m_s = -1"),
        ("[wind]\nfrom_deg = 361", "wind.from_deg = 361"),
    ];
    for (text, expected) in cases {
        let m = error_of(text);
        assert!(
            m.contains(expected),
            "`{text}` gave `{m}`, expected it to mention `{expected}`"
        );
        assert!(m.contains("must be"), "`{m}` does not say what is allowed");
    }
}

#[test]
fn look_at_excludes_yaw_and_pitch_and_needs_a_horizontal_offset() {
    let m = error_of("[camera]\nlook_at_m = [0.0, 0.0, -100.0]\nyaw_deg = 10");
    assert!(
        m.contains("camera.look_at_m") && m.contains("not both"),
        "{m}"
    );
    let m = error_of("[camera]\nposition_m = [0.0, 100.0, 0.0]\nlook_at_m = [0.0, 0.0, 0.0]");
    assert!(m.contains("straight above or below"), "{m}");
}

#[test]
fn the_sun_is_given_by_angles_or_by_time_and_place() {
    let scene = Scene::from_toml_str(
        "[sun]\ntime_utc = \"2003-10-17T12:30:30-07:00\"\nlatitude_deg = 39.742476\nlongitude_deg = -105.1786\n",
        "s.toml",
    )
    .expect("scene");
    let (azimuth, elevation) = scene.sun.angles_deg();
    // NREL SPA worked example at sea level (the report's 194.34° azimuth, 39.87° elevation at 1830 m).
    assert!(
        (azimuth - 194.34).abs() < 0.01 && (elevation - 39.87).abs() < 0.02,
        "{azimuth} {elevation}"
    );
    let cases = [
        (
            "[sun]\nazimuth_deg = 10.0\ntime_utc = \"2026-06-21T12:00:00Z\"\nlatitude_deg = 1.0\nlongitude_deg = 2.0",
            "not be combined",
        ),
        (
            "[sun]\ntime_utc = \"2026-06-21 noon\"\nlatitude_deg = 1.0\nlongitude_deg = 2.0",
            "sun.time_utc = \"2026-06-21 noon\"",
        ),
        (
            "[sun]\ntime_utc = \"2026-02-30T12:00:00Z\"\nlatitude_deg = 1.0\nlongitude_deg = 2.0",
            "no such date",
        ),
        (
            "[sun]\ntime_utc = \"2026-06-21T12:00:00Z\"\nlatitude_deg = 1.0",
            "sun.longitude_deg = (missing)",
        ),
        (
            "[sun]\nlatitude_deg = 1.0\nlongitude_deg = 2.0",
            "sun.time_utc = (missing)",
        ),
        ("[sun]\nlatitude_deg = 95.0", "sun.latitude_deg = 95"),
        ("[sun]\nlongitude_deg = -181.0", "sun.longitude_deg = -181"),
        ("[sun]\nazimuth_deg = 10.0", "sun.elevation_deg = (missing)"),
    ];
    for (text, expected) in cases {
        let m = error_of(text);
        assert!(
            m.contains(expected),
            "`{text}` gave `{m}`, expected `{expected}`"
        );
    }
}

#[test]
fn rain_and_wind_sections_parse() {
    let scene = Scene::from_toml_str(
        "[rain]\nintensity_mm_h = 12.5\nbox_shape = \"frustum\"\n[[rain.areas]]\ncenter_m = [0, 0]\nradius_m = 900\n[wind]\n[[wind.primitives]]\nkind = \"gust_front\"\nspeed_m_s = 8\naxis = [1, 0, 0]\n",
        "s.toml",
    )
    .expect("scene");
    let rain = scene.rain.as_ref().expect("rain");
    assert_eq!(rain.intensity_mm_h, 12.5);
    assert_eq!(rain.box_shape, RainBoxKind::Frustum);
    assert_eq!(rain.areas[0].edge_m, 500.0);
    let wind = scene.wind.as_ref().expect("wind");
    assert_eq!(wind.primitives[0].kind, WindPrimitiveKindSetting::GustFront);
    for (text, key) in [
        (
            "[rain]\nmax_diameter_mm = 0.3",
            "rain.max_diameter_mm = 0.3",
        ),
        ("[rain]\nmax_drops = 0", "rain.max_drops = 0"),
        ("[rain]\nbox_radius_m = 1000", "rain.box_radius_m = 1000"),
        ("[rain]\nexposure_s = nan", "rain.exposure_s"),
        (
            "[[rain.areas]]\ncenter_m = [0, 0]\nradius_m = 10\nedge_m = 20",
            "rain.areas[0].edge_m = 20",
        ),
        (
            "[[wind.primitives]]\nkind = \"vortex\"\nspeed_m_s = 500",
            "wind.primitives[0].speed_m_s = 500",
        ),
        (
            "[[wind.primitives]]\nkind = \"vortex\"\nspeed_m_s = 5\naxis = [0, 0, 0]",
            "wind.primitives[0].axis",
        ),
        (
            "[wind.turbulence]\ntile_m = 1",
            "wind.turbulence.tile_m = 1",
        ),
        (
            "[wind.field]\nfile = \"no-such-field.npy\"\ncell_m = 2",
            "wind.field.file = \"no-such-field.npy\": must be a float32 or float64 .npy array",
        ),
        (
            "[wind.field]\nfile = \"field.csv\"\ncell_m = 2",
            "must be the path of a NumPy .npy file",
        ),
        (
            "[wind.field]\nfile = \"field.npy\"\ncell_m = 0",
            "wind.field.cell_m = 0",
        ),
        (
            "[wind.turbulence]\n[wind.field]\nfile = \"field.npy\"\ncell_m = 2",
            "cannot be used with [wind.turbulence]",
        ),
    ] {
        let m = error_of(text);
        assert!(m.contains(key), "{text}: {m}");
    }
}

/// A wind field file is read relative to the scene file, and a file that
/// is not a velocity array fails the scene with the reason.
#[test]
fn wind_field_files_are_read_next_to_the_scene() {
    use nimbus_physics::rain::wind::WindGrid;
    let dir = std::env::temp_dir().join(format!("nimbus-wind-field-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("fields")).expect("dir");
    let grid = WindGrid {
        cells: [2, 2, 3],
        cell_m: 5.0,
        origin_m: glam::Vec3::new(1.0, 2.0, 3.0),
        carried: true,
        velocities_m_s: (0..12).map(|i| [i as f32, 0.0, -1.0, 0.0]).collect(),
    };
    std::fs::write(dir.join("fields/gusts.npy"), grid.to_npy()).expect("field");
    std::fs::write(dir.join("fields/text.npy"), "not an array").expect("text");
    let scene_text = |file: &str| {
        format!(
            "[wind]\n[wind.field]\nfile = \"{file}\"\ncell_m = 5\norigin_m = [1, 2, 3]\ncarried = true\n"
        )
    };
    std::fs::write(dir.join("good.toml"), scene_text("fields/gusts.npy")).expect("scene");
    let scene = Scene::from_file(&dir.join("good.toml")).expect("scene");
    assert_eq!(scene.wind_field().expect("field").grid, Some(grid));
    std::fs::write(dir.join("bad.toml"), scene_text("fields/text.npy")).expect("scene");
    let error = Scene::from_file(&dir.join("bad.toml"))
        .expect_err("bad field")
        .to_string();
    assert!(
        error.contains("wind.field.file = \"fields/text.npy\"") && error.contains("magic"),
        "{error}"
    );
    assert_eq!(error.lines().count(), 1, "{error}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn wind_from_the_west_blows_towards_the_east() {
    let wind = WindSettings {
        speed_m_s: 10.0,
        from_deg: 270.0,
        ..WindSettings::default()
    };
    let [x, z] = wind.velocity_xz_m_s();
    assert!((x - 10.0).abs() < 1e-9 && z.abs() < 1e-9);
    // From the north (−z) towards the south (+z).
    let [x, z] = WindSettings {
        from_deg: 0.0,
        ..wind
    }
    .velocity_xz_m_s();
    assert!(x.abs() < 1e-9 && (z - 10.0).abs() < 1e-9);
}

#[test]
fn missing_file_is_reported_with_its_name() {
    let err =
        Scene::from_file(std::path::Path::new("/nonexistent/scene.toml")).expect_err("missing");
    assert!(
        err.to_string()
            .starts_with("/nonexistent/scene.toml: cannot read"),
        "{err}"
    );
}

#[test]
fn scene_reference_documents_every_key_of_the_default_scene() {
    // Read, not embedded: the published crate holds no file from outside it.
    let doc_path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/scene-file.md");
    let doc = std::fs::read_to_string(doc_path).expect("docs/scene-file.md");
    let doc = doc.as_str();
    let value: toml::Table = toml::from_str(DEFAULT_SCENE_TOML).expect("default scene is TOML");
    fn walk(prefix: &str, table: &toml::Table, doc: &str) {
        for (key, value) in table {
            let path = if prefix.is_empty() {
                key.clone()
            } else {
                format!("{prefix}.{key}")
            };
            match value {
                toml::Value::Table(inner) => walk(&path, inner, doc),
                _ => assert!(
                    doc.contains(&format!("`{path}`")),
                    "docs/scene-file.md does not document `{path}`"
                ),
            }
        }
    }
    walk("", &value, doc);
}

/// `Scene::check` (run by the renderer's `prepare` on every frame) has the
/// file's range checks and their one-line errors, but reads no file: a
/// mesh whose file is missing passes it and fails the file's validation.
#[test]
fn check_has_the_range_errors_and_reads_no_file() {
    let mut scene = Scene::default();
    scene.camera.fov_deg = 0.0;
    assert_eq!(
        scene.check().expect_err("fov 0").to_string(),
        "scene: camera.fov_deg = 0: must be a finite number in [0.01, 179]"
    );
    let text =
        "[[objects]]\nkind = \"mesh\"\ngltf = \"no/such/file.glb\"\nposition_m = [0.0, 0.0, 0.0]\n";
    let error = error_of(text);
    assert!(
        error.contains("must be a readable glTF 2.0 file"),
        "{error}"
    );
    let scene: Scene = toml::from_str(text).expect("parses");
    scene.check().expect("check reads no file");
}

/// Issue 28: every error line names the key, the value (shortened, with
/// characters that act on a terminal escaped) and what is allowed, and no
/// Rust type name.
#[test]
fn error_lines_show_value_and_range_in_the_scene_authors_words() {
    // An overflowed number: the value and the key's range.
    assert_eq!(
        error_of("[camera]\nyaw_deg = 1e999"),
        "scene.toml: camera.yaw_deg: 1e999: floating-point number overflowed; must be a finite number in [-360, 360] (line 2)"
    );
    // An integer too large for a float field, and for an integer field.
    let m = error_of("[camera]\nyaw_deg = 100000000000000000000");
    assert!(
        !m.contains("i128") && !m.contains("f64") && m.contains("[-360, 360]"),
        "{m}"
    );
    let m = error_of("[image]\nwidth = 5000000000");
    assert!(
        !m.contains("u32") && m.contains("5000000000") && m.contains("[1, 16384]"),
        "{m}"
    );
    // A table where a number goes, a number where a table goes.
    let m = error_of("camera = 5");
    assert!(
        m.contains("expected a table") && !m.contains("struct") && !m.contains("Settings"),
        "{m}"
    );
    // Huge numbers in exponent form, not 300 digits.
    assert_eq!(
        error_of("[camera]\nyaw_deg = 1e308"),
        "scene.toml: camera.yaw_deg = 1e308: must be a finite number in [-360, 360]"
    );
    // A long value with a bidirectional override: shortened and escaped.
    let long = format!("[camera]\nprojection = \"\u{202e}{}\"", "x".repeat(100_000));
    let m = error_of(&long);
    assert!(m.len() < 400, "{} bytes", m.len());
    assert!(
        m.contains("\\u{202e}") && !m.contains('\u{202e}') && m.contains("100001 characters"),
        "{m}"
    );
}
