//! Binary glTF 2.0 (`.glb`) writing: [`GlbBuilder`] builds a document of
//! meshes, materials, nodes and scenes with `gltf-json`, its data in one
//! binary buffer, and frames it with the `gltf` crate's
//! [`gltf::binary::Glb`]. The cumulus export
//! ([`crate::cumulus::gltf`]) and the scene export (`nimbus_render::export`)
//! are built on it.
//!
//! A `.glb` stores its chunk lengths and its total length as u32 (glTF 2.0
//! §4.4), and so every buffer offset and length in it: each is checked
//! against [`MAX_GLB_BYTES`] before it is written (the binary buffer before
//! it grows), and a file that would be larger is a [`GlbError::TooLarge`],
//! never a wrapped length.
//!
//! Custom per-vertex attributes are glTF's application-specific ones
//! (glTF 2.0 §3.7.2.1: names beginning with `_`), `gltf-json`'s
//! `Semantic::Extras`.

use gltf_json as json;
use json::validation::{Checked::Valid, USize64, Validate};
use std::borrow::Cow;
use std::collections::BTreeMap;

/// Largest `.glb`, bytes: its header, chunk lengths and so every buffer
/// length and offset in it are u32 (glTF 2.0 §4.4).
pub const MAX_GLB_BYTES: u64 = u32::MAX as u64;

/// Bytes of the `.glb` header (magic, version, length) and of each chunk's
/// header (length, type).
const HEADER_BYTES: u64 = 12;
const CHUNK_HEADER_BYTES: u64 = 8;

/// Why a `.glb` could not be written.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GlbError {
    /// A length that the container stores as u32 would pass [`MAX_GLB_BYTES`].
    #[error(
        "glTF: the {part} would be {bytes} bytes, past the {MAX_GLB_BYTES} bytes (u32::MAX) that a .glb's 32-bit lengths allow"
    )]
    TooLarge {
        /// What would be too long: "binary buffer", "JSON chunk" or ".glb file".
        part: &'static str,
        /// Its length, bytes.
        bytes: u64,
    },
    /// A mesh without vertices (a glTF accessor counts at least one).
    #[error("glTF mesh {mesh:?}: no vertices (a mesh needs at least one)")]
    EmptyMesh {
        /// The mesh's name.
        mesh: String,
    },
    /// An attribute with another number of values than the mesh has vertices.
    #[error(
        "glTF mesh {mesh:?}: attribute {attribute} has {count} values for {vertices} vertices (one per vertex)"
    )]
    AttributeCount {
        /// The mesh's name.
        mesh: String,
        /// The attribute's name.
        attribute: String,
        /// Its number of values.
        count: usize,
        /// The mesh's number of vertices.
        vertices: usize,
    },
    /// A custom attribute whose name does not begin with `_` or is repeated.
    #[error(
        "glTF mesh {mesh:?}: attribute name {attribute:?} must begin with '_' followed by a name, once per mesh (application-specific attributes, glTF 2.0 §3.7.2.1)"
    )]
    AttributeName {
        /// The mesh's name.
        mesh: String,
        /// The attribute's name.
        attribute: String,
    },
    /// A non-finite value (glTF's JSON bounds and readers expect numbers).
    #[error(
        "glTF mesh {mesh:?}: attribute {attribute} is {value} at vertex {vertex}; values must be finite"
    )]
    NonFinite {
        /// The mesh's name.
        mesh: String,
        /// The attribute's name.
        attribute: String,
        /// The vertex.
        vertex: usize,
        /// The value.
        value: f32,
    },
    /// Indices that are not whole triangles.
    #[error(
        "glTF mesh {mesh:?}: {count} indices, not a whole number of triangles (a multiple of 3)"
    )]
    IndexCount {
        /// The mesh's name.
        mesh: String,
        /// Number of indices.
        count: usize,
    },
    /// An index past the last vertex.
    #[error(
        "glTF mesh {mesh:?}: index {index} (at {position}) is past the last of {vertices} vertices"
    )]
    IndexRange {
        /// The mesh's name.
        mesh: String,
        /// The index's position in the index list.
        position: usize,
        /// The index.
        index: u32,
        /// The mesh's number of vertices.
        vertices: usize,
    },
    /// A scene without nodes (glTF 2.0 asks for at least one).
    #[error("glTF scene {scene:?}: no nodes (a scene lists at least one)")]
    EmptyScene {
        /// The scene's name.
        scene: String,
    },
    /// The document breaks a rule of glTF 2.0 (a bug in the caller's use of
    /// the ids, e.g. one from another builder): `gltf-json`'s validation.
    #[error("glTF: {path}: {problem}")]
    Invalid {
        /// JSON path of the offending value.
        path: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The JSON or the container could not be serialised.
    #[error("glTF: cannot serialise the {part}: {message}")]
    Serialise {
        /// "JSON" or "container".
        part: &'static str,
        /// The serialiser's message.
        message: String,
    },
}

/// The values of one vertex attribute, one per vertex.
#[derive(Clone, Debug, PartialEq)]
pub enum AttributeValues<'a> {
    /// SCALAR float.
    Scalar(Cow<'a, [f32]>),
    /// VEC3 float.
    Vec3(Cow<'a, [[f32; 3]]>),
}

impl AttributeValues<'_> {
    fn len(&self) -> usize {
        match self {
            Self::Scalar(v) => v.len(),
            Self::Vec3(v) => v.len(),
        }
    }
}

/// A triangle list to add with [`GlbBuilder::add_mesh`]; every attribute has
/// one value per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData<'a> {
    /// The mesh's name (Blender shows it as the mesh data's name).
    pub name: String,
    /// `POSITION`, m.
    pub positions: Cow<'a, [[f32; 3]]>,
    /// `NORMAL`: unit normals.
    pub normals: Option<Cow<'a, [[f32; 3]]>>,
    /// `COLOR_0`: linear RGB (glTF vertex colours are linear), multiplying
    /// the material's base colour.
    pub colours: Option<Cow<'a, [[f32; 3]]>>,
    /// Application-specific attributes, each name beginning with `_`.
    pub custom: Vec<(String, AttributeValues<'a>)>,
    /// Triangles, three indices each, counter-clockwise seen from outside.
    pub indices: Cow<'a, [u32]>,
    /// The material, if any.
    pub material: Option<MaterialId>,
}

/// A mesh added to a [`GlbBuilder`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshId(u32);

/// A node added to a [`GlbBuilder`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeId(u32);

/// A material added to a [`GlbBuilder`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialId(u32);

/// A node's placement in its parent's frame: world = translation +
/// scale · R(yaw) · local, R(yaw) the turn about +y by `yaw_rad`
/// (x cos yaw + z sin yaw, y, −x sin yaw + z cos yaw): the cumulus
/// instances' transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeTransform {
    /// Translation, m.
    pub translation_m: [f64; 3],
    /// Turn about the vertical, rad.
    pub yaw_rad: f64,
    /// Uniform scale.
    pub scale: f64,
}

impl NodeTransform {
    /// No translation, no turn, unit scale.
    pub const IDENTITY: Self = Self {
        translation_m: [0.0; 3],
        yaw_rad: 0.0,
        scale: 1.0,
    };
}

impl Default for NodeTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// The length, bytes, of a `.glb` with a JSON chunk of `json_bytes` and a
/// binary chunk of `bin_bytes` (`None`: no binary chunk), each padded to a
/// multiple of 4 (glTF 2.0 §4.4), checked against [`MAX_GLB_BYTES`].
pub fn glb_length(json_bytes: u64, bin_bytes: Option<u64>) -> Result<u32, GlbError> {
    let pad = |n: u64| n.div_ceil(4).saturating_mul(4);
    let check = |part: &'static str, bytes: u64| {
        u32::try_from(bytes).map_err(|_| GlbError::TooLarge { part, bytes })
    };
    check("JSON chunk", pad(json_bytes))?;
    let mut total = HEADER_BYTES
        .saturating_add(CHUNK_HEADER_BYTES)
        .saturating_add(pad(json_bytes));
    if let Some(bin) = bin_bytes {
        check("binary buffer", pad(bin))?;
        total = total
            .saturating_add(CHUNK_HEADER_BYTES)
            .saturating_add(pad(bin));
    }
    check(".glb file", total)
}

/// Builds a glTF 2.0 document with one binary buffer and writes it as `.glb`.
///
/// Add materials and meshes, then nodes (children before their parents),
/// then scenes; the first scene added is the default one.
#[derive(Debug)]
pub struct GlbBuilder {
    root: json::Root,
    bin: Vec<u8>,
}

impl Default for GlbBuilder {
    fn default() -> Self {
        Self::new()
    }
}

fn index_u32(len: usize) -> u32 {
    // Root::push panics past u32::MAX items; these counts are meshes, nodes
    // and accessors (a few per cloud), far below it.
    u32::try_from(len).unwrap_or(u32::MAX)
}

impl GlbBuilder {
    /// An empty document (asset version 2.0, generator "nimbus VERSION").
    pub fn new() -> Self {
        Self {
            root: json::Root {
                asset: json::Asset {
                    version: "2.0".into(),
                    generator: Some(concat!("nimbus ", env!("CARGO_PKG_VERSION")).into()),
                    copyright: None,
                    min_version: None,
                    extensions: None,
                    extras: None,
                },
                ..Default::default()
            },
            bin: Vec::new(),
        }
    }

    /// Appends `bytes` to the binary buffer, 4-byte aligned, as a buffer
    /// view; its index. Fails, before growing the buffer, if the buffer
    /// would pass [`MAX_GLB_BYTES`].
    fn push_view(
        &mut self,
        bytes: impl ExactSizeIterator<Item = u8>,
        target: json::buffer::Target,
    ) -> Result<json::Index<json::buffer::View>, GlbError> {
        let offset = (self.bin.len() as u64).div_ceil(4) * 4;
        let end = offset.saturating_add(bytes.len() as u64);
        if end > MAX_GLB_BYTES {
            return Err(GlbError::TooLarge {
                part: "binary buffer",
                bytes: end,
            });
        }
        self.bin.resize(offset as usize, 0);
        let length = bytes.len();
        self.bin.extend(bytes);
        Ok(self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(length),
            byte_offset: Some(USize64(offset)),
            byte_stride: None,
            name: None,
            target: Some(Valid(target)),
            extensions: None,
            extras: None,
        }))
    }

    fn push_accessor(
        &mut self,
        view: json::Index<json::buffer::View>,
        count: usize,
        kind: json::accessor::Type,
        component: json::accessor::ComponentType,
        bounds: Option<([f32; 3], [f32; 3])>,
    ) -> json::Index<json::Accessor> {
        let (min, max) = match bounds {
            Some((min, max)) => (
                Some(json::Value::from(&min[..])),
                Some(json::Value::from(&max[..])),
            ),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Valid(kind),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    fn vec3(
        &mut self,
        values: &[[f32; 3]],
        bounds: bool,
    ) -> Result<json::Index<json::Accessor>, GlbError> {
        let bytes = values.iter().flatten().flat_map(|v| v.to_le_bytes());
        let view = self.push_view(
            ExactBytes::new(bytes, values.len() * 12),
            json::buffer::Target::ArrayBuffer,
        )?;
        // POSITION must carry its bounds (glTF 2.0 §3.7.2.1).
        let bounds = bounds.then(|| {
            values.iter().fold(
                ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
                |(lo, hi), p| {
                    (
                        std::array::from_fn(|k| lo[k].min(p[k])),
                        std::array::from_fn(|k| hi[k].max(p[k])),
                    )
                },
            )
        });
        Ok(self.push_accessor(
            view,
            values.len(),
            json::accessor::Type::Vec3,
            json::accessor::ComponentType::F32,
            bounds,
        ))
    }

    fn scalar(&mut self, values: &[f32]) -> Result<json::Index<json::Accessor>, GlbError> {
        let bytes = values.iter().flat_map(|v| v.to_le_bytes());
        let view = self.push_view(
            ExactBytes::new(bytes, values.len() * 4),
            json::buffer::Target::ArrayBuffer,
        )?;
        Ok(self.push_accessor(
            view,
            values.len(),
            json::accessor::Type::Scalar,
            json::accessor::ComponentType::F32,
            None,
        ))
    }

    /// Adds a matte material: `base_colour` linear RGB (times the vertex
    /// colours where a mesh has them), metallic 0, roughness 1.
    pub fn add_material(&mut self, name: &str, base_colour: [f32; 3]) -> MaterialId {
        let [r, g, b] = base_colour;
        let index = self.root.push(json::Material {
            name: Some(name.into()),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor([r, g, b, 1.0]),
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(1.0),
                ..Default::default()
            },
            ..Default::default()
        });
        MaterialId(index_u32(index.value()))
    }

    /// Adds a triangle mesh after checking it: at least one vertex, one
    /// value per vertex in every attribute, finite values, custom names
    /// beginning with `_` and unique, whole triangles of valid indices.
    pub fn add_mesh(&mut self, mesh: &MeshData<'_>) -> Result<MeshId, GlbError> {
        use json::mesh::Semantic;
        let name = &mesh.name;
        let vertices = mesh.positions.len();
        if vertices == 0 {
            return Err(GlbError::EmptyMesh { mesh: name.clone() });
        }
        let check = |attribute: &str, values: &AttributeValues<'_>| -> Result<(), GlbError> {
            if values.len() != vertices {
                return Err(GlbError::AttributeCount {
                    mesh: name.clone(),
                    attribute: attribute.into(),
                    count: values.len(),
                    vertices,
                });
            }
            let bad = match values {
                AttributeValues::Scalar(v) => v
                    .iter()
                    .enumerate()
                    .find(|(_, x)| !x.is_finite())
                    .map(|(i, &x)| (i, x)),
                AttributeValues::Vec3(v) => v
                    .iter()
                    .enumerate()
                    .find_map(|(i, p)| p.iter().find(|x| !x.is_finite()).map(|&x| (i, x))),
            };
            match bad {
                Some((vertex, value)) => Err(GlbError::NonFinite {
                    mesh: name.clone(),
                    attribute: attribute.into(),
                    vertex,
                    value,
                }),
                None => Ok(()),
            }
        };
        fn vec3(v: &[[f32; 3]]) -> AttributeValues<'_> {
            AttributeValues::Vec3(Cow::Borrowed(v))
        }
        check("POSITION", &vec3(&mesh.positions))?;
        if let Some(n) = &mesh.normals {
            check("NORMAL", &vec3(n))?;
        }
        if let Some(c) = &mesh.colours {
            check("COLOR_0", &vec3(c))?;
        }
        let mut custom_names = std::collections::BTreeSet::new();
        for (attribute, values) in &mesh.custom {
            let valid = attribute.len() > 1
                && attribute.starts_with('_')
                && custom_names.insert(attribute.as_str());
            if !valid {
                return Err(GlbError::AttributeName {
                    mesh: name.clone(),
                    attribute: attribute.clone(),
                });
            }
            check(attribute, values)?;
        }
        if !mesh.indices.len().is_multiple_of(3) {
            return Err(GlbError::IndexCount {
                mesh: name.clone(),
                count: mesh.indices.len(),
            });
        }
        if let Some((position, &index)) = mesh
            .indices
            .iter()
            .enumerate()
            .find(|(_, i)| **i as usize >= vertices)
        {
            return Err(GlbError::IndexRange {
                mesh: name.clone(),
                position,
                index,
                vertices,
            });
        }

        let mut attributes = BTreeMap::new();
        attributes.insert(
            Valid(Semantic::Positions),
            self.vec3(&mesh.positions, true)?,
        );
        if let Some(n) = &mesh.normals {
            attributes.insert(Valid(Semantic::Normals), self.vec3(n, false)?);
        }
        if let Some(c) = &mesh.colours {
            attributes.insert(Valid(Semantic::Colors(0)), self.vec3(c, false)?);
        }
        for (attribute, values) in &mesh.custom {
            let accessor = match values {
                AttributeValues::Scalar(v) => self.scalar(v)?,
                AttributeValues::Vec3(v) => self.vec3(v, false)?,
            };
            // Semantic::Extras holds the name after the underscore.
            attributes.insert(Valid(Semantic::Extras(attribute[1..].into())), accessor);
        }
        let indices = if mesh.indices.is_empty() {
            None
        } else {
            let bytes = mesh.indices.iter().flat_map(|i| i.to_le_bytes());
            let view = self.push_view(
                ExactBytes::new(bytes, mesh.indices.len() * 4),
                json::buffer::Target::ElementArrayBuffer,
            )?;
            Some(self.push_accessor(
                view,
                mesh.indices.len(),
                json::accessor::Type::Scalar,
                json::accessor::ComponentType::U32,
                None,
            ))
        };
        let index = self.root.push(json::Mesh {
            extensions: None,
            extras: None,
            name: Some(name.clone()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices,
                material: mesh.material.map(|m| json::Index::new(m.0)),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
        });
        Ok(MeshId(index_u32(index.value())))
    }

    /// Adds a node named `name` drawing `mesh` (if any) at `transform` in
    /// its parent's frame, with `children` (added before it).
    pub fn add_node(
        &mut self,
        name: &str,
        mesh: Option<MeshId>,
        transform: NodeTransform,
        children: &[NodeId],
    ) -> NodeId {
        let t = transform.translation_m.map(|v| v as f32);
        let half = 0.5 * transform.yaw_rad;
        let index = self.root.push(json::Node {
            children: (!children.is_empty())
                .then(|| children.iter().map(|c| json::Index::new(c.0)).collect()),
            mesh: mesh.map(|m| json::Index::new(m.0)),
            name: Some(name.into()),
            // A turn by yaw about +y is the unit quaternion (0, sin yaw/2, 0, cos yaw/2).
            rotation: (transform.yaw_rad != 0.0).then_some(json::scene::UnitQuaternion([
                0.0,
                half.sin() as f32,
                0.0,
                half.cos() as f32,
            ])),
            scale: (transform.scale != 1.0).then_some([transform.scale as f32; 3]),
            translation: (transform.translation_m != [0.0; 3]).then_some(t),
            ..Default::default()
        });
        NodeId(index_u32(index.value()))
    }

    /// Adds a scene of the root nodes `nodes` (at least one); the first
    /// scene added is the one importers open.
    pub fn add_scene(&mut self, name: &str, nodes: &[NodeId]) -> Result<(), GlbError> {
        if nodes.is_empty() {
            return Err(GlbError::EmptyScene { scene: name.into() });
        }
        let index = self.root.push(json::Scene {
            extensions: None,
            extras: None,
            name: Some(name.into()),
            nodes: nodes.iter().map(|n| json::Index::new(n.0)).collect(),
        });
        if self.root.scene.is_none() {
            self.root.scene = Some(index);
        }
        Ok(())
    }

    /// Bytes of binary data so far (before the container's padding).
    pub fn binary_len(&self) -> usize {
        self.bin.len()
    }

    /// The `.glb` bytes: the document validated by `gltf-json`, every
    /// length checked against [`MAX_GLB_BYTES`].
    pub fn finish(mut self) -> Result<Vec<u8>, GlbError> {
        let bin_len = (self.bin.len() as u64).div_ceil(4) * 4;
        if !self.bin.is_empty() {
            self.root.buffers.push(json::Buffer {
                byte_length: USize64(bin_len),
                name: None,
                uri: None,
                extensions: None,
                extras: None,
            });
        }
        let mut problems = Vec::new();
        self.root.validate(
            &self.root,
            json::Path::new,
            &mut |path: &dyn Fn() -> json::Path, error: json::validation::Error| {
                problems.push((path().as_str().to_owned(), error.to_string()))
            },
        );
        if let Some((path, problem)) = problems.into_iter().next() {
            return Err(GlbError::Invalid { path, problem });
        }
        let json_bytes = self.root.to_vec().map_err(|e| GlbError::Serialise {
            part: "JSON",
            message: e.to_string(),
        })?;
        let bin = (!self.bin.is_empty()).then_some(self.bin);
        let length = glb_length(
            json_bytes.len() as u64,
            bin.as_ref().map(|b| b.len() as u64),
        )?;
        gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length,
            },
            json: Cow::Owned(json_bytes),
            bin: bin.map(Cow::Owned),
        }
        .to_vec()
        .map_err(|e| GlbError::Serialise {
            part: "container",
            message: e.to_string(),
        })
    }
}

/// An iterator of bytes with its length known in advance (`flat_map` over
/// `to_le_bytes` loses it), so that the buffer's size is checked before it
/// grows.
struct ExactBytes<I> {
    bytes: I,
    remaining: usize,
}

impl<I: Iterator<Item = u8>> ExactBytes<I> {
    fn new(bytes: I, len: usize) -> Self {
        Self {
            bytes,
            remaining: len,
        }
    }
}

impl<I: Iterator<Item = u8>> Iterator for ExactBytes<I> {
    type Item = u8;
    fn next(&mut self) -> Option<u8> {
        let byte = self.bytes.next()?;
        self.remaining = self.remaining.saturating_sub(1);
        Some(byte)
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.remaining, Some(self.remaining))
    }
}

impl<I: Iterator<Item = u8>> ExactSizeIterator for ExactBytes<I> {}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle(name: &str) -> MeshData<'static> {
        MeshData {
            name: name.into(),
            positions: Cow::Owned(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),
            normals: Some(Cow::Owned(vec![[0.0, 1.0, 0.0]; 3])),
            indices: Cow::Owned(vec![0, 1, 2]),
            ..Default::default()
        }
    }

    /// The length check: at the limit a `.glb` fits, one byte of padding
    /// more and each of its parts is a typed error, not a wrapped u32.
    #[test]
    fn lengths_past_u32_are_errors_not_wrapped() {
        assert_eq!(glb_length(3, Some(5)), Ok(12 + 8 + 4 + 8 + 8));
        assert_eq!(glb_length(4, None), Ok(12 + 8 + 4));
        // The largest binary chunk that fits beside 4 bytes of JSON (a
        // multiple of 4): the headers take 12 + 8 + 8 bytes.
        let largest = (MAX_GLB_BYTES - 12 - 8 - 4 - 8) / 4 * 4;
        assert_eq!(glb_length(4, Some(largest)), Ok(u32::MAX - 3));
        assert_eq!(
            glb_length(4, Some(largest + 1)),
            Err(GlbError::TooLarge {
                part: ".glb file",
                bytes: MAX_GLB_BYTES + 1
            })
        );
        assert_eq!(
            glb_length(4, Some(MAX_GLB_BYTES)),
            Err(GlbError::TooLarge {
                part: "binary buffer",
                bytes: MAX_GLB_BYTES + 1
            })
        );
        assert!(matches!(
            glb_length(MAX_GLB_BYTES, None),
            Err(GlbError::TooLarge {
                part: "JSON chunk",
                ..
            })
        ));
        let message = glb_length(4, Some(u64::MAX))
            .expect_err("too large")
            .to_string();
        assert!(
            message.contains("binary buffer") && message.contains("4294967295"),
            "{message}"
        );
    }

    /// The buffer refuses to grow past the limit before it allocates.
    #[test]
    fn a_view_past_the_limit_is_refused_before_it_is_written() {
        let mut builder = GlbBuilder::new();
        builder.bin = vec![0; 6];
        let huge = ExactBytes::new(std::iter::empty(), MAX_GLB_BYTES as usize);
        let error = builder
            .push_view(huge, json::buffer::Target::ArrayBuffer)
            .expect_err("too large");
        assert_eq!(
            error,
            GlbError::TooLarge {
                part: "binary buffer",
                bytes: MAX_GLB_BYTES + 8
            }
        );
        assert_eq!(builder.binary_len(), 6);
    }

    #[test]
    fn bad_meshes_are_refused_with_the_mesh_and_the_attribute_named() {
        let mut builder = GlbBuilder::new();
        let cases: Vec<(MeshData<'static>, &str)> = vec![
            (
                MeshData {
                    positions: Cow::Owned(Vec::new()),
                    indices: Cow::Owned(Vec::new()),
                    ..triangle("empty")
                },
                "glTF mesh \"empty\": no vertices",
            ),
            (
                MeshData {
                    normals: Some(Cow::Owned(vec![[0.0, 1.0, 0.0]; 2])),
                    ..triangle("short")
                },
                "attribute NORMAL has 2 values for 3 vertices",
            ),
            (
                MeshData {
                    custom: vec![(
                        "D1".into(),
                        AttributeValues::Scalar(Cow::Owned(vec![0.0; 3])),
                    )],
                    ..triangle("unnamed")
                },
                "attribute name \"D1\" must begin with '_'",
            ),
            (
                MeshData {
                    custom: vec![
                        (
                            "_D1".into(),
                            AttributeValues::Scalar(Cow::Owned(vec![0.0; 3])),
                        ),
                        (
                            "_D1".into(),
                            AttributeValues::Scalar(Cow::Owned(vec![0.0; 3])),
                        ),
                    ],
                    ..triangle("twice")
                },
                "attribute name \"_D1\"",
            ),
            (
                MeshData {
                    positions: Cow::Owned(vec![[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0; 3]]),
                    ..triangle("nan")
                },
                "attribute POSITION is NaN at vertex 1",
            ),
            (
                MeshData {
                    indices: Cow::Owned(vec![0, 1]),
                    ..triangle("partial")
                },
                "2 indices, not a whole number of triangles",
            ),
            (
                MeshData {
                    indices: Cow::Owned(vec![0, 1, 3]),
                    ..triangle("outside")
                },
                "index 3 (at 2) is past the last of 3 vertices",
            ),
        ];
        for (mesh, expected) in cases {
            let message = builder.add_mesh(&mesh).expect_err(&mesh.name).to_string();
            assert!(message.contains(expected), "{message}");
        }
        // Nothing of the refused meshes was written.
        assert_eq!(builder.binary_len(), 0);
    }

    /// Nodes, transforms, materials and custom attributes read back in the
    /// `gltf` crate's reader.
    #[test]
    fn a_built_document_reads_back_with_its_transforms_and_attributes() {
        let mut builder = GlbBuilder::new();
        let white = builder.add_material("white", [1.0; 3]);
        let mesh = builder
            .add_mesh(&MeshData {
                custom: vec![(
                    "_WEIGHT".into(),
                    AttributeValues::Scalar(Cow::Owned(vec![1.0, 2.0, 3.0])),
                )],
                colours: Some(Cow::Owned(vec![[0.5; 3]; 3])),
                material: Some(white),
                ..triangle("tri")
            })
            .expect("mesh");
        let yaw = std::f64::consts::FRAC_PI_2;
        let child = builder.add_node(
            "turned",
            Some(mesh),
            NodeTransform {
                translation_m: [10.0, 20.0, 30.0],
                yaw_rad: yaw,
                scale: 2.0,
            },
            &[],
        );
        let plain = builder.add_node("plain", Some(mesh), NodeTransform::IDENTITY, &[]);
        let group = builder.add_node("group", None, NodeTransform::IDENTITY, &[child, plain]);
        builder.add_scene("scene", &[group]).expect("scene");
        assert_eq!(
            builder.add_scene("nothing", &[]),
            Err(GlbError::EmptyScene {
                scene: "nothing".into()
            })
        );
        let bytes = builder.finish().expect("glb");
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes")) as usize,
            bytes.len()
        );
        let (document, buffers, _) = gltf::import_slice(&bytes).expect("valid glb");
        let node = document
            .nodes()
            .find(|n| n.name() == Some("turned"))
            .expect("node");
        let m = glam::Mat4::from_cols_array_2d(&node.transform().matrix());
        // R(yaw = 90°) takes +x to −z: (1, 0, 0) → 2·(0, 0, −1) + t.
        let p = m.transform_point3(glam::Vec3::X);
        assert!(
            (p - glam::Vec3::new(10.0, 20.0, 28.0)).length() < 1e-5,
            "{p}"
        );
        let plain = document
            .nodes()
            .find(|n| n.name() == Some("plain"))
            .expect("plain");
        assert_eq!(
            plain.transform().matrix(),
            glam::Mat4::IDENTITY.to_cols_array_2d()
        );
        let primitive = document
            .meshes()
            .next()
            .expect("mesh")
            .primitives()
            .next()
            .expect("p");
        assert_eq!(primitive.material().name(), Some("white"));
        let mut names: Vec<String> = primitive.attributes().map(|(s, _)| s.to_string()).collect();
        names.sort();
        assert_eq!(names, ["COLOR_0", "NORMAL", "POSITION", "_WEIGHT"]);
        let (_, weight) = primitive
            .attributes()
            .find(|(s, _)| s.to_string() == "_WEIGHT")
            .expect("weight");
        let view = weight.view().expect("view");
        let data = &buffers[0][view.offset()..view.offset() + view.length()];
        let values: Vec<f32> = data
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        assert_eq!(values, [1.0, 2.0, 3.0]);
        let bounds = primitive.bounding_box();
        assert_eq!(
            (bounds.min, bounds.max),
            ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0])
        );
    }
}
