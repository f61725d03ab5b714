//! Sky pass: the physically based sky (from the sky-view LUT), the sun disk
//! and the open sea at the horizon.
//!
//! Drawn first, as a full-screen triangle at the far plane; under reverse-Z
//! its depth test passes only where nothing nearer has been drawn, so it also
//! works behind a caller's own geometry.

use crate::core::pipeline::{DrawPipeline, depth_state, hdr_target};
use crate::frame::{FrameBindings, FrameLayouts};
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};

const SKY_WGSL: WgslFile = WgslFile {
    name: "passes/sky/sky.wgsl",
    source: include_str!("sky.wgsl"),
};

/// The composed WGSL of this pass.
pub fn shader_source() -> String {
    shader::compose(&[SKY_WGSL])
}

/// Linear limb-darkening coefficient of the sun in the visible, u ≈ 0.6
/// (Neckel & Labs, Solar Physics 153, 1994, at 550 nm).
pub const SOLAR_LIMB_DARKENING_U: f32 = 0.6;

/// Settings of the sky pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkySettings {
    /// Height of the open sea drawn below the horizon, m.
    pub water_level_m: f32,
    /// Diffuse albedo of deep water.
    pub water_albedo: [f32; 3],
    /// Half the side of the square, centred on the origin, that the
    /// terrain pass covers once its mesh is ready, m (0 where no relief is
    /// drawn): the sea under it is hidden, so it is shaded plainly there.
    pub terrain_half_extent_m: f32,
}

/// GPU layout of WGSL `SkyPassParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SkyPassUniform {
    /// Height of the open sea, m.
    pub water_level_m: f32,
    /// Limb-darkening coefficient.
    pub limb_darkening_u: f32,
    /// Half the side of the terrain's square, m (0: none).
    pub terrain_half_extent_m: f32,
    /// Padding to 16 bytes.
    pub _padding: f32,
    /// Diffuse albedo of deep water (w unused).
    pub water_albedo: [f32; 4],
}

impl From<SkySettings> for SkyPassUniform {
    fn from(s: SkySettings) -> Self {
        let [r, g, b] = s.water_albedo;
        Self {
            water_level_m: s.water_level_m,
            limb_darkening_u: SOLAR_LIMB_DARKENING_U,
            terrain_half_extent_m: s.terrain_half_extent_m,
            _padding: 0.0,
            water_albedo: [r, g, b, 0.0],
        }
    }
}

/// GPU resources of the sky pass.
#[derive(Debug)]
pub struct SkyPass {
    pipeline: wgpu::RenderPipeline,
    params: crate::core::binding::UniformBinding<SkyPassUniform>,
}

impl SkyPass {
    /// Creates the pipeline on the frame's groups and its own group 1.
    pub fn new(device: &wgpu::Device, frame: &FrameLayouts<'_>) -> Self {
        let params = crate::core::binding::UniformBinding::new(
            device,
            "sky params",
            wgpu::ShaderStages::FRAGMENT,
        );
        let module = shader::create_module(device, "sky", &shader_source());
        let layout = frame.pipeline_layout(device, "sky", Some(&params.layout));
        // A full-screen triangle at the far plane: it fills the pixels
        // still at the cleared (or the caller's) far depth.
        let pipeline = DrawPipeline {
            label: "sky",
            layout: &layout,
            module: &module,
            vertex_entry: "fullscreen_vertex",
            fragment_entry: Some("sky_fragment"),
            vertex_buffers: &[],
            cull_mode: None,
            depth: Some(depth_state(false, wgpu::CompareFunction::GreaterEqual)),
            targets: &hdr_target(None),
        }
        .create(device);
        Self { pipeline, params }
    }

    /// Uploads the settings.
    pub fn prepare(&self, queue: &wgpu::Queue, settings: SkySettings) {
        self.params.write(queue, &settings.into());
    }

    /// Records the pass into `pass`, which targets the HDR colour and the depth buffer.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame: &FrameBindings<'_>) {
        pass.set_pipeline(&self.pipeline);
        frame.set_on(pass, Some(&self.params.bind_group));
        pass.draw(0..3, 0..1);
    }
}
