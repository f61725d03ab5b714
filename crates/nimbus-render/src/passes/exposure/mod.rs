//! Exposure pass: meters the HDR frame and sets the exposure the tone mapper
//! applies ([`ExposureState`]): the scene's manual EV100, or automatic
//! exposure from the frame's log-average luminance with adaptation over time.
//!
//! The drawing passes write radiance times a pre-exposure (the manual
//! exposure, or the lighting pass's incident-light estimate) so that values
//! stay within half-float range; the tone mapper multiplies by
//! `tonemap_scale` = final exposure / pre-exposure, so the metered exposure
//! applies to the frame it was metered on.

use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};

const EXPOSURE_WGSL: WgslFile = WgslFile {
    name: "passes/exposure/exposure.wgsl",
    source: include_str!("exposure.wgsl"),
};

/// Samples per side of the metering grid.
pub const METER_GRID: u32 = 64;

/// Reflected-light meter calibration constant K, cd·s·m⁻² (ISO 2720, the
/// value camera makers use; Lagarde & de Rousiers 2014, §4.2).
pub const REFLECTED_METER_K: f64 = 12.5;

/// The composed WGSL of this pass.
pub fn shader_source() -> String {
    shader::compose(&[EXPOSURE_WGSL])
}

/// GPU layout of WGSL `ExposureState`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ExposureState {
    /// EV100 applied to the frame's output.
    pub ev100: f32,
    /// Final exposure over pre-exposure, applied by the tone mapper.
    pub tonemap_scale: f32,
    /// Log-average luminance of the frame, cd/m².
    pub average_luminance_cd_m2: f32,
    /// Time of the frame that set `ev100`, s.
    pub time_s: f32,
    /// 1 once a frame has been metered.
    pub valid: u32,
    /// Padding.
    pub _padding0: u32,
    /// Padding.
    pub _padding1: u32,
    /// Padding.
    pub _padding2: u32,
}

/// CPU reference of the meter: EV100 from radiance samples (W·sr⁻¹·m⁻²) by
/// the log-average luminance and the reflected-light calibration.
pub fn metered_ev100(radiance_samples: &[[f64; 3]]) -> f64 {
    let sum: f64 = radiance_samples
        .iter()
        .map(|rgb| {
            nimbus_physics::photometry::luminance_cd_m2(*rgb)
                .max(1e-4)
                .log2()
        })
        .sum();
    let average = (sum / radiance_samples.len() as f64).exp2();
    (average * 100.0 / REFLECTED_METER_K).log2()
}

/// Pixel metered by grid sample (i, j) of an image of the given size.
pub fn meter_pixel(i: u32, j: u32, width: u32, height: u32) -> (u32, u32) {
    let at = |k: u32, size: u32| (((k as f32 + 0.5) / METER_GRID as f32) * size as f32) as u32;
    (at(i, width), at(j, height))
}

/// GPU resources of the exposure pass.
#[derive(Debug)]
pub struct ExposurePass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    state: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
}

impl ExposurePass {
    /// Creates the pipeline and the state buffer.
    pub fn new(device: &wgpu::Device, frame_layout: &wgpu::BindGroupLayout) -> Self {
        let compute = wgpu::ShaderStages::COMPUTE;
        let storage = |binding, read_only, size| {
            crate::core::binding::buffer_entry(
                binding,
                wgpu::BufferBindingType::Storage { read_only },
                size,
                compute,
            )
        };
        let hdr_entry =
            crate::core::binding::texture_entry(0, wgpu::TextureViewDimension::D2, false, compute);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("exposure"),
            entries: &[
                hdr_entry,
                storage(
                    1,
                    true,
                    std::mem::size_of::<crate::frame::atmosphere::LightingUniform>() as u64,
                ),
                storage(2, false, std::mem::size_of::<ExposureState>() as u64),
            ],
        });
        let state = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("exposure state"),
            size: std::mem::size_of::<ExposureState>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let module = shader::create_module(device, "exposure", &shader_source());
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("exposure"),
            bind_group_layouts: &[Some(frame_layout), Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("exposure"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("exposure_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Self {
            pipeline,
            layout,
            state,
            bind_group: None,
        }
    }

    /// Binds the HDR target to meter (call when it is recreated).
    pub fn set_input(
        &mut self,
        device: &wgpu::Device,
        hdr_view: &wgpu::TextureView,
        lighting: &wgpu::Buffer,
    ) {
        self.bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("exposure"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(hdr_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: lighting.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: self.state.as_entire_binding(),
                },
            ],
        }));
    }

    /// Records the pass.
    pub fn encode(&self, pass: &mut wgpu::ComputePass<'_>, frame: &wgpu::BindGroup) {
        let Some(bind_group) = &self.bind_group else {
            return;
        };
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(1, bind_group, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// The state buffer ([`ExposureState`]), read by the tone mapper.
    pub fn state_buffer(&self) -> &wgpu::Buffer {
        &self.state
    }
}
