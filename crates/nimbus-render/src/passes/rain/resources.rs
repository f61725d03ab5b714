//! The rain pass's pipelines and bind-group layouts, created once.

use super::depth_occluder::DepthOccluderDraw;
use super::gpu_types::{RainSegmentUniform, RainStepUniform, RainUniform};
use super::{
    DROP_BYTES, FramePlan, OCCLUSION_MAP_SIZE, RainPass, SPLASH_BYTES, STEP_STRIDE,
    mist_shader_source, occluders_shader_source, simulation_shader_source, streaks_shader_source,
    visibility_shader_source,
};
use crate::core::background::Deferred;
use crate::core::binding;
use crate::core::binding::{buffer_entry, uniform_layout_entry};
use crate::core::pipeline::{DrawPipeline, PREMULTIPLIED_OVER, depth_state, hdr_target};
use crate::frame::FrameLayouts;
use nimbus_physics::rain::drop_optics::DropTransfer;
use nimbus_physics::rain::simulation::MAX_STEPS_PER_FRAME;
use nimbus_physics::rain::zones::RainZones;
use wgpu::util::DeviceExt;

pub(super) fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    source: String,
    entry: &str,
    layouts: &[Option<&wgpu::BindGroupLayout>],
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

#[allow(clippy::too_many_arguments)]
pub(super) fn draw_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    vertex: &str,
    fragment: &str,
    layout: &wgpu::PipelineLayout,
    blend: wgpu::BlendState,
    depth: bool,
) -> wgpu::RenderPipeline {
    DrawPipeline {
        label,
        layout,
        module,
        vertex_entry: vertex,
        fragment_entry: Some(fragment),
        vertex_buffers: &[],
        cull_mode: None,
        depth: depth.then(|| depth_state(false, wgpu::CompareFunction::Greater)),
        targets: &hdr_target(Some(blend)),
    }
    .create(device)
}

impl RainPass {
    /// Creates the pipelines; buffers are made by [`Self::prepare`] when a scene has rain.
    pub fn new(device: &wgpu::Device, frame: &FrameLayouts<'_>) -> Self {
        use wgpu::BufferBindingType::{Storage, Uniform};
        let compute = wgpu::ShaderStages::COMPUTE;
        let draw = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let uniform_size = std::mem::size_of::<RainUniform>() as u64;
        let step_size = std::mem::size_of::<RainStepUniform>() as u64;
        let segment_size = std::mem::size_of::<RainSegmentUniform>() as u64;
        let read = Storage { read_only: true };
        let write = Storage { read_only: false };
        let depth_texture = |binding: u32, visibility: wgpu::ShaderStages| {
            binding::depth_texture_entry(binding, wgpu::TextureViewDimension::D2, visibility)
        };
        let simulation_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("rain simulation"),
            entries: &[
                uniform_layout_entry(0, compute, uniform_size),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: compute,
                    ty: wgpu::BindingType::Buffer {
                        ty: Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: wgpu::BufferSize::new(step_size),
                    },
                    count: None,
                },
                buffer_entry(2, write, DROP_BYTES, compute),
                buffer_entry(3, read, 16, compute),
                buffer_entry(4, read, 4, compute),
                depth_texture(5, compute),
                buffer_entry(6, write, SPLASH_BYTES, compute),
                buffer_entry(7, write, 4, compute),
                uniform_layout_entry(8, compute, segment_size),
                buffer_entry(9, write, 4, compute),
            ],
        });
        let visibility_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("rain visibility"),
            entries: &[
                uniform_layout_entry(0, compute, uniform_size),
                buffer_entry(1, read, DROP_BYTES, compute),
                buffer_entry(2, write, 4, compute),
                buffer_entry(3, write, 16, compute),
                uniform_layout_entry(4, compute, segment_size),
                buffer_entry(5, write, 4, compute),
                buffer_entry(6, write, 4, compute),
            ],
        });
        let draw_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("rain draw"),
            entries: &[
                uniform_layout_entry(0, draw, uniform_size),
                buffer_entry(1, read, DROP_BYTES, wgpu::ShaderStages::VERTEX),
                buffer_entry(2, read, 4, wgpu::ShaderStages::VERTEX),
                buffer_entry(3, read, SPLASH_BYTES, wgpu::ShaderStages::VERTEX),
                depth_texture(4, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let mist_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("rain mist"),
            entries: &[
                uniform_layout_entry(0, draw, uniform_size),
                depth_texture(2, wgpu::ShaderStages::FRAGMENT),
                // The zone map at the simulation's binding (passes/rain/zones.wgsl),
                // also read by the vertex shader (the column's sun, mist.wgsl).
                buffer_entry(4, read, 4, draw),
                // The mist slab's light (passes/rain/mist_slab.wgsl).
                buffer_entry(5, read, 4, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let simulation = |entry: &str| {
            compute_pipeline(
                device,
                "rain simulation",
                simulation_shader_source(),
                entry,
                &[Some(frame.frame), Some(&simulation_layout)],
            )
        };
        let (simulate, place_splashes) = (simulation("simulate"), simulation("place_splashes"));
        let cull = ["mark", "scan", "scatter"].map(|entry| {
            compute_pipeline(
                device,
                "rain visibility",
                visibility_shader_source(),
                entry,
                &[Some(frame.frame), Some(&visibility_layout)],
            )
        });
        let streaks_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("rain streaks"),
            source: wgpu::ShaderSource::Wgsl(streaks_shader_source().into()),
        });
        let draw_pipeline_layout = frame.pipeline_layout(device, "rain draw", Some(&draw_layout));
        let streaks = draw_pipeline(
            device,
            "rain streaks",
            &streaks_module,
            "streak_vertex_main",
            "streak_fragment",
            &draw_pipeline_layout,
            PREMULTIPLIED_OVER,
            true,
        );
        let splash = draw_pipeline(
            device,
            "rain splashes",
            &streaks_module,
            "splash_vertex_main",
            "streak_fragment",
            &draw_pipeline_layout,
            PREMULTIPLIED_OVER,
            true,
        );
        let mist_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("rain mist"),
            source: wgpu::ShaderSource::Wgsl(mist_shader_source().into()),
        });
        let mist_pipeline_layout = frame.pipeline_layout(device, "rain mist", Some(&mist_layout));
        let mist = draw_pipeline(
            device,
            "rain mist",
            &mist_module,
            "mist_vertex",
            "mist_fragment",
            &mist_pipeline_layout,
            PREMULTIPLIED_OVER,
            false,
        );
        let occlusion_uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain shadow map view"),
            size: 64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let occlusion_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("rain shadow map view"),
            entries: &[uniform_layout_entry(0, wgpu::ShaderStages::VERTEX, 64)],
        });
        let occlusion_group = binding::sequential_bind_group(
            device,
            "rain shadow map view",
            &occlusion_layout,
            vec![occlusion_uniform.as_entire_binding()],
        );
        let occluders_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("rain shadow map"),
            source: wgpu::ShaderSource::Wgsl(occluders_shader_source().into()),
        });
        let occluders_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("rain shadow map"),
            bind_group_layouts: &[Some(&occlusion_layout)],
            immediate_size: 0,
        });
        let occlusion_texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("rain shadow map"),
            size: wgpu::Extent3d {
                width: OCCLUSION_MAP_SIZE,
                height: OCCLUSION_MAP_SIZE,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Depth32Float,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let steps = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain steps"),
            size: STEP_STRIDE * MAX_STEPS_PER_FRAME as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain"),
            size: uniform_size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mist_slab = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rain mist slab"),
            contents: bytemuck::cast_slice(&nimbus_physics::rain::mist_slab::MIST_SLAB_TABLE),
            usage: wgpu::BufferUsages::STORAGE,
        });
        Self {
            device: device.clone(),
            uniform,
            mist_slab,
            steps,
            occlusion_uniform,
            occlusion_group,
            simulation_layout,
            visibility_layout,
            draw_layout,
            mist_layout,
            simulate,
            place_splashes,
            cull,
            streaks,
            splash,
            mist,
            occluders_module,
            occluders_layout,
            occluders: Vec::new(),
            depth_occluder: DepthOccluderDraw::new(device, &occlusion_layout),
            zones_job: Deferred::new("rain zones"),
            occlusion_texture,
            state: None,
            plan: FramePlan::default(),
            settings: None,
            drops_per_buffer_cap: None,
            drop: DropTransfer::water(),
        }
    }

    /// The rain shadow map's depth-only pipeline for vertices of `stride` bytes.
    pub(super) fn occluder_pipeline(
        &self,
        device: &wgpu::Device,
        stride: u64,
    ) -> wgpu::RenderPipeline {
        // Depth only: the nearest occluder seen from above (z grows downwards).
        DrawPipeline {
            label: "rain shadow map",
            layout: &self.occluders_layout,
            module: &self.occluders_module,
            vertex_entry: "occluder_vertex",
            fragment_entry: None,
            vertex_buffers: &[wgpu::VertexBufferLayout {
                array_stride: stride,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &crate::frame::occluders::POSITION_ATTRIBUTES,
            }],
            cull_mode: None,
            depth: Some(depth_state(true, wgpu::CompareFunction::Less)),
            targets: &[],
        }
        .create(device)
    }

    /// The caller's depth buffer of its world seen from above through
    /// `view` (`width` × `height` texels; the view of its depth aspect,
    /// `TEXTURE_BINDING` usage) drawn into the rain shadow map with the
    /// occluders' triangles, or none. The map is redrawn when the renderer's
    /// occluder generation changes.
    pub fn set_depth_occluder(
        &mut self,
        queue: &wgpu::Queue,
        depth: Option<(&wgpu::TextureView, &crate::frame::View, u32, u32)>,
    ) {
        self.depth_occluder.set(&self.device, queue, depth);
    }

    /// The work under way on a worker thread, if any.
    pub fn pending(&self) -> Option<&'static str> {
        self.zones_job.pending()
    }

    /// Blocks until the work under way has finished.
    pub fn wait(&mut self) {
        self.zones_job.wait();
    }

    /// Whether the current scene has rain.
    pub fn enabled(&self) -> bool {
        self.settings.is_some() && self.state.is_some()
    }

    /// Whether the current scene's rain has mist.
    pub fn mist_enabled(&self) -> bool {
        self.enabled() && self.settings.as_ref().is_some_and(|s| s.mist)
    }

    /// Drops simulated this frame (the dispatched count).
    pub fn dispatched_drops(&self) -> u32 {
        self.state.as_ref().map_or(0, |s| s.dispatched)
    }

    /// The map of rain zones in use (for tests and tools).
    pub fn zones(&self) -> Option<&RainZones> {
        self.state.as_ref().map(|s| &s.zone_map)
    }

    /// The steps the last [`Self::prepare`] planned (for tests replaying them on the CPU).
    pub fn planned_steps(&self) -> &[RainStepUniform] {
        &self.plan.steps
    }

    /// The drops' buffers in order of their ids, each with the number of
    /// drops it holds (for tests and tools that read the simulation back).
    pub fn drops_buffers(&self) -> Vec<(&wgpu::Buffer, u32)> {
        self.state.as_ref().map_or_else(Vec::new, |s| {
            s.drops
                .segments
                .iter()
                .map(|g| (&g.drops, g.capacity))
                .collect()
        })
    }

    /// Each drops' buffer's list of the drops in view (indices into the
    /// buffer's drops, in increasing order) with the byte offset of its
    /// indirect draw's arguments (vertex count, instance count = the list's
    /// length, …) in [`Self::draw_arguments`] (for tests and tools that read
    /// the lists back).
    pub fn visible_lists(&self) -> Vec<(&wgpu::Buffer, u64)> {
        self.state.as_ref().map_or_else(Vec::new, |s| {
            (s.drops.segments.iter().enumerate())
                .map(|(i, g)| (&g.visible, i as u64 * s.drops.draw_args_stride))
                .collect()
        })
    }

    /// The streaks' indirect draw arguments of every drops' buffer (see
    /// [`Self::visible_lists`]).
    pub fn draw_arguments(&self) -> Option<&wgpu::Buffer> {
        self.state.as_ref().map(|s| &s.drops.draw_args)
    }

    /// The splashes' ring ([`super::SPLASH_CAPACITY`] records of 8 floats: impact
    /// point and time, the drop's velocity and diameter) and its head (the
    /// splashes written since the rain started; the next is written at the
    /// head modulo the capacity), for tests and tools.
    pub fn splash_ring(&self) -> Option<(&wgpu::Buffer, &wgpu::Buffer)> {
        self.state
            .as_ref()
            .map(|s| (&s.shared.splashes, &s.shared.splash_head))
    }

    /// Caps the drops per buffer below what the device binds in one
    /// (`None`: the device's limit), so that a device's split of millions
    /// of drops can be exercised with a few thousand. Takes effect when the
    /// rain next starts anew.
    pub fn set_drops_per_buffer_cap(&mut self, cap: Option<u32>) {
        if self.drops_per_buffer_cap != cap {
            self.drops_per_buffer_cap = cap;
            self.state = None;
        }
    }
}
