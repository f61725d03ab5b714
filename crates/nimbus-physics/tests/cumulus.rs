//! The cumulus generator end to end: hierarchy → mesh → glTF, checked for
//! the properties the shader and the export promise.

use nimbus_physics::cumulus::gltf::to_glb;
use nimbus_physics::cumulus::hierarchy::{CumulusParams, RootBlob, Roots, build};
use nimbus_physics::cumulus::mesh::{check_closed_manifold, count_self_intersections};
use nimbus_physics::cumulus::surface::{cumulus_lods, cumulus_mesh};

fn two_root_cloud(levels: u32) -> nimbus_physics::cumulus::hierarchy::Cumulus {
    let params = CumulusParams {
        roots: Roots::Given(vec![
            RootBlob {
                centre_m: [0.0, 300.0, 0.0],
                radius_m: 320.0,
                flattening: 0.3,
            },
            RootBlob {
                centre_m: [420.0, 200.0, 60.0],
                radius_m: 260.0,
                flattening: 0.5,
            },
        ]),
        generated_levels: levels,
        ..CumulusParams::default()
    };
    build(&params, |_| {}).expect("build")
}

/// One generated level: a closed, consistently oriented, self-intersection
/// free surface; nothing below the floor beyond the field's analytic bound
/// (h₀ − α_h (1 − 1/(2e)) with g + n ≤ 2e); blob attributes filled.
#[test]
fn generated_cloud_is_watertight_with_a_flat_floor() {
    let cumulus = two_root_cloud(1);
    let mesh = cumulus_mesh(&cumulus, 0.5 * cumulus.field.mean_radius_m(1));
    let geometry = mesh.triangle_mesh();
    let topology = check_closed_manifold(&geometry);
    assert!(topology.is_watertight(), "{topology:?}");
    assert!(
        mesh.triangle_count() > 2000,
        "{} triangles",
        mesh.triangle_count()
    );
    assert_eq!(count_self_intersections(&geometry, 2.0 * mesh.cell_m), 0);

    let floor = cumulus.field.floor();
    let bound = floor.height_m - floor.stiffness_m * (1.0 - 1.0 / (2.0 * std::f64::consts::E));
    let lowest = mesh
        .positions
        .iter()
        .map(|p| p[1] as f64)
        .fold(f64::INFINITY, f64::min);
    assert!(
        lowest >= bound - mesh.cell_m,
        "lowest point {lowest} m, floor {} m",
        floor.height_m
    );
    // The floor is flat: many vertices lie within a cell of the lowest one.
    let flat = mesh
        .positions
        .iter()
        .filter(|p| (p[1] as f64) < lowest + mesh.cell_m)
        .count();
    assert!(flat > 30, "{flat} vertices on the floor");

    // Attributes: unit normals pointing away from the blob centre on the
    // whole, distances to S_0 non-negative, ids valid.
    let blob_count = (cumulus.levels[0].count + cumulus.levels[1].count) as u32;
    let mut outward = 0;
    for i in 0..mesh.positions.len() {
        let n = glam::Vec3::from(mesh.normals[i]);
        assert!((n.length() - 1.0).abs() < 1e-3);
        assert!(mesh.base_distances_m[0][i] >= 0.0);
        assert!(mesh.blob_ids[i] < blob_count);
        let from_centre =
            glam::Vec3::from(mesh.positions[i]) - glam::Vec3::from(mesh.blob_centres_m[i]);
        outward += usize::from(n.dot(from_centre) > 0.0);
    }
    assert!(
        outward as f64 > 0.9 * mesh.positions.len() as f64,
        "{outward} outward"
    );
}

/// The `.glb` reads back in an independent reader (the `gltf` crate) with
/// every attribute, the right counts and the same data.
#[test]
fn glb_reads_back_in_an_independent_reader() {
    let cumulus = two_root_cloud(2);
    let lods = cumulus_lods(&cumulus, 2, |_| {});
    let bytes = to_glb(&lods).expect("glb");
    let (document, buffers, _) = gltf::import_slice(&bytes).expect("valid glb");
    assert_eq!(document.meshes().count(), 2);
    assert_eq!(document.scenes().count(), 2);
    for (mesh, lod) in document.meshes().zip(&lods) {
        let primitive = mesh.primitives().next().expect("primitive");
        let names: Vec<String> = primitive.attributes().map(|(s, _)| s.to_string()).collect();
        for name in [
            "POSITION",
            "NORMAL",
            "_D1",
            "_N1",
            "_D2",
            "_N2",
            "_BLOB_CENTRE",
            "_BLOB_RADIUS",
            "_BLOB_ID",
        ] {
            assert!(
                names.iter().any(|n| n == name),
                "{name} missing from {names:?}"
            );
        }
        for (_, accessor) in primitive.attributes() {
            assert_eq!(accessor.count(), lod.positions.len());
        }
        let reader = primitive.reader(|b| Some(&buffers[b.index()]));
        let positions: Vec<[f32; 3]> = reader.read_positions().expect("positions").collect();
        assert_eq!(positions, lod.positions);
        let indices: Vec<u32> = reader.read_indices().expect("indices").into_u32().collect();
        assert_eq!(indices, lod.indices);
    }
    // The coarser level of detail has fewer triangles.
    assert!(lods[1].triangle_count() * 2 < lods[0].triangle_count());
}
