//! Shared by the tests that run a WGSL function on the GPU against its CPU
//! twin: a compute kernel reading an array at group 0, binding 1 and
//! writing one at binding 2 (binding 0 of group 0 is the frame uniform the
//! drawing libraries declare), with the pass's own groups bound beside.

use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::shader;
use wgpu::util::DeviceExt;

/// A bind group the kernel needs besides its inputs and outputs.
pub struct ExtraGroup<'a> {
    /// Group index.
    pub index: u32,
    /// Its layout.
    pub layout: &'a wgpu::BindGroupLayout,
    /// The group.
    pub group: &'a wgpu::BindGroup,
}

/// A kernel and its work.
pub struct Kernel<'a> {
    /// Label of the GPU objects.
    pub label: &'a str,
    /// Composed WGSL.
    pub source: &'a str,
    /// Entry point (64 invocations per workgroup, one per item).
    pub entry: &'a str,
    /// The items, bound at binding 1.
    pub input: &'a [u8],
    /// Bytes per item.
    pub input_stride: u64,
    /// Number of items.
    pub count: usize,
    /// Output elements per item, at binding 2.
    pub outputs_per_item: usize,
    /// Further groups.
    pub extra: &'a [ExtraGroup<'a>],
}

/// Runs the kernel and reads back `count × outputs_per_item` elements of
/// type `T` from binding 2.
pub fn run_kernel<T: bytemuck::Pod>(h: &HeadlessRenderer, kernel: &Kernel<'_>) -> Vec<T> {
    let Kernel {
        label,
        source,
        entry,
        input,
        input_stride,
        count,
        outputs_per_item,
        extra,
    } = *kernel;
    let device = &h.gpu.device;
    let module = shader::create_module(device, label, source);
    let storage = |binding, read_only, size| {
        nimbus_render::binding::buffer_entry(
            binding,
            wgpu::BufferBindingType::Storage { read_only },
            size,
            wgpu::ShaderStages::COMPUTE,
        )
    };
    let element = std::mem::size_of::<T>() as u64;
    let io_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &[storage(1, true, input_stride), storage(2, false, element)],
    });
    let top = extra.iter().map(|g| g.index).max().unwrap_or(0) as usize;
    let mut layouts: Vec<Option<&wgpu::BindGroupLayout>> = vec![None; top + 1];
    layouts[0] = Some(&io_layout);
    for g in extra {
        layouts[g.index as usize] = Some(g.layout);
    }
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    });
    let input_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: input,
        usage: wgpu::BufferUsages::STORAGE,
    });
    let outputs = count * outputs_per_item;
    let output_buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: outputs as u64 * element,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let io = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &io_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 1,
                resource: input_buffer.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: output_buffer.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &io, &[]);
        for g in extra {
            pass.set_bind_group(g.index, g.group, &[]);
        }
        pass.dispatch_workgroups(count.div_ceil(64) as u32, 1, 1);
    }
    h.gpu.queue.submit([encoder.finish()]);
    h.read_buffer_elements(&output_buffer, outputs)
        .expect("read the kernel's output")
}
