//! Binary glTF 2.0 (`.glb`) export of the cumulus meshes, with the shader's
//! per-vertex data as application-specific attributes (glTF 2.0 §3.7.2.1:
//! names starting with an underscore):
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
//! Each level of detail is a mesh in a scene of its own (scene 0, the
//! finest, is the default), so that an importer shows one at a time.
//! Units are metres, y up, as glTF wants.

use super::surface::CumulusMesh;
use serde_json::{Value, json};

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// Appends a view and an accessor; returns the accessor's index.
    fn push(
        &mut self,
        bytes: &[u8],
        count: usize,
        kind: &str,
        component: u32,
        target: u32,
        bounds: Option<(Vec<f32>, Vec<f32>)>,
    ) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": bytes.len(),
            "target": target,
        }));
        let mut accessor = json!({
            "bufferView": self.views.len() - 1,
            "componentType": component,
            "count": count,
            "type": kind,
        });
        if let Some((min, max)) = bounds {
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn vec3(&mut self, data: &[[f32; 3]], bounds: bool) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let bounds = bounds.then(|| {
            let mut min = [f32::INFINITY; 3];
            let mut max = [f32::NEG_INFINITY; 3];
            for p in data {
                for k in 0..3 {
                    min[k] = min[k].min(p[k]);
                    max[k] = max[k].max(p[k]);
                }
            }
            (min.to_vec(), max.to_vec())
        });
        self.push(&bytes, data.len(), "VEC3", FLOAT, ARRAY_BUFFER, bounds)
    }

    fn scalar(&mut self, data: &[f32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.push(&bytes, data.len(), "SCALAR", FLOAT, ARRAY_BUFFER, None)
    }
}

/// The `.glb` bytes of the levels of detail `lods` (finest first).
pub fn to_glb(lods: &[CumulusMesh]) -> Vec<u8> {
    let mut b = Builder {
        bin: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let mut meshes = Vec::new();
    for (lod, mesh) in lods.iter().enumerate() {
        let mut attributes = serde_json::Map::new();
        attributes.insert("POSITION".into(), json!(b.vec3(&mesh.positions, true)));
        attributes.insert("NORMAL".into(), json!(b.vec3(&mesh.normals, false)));
        for (j, (d, n)) in mesh
            .base_distances_m
            .iter()
            .zip(&mesh.base_normals)
            .enumerate()
        {
            attributes.insert(format!("_D{}", j + 1), json!(b.scalar(d)));
            attributes.insert(format!("_N{}", j + 1), json!(b.vec3(n, false)));
        }
        attributes.insert(
            "_BLOB_CENTRE".into(),
            json!(b.vec3(&mesh.blob_centres_m, false)),
        );
        attributes.insert("_BLOB_RADIUS".into(), json!(b.scalar(&mesh.blob_radii_m)));
        let ids: Vec<f32> = mesh.blob_ids.iter().map(|&i| i as f32).collect();
        attributes.insert("_BLOB_ID".into(), json!(b.scalar(&ids)));
        let index_bytes: Vec<u8> = mesh.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let indices = b.push(
            &index_bytes,
            mesh.indices.len(),
            "SCALAR",
            UNSIGNED_INT,
            ELEMENT_ARRAY_BUFFER,
            None,
        );
        meshes.push(json!({
            "name": format!("cumulus_lod{lod}"),
            "primitives": [{ "attributes": attributes, "indices": indices, "mode": 4 }],
        }));
    }
    while !b.bin.len().is_multiple_of(4) {
        b.bin.push(0);
    }
    let nodes: Vec<Value> = (0..lods.len())
        .map(|lod| json!({ "name": format!("cumulus_lod{lod}"), "mesh": lod }))
        .collect();
    let scenes: Vec<Value> = (0..lods.len())
        .map(|lod| json!({ "name": format!("lod{lod}"), "nodes": [lod] }))
        .collect();
    let document = json!({
        "asset": { "version": "2.0", "generator": concat!("nimbus ", env!("CARGO_PKG_VERSION")) },
        "scene": 0,
        "scenes": scenes,
        "nodes": nodes,
        "meshes": meshes,
        "buffers": [{ "byteLength": b.bin.len() }],
        "bufferViews": b.views,
        "accessors": b.accessors,
    });
    let mut json_bytes = document.to_string().into_bytes();
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + b.bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(b.bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b.bin);
    out
}
