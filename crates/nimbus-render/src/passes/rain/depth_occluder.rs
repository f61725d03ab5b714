//! The caller's depth buffer of its world seen from above as rain cover
//! (`Renderer::set_occluder_depth`): drawn into the rain shadow map
//! as a height field (`depth_occluder.wgsl`), beside the occluders'
//! triangles, so that the simulation (the GPU twin of
//! `nimbus_physics::rain::simulation`) needs nothing new.

use crate::core::binding;
use crate::core::pipeline::{DrawPipeline, depth_state};
use crate::frame::View;
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};

const DEPTH_OCCLUDER_WGSL: WgslFile = WgslFile {
    name: "passes/rain/depth_occluder.wgsl",
    source: include_str!("depth_occluder.wgsl"),
};

/// The composed WGSL of the height-field draw.
pub fn depth_occluder_shader_source() -> String {
    shader::compose(&[DEPTH_OCCLUDER_WGSL])
}

/// Most vertices per side of the height field: a larger depth buffer is
/// sampled every few texels (the rain shadow map has 1024 texels per side
/// over a few hundred metres; finer adds cost, not cover).
pub const MAX_GRID_VERTICES: u32 = 512;

/// GPU layout of WGSL `DepthOccluder`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DepthOccluderUniform {
    /// World space from the caller's clip space.
    pub world_from_clip: [[f32; 4]; 4],
    /// Vertices per side (x, y), texels between vertices, unused.
    pub grid: [u32; 4],
    /// The caller's far-plane depth, its near-plane depth, two unused.
    pub depths: [f32; 4],
}

impl DepthOccluderUniform {
    /// The uniform of a `width` × `height` depth buffer rendered through `view`.
    pub fn new(view: &View, width: u32, height: u32) -> Self {
        let stride = width.max(height).div_ceil(MAX_GRID_VERTICES).max(1);
        let vertices = |texels: u32| (texels - 1) / stride + 1;
        let clip_from_world = view.caller_clip_from_view() * view.view_from_world();
        let far = view.caller_far_depth();
        Self {
            world_from_clip: clip_from_world.inverse().as_mat4().to_cols_array_2d(),
            grid: [vertices(width), vertices(height), stride, 0],
            depths: [far, 1.0 - far, 0.0, 0.0],
        }
    }

    /// Vertices of the draw: six per cell of the grid.
    pub fn vertex_count(&self) -> u32 {
        6 * (self.grid[0] - 1) * (self.grid[1] - 1)
    }
}

/// The height-field pipeline, and the caller's depth bound when given.
#[derive(Debug)]
pub struct DepthOccluderDraw {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    uniform: wgpu::Buffer,
    /// The bound depth buffer and the vertices to draw.
    bound: Option<(wgpu::BindGroup, u32)>,
}

impl DepthOccluderDraw {
    /// Creates the pipeline; `occlusion_layout` is the rain shadow map's
    /// view (group 0, `occlusion_from_world`).
    pub fn new(device: &wgpu::Device, occlusion_layout: &wgpu::BindGroupLayout) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("rain depth occluder"),
            entries: &[
                binding::uniform_layout_entry(
                    0,
                    wgpu::ShaderStages::VERTEX,
                    std::mem::size_of::<DepthOccluderUniform>() as u64,
                ),
                binding::depth_texture_entry(
                    1,
                    wgpu::TextureViewDimension::D2,
                    wgpu::ShaderStages::VERTEX,
                ),
            ],
        });
        let module = shader::create_module(
            device,
            "rain depth occluder",
            &depth_occluder_shader_source(),
        );
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("rain depth occluder"),
            bind_group_layouts: &[Some(occlusion_layout), Some(&layout)],
            immediate_size: 0,
        });
        // Depth only, like the triangles' pipeline: the nearest cover seen
        // along the rain.
        let pipeline = DrawPipeline {
            label: "rain depth occluder",
            layout: &pipeline_layout,
            module: &module,
            vertex_entry: "depth_occluder_vertex",
            fragment_entry: Some("depth_occluder_fragment"),
            vertex_buffers: &[],
            cull_mode: None,
            depth: Some(depth_state(true, wgpu::CompareFunction::Less)),
            targets: &[],
        }
        .create(device);
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain depth occluder"),
            size: std::mem::size_of::<DepthOccluderUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            layout,
            pipeline,
            uniform,
            bound: None,
        }
    }

    /// Binds the caller's depth (the view of its depth aspect, with
    /// `TEXTURE_BINDING` usage) rendered through `view`, or unbinds it.
    pub fn set(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        depth: Option<(&wgpu::TextureView, &View, u32, u32)>,
    ) {
        self.bound = depth.map(|(texture, view, width, height)| {
            let uniform = DepthOccluderUniform::new(view, width, height);
            queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
            let group = binding::sequential_bind_group(
                device,
                "rain depth occluder",
                &self.layout,
                vec![
                    self.uniform.as_entire_binding(),
                    wgpu::BindingResource::TextureView(texture),
                ],
            );
            (group, uniform.vertex_count())
        });
    }

    /// Records the height field's draw into the rain shadow map's `pass`
    /// (whose group 0 is already bound); nothing without a depth buffer.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        if let Some((group, vertices)) = &self.bound {
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(1, group, &[]);
            pass.draw(0..*vertices, 0..1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{DepthConvention, Projection};
    use glam::{DMat4, DVec3, DVec4};

    #[test]
    fn the_grid_covers_the_depth_buffer_and_inverts_the_callers_projection() {
        let view = View {
            world_from_view: DMat4::look_to_rh(
                DVec3::new(10.0, 100.0, -20.0),
                DVec3::NEG_Y,
                DVec3::NEG_Z,
            )
            .inverse(),
            projection: Projection::Orthographic {
                height_m: 40.0,
                aspect: 1.0,
                near_m: 0.0,
                far_m: 200.0,
            },
            depth: DepthConvention::Standard,
        };
        let small = DepthOccluderUniform::new(&view, 256, 128);
        assert_eq!(small.grid, [256, 128, 1, 0]);
        assert_eq!(small.vertex_count(), 6 * 255 * 127);
        let large = DepthOccluderUniform::new(&view, 2048, 1000);
        assert_eq!(large.grid[2], 4);
        assert_eq!(large.grid[0], 512);
        assert!((large.grid[1] - 1) * 4 <= 999);
        // The image centre at depth 0.5 (standard, orthographic): 100 m
        // below the eye, straight under it.
        let m = glam::Mat4::from_cols_array_2d(&small.world_from_clip).as_dmat4();
        let w = m * DVec4::new(0.0, 0.0, 0.5, 1.0);
        let p = w.truncate() / w.w;
        assert!((p - DVec3::new(10.0, 0.0, -20.0)).length() < 1e-3, "{p}");
        assert_eq!(small.depths, [1.0, 0.0, 0.0, 0.0]);
    }
}
