//! The cumulus pass's pipelines and layouts, created once.

use super::gpu_types::{CumulusUniform, draw_vertex_layouts, vertex_layouts};
use super::in_cloud::InCloud;
use super::node::{ACCUMULATION_FORMAT, REVEALAGE_FORMAT};
use super::{
    CumulusPass, FORWARD_PEAK_TEXTURE, PHASE_TEXTURE, composite_shader_source, draw_shader_source,
    shadow_shader_source,
};
use crate::core::background::Deferred;
use crate::core::binding;
use crate::core::pipeline::{DrawPipeline, PREMULTIPLIED_OVER, depth_state, hdr_target};
use crate::frame::FrameLayouts;
use crate::frame::cloud_shadow::CloudShadowMap;
use crate::shader;
use std::sync::atomic::AtomicBool;

impl CumulusPass {
    /// Creates the pipelines; shapes and the field are made by [`Self::prepare`].
    pub fn new(
        device: &wgpu::Device,
        frame: &FrameLayouts<'_>,
        shadow_map: &CloudShadowMap,
    ) -> Self {
        let uniform_size = std::mem::size_of::<CumulusUniform>() as u64;
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cumulus uniform"),
            size: uniform_size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let draw_stages = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cumulus"),
            entries: &[
                binding::uniform_layout_entry(0, draw_stages, uniform_size),
                binding::texture_entry(
                    1,
                    wgpu::TextureViewDimension::D2,
                    false,
                    wgpu::ShaderStages::FRAGMENT,
                ),
                binding::texture_entry(
                    2,
                    wgpu::TextureViewDimension::D2,
                    false,
                    wgpu::ShaderStages::FRAGMENT,
                ),
            ],
        });
        // F(θ, τ) and P_S(Θ), written by `prepare` when the droplets change
        // (zero: no forward peak until then).
        let forward_peak_table = device.create_texture(&FORWARD_PEAK_TEXTURE);
        let phase_table = device.create_texture(&PHASE_TEXTURE);
        let in_cloud = InCloud::new(
            device,
            frame,
            uniform_size,
            forward_peak_table.create_view(&Default::default()),
            phase_table.create_view(&Default::default()),
        );
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cumulus"),
            layout: &group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(
                        &forward_peak_table.create_view(&Default::default()),
                    ),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(
                        &phase_table.create_view(&Default::default()),
                    ),
                },
            ],
        });

        let shadow_module =
            shader::create_module(device, "cumulus shadow", &shadow_shader_source());
        // The map is drawn here, so group 3 holds only its uniform.
        let shadow_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cumulus shadow"),
            bind_group_layouts: &[
                Some(frame.frame),
                Some(&group_layout),
                None,
                Some(shadow_map.uniform_layout()),
            ],
            immediate_size: 0,
        });
        let buffers = vertex_layouts();
        let shadow_pipeline = |label: &str, compare| {
            DrawPipeline {
                label,
                layout: &shadow_layout,
                module: &shadow_module,
                vertex_entry: "cumulus_shadow_vertex",
                fragment_entry: Some("cumulus_shadow_fragment"),
                vertex_buffers: &buffers,
                cull_mode: None,
                depth: Some(depth_state(true, compare)),
                targets: &[],
            }
            .create(device)
        };
        let shadow_pipelines = [
            shadow_pipeline("cumulus shadow nearest", wgpu::CompareFunction::Less),
            shadow_pipeline("cumulus shadow farthest", wgpu::CompareFunction::Greater),
        ];

        let module = shader::create_module(device, "cumulus", &draw_shader_source());
        let draw_buffers = draw_vertex_layouts();
        let layout = frame.pipeline_layout(device, "cumulus", Some(&group_layout));
        let draw_pipeline =
            |label: &str,
             entry: &str,
             depth_write: bool,
             targets: &[Option<wgpu::ColorTargetState>]| {
                DrawPipeline {
                    label,
                    layout: &layout,
                    module: &module,
                    vertex_entry: "cumulus_vertex",
                    fragment_entry: Some(entry),
                    vertex_buffers: &draw_buffers,
                    cull_mode: Some(wgpu::Face::Back),
                    depth: Some(depth_state(depth_write, wgpu::CompareFunction::Greater)),
                    targets,
                }
                .create(device)
            };
        let opaque_pipeline = draw_pipeline(
            "cumulus",
            "cumulus_opaque_fragment",
            true,
            &hdr_target(None),
        );
        let additive = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let multiplicative = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::Zero,
            dst_factor: wgpu::BlendFactor::OneMinusSrc,
            operation: wgpu::BlendOperation::Add,
        };
        let fringe_pipeline = draw_pipeline(
            "cumulus fringes",
            "cumulus_fringe_fragment",
            false,
            &[
                Some(wgpu::ColorTargetState {
                    format: ACCUMULATION_FORMAT,
                    blend: Some(wgpu::BlendState {
                        color: additive,
                        alpha: additive,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                }),
                Some(wgpu::ColorTargetState {
                    format: REVEALAGE_FORMAT,
                    blend: Some(wgpu::BlendState {
                        color: multiplicative,
                        alpha: multiplicative,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                }),
            ],
        );

        let composite_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cumulus composite"),
            entries: &[
                binding::texture_entry(
                    0,
                    wgpu::TextureViewDimension::D2,
                    false,
                    wgpu::ShaderStages::FRAGMENT,
                ),
                binding::texture_entry(
                    1,
                    wgpu::TextureViewDimension::D2,
                    false,
                    wgpu::ShaderStages::FRAGMENT,
                ),
            ],
        });
        let composite_module =
            shader::create_module(device, "cumulus composite", &composite_shader_source());
        let composite_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("cumulus composite"),
                bind_group_layouts: &[Some(&composite_layout)],
                immediate_size: 0,
            });
        let composite_pipeline = DrawPipeline {
            label: "cumulus composite",
            layout: &composite_pipeline_layout,
            module: &composite_module,
            vertex_entry: "fullscreen_vertex",
            fragment_entry: Some("cumulus_composite_fragment"),
            vertex_buffers: &[],
            cull_mode: None,
            depth: None,
            targets: &hdr_target(Some(PREMULTIPLIED_OVER)),
        }
        .create(device);
        Self {
            uniform,
            group,
            forward_peak_table,
            forward_peak_key: None,
            shadow_pipelines,
            opaque_pipeline,
            fringe_pipeline,
            composite_pipeline,
            composite_layout,
            fringe: None,
            variants: None,
            shapes: Deferred::new("cumulus shapes"),
            forward_peak: Deferred::new("cumulus forward peak"),
            phase_table,
            transfers: Deferred::new("cumulus light transfer"),
            transfer_uploaded: None,
            transport_truncation: 1.0,
            field: None,
            moved: Vec::new(),
            instances: None,
            draws: Vec::new(),
            shadow_draws: Vec::new(),
            enabled: false,
            shadow_enabled: false,
            shadow_content: None,
            shadow_redraw: false,
            shadow_drawn: AtomicBool::new(false),
            in_cloud,
        }
    }
}
