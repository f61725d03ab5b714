//! Pipeline-building helpers shared by the passes: one description of a
//! draw pipeline ([`DrawPipeline`]) instead of a full wgpu descriptor
//! written out in every pass, the depth states nimbus uses (reverse-Z, so
//! nearer is greater) and the premultiplied blend of translucent media.

use super::targets::{DEPTH_FORMAT, HDR_FORMAT};

/// Premultiplied-alpha "over" blending of colour and alpha: what a pass
/// that draws a translucent medium (its in-scattered radiance and
/// 1 − transmittance) over the frame uses.
pub const PREMULTIPLIED_OVER: wgpu::BlendState = wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING;

/// A depth test against [`DEPTH_FORMAT`], writing depth or not.
pub fn depth_state(write: bool, compare: wgpu::CompareFunction) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// The depth state of opaque surfaces under reverse-Z: nearer (greater)
/// fragments pass and write their depth.
pub fn opaque_depth() -> wgpu::DepthStencilState {
    depth_state(true, wgpu::CompareFunction::Greater)
}

/// One colour target of the HDR format, blended as given (`None`: replaced).
pub fn hdr_target(blend: Option<wgpu::BlendState>) -> [Option<wgpu::ColorTargetState>; 1] {
    [Some(wgpu::ColorTargetState {
        format: HDR_FORMAT,
        blend,
        write_mask: wgpu::ColorWrites::ALL,
    })]
}

/// What differs between nimbus's draw pipelines; everything else (no
/// multisampling, no stencil, triangle lists, one module for both stages)
/// is the same for all of them.
#[derive(Clone, Debug)]
pub struct DrawPipeline<'a> {
    /// Label of the pipeline.
    pub label: &'a str,
    /// Its layout.
    pub layout: &'a wgpu::PipelineLayout,
    /// The shader module holding both entry points.
    pub module: &'a wgpu::ShaderModule,
    /// The vertex entry point.
    pub vertex_entry: &'a str,
    /// The fragment entry point (`None`: a depth-only pipeline).
    pub fragment_entry: Option<&'a str>,
    /// The vertex buffers read.
    pub vertex_buffers: &'a [wgpu::VertexBufferLayout<'a>],
    /// Faces culled.
    pub cull_mode: Option<wgpu::Face>,
    /// The depth test, if any.
    pub depth: Option<wgpu::DepthStencilState>,
    /// The colour targets.
    pub targets: &'a [Option<wgpu::ColorTargetState>],
}

impl DrawPipeline<'_> {
    /// Creates the pipeline.
    pub fn create(&self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(self.label),
            layout: Some(self.layout),
            vertex: wgpu::VertexState {
                module: self.module,
                entry_point: Some(self.vertex_entry),
                compilation_options: Default::default(),
                buffers: self.vertex_buffers,
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: self.cull_mode,
                ..Default::default()
            },
            depth_stencil: self.depth.clone(),
            multisample: Default::default(),
            fragment: self.fragment_entry.map(|entry| wgpu::FragmentState {
                module: self.module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                targets: self.targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}
