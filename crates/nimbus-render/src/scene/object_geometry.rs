//! CPU geometry of the static objects: boxes built from their size and glTF
//! meshes (read by [`crate::scene::gltf`]), both baked into one world-space
//! triangle list (the objects never move, so there is no per-object
//! transform on the GPU).

use super::gltf::{GltfError, GltfMesh, load_gltf};
use crate::scene::{MAX_OBJECT_TRIANGLES, ObjectShape, Scene};
use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4, DVec3};

/// One baked vertex (WGSL `ObjectVertex`): world position at offset 0, as
/// the occluder consumers expect (see `frame::occluders`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ObjectVertex {
    /// World position, m.
    pub position_m: [f32; 3],
    /// Unit surface normal, world frame.
    pub normal: [f32; 3],
    /// Linear Rec.709 albedo.
    pub albedo: [f32; 3],
}

/// All objects of a scene as one world-space indexed triangle list,
/// counter-clockwise seen from outside.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectGeometry {
    /// The vertices.
    pub vertices: Vec<ObjectVertex>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// The files read (glTF files and their external buffers).
    pub files_read: Vec<std::path::PathBuf>,
}

impl ObjectGeometry {
    /// Number of triangles.
    pub fn triangle_count(&self) -> u64 {
        self.indices.len() as u64 / 3
    }

    /// Axis-aligned bounds (min, max) of the vertices, world m; `None` when empty.
    pub fn bounds_m(&self) -> Option<([f32; 3], [f32; 3])> {
        let first = self.vertices.first()?.position_m;
        Some(self.vertices.iter().fold((first, first), |(lo, hi), v| {
            (
                [0, 1, 2].map(|k| lo[k].min(v.position_m[k])),
                [0, 1, 2].map(|k| hi[k].max(v.position_m[k])),
            )
        }))
    }

    /// Appends a box: 24 vertices (four per face, so each face has its own
    /// flat normal) and 12 triangles.
    pub fn push_box(
        &mut self,
        center_m: [f64; 3],
        size_m: [f64; 3],
        yaw_deg: f64,
        albedo: [f32; 3],
    ) {
        let rotation = DMat3::from_rotation_y(yaw_deg.to_radians());
        let centre = DVec3::from_array(center_m);
        let half = DVec3::from_array(size_m) * 0.5;
        // Each face: its outward normal n and two edge directions u, v with
        // u × v = n, so corners in the order (−u−v, +u−v, +u+v, −u+v) turn
        // anticlockwise seen from outside.
        let faces = [
            (DVec3::X, DVec3::Y, DVec3::Z),
            (DVec3::NEG_X, DVec3::Z, DVec3::Y),
            (DVec3::Y, DVec3::Z, DVec3::X),
            (DVec3::NEG_Y, DVec3::X, DVec3::Z),
            (DVec3::Z, DVec3::X, DVec3::Y),
            (DVec3::NEG_Z, DVec3::Y, DVec3::X),
        ];
        for (n, u, v) in faces {
            let base = self.vertices.len() as u32;
            let normal = (rotation * n).as_vec3().to_array();
            for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let local = (n + u * su + v * sv) * half;
                self.vertices.push(ObjectVertex {
                    position_m: (centre + rotation * local).as_vec3().to_array(),
                    normal,
                    albedo,
                });
            }
            self.indices
                .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }

    /// Appends a glTF mesh placed in the world by `world_from_mesh`; vertices
    /// without a base colour of their own take `albedo`.
    pub fn push_mesh(&mut self, mesh: &GltfMesh, world_from_mesh: DMat4, albedo: [f32; 3]) {
        let base = self.vertices.len() as u32;
        let normal_matrix = DMat3::from_mat4(world_from_mesh).inverse().transpose();
        let flip = DMat3::from_mat4(world_from_mesh).determinant() < 0.0;
        for ((p, n), colour) in mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .zip(&mesh.base_colour)
        {
            self.vertices.push(ObjectVertex {
                position_m: world_from_mesh.transform_point3(*p).as_vec3().to_array(),
                normal: (normal_matrix * *n)
                    .normalize_or(DVec3::Y)
                    .as_vec3()
                    .to_array(),
                albedo: colour.unwrap_or(albedo),
            });
        }
        for tri in mesh.indices.chunks_exact(3) {
            // A mirroring transform turns the winding over (glTF §3.7.4).
            let (b, c) = if flip {
                (tri[2], tri[1])
            } else {
                (tri[1], tri[2])
            };
            self.indices
                .extend_from_slice(&[base + tri[0], base + b, base + c]);
        }
    }
}

/// Why the objects' geometry could not be built.
#[derive(Debug, thiserror::Error)]
pub enum ObjectsError {
    /// The geometry exceeds the device's buffer limit.
    #[error(transparent)]
    Limit(#[from] crate::core::limits::LimitError),
    /// A mesh's glTF file could not be read.
    #[error("objects[{index}].gltf = {path:?}: {source}")]
    Gltf {
        /// Index of the object in `[[objects]]`.
        index: usize,
        /// The path as written in the scene.
        path: String,
        /// Why.
        source: GltfError,
    },
    /// An object lacks a key its kind needs (a scene that was not validated).
    #[error("objects[{index}]: a key of its kind is missing (validate the scene first)")]
    Incomplete {
        /// Index of the object.
        index: usize,
    },
    /// A position is not finite after the object's transform.
    #[error("objects[{index}]: a vertex position is not finite after the object's transform")]
    NotFinite {
        /// Index of the object.
        index: usize,
    },
}

/// Builds the world-space geometry of every object of `scene`, reading the
/// glTF files (relative paths resolved with [`Scene::resolve_path`]).
pub fn build(scene: &Scene) -> Result<ObjectGeometry, ObjectsError> {
    let mut geometry = ObjectGeometry::default();
    for (index, object) in scene.objects.iter().enumerate() {
        let albedo = object.albedo.map(|c| {
            if c.is_finite() {
                c.clamp(0.0, 1.0) as f32
            } else {
                0.0
            }
        });
        let first_vertex = geometry.vertices.len();
        match object.shape() {
            Some(ObjectShape::Box { center_m, size_m }) => {
                geometry.push_box(center_m, size_m, object.yaw_deg, albedo);
            }
            Some(ObjectShape::Mesh {
                gltf,
                position_m,
                scale,
            }) => {
                let budget = MAX_OBJECT_TRIANGLES.saturating_sub(geometry.triangle_count());
                let mesh = load_gltf(&scene.resolve_path(gltf), budget).map_err(|source| {
                    ObjectsError::Gltf {
                        index,
                        path: gltf.to_owned(),
                        source,
                    }
                })?;
                let world_from_mesh = DMat4::from_scale_rotation_translation(
                    DVec3::splat(scale),
                    glam::DQuat::from_rotation_y(object.yaw_deg.to_radians()),
                    DVec3::from_array(position_m),
                );
                geometry.push_mesh(&mesh, world_from_mesh, albedo);
                geometry.files_read.extend(mesh.files_read);
            }
            None => return Err(ObjectsError::Incomplete { index }),
        }
        let added = &geometry.vertices[first_vertex..];
        if !added
            .iter()
            .all(|v| v.position_m.iter().all(|c| c.is_finite()))
        {
            return Err(ObjectsError::NotFinite { index });
        }
    }
    Ok(geometry)
}

/// Asserts that each triangle's winding normal agrees with its vertices' normals.
#[cfg(test)]
pub(crate) fn assert_winding_matches_normals(vertices: &[ObjectVertex], indices: &[u32]) {
    for tri in indices.chunks_exact(3) {
        let p = |k: usize| glam::Vec3::from_array(vertices[tri[k] as usize].position_m);
        let face = (p(1) - p(0)).cross(p(2) - p(0));
        for k in 0..3 {
            let n = glam::Vec3::from_array(vertices[tri[k] as usize].normal);
            assert!(
                face.dot(n) > 0.0,
                "triangle {tri:?} is wound against its normals"
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneObject;
    use std::path::PathBuf;

    fn scenes_dir() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
    }

    #[test]
    fn box_faces_are_flat_outward_and_counter_clockwise_from_outside() {
        for yaw in [0.0, 37.0, -200.0] {
            let mut g = ObjectGeometry::default();
            let centre = [3.0, 1.5, -2.0];
            g.push_box(centre, [2.0, 3.0, 4.0], yaw, [0.5; 3]);
            assert_eq!((g.vertices.len(), g.indices.len()), (24, 36));
            assert_winding_matches_normals(&g.vertices, &g.indices);
            for v in &g.vertices {
                let n = glam::Vec3::from_array(v.normal);
                let out = glam::Vec3::from_array(v.position_m)
                    - glam::DVec3::from_array(centre).as_vec3();
                assert!((n.length() - 1.0).abs() < 1e-5);
                assert!(n.dot(out) > 0.0, "normal {n} points inwards");
            }
        }
    }

    #[test]
    fn positive_yaw_turns_east_towards_north() {
        let mut g = ObjectGeometry::default();
        g.push_box([0.0; 3], [4.0, 1.0, 1.0], 90.0, [0.5; 3]);
        let (lo, hi) = g.bounds_m().expect("bounds");
        assert!((hi[0] - lo[0] - 1.0).abs() < 1e-5 && (hi[2] - lo[2] - 4.0).abs() < 1e-5);
        // The face that looked east (+X) now looks north (−Z).
        assert!(
            g.vertices[..4].iter().all(|v| {
                (glam::Vec3::from_array(v.normal) - glam::Vec3::NEG_Z).length() < 1e-6
            })
        );
    }

    #[test]
    fn build_places_meshes_and_boxes_in_the_world() {
        let mut scene = Scene {
            base_dir: Some(scenes_dir()),
            ..Scene::default()
        };
        let mut shed = SceneObject::new_mesh("assets/shed.gltf", [100.0, 20.0, -50.0], 90.0);
        shed.scale = Some(2.0);
        scene.objects = vec![
            SceneObject::new_box([0.0, 1.0, 0.0], [2.0, 2.0, 2.0], 0.0, [0.2, 0.3, 0.4]),
            shed,
        ];
        let g = build(&scene).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(g.triangle_count(), 12 + 30);
        assert_winding_matches_normals(&g.vertices, &g.indices);
        // The shed, twice its size and turned a quarter anticlockwise: its
        // 2.7 m span along x now lies along z.
        let shed: Vec<_> = g.vertices[24..].iter().map(|v| v.position_m).collect();
        let lo = shed
            .iter()
            .fold([f32::MAX; 3], |a, p| [0, 1, 2].map(|k| a[k].min(p[k])));
        let hi = shed
            .iter()
            .fold([f32::MIN; 3], |a, p| [0, 1, 2].map(|k| a[k].max(p[k])));
        let expect_lo = [100.0 - 2.1, 20.0, -50.0 - 2.7];
        let expect_hi = [100.0 + 2.1, 25.2, -50.0 + 2.7];
        for k in 0..3 {
            assert!(
                (lo[k] - expect_lo[k]).abs() < 1e-3 && (hi[k] - expect_hi[k]).abs() < 1e-3,
                "{lo:?} {hi:?}"
            );
        }
        assert_eq!(g.bounds_m().map(|b| b.1[1]), Some(25.2));
        // An unvalidated scene with a missing file: a typed error, not a panic.
        scene.objects[1].gltf = Some("assets/absent.gltf".into());
        let err = build(&scene).expect_err("missing file").to_string();
        assert!(
            err.starts_with("objects[1].gltf = \"assets/absent.gltf\": cannot read"),
            "{err}"
        );
    }
}
