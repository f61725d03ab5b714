//! The stratus pass's layouts and pipelines, created once.

use super::{
    StratusPass, StratusUniform, compute_shader_source, in_layer_shader_source, layer_shader_source,
};
use crate::core::background::Deferred;
use crate::core::binding;
use crate::core::pipeline::{DrawPipeline, PREMULTIPLIED_OVER, depth_state, hdr_target};
use crate::frame::FrameLayouts;
use crate::frame::cloud_lighting::CloudLighting;
use crate::shader;

impl StratusPass {
    /// Creates the pipelines; resources are built by [`Self::prepare`].
    pub fn new(
        device: &wgpu::Device,
        frame: &FrameLayouts<'_>,
        cloud_lighting: &CloudLighting,
    ) -> Self {
        let uniform_size = std::mem::size_of::<StratusUniform>() as u64;
        let compute = wgpu::ShaderStages::COMPUTE;
        let storage_write = wgpu::BufferBindingType::Storage { read_only: false };
        let vec4 = 16;
        let compute_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stratus compute"),
            entries: &[
                binding::uniform_layout_entry(0, compute, uniform_size),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: compute,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::R32Float,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
                binding::buffer_entry(2, storage_write, vec4, compute),
                binding::buffer_entry(3, storage_write, vec4, compute),
                binding::buffer_entry(4, storage_write, vec4, compute),
                binding::buffer_entry(5, storage_write, vec4, compute),
                binding::buffer_entry(6, storage_write, vec4, compute),
            ],
        });
        let compute_module =
            shader::create_module(device, "stratus compute", &compute_shader_source());
        let compute_layout_full = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stratus compute"),
            bind_group_layouts: &[
                Some(frame.frame),
                Some(&compute_layout),
                Some(frame.atmosphere),
            ],
            immediate_size: 0,
        });
        let compute_pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&compute_layout_full),
                module: &compute_module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let thickness_pipeline = compute_pipeline("thickness_field");
        let inputs_pipeline = compute_pipeline("radiosity_inputs");

        let layer_module = shader::create_module(device, "stratus layer", &layer_shader_source());
        let layer_layout = frame.pipeline_layout(device, "stratus layer", None);
        // Blended over what is behind it, depth-tested but not written.
        let draw_pipeline = |label, vertex_entry, fragment_entry, write| {
            DrawPipeline {
                label,
                layout: &layer_layout,
                module: &layer_module,
                vertex_entry,
                fragment_entry: Some(fragment_entry),
                vertex_buffers: &[],
                cull_mode: None,
                depth: Some(depth_state(write, wgpu::CompareFunction::Greater)),
                targets: &hdr_target(Some(PREMULTIPLIED_OVER)),
            }
            .create(device)
        };
        let layer_pipeline =
            draw_pipeline("stratus layer", "layer_vertex", "layer_fragment", false);
        // The camera level with the layer: a full-screen triangle whose
        // fragments march to the layer and write the entry's depth (or not,
        // while the in-layer march fades in).
        let level_pipeline = draw_pipeline(
            "stratus layer (level)",
            "fullscreen_vertex",
            "level_fragment",
            true,
        );
        let level_blend_pipeline = draw_pipeline(
            "stratus layer (level, blended)",
            "fullscreen_vertex",
            "level_fragment",
            false,
        );
        // The camera in the layer: a full-screen march over everything,
        // reading the depth (no depth attachment).
        let in_layer_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stratus in-layer"),
            entries: &[crate::core::binding::depth_texture_entry(
                0,
                wgpu::TextureViewDimension::D2,
                wgpu::ShaderStages::FRAGMENT,
            )],
        });
        let in_layer_module =
            shader::create_module(device, "stratus in-layer", &in_layer_shader_source());
        let in_layer_pipeline_layout =
            frame.pipeline_layout(device, "stratus in-layer", Some(&in_layer_layout));
        let in_layer_pipeline = DrawPipeline {
            label: "stratus in-layer",
            layout: &in_layer_pipeline_layout,
            module: &in_layer_module,
            vertex_entry: "fullscreen_vertex",
            fragment_entry: Some("in_layer_fragment"),
            vertex_buffers: &[],
            cull_mode: None,
            depth: None,
            targets: &hdr_target(Some(PREMULTIPLIED_OVER)),
        }
        .create(device);
        Self {
            uniform: cloud_lighting.layer_uniform_buffer().clone(),
            compute_layout,
            thickness_pipeline,
            inputs_pipeline,
            layer_pipeline,
            level_pipeline,
            level_blend_pipeline,
            in_layer_pipeline,
            in_layer_layout,
            in_layer_groups: Default::default(),
            device: device.clone(),
            resources: None,
            settings: None,
            current: StratusUniform::default(),
            camera_height_m: 0.0,
            in_layer_weight: 0.0,
            optics_tables: Deferred::new("stratus optics"),
        }
    }
}
