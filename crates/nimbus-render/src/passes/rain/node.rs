//! The encode step: the simulation and visibility compute, the streaks and splashes, the mist.

use super::{
    DropSegment, RainPass, RainState, SPLASH_CAPACITY, SPLASH_DROPLETS, STEP_STRIDE, WORKGROUP_SIZE,
};
use crate::core::binding;
use crate::frame::occluders::OccluderGeometry;
use crate::frame::{FRAME_GROUP, FrameBindings, PASS_GROUP};

impl RainPass {
    /// Records the rain shadow map (when it must be redrawn), the
    /// simulation's steps and the visibility list.
    pub fn encode_simulation(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &FrameBindings<'_>,
        occluders: &[OccluderGeometry<'_>],
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let Some(state) = &self.state else { return };
        if self.plan.redraw_occlusion {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("rain shadow map"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &state.shared.occlusion_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.occlusion_group, &[]);
            for geometry in occluders {
                let pipeline = self
                    .occluders
                    .iter()
                    .find(|(stride, _)| *stride == geometry.vertex_stride);
                if let Some((_, pipeline)) = pipeline {
                    pass.set_pipeline(pipeline);
                    geometry.draw(&mut pass);
                }
            }
            self.depth_occluder.draw(&mut pass);
        }
        // The bit masks start each frame clear: the first step's splashes
        // are marked in them (each step's placement clears its own).
        for segment in &state.drops.segments {
            encoder.clear_buffer(&segment.group_masks, 0, None);
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("rain simulation"),
            timestamp_writes: timestamps,
        });
        // Workgroups per buffer (a buffer holds at most one dispatch row's).
        let groups: Vec<(&DropSegment, u32)> = state
            .drops
            .segments
            .iter()
            .map(|segment| {
                let drops = segment.dispatched(state.dispatched);
                (segment, drops.div_ceil(WORKGROUP_SIZE))
            })
            .filter(|&(_, groups)| groups > 0)
            .collect();
        let splashes = self.settings.as_ref().is_some_and(|s| s.splashes);
        pass.set_bind_group(FRAME_GROUP, frame.frame, &[]);
        for i in 0..self.plan.steps.len() {
            for &(segment, groups) in &groups {
                pass.set_bind_group(
                    1,
                    &segment.simulation_group,
                    &[(i as u64 * STEP_STRIDE) as u32],
                );
                pass.set_pipeline(&self.simulate);
                pass.dispatch_workgroups(groups, 1, 1);
                // The step's splashes of this buffer, appended to the ring
                // in the order of the drops (after the buffers before it).
                if splashes {
                    pass.set_pipeline(&self.place_splashes);
                    pass.dispatch_workgroups(1, 1, 1);
                }
            }
        }
        // The visibility lists: mark the drops in view (in the masks the
        // last placement left clear), scan the workgroups' counts (one
        // workgroup), scatter in the drops' order.
        let [mark, scan, scatter] = &self.cull;
        for &(segment, groups) in &groups {
            pass.set_bind_group(1, &segment.visibility_group, &[]);
            pass.set_pipeline(mark);
            pass.dispatch_workgroups(groups, 1, 1);
            pass.set_pipeline(scan);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(scatter);
            pass.dispatch_workgroups(groups, 1, 1);
        }
    }

    /// The bind groups of the draws, one per drops' buffer, with the
    /// frame's depth (read-only): made the first time `depth` is seen.
    fn draw_groups(&self, state: &RainState, depth: &wgpu::TextureView) -> Vec<wgpu::BindGroup> {
        state.drops.draw_groups.get(depth, || {
            state
                .drops
                .segments
                .iter()
                .map(|segment| {
                    binding::sequential_bind_group(
                        &self.device,
                        "rain draw",
                        &self.draw_layout,
                        vec![
                            self.uniform.as_entire_binding(),
                            segment.drops.as_entire_binding(),
                            segment.visible.as_entire_binding(),
                            state.shared.splashes.as_entire_binding(),
                            wgpu::BindingResource::TextureView(depth),
                        ],
                    )
                })
                .collect()
        })
    }

    /// Draws the streaks and splashes into `pass` (whose depth attachment is
    /// `depth`, read-only: the streaks fade where they meet surfaces).
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
    ) {
        let Some(state) = &self.state else {
            return;
        };
        // Group 1 differs per drops' buffer, set below.
        frame.set_on(pass, None);
        pass.set_pipeline(&self.streaks);
        let groups = self.draw_groups(state, depth);
        for (index, (segment, group)) in state.drops.segments.iter().zip(&groups).enumerate() {
            if index > 0 && segment.dispatched(state.dispatched) == 0 {
                break;
            }
            pass.set_bind_group(PASS_GROUP, group, &[]);
            pass.draw_indirect(
                &state.drops.draw_args,
                index as u64 * state.drops.draw_args_stride,
            );
        }
        if self.settings.as_ref().is_some_and(|s| s.splashes) {
            // The splashes read no drops: the last buffer's group, still
            // bound, serves them.
            pass.set_pipeline(&self.splash);
            pass.draw(0..6, 0..SPLASH_CAPACITY * SPLASH_DROPLETS);
        }
    }

    /// Draws the mist over the frame (full screen, no depth attachment; the
    /// frame's depth is read as a texture).
    pub fn draw_mist(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
    ) {
        let Some(state) = &self.state else { return };
        let group = state.shared.mist_group.get(depth, || {
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("rain mist"),
                layout: &self.mist_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(depth),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: state.shared.zones.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: self.mist_slab.as_entire_binding(),
                    },
                ],
            })
        });
        pass.set_pipeline(&self.mist);
        frame.set_on(pass, Some(&group));
        pass.draw(0..3, 0..1);
    }
}
