//! `nimbus export SCENE --mitsuba DIR`: the cumulus media as Mitsuba 3
//! reads them (one medium at a time): clouds whose boxes overlap become one
//! grid, the others keep their own; read back from the written XML and the
//! grids' `.vol` headers. Needs an adapter (the export places the clouds
//! by rendering a frame).

use crate::support::*;

/// Two clouds of one shape 500 m apart (their boxes, over a kilometre
/// across, overlap) and a third 9 km away.
const SCENE: &str = r#"
[terrain]
resolution = 32
extent_m = 24000.0
height_scale_m = 200.0

[cumulus]
variants = 1
levels_of_detail = 1

[[cumulus.clouds]]
position_m = [0.0, 1500.0, 0.0]

[[cumulus.clouds]]
position_m = [500.0, 1500.0, 200.0]
yaw_deg = 60.0

[[cumulus.clouds]]
position_m = [9000.0, 1500.0, 0.0]
"#;

/// The world box of a `.vol` grid: its header's bounding box (min x, y,
/// z, max x, y, z) and its cell counts.
fn vol_box(path: &std::path::Path) -> ([f32; 6], [i32; 3]) {
    let bytes = std::fs::read(path).expect("vol");
    assert_eq!(&bytes[..3], b"VOL");
    let int = |at: usize| i32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let dims = [int(8), int(12), int(16)];
    assert_eq!(
        bytes.len(),
        48 + 4 * dims.iter().map(|&d| d as usize).product::<usize>()
    );
    (std::array::from_fn(|i| float(24 + 4 * i)), dims)
}

#[test]
fn export_mitsuba_merges_the_clouds_whose_boxes_overlap() {
    let dir = temp_dir("mitsuba", "overlap");
    std::fs::write(dir.join("scene.toml"), SCENE).expect("scene");
    let out = nimbus(
        &[
            "export",
            "scene.toml",
            "--mitsuba",
            "out",
            "--width",
            "64",
            "--height",
            "36",
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("merged (2 clouds in 1 medium)") && stderr.contains("(3 cumulus"),
        "{stderr}"
    );
    let xml = std::fs::read_to_string(dir.join("out/scene.xml")).expect("scene.xml");
    // One medium for the pair, the far cloud its own; each bounded by one box.
    let media: Vec<&str> = xml
        .match_indices("<medium type=\"heterogeneous\" id=\"")
        .map(|(at, m)| {
            let rest = &xml[at + m.len()..];
            &rest[..rest.find('"').expect("id")]
        })
        .collect();
    assert_eq!(media, ["cumulus_merged_0", "cumulus_2"], "{media:?}");
    for id in &media {
        assert_eq!(
            xml.matches(&format!("<ref name=\"interior\" id=\"{id}\"/>"))
                .count(),
            1
        );
    }
    assert!(xml.contains("<string name=\"filename\" value=\"cumulus_merged_0.vol\"/>"));
    // The merged grid lies in the world's axes around both clouds' bases;
    // the single cloud's grid is in its shape's frame (a few km across).
    let ([x0, y0, z0, x1, y1, z1], dims) = vol_box(&dir.join("out/cumulus_merged_0.vol"));
    for (x, z) in [(0.0, 0.0), (500.0, 200.0)] {
        assert!(
            x0 < x && x < x1 && z0 < z && z < z1,
            "({x}, {z}) outside {x0}..{x1} × {z0}..{z1}"
        );
    }
    assert!(
        (1400.0..1600.0).contains(&y0) && y1 > y0 + 300.0,
        "{y0}..{y1}"
    );
    assert!(x1 < 4000.0, "the far cloud is not in it: {x0}..{x1}");
    assert!(dims.iter().all(|&d| d > 16), "{dims:?}");
    let (_, single) = vol_box(&dir.join("out/cumulus_0.vol"));
    assert!(single.iter().all(|&d| d > 16), "{single:?}");
    let notes = std::fs::read_to_string(dir.join("out/APPROXIMATIONS.md")).expect("notes");
    assert!(
        notes.contains("cumulus whose boxes overlap are merged"),
        "{notes}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--light sun` and `--light sky` keep one emitter each and turn the
/// terrain and the sea black (the full export keeps both and their
/// albedo): the reference's light split by where it comes from.
#[test]
fn export_mitsuba_light_keeps_one_emitter_over_black_surfaces() {
    let dir = temp_dir("mitsuba", "light");
    std::fs::write(dir.join("scene.toml"), SCENE).expect("scene");
    let export = |out: &str, light: Option<&str>| -> String {
        let mut args = vec![
            "export",
            "scene.toml",
            "--mitsuba",
            out,
            "--width",
            "32",
            "--height",
            "18",
        ];
        if let Some(light) = light {
            args.extend(["--light", light]);
        }
        let run = nimbus(&args, &dir);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        std::fs::read_to_string(dir.join(out).join("scene.xml")).expect("scene.xml")
    };
    let full = export("full", None);
    let sun = export("sun", Some("sun"));
    let sky = export("sky", Some("sky"));
    let emitters = |xml: &str| {
        (
            xml.matches("<emitter type=\"directional\">").count(),
            xml.matches("<emitter type=\"envmap\">").count(),
        )
    };
    assert_eq!(emitters(&full), (1, 1));
    assert_eq!(emitters(&sun), (1, 0));
    assert_eq!(emitters(&sky), (0, 1));
    for xml in [&sun, &sky] {
        assert!(!xml.contains("terrain_albedo.png") && !xml.contains("roughplastic"));
        assert_eq!(
            xml.matches("<rgb name=\"reflectance\" value=\"0, 0, 0\"/>")
                .count(),
            2
        );
    }
    assert!(full.contains("terrain_albedo.png") && full.contains("roughplastic"));
    // The clouds are the same media in all three.
    let media = |xml: &str| xml.matches("<medium type=\"heterogeneous\"").count();
    assert_eq!(media(&sun), media(&full));
    assert_eq!(media(&sky), media(&full));
    let notes = std::fs::read_to_string(dir.join("sky/APPROXIMATIONS.md")).expect("notes");
    assert!(notes.contains("--light sky"), "{notes}");
    // Without --mitsuba it is refused in one line.
    let bad = nimbus(
        &["export", "scene.toml", "--gltf", "x.glb", "--light", "sun"],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && stderr.contains("--mitsuba"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
