//! The encode step: the thickness window and radiosity compute, and the layer's draw.

use super::StratusPass;
use crate::frame::FrameBindings;

impl StratusPass {
    /// Records the compute work of the frame (thickness window, radiosity
    /// inputs and iterations) into `pass`; nothing without a layer.
    pub fn encode_compute(&self, pass: &mut wgpu::ComputePass<'_>, frame: &FrameBindings<'_>) {
        let (Some(resources), Some(settings)) = (&self.resources, &self.settings) else {
            return;
        };
        let n = settings.resolution;
        // Group 3 is not bound: this compute writes the layer's parts of it.
        pass.set_bind_group(0, frame.frame, &[]);
        pass.set_bind_group(1, &resources.compute_group, &[]);
        pass.set_bind_group(2, frame.atmosphere, &[]);
        pass.set_pipeline(&self.thickness_pipeline);
        pass.dispatch_workgroups(n.div_ceil(8), n.div_ceil(8), 1);
        let size = resources.radiosity.size();
        pass.set_pipeline(&self.inputs_pipeline);
        pass.dispatch_workgroups(size.div_ceil(8), size.div_ceil(8), 1);
        resources
            .radiosity
            .encode_into(pass, settings.radiosity_iterations);
    }

    /// Records the layer's draw into `pass` (after the opaque passes, depth-tested).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame: &FrameBindings<'_>) {
        let (Some(resources), Some(_)) = (&self.resources, &self.settings) else {
            return;
        };
        // The march alone draws the layer from inside a cell.
        if self.in_layer_weight >= 1.0 {
            return;
        }
        frame.set_on(pass, None);
        if self.camera_is_level() {
            // Tops and bases edge-on: each pixel marches to the layer. While
            // the in-layer march fades in, the entry's depth is not written
            // (the march would stop at it).
            let pipeline = if self.in_layer_weight > 0.0 {
                &self.level_blend_pipeline
            } else {
                &self.level_pipeline
            };
            pass.set_pipeline(pipeline);
            pass.draw(0..3, 0..1);
        } else {
            pass.set_pipeline(&self.layer_pipeline);
            pass.set_index_buffer(resources.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..resources.index_count, 0, 0..1);
        }
    }

    /// Whether the in-layer march runs this frame.
    pub fn in_layer_active(&self) -> bool {
        self.settings.is_some() && self.resources.is_some() && self.in_layer_weight > 0.0
    }

    /// Records the in-layer march over `hdr` (its own pass), reading `depth`.
    pub fn encode_in_layer(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        hdr: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        if !self.in_layer_active() {
            return;
        }
        let group = self.in_layer_groups.get(depth, || {
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("stratus in-layer"),
                layout: &self.in_layer_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(depth),
                }],
            })
        });
        let mut pass = crate::core::targets::colour_pass(
            encoder,
            "stratus in-layer",
            hdr,
            None,
            timestamp_writes,
        );
        pass.set_pipeline(&self.in_layer_pipeline);
        frame.set_on(&mut pass, Some(&group));
        pass.draw(0..3, 0..1);
    }
}
