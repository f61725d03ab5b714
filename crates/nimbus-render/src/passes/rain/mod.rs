//! Rain pass (Blanchard 2023, §4.2–4.3, after Rousseau et al. 2006/2008):
//! drops simulated on the GPU in a rain box around the camera, stopped by a
//! rain shadow map, drawn as streaks with splashes, and continued beyond the
//! box as mist.
//!
//! Per frame: [`RainPass::prepare`] advances the simulation clock in fixed
//! steps of [`STEP_S`] (independent of the frame rate) and writes one step
//! uniform per step; [`RainPass::encode_simulation`] redraws the rain shadow
//! map when the wind, the box's neighbourhood or the scene changed, runs the
//! steps (`simulation.wgsl`, the twin of
//! [`nimbus_physics::rain::simulation::step_drop`]) and lists the drops in
//! view (`visibility.wgsl`); [`RainPass::draw`] draws the streaks (indirect)
//! and splashes; [`RainPass::draw_mist`] lays the mist over the frame.
//!
//! The picture is the same in every run: the list of drops in view and the
//! splashes' ring are filled by stable compactions in the order of the
//! drops (CPU twins: [`visible_list`], [`splash_slots`]), so the streaks
//! and splashes are drawn, and blended, in the same order.

use crate::core::background::Deferred;
use crate::core::binding::PerViewGroups;
use crate::core::limits::LimitError;
use crate::scene::{FileStamp, RainBoxKind, RainSettings, Scene};
use crate::shader::{self, WgslFile};
use glam::Vec3;
use nimbus_physics::rain::drop_optics::DropTransfer;
use nimbus_physics::rain::wind::WindField;
use nimbus_physics::rain::zones::RainZones;

pub use nimbus_physics::rain::simulation::STEP_S;

mod compaction;
mod depth_occluder;
mod gpu_types;
mod node;
mod prepare;
mod resources;
mod settings;

pub use compaction::{
    GROUP_WORDS, exclusive_scan, group_masks, splash_slots, streak_in_view, visible_list,
};
pub use depth_occluder::{DepthOccluderUniform, MAX_GRID_VERTICES, depth_occluder_shader_source};
pub use gpu_types::{
    DropGpu, RainSegmentUniform, RainStepUniform, RainUniform, WindPrimitiveUniform,
    drops_per_buffer,
};
pub use settings::{mean_rain_direction, occlusion_from_world, rain_box, rain_params, rain_zones};

const RAIN_TYPES_WGSL: WgslFile = WgslFile {
    name: "passes/rain/rain_types.wgsl",
    source: include_str!("rain_types.wgsl"),
};
const SIMULATION_WGSL: WgslFile = WgslFile {
    name: "passes/rain/simulation.wgsl",
    source: include_str!("simulation.wgsl"),
};
const RANDOM_WGSL: WgslFile = WgslFile {
    name: "passes/rain/random.wgsl",
    source: include_str!("random.wgsl"),
};
const WIND_WGSL: WgslFile = WgslFile {
    name: "passes/rain/wind.wgsl",
    source: include_str!("wind.wgsl"),
};
const ZONES_WGSL: WgslFile = WgslFile {
    name: "passes/rain/zones.wgsl",
    source: include_str!("zones.wgsl"),
};
const RAIN_BOX_WGSL: WgslFile = WgslFile {
    name: "passes/rain/rain_box.wgsl",
    source: include_str!("rain_box.wgsl"),
};
/// The mist slab's light from its table (the CPU twin is
/// `nimbus_physics::rain::mist_slab::diffuse_source_in_mist`).
pub const MIST_SLAB_WGSL: WgslFile = WgslFile {
    name: "passes/rain/mist_slab.wgsl",
    source: include_str!("mist_slab.wgsl"),
};
/// The pass's own WGSL library: what its shaders import besides the crate's.
const LIBRARY: [WgslFile; 6] = [
    RAIN_TYPES_WGSL,
    RANDOM_WGSL,
    WIND_WGSL,
    ZONES_WGSL,
    RAIN_BOX_WGSL,
    MIST_SLAB_WGSL,
];

/// Composes `file` with what it imports of the pass's library and the crate's.
fn compose_with_library(file: WgslFile) -> String {
    shader::compose_with_library(&[file], &LIBRARY)
}
const VISIBILITY_WGSL: WgslFile = WgslFile {
    name: "passes/rain/visibility.wgsl",
    source: include_str!("visibility.wgsl"),
};
const STREAKS_WGSL: WgslFile = WgslFile {
    name: "passes/rain/streaks.wgsl",
    source: include_str!("streaks.wgsl"),
};
const MIST_WGSL: WgslFile = WgslFile {
    name: "passes/rain/mist.wgsl",
    source: include_str!("mist.wgsl"),
};
const OCCLUDERS_WGSL: WgslFile = WgslFile {
    name: "passes/rain/occluders.wgsl",
    source: include_str!("occluders.wgsl"),
};

/// The composed WGSL of the simulation (compute).
pub fn simulation_shader_source() -> String {
    compose_with_library(SIMULATION_WGSL)
}

/// The composed WGSL of the visibility list (compute).
pub fn visibility_shader_source() -> String {
    compose_with_library(VISIBILITY_WGSL)
}

fn drawing_files(last: WgslFile) -> String {
    compose_with_library(last)
}

/// The composed WGSL of the streaks and splashes.
pub fn streaks_shader_source() -> String {
    drawing_files(STREAKS_WGSL)
}

/// The composed WGSL of the mist.
pub fn mist_shader_source() -> String {
    drawing_files(MIST_WGSL)
}

/// The composed WGSL of the rain shadow map.
pub fn occluders_shader_source() -> String {
    shader::compose(&[OCCLUDERS_WGSL])
}

/// Texels per side of the rain shadow map.
pub const OCCLUSION_MAP_SIZE: u32 = 1024;
/// Splashes kept in the ring (older ones are overwritten).
pub const SPLASH_CAPACITY: u32 = 65_536;
/// Bytes of one splash record (WGSL `Splash`: impact point and time, the
/// drop's velocity and diameter; written and read on the GPU alone).
pub const SPLASH_BYTES: u64 = 32;
/// Bytes of one drop record (WGSL `Drop`, [`DropGpu`]).
const DROP_BYTES: u64 = std::mem::size_of::<DropGpu>() as u64;
/// Splash droplets per splash (`streaks.wgsl`'s `SPLASH_DROPLETS`).
pub const SPLASH_DROPLETS: u32 = 4;
/// Texels per side of the rain-zone map.
pub const ZONE_MAP_SIZE: u32 = 256;
/// Cells per side of the turbulence grid.
pub const TURBULENCE_CELLS: u32 = 32;
/// Height above the box covered by the rain shadow map (roofs, bridges,
/// trees above the camera shelter the rain too), m.
const OCCLUSION_REACH_ABOVE_M: f32 = 300.0;
/// Alignment of the per-step uniforms (WebGPU's minimum dynamic-offset alignment).
const STEP_STRIDE: u64 = 256;
/// Invocations per workgroup of the simulation and the cull (WGSL
/// `@workgroup_size` and `GROUP_SIZE`).
pub const WORKGROUP_SIZE: u32 = 256;
/// Workgroups along one dimension of a dispatch (WebGPU's default limit).
const MAX_WORKGROUPS_PER_DISPATCH: u32 = 65_535;

/// Why rain cannot be simulated on this device.
#[derive(Debug, thiserror::Error)]
pub enum RainError {
    /// The wind field's file no longer reads.
    #[error("{0}")]
    WindField(String),
    /// A buffer exceeds the device's limit.
    #[error(transparent)]
    Limit(#[from] LimitError),
}

/// What the drops' buffers and placement depend on: when it changes, the
/// rain starts anew. Everything else (the intensity, the mean wind and its
/// primitives, the ceiling, the zones, the streaks' look) changes from one
/// frame to the next without disturbing the drops: a rising intensity
/// revives drops at the box's upstream side, a falling one lets them die as
/// they leave (§4.2.2), and a larger count grows the buffers keeping the
/// drops in them.
#[derive(Clone, Debug, PartialEq)]
struct RainKey {
    box_shape: RainBoxKind,
    box_radius_m: f64,
    diameters_mm: [f64; 2],
    max_drops: u64,
    /// The wind grid's source: the turbulence's or the file's settings.
    turbulence: Option<crate::scene::TurbulenceSettings>,
    wind_field: Option<crate::scene::WindFieldSettings>,
    /// The wind field's file as last read (rewritten, it is read again).
    wind_field_file: Option<FileStamp>,
}

impl RainKey {
    fn new(scene: &Scene, settings: &RainSettings) -> Self {
        let wind = scene.wind.as_ref();
        let wind_field = wind.and_then(|w| w.field.clone());
        Self {
            box_shape: settings.box_shape,
            box_radius_m: settings.box_radius_m,
            diameters_mm: [settings.min_diameter_mm, settings.max_diameter_mm],
            max_drops: settings.max_drops,
            turbulence: wind.and_then(|w| w.turbulence.clone()),
            wind_field_file: wind_field
                .as_ref()
                .and_then(|f| FileStamp::of(&scene.resolve_path(&f.file))),
            wind_field,
        }
    }
}

/// What the map of rain zones depends on: rebuilt (on the CPU, uploaded)
/// when it changes, the drops untouched. Moving clouds count in steps of a
/// quarter of the map's texel, the stratus layer's evolution in 1/256 of
/// its evolution time, so that drifting clouds carry their rain along.
#[derive(Clone, Debug, PartialEq)]
struct ZonesKey {
    areas: Vec<crate::scene::RainAreaSettings>,
    under_clouds: bool,
    cloud_threshold_m: f64,
    stratus: Option<crate::scene::StratusSettings>,
    terrain_extent_m: f64,
    /// The stratus layer's drift and evolution, and the cumulus footprints,
    /// in the steps above.
    cloud_motion: Vec<i64>,
}

impl ZonesKey {
    fn new(
        scene: &Scene,
        settings: &RainSettings,
        time_s: f64,
        cumulus_footprints_m: &[[f32; 3]],
    ) -> Self {
        let stratus = scene.stratus.clone().filter(|_| settings.under_clouds);
        let step_m = scene.terrain.extent_m / ZONE_MAP_SIZE as f64 / 4.0;
        let steps = |x: f64| (x / step_m).round() as i64;
        let mut cloud_motion = Vec::new();
        if let Some(layer) = &stratus {
            let [x, z] = scene.cloud_drift_m(time_s);
            let evolution = (time_s / layer.evolution_time_s * 256.0).round() as i64;
            cloud_motion.extend([steps(x), steps(z), evolution]);
        }
        if settings.under_clouds {
            cloud_motion.extend(
                cumulus_footprints_m
                    .iter()
                    .flat_map(|c| c.map(|v| steps(v as f64))),
            );
        }
        Self {
            areas: settings.areas.clone(),
            under_clouds: settings.under_clouds,
            cloud_threshold_m: settings.cloud_threshold_m,
            stratus,
            terrain_extent_m: scene.terrain.extent_m,
            cloud_motion,
        }
    }
}

/// The rain shadow map's view, for deciding when to redraw it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct OcclusionView {
    centre_m: [i32; 3],
    direction: [f32; 3],
    /// The generations of the occluders (objects, terrain, the caller's).
    occluder_generations: [u64; 3],
}

/// One buffer's share of the drops: devices bind a limited number of bytes
/// per storage buffer (128 MiB on many), so millions of drops are split into
/// buffers that each fit, simulated, listed and drawn one after another.
struct DropSegment {
    /// Id of the buffer's first drop.
    first_drop: u32,
    /// Drops the buffer holds.
    capacity: u32,
    drops: wgpu::Buffer,
    /// Indices (into `drops`) of the drops in view.
    visible: wgpu::Buffer,
    /// Per workgroup of drops, a bit per drop ([`GROUP_WORDS`] words): the
    /// splashes of a step, then the drops in view; cleared before each
    /// frame's simulation.
    group_masks: wgpu::Buffer,
    /// The simulation's bindings, with `group_masks`.
    simulation_group: wgpu::BindGroup,
    /// The visibility list's bindings, with `group_masks` and the
    /// workgroups' first places in `visible`.
    visibility_group: wgpu::BindGroup,
}

impl DropSegment {
    /// Drops of this buffer among the first `dispatched`.
    fn dispatched(&self, dispatched: u32) -> u32 {
        dispatched
            .saturating_sub(self.first_drop)
            .min(self.capacity)
    }
}

/// The drops' buffers for a capacity, with their bind groups over the
/// rain's other buffers: what a larger count replaces.
struct DropBuffers {
    capacity: u32,
    segments: Vec<DropSegment>,
    /// Each segment's indirect draw arguments, `draw_args_stride` bytes apart.
    draw_args: wgpu::Buffer,
    draw_args_stride: u64,
    /// The streaks' and splashes' bind groups, one per segment, with the
    /// frame's depth: made once per depth view, not per frame.
    draw_groups: PerViewGroups<Vec<wgpu::BindGroup>>,
}

/// The rain's buffers besides the drops', which the drops' bind groups bind.
struct SharedBuffers {
    splashes: wgpu::Buffer,
    splash_head: wgpu::Buffer,
    wind_grid: wgpu::Buffer,
    zones: wgpu::Buffer,
    occlusion_view: wgpu::TextureView,
    /// The mist's bind group with the frame's depth, made once per depth view.
    mist_group: PerViewGroups<wgpu::BindGroup>,
}

struct RainState {
    key: RainKey,
    zones_key: ZonesKey,
    drops: DropBuffers,
    shared: SharedBuffers,
    zone_map: RainZones,
    wind: WindField,
    occlusion_drawn: Option<OcclusionView>,
    /// Drops dispatched: the largest count asked for since the start (drops
    /// above a lower count die as they leave, so they stay simulated).
    dispatched: u32,
    /// Simulated time, s.
    time_s: f32,
    /// Steps taken (keys the random numbers).
    step: u32,
    /// Camera at the last frame.
    camera_m: Vec3,
    forward: Vec3,
    warned_cap: bool,
}

impl std::fmt::Debug for RainState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RainState")
            .field("capacity", &self.drops.capacity)
            .field("buffers", &self.drops.segments.len())
            .field("dispatched", &self.dispatched)
            .field("time_s", &self.time_s)
            .finish_non_exhaustive()
    }
}

/// What one frame's encode does.
#[derive(Clone, Debug, Default)]
struct FramePlan {
    steps: Vec<RainStepUniform>,
    redraw_occlusion: bool,
}

/// The rain pass.
#[derive(Debug)]
pub struct RainPass {
    device: wgpu::Device,
    uniform: wgpu::Buffer,
    /// The mist slab's light, [`nimbus_physics::rain::mist_slab::MIST_SLAB_TABLE`].
    mist_slab: wgpu::Buffer,
    steps: wgpu::Buffer,
    occlusion_uniform: wgpu::Buffer,
    occlusion_group: wgpu::BindGroup,
    simulation_layout: wgpu::BindGroupLayout,
    visibility_layout: wgpu::BindGroupLayout,
    draw_layout: wgpu::BindGroupLayout,
    mist_layout: wgpu::BindGroupLayout,
    simulate: wgpu::ComputePipeline,
    /// The splashes of a step written to the ring in the drops' order.
    place_splashes: wgpu::ComputePipeline,
    /// The visibility list's three steps: mark, scan, scatter.
    cull: [wgpu::ComputePipeline; 3],
    streaks: wgpu::RenderPipeline,
    splash: wgpu::RenderPipeline,
    mist: wgpu::RenderPipeline,
    occluders_module: wgpu::ShaderModule,
    occluders_layout: wgpu::PipelineLayout,
    /// Rain shadow map pipelines, one per vertex stride of the occluders.
    occluders: Vec<(u64, wgpu::RenderPipeline)>,
    /// The rain-zone map of drifting clouds, made on a worker thread.
    zones_job: Deferred<ZonesKey, RainZones>,
    /// The caller's depth from above, drawn into the rain shadow map.
    depth_occluder: depth_occluder::DepthOccluderDraw,
    occlusion_texture: wgpu::Texture,
    state: Option<RainState>,
    plan: FramePlan,
    settings: Option<RainSettings>,
    /// A cap on the drops per buffer below the device's (see
    /// [`RainPass::set_drops_per_buffer_cap`]).
    drops_per_buffer_cap: Option<u32>,
    /// What a water drop refracts and reflects, for the streaks' shading.
    drop: DropTransfer,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_uniform_fills_the_dynamic_offset_stride() {
        assert_eq!(std::mem::size_of::<RainStepUniform>() as u64, STEP_STRIDE);
        assert_eq!(std::mem::size_of::<DropGpu>(), 32);
    }

    #[test]
    fn occlusion_view_maps_the_box_into_the_unit_square_along_the_rain() {
        let direction = Vec3::new(0.3, -1.0, 0.1).normalize();
        let centre = Vec3::new(100.0, 20.0, -40.0);
        let m = occlusion_from_world(centre, direction, 25.0, 300.0);
        let c = m.project_point3(centre);
        assert!(c.x.abs() < 1e-5 && c.y.abs() < 1e-5, "{c}");
        // Downstream is deeper.
        let below = m.project_point3(centre + direction * 10.0);
        assert!(below.z > c.z);
        assert!((0.0..=1.0).contains(&c.z));
    }
}
