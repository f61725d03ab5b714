//! The clouds' lighting, read by every pass that draws what the clouds
//! light or shade (terrain, objects, the stratus layer, the cumulus bodies,
//! the rain): bind group 3 of the drawing passes.
//!
//! | binding | what | written by | WGSL |
//! |---|---|---|---|
//! | 0 | the cloud shadow map's uniform | cumulus pass | `shader/cloud_shadow_uniform.wgsl` |
//! | 1 | the cloud shadow map (nearest and farthest core depth) | cumulus pass | `shader/cloud_shadow_lookup.wgsl` |
//! | 2 | the stratus layer's uniform ([`StratusUniform`]) | stratus pass (prepare) | `shader/cloud_layer_lookup.wgsl` |
//! | 3 | the layer's thickness window (R32Float, m) | stratus pass (compute) | idem |
//! | 4 | the layer's phase tables P_S, P², P_F; then the shape A of the reflected orders 3+ | stratus pass (when the droplets change); A once, here | idem |
//! | 5 | R_G, the radiosity received by the ground | radiosity iterations | idem |
//! | 6 | R_C, the radiosity received by the cloud base | radiosity iterations | idem |
//! | 7 | the terrain's shadow ceiling over its square (R32Float, m: [`nimbus_physics::terrain::sun_shadow_ceiling_m`]) | renderer, when the terrain or the sun changed | `shader/terrain_shadow_lookup.wgsl` |
//! | 8 | its uniform ([`TerrainShadowUniform`]) | idem | idem |
//!
//! The shadow map comes first for a measured reason: with it after the
//! layer's bindings (at 8 and 9), lavapipe (Mesa 22.3) drew the stratus layer
//! 13–15 % slower in scenes without cumulus, where the map is never read,
//! from the same WGSL but for the binding numbers; in front of them the
//! times are those of the map in a group of its own (docs/PERFORMANCE.md).
//!
//! [`CloudLighting`] owns the layout, the bind group, the uniform, the phase
//! tables and the [`CloudShadowMap`]; the thickness window and the radiosity
//! fields are sized by the layer and handed in by the stratus pass
//! ([`CloudLighting::set_layer`]). Without a layer the group holds small
//! placeholders and a uniform that says "no layer", so the group always
//! exists and no pass depends on another to draw.

use crate::core::binding;
use crate::frame::cloud_shadow::CloudShadowMap;
use crate::scene::StratusSettings;
use bytemuck::{Pod, Zeroable};
use nimbus_physics::optics::dsd::SizeDistribution;
use nimbus_physics::optics::tables::{CloudOpticsParams, CloudOpticsTables};
use nimbus_physics::terrain::SHADOW_CEILING_TEXELS;
use nimbus_physics::transport::{interior_source, reflected_exit, sky_source};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};
use wgpu::util::DeviceExt;

/// Half-angle θ_f of the forward peak, degrees (Bouthors 2006, §4.1).
pub const FORWARD_PEAK_DEG: f64 = 5.0;

/// Where the optical tables are cached (see [`crate::core::cache::cache_dir`]).
pub fn optics_cache_dir() -> PathBuf {
    crate::core::cache::cache_dir()
}

/// The optical-table parameters of a layer's droplets.
pub fn optics_params(settings: &StratusSettings) -> CloudOpticsParams {
    CloudOpticsParams {
        dsd: SizeDistribution::ModifiedGamma {
            number_density_per_m3: settings.droplet_concentration_cm3 * 1e6,
            gamma: 2.0,
            effective_radius_m: settings.effective_radius_um * 1e-6,
        },
        forward_peak_deg: FORWARD_PEAK_DEG,
        texels: PHASE_TEXELS,
        peak_texels: PEAK_TEXELS,
        tolerance: 1e-3,
    }
}

/// A layer's optical tables: from this process's memory, else loaded from
/// the disk cache, else computed (and cached; a cache that cannot be
/// written only costs the computation). One computation at a time per
/// process: the stratus layer's and the cumulus forward peak's workers,
/// asking for the same droplets at once, compute them once.
pub fn load_optics(params: &CloudOpticsParams) -> Arc<CloudOpticsTables> {
    type Memory = Mutex<HashMap<u64, Arc<CloudOpticsTables>>>;
    static MEMORY: OnceLock<Memory> = OnceLock::new();
    let mut memory = MEMORY
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    let key = params.cache_hash();
    if let Some(tables) = memory.get(&key).filter(|t| t.params == *params) {
        return tables.clone();
    }
    let tables = Arc::new(
        CloudOpticsTables::load_or_compute(&optics_cache_dir(), params)
            .unwrap_or_else(|_| CloudOpticsTables::compute(params)),
    );
    memory.insert(key, tables.clone());
    tables
}

/// Texels of the P_S and P² tables over 0–180°.
pub const PHASE_TEXELS: usize = 1024;
/// Texels of the P_F table over 0–θ_f.
pub const PEAK_TEXELS: usize = 256;
/// GPU layout of WGSL `Stratus` (`shader/cloud_layer_field.wgsl`); see it for each field.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct StratusUniform {
    /// 1/feature size (1/m), edge threshold n_c, ramp width, thickest cells (m).
    pub shape: [f32; 4],
    /// Wind drift (x, z) m ([`crate::scene::Scene::cloud_drift_m`]), 1/evolution time (1/s), time (s).
    pub motion: [f32; 4],
    /// Mid-plane height (m), window side (m), window min corner (x, z) (m).
    pub window: [f32; 4],
    /// Extinction κ per channel (1/m), forward-peak half-angle θ_f (rad).
    pub extinction: [f32; 4],
    /// Forward-peak weight P_f per channel.
    pub forward_fraction: [f32; 4],
    /// Mean square angle of P_F per channel, rad².
    pub forward_spread: [f32; 4],
    /// 1-D model at the sun's zenith: b, c (1/m), κ_c (1/m), t.
    pub slab: [f32; 4],
    /// 1-D model: r, β.
    pub slab_r_beta: [f32; 4],
    /// Radiosity grid min corner (x, z) (m), texel size (m), mean ground height (m).
    pub radiosity: [f32; 4],
    /// Layer present (0/1), octaves, seed, thickness-window texels per side.
    pub flags: [u32; 4],
    /// P_S/P² texels, P_F texels, radiosity texels per side, unused.
    pub sizes: [u32; 4],
    /// View and sun paths marched through the field (1, `stratus.model =
    /// "marched"` or `"volume"`) or the paper's slab (0, `"bnl2006"`); the
    /// layer drawn as a volume (1, `"volume"`: the light under it leaves
    /// the deck uniformly, as the marched deck is seen from below); two
    /// unused.
    pub model: [u32; 4],
}

/// GPU layout of WGSL `TerrainShadow` (`shader/terrain_shadow_lookup.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TerrainShadowUniform {
    /// Half the side of the terrain's square (centred on the origin), m;
    /// 1 when the ceiling map holds a relief, 0 without one (every point
    /// sees the sun over the ground); the half-width of the shadow's edge
    /// in height, m; unused.
    pub square: [f32; 4],
}

/// Half-width in height of the terrain shadow's edge in the air, m: the
/// solar disk's angular radius (4.65 mrad) at the ~5 km of a ridge from the
/// clouds it shades, about one ceiling texel's rise under a low sun.
pub const TERRAIN_SHADOW_EDGE_M: f32 = 25.0;

/// The layer-sized resources of group 3, owned by the stratus pass.
#[derive(Clone, Copy, Debug)]
pub struct CloudLayerResources<'a> {
    /// The thickness window (R32Float, m; binding 1).
    pub thickness: &'a wgpu::TextureView,
    /// R_G, one `vec4<f32>` per radiosity texel (binding 3).
    pub ground_received: &'a wgpu::Buffer,
    /// R_C, one `vec4<f32>` per radiosity texel (binding 4).
    pub cloud_received: &'a wgpu::Buffer,
}

/// Placeholders bound while there is no layer: a 1×1 thickness of 0 and
/// one radiosity texel.
#[derive(Debug)]
struct Placeholders {
    thickness: wgpu::TextureView,
    ground_received: wgpu::Buffer,
    cloud_received: wgpu::Buffer,
}

/// Group 3 of the drawing passes: the stratus layer's lighting and the
/// cloud shadow map (see the module's table).
#[derive(Debug)]
pub struct CloudLighting {
    uniform: wgpu::Buffer,
    phase_tables: wgpu::Buffer,
    shadow: CloudShadowMap,
    terrain_ceiling: wgpu::Texture,
    terrain_ceiling_view: wgpu::TextureView,
    terrain_uniform: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    placeholders: Placeholders,
    bind_group: wgpu::BindGroup,
}

/// Binding of the layer's uniform; the layer's resources follow it in the
/// table's order (the shadow map holds 0 and 1).
const LAYER_FIRST_BINDING: u32 = 2;

/// Bytes of one `vec4<f32>`.
const VEC4_BYTES: u64 = 16;

impl CloudLighting {
    /// Values in the phase-table buffer: P_S and P² over 0–180°
    /// ([`PHASE_TEXELS`] each), then P_F over 0–θ_f ([`PEAK_TEXELS`]).
    pub const PHASE_TABLE_TEXELS: usize = 2 * PHASE_TEXELS + PEAK_TEXELS;

    /// Values after the phase tables: the shape A(θ_l, θ_v, φ) of the
    /// reflected orders 3+ (`nimbus_physics::transport::reflected_exit`,
    /// the same for every layer; written once at creation).
    pub const REFLECTED_SHAPE_TEXELS: usize = reflected_exit::TABLE_VALUES;

    /// Values after the reflected shape: the sun's scattered light inside
    /// a layer near its lit face (`nimbus_physics::transport::
    /// interior_source`, the same for every layer; written once at
    /// creation).
    pub const INTERIOR_SOURCE_TEXELS: usize = interior_source::TABLE_VALUES;

    /// Values after the sun's interior source: the sky's scattered light
    /// inside a layer near its top, per band of the sky's zenith angles
    /// (`nimbus_physics::transport::sky_source`, the same for every layer;
    /// written once at creation).
    pub const SKY_SOURCE_TEXELS: usize = sky_source::TABLE_VALUES;

    /// Creates the group with no layer and an empty shadow map.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let uniform_size = std::mem::size_of::<StratusUniform>() as u64;
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stratus uniform"),
            size: uniform_size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let phase_tables = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stratus phase tables"),
            size: (Self::PHASE_TABLE_TEXELS
                + Self::REFLECTED_SHAPE_TEXELS
                + Self::INTERIOR_SOURCE_TEXELS
                + Self::SKY_SOURCE_TEXELS) as u64
                * VEC4_BYTES,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // The tables shared by every layer, one value per texel (grey),
        // after the per-layer phase tables, in the order the lookups
        // (cloud_layer_lookup.wgsl) find them.
        let mut offset_texels = Self::PHASE_TABLE_TEXELS;
        for table in [
            &reflected_exit::REFLECTED_SHAPE[..],
            &interior_source::INTERIOR_SOURCE[..],
            &sky_source::SKY_SOURCE[..],
        ] {
            let grey: Vec<[f32; 4]> = table.iter().map(|&v| [v, v, v, 0.0]).collect();
            queue.write_buffer(
                &phase_tables,
                offset_texels as u64 * VEC4_BYTES,
                bytemuck::cast_slice(&grey),
            );
            offset_texels += table.len();
        }
        let shadow = CloudShadowMap::new(device, queue);
        let side = SHADOW_CEILING_TEXELS as u32;
        let terrain_ceiling = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("terrain shadow ceiling"),
            size: wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let terrain_ceiling_view = terrain_ceiling.create_view(&Default::default());
        let terrain_uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("terrain shadow uniform"),
            contents: bytemuck::bytes_of(&TerrainShadowUniform::default()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let draw = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let compute = wgpu::ShaderStages::COMPUTE;
        let storage_read = wgpu::BufferBindingType::Storage { read_only: true };
        let [shadow_uniform, shadow_map] = CloudShadowMap::layout_entries(draw);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cloud lighting"),
            entries: &[
                // The layer's shape is also for compute passes (and the
                // tests' kernels) that need to know where the cloud is.
                binding::uniform_layout_entry(2, draw | compute, uniform_size),
                binding::texture_entry(3, wgpu::TextureViewDimension::D2, false, draw | compute),
                binding::buffer_entry(4, storage_read, VEC4_BYTES, draw | compute),
                binding::buffer_entry(5, storage_read, VEC4_BYTES, wgpu::ShaderStages::FRAGMENT),
                binding::buffer_entry(6, storage_read, VEC4_BYTES, wgpu::ShaderStages::FRAGMENT),
                shadow_uniform,
                shadow_map,
                // Also for compute: the tests' kernels read the terrain's
                // shadow against its CPU reference.
                binding::texture_entry(7, wgpu::TextureViewDimension::D2, false, draw | compute),
                binding::uniform_layout_entry(
                    8,
                    draw | compute,
                    std::mem::size_of::<TerrainShadowUniform>() as u64,
                ),
            ],
        });
        let radiosity_texel = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: VEC4_BYTES,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: true,
            })
        };
        let placeholders = Placeholders {
            thickness: crate::core::targets::zero_texel(
                device,
                "no stratus thickness",
                wgpu::TextureDimension::D2,
                wgpu::TextureFormat::R32Float,
            ),
            ground_received: radiosity_texel("no radiosity (ground)"),
            cloud_received: radiosity_texel("no radiosity (cloud)"),
        };
        // Mapped at creation: zero-filled, then unmapped for the GPU.
        placeholders.ground_received.unmap();
        placeholders.cloud_received.unmap();
        let bind_group = Self::make_group(
            device,
            &layout,
            &uniform,
            &phase_tables,
            &shadow,
            (&terrain_ceiling_view, &terrain_uniform),
            CloudLayerResources {
                thickness: &placeholders.thickness,
                ground_received: &placeholders.ground_received,
                cloud_received: &placeholders.cloud_received,
            },
        );
        let lighting = Self {
            uniform,
            phase_tables,
            shadow,
            terrain_ceiling,
            terrain_ceiling_view,
            terrain_uniform,
            layout,
            placeholders,
            bind_group,
        };
        lighting.write_layer_uniform(queue, &StratusUniform::default());
        lighting
    }

    fn make_group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        uniform: &wgpu::Buffer,
        phase_tables: &wgpu::Buffer,
        shadow: &CloudShadowMap,
        (terrain_ceiling, terrain_uniform): (&wgpu::TextureView, &wgpu::Buffer),
        layer: CloudLayerResources<'_>,
    ) -> wgpu::BindGroup {
        let [shadow_uniform, shadow_map] = shadow.bind_group_entries();
        let layer_entries = [
            uniform.as_entire_binding(),
            wgpu::BindingResource::TextureView(layer.thickness),
            phase_tables.as_entire_binding(),
            layer.ground_received.as_entire_binding(),
            layer.cloud_received.as_entire_binding(),
        ];
        let entries: Vec<wgpu::BindGroupEntry<'_>> = layer_entries
            .into_iter()
            .enumerate()
            .map(|(binding, resource)| wgpu::BindGroupEntry {
                binding: LAYER_FIRST_BINDING + binding as u32,
                resource,
            })
            .chain([shadow_uniform, shadow_map])
            .chain([
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: wgpu::BindingResource::TextureView(terrain_ceiling),
                },
                wgpu::BindGroupEntry {
                    binding: 8,
                    resource: terrain_uniform.as_entire_binding(),
                },
            ])
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cloud lighting"),
            layout,
            entries: &entries,
        })
    }

    /// Binds the layer's thickness window and radiosity fields (when the
    /// stratus pass rebuilt them), or the placeholders for `None` (no layer).
    pub fn set_layer(&mut self, device: &wgpu::Device, layer: Option<CloudLayerResources<'_>>) {
        let placeholders = CloudLayerResources {
            thickness: &self.placeholders.thickness,
            ground_received: &self.placeholders.ground_received,
            cloud_received: &self.placeholders.cloud_received,
        };
        self.bind_group = Self::make_group(
            device,
            &self.layout,
            &self.uniform,
            &self.phase_tables,
            &self.shadow,
            (&self.terrain_ceiling_view, &self.terrain_uniform),
            layer.unwrap_or(placeholders),
        );
    }

    /// Writes the terrain's shadow ceiling (bindings 7 and 8): the
    /// [`SHADOW_CEILING_TEXELS`]² heights of
    /// [`nimbus_physics::terrain::sun_shadow_ceiling_m`] over a square of
    /// half side `half_extent_m` centred on the origin. Until the first
    /// write nothing shades the air.
    pub fn write_terrain_shadow(&self, queue: &wgpu::Queue, ceiling: &[f32], half_extent_m: f64) {
        let side = SHADOW_CEILING_TEXELS as u32;
        debug_assert_eq!(ceiling.len(), SHADOW_CEILING_TEXELS * SHADOW_CEILING_TEXELS);
        if ceiling.len() != SHADOW_CEILING_TEXELS * SHADOW_CEILING_TEXELS {
            return;
        }
        queue.write_texture(
            self.terrain_ceiling.as_image_copy(),
            bytemuck::cast_slice(ceiling),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * side),
                rows_per_image: Some(side),
            },
            wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: 1,
            },
        );
        let uniform = TerrainShadowUniform {
            square: [half_extent_m as f32, 1.0, TERRAIN_SHADOW_EDGE_M, 0.0],
        };
        queue.write_buffer(&self.terrain_uniform, 0, bytemuck::bytes_of(&uniform));
    }

    /// Writes the layer's uniform (binding 0).
    pub fn write_layer_uniform(&self, queue: &wgpu::Queue, value: &StratusUniform) {
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(value));
    }

    /// Writes the phase tables (binding 2): [`Self::PHASE_TABLE_TEXELS`]
    /// values of RGB and an unused lane.
    pub fn write_phase_tables(&self, queue: &wgpu::Queue, texels: &[[f32; 4]]) {
        debug_assert_eq!(texels.len(), Self::PHASE_TABLE_TEXELS);
        let count = texels.len().min(Self::PHASE_TABLE_TEXELS);
        queue.write_buffer(
            &self.phase_tables,
            0,
            bytemuck::cast_slice(&texels[..count]),
        );
    }

    /// The layer's uniform buffer (for the stratus pass's compute group).
    pub fn layer_uniform_buffer(&self) -> &wgpu::Buffer {
        &self.uniform
    }

    /// The cloud shadow map (bindings 0 and 1), drawn by the cumulus pass.
    pub fn shadow(&self) -> &CloudShadowMap {
        &self.shadow
    }

    /// Layout of group 3.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// Group 3.
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }
}
