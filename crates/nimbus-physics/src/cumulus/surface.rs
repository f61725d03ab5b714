//! The mesh the cumulus shader draws: the surface of the last level with,
//! per vertex, what Bouthors (2004, ch. 5) reads: the normal, the distance
//! to and the normal of each lower level's surface (for the simulated
//! higher levels, the light traps and the normal blending of §5.9), and
//! the blob the vertex belongs to (for the volumetric terms).

use super::field::BlobField;
use super::hierarchy::Cumulus;
use super::mesh::{TriangleMesh, extract_surface, surface_seeds};
use glam::DVec3;
use rayon::prelude::*;

/// One level of detail of the cloud's surface with its attributes. Arrays
/// are per vertex; `base_distances_m[j]` and `base_normals[j]` describe
/// S_{L−1−j}, the surface j + 1 levels below the last.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CumulusMesh {
    /// Side of the extraction grid's cells, m.
    pub cell_m: f64,
    /// Positions, m.
    pub positions: Vec<[f32; 3]>,
    /// Outward unit normals of the surface.
    pub normals: Vec<[f32; 3]>,
    /// Distance to S_{L−1−j}, m (the field's estimate, 0 inside it).
    pub base_distances_m: Vec<Vec<f32>>,
    /// Outward unit normal of S_{L−1−j} at the vertex.
    pub base_normals: Vec<Vec<[f32; 3]>>,
    /// Centre of the vertex's blob, m.
    pub blob_centres_m: Vec<[f32; 3]>,
    /// Radius of the vertex's blob, m.
    pub blob_radii_m: Vec<f32>,
    /// Id of the vertex's blob: its index in the hierarchy, levels in order.
    pub blob_ids: Vec<u32>,
    /// Triangles (counter-clockwise from outside), three indices each.
    pub indices: Vec<u32>,
}

impl CumulusMesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The bare geometry.
    pub fn triangle_mesh(&self) -> TriangleMesh {
        TriangleMesh {
            positions: self
                .positions
                .iter()
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                .collect(),
            triangles: self.indices.chunks(3).map(|t| [t[0], t[1], t[2]]).collect(),
        }
    }
}

fn unit_outward(gradient: DVec3) -> [f32; 3] {
    (-gradient).normalize_or(DVec3::Y).as_vec3().to_array()
}

/// The surface of the last level on cells of `cell_m`, with attributes.
pub fn cumulus_mesh(cumulus: &Cumulus, cell_m: f64) -> CumulusMesh {
    let field: &BlobField = &cumulus.field;
    let last = field.level_count() - 1;
    let seeds = surface_seeds(field, last, 0.5 * cell_m);
    let potential = |p: DVec3| field.sample(last, p).potential.value;
    let geometry = extract_surface(&potential, &seeds, cell_m);

    // Blob ids: offsets of each level in the hierarchy.
    let mut first_id = vec![0u32; field.level_count()];
    for l in 1..field.level_count() {
        first_id[l] = first_id[l - 1] + field.blobs(l - 1).len() as u32;
    }
    struct VertexAttributes {
        normal: [f32; 3],
        base: Vec<(f32, [f32; 3])>,
        centre: [f32; 3],
        radius: f32,
        id: u32,
    }
    let attributes: Vec<VertexAttributes> = geometry
        .positions
        .par_iter()
        .map(|&p| {
            let samples = field.samples(last, p);
            let top = samples[last];
            let base = (0..last)
                .rev()
                .map(|l| {
                    let d = field.distance_from_potential(l, samples[l].potential).value as f32;
                    (d, unit_outward(samples[l].potential.gradient))
                })
                .collect();
            let (centre, radius, id) = match top.blob {
                Some((l, i)) => {
                    let b = field.blobs(l)[i];
                    (
                        b.centre_m.as_vec3().to_array(),
                        b.radius_m as f32,
                        first_id[l] + i as u32,
                    )
                }
                None => ([0.0; 3], 0.0, u32::MAX),
            };
            VertexAttributes {
                normal: unit_outward(top.potential.gradient),
                base,
                centre,
                radius,
                id,
            }
        })
        .collect();

    let mut mesh = CumulusMesh {
        cell_m,
        positions: geometry
            .positions
            .iter()
            .map(|p| p.as_vec3().to_array())
            .collect(),
        indices: geometry.triangles.iter().flatten().copied().collect(),
        base_distances_m: vec![Vec::with_capacity(attributes.len()); last],
        base_normals: vec![Vec::with_capacity(attributes.len()); last],
        ..CumulusMesh::default()
    };
    for a in attributes {
        mesh.normals.push(a.normal);
        for (j, (d, n)) in a.base.into_iter().enumerate() {
            mesh.base_distances_m[j].push(d);
            mesh.base_normals[j].push(n);
        }
        mesh.blob_centres_m.push(a.centre);
        mesh.blob_radii_m.push(a.radius);
        mesh.blob_ids.push(a.id);
    }
    mesh
}

/// Levels of detail: the first on cells of half the last level's mean blob
/// radius, each next one on cells twice as large.
pub fn cumulus_lods(
    cumulus: &Cumulus,
    count: u32,
    mut progress: impl FnMut(u32),
) -> Vec<CumulusMesh> {
    let last = cumulus.field.level_count() - 1;
    let finest = 0.5 * cumulus.field.mean_radius_m(last);
    (0..count)
        .map(|lod| {
            progress(lod);
            cumulus_mesh(cumulus, finest * f64::from(1u32 << lod))
        })
        .collect()
}
