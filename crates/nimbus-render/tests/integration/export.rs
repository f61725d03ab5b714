//! The scene's glTF export (`nimbus_render::export::scene_glb`) read back
//! with an independent reader (the `gltf` crate): named nodes, vertex
//! counts, the cumulus attributes, and every cloud where the scene puts it
//! at that time (its hand-placed base moved by the wind's drift), in world
//! metres, y up. CPU only: no adapter needed.

use glam::{Mat4, Vec3};
use nimbus_render::Scene;
use nimbus_render::export::scene_glb;

/// Two hand-placed clouds of two shapes (the second turned and scaled), a
/// steady wind, a small terrain.
const SCENE: &str = r#"
[terrain]
resolution = 48
extent_m = 12000.0

[wind]
speed_m_s = 10.0
from_deg = 270.0

[cumulus]
variants = 2
levels_of_detail = 1

[[cumulus.clouds]]
position_m = [-1500.0, 1400.0, 800.0]

[[cumulus.clouds]]
position_m = [2500.0, 1700.0, -600.0]
yaw_deg = 90.0
scale = 0.5
variant = 1
"#;

/// A node's name. (Read from the JSON: nimbus-render's `gltf` leaves out its
/// `names` feature; `gltf-json` has it, which the physics crate's writer
/// needs.)
fn node_name<'a>(document: &'a gltf::Document, node: &gltf::Node<'_>) -> Option<&'a str> {
    document.as_json().nodes[node.index()].name.as_deref()
}

/// A mesh's name (see [`node_name`]).
fn mesh_name<'a>(document: &'a gltf::Document, mesh: &gltf::Mesh<'_>) -> Option<&'a str> {
    document.as_json().meshes[mesh.index()].name.as_deref()
}

fn read_back(bytes: &[u8]) -> (gltf::Document, Vec<gltf::buffer::Data>) {
    let (document, buffers, _) = gltf::import_slice(bytes).expect("a valid .glb");
    (document, buffers)
}

/// World positions of a node's mesh: its parent chain's transforms applied.
fn world_positions(
    node: &gltf::Node<'_>,
    parent: Mat4,
    buffers: &[gltf::buffer::Data],
) -> Vec<Vec3> {
    let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
    let mesh = node.mesh().expect("a mesh");
    let primitive = mesh.primitives().next().expect("a primitive");
    let reader = primitive.reader(|b| Some(&buffers[b.index()]));
    reader
        .read_positions()
        .expect("positions")
        .map(|p| world.transform_point3(Vec3::from(p)))
        .collect()
}

#[test]
fn the_scene_glb_holds_the_terrain_and_each_cloud_where_the_wind_has_carried_it() {
    let start = std::time::Instant::now();
    let time_s = 120.0;
    let scene = Scene::from_toml_str(SCENE, "export.toml")
        .expect("scene")
        .at_time(time_s);
    let drift = scene.cloud_drift_m(time_s);
    // A west wind (from 270°) carries the clouds east, 10 m/s × 120 s.
    assert!(
        (drift[0] - 1200.0).abs() < 1e-6 && drift[1].abs() < 1e-6,
        "{drift:?}"
    );

    let export = scene_glb(&scene, time_s).expect("export");
    let (document, buffers) = read_back(&export.bytes);

    // Named nodes: the terrain and the cumulus group at the root.
    let gltf_scene = document.default_scene().expect("a default scene");
    let roots: Vec<_> = gltf_scene.nodes().collect();
    let names: Vec<&str> = roots
        .iter()
        .filter_map(|n| node_name(&document, n))
        .collect();
    assert_eq!(names, ["terrain", "cumulus"]);

    // The terrain: (resolution + 1)² vertices over the extent, world space.
    let terrain = &roots[0];
    let terrain_mesh = terrain.mesh().expect("terrain mesh");
    assert_eq!(mesh_name(&document, &terrain_mesh), Some("terrain"));
    let primitive = terrain_mesh.primitives().next().expect("primitive");
    let positions = primitive
        .get(&gltf::Semantic::Positions)
        .expect("positions");
    assert_eq!(positions.count(), 49 * 49);
    assert_eq!(export.terrain_vertices, Some(49 * 49));
    assert_eq!(primitive.indices().expect("indices").count(), 48 * 48 * 6);
    assert!(primitive.get(&gltf::Semantic::Colors(0)).is_some());
    let bounds = primitive.bounding_box();
    assert_eq!([bounds.min[0], bounds.min[2]], [-6000.0, -6000.0]);
    assert_eq!([bounds.max[0], bounds.max[2]], [6000.0, 6000.0]);

    // The clouds: one node each, named, instancing their shape's mesh.
    let group = &roots[1];
    let clouds: Vec<_> = group.children().collect();
    let names: Vec<&str> = clouds
        .iter()
        .filter_map(|n| node_name(&document, n))
        .collect();
    assert_eq!(names, ["cumulus_0", "cumulus_1"]);
    assert_eq!(export.clouds.len(), 2);
    let settings = scene.cumulus.as_ref().expect("cumulus");
    for (k, node) in clouds.iter().enumerate() {
        let placed = &settings.clouds[k];
        let mesh = node.mesh().expect("cloud mesh");
        assert_eq!(
            mesh_name(&document, &mesh),
            Some(format!("cumulus_variant{}", placed.variant).as_str())
        );
        let primitive = mesh.primitives().next().expect("primitive");
        let mut attributes: Vec<String> =
            primitive.attributes().map(|(s, _)| s.to_string()).collect();
        attributes.sort();
        // Two generated levels above the roots: two lower surfaces.
        assert_eq!(
            attributes,
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
        let count = primitive
            .get(&gltf::Semantic::Positions)
            .expect("positions")
            .count();
        assert_eq!(count, export.variant_vertices[placed.variant as usize]);
        assert!(count > 1000, "{count} vertices");
        for (_, accessor) in primitive.attributes() {
            assert_eq!(accessor.count(), count);
        }

        // World space: the base's centre is the hand-placed one moved by
        // the drift; the shape's lowest point lies on it, and the centre of
        // its footprint (a turn by 90° maps the footprint's box onto a box)
        // above it.
        let expected = Vec3::new(
            (placed.position_m[0] + drift[0]) as f32,
            placed.position_m[1] as f32,
            (placed.position_m[2] + drift[1]) as f32,
        );
        let world = world_positions(node, Mat4::IDENTITY, &buffers);
        let lo = world.iter().fold(Vec3::splat(f32::MAX), |a, p| a.min(*p));
        let hi = world.iter().fold(Vec3::splat(f32::MIN), |a, p| a.max(*p));
        assert!(
            (lo.y - expected.y).abs() < 0.05,
            "cloud {k}: lowest {} m, base {} m",
            lo.y,
            expected.y
        );
        let footprint_centre = 0.5 * (lo + hi);
        assert!(
            (footprint_centre.x - expected.x).abs() < 0.05
                && (footprint_centre.z - expected.z).abs() < 0.05,
            "cloud {k}: footprint centred at {footprint_centre}, base {expected}"
        );
        // The size follows the scale: the half-size cloud is a cumulus of
        // a few hundred metres, the other about a kilometre or more.
        let extent = hi - lo;
        let scale = placed.scale as f32;
        assert!(
            extent.x.max(extent.z) > 600.0 * scale && extent.x.max(extent.z) < 6000.0 * scale,
            "cloud {k}: extent {extent}"
        );
    }
    // The second cloud is turned by 90° about +y: its node says so.
    let (_, rotation, scale) = clouds[1].transform().decomposed();
    let expected = glam::Quat::from_rotation_y(90f32.to_radians());
    assert!(
        glam::Quat::from_array(rotation).dot(expected).abs() > 0.99999,
        "{rotation:?}"
    );
    assert_eq!(scale, [0.5; 3]);
    eprintln!("export read back in {:.2} s", start.elapsed().as_secs_f64());
}

/// Without drawn terrain (`ground.terrain = false`) the file holds no
/// terrain node, and a coverage-placed field stays inside its area; with
/// neither, there is nothing to export (an error, not an empty file).
#[test]
fn a_generated_field_without_terrain_exports_only_its_clouds_inside_the_area() {
    let text = "[ground]\nterrain = false\n\n[cumulus]\nvariants = 1\nlevels_of_detail = 1\ncoverage = 0.2\narea_m = 8000.0\n";
    let scene = Scene::from_toml_str(text, "field.toml").expect("scene");
    let export = scene_glb(&scene, 0.0).expect("export");
    assert_eq!(export.terrain_vertices, None);
    let (document, buffers) = read_back(&export.bytes);
    let roots: Vec<_> = document.default_scene().expect("scene").nodes().collect();
    assert_eq!(roots.len(), 1);
    assert_eq!(node_name(&document, &roots[0]), Some("cumulus"));
    let clouds: Vec<_> = roots[0].children().collect();
    assert!(clouds.len() >= 2, "{} clouds", clouds.len());
    assert_eq!(clouds.len(), export.clouds.len());
    // One shape, one mesh, instanced by every node.
    assert_eq!(document.meshes().count(), 1);
    for (node, placed) in clouds.iter().zip(&export.clouds) {
        let (translation, _, _) = node.transform().decomposed();
        let base = placed.base_centre_m;
        assert!(base.x.abs() <= 4000.0 && base.z.abs() <= 4000.0, "{base}");
        assert!((f64::from(translation[0]) - base.x).abs() < 1e-3);
        assert!((f64::from(translation[2]) - base.z).abs() < 1e-3);
        assert!((f64::from(translation[1]) - 1500.0).abs() < 1e-3);
        let world = world_positions(node, Mat4::IDENTITY, &buffers);
        let lowest = world.iter().map(|p| p.y).fold(f32::MAX, f32::min);
        assert!((lowest - 1500.0).abs() < 0.05, "lowest {lowest} m");
    }

    let none = Scene::from_toml_str("[ground]\nterrain = false\n", "empty.toml").expect("scene");
    let message = scene_glb(&none, 0.0).expect_err("nothing").to_string();
    assert!(
        message.contains("nothing to export") && message.contains("ground.terrain = false"),
        "{message}"
    );
}

/// The export places the clouds exactly where the cumulus pass draws them:
/// a generated field carried 6 km by the wind (so that it wraps around its
/// 8 km square) rendered once on the GPU, its placements compared with the
/// export's. Fails, never skips, without an adapter.
#[test]
fn the_export_places_every_cloud_where_the_renderer_draws_it() {
    let text = "[terrain]\nresolution = 32\n\n[wind]\nspeed_m_s = 20.0\nfrom_deg = 300.0\n\n[cumulus]\nvariants = 1\nlevels_of_detail = 1\ncoverage = 0.2\narea_m = 8000.0\n";
    // 300 s is exact in f32 (the renderer's frame time).
    let time_s = 300.0;
    let scene = Scene::from_toml_str(text, "wrap.toml")
        .expect("scene")
        .at_time(time_s);
    let mut headless = nimbus_render::headless::HeadlessRenderer::new(
        nimbus_render::AdapterPreference::Auto,
    )
    .unwrap_or_else(|e| {
        panic!("this test needs a GPU adapter (install Mesa's lavapipe for software Vulkan): {e}")
    });
    headless
        .render_frame(&scene, 16, 16, time_s as f32)
        .expect("render");
    let drawn = headless.renderer.cumulus().placed_clouds();
    let exported = scene_glb(&scene, time_s).expect("export").clouds;
    assert!(drawn.len() >= 2, "{} clouds", drawn.len());
    assert_eq!(exported, drawn);
    // The drift wrapped some clouds around the square: all stay inside it.
    assert!(
        exported
            .iter()
            .all(|c| c.base_centre_m.x.abs() <= 4000.0 && c.base_centre_m.z.abs() <= 4000.0)
    );
}
