//! Indexed triangle meshes on the GPU (the terrain and the static objects)
//! and the index buffers of regular grids (the terrain and the stratus layer).

use wgpu::util::DeviceExt;

/// Triangle indices of a row-major n × n vertex grid: two triangles per
/// cell, counter-clockwise seen from +Y (+Z is south, so (a, c, b) turns
/// anticlockwise from above).
pub fn grid_indices(n: u32) -> Vec<u32> {
    let cells = n.saturating_sub(1);
    let mut indices = Vec::with_capacity((cells * cells * 6) as usize);
    for j in 0..cells {
        for i in 0..cells {
            let a = j * n + i;
            let (b, c) = (a + 1, a + n);
            indices.extend_from_slice(&[a, c, b, b, c, c + 1]);
        }
    }
    indices
}

/// An indexed triangle list on the GPU: vertices (usage `VERTEX`) and
/// `u32` indices (usage `INDEX`).
#[derive(Debug)]
pub struct IndexedMesh {
    /// The vertices.
    pub vertices: wgpu::Buffer,
    /// The triangle indices.
    pub indices: wgpu::Buffer,
    /// Number of indices (three per triangle).
    pub index_count: u32,
}

impl IndexedMesh {
    /// Uploads `vertices` (any `Pod` vertex type) and `indices`. Check the
    /// sizes against the device's limits first.
    pub fn upload<V: bytemuck::Pod>(
        device: &wgpu::Device,
        label: &str,
        vertices: &[V],
        indices: &[u32],
    ) -> Self {
        Self {
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&format!("{label} vertices")),
                contents: bytemuck::cast_slice(vertices),
                usage: wgpu::BufferUsages::VERTEX,
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&format!("{label} indices")),
                contents: bytemuck::cast_slice(indices),
                usage: wgpu::BufferUsages::INDEX,
            }),
            index_count: indices.len() as u32,
        }
    }

    /// Records a draw of every triangle into `pass` (vertex buffer slot 0).
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
