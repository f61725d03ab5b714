//! Bind-group helpers shared by the passes: a uniform buffer of one `Pod`
//! type with its bind group (the layout's `min_binding_size` is the type's
//! size, so wgpu checks it against the shader's struct at pipeline
//! creation), and the layout entries the passes use.

use bytemuck::Pod;
use std::marker::PhantomData;

/// A uniform buffer holding one `T`, bound at binding 0 of its own group.
#[derive(Debug)]
pub struct UniformBinding<T> {
    /// The buffer.
    pub buffer: wgpu::Buffer,
    /// The group layout.
    pub layout: wgpu::BindGroupLayout,
    /// The bind group.
    pub bind_group: wgpu::BindGroup,
    _marker: PhantomData<T>,
}

impl<T: Pod> UniformBinding<T> {
    /// Creates the buffer, layout and group.
    pub fn new(device: &wgpu::Device, label: &str, visibility: wgpu::ShaderStages) -> Self {
        let size = std::mem::size_of::<T>() as u64;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &[uniform_layout_entry(0, visibility, size)],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: buffer.as_entire_binding(),
            }],
        });
        Self {
            buffer,
            layout,
            bind_group,
            _marker: PhantomData,
        }
    }

    /// Uploads a value.
    pub fn write(&self, queue: &wgpu::Queue, value: &T) {
        queue.write_buffer(&self.buffer, 0, bytemuck::bytes_of(value));
    }
}

/// A layout entry for a uniform buffer of `size` bytes.
pub fn uniform_layout_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    size: u64,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size),
        },
        count: None,
    }
}

/// A layout entry for a 2D float texture read by fragment shaders.
pub fn texture_2d_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A layout entry for a filtering sampler used by fragment shaders.
pub fn filtering_sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}
