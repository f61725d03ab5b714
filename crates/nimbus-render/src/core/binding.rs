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

/// A layout entry for a buffer of `size` bytes (its `min_binding_size`).
pub fn buffer_entry(
    binding: u32,
    ty: wgpu::BufferBindingType,
    size: u64,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size),
        },
        count: None,
    }
}

/// A layout entry for a uniform buffer of `size` bytes.
pub fn uniform_layout_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    size: u64,
) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, wgpu::BufferBindingType::Uniform, size, visibility)
}

/// A layout entry for a depth texture (`texture_depth_2d` and the like).
pub fn depth_texture_entry(
    binding: u32,
    dimension: wgpu::TextureViewDimension,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: dimension,
            multisampled: false,
        },
        count: None,
    }
}

/// A layout entry for a float texture of any dimension.
pub fn texture_entry(
    binding: u32,
    dimension: wgpu::TextureViewDimension,
    filterable: bool,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: dimension,
            multisampled: false,
        },
        count: None,
    }
}

/// A layout entry for a 2D float texture read by fragment shaders.
pub fn texture_2d_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    texture_entry(
        binding,
        wgpu::TextureViewDimension::D2,
        filterable,
        wgpu::ShaderStages::FRAGMENT,
    )
}

/// A layout entry for a write-only `Rgba16Float` storage texture of compute shaders.
pub fn storage_texture_entry(
    binding: u32,
    dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::Rgba16Float,
            view_dimension: dimension,
        },
        count: None,
    }
}

/// A layout entry for a filtering sampler.
pub fn sampler_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// A layout entry for a filtering sampler used by fragment shaders.
pub fn filtering_sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    sampler_entry(binding, wgpu::ShaderStages::FRAGMENT)
}

/// A bind group whose entries are `resources` at bindings 0, 1, 2, … in order.
pub fn sequential_bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: Vec<wgpu::BindingResource<'_>>,
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
        .into_iter()
        .enumerate()
        .map(|(i, resource)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource,
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// Bind groups that bind a texture view handed in at encode time (the
/// caller's depth buffer), made the first time a view is seen and kept while
/// the same view comes back, instead of made and dropped every frame. Holds
/// one view's groups: a new view replaces them. Owned by whatever owns the
/// groups' other resources, so that it goes with them.
#[derive(Debug)]
pub struct PerViewGroups<T> {
    cached: std::sync::Mutex<Option<(wgpu::TextureView, T)>>,
}

impl<T> Default for PerViewGroups<T> {
    fn default() -> Self {
        Self {
            cached: std::sync::Mutex::new(None),
        }
    }
}

impl<T: Clone> PerViewGroups<T> {
    /// The groups made for `view`: those kept when `view` is the one they
    /// were made for, else `make()`'s, kept for the next call.
    pub fn get(&self, view: &wgpu::TextureView, make: impl FnOnce() -> T) -> T {
        // A poisoned lock only means a panic elsewhere while it was held:
        // the cache is then remade.
        let mut cached = self
            .cached
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        match &*cached {
            Some((kept, groups)) if kept == view => groups.clone(),
            _ => {
                let groups = make();
                *cached = Some((view.clone(), groups.clone()));
                groups
            }
        }
    }
}

/// Maps a `MAP_READ` buffer after its copies were submitted, waits for the
/// device, and returns its bytes (the buffer is unmapped again). An error
/// (e.g. the device was lost) is wgpu's message; callers on a device with
/// [`super::fault::DeviceFaults`] report the recorded fault instead.
pub fn read_mapped(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<Vec<u8>, String> {
    if buffer.size() == 0 {
        // wgpu 29 cannot map an empty range (its buffer slices are never
        // empty: it panics); there is nothing to read, but the wait still
        // reports a device lost meanwhile.
        super::fault::wait_for_device(device)?;
        return Ok(Vec::new());
    }
    let (sender, receiver) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = sender.send(r);
    });
    super::fault::wait_for_device(device)?;
    receiver
        .recv()
        .map_err(|e| e.to_string())?
        .map_err(|e| e.to_string())?;
    let bytes = buffer.get_mapped_range(..).to_vec();
    buffer.unmap();
    Ok(bytes)
}
