//! `nimbus export SCENE --gltf FILE.glb`: the file read back twice, its
//! JSON chunk (node and mesh names, attributes, counts, the clouds'
//! translations) and its geometry through nimbus's own glTF reader (the
//! one `[[objects]] gltf = …` uses: node transforms applied, world
//! metres); one-line errors and no file on bad input. CPU only.

use crate::support::*;

/// The JSON chunk of a `.glb` (glTF 2.0 §4.4), as the gltf crate frames it
/// (its header, chunk lengths and types checked).
fn json_chunk(glb: &[u8]) -> serde_json::Value {
    let glb = gltf::Glb::from_slice(glb).expect("a binary glTF file");
    serde_json::from_slice(&glb.json).expect("JSON chunk")
}

/// Two hand-placed clouds of one shape, a steady 5 m/s wind from the west,
/// a terrain of 32 × 32 cells below 1000 m.
const SCENE: &str = r#"
[terrain]
resolution = 32
extent_m = 10000.0
height_scale_m = 300.0

[wind]
speed_m_s = 5.0
from_deg = 270.0

[cumulus]
variants = 1
levels_of_detail = 1

[[cumulus.clouds]]
position_m = [-2000.0, 1500.0, 1000.0]

[[cumulus.clouds]]
position_m = [1500.0, 1800.0, -2500.0]
yaw_deg = 45.0
scale = 0.7
"#;

#[test]
fn export_gltf_writes_named_terrain_and_clouds_where_the_wind_has_carried_them() {
    let dir = temp_dir("gltf", "scene");
    std::fs::write(dir.join("scene.toml"), SCENE).expect("scene");
    let start = std::time::Instant::now();
    let out = nimbus(
        &[
            "export",
            "scene.toml",
            "--gltf",
            "out.glb",
            "--time-s",
            "60",
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    eprintln!("export took {:.2} s", start.elapsed().as_secs_f64());
    assert!(
        stderr.contains("2 cumulus instancing 1 shapes") && stderr.contains("1089 vertices"),
        "{stderr}"
    );
    // Nothing but the file: the temporary one was renamed into place.
    assert_eq!(files_in(&dir), ["out.glb", "scene.toml"]);

    let glb = std::fs::read(dir.join("out.glb")).expect("glb");
    let json = json_chunk(&glb);
    let nodes = json["nodes"].as_array().expect("nodes");
    let name = |i: &serde_json::Value| {
        nodes[i.as_u64().expect("index") as usize]["name"]
            .as_str()
            .expect("named")
            .to_owned()
    };
    let scene = &json["scenes"][json["scene"].as_u64().expect("default scene") as usize];
    let roots: Vec<String> = scene["nodes"]
        .as_array()
        .expect("roots")
        .iter()
        .map(name)
        .collect();
    assert_eq!(roots, ["terrain", "cumulus"]);
    let group = nodes
        .iter()
        .find(|n| n["name"] == "cumulus")
        .expect("cumulus");
    let clouds: Vec<String> = group["children"]
        .as_array()
        .expect("children")
        .iter()
        .map(name)
        .collect();
    assert_eq!(clouds, ["cumulus_0", "cumulus_1"]);

    // Each cloud's node: its hand-placed base moved 300 m east (5 m/s × 60 s).
    for (cloud, base) in [
        ("cumulus_0", [-1700.0, 1500.0, 1000.0]),
        ("cumulus_1", [1800.0, 1800.0, -2500.0]),
    ] {
        let node = nodes.iter().find(|n| n["name"] == cloud).expect(cloud);
        let t: Vec<f64> = node["translation"]
            .as_array()
            .expect("translation")
            .iter()
            .map(|v| v.as_f64().expect("number"))
            .collect();
        for k in 0..3 {
            assert!(
                (t[k] - base[k]).abs() < 1e-3,
                "{cloud}: {t:?}, not {base:?}"
            );
        }
        assert_eq!(
            json["meshes"][node["mesh"].as_u64().expect("mesh") as usize]["name"],
            "cumulus_variant0"
        );
    }

    // Meshes: attributes and counts.
    let accessors = json["accessors"].as_array().expect("accessors");
    let count = |i: &serde_json::Value| {
        accessors[i.as_u64().expect("index") as usize]["count"]
            .as_u64()
            .expect("count")
    };
    let mesh = |name: &str| {
        json["meshes"]
            .as_array()
            .expect("meshes")
            .iter()
            .find(|m| m["name"] == name)
            .unwrap_or_else(|| panic!("mesh {name}"))["primitives"][0]
            .clone()
    };
    let terrain = mesh("terrain");
    assert_eq!(count(&terrain["attributes"]["POSITION"]), 33 * 33);
    assert_eq!(count(&terrain["indices"]), 32 * 32 * 6);
    let cloud = mesh("cumulus_variant0");
    let attributes = cloud["attributes"].as_object().expect("attributes");
    let mut names: Vec<&str> = attributes.keys().map(String::as_str).collect();
    names.sort();
    assert_eq!(
        names,
        [
            "NORMAL",
            "POSITION",
            "_BLOB_CENTRE",
            "_BLOB_RADIUS",
            "_D1",
            "_D2",
            "_N1",
            "_N2"
        ]
    );
    let cloud_vertices = count(&attributes["POSITION"]);
    assert!(cloud_vertices > 1000, "{cloud_vertices}");
    for (attribute, accessor) in attributes {
        assert_eq!(count(accessor), cloud_vertices, "{attribute}");
    }

    // The geometry in world space, through nimbus's glTF reader: the
    // terrain once and the shape twice, the clouds above the bases.
    let world = nimbus_render::scene::gltf::load_gltf(&dir.join("out.glb"), 2_000_000)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(world.positions.len() as u64, 33 * 33 + 2 * cloud_vertices);
    let (lo, hi) = world.bounds_m().expect("bounds");
    assert!(
        (lo.x + 5000.0).abs() < 1e-3 && (hi.x - 5000.0).abs() < 1e-3,
        "{lo} {hi}"
    );
    assert!(
        hi.y > 1800.0 + 300.0,
        "the clouds rise above their bases: {hi}"
    );
    let above = |base: f64| {
        world
            .positions
            .iter()
            .filter(|p| p.y >= base - 0.05)
            .count()
    };
    // Every cloud vertex lies on or above the lower base (1500 m), every
    // one of the higher cloud's above 1800 m; the terrain's none.
    assert_eq!(above(1500.0) as u64, 2 * cloud_vertices);
    assert!(above(1800.0) as u64 >= cloud_vertices);
}

#[test]
fn export_gltf_bad_input_fails_with_one_line_and_writes_nothing() {
    let dir = temp_dir("gltf", "bad");
    std::fs::write(dir.join("empty.toml"), "[ground]\nterrain = false\n").expect("scene");
    std::fs::write(dir.join("scene.toml"), SCENE).expect("scene");
    let cases: [(&[&str], &[&str]); 5] = [
        (
            &["export", "scene.toml", "--gltf", "out.obj"],
            &["--gltf out.obj", ".glb"],
        ),
        (
            &["export", "scene.toml", "--gltf", "missing/out.glb"],
            &["missing/out.glb", "does not exist"],
        ),
        (
            &["export", "empty.toml", "--gltf", "out.glb"],
            &[
                "--gltf out.glb",
                "nothing to export",
                "ground.terrain = false",
            ],
        ),
        (&["export", "scene.toml"], &["--mitsuba", "--gltf"]),
        // The phase function per channel: only with the full peak.
        (
            &[
                "export",
                "scene.toml",
                "--mitsuba",
                "mitsuba",
                "--phase-per-channel",
            ],
            &["--phase-per-channel", "--phase-truncation-deg 0", "not 5"],
        ),
    ];
    for (args, fragments) in cases {
        assert_fails_with(&nimbus(args, &dir), fragments);
    }
    assert_eq!(files_in(&dir), ["empty.toml", "scene.toml"]);
}
