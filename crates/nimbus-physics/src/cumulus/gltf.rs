//! Binary glTF 2.0 (`.glb`) export of the cumulus meshes, with the shader's
//! per-vertex data as application-specific attributes (glTF 2.0 §3.7.2.1:
//! names starting with an underscore), written by [`crate::glb`]:
//!
//! | attribute | type | content |
//! |---|---|---|
//! | `POSITION`, `NORMAL` | VEC3 float | m; outward unit normal |
//! | `_D1`, `_D2`, … | SCALAR float | distance to the surface 1, 2, … levels below, m |
//! | `_N1`, `_N2`, … | VEC3 float | outward unit normal of that surface |
//! | `_BLOB_CENTRE` | VEC3 float | centre of the vertex's blob, m |
//! | `_BLOB_RADIUS` | SCALAR float | its radius, m |
//! | `_BLOB_ID` | SCALAR float | its index in the hierarchy (exact below 2²⁴) |
//!
//! Levels of detail: each is a mesh in a scene of its own (scene 0, the
//! finest, is the default), so that an importer shows one at a time.
//! `MSFT_lod` would hang them on one node, but Blender's importer (and most
//! others) ignores it and would show the finest only, so the levels stay
//! separate scenes. Units are metres, y up, as glTF wants; the material
//! `cumulus` is white and matte.

use super::surface::CumulusMesh;
use crate::glb::{AttributeValues, GlbBuilder, GlbError, MeshData, NodeTransform};
use std::borrow::Cow;

/// A cumulus mesh as [`MeshData`] with the attributes of the module's table.
pub fn cumulus_mesh_data<'a>(name: &str, mesh: &'a CumulusMesh) -> MeshData<'a> {
    let mut custom = Vec::new();
    for (j, (d, n)) in mesh
        .base_distances_m
        .iter()
        .zip(&mesh.base_normals)
        .enumerate()
    {
        custom.push((
            format!("_D{}", j + 1),
            AttributeValues::Scalar(Cow::Borrowed(d)),
        ));
        custom.push((
            format!("_N{}", j + 1),
            AttributeValues::Vec3(Cow::Borrowed(n)),
        ));
    }
    custom.push((
        "_BLOB_CENTRE".into(),
        AttributeValues::Vec3(Cow::Borrowed(&mesh.blob_centres_m)),
    ));
    custom.push((
        "_BLOB_RADIUS".into(),
        AttributeValues::Scalar(Cow::Borrowed(&mesh.blob_radii_m)),
    ));
    custom.push((
        "_BLOB_ID".into(),
        AttributeValues::Scalar(mesh.blob_ids.iter().map(|&i| i as f32).collect()),
    ));
    MeshData {
        name: name.into(),
        positions: Cow::Borrowed(&mesh.positions),
        normals: Some(Cow::Borrowed(&mesh.normals)),
        colours: None,
        custom,
        indices: Cow::Borrowed(&mesh.indices),
        material: None,
    }
}

/// The `.glb` bytes of the levels of detail `lods` (finest first): mesh and
/// node `cumulus_lod{i}` in scene `lod{i}`, each level a scene of its own.
pub fn to_glb(lods: &[CumulusMesh]) -> Result<Vec<u8>, GlbError> {
    let mut builder = GlbBuilder::new();
    let material = builder.add_material("cumulus", [1.0, 1.0, 1.0]);
    for (lod, mesh) in lods.iter().enumerate() {
        let name = format!("cumulus_lod{lod}");
        let mesh = builder.add_mesh(&MeshData {
            material: Some(material),
            ..cumulus_mesh_data(&name, mesh)
        })?;
        let node = builder.add_node(&name, Some(mesh), NodeTransform::IDENTITY, &[]);
        builder.add_scene(&format!("lod{lod}"), &[node])?;
    }
    builder.finish()
}
