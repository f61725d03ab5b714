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
//! 6. Only with the camera in or near a cloud ([`in_cloud`]): that cloud
//!    marched as a volume over everything, its mesh faded out. In the
//!    volume model every cloud in view is marched, before the stratus layer
//!    or, wholly between the camera and the layer, after it.

pub mod in_cloud;
pub mod interior;
pub mod transfer;
pub mod variants;

use crate::core::background::Deferred;
pub use crate::frame::cloud_shadow::{CloudShadowMap, CloudShadowUniform, SHADOW_MAP_SIZE};
use crate::scene::CumulusSettings;
use crate::shader::{self, WgslFile};
use glam::DVec3;
use nimbus_physics::cumulus::forward_peak::ForwardPeakTable;
use nimbus_physics::optics::tables::CloudOpticsParams;
use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use variants::{CumulusVariant, VariantParams};

/// The shader's terms (CPU twin: `nimbus_physics::cumulus::shading`).
pub const SHADING: WgslFile = WgslFile {
    name: "passes/cumulus/shading.wgsl",
    source: include_str!("shading.wgsl"),
};
pub use crate::shader::{
    CLOUD_SHADOW_LOOKUP as SHADOW_LOOKUP, CLOUD_SHADOW_UNIFORM as SHADOW_UNIFORM,
};
/// The pass's vertex inputs, varyings and shadow entry points
/// (`cumulus_transfer_at` among them).
pub const CUMULUS_WGSL: WgslFile = WgslFile {
    name: "passes/cumulus/cumulus.wgsl",
    source: include_str!("cumulus.wgsl"),
};
const DRAW_WGSL: WgslFile = WgslFile {
    name: "passes/cumulus/draw.wgsl",
    source: include_str!("draw.wgsl"),
};
const COMPOSITE_WGSL: WgslFile = WgslFile {
    name: "passes/cumulus/composite.wgsl",
    source: include_str!("composite.wgsl"),
};

/// What a pass that is shadowed by the clouds composes (after the drawing
/// libraries): the shadow uniform and lookup, group 3 bindings 0 and 1.
pub const SHADOW_LIBRARIES: [WgslFile; 2] = [SHADOW_UNIFORM, SHADOW_LOOKUP];

/// The composed WGSL of the camera's passes.
pub fn draw_shader_source() -> String {
    shader::compose(&[SHADING, CUMULUS_WGSL, DRAW_WGSL])
}

/// The composed WGSL of the shadow map's pass.
pub fn shadow_shader_source() -> String {
    shader::compose(&[SHADING, CUMULUS_WGSL])
}

/// The composed WGSL of the fringes' composite.
pub fn composite_shader_source() -> String {
    shader::compose(&[COMPOSITE_WGSL])
}

/// The forward-peak table of `shading.wgsl` (group 1, binding 1), F(θ, τ)'s
/// rows then H(θ, τ)'s:
/// [`nimbus_physics::cumulus::forward_peak::ForwardPeakTable::rgba_texels`],
/// read with `textureLoad` (RGBA32 float is not filterable everywhere).
pub const FORWARD_PEAK_TEXTURE: wgpu::TextureDescriptor<'static> = wgpu::TextureDescriptor {
    label: Some("cumulus forward peak"),
    size: wgpu::Extent3d {
        width: nimbus_physics::cumulus::forward_peak::ANGLES as u32,
        height: nimbus_physics::cumulus::forward_peak::TABLE_ROWS as u32,
        depth_or_array_layers: 1,
    },
    mip_level_count: 1,
    sample_count: 1,
    dimension: wgpu::TextureDimension::D2,
    format: wgpu::TextureFormat::Rgba32Float,
    usage: wgpu::TextureUsages::TEXTURE_BINDING.union(wgpu::TextureUsages::COPY_DST),
    view_formats: &[],
};

/// The transport model's phase table P_S(Θ) (group 1, binding 2): one row
/// of [`PHASE_TEXELS`] RGBA32 float texels, uniform in Θ over 0–180°.
pub const PHASE_TEXTURE: wgpu::TextureDescriptor<'static> = wgpu::TextureDescriptor {
    label: Some("cumulus phase"),
    size: wgpu::Extent3d {
        width: PHASE_TEXELS as u32,
        height: 1,
        depth_or_array_layers: 1,
    },
    mip_level_count: 1,
    sample_count: 1,
    dimension: wgpu::TextureDimension::D2,
    format: wgpu::TextureFormat::Rgba32Float,
    usage: wgpu::TextureUsages::TEXTURE_BINDING.union(wgpu::TextureUsages::COPY_DST),
    view_formats: &[],
};

/// Percentage-closer filter radius of the shadow lookups, texels ((2k + 1)² taps).
pub const SHADOW_FILTER_TEXELS: u32 = 1;
/// Largest projected size of a mesh cell, pixels, before a coarser level of
/// detail is used.
pub const LOD_CELL_PX: f64 = 3.0;
pub use crate::scene::MAX_CLOUDS;

mod field;
mod gpu_types;
mod node;
mod prepare;
mod resources;
mod shadow;

pub use field::{
    CumulusField, cumulus_field_at, level_of_detail, shadow_clip_from_world, sphere_in_frustum,
};
pub use gpu_types::{
    BUMP_LACUNARITY, CloudPlacement, CumulusInstance, CumulusUniform, PHASE_TEXELS,
};
pub use in_cloud::{InCloudUniform, MarchGroup, in_cloud_shader_source};
/// Level of detail drawn into the shadow map (clamped to what exists): its
/// cells (a last-level blob radius) match the map's texels of ~10 m.
const SHADOW_LOD: usize = 1;

#[derive(Debug)]
struct GpuLod {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    /// The transport model's transfer per vertex (zero until computed).
    transfer: wgpu::Buffer,
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

/// The shape variants, or why they could not be made.
type ShapesResult = Result<Vec<Arc<CumulusVariant>>, variants::VariantError>;
/// The variants' transfers, or why they could not be made.
type TransfersResult = Result<Vec<Arc<transfer::VariantTransfer>>, variants::VariantError>;

/// What the transfers are computed for: the parameters, and the droplets.
#[derive(Clone, Debug, PartialEq)]
struct TransferKey {
    params: transfer::TransferParams,
    optics: CloudOpticsParams,
}

/// The droplets' tables the pass uploads.
#[derive(Debug)]
struct DropletTables {
    forward_peak: ForwardPeakTable,
    /// P_S(Θ) RGBA per texel ([`PHASE_TEXELS`] over 0–180°), sr⁻¹.
    phase_rgba: Vec<f32>,
    /// δ-M's 1 − f at 550 nm.
    truncation: f32,
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
    /// Group 1: the cumulus uniform (the bodies, the fringes and the shadow
    /// map) and the forward-peak table.
    group: wgpu::BindGroup,
    forward_peak_table: wgpu::Texture,
    /// Cache hash of the droplet optics the table was computed from.
    forward_peak_key: Option<u64>,
    shadow_pipelines: [wgpu::RenderPipeline; 2],
    opaque_pipeline: wgpu::RenderPipeline,
    fringe_pipeline: wgpu::RenderPipeline,
    composite_pipeline: wgpu::RenderPipeline,
    composite_layout: wgpu::BindGroupLayout,
    fringe: Option<FringeTargets>,
    variants: Option<(VariantParams, Vec<GpuVariant>)>,
    /// The shapes generated or loaded (a worker thread's work).
    shapes: Deferred<VariantParams, ShapesResult>,
    /// The forward-peak table of the droplets and their phase function
    /// without the peak (from their Mie tables).
    forward_peak: Deferred<CloudOpticsParams, Arc<DropletTables>>,
    /// The phase table P_S of the transport model.
    phase_table: wgpu::Texture,
    /// The transport model's transfers (a worker thread's work).
    transfers: Deferred<TransferKey, TransfersResult>,
    /// The transfer held by the variants' buffers.
    transfer_uploaded: Option<TransferKey>,
    /// δ-M's 1 − f of the droplets uploaded (550 nm).
    transport_truncation: f32,
    field: Option<(FieldKey, Vec<FieldCloud>)>,
    /// The field's clouds where the wind has carried them this frame.
    moved: Vec<FieldCloud>,
    instances: Option<wgpu::Buffer>,
    draws: Vec<Draw>,
    shadow_draws: Vec<Draw>,
    enabled: bool,
    /// The clouds cast shadows this frame (the map's uniform says so).
    shadow_enabled: bool,
    /// What the shadow map holds, or is to hold once this frame's encode
    /// has drawn it.
    shadow_content: Option<shadow::ShadowContent>,
    /// This frame's encode draws the map (its content changed).
    shadow_redraw: bool,
    /// The camera inside a cloud.
    in_cloud: in_cloud::InCloud,
    /// An encode has recorded the drawing of [`Self::shadow_content`]; until
    /// then a frame whose clouds match it still draws it. Atomic: encoding
    /// takes `&self`.
    shadow_drawn: AtomicBool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

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
