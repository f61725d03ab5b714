//! The stratus pass's layouts and pipelines, created once.

#[allow(unused_imports)]
use super::*;

impl StratusPass {
    /// Creates the pipelines; resources are built by [`Self::prepare`].
    pub fn new(
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        atmosphere_layout: &wgpu::BindGroupLayout,
        cloud_shadow_layout: &wgpu::BindGroupLayout,
    ) -> Self {
        let uniform_size = std::mem::size_of::<StratusUniform>() as u64;
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stratus uniform"),
            size: uniform_size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let draw = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let compute = wgpu::ShaderStages::COMPUTE;
        let storage_read = wgpu::BufferBindingType::Storage { read_only: true };
        let storage_write = wgpu::BufferBindingType::Storage { read_only: false };
        let vec4 = 16;
        let lookup_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stratus lookup"),
            entries: &[
                // The layer's shape is also for compute passes (and the
                // tests' kernels) that need to know where the cloud is.
                binding::uniform_layout_entry(0, draw | compute, uniform_size),
                binding::texture_entry(1, wgpu::TextureViewDimension::D2, false, draw | compute),
                binding::buffer_entry(2, storage_read, vec4, draw),
                binding::buffer_entry(3, storage_read, vec4, wgpu::ShaderStages::FRAGMENT),
                binding::buffer_entry(4, storage_read, vec4, wgpu::ShaderStages::FRAGMENT),
            ],
        });
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
                Some(frame_layout),
                Some(&compute_layout),
                Some(atmosphere_layout),
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
        let layer_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stratus layer"),
            bind_group_layouts: &[
                Some(frame_layout),
                Some(cloud_shadow_layout),
                Some(atmosphere_layout),
                Some(&lookup_layout),
            ],
            immediate_size: 0,
        });
        let layer_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("stratus layer"),
            layout: Some(&layer_layout),
            vertex: wgpu::VertexState {
                module: &layer_module,
                entry_point: Some("layer_vertex"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &layer_module,
                entry_point: Some("layer_fragment"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    blend: Some(crate::core::pipeline::PREMULTIPLIED_OVER),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        Self {
            uniform,
            lookup_layout,
            compute_layout,
            thickness_pipeline,
            inputs_pipeline,
            layer_pipeline,
            resources: None,
            settings: None,
            current: StratusUniform::default(),
            camera_height_m: 0.0,
        }
    }
}
