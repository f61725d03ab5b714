//! The frame-wide resources in one place, and what passes see of them:
//! [`FrameLayouts`] to build their pipelines, [`FrameBindings`] to draw.
//!
//! Every drawing pass uses the same four bind groups:
//!
//! | group | what | owner | WGSL |
//! |---|---|---|---|
//! | 0 | the frame uniform ([`FrameUniform`]) | [`FrameResources`] | `shader/common.wgsl` |
//! | 1 | the pass's own resources | the pass | its own files |
//! | 2 | atmosphere lookups ([`AtmosphereLookups`]) | [`FrameResources`] | `shader/atmosphere_lookup.wgsl` |
//! | 3 | cloud lighting ([`CloudLighting`]) | [`FrameResources`] | `shader/cloud_layer_lookup.wgsl`, `shader/cloud_shadow_lookup.wgsl` |
//!
//! The atmosphere pass writes group 2, the stratus and cumulus passes write
//! group 3; each exists from the renderer's creation on, so no pass needs
//! another to have run before it can draw.

use super::atmosphere::AtmosphereLookups;
use super::cloud_lighting::CloudLighting;
use super::{FrameBinding, FrameUniform};

/// Index of the frame uniform's group.
pub const FRAME_GROUP: u32 = 0;
/// Index of a pass's own group.
pub const PASS_GROUP: u32 = 1;
/// Index of the atmosphere lookups' group.
pub const ATMOSPHERE_GROUP: u32 = 2;
/// Index of the cloud lighting's group.
pub const CLOUD_LIGHTING_GROUP: u32 = 3;

/// The frame-wide GPU resources: the frame uniform, the atmosphere lookups
/// and the clouds' lighting (with the cloud shadow map).
#[derive(Debug)]
pub struct FrameResources {
    /// Group 0: the frame uniform.
    pub uniform: FrameBinding,
    /// Group 2: the atmosphere's LUTs, parameters and lighting inputs.
    pub atmosphere: AtmosphereLookups,
    /// Group 3: the stratus layer's lighting and the cloud shadow map.
    pub cloud_lighting: CloudLighting,
}

impl FrameResources {
    /// Creates every frame-wide resource (empty: no layer, no cloud shadow).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        Self {
            uniform: FrameBinding::new(
                device,
                "frame uniform",
                wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
            ),
            atmosphere: AtmosphereLookups::new(device),
            cloud_lighting: CloudLighting::new(device, queue),
        }
    }

    /// Writes the frame uniform.
    pub fn write_uniform(&self, queue: &wgpu::Queue, value: &FrameUniform) {
        self.uniform.write(queue, value);
    }

    /// The layouts, for pipelines.
    pub fn layouts(&self) -> FrameLayouts<'_> {
        FrameLayouts {
            frame: &self.uniform.layout,
            atmosphere: self.atmosphere.layout(),
            cloud_lighting: self.cloud_lighting.layout(),
        }
    }

    /// The bind groups, for drawing.
    pub fn bindings(&self) -> FrameBindings<'_> {
        FrameBindings {
            frame: &self.uniform.bind_group,
            atmosphere: self.atmosphere.bind_group(),
            cloud_lighting: self.cloud_lighting.bind_group(),
        }
    }
}

/// The layouts of the frame-wide groups 0, 2 and 3.
#[derive(Clone, Copy, Debug)]
pub struct FrameLayouts<'a> {
    /// Group 0.
    pub frame: &'a wgpu::BindGroupLayout,
    /// Group 2.
    pub atmosphere: &'a wgpu::BindGroupLayout,
    /// Group 3.
    pub cloud_lighting: &'a wgpu::BindGroupLayout,
}

impl FrameLayouts<'_> {
    /// A pipeline layout of the four groups: the frame's 0, 2 and 3 around
    /// the pass's own group 1 (`None` when the pass has none).
    pub fn pipeline_layout(
        &self,
        device: &wgpu::Device,
        label: &str,
        pass_group: Option<&wgpu::BindGroupLayout>,
    ) -> wgpu::PipelineLayout {
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[
                Some(self.frame),
                pass_group,
                Some(self.atmosphere),
                Some(self.cloud_lighting),
            ],
            immediate_size: 0,
        })
    }
}

/// The frame-wide bind groups 0, 2 and 3, handed to every pass that draws.
#[derive(Clone, Copy, Debug)]
pub struct FrameBindings<'a> {
    /// Group 0: the frame uniform.
    pub frame: &'a wgpu::BindGroup,
    /// Group 2: the atmosphere lookups.
    pub atmosphere: &'a wgpu::BindGroup,
    /// Group 3: the clouds' lighting.
    pub cloud_lighting: &'a wgpu::BindGroup,
}

/// What bind groups are set on: wgpu's render and compute passes.
pub trait SetBindGroup {
    /// Sets `group` at `index`, without dynamic offsets.
    fn set_group(&mut self, index: u32, group: &wgpu::BindGroup);
}

impl SetBindGroup for wgpu::RenderPass<'_> {
    fn set_group(&mut self, index: u32, group: &wgpu::BindGroup) {
        self.set_bind_group(index, group, &[]);
    }
}

impl SetBindGroup for wgpu::ComputePass<'_> {
    fn set_group(&mut self, index: u32, group: &wgpu::BindGroup) {
        self.set_bind_group(index, group, &[]);
    }
}

impl FrameBindings<'_> {
    /// Sets groups 0, 2 and 3 on a render or compute pass, and the pass's
    /// own group 1 when given.
    pub fn set_on(&self, pass: &mut impl SetBindGroup, pass_group: Option<&wgpu::BindGroup>) {
        pass.set_group(FRAME_GROUP, self.frame);
        if let Some(group) = pass_group {
            pass.set_group(PASS_GROUP, group);
        }
        pass.set_group(ATMOSPHERE_GROUP, self.atmosphere);
        pass.set_group(CLOUD_LIGHTING_GROUP, self.cloud_lighting);
    }
}
