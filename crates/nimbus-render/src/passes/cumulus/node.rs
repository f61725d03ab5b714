//! The encode step: the shadow map, the opaque bodies, the fringes' order-independent accumulation (weighted blended OIT) and its composite.

use super::{CumulusPass, Draw, FringeTargets, MarchGroup};
use crate::core::binding;
use crate::frame::cloud_shadow::CloudShadowMap;
use crate::frame::{CLOUD_LIGHTING_GROUP, FRAME_GROUP, FrameBindings, PASS_GROUP};
use std::sync::atomic::Ordering;

impl CumulusPass {
    pub(super) fn ensure_fringe_targets(&mut self, device: &wgpu::Device, width: u32, height: u32) {
        if self.fringe.as_ref().map(|f| f.size) == Some((width, height)) {
            return;
        }
        let target = |label: &str, format| {
            crate::core::targets::Target::new(
                device,
                label,
                format,
                width,
                height,
                wgpu::TextureUsages::TEXTURE_BINDING,
            )
            .view
        };
        let accumulation = target("cumulus fringe accumulation", ACCUMULATION_FORMAT);
        let revealage = target("cumulus fringe revealage", REVEALAGE_FORMAT);
        let composite_group = binding::sequential_bind_group(
            device,
            "cumulus composite",
            &self.composite_layout,
            vec![
                wgpu::BindingResource::TextureView(&accumulation),
                wgpu::BindingResource::TextureView(&revealage),
            ],
        );
        self.fringe = Some(FringeTargets {
            size: (width, height),
            accumulation,
            revealage,
            composite_group,
        });
    }

    pub(super) fn record(&self, pass: &mut wgpu::RenderPass<'_>, draws: &[Draw]) {
        let (Some((_, variants)), Some(instances)) = (&self.variants, &self.instances) else {
            return;
        };
        pass.set_vertex_buffer(1, instances.slice(..));
        for draw in draws {
            let lod = &variants[draw.variant].lods[draw.lod];
            pass.set_vertex_buffer(0, lod.vertices.slice(..));
            // Read by the camera's pipelines only (the shadow map's have two buffers).
            pass.set_vertex_buffer(2, lod.transfer.slice(..));
            pass.set_index_buffer(lod.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..lod.index_count, 0, draw.instances.clone());
        }
    }

    /// Records the shadow map, nearest cores then farthest, when its
    /// content changed this frame (see the `shadow` module); nothing when the
    /// map it holds is this frame's or the clouds cast no shadow (the
    /// map's uniform then says it holds none, and nothing reads it).
    pub fn encode_shadow(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &FrameBindings<'_>,
        shadow_map: &CloudShadowMap,
        timestamps: Option<(&wgpu::QuerySet, u32)>,
    ) {
        if !self.shadow_redrawn() {
            return;
        }
        for (layer, pipeline) in self.shadow_pipelines.iter().enumerate() {
            let clear = if layer == 0 { 1.0 } else { 0.0 };
            let timestamp_writes =
                timestamps.map(|(query_set, index)| wgpu::RenderPassTimestampWrites {
                    query_set,
                    beginning_of_pass_write_index: (layer == 0).then_some(index * 2),
                    end_of_pass_write_index: (layer == 1).then_some(index * 2 + 1),
                });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cumulus shadow"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &shadow_map.layer_views()[layer],
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(clear),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(FRAME_GROUP, frame.frame, &[]);
            pass.set_bind_group(PASS_GROUP, &self.group, &[]);
            pass.set_bind_group(CLOUD_LIGHTING_GROUP, shadow_map.uniform_group(), &[]);
            self.record(&mut pass, &self.shadow_draws);
        }
        self.shadow_drawn.store(true, Ordering::Release);
    }

    /// Records the opaque bodies into a pass on the HDR target and depth.
    pub fn draw_opaque(&self, pass: &mut wgpu::RenderPass<'_>, frame: &FrameBindings<'_>) {
        pass.set_pipeline(&self.opaque_pipeline);
        frame.set_on(pass, Some(&self.group));
        self.record(pass, &self.draws);
    }

    /// Records the fringes' accumulation (its own pass, depth read-only).
    pub fn encode_fringes(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let Some(fringe) = &self.fringe else { return };
        let attachment = |view, clear: f64| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: clear,
                        g: clear,
                        b: clear,
                        a: clear,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("cumulus fringes"),
            color_attachments: &[
                attachment(&fringe.accumulation, 0.0),
                attachment(&fringe.revealage, 1.0),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: None,
                stencil_ops: None,
            }),
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.fringe_pipeline);
        frame.set_on(&mut pass, Some(&self.group));
        self.record(&mut pass, &self.draws);
    }

    /// Whether the camera is in or near a cloud this frame (the in-cloud
    /// passes run).
    pub fn in_cloud_active(&self) -> bool {
        !self.in_cloud.active().is_empty() && !self.in_cloud.volume()
    }

    /// Whether the volume model marches clouds this frame (drawn with the
    /// bodies, before the stratus layer: [`Self::encode_in_cloud`] there).
    pub fn volume_active(&self) -> bool {
        !self.in_cloud.active().is_empty() && self.in_cloud.volume()
    }

    /// Whether the volume model marches clouds wholly between the camera
    /// and the stratus layer this frame (drawn after the layer:
    /// [`Self::encode_in_cloud`] with [`MarchGroup::InFrontOfLayer`]).
    pub fn volume_in_front_of_layer(&self) -> bool {
        self.in_cloud.volume() && self.in_cloud.any_in_front_of_layer()
    }

    /// Whether [`Self::encode_in_cloud`] will render any instance's light
    /// atlas this frame (`lighting_generation`: the atmosphere's count of
    /// lighting steps recorded; the atlases are kept while it and the
    /// instances' scale and yaw hold).
    pub fn in_cloud_light_pending(&self, lighting_generation: u64) -> bool {
        self.in_cloud.light_pending(lighting_generation)
    }

    /// Records the in-cloud passes (see [`super::in_cloud`]): with
    /// [`MarchGroup::BehindOrAmongLayer`] (the first call) the active
    /// instances' light where it is stale; then the marches of `group` over
    /// `hdr`, reading `depth`.
    #[allow(clippy::too_many_arguments)]
    pub fn encode_in_cloud(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        hdr: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
        lighting_generation: u64,
        group: MarchGroup,
        light_timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
        march_timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        self.in_cloud.encode(
            encoder,
            hdr,
            depth,
            frame,
            &self.uniform,
            lighting_generation,
            group,
            light_timestamps,
            march_timestamps,
        );
    }

    /// Records the fringes' composite into a pass on the HDR target.
    pub fn draw_composite(&self, pass: &mut wgpu::RenderPass<'_>) {
        let Some(fringe) = &self.fringe else { return };
        pass.set_pipeline(&self.composite_pipeline);
        pass.set_bind_group(0, &fringe.composite_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// Format of the fringes' Σ w α C, Σ w α target.
pub(super) const ACCUMULATION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of the fringes' Π (1 − α) target.
pub(super) const REVEALAGE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;
