//! The cloud shadow map: what the cumulus pass draws and every pass lit by
//! the sun reads (terrain, objects, the stratus layer, the cumulus bodies)
//! at group 3, bindings 0 and 1, beside the stratus layer's lighting
//! ([`crate::frame::cloud_lighting`]). WGSL: `shader/cloud_shadow_uniform.wgsl`,
//! `shader/cloud_shadow_lookup.wgsl`.

use crate::core::binding;
use crate::core::targets::DEPTH_FORMAT;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

/// Side of the cloud shadow map, texels.
pub const SHADOW_MAP_SIZE: u32 = 2048;
/// GPU layout of the shadow map's uniform (WGSL `CloudShadow`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CloudShadowUniform {
    /// Shadow clip space from world space (orthographic, z in [0, 1]).
    pub clip_from_world: [[f32; 4]; 4],
    /// Depth range (m), core extinction α_ρ (m⁻¹), asymmetry g, texels per side.
    pub params: [f32; 4],
    /// Map holds clouds (0/1), filter radius (texels), unused, unused.
    pub flags: [u32; 4],
}

/// The cloud shadow map: a two-layer depth texture (nearest and farthest
/// cloud core along the sun's light) and its uniform. Owned by the frame's
/// [`crate::frame::cloud_lighting::CloudLighting`]; the cumulus pass draws
/// it, the passes lit by the sun bind it at group 3, bindings 0 and 1.
#[derive(Debug)]
pub struct CloudShadowMap {
    texture: wgpu::Texture,
    array_view: wgpu::TextureView,
    layer_views: [wgpu::TextureView; 2],
    uniform: wgpu::Buffer,
    uniform_layout: wgpu::BindGroupLayout,
    uniform_group: wgpu::BindGroup,
}

impl CloudShadowMap {
    /// Creates the map (empty: no clouds, every lookup returns 1).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("cloud shadow map"),
            size: wgpu::Extent3d {
                width: SHADOW_MAP_SIZE,
                height: SHADOW_MAP_SIZE,
                depth_or_array_layers: 2,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let array_view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layer_view = |layer: u32| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        };
        let layer_views = [layer_view(0), layer_view(1)];
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cloud shadow uniform"),
            contents: bytemuck::bytes_of(&CloudShadowUniform::default()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let [uniform_entry, _] = Self::layout_entries(wgpu::ShaderStages::VERTEX_FRAGMENT);
        let uniform_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cloud shadow uniform"),
            entries: &[uniform_entry],
        });
        let [uniform_binding, _] = shadow_entries(&uniform, &array_view);
        let map = Self {
            uniform_group: device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cloud shadow uniform"),
                layout: &uniform_layout,
                entries: &[uniform_binding],
            }),
            texture,
            array_view,
            layer_views,
            uniform,
            uniform_layout,
        };
        map.write(queue, &CloudShadowUniform::default());
        map
    }

    /// Layout entries of the uniform (binding 0) and the map (binding 1).
    pub fn layout_entries(visibility: wgpu::ShaderStages) -> [wgpu::BindGroupLayoutEntry; 2] {
        [
            binding::uniform_layout_entry(
                0,
                visibility,
                std::mem::size_of::<CloudShadowUniform>() as u64,
            ),
            binding::depth_texture_entry(1, wgpu::TextureViewDimension::D2Array, visibility),
        ]
    }

    /// Bind group entries matching [`Self::layout_entries`].
    pub fn bind_group_entries(&self) -> [wgpu::BindGroupEntry<'_>; 2] {
        shadow_entries(&self.uniform, &self.array_view)
    }

    /// A group 3 holding only the uniform (binding 0), for the pass that
    /// draws the map: it cannot bind the map it renders into.
    pub fn uniform_layout(&self) -> &wgpu::BindGroupLayout {
        &self.uniform_layout
    }

    /// The group of [`Self::uniform_layout`].
    pub fn uniform_group(&self) -> &wgpu::BindGroup {
        &self.uniform_group
    }

    /// The depth texture (layer 0 nearest core, layer 1 farthest).
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// The depth view of one layer (0 nearest core, 1 farthest), for the
    /// pass that draws the map.
    pub fn layer_views(&self) -> &[wgpu::TextureView; 2] {
        &self.layer_views
    }

    /// Writes the map's uniform (the pass that draws the map does, each frame).
    pub fn write(&self, queue: &wgpu::Queue, value: &CloudShadowUniform) {
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(value));
    }
}

/// The shadow map's bind group entries: the uniform at 0, the map at 1.
fn shadow_entries<'a>(
    uniform: &'a wgpu::Buffer,
    map: &'a wgpu::TextureView,
) -> [wgpu::BindGroupEntry<'a>; 2] {
    [
        wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 1,
            resource: wgpu::BindingResource::TextureView(map),
        },
    ]
}
