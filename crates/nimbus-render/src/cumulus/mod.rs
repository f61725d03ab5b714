//! Cumulus pass: fields of cumulus clouds, each an instance of a few shape
//! variants ([`variants`], from [`nimbus_physics::cumulus`]), shaded by the
//! phenomenological shader of Bouthors (2004, ch. 5) after Neyret (2000)
//! (`shading.wgsl`, twin of [`nimbus_physics::cumulus::shading`]).
//!
//! Per frame:
//! 1. On the CPU, the clouds in the view frustum get a level of detail by
//!    their distance (a mesh cell of at most [`LOD_CELL_PX`] pixels); the
//!    instance buffer is grouped by variant and level.
//! 2. `cumulus_shadow`: the cores (τ ≥ 1 seen from the sun) of every cloud
//!    drawn into the [`CloudShadowMap`], an orthographic depth map along the
//!    sun's light: layer 0 the nearest core, layer 1 the farthest. Terrain,
//!    the stratus layer and the clouds read it (`shadow_lookup.wgsl`).
//! 3. `cumulus`: the opaque body (A ≥ 0.995), depth-tested against the
//!    terrain and depth-written.
//! 4. `cumulus_fringes`: the semi-transparent fringes into weighted blended
//!    order-independent transparency targets (McGuire & Bavoil 2013),
//!    depth-tested against the terrain and the bodies: no sorting, so no
//!    popping, between clouds or within one.
//! 5. After the stratus layer (which is depth-tested against the bodies),
//!    `cumulus_composite` blends the fringes over the frame.

pub mod variants;

use crate::binding;
use crate::frame::FrameUniform;
use crate::scene::{CumulusSettings, Scene};
use crate::shader::{self, WgslFile};
use crate::targets::{DEPTH_FORMAT, HDR_FORMAT};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Mat4, Vec3, Vec4};
use nimbus_physics::atmosphere::AtmosphereParams;
use nimbus_physics::cumulus::cloud_field::{CloudFieldParams, CloudInstance, place_clouds};
use nimbus_physics::cumulus::shading::{CLOUD_ASYMMETRY, LightTrapModel};
use std::ops::Range;
use std::sync::Arc;
use variants::{CumulusVariant, CumulusVertex, VariantParams};
use wgpu::util::DeviceExt;

/// The shader's terms (CPU twin: `nimbus_physics::cumulus::shading`).
pub const SHADING: WgslFile = WgslFile {
    name: "cumulus/shading.wgsl",
    source: include_str!("shading.wgsl"),
};
/// The shadow map's uniform (group 1, binding 8).
pub const SHADOW_UNIFORM: WgslFile = WgslFile {
    name: "cumulus/shadow_uniform.wgsl",
    source: include_str!("shadow_uniform.wgsl"),
};
/// The shadow map's lookup (group 1, binding 9).
pub const SHADOW_LOOKUP: WgslFile = WgslFile {
    name: "cumulus/shadow_lookup.wgsl",
    source: include_str!("shadow_lookup.wgsl"),
};
const CUMULUS_WGSL: WgslFile = WgslFile {
    name: "cumulus/cumulus.wgsl",
    source: include_str!("cumulus.wgsl"),
};
const DRAW_WGSL: WgslFile = WgslFile {
    name: "cumulus/draw.wgsl",
    source: include_str!("draw.wgsl"),
};
const COMPOSITE_WGSL: WgslFile = WgslFile {
    name: "cumulus/composite.wgsl",
    source: include_str!("composite.wgsl"),
};

/// What a pass that is shadowed by the clouds composes (after the drawing
/// libraries): the shadow uniform and lookup, group 1 bindings 8 and 9.
pub const SHADOW_LIBRARIES: [WgslFile; 2] = [SHADOW_UNIFORM, SHADOW_LOOKUP];

/// The composed WGSL of the camera's passes.
pub fn draw_shader_source() -> String {
    let mut files = shader::DRAWING_LIBRARIES.to_vec();
    files.extend(crate::stratus::DRAWING_LIBRARIES);
    files.extend([
        SHADING,
        SHADOW_UNIFORM,
        SHADOW_LOOKUP,
        CUMULUS_WGSL,
        DRAW_WGSL,
    ]);
    shader::compose(&files)
}

/// The composed WGSL of the shadow map's pass.
pub fn shadow_shader_source() -> String {
    let mut files = shader::DRAWING_LIBRARIES.to_vec();
    files.extend(crate::stratus::DRAWING_LIBRARIES);
    files.extend([SHADING, SHADOW_UNIFORM, CUMULUS_WGSL]);
    shader::compose(&files)
}

/// The composed WGSL of the fringes' composite.
pub fn composite_shader_source() -> String {
    shader::compose(&[shader::FULLSCREEN, COMPOSITE_WGSL])
}

/// Side of the cloud shadow map, texels.
pub const SHADOW_MAP_SIZE: u32 = 2048;
/// Percentage-closer filter radius of the shadow lookups, texels ((2k + 1)² taps).
pub const SHADOW_FILTER_TEXELS: u32 = 1;
/// Largest projected size of a mesh cell, pixels, before a coarser level of
/// detail is used.
pub const LOD_CELL_PX: f64 = 3.0;
/// Most clouds a field places.
pub const MAX_CLOUDS: usize = 400;
/// Level of detail drawn into the shadow map (clamped to what exists): its
/// cells (a last-level blob radius) match the map's texels of ~10 m.
const SHADOW_LOD: usize = 1;

/// GPU layout of the shader's parameters (WGSL `Cumulus`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CumulusUniform {
    /// α_a, α_l, α_f, α_t.
    pub weights: [f32; 4],
    /// α_g, Trans, α_ρ (m⁻¹), corona thickness r (m).
    pub corona: [f32; 4],
    /// α_b, α_w, α_d, α_h.
    pub detail: [f32; 4],
    /// Neyret's k, bump lacunarity, bump octaves, unused.
    pub noise: [f32; 4],
    /// Terms on (bits), light-trap model (0 furrows, 1 arctan), unused, unused.
    pub flags: [u32; 4],
    /// The sun's radiance E_sun/π at the cloud bases (RGB), and their height, m.
    pub sun_at_base: [f32; 4],
    /// Its change per metre of height above the bases (RGB), unused.
    pub sun_per_m: [f32; 4],
}

impl CumulusUniform {
    /// The uniform of a scene's cumulus settings.
    ///
    /// C_s is computed here rather than per pixel from the transmittance
    /// LUT: lavapipe (Mesa 22–23) crashes compiling this pass with the LUT
    /// lookup, and the sun's transmittance changes little over a cloud's
    /// height (linear over 2 km is within 0.5 % for a sun above 5°).
    pub fn new(
        settings: &CumulusSettings,
        atmosphere: &AtmosphereParams,
        to_sun: [f64; 3],
    ) -> Self {
        let s = &settings.shading;
        let top = crate::atmosphere::solar_irradiance_top();
        let sun_at = |height_m: f64| -> [f64; 3] {
            let r = atmosphere.bottom_radius_m + height_m.max(0.0);
            let t = atmosphere.transmittance_to_top(r, to_sun[1]);
            std::array::from_fn(|c| f64::from(top[c]) * t[c] / std::f64::consts::PI)
        };
        let (base, above) = (sun_at(settings.base_m), sun_at(settings.base_m + 2000.0));
        Self {
            weights: [s.ambient, s.lambert, s.light_traps, s.transmission].map(|v| v as f32),
            corona: [
                s.forward_width,
                s.transmission_gain,
                s.density_per_m,
                s.corona_thickness_m,
            ]
            .map(|v| v as f32),
            detail: [s.bump, s.normal_smoothing, s.trap_width, s.trap_height].map(|v| v as f32),
            noise: [
                s.trap_sharpness as f32,
                BUMP_LACUNARITY,
                s.bump_octaves as f32,
                0.0,
            ],
            flags: [
                settings.terms.bits(),
                u32::from(s.trap_model == LightTrapModel::Arctan),
                0,
                0,
            ],
            sun_at_base: [
                base[0] as f32,
                base[1] as f32,
                base[2] as f32,
                settings.base_m as f32,
            ],
            sun_per_m: [
                ((above[0] - base[0]) / 2000.0) as f32,
                ((above[1] - base[1]) / 2000.0) as f32,
                ((above[2] - base[2]) / 2000.0) as f32,
                0.0,
            ],
        }
    }
}

/// Lacunarity of the bump octaves: the hierarchy's radius ratio is 1/3.
pub const BUMP_LACUNARITY: f32 = 3.0;

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

/// A cloud as placed in the world: a variant's shape (object space: origin
/// at the centre of its base) scaled, turned about the vertical and moved:
/// world = base_centre + scale · R(yaw) · object, where
/// R(yaw)·(x, y, z) = (x cos yaw + z sin yaw, y, −x sin yaw + z cos yaw).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudPlacement {
    /// Index of the variant (see [`variants::VariantParams::hierarchy`]).
    pub variant: usize,
    /// World position of the variant's origin, m.
    pub base_centre_m: DVec3,
    /// Turn about the vertical, rad.
    pub yaw_rad: f64,
    /// Scale of the variant.
    pub scale: f64,
}

/// One drawn cloud (WGSL `CumulusInstance`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CumulusInstance {
    /// World position of the variant's origin (base centre), m; scale.
    pub offset_scale: [f32; 4],
    /// cos yaw, sin yaw, noise offset, unused.
    pub rotation_noise: [f32; 4],
    /// Lower levels' mean radii and the bump's first wavelength, object m.
    pub radii_wavelength: [f32; 4],
}

const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 6] = wgpu::vertex_attr_array![
    0 => Float32x4, 1 => Float32x4, 2 => Float32x4, 3 => Float32x4, 4 => Float32x4, 5 => Float32x4
];
const INSTANCE_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![6 => Float32x4, 7 => Float32x4, 8 => Float32x4];

fn vertex_layouts() -> [wgpu::VertexBufferLayout<'static>; 2] {
    [
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<CumulusVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &VERTEX_ATTRIBUTES,
        },
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<CumulusInstance>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &INSTANCE_ATTRIBUTES,
        },
    ]
}

/// The cloud shadow map: a two-layer depth texture (nearest and farthest
/// cloud core along the sun's light) and its uniform. Created once by the
/// renderer; the cumulus pass draws it, the passes lit by the sun bind it
/// at group 1, bindings 8 and 9.
#[derive(Debug)]
pub struct CloudShadowMap {
    texture: wgpu::Texture,
    array_view: wgpu::TextureView,
    layer_views: [wgpu::TextureView; 2],
    uniform: wgpu::Buffer,
    lookup_layout: wgpu::BindGroupLayout,
    lookup_group: wgpu::BindGroup,
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
        let lookup_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cloud shadow lookup"),
            entries: &Self::layout_entries(wgpu::ShaderStages::FRAGMENT),
        });
        let map = Self {
            lookup_group: device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cloud shadow lookup"),
                layout: &lookup_layout,
                entries: &shadow_entries(&uniform, &array_view),
            }),
            texture,
            array_view,
            layer_views,
            uniform,
            lookup_layout,
        };
        map.write(queue, &CloudShadowUniform::default());
        map
    }

    /// Layout entries of the uniform (binding 8) and the map (binding 9).
    pub fn layout_entries(visibility: wgpu::ShaderStages) -> [wgpu::BindGroupLayoutEntry; 2] {
        [
            binding::uniform_layout_entry(
                8,
                visibility,
                std::mem::size_of::<CloudShadowUniform>() as u64,
            ),
            wgpu::BindGroupLayoutEntry {
                binding: 9,
                visibility,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
        ]
    }

    /// Bind group entries matching [`Self::layout_entries`].
    pub fn bind_group_entries(&self) -> [wgpu::BindGroupEntry<'_>; 2] {
        shadow_entries(&self.uniform, &self.array_view)
    }

    /// A group holding only the lookup (for passes with no group 1 of their own).
    pub fn lookup_layout(&self) -> &wgpu::BindGroupLayout {
        &self.lookup_layout
    }

    /// The group of [`Self::lookup_layout`].
    pub fn lookup_group(&self) -> &wgpu::BindGroup {
        &self.lookup_group
    }

    /// The depth texture (layer 0 nearest core, layer 1 farthest).
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    fn write(&self, queue: &wgpu::Queue, value: &CloudShadowUniform) {
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(value));
    }
}

/// The shadow map's bind group entries: the uniform at 8, the map at 9.
fn shadow_entries<'a>(
    uniform: &'a wgpu::Buffer,
    map: &'a wgpu::TextureView,
) -> [wgpu::BindGroupEntry<'a>; 2] {
    [
        wgpu::BindGroupEntry {
            binding: 8,
            resource: uniform.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 9,
            resource: wgpu::BindingResource::TextureView(map),
        },
    ]
}

/// Shadow clip space from world space: orthographic along the light
/// (towards −`to_sun`) over the given bounding spheres; x, y in [−1, 1]
/// (square texels), z in [0, 1] from the nearest to the farthest sphere.
/// Returns the matrix and the depth range, m.
pub fn shadow_clip_from_world(to_sun: DVec3, spheres: &[(DVec3, f64)]) -> (Mat4, f64) {
    let forward = -to_sun.normalize();
    let right = if forward.y.abs() < 0.999 {
        forward.cross(DVec3::Y).normalize()
    } else {
        DVec3::X
    };
    let up = right.cross(forward);
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for &(c, r) in spheres {
        let p = DVec3::new(c.dot(right), c.dot(up), c.dot(forward));
        lo = lo.min(p - DVec3::splat(r));
        hi = hi.max(p + DVec3::splat(r));
    }
    let half = 0.5 * (hi.x - lo.x).max(hi.y - lo.y).max(1.0);
    let (cx, cy) = (0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
    let depth = (hi.z - lo.z).max(1.0);
    let rows = [
        [right.x / half, right.y / half, right.z / half, -cx / half],
        [up.x / half, up.y / half, up.z / half, -cy / half],
        [
            forward.x / depth,
            forward.y / depth,
            forward.z / depth,
            -lo.z / depth,
        ],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let m = glam::DMat4::from_cols_array_2d(&rows).transpose();
    (m.as_mat4(), depth)
}

/// Level of detail of a cloud at `distance_m` whose finest cell is `cell_m`
/// (scaled), for a pixel angle `pixel_angle_rad`: the coarsest whose cell
/// projects to at most [`LOD_CELL_PX`] pixels.
pub fn level_of_detail(cell_m: f64, distance_m: f64, pixel_angle_rad: f64, levels: usize) -> usize {
    let ratio = LOD_CELL_PX * distance_m.max(1.0) * pixel_angle_rad / cell_m.max(1e-6);
    if ratio < 2.0 {
        return 0;
    }
    (ratio.log2().floor() as usize).min(levels.saturating_sub(1))
}

/// Whether a sphere is (partly) inside the frustum of a reverse-Z,
/// infinite-far clip transform.
pub fn sphere_in_frustum(clip_from_world: &Mat4, centre: Vec3, radius: f32) -> bool {
    let rows = [
        clip_from_world.row(0),
        clip_from_world.row(1),
        clip_from_world.row(2),
        clip_from_world.row(3),
    ];
    let planes: [Vec4; 5] = [
        rows[3] + rows[0],
        rows[3] - rows[0],
        rows[3] + rows[1],
        rows[3] - rows[1],
        rows[3] - rows[2],
    ];
    planes.iter().all(|p| {
        let n = p.truncate();
        n.dot(centre) + p.w >= -radius * n.length()
    })
}

/// The per-frame data of the `index`th cloud, an instance of `shape`.
fn field_cloud(index: usize, cloud: &CloudInstance, shape: &CumulusVariant) -> FieldCloud {
    let (c, s) = (cloud.yaw_rad.cos(), cloud.yaw_rad.sin());
    let b = DVec3::from_array(shape.bounds_centre_m.map(f64::from)) * cloud.scale;
    let r = shape.base_radii_m;
    FieldCloud {
        variant: cloud.variant as usize,
        centre_m: cloud.base_centre_m + DVec3::new(c * b.x + s * b.z, b.y, -s * b.x + c * b.z),
        radius_m: f64::from(shape.bounds_radius_m) * cloud.scale,
        finest_cell_m: f64::from(shape.lods[0].cell_m) * cloud.scale,
        instance: CumulusInstance {
            offset_scale: [
                cloud.base_centre_m.x as f32,
                cloud.base_centre_m.y as f32,
                cloud.base_centre_m.z as f32,
                cloud.scale as f32,
            ],
            rotation_noise: [c as f32, s as f32, (index as f32 * 37.31) % 512.0, 0.0],
            radii_wavelength: [
                r[0],
                r[1],
                r[2],
                2.0 * shape.last_radius_m / BUMP_LACUNARITY,
            ],
        },
    }
}

/// `cloud` moved by the wind's drift (x, z), m; with `wrap_side_m`, its base
/// kept inside the square of that side around `area_centre_m`.
fn drifted_cloud(
    cloud: &FieldCloud,
    drift_m: [f64; 2],
    area_centre_m: [f64; 2],
    wrap_side_m: Option<f64>,
) -> FieldCloud {
    let base = cloud.instance.offset_scale;
    let mut target = [
        f64::from(base[0]) + drift_m[0],
        f64::from(base[2]) + drift_m[1],
    ];
    if let Some(side) = wrap_side_m {
        for (t, c) in target.iter_mut().zip(area_centre_m) {
            *t = c - 0.5 * side + (*t - (c - 0.5 * side)).rem_euclid(side);
        }
    }
    let shift = DVec3::new(
        target[0] - f64::from(base[0]),
        0.0,
        target[1] - f64::from(base[2]),
    );
    let mut moved = cloud.clone();
    moved.centre_m += shift;
    moved.instance.offset_scale[0] = target[0] as f32;
    moved.instance.offset_scale[2] = target[1] as f32;
    moved
}

#[derive(Debug)]
struct GpuLod {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

#[derive(Debug)]
struct GpuVariant {
    shape: Arc<CumulusVariant>,
    lods: Vec<GpuLod>,
}

/// A run of instances of one mesh.
#[derive(Clone, Debug, PartialEq)]
struct Draw {
    variant: usize,
    lod: usize,
    instances: Range<u32>,
}

#[derive(Debug)]
struct FringeTargets {
    size: (u32, u32),
    accumulation: wgpu::TextureView,
    revealage: wgpu::TextureView,
    composite_group: wgpu::BindGroup,
}

/// Why the cumulus cannot be prepared.
#[derive(Debug, thiserror::Error)]
pub enum CumulusError {
    /// A shape variant could not be generated.
    #[error(transparent)]
    Variant(#[from] variants::VariantError),
}

/// A cloud of the field with what every frame needs of it, derived once
/// when the field is placed.
#[derive(Clone, Debug)]
struct FieldCloud {
    variant: usize,
    /// World bounding sphere: centre and radius, m.
    centre_m: DVec3,
    radius_m: f64,
    /// The finest level's cell at the cloud's scale, m.
    finest_cell_m: f64,
    instance: CumulusInstance,
}

/// What the clouds of a frame are.
#[derive(Clone, Debug, PartialEq)]
struct FieldKey {
    /// The settings with the shader's parameters and terms left at their
    /// defaults: changing those does not move the clouds.
    placement: CumulusSettings,
    area_centre_m: [f64; 2],
    area_side_m: f64,
}

/// The cumulus pass.
#[derive(Debug)]
pub struct CumulusPass {
    uniform: wgpu::Buffer,
    group: wgpu::BindGroup,
    shadow_group: wgpu::BindGroup,
    shadow_pipelines: [wgpu::RenderPipeline; 2],
    opaque_pipeline: wgpu::RenderPipeline,
    fringe_pipeline: wgpu::RenderPipeline,
    composite_pipeline: wgpu::RenderPipeline,
    composite_layout: wgpu::BindGroupLayout,
    fringe: Option<FringeTargets>,
    variants: Option<(VariantParams, Vec<GpuVariant>)>,
    field: Option<(FieldKey, Vec<FieldCloud>)>,
    /// The field's clouds where the wind has carried them this frame.
    moved: Vec<FieldCloud>,
    instances: Option<wgpu::Buffer>,
    draws: Vec<Draw>,
    shadow_draws: Vec<Draw>,
    enabled: bool,
    shadow_enabled: bool,
}

fn pipeline_descriptor_depth(
    write: bool,
    compare: wgpu::CompareFunction,
) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

impl CumulusPass {
    /// Creates the pipelines; shapes and the field are made by [`Self::prepare`].
    pub fn new(
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        atmosphere_layout: &wgpu::BindGroupLayout,
        stratus_layout: &wgpu::BindGroupLayout,
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
        let [shadow_uniform_entry, shadow_map_entry] = CloudShadowMap::layout_entries(draw_stages);
        let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cumulus"),
            entries: &[
                binding::uniform_layout_entry(0, draw_stages, uniform_size),
                shadow_uniform_entry,
                shadow_map_entry,
            ],
        });
        let shadow_group_layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cumulus shadow"),
                entries: &[
                    binding::uniform_layout_entry(0, draw_stages, uniform_size),
                    shadow_uniform_entry,
                ],
            });
        let [shadow_uniform, shadow_texture] = shadow_map.bind_group_entries();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cumulus"),
            layout: &group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                shadow_uniform.clone(),
                shadow_texture,
            ],
        });
        let shadow_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cumulus shadow"),
            layout: &shadow_group_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                shadow_uniform,
            ],
        });

        let shadow_module =
            shader::create_module(device, "cumulus shadow", &shadow_shader_source());
        let shadow_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cumulus shadow"),
            bind_group_layouts: &[Some(frame_layout), Some(&shadow_group_layout)],
            immediate_size: 0,
        });
        let buffers = vertex_layouts().map(Some);
        let shadow_pipeline = |label: &str, compare| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&shadow_layout),
                vertex: wgpu::VertexState {
                    module: &shadow_module,
                    entry_point: Some("cumulus_shadow_vertex"),
                    compilation_options: Default::default(),
                    buffers: &buffers,
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: Some(pipeline_descriptor_depth(true, compare)),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shadow_module,
                    entry_point: Some("cumulus_shadow_fragment"),
                    compilation_options: Default::default(),
                    targets: &[],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let shadow_pipelines = [
            shadow_pipeline("cumulus shadow nearest", wgpu::CompareFunction::Less),
            shadow_pipeline("cumulus shadow farthest", wgpu::CompareFunction::Greater),
        ];

        let module = shader::create_module(device, "cumulus", &draw_shader_source());
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cumulus"),
            bind_group_layouts: &[
                Some(frame_layout),
                Some(&group_layout),
                Some(atmosphere_layout),
                Some(stratus_layout),
            ],
            immediate_size: 0,
        });
        let draw_pipeline =
            |label: &str,
             entry: &str,
             depth_write: bool,
             targets: &[Option<wgpu::ColorTargetState>]| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(label),
                    layout: Some(&layout),
                    vertex: wgpu::VertexState {
                        module: &module,
                        entry_point: Some("cumulus_vertex"),
                        compilation_options: Default::default(),
                        buffers: &buffers,
                    },
                    primitive: wgpu::PrimitiveState {
                        cull_mode: Some(wgpu::Face::Back),
                        ..Default::default()
                    },
                    depth_stencil: Some(pipeline_descriptor_depth(
                        depth_write,
                        wgpu::CompareFunction::Greater,
                    )),
                    multisample: Default::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        targets,
                    }),
                    multiview_mask: None,
                    cache: None,
                })
            };
        let opaque_pipeline = draw_pipeline(
            "cumulus",
            "cumulus_opaque_fragment",
            true,
            &[Some(HDR_FORMAT.into())],
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
        let premultiplied = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
            operation: wgpu::BlendOperation::Add,
        };
        let composite_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("cumulus composite"),
            layout: Some(&composite_pipeline_layout),
            vertex: wgpu::VertexState {
                module: &composite_module,
                entry_point: Some("fullscreen_vertex"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &composite_module,
                entry_point: Some("cumulus_composite_fragment"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    blend: Some(wgpu::BlendState {
                        color: premultiplied,
                        alpha: premultiplied,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        Self {
            uniform,
            group,
            shadow_group,
            shadow_pipelines,
            opaque_pipeline,
            fringe_pipeline,
            composite_pipeline,
            composite_layout,
            fringe: None,
            variants: None,
            field: None,
            moved: Vec::new(),
            instances: None,
            draws: Vec::new(),
            shadow_draws: Vec::new(),
            enabled: false,
            shadow_enabled: false,
        }
    }

    /// Whether the frame has clouds to draw.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Whether the shadow map is drawn this frame.
    pub fn shadow_enabled(&self) -> bool {
        self.shadow_enabled
    }

    /// The clouds of the last prepared frame, where the wind has carried
    /// them (see [`CloudPlacement`]).
    pub fn placed_clouds(&self) -> Vec<CloudPlacement> {
        self.moved
            .iter()
            .map(|cloud| {
                let [x, y, z, scale] = cloud.instance.offset_scale;
                let [cos_yaw, sin_yaw, ..] = cloud.instance.rotation_noise;
                CloudPlacement {
                    variant: cloud.variant,
                    base_centre_m: DVec3::new(f64::from(x), f64::from(y), f64::from(z)),
                    yaw_rad: f64::from(sin_yaw).atan2(f64::from(cos_yaw)),
                    scale: f64::from(scale),
                }
            })
            .collect()
    }

    /// The variants' generation parameters (`None` without cumulus).
    pub fn variant_params(&self) -> Option<&VariantParams> {
        self.variants.as_ref().map(|v| &v.0)
    }

    /// The placed clouds' footprints as (x, z, radius), m: their bounding
    /// spheres seen from below (where rain under cumulus falls).
    pub fn footprints_m(&self) -> Vec<[f32; 3]> {
        self.moved
            .iter()
            .map(|c| [c.centre_m.x as f32, c.centre_m.z as f32, c.radius_m as f32])
            .collect()
    }

    /// Number of clouds in the field and number drawn this frame.
    pub fn cloud_counts(&self) -> (usize, usize) {
        let drawn = self.draws.iter().map(|d| d.instances.len()).sum();
        (self.field.as_ref().map_or(0, |f| f.1.len()), drawn)
    }

    /// Generates (or loads) the shapes, places the field, and selects and
    /// uploads this frame's instances and shadow transform.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        frame: &FrameUniform,
        shadow_map: &CloudShadowMap,
        width: u32,
        height: u32,
    ) -> Result<(), CumulusError> {
        self.draws.clear();
        self.shadow_draws.clear();
        let Some(settings) = &scene.cumulus else {
            self.moved.clear();
            self.enabled = false;
            self.shadow_enabled = false;
            shadow_map.write(queue, &CloudShadowUniform::default());
            return Ok(());
        };
        let params = VariantParams {
            count: settings.variants,
            seed: settings.shape_seed,
            levels_of_detail: settings.levels_of_detail,
        };
        if self.variants.as_ref().map(|v| &v.0) != Some(&params) {
            let shapes = variants::load_or_generate(&crate::stratus::optics_cache_dir(), &params)?;
            let gpu = shapes
                .into_iter()
                .map(|shape| GpuVariant {
                    lods: shape
                        .lods
                        .iter()
                        .map(|lod| GpuLod {
                            vertices: device.create_buffer_init(
                                &wgpu::util::BufferInitDescriptor {
                                    label: Some("cumulus vertices"),
                                    contents: bytemuck::cast_slice(&lod.vertices),
                                    usage: wgpu::BufferUsages::VERTEX,
                                },
                            ),
                            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                                label: Some("cumulus indices"),
                                contents: bytemuck::cast_slice(&lod.indices),
                                usage: wgpu::BufferUsages::INDEX,
                            }),
                            index_count: lod.indices.len() as u32,
                        })
                        .collect(),
                    shape,
                })
                .collect();
            self.variants = Some((params, gpu));
            self.field = None;
        }
        let Some((_, variants)) = &self.variants else {
            return Ok(());
        };
        let key = FieldKey {
            placement: CumulusSettings {
                shading: Default::default(),
                terms: Default::default(),
                ..settings.clone()
            },
            area_centre_m: [0.0, 0.0],
            area_side_m: settings.area_m.unwrap_or(scene.terrain.extent_m),
        };
        if self.field.as_ref().map(|f| &f.0) != Some(&key) {
            let clouds = if settings.clouds.is_empty() {
                let footprints: Vec<f64> = variants
                    .iter()
                    .map(|v| f64::from(v.shape.footprint_radius_m))
                    .collect();
                place_clouds(
                    &CloudFieldParams {
                        coverage: settings.coverage,
                        base_m: settings.base_m,
                        seed: settings.seed,
                        centre_m: key.area_centre_m,
                        side_m: key.area_side_m,
                        scale_range: settings.scale_range,
                        max_clouds: MAX_CLOUDS,
                    },
                    &footprints,
                )
                .clouds
            } else {
                settings
                    .clouds
                    .iter()
                    .map(|c| CloudInstance {
                        variant: c.variant.min(settings.variants.saturating_sub(1)),
                        base_centre_m: DVec3::from_array(c.position_m),
                        yaw_rad: c.yaw_deg.to_radians(),
                        scale: c.scale,
                    })
                    .collect()
            };
            let clouds = clouds
                .iter()
                .enumerate()
                .map(|(index, cloud)| {
                    field_cloud(index, cloud, &variants[cloud.variant as usize].shape)
                })
                .collect();
            self.field = Some((key, clouds));
        }
        let Some((key, placed)) = &self.field else {
            return Ok(());
        };
        // The wind carries the clouds; a generated field wraps around its
        // square area so that it never empties.
        let drift = scene.cloud_drift_m(f64::from(frame.time_s));
        let wrap = settings.clouds.is_empty().then_some(key.area_side_m);
        self.moved.clear();
        self.moved.extend(
            placed
                .iter()
                .map(|cloud| drifted_cloud(cloud, drift, key.area_centre_m, wrap)),
        );
        let clouds = &self.moved;
        let uniform = CumulusUniform::new(settings, &scene.atmosphere, scene.sun.direction());
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));

        // Instances: the camera's (culled, by level of detail), then the shadow's (all).
        let clip_from_world = frame.clip_from_world();
        let camera = Vec3::from_array(frame.camera_position_m);
        let mut camera_list: Vec<(usize, usize, CumulusInstance)> = Vec::new();
        for cloud in clouds {
            if !sphere_in_frustum(
                &clip_from_world,
                cloud.centre_m.as_vec3(),
                cloud.radius_m as f32,
            ) {
                continue;
            }
            let distance = (cloud.centre_m.as_vec3() - camera).length() as f64 - cloud.radius_m;
            let lod = level_of_detail(
                cloud.finest_cell_m,
                distance,
                f64::from(frame.pixel_angle_rad),
                variants[cloud.variant].lods.len(),
            );
            camera_list.push((cloud.variant, lod, cloud.instance));
        }
        camera_list.sort_by_key(|(v, l, _)| (*v, *l));
        let mut data: Vec<CumulusInstance> = Vec::with_capacity(camera_list.len() + clouds.len());
        let push_runs = |list: &[(usize, usize, CumulusInstance)],
                         draws: &mut Vec<Draw>,
                         data: &mut Vec<CumulusInstance>| {
            for (v, l, inst) in list {
                let at = data.len() as u32;
                data.push(*inst);
                match draws.last_mut() {
                    Some(d) if d.variant == *v && d.lod == *l && d.instances.end == at => {
                        d.instances.end = at + 1
                    }
                    _ => draws.push(Draw {
                        variant: *v,
                        lod: *l,
                        instances: at..at + 1,
                    }),
                }
            }
        };
        push_runs(&camera_list, &mut self.draws, &mut data);
        let sun = scene.sun.direction();
        let to_sun = DVec3::from_array(sun);
        self.shadow_enabled = to_sun.y > 0.0 && !clouds.is_empty() && settings.terms.shadow;
        if self.shadow_enabled {
            let mut shadow_list: Vec<(usize, usize, CumulusInstance)> = clouds
                .iter()
                .map(|cloud| {
                    let lods = variants[cloud.variant].lods.len();
                    (cloud.variant, SHADOW_LOD.min(lods - 1), cloud.instance)
                })
                .collect();
            shadow_list.sort_by_key(|(v, l, _)| (*v, *l));
            push_runs(&shadow_list, &mut self.shadow_draws, &mut data);
            let spheres: Vec<(DVec3, f64)> =
                clouds.iter().map(|c| (c.centre_m, c.radius_m)).collect();
            let (matrix, depth_m) = shadow_clip_from_world(to_sun, &spheres);
            shadow_map.write(
                queue,
                &CloudShadowUniform {
                    clip_from_world: matrix.to_cols_array_2d(),
                    params: [
                        depth_m as f32,
                        settings.shading.density_per_m as f32,
                        CLOUD_ASYMMETRY as f32,
                        SHADOW_MAP_SIZE as f32,
                    ],
                    flags: [1, SHADOW_FILTER_TEXELS, 0, 0],
                },
            );
        } else {
            shadow_map.write(queue, &CloudShadowUniform::default());
        }
        self.enabled = !self.draws.is_empty();
        let bytes = (data.len().max(1) * std::mem::size_of::<CumulusInstance>()) as u64;
        if self.instances.as_ref().is_none_or(|b| b.size() < bytes) {
            self.instances = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cumulus instances"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if let Some(buffer) = &self.instances {
            queue.write_buffer(buffer, 0, bytemuck::cast_slice(&data));
        }
        self.ensure_fringe_targets(device, width, height);
        Ok(())
    }

    fn ensure_fringe_targets(&mut self, device: &wgpu::Device, width: u32, height: u32) {
        if self.fringe.as_ref().map(|f| f.size) == Some((width, height)) {
            return;
        }
        let target = |label: &str, format| {
            crate::targets::Target::new(
                device,
                label,
                format,
                width,
                height,
                wgpu::TextureUsages::TEXTURE_BINDING,
            )
            .view
        };
        let accumulation = target("cumulus fringe accumulation", ACCUMULATION_FORMAT);
        let revealage = target("cumulus fringe revealage", REVEALAGE_FORMAT);
        let composite_group = binding::sequential_bind_group(
            device,
            "cumulus composite",
            &self.composite_layout,
            vec![
                wgpu::BindingResource::TextureView(&accumulation),
                wgpu::BindingResource::TextureView(&revealage),
            ],
        );
        self.fringe = Some(FringeTargets {
            size: (width, height),
            accumulation,
            revealage,
            composite_group,
        });
    }

    fn record(&self, pass: &mut wgpu::RenderPass<'_>, draws: &[Draw]) {
        let (Some((_, variants)), Some(instances)) = (&self.variants, &self.instances) else {
            return;
        };
        pass.set_vertex_buffer(1, instances.slice(..));
        for draw in draws {
            let lod = &variants[draw.variant].lods[draw.lod];
            pass.set_vertex_buffer(0, lod.vertices.slice(..));
            pass.set_index_buffer(lod.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..lod.index_count, 0, draw.instances.clone());
        }
    }

    /// Records the shadow map: nearest cores, then farthest.
    pub fn encode_shadow(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &wgpu::BindGroup,
        shadow_map: &CloudShadowMap,
        timestamps: Option<(&wgpu::QuerySet, u32)>,
    ) {
        for (layer, pipeline) in self.shadow_pipelines.iter().enumerate() {
            let clear = if layer == 0 { 1.0 } else { 0.0 };
            let timestamp_writes =
                timestamps.map(|(query_set, index)| wgpu::RenderPassTimestampWrites {
                    query_set,
                    beginning_of_pass_write_index: (layer == 0).then_some(index * 2),
                    end_of_pass_write_index: (layer == 1).then_some(index * 2 + 1),
                });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cumulus shadow"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &shadow_map.layer_views[layer],
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(clear),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if !self.shadow_enabled {
                continue;
            }
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, frame, &[]);
            pass.set_bind_group(1, &self.shadow_group, &[]);
            self.record(&mut pass, &self.shadow_draws);
        }
    }

    /// Records the opaque bodies into a pass on the HDR target and depth.
    pub fn draw_opaque(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        frame: &wgpu::BindGroup,
        atmosphere: &wgpu::BindGroup,
        stratus: &wgpu::BindGroup,
    ) {
        pass.set_pipeline(&self.opaque_pipeline);
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(1, &self.group, &[]);
        pass.set_bind_group(2, atmosphere, &[]);
        pass.set_bind_group(3, stratus, &[]);
        self.record(pass, &self.draws);
    }

    /// Records the fringes' accumulation (its own pass, depth read-only).
    pub fn encode_fringes(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::TextureView,
        groups: [&wgpu::BindGroup; 3],
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let Some(fringe) = &self.fringe else { return };
        let [frame, atmosphere, stratus] = groups;
        let attachment = |view, clear: f64| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: clear,
                        g: clear,
                        b: clear,
                        a: clear,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("cumulus fringes"),
            color_attachments: &[
                attachment(&fringe.accumulation, 0.0),
                attachment(&fringe.revealage, 1.0),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: None,
                stencil_ops: None,
            }),
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.fringe_pipeline);
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(1, &self.group, &[]);
        pass.set_bind_group(2, atmosphere, &[]);
        pass.set_bind_group(3, stratus, &[]);
        self.record(&mut pass, &self.draws);
    }

    /// Records the fringes' composite into a pass on the HDR target.
    pub fn draw_composite(&self, pass: &mut wgpu::RenderPass<'_>) {
        let Some(fringe) = &self.fringe else { return };
        pass.set_pipeline(&self.composite_pipeline);
        pass.set_bind_group(0, &fringe.composite_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// Format of the fringes' Σ w α C, Σ w α target.
const ACCUMULATION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of the fringes' Π (1 − α) target.
const REVEALAGE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadow_transform_maps_the_spheres_into_the_unit_box() {
        let to_sun = DVec3::new(0.3, 0.8, -0.2).normalize();
        let spheres = [
            (DVec3::new(1000.0, 1500.0, -200.0), 500.0),
            (DVec3::new(-3000.0, 1800.0, 4000.0), 800.0),
        ];
        let (m, depth) = shadow_clip_from_world(to_sun, &spheres);
        for (c, r) in spheres {
            for d in [
                DVec3::X,
                DVec3::Y,
                DVec3::Z,
                -DVec3::X,
                -DVec3::Y,
                -DVec3::Z,
            ] {
                let p = m * (c + d * r).as_vec3().extend(1.0);
                assert!(p.x.abs() <= 1.0 + 1e-4 && p.y.abs() <= 1.0 + 1e-4, "{p}");
                assert!((-1e-4..=1.0 + 1e-4).contains(&p.z), "{p}");
            }
        }
        // Depth grows along the light: a point towards the sun is nearer.
        let a = m * Vec3::new(0.0, 1600.0, 0.0).extend(1.0);
        let b = m
            * (DVec3::new(0.0, 1600.0, 0.0) + to_sun * 100.0)
                .as_vec3()
                .extend(1.0);
        assert!(b.z < a.z);
        assert!(((a.z - b.z) as f64 * depth - 100.0).abs() < 0.1);
    }

    #[test]
    fn levels_of_detail_coarsen_with_distance() {
        let pixel = 1.0e-3;
        assert_eq!(level_of_detail(20.0, 1000.0, pixel, 3), 0);
        assert_eq!(level_of_detail(20.0, 14_000.0, pixel, 3), 1);
        assert_eq!(level_of_detail(20.0, 30_000.0, pixel, 3), 2);
        assert_eq!(level_of_detail(20.0, 300_000.0, pixel, 3), 2);
    }

    #[test]
    fn frustum_keeps_what_is_ahead() {
        let camera = crate::frame::Camera {
            position_m: DVec3::ZERO,
            forward: DVec3::NEG_Z,
            up: DVec3::Y,
            fov_y_rad: 1.0,
            aspect: 1.5,
            height_px: 720,
        };
        let m = camera.clip_from_world().as_mat4();
        assert!(sphere_in_frustum(&m, Vec3::new(0.0, 0.0, -5000.0), 100.0));
        assert!(!sphere_in_frustum(&m, Vec3::new(0.0, 0.0, 5000.0), 100.0));
        assert!(!sphere_in_frustum(
            &m,
            Vec3::new(9000.0, 0.0, -1000.0),
            100.0
        ));
        // A sphere around the camera is always drawn.
        assert!(sphere_in_frustum(&m, Vec3::new(0.0, 0.0, 50.0), 100.0));
    }
}
