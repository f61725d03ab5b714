//! A caller's depth buffer as its own pipeline leaves it, for the tests of
//! what nimbus reads of it: cleared to the far plane, with one rectangle
//! drawn at a constant depth (depth buffers cannot be written by copies).

use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::targets::{DEPTH_FORMAT, Target};

/// A rectangle of normalised device coordinates (x from left to right, y
/// from bottom to top) at a depth.
pub struct DepthRect {
    /// Left, bottom, right, top.
    pub ndc: [f32; 4],
    /// The depth written there.
    pub depth: f32,
}

/// A `width` × `height` `Depth32Float` texture (`TEXTURE_BINDING` usage)
/// cleared to `far_depth`, with `rect` drawn into it when given.
pub fn caller_depth(
    h: &HeadlessRenderer,
    width: u32,
    height: u32,
    far_depth: f32,
    rect: Option<DepthRect>,
) -> Target {
    let device = &h.gpu.device;
    let target = Target::new(
        device,
        "caller depth",
        DEPTH_FORMAT,
        width,
        height,
        wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("caller depth"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &target.view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(far_depth),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if let Some(DepthRect {
            ndc: [left, bottom, right, top],
            depth,
        }) = rect
        {
            let source = format!(
                "@vertex fn rect(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {{
                    let x = select({left:?}, {right:?}, i == 1u || i == 2u || i == 4u);
                    let y = select({bottom:?}, {top:?}, i == 2u || i == 4u || i == 5u);
                    return vec4<f32>(x, y, {depth:?}, 1.0);
                }}"
            );
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("caller rectangle"),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("caller rectangle"),
                layout: None,
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("rect"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: Default::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Always),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: None,
                multiview_mask: None,
                cache: None,
            });
            pass.set_pipeline(&pipeline);
            pass.draw(0..6, 0..1);
        }
    }
    h.gpu.queue.submit([encoder.finish()]);
    target
}
