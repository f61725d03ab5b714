//! Composite pass: nimbus inside the caller's HDR frame
//! (`LinearHdr` output mode of the renderer).
//!
//! Three full-screen draws around the frame's other passes:
//!
//! 1. **depth import**, first: the caller's depth buffer (any depth
//!    convention, any projection, [`crate::frame::View`]) translated into
//!    nimbus's own reverse-Z depth target, so that the sky fills only what the
//!    caller left at its far plane, the clouds hide behind the caller's
//!    geometry, and the caller's depth buffer is never written;
//! 2. **aerial perspective** over the caller's pixels, before nimbus draws
//!    its own surfaces: the air between the eye and the caller's geometry;
//! 3. **export**, last: nimbus's HDR target (radiance added, and coverage of
//!    what lies behind in alpha) blended premultiplied "over" the caller's
//!    colour target, so that a pixel nimbus did not draw over keeps its value.

use crate::core::binding::{self, PerViewGroups, UniformBinding};
use crate::core::pipeline::{DrawPipeline, PREMULTIPLIED_OVER, depth_state, hdr_target};
use crate::frame::{FrameBindings, FrameLayouts, View};
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};

const COMPOSITE_WGSL: WgslFile = WgslFile {
    name: "passes/composite/composite.wgsl",
    source: include_str!("composite.wgsl"),
};

/// The composed WGSL of this pass.
pub fn shader_source() -> String {
    shader::compose(&[COMPOSITE_WGSL])
}

/// GPU layout of WGSL `CompositeParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CompositeUniform {
    /// nimbus's clip space from the caller's ([`View::nimbus_clip_from_caller_clip`]).
    pub nimbus_clip_from_caller_clip: [[f32; 4]; 4],
    /// x: the caller's far-plane depth; yzw unused.
    pub caller: [f32; 4],
}

impl CompositeUniform {
    /// The uniform of a view.
    pub fn new(view: &View) -> Self {
        Self {
            nimbus_clip_from_caller_clip: view
                .nimbus_clip_from_caller_clip()
                .as_mat4()
                .to_cols_array_2d(),
            caller: [view.caller_far_depth(), 0.0, 0.0, 0.0],
        }
    }
}

/// The composite pass.
#[derive(Debug)]
pub struct CompositePass {
    params: UniformBinding<CompositeUniform>,
    import_layout: wgpu::BindGroupLayout,
    aerial_layout: wgpu::BindGroupLayout,
    export_layout: wgpu::BindGroupLayout,
    /// The groups of nimbus's own targets (its depth for the air, its colour
    /// for the export), made when they are ([`Self::set_targets`]).
    target_groups: Option<(wgpu::BindGroup, wgpu::BindGroup)>,
    /// The depth import's group with the caller's depth, made once per
    /// depth view the caller hands in.
    import_group: PerViewGroups<wgpu::BindGroup>,
    depth_import: wgpu::RenderPipeline,
    aerial: wgpu::RenderPipeline,
    export: wgpu::RenderPipeline,
}

fn depth_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    binding::depth_texture_entry(
        binding,
        wgpu::TextureViewDimension::D2,
        wgpu::ShaderStages::FRAGMENT,
    )
}

impl CompositePass {
    /// Creates the pipelines; the export writes `output_format` (a float
    /// format the device can blend).
    pub fn new(
        device: &wgpu::Device,
        frame: &FrameLayouts<'_>,
        output_format: wgpu::TextureFormat,
    ) -> Self {
        let params = UniformBinding::<CompositeUniform>::new(
            device,
            "composite params",
            wgpu::ShaderStages::FRAGMENT,
        );
        let size = std::mem::size_of::<CompositeUniform>() as u64;
        let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            })
        };
        let import_layout = layout(
            "depth import",
            &[
                binding::uniform_layout_entry(0, wgpu::ShaderStages::FRAGMENT, size),
                depth_entry(1),
            ],
        );
        let aerial_layout = layout("caller aerial perspective", &[depth_entry(2)]);
        let export_layout = layout("export", &[binding::texture_2d_entry(3, false)]);
        let module = shader::create_module(device, "composite", &shader_source());
        let pipeline = |label, entry, group: &wgpu::BindGroupLayout, depth, targets: &[_]| {
            let layout = frame.pipeline_layout(device, label, Some(group));
            DrawPipeline {
                label,
                layout: &layout,
                module: &module,
                vertex_entry: "fullscreen_vertex",
                fragment_entry: Some(entry),
                vertex_buffers: &[],
                cull_mode: None,
                depth,
                targets,
            }
            .create(device)
        };
        let depth_import = pipeline(
            "depth import",
            "depth_import_fragment",
            &import_layout,
            Some(depth_state(true, wgpu::CompareFunction::Always)),
            &[],
        );
        let aerial = pipeline(
            "caller aerial perspective",
            "aerial_fragment",
            &aerial_layout,
            None,
            &hdr_target(Some(PREMULTIPLIED_OVER)),
        );
        let export = pipeline(
            "export",
            "export_fragment",
            &export_layout,
            None,
            &[Some(wgpu::ColorTargetState {
                format: output_format,
                blend: Some(PREMULTIPLIED_OVER),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        );
        Self {
            params,
            import_layout,
            aerial_layout,
            export_layout,
            target_groups: None,
            import_group: PerViewGroups::default(),
            depth_import,
            aerial,
            export,
        }
    }

    /// Writes the view's depth translation.
    pub fn prepare(&self, queue: &wgpu::Queue, view: &View) {
        self.params.write(queue, &CompositeUniform::new(view));
    }

    fn group(
        &self,
        device: &wgpu::Device,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        entries: &[wgpu::BindGroupEntry<'_>],
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries,
        })
    }

    /// Records the depth import: the caller's depth (`caller_depth`, any
    /// depth format's depth aspect) into `nimbus_depth` ([`crate::core::targets::DEPTH_FORMAT`]),
    /// cleared first, with nimbus's colour target cleared to transparent.
    pub fn encode_depth_import(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        caller_depth: &wgpu::TextureView,
        nimbus_depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let group = self.import_group.get(caller_depth, || {
            self.group(
                device,
                "depth import",
                &self.import_layout,
                &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.params.buffer.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(caller_depth),
                    },
                ],
            )
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("depth import"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: nimbus_depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(crate::core::targets::FAR_DEPTH),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.depth_import);
        frame.set_on(&mut pass, Some(&group));
        pass.draw(0..3, 0..1);
    }

    /// Binds nimbus's own targets: its depth (the caller's translated),
    /// which the air reads, and its HDR colour, which the export reads.
    /// Call when they are created or resized.
    pub fn set_targets(
        &mut self,
        device: &wgpu::Device,
        nimbus_depth: &wgpu::TextureView,
        nimbus_colour: &wgpu::TextureView,
    ) {
        let group = |label, layout, binding, view| {
            self.group(
                device,
                label,
                layout,
                &[wgpu::BindGroupEntry {
                    binding,
                    resource: wgpu::BindingResource::TextureView(view),
                }],
            )
        };
        self.target_groups = Some((
            group(
                "caller aerial perspective",
                &self.aerial_layout,
                2,
                nimbus_depth,
            ),
            group("export", &self.export_layout, 3, nimbus_colour),
        ));
    }

    /// Records the air in front of the caller's surfaces into `pass` (the
    /// HDR target, no depth attachment), reading nimbus's depth; nothing
    /// before [`Self::set_targets`].
    pub fn draw_aerial(&self, pass: &mut wgpu::RenderPass<'_>, frame: &FrameBindings<'_>) {
        if let Some((aerial, _)) = &self.target_groups {
            pass.set_pipeline(&self.aerial);
            frame.set_on(pass, Some(aerial));
            pass.draw(0..3, 0..1);
        }
    }

    /// Records the export of nimbus's colour over the caller's target into
    /// `pass` (whose colour attachment is the caller's, loaded); nothing
    /// before [`Self::set_targets`].
    pub fn draw_export(&self, pass: &mut wgpu::RenderPass<'_>, frame: &FrameBindings<'_>) {
        if let Some((_, export)) = &self.target_groups {
            pass.set_pipeline(&self.export);
            frame.set_on(pass, Some(export));
            pass.draw(0..3, 0..1);
        }
    }
}
