//! Scene exports for other tools, without a GPU: [`scene_glb`] writes a
//! scene's cumulus field and terrain at one time as binary glTF 2.0, for
//! Blender and other DCC tools.
//!
//! The file (metres, +y up, east +x, north −z: nimbus's world frame is
//! glTF's), every node named:
//!
//! - `terrain`: the relief the terrain pass draws
//!   ([`crate::passes::terrain::build_mesh`]: the water surface where it is
//!   above the ground), in world space, with `COLOR_0` the linear surface
//!   albedo and the matte material `terrain`. Absent when `ground.terrain =
//!   false` (nothing is drawn then).
//! - `cumulus`: the parent of one node `cumulus_{i}` per cloud of the field
//!   (all of them, not only those a camera sees), where the cumulus pass
//!   draws them at that time ([`crate::passes::cumulus::cumulus_field_at`]:
//!   the same placement and wind drift). Each instances the mesh
//!   `cumulus_variant{v}` of its shape, the variant's finest level of detail
//!   in its own frame (origin at the centre of its base), through the
//!   node's translation (the base centre, m), rotation (turn about +y) and
//!   uniform scale: world = base + scale · R(yaw) · object, as in the
//!   shader. Blender imports the instances as linked duplicates. Attributes
//!   as in [`nimbus_physics::cumulus::gltf`] (`_D1`… distances in m, `_N1`…,
//!   `_BLOB_CENTRE` in the mesh's frame, `_BLOB_RADIUS`) except `_BLOB_ID`,
//!   which the renderer's vertex format does not keep.

use crate::passes::cumulus::variants::{CumulusVariant, LOWER_LEVELS};
use crate::passes::cumulus::{CloudPlacement, CumulusError, cumulus_field_at};
use crate::passes::terrain::build_mesh;
use crate::scene::{Scene, SceneError};
use nimbus_physics::glb::{
    AttributeValues, GlbBuilder, GlbError, MeshData, MeshId, NodeId, NodeTransform,
};
use std::borrow::Cow;

/// Why a scene could not be exported.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The scene breaks a documented range.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A cumulus shape could not be generated.
    #[error(transparent)]
    Cumulus(#[from] CumulusError),
    /// Neither a drawn terrain nor cumulus: nothing to write.
    #[error(
        "the scene has nothing to export: no drawn terrain (ground.terrain = false) and no [cumulus]"
    )]
    Empty,
    /// The glTF document or container could not be written.
    #[error(transparent)]
    Glb(#[from] GlbError),
}

/// A scene written as `.glb`, with what it holds.
#[derive(Clone, Debug)]
pub struct SceneGlb {
    /// The `.glb` bytes.
    pub bytes: Vec<u8>,
    /// The clouds, in the order of the nodes `cumulus_{i}`.
    pub clouds: Vec<CloudPlacement>,
    /// Vertices of each cloud shape's mesh `cumulus_variant{v}`.
    pub variant_vertices: Vec<usize>,
    /// Vertices of the terrain's mesh (`None`: no terrain drawn).
    pub terrain_vertices: Option<usize>,
}

/// The mesh of a variant's finest level of detail, unpacked from the
/// shader's vertex format: distances back to metres (the format divides
/// them by their level's mean radius), the absent lower levels left out.
fn variant_mesh(name: String, shape: &CumulusVariant) -> MeshData<'static> {
    let Some(lod) = shape.lods.first() else {
        return MeshData {
            name,
            ..Default::default()
        };
    };
    let v = &lod.vertices;
    let xyz = |a: [f32; 4]| [a[0], a[1], a[2]];
    let mut custom = Vec::new();
    for level in 0..LOWER_LEVELS {
        let radius_m = shape.base_radii_m[level];
        if radius_m <= 0.0 {
            continue;
        }
        let (distance, normal): (Vec<f32>, Vec<[f32; 3]>) = v
            .iter()
            .map(|v| match level {
                0 => (v.normal_d1[3], xyz(v.n1_d3)),
                1 => (v.centre_d2[3], xyz(v.n2)),
                _ => (v.n1_d3[3], xyz(v.n3)),
            })
            .map(|(d, n)| (d * radius_m, n))
            .unzip();
        custom.push((
            format!("_D{}", level + 1),
            AttributeValues::Scalar(distance.into()),
        ));
        custom.push((
            format!("_N{}", level + 1),
            AttributeValues::Vec3(normal.into()),
        ));
    }
    custom.push((
        "_BLOB_CENTRE".into(),
        AttributeValues::Vec3(v.iter().map(|v| xyz(v.centre_d2)).collect()),
    ));
    custom.push((
        "_BLOB_RADIUS".into(),
        AttributeValues::Scalar(v.iter().map(|v| v.position_radius[3]).collect()),
    ));
    MeshData {
        name,
        positions: v.iter().map(|v| xyz(v.position_radius)).collect(),
        normals: Some(v.iter().map(|v| xyz(v.normal_d1)).collect()),
        colours: None,
        custom,
        indices: Cow::Owned(lod.indices.clone()),
        material: None,
    }
}

/// `scene` (as [`Scene::at_time`] gives it at `time_s`, like
/// [`crate::renderer::Renderer::prepare`]) at `time_s` as a `.glb`: its cumulus field
/// and its terrain (see the module's documentation). Generates or loads
/// the cumulus shapes (seconds the first time; cached on disk).
pub fn scene_glb(scene: &Scene, time_s: f64) -> Result<SceneGlb, ExportError> {
    scene.check()?;
    if !scene.ground.terrain && scene.cumulus.is_none() {
        return Err(ExportError::Empty);
    }
    let mut builder = GlbBuilder::new();
    let mut roots: Vec<NodeId> = Vec::new();

    let mut terrain_vertices = None;
    if scene.ground.terrain {
        let terrain = nimbus_physics::terrain::generate(&scene.terrain);
        let (vertices, indices) = build_mesh(&terrain);
        let material = builder.add_material("terrain", [1.0; 3]);
        terrain_vertices = Some(vertices.len());
        let mesh = builder.add_mesh(&MeshData {
            name: "terrain".into(),
            positions: vertices.iter().map(|v| v.position_m).collect(),
            normals: Some(vertices.iter().map(|v| v.normal).collect()),
            // build_mesh's vertex k is the terrain's grid vertex k.
            colours: Some(Cow::Borrowed(&terrain.albedo)),
            custom: Vec::new(),
            indices: Cow::Owned(indices),
            material: Some(material),
        })?;
        roots.push(builder.add_node("terrain", Some(mesh), NodeTransform::IDENTITY, &[]));
    }

    let mut clouds = Vec::new();
    let mut variant_vertices = Vec::new();
    if let Some(field) = cumulus_field_at(scene, time_s)? {
        let material = builder.add_material("cumulus", [1.0; 3]);
        // Only the shapes some cloud instances.
        let mut meshes: Vec<Option<MeshId>> = vec![None; field.shapes.len()];
        let mut children = Vec::with_capacity(field.clouds.len());
        for (index, cloud) in field.clouds.iter().enumerate() {
            let Some(shape) = field.shapes.get(cloud.variant) else {
                continue;
            };
            let mesh = match meshes[cloud.variant] {
                Some(mesh) => mesh,
                None => {
                    let data = MeshData {
                        material: Some(material),
                        ..variant_mesh(format!("cumulus_variant{}", cloud.variant), shape)
                    };
                    let mesh = builder.add_mesh(&data)?;
                    meshes[cloud.variant] = Some(mesh);
                    mesh
                }
            };
            children.push(builder.add_node(
                &format!("cumulus_{index}"),
                Some(mesh),
                NodeTransform {
                    translation_m: cloud.base_centre_m.to_array(),
                    yaw_rad: cloud.yaw_rad,
                    scale: cloud.scale,
                },
                &[],
            ));
        }
        roots.push(builder.add_node("cumulus", None, NodeTransform::IDENTITY, &children));
        clouds = field.clouds;
        variant_vertices = field
            .shapes
            .iter()
            .map(|s| s.lods.first().map_or(0, |l| l.vertices.len()))
            .collect();
    }
    builder.add_scene("nimbus", &roots)?;
    Ok(SceneGlb {
        bytes: builder.finish()?,
        clouds,
        variant_vertices,
        terrain_vertices,
    })
}
