//! Tone-mapping pass: reads the HDR target and writes the caller's output
//! target. For 8-bit unorm outputs it applies the sRGB transfer function and
//! dithering itself; `*Srgb` formats are encoded by the hardware (no dither);
//! float outputs receive the tone-mapped linear values.

use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};

const TONEMAP_WGSL: WgslFile = WgslFile {
    name: "passes/tonemap/tonemap.wgsl",
    source: include_str!("tonemap.wgsl"),
};

/// The composed WGSL of this pass (it does not use the frame uniform).
pub fn shader_source() -> String {
    shader::compose(&[TONEMAP_WGSL])
}

/// GPU layout of WGSL `TonemapParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TonemapUniform {
    /// 1 to apply the sRGB transfer function in the shader.
    pub encode_srgb: u32,
    /// Dither amplitude in code values.
    pub dither_lsb: f32,
    /// Number of code values of the output minus one.
    pub code_values: f32,
    /// Padding to 16 bytes.
    pub _padding: f32,
}

impl TonemapUniform {
    /// The settings suited to an output format.
    pub fn for_format(format: wgpu::TextureFormat) -> Self {
        let eight_bit_unorm = matches!(
            format,
            wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Bgra8Unorm
        );
        Self {
            encode_srgb: u32::from(eight_bit_unorm),
            dither_lsb: if eight_bit_unorm { 1.0 } else { 0.0 },
            code_values: 255.0,
            _padding: 0.0,
        }
    }
}

/// CPU reference of the shader's ACES fit (Hill 2016), for tests.
pub fn aces_fitted_reference(color: [f64; 3]) -> [f64; 3] {
    let input = [
        [0.59719, 0.35458, 0.04823],
        [0.07600, 0.90834, 0.01566],
        [0.02840, 0.13383, 0.83777],
    ];
    let output = [
        [1.60475, -0.53108, -0.07367],
        [-0.10208, 1.10813, -0.00605],
        [-0.00327, -0.07276, 1.07602],
    ];
    let mul = |m: [[f64; 3]; 3], v: [f64; 3]| {
        [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
    };
    let fit =
        |v: f64| (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081);
    mul(output, mul(input, color).map(fit)).map(|c| c.clamp(0.0, 1.0))
}

/// The tone-mapping pass.
#[derive(Debug)]
pub struct TonemapPass {
    pipeline: wgpu::RenderPipeline,
    group_layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
}

impl TonemapPass {
    /// Creates the pipeline for an output format.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        output_format: wgpu::TextureFormat,
    ) -> Self {
        let size = std::mem::size_of::<TonemapUniform>() as u64;
        let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tonemap"),
            entries: &[
                crate::core::binding::texture_2d_entry(0, false),
                crate::core::binding::uniform_layout_entry(1, wgpu::ShaderStages::FRAGMENT, size),
                // The exposure state; the shader reads its first two f32.
                crate::core::binding::buffer_entry(
                    2,
                    wgpu::BufferBindingType::Storage { read_only: true },
                    8,
                    wgpu::ShaderStages::FRAGMENT,
                ),
            ],
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tonemap params"),
            size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(
            &params,
            0,
            bytemuck::bytes_of(&TonemapUniform::for_format(output_format)),
        );
        let module = shader::create_module(device, "tonemap", &shader_source());
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("tonemap"),
            bind_group_layouts: &[Some(&group_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("tonemap"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("fullscreen_vertex"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("tonemap_fragment"),
                compilation_options: Default::default(),
                targets: &[Some(output_format.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        Self {
            pipeline,
            group_layout,
            params,
            bind_group: None,
        }
    }

    /// Binds the HDR target to read and the exposure state (call when the target is recreated).
    pub fn set_input(
        &mut self,
        device: &wgpu::Device,
        hdr_view: &wgpu::TextureView,
        exposure: &wgpu::Buffer,
    ) {
        self.bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonemap"),
            layout: &self.group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(hdr_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: exposure.as_entire_binding(),
                },
            ],
        }));
    }

    /// Records the draw into `pass`, which targets the output.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        let Some(bind_group) = &self.bind_group else {
            return;
        };
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aces_fit_is_monotonic_and_maps_black_to_black() {
        assert!(
            aces_fitted_reference([0.0; 3])
                .iter()
                .all(|c| c.abs() < 1e-3)
        );
        let mut last = -1.0;
        for k in 0..100 {
            let v = 0.02 * k as f64;
            let g = aces_fitted_reference([v; 3])[1];
            assert!(g >= last);
            last = g;
        }
        assert!(aces_fitted_reference([16.0; 3]).iter().all(|c| *c > 0.95));
    }
}
