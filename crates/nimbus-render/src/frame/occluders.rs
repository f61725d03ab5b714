//! Occluder geometry: the triangles that block what falls or shines through
//! the scene (the rain's occlusion map draws them seen from above). The
//! terrain and the static objects (their passes' `occluder_geometry`) hand
//! out their GPU buffers as they are: the consumer reads only the world
//! position at the start of each vertex, so one pipeline with
//! [`OccluderGeometry::vertex_buffer_layout`] draws both.

use crate::core::mesh::IndexedMesh;

/// The vertex attribute an occluder consumer reads: world position, m, as
/// `Float32x3` at offset 0, shader location 0.
pub static POSITION_ATTRIBUTES: [wgpu::VertexAttribute; 1] =
    wgpu::vertex_attr_array![0 => Float32x3];

/// A world-space indexed triangle list on the GPU.
#[derive(Clone, Copy, Debug)]
pub struct OccluderGeometry<'a> {
    /// Vertices (usage `VERTEX`), each `vertex_stride` bytes, beginning with
    /// the world position in metres as three `f32`.
    pub vertices: &'a wgpu::Buffer,
    /// Triangle indices, `u32` (usage `INDEX`).
    pub indices: &'a wgpu::Buffer,
    /// Number of indices to draw (three per triangle).
    pub index_count: u32,
    /// Bytes from one vertex to the next.
    pub vertex_stride: u64,
}

impl<'a> OccluderGeometry<'a> {
    /// The triangles of `mesh`, whose vertices are `V`s beginning with the
    /// world position (check with `offset_of!` where `V` is defined).
    pub fn of_mesh<V>(mesh: &'a IndexedMesh) -> Self {
        Self {
            vertices: &mesh.vertices,
            indices: &mesh.indices,
            index_count: mesh.index_count,
            vertex_stride: std::mem::size_of::<V>() as u64,
        }
    }

    /// The vertex buffer layout that reads only the position (location 0).
    pub fn vertex_buffer_layout(&self) -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: self.vertex_stride,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &POSITION_ATTRIBUTES,
        }
    }

    /// Records an indexed draw of the triangles into `pass` (whose pipeline
    /// uses [`Self::vertex_buffer_layout`] at vertex buffer slot 0).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        // Nothing to draw; and wgpu 29 cannot slice an empty buffer (it panics).
        if self.index_count == 0 {
            return;
        }
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.index_count, 0, 0..1);
    }
}
