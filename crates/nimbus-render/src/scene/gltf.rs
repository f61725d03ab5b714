//! Reading static objects' meshes from glTF 2.0 files (Khronos 2021).
//!
//! glTF is, like nimbus's world, right-handed with +Y up and metres, so a
//! mesh's scene frame needs no change of axes. Read: every primitive of mode
//! TRIANGLES reachable from the default scene (the first scene when none is
//! marked), with the node transforms applied (§3.5.3), positions and
//! normals as 32-bit floats and indices as unsigned integers (§3.7.2.1), and
//! each material's base colour factor. Not read: other primitive modes,
//! textures, morph targets, skins, sparse accessors and quantised
//! attributes. Where a primitive has no normals, it is drawn with flat
//! normals, as §3.7.2.1 requires.
//!
//! Every count and byte range taken from a file is checked before use, so a
//! malformed file gives a [`GltfError`] rather than a panic or an
//! out-of-bounds read.

use crate::scene::MAX_OBJECT_TRIANGLES;
use glam::{DMat3, DMat4, DVec3};
use std::path::{Path, PathBuf};

/// Largest glTF file read (JSON or binary; external buffers are bounded by
/// the triangle limit's accessor counts), bytes.
pub const MAX_GLTF_FILE_BYTES: u64 = 512 * 1024 * 1024;

/// Deepest node hierarchy followed: deeper ones are almost surely cycles,
/// which glTF forbids.
pub const MAX_NODE_DEPTH: usize = 64;

/// Most mesh instances (a primitive under one node) in one file.
pub const MAX_PRIMITIVE_INSTANCES: usize = 100_000;

/// Most elements of one accessor, and most vertices read from one file:
/// three for every allowed triangle.
const MAX_ACCESSOR_ELEMENTS: usize = 3 * MAX_OBJECT_TRIANGLES as usize;

/// glTF's largest vertex-attribute byte stride (§3.6.2.4).
const MAX_BYTE_STRIDE: usize = 252;

/// Why a glTF file could not be read. Each message is one line naming the file.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The file (or an external buffer) could not be read.
    #[error("cannot read {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The file is larger than [`MAX_GLTF_FILE_BYTES`].
    #[error(
        "{path} is {bytes} bytes ({}); at most {max} ({}) are read",
        nimbus_physics::io::human_bytes(*bytes),
        nimbus_physics::io::human_bytes(*max)
    )]
    TooLarge {
        /// The file.
        path: String,
        /// Its size.
        bytes: u64,
        /// The limit.
        max: u64,
    },
    /// The file is not valid glTF 2.0, or uses what nimbus does not read.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: String,
        /// What is wrong, naming the mesh, primitive or accessor.
        message: String,
    },
    /// The file has more triangles than the scene may still take.
    #[error(
        "{path} has {triangles} triangles; the objects may have at most {max} more (all objects together: {MAX_OBJECT_TRIANGLES})"
    )]
    TooManyTriangles {
        /// The file.
        path: String,
        /// Its triangles (counted from the accessors, before reading them).
        triangles: u64,
        /// The remaining budget.
        max: u64,
    },
}

/// The triangles of a glTF file in its scene frame (node transforms applied),
/// m: an indexed triangle list, counter-clockwise seen from the front.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GltfMesh {
    /// Vertex positions, m.
    pub positions: Vec<DVec3>,
    /// Unit vertex normals.
    pub normals: Vec<DVec3>,
    /// The material's base colour (linear), `None` where the object's albedo
    /// applies: no material, or a textured base colour (textures are not read).
    pub base_colour: Vec<Option<[f32; 3]>>,
    /// Three indices per triangle into the vertex arrays.
    pub indices: Vec<u32>,
    /// The files read: the glTF file and its external buffers.
    pub files_read: Vec<PathBuf>,
}

impl GltfMesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> u64 {
        self.indices.len() as u64 / 3
    }

    /// Axis-aligned bounds (min, max) of the positions, m; `None` when empty.
    pub fn bounds_m(&self) -> Option<(DVec3, DVec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }
}

/// Reads the triangles of a `.gltf` (embedded or external buffers) or `.glb`
/// file, refusing one with more than `max_triangles` before reading its
/// buffers.
pub fn load_gltf(path: &Path, max_triangles: u64) -> Result<GltfMesh, GltfError> {
    let data = read_bounded(path, &path.display().to_string())?;
    gltf_from_bytes(&data, path, max_triangles)
}

/// Reads the triangles of a glTF document (JSON or `.glb` bytes) as
/// [`load_gltf`] reads the file at `path`: errors name `path`, and external
/// buffers are looked up beside it.
pub fn gltf_from_bytes(
    data: &[u8],
    path: &Path,
    max_triangles: u64,
) -> Result<GltfMesh, GltfError> {
    let name = path.display().to_string();
    let io = |e: std::io::Error| GltfError::Io {
        path: name.clone(),
        message: e.to_string(),
    };
    let invalid = |message: String| GltfError::Invalid {
        path: name.clone(),
        message,
    };
    let not_gltf = |e: gltf::Error| invalid(format!("not valid glTF 2.0: {e}"));
    // gltf-json 1.4.1's validation indexes the accessor a primitive's
    // POSITION names without checking it exists (a panic found by fuzzing:
    // fuzz/regressions/gltf/); those indices are checked first, then the
    // parsed document is validated (parsed once: a .glb's binary chunk is
    // copied by the parse).
    let gltf::Gltf {
        document: unchecked,
        blob,
    } = gltf::Gltf::from_slice_without_validation(data).map_err(not_gltf)?;
    let root = unchecked.as_json();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(accessor) = primitive.attributes.get(&position)
                && accessor.value() >= root.accessors.len()
            {
                return Err(invalid(format!(
                    "mesh {m} primitive {p}: POSITION is accessor {}, but the file has {} accessors",
                    accessor.value(),
                    root.accessors.len()
                )));
            }
        }
    }
    let document = gltf::Document::from_json(unchecked.into_json()).map_err(not_gltf)?;
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| invalid("has no scene".to_owned()))?;

    // Every triangle primitive under the scene's nodes, with the node's
    // transform; counted before any buffer is read.
    let mut instances = Vec::new();
    let mut stack: Vec<_> = scene.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    let (mut triangles, mut vertices) = (0u64, 0u64);
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(invalid(format!(
                "node {} is nested deeper than {MAX_NODE_DEPTH} levels (a cycle?)",
                node.index()
            )));
        }
        // glTF matrices are column-major, as glam's.
        let matrix = parent * glam::Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
        if let Some(mesh) = node.mesh() {
            for primitive in mesh.primitives() {
                if primitive.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                let what = format!("mesh {} primitive {}", mesh.index(), primitive.index());
                let (t, v) =
                    primitive_size(&primitive).map_err(|m| invalid(format!("{what}: {m}")))?;
                triangles += t;
                vertices += v;
                if vertices > MAX_ACCESSOR_ELEMENTS as u64 {
                    return Err(invalid(format!(
                        "its scene has more than {MAX_ACCESSOR_ELEMENTS} vertices"
                    )));
                }
                if instances.len() == MAX_PRIMITIVE_INSTANCES {
                    return Err(invalid(format!(
                        "has more than {MAX_PRIMITIVE_INSTANCES} mesh primitive instances"
                    )));
                }
                instances.push((primitive, matrix, what));
            }
        }
        stack.extend(node.children().map(|c| (c, matrix, depth + 1)));
    }
    if triangles > max_triangles {
        return Err(GltfError::TooManyTriangles {
            path: name,
            triangles,
            max: max_triangles,
        });
    }
    if triangles == 0 {
        return Err(invalid("has no triangles in its scene".to_owned()));
    }

    let base_dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    // External buffers are checked as the file itself is (regular files of
    // at most MAX_GLTF_FILE_BYTES, their declared length present) before the
    // glTF crate reads them: it reads a file whole, whatever its size.
    for buffer in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = buffer.source()
            && !uri.starts_with("data:")
        {
            let file = base_dir.join(percent_decoded(uri));
            let shown = file.display().to_string();
            let bytes = nimbus_physics::io::check_regular_file(&file, MAX_GLTF_FILE_BYTES)
                .map_err(|e| invalid(format!("buffer {} {shown}: {e}", buffer.index())))?;
            if bytes < buffer.length() as u64 {
                return Err(invalid(format!(
                    "buffer {} ({uri}) is {bytes} bytes, shorter than its byteLength {}",
                    buffer.index(),
                    buffer.length()
                )));
            }
        }
    }
    let buffers = gltf::import_buffers(&document, Some(base_dir), blob).map_err(|e| match e {
        gltf::Error::Io(e) => io(e),
        e => invalid(format!("cannot read its buffers: {e}")),
    })?;
    let mut mesh = GltfMesh {
        files_read: std::iter::once(path.to_path_buf())
            .chain(
                document
                    .buffers()
                    .filter_map(|buffer| match buffer.source() {
                        gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => {
                            Some(base_dir.join(percent_decoded(uri)))
                        }
                        _ => None,
                    }),
            )
            .collect(),
        ..GltfMesh::default()
    };
    for (primitive, matrix, what) in &instances {
        read_primitive(&mut mesh, primitive, *matrix, &buffers)
            .map_err(|m| invalid(format!("{what}: {m}")))?;
    }
    Ok(mesh)
}

/// The bytes of a glTF file: a regular file of at most
/// [`MAX_GLTF_FILE_BYTES`], read through a bounded reader.
fn read_bounded(path: &Path, name: &str) -> Result<Vec<u8>, GltfError> {
    nimbus_physics::io::read_bounded(path, MAX_GLTF_FILE_BYTES).map_err(|e| read_error(name, e))
}

/// The error of a bounded read of `name` (the file or an external buffer).
fn read_error(name: &str, error: nimbus_physics::io::ReadError) -> GltfError {
    use nimbus_physics::io::ReadError;
    match error {
        ReadError::TooLarge { bytes, max } => GltfError::TooLarge {
            path: name.to_owned(),
            bytes,
            max,
        },
        ReadError::Io(message) => GltfError::Io {
            path: name.to_owned(),
            message,
        },
        other => GltfError::Invalid {
            path: name.to_owned(),
            message: other.to_string(),
        },
    }
}

/// A relative URI reference with its percent-escapes decoded (RFC 3986
/// §2.1), as glTF buffer URIs are written: `my%20mesh.bin` names
/// `my mesh.bin`. Malformed escapes are kept as they are.
fn percent_decoded(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && let (Some(hi), Some(lo)) = (
                bytes.get(i + 1).and_then(|&b| hex(b)),
                bytes.get(i + 2).and_then(|&b| hex(b)),
            )
        {
            out.push((hi * 16 + lo) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Triangles and vertices read from a TRIANGLES primitive, from its
/// accessors' counts, after checking the accessors it uses. Vertices: the
/// file's, or three per triangle where flat normals are made.
fn primitive_size(primitive: &gltf::Primitive<'_>) -> Result<(u64, u64), String> {
    use gltf::accessor::{DataType, Dimensions};
    let positions = primitive
        .get(&gltf::Semantic::Positions)
        .ok_or("has no POSITION")?;
    check_accessor(&positions, "POSITION", Dimensions::Vec3, &[DataType::F32])?;
    let normals = primitive.get(&gltf::Semantic::Normals);
    if let Some(normals) = &normals {
        check_accessor(normals, "NORMAL", Dimensions::Vec3, &[DataType::F32])?;
    }
    let count = match primitive.indices() {
        Some(indices) => {
            check_accessor(
                &indices,
                "indices",
                Dimensions::Scalar,
                &[DataType::U8, DataType::U16, DataType::U32],
            )?;
            indices.count()
        }
        None => positions.count(),
    };
    let triangles = count as u64 / 3;
    let vertices = if normals.is_some() {
        (positions.count() as u64).max(3 * triangles)
    } else {
        3 * triangles
    };
    Ok((triangles, vertices))
}

/// Checks an accessor's type, count and byte range, so that reading it can
/// neither panic nor read outside its buffer.
fn check_accessor(
    accessor: &gltf::Accessor<'_>,
    name: &str,
    dimensions: gltf::accessor::Dimensions,
    types: &[gltf::accessor::DataType],
) -> Result<(), String> {
    let what = format!("{name} (accessor {})", accessor.index());
    if accessor.sparse().is_some() {
        return Err(format!("{what} is sparse, which is not supported"));
    }
    if accessor.dimensions() != dimensions || !types.contains(&accessor.data_type()) {
        return Err(format!(
            "{what} is {:?} of {:?}; expected {dimensions:?} of {types:?}",
            accessor.dimensions(),
            accessor.data_type()
        ));
    }
    if accessor.normalized() {
        return Err(format!(
            "{what} is normalized (quantised), which is not supported"
        ));
    }
    let count = accessor.count();
    if count == 0 || count > MAX_ACCESSOR_ELEMENTS {
        return Err(format!(
            "{what} has {count} elements; expected 1 to {MAX_ACCESSOR_ELEMENTS}"
        ));
    }
    let view = accessor
        .view()
        .ok_or_else(|| format!("{what} has no buffer view"))?;
    let size = accessor.size();
    let stride = view.stride().unwrap_or(size);
    if stride < size || stride > MAX_BYTE_STRIDE {
        return Err(format!(
            "{what}: byte stride {stride} must be in [{size}, {MAX_BYTE_STRIDE}]"
        ));
    }
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > view.buffer().length()) {
        return Err(format!("{what}: its buffer view lies outside its buffer"));
    }
    // count ≤ 6e6 and stride ≤ 252, so the product cannot overflow.
    let end = accessor.offset().checked_add(stride * (count - 1) + size);
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!("{what} lies outside its buffer view"));
    }
    Ok(())
}

/// Appends one primitive (already checked by [`primitive_size`]),
/// transformed by `matrix`, to `mesh`.
fn read_primitive(
    mesh: &mut GltfMesh,
    primitive: &gltf::Primitive<'_>,
    matrix: DMat4,
    buffers: &[gltf::buffer::Data],
) -> Result<(), String> {
    let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let positions: Vec<DVec3> = reader
        .read_positions()
        .ok_or("POSITION data lies outside its buffer")?
        .map(|p| matrix.transform_point3(DVec3::from_array(p.map(f64::from))))
        .collect();
    if !positions.iter().all(|p| p.is_finite()) {
        return Err("a vertex position is not finite".to_owned());
    }
    let indices: Vec<u32> = match reader.read_indices() {
        Some(indices) => indices.into_u32().collect(),
        None if primitive.indices().is_some() => {
            return Err("index data lies outside its buffer".to_owned());
        }
        None => (0..positions.len() as u32).collect(),
    };
    let triangles = indices.len() / 3 * 3;
    let indices = &indices[..triangles];
    if let Some(bad) = indices.iter().find(|i| **i as usize >= positions.len()) {
        return Err(format!(
            "index {bad} is out of range (the primitive has {} vertices)",
            positions.len()
        ));
    }
    let normal_matrix = DMat3::from_mat4(matrix).inverse().transpose();
    let normals: Option<Vec<DVec3>> = reader.read_normals().map(|normals| {
        normals
            .map(|n| (normal_matrix * DVec3::from_array(n.map(f64::from))).normalize_or_zero())
            .collect()
    });
    let material = primitive.material();
    let pbr = material.pbr_metallic_roughness();
    let colour = (material.index().is_some() && pbr.base_color_texture().is_none()).then(|| {
        let [r, g, b, _] = pbr.base_color_factor();
        [r, g, b].map(|c| {
            if c.is_finite() {
                c.clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
    });
    // A mirroring node transform turns the winding over (glTF §3.7.4).
    let flip = DMat3::from_mat4(matrix).determinant() < 0.0;
    let base = mesh.positions.len();
    match normals {
        // Smooth: the file's vertices as they are.
        Some(normals)
            if normals.len() == positions.len() && normals.iter().all(|n| *n != DVec3::ZERO) =>
        {
            let base = base as u32;
            mesh.positions.extend(&positions);
            mesh.normals.extend(normals);
            mesh.base_colour
                .extend(std::iter::repeat_n(colour, positions.len()));
            for tri in indices.chunks_exact(3) {
                let (b, c) = if flip {
                    (tri[2], tri[1])
                } else {
                    (tri[1], tri[2])
                };
                mesh.indices
                    .extend_from_slice(&[base + tri[0], base + b, base + c]);
            }
        }
        // Flat (no normals, or unusable ones): three vertices per triangle,
        // each with the face normal.
        _ => {
            for tri in indices.chunks_exact(3) {
                let (b, c) = if flip {
                    (tri[2], tri[1])
                } else {
                    (tri[1], tri[2])
                };
                let p = [tri[0], b, c].map(|i| positions[i as usize]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or(DVec3::Y);
                let first = mesh.positions.len() as u32;
                mesh.positions.extend(p);
                mesh.normals.extend([n; 3]);
                mesh.base_colour.extend([colour; 3]);
                mesh.indices
                    .extend_from_slice(&[first, first + 1, first + 2]);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::object_geometry::{ObjectGeometry, assert_winding_matches_normals};
    use std::path::PathBuf;

    fn scenes_dir() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
    }

    fn temp_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("nimbus-objects-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        dir
    }

    #[test]
    fn shed_asset_loads_with_its_node_transforms_and_materials() {
        let mesh = load_gltf(&scenes_dir().join("assets/shed.gltf"), MAX_OBJECT_TRIANGLES)
            .unwrap_or_else(|e| panic!("{e}"));
        // Walls 12 + gables 2, roof 4, door 12.
        assert_eq!(mesh.triangle_count(), 30);
        let (lo, hi) = mesh.bounds_m().expect("bounds");
        // The roof node is translated 2 m up: its eaves at 1.9 m, the ridge at 2.6 m.
        assert!(
            (lo - DVec3::new(-1.35, 0.0, -1.05)).abs().max_element() < 1e-5,
            "{lo}"
        );
        assert!(
            (hi - DVec3::new(1.35, 2.6, 1.05)).abs().max_element() < 1e-5,
            "{hi}"
        );
        let mut g = ObjectGeometry::default();
        g.push_mesh(&mesh, DMat4::IDENTITY, [0.9; 3]);
        assert_winding_matches_normals(&g.vertices, &g.indices);
        // The roof sheets have no normals in the file: flat ones, up the
        // slope's normal (0, 0.9, ±0.6) / √1.17 (0.6 m rise over 0.9 m).
        let roof = [0.22, 0.06, 0.05];
        let roof_vertices: Vec<_> = g.vertices.iter().filter(|v| v.albedo == roof).collect();
        assert_eq!(roof_vertices.len(), 12);
        let norm = 1.17f32.sqrt();
        assert!(roof_vertices.iter().all(|v| {
            (v.normal[1] - 0.9 / norm).abs() < 1e-5 && (v.normal[2].abs() - 0.6 / norm).abs() < 1e-5
        }));
        // Every primitive has a material: the object's albedo is never used.
        assert!(g.vertices.iter().all(|v| v.albedo != [0.9; 3]));
    }

    /// A glTF document of one upward-facing triangle, its buffer `uri`
    /// (none: the GLB chunk), and the buffer's bytes.
    fn triangle_gltf(
        uri: Option<&str>,
        nodes: &str,
        position_count: u32,
        index: u16,
    ) -> (String, Vec<u8>) {
        let mut bin: Vec<u8> = [[0.0f32, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        for i in [0u16, 1, index] {
            bin.extend(i.to_le_bytes());
        }
        bin.extend([0, 0]);
        let uri = uri.map(|u| format!(r#","uri":"{u}""#)).unwrap_or_default();
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":{nodes},
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "buffers":[{{"byteLength":44{uri}}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":{position_count},"type":"VEC3","min":[0,0,0],"max":[1,0,1]}},
            {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#
        );
        (json, bin)
    }

    fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
        let mut json = json.as_bytes().to_vec();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::new();
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((json.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(&json);
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(bin);
        out
    }

    #[test]
    fn glb_and_external_buffer_files_load() {
        let dir = temp_dir("formats");
        let (json, bin) = triangle_gltf(None, r#"[{"mesh":0}]"#, 3, 2);
        std::fs::write(dir.join("triangle.glb"), glb(&json, &bin)).expect("write");
        let (json, bin) = triangle_gltf(Some("triangle.bin"), r#"[{"mesh":0}]"#, 3, 2);
        std::fs::write(dir.join("triangle.gltf"), json).expect("write");
        std::fs::write(dir.join("triangle.bin"), bin).expect("write");
        for name in ["triangle.glb", "triangle.gltf"] {
            let mesh = load_gltf(&dir.join(name), 10).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(mesh.triangle_count(), 1, "{name}");
            // No normals in the file: the face's, up.
            assert!(
                mesh.normals.iter().all(|n| (*n - DVec3::Y).length() < 1e-9),
                "{name}"
            );
            assert_eq!(mesh.base_colour, vec![None; 3], "{name}: no material");
        }
    }

    #[test]
    fn a_mirroring_node_keeps_the_front_face_in_front() {
        let dir = temp_dir("mirror");
        let (json, bin) = triangle_gltf(None, r#"[{"mesh":0,"scale":[-1,1,1]}]"#, 3, 2);
        let path = dir.join("mirror.glb");
        std::fs::write(&path, glb(&json, &bin)).expect("write");
        let mesh = load_gltf(&path, 10).unwrap_or_else(|e| panic!("{e}"));
        let mut g = ObjectGeometry::default();
        g.push_mesh(&mesh, DMat4::IDENTITY, [0.5; 3]);
        assert_winding_matches_normals(&g.vertices, &g.indices);
        assert!(g.vertices.iter().all(|v| v.normal[1] > 0.99));
        // And a mirroring object transform on top turns it back.
        let mut g = ObjectGeometry::default();
        g.push_mesh(
            &mesh,
            DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0)),
            [0.5; 3],
        );
        assert_winding_matches_normals(&g.vertices, &g.indices);
    }

    #[test]
    fn malformed_files_are_one_line_errors_not_panics() {
        let dir = temp_dir("malformed");
        let cases: Vec<(&str, Vec<u8>, &str)> = vec![
            (
                "not-json.gltf",
                b"{ this is not json".to_vec(),
                "not valid glTF 2.0",
            ),
            ("empty.glb", Vec::new(), "not valid glTF 2.0"),
            {
                let (json, bin) = triangle_gltf(None, r#"[{"mesh":0}]"#, 4, 2);
                (
                    "long-accessor.glb",
                    glb(&json, &bin),
                    "lies outside its buffer view",
                )
            },
            {
                let (json, bin) = triangle_gltf(None, r#"[{"mesh":0}]"#, 3, 7);
                ("bad-index.glb", glb(&json, &bin), "index 7 is out of range")
            },
            {
                let (json, bin) = triangle_gltf(None, r#"[{"mesh":0}]"#, 0, 2);
                ("no-elements.glb", glb(&json, &bin), "has 0 elements")
            },
            {
                let (json, bin) = triangle_gltf(None, r#"[{"mesh":0,"children":[0]}]"#, 3, 2);
                ("cycle.glb", glb(&json, &bin), "node 0")
            },
            {
                let (json, _) = triangle_gltf(Some("missing.bin"), r#"[{"mesh":0}]"#, 3, 2);
                ("missing-buffer.gltf", json.into_bytes(), "cannot read")
            },
        ];
        for (name, bytes, expected) in cases {
            let path = dir.join(name);
            std::fs::write(&path, bytes).expect("write");
            let message = load_gltf(&path, 10).expect_err(name).to_string();
            assert!(!message.contains('\n'), "{name}: {message}");
            assert!(
                message.contains(expected) && message.contains(name),
                "{name}: {message}"
            );
        }
    }

    #[test]
    fn the_triangle_budget_is_checked_before_the_buffers_are_read() {
        let dir = temp_dir("budget");
        let (json, _) = triangle_gltf(Some("absent.bin"), r#"[{"mesh":0},{"mesh":0}]"#, 3, 2);
        let json = json.replace(r#""nodes":[0]"#, r#""nodes":[0,1]"#);
        let path = dir.join("two.gltf");
        std::fs::write(&path, json).expect("write");
        let err = load_gltf(&path, 1).expect_err("over budget");
        assert!(
            matches!(
                err,
                GltfError::TooManyTriangles {
                    triangles: 2,
                    max: 1,
                    ..
                }
            ),
            "{err}"
        );
    }
}
