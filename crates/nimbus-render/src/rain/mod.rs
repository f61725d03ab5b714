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
//! and splashes; [`RainPass::encode_mist`] lays the mist over the frame.

use crate::binding::{self, buffer_entry, uniform_layout_entry};
use crate::frame::Camera;
use crate::occluders::OccluderGeometry;
use crate::renderer::{RenderError, Renderer};
use crate::scene::{FileStamp, RainBoxKind, RainSettings, Scene};
use crate::shader::{self, WgslFile};
use crate::targets::{DEPTH_FORMAT, HDR_FORMAT};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use nimbus_physics::rain::drag::terminal_speed_m_s_f32;
use nimbus_physics::rain::drop_optics::{DropTransfer, KERNEL_BINS};
use nimbus_physics::rain::dsd::mean_sampled_diameter_mm;
use nimbus_physics::rain::rain_box::{RainBox, RainBoxShape, orthonormal_basis};
use nimbus_physics::rain::simulation::{MAX_STEPS_PER_FRAME, RainParams, target_drop_count};
use nimbus_physics::rain::wind::{MAX_WIND_PRIMITIVES, WindField};
use nimbus_physics::rain::zones::{RainArea, RainZones, smoothstep};

pub use nimbus_physics::rain::simulation::STEP_S;

const RAIN_TYPES_WGSL: WgslFile = WgslFile {
    name: "rain/rain_types.wgsl",
    source: include_str!("rain_types.wgsl"),
};
const SIMULATION_WGSL: WgslFile = WgslFile {
    name: "rain/simulation.wgsl",
    source: include_str!("simulation.wgsl"),
};
const VISIBILITY_WGSL: WgslFile = WgslFile {
    name: "rain/visibility.wgsl",
    source: include_str!("visibility.wgsl"),
};
const STREAKS_WGSL: WgslFile = WgslFile {
    name: "rain/streaks.wgsl",
    source: include_str!("streaks.wgsl"),
};
const MIST_WGSL: WgslFile = WgslFile {
    name: "rain/mist.wgsl",
    source: include_str!("mist.wgsl"),
};
const OCCLUDERS_WGSL: WgslFile = WgslFile {
    name: "rain/occluders.wgsl",
    source: include_str!("occluders.wgsl"),
};

/// The composed WGSL of the simulation (compute).
pub fn simulation_shader_source() -> String {
    shader::compose(&[shader::COMMON, RAIN_TYPES_WGSL, SIMULATION_WGSL])
}

/// The composed WGSL of the visibility list (compute).
pub fn visibility_shader_source() -> String {
    shader::compose(&[shader::COMMON, RAIN_TYPES_WGSL, VISIBILITY_WGSL])
}

fn drawing_files(last: WgslFile) -> String {
    let mut files = shader::DRAWING_LIBRARIES.to_vec();
    files.extend(crate::stratus::DRAWING_LIBRARIES);
    files.extend([RAIN_TYPES_WGSL, last]);
    shader::compose(&files)
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
/// `@workgroup_size`).
const WORKGROUP_SIZE: u32 = 256;
/// Workgroups along one dimension of a dispatch (WebGPU's default limit).
const MAX_WORKGROUPS_PER_DISPATCH: u32 = 65_535;

/// GPU layout of a wind primitive (WGSL `WindPrimitive`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct WindPrimitiveUniform {
    /// Centre and kind.
    pub center: [f32; 4],
    /// Axis and speed.
    pub axis: [f32; 4],
    /// Drift and radius.
    pub drift: [f32; 4],
    /// Gust period and front speed.
    pub gust: [f32; 4],
}

/// GPU layout of the rain's per-frame uniform (WGSL `Rain`; see its fields' comments there).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct RainUniform {
    /// Camera right, box shape.
    pub box_right: [f32; 4],
    /// Camera up, frustum near.
    pub box_up: [f32; 4],
    /// Camera forward, frustum far.
    pub box_forward: [f32; 4],
    /// Box size and volume.
    pub box_size: [f32; 4],
    /// Camera angular velocity, bounding radius.
    pub box_angular_velocity: [f32; 4],
    /// Mean wind, wind grid spacing.
    pub wind_mean: [f32; 4],
    /// Intensity, diameters, ceiling.
    pub drops: [f32; 4],
    /// Zone map corner and texel, exposure time.
    pub zones: [f32; 4],
    /// Drops dispatched, capacity, primitives, 1 with a wind grid.
    pub counts: [u32; 4],
    /// Zone size, splash capacity, occlusion, splashes.
    pub flags: [u32; 4],
    /// The rain shadow map's clip from world.
    pub occlusion_from_world: [[f32; 4]; 4],
    /// Camera velocity, smallest streak width.
    pub camera_velocity: [f32; 4],
    /// Mist start and layer end, splash radius, mist on.
    pub mist: [f32; 4],
    /// The wind grid's points along x, y, z, and 1 when the mean wind carries it.
    pub wind_grid: [u32; 4],
    /// World position of the wind grid's point (0, 0, 0) at time 0, m.
    pub wind_grid_origin: [f32; 4],
    /// A drop's scale of the environment's SH bands 0, 1, 2 (and 0).
    pub drop_sh_weights: [f32; 4],
    /// A drop's kernel K(cos γ), sr⁻¹, in [`KERNEL_BINS`] bins.
    pub drop_kernel: [[f32; 4]; KERNEL_BINS / 4],
    /// Wind primitives.
    pub primitives: [WindPrimitiveUniform; MAX_WIND_PRIMITIVES],
}

/// GPU layout of one step (WGSL `RainStep`), padded to the dynamic-offset stride.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct RainStepUniform {
    /// Box centre at the step's end, and that time.
    pub box_center: [f32; 4],
    /// Box velocity, and the step length.
    pub box_velocity: [f32; 4],
    /// Step index, and 1 to place the drops anew.
    pub index: [u32; 4],
    /// Padding to 256 bytes.
    pub _padding: [u32; 52],
}

/// GPU layout of one drop (WGSL `Drop`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DropGpu {
    /// Position, m.
    pub position_m: [f32; 3],
    /// Diameter, mm.
    pub diameter_mm: f32,
    /// Velocity, m/s.
    pub velocity_m_s: [f32; 3],
    /// State (see [`nimbus_physics::rain::simulation::DropState`]).
    pub state: u32,
}

/// GPU layout of one drops' buffer's place among all drops (WGSL `RainSegment`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RainSegmentUniform {
    /// x: id of the buffer's first drop; y: drops the buffer holds.
    pub range: [u32; 4],
}

/// The most drops one buffer holds on `device`: what one storage binding
/// takes (drops of 32 bytes), at most what one dispatch's row of workgroups
/// reaches (65 535 × 256), in whole workgroups; `cap` lowers it further.
pub fn drops_per_buffer(limits: &wgpu::Limits, cap: Option<u32>) -> u32 {
    let bindable = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
        / DROP_BYTES;
    let most = bindable
        .min(MAX_WORKGROUPS_PER_DISPATCH as u64 * WORKGROUP_SIZE as u64)
        .min(cap.map_or(u64::MAX, u64::from));
    ((most / WORKGROUP_SIZE as u64) * WORKGROUP_SIZE as u64).max(WORKGROUP_SIZE as u64) as u32
}

/// Why rain cannot be simulated on this device.
#[derive(Debug, thiserror::Error)]
pub enum RainError {
    /// The wind field's file no longer reads.
    #[error("{0}")]
    WindField(String),
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
    objects_generation: u64,
    terrain: u64,
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
    simulation_group: wgpu::BindGroup,
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
}

/// The rain's buffers besides the drops', which the drops' bind groups bind.
struct SharedBuffers {
    splashes: wgpu::Buffer,
    splash_head: wgpu::Buffer,
    wind_grid: wgpu::Buffer,
    zones: wgpu::Buffer,
    occlusion_view: wgpu::TextureView,
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
    steps: wgpu::Buffer,
    occlusion_uniform: wgpu::Buffer,
    occlusion_group: wgpu::BindGroup,
    simulation_layout: wgpu::BindGroupLayout,
    visibility_layout: wgpu::BindGroupLayout,
    draw_layout: wgpu::BindGroupLayout,
    mist_layout: wgpu::BindGroupLayout,
    simulate: wgpu::ComputePipeline,
    cull: wgpu::ComputePipeline,
    streaks: wgpu::RenderPipeline,
    splash: wgpu::RenderPipeline,
    mist: wgpu::RenderPipeline,
    occluders_module: wgpu::ShaderModule,
    occluders_layout: wgpu::PipelineLayout,
    /// Rain shadow map pipelines, one per vertex stride of the occluders.
    occluders: Vec<(u64, wgpu::RenderPipeline)>,
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

fn compute_pipeline(
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

/// Premultiplied "over" blending.
const OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

/// dst·T + src: the mist's in-scattering over the attenuated frame.
const ATTENUATE_AND_ADD: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::SrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

#[allow(clippy::too_many_arguments)]
fn draw_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    vertex: &str,
    fragment: &str,
    layout: &wgpu::PipelineLayout,
    blend: wgpu::BlendState,
    depth: bool,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vertex),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fragment),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: HDR_FORMAT,
                blend: Some(blend),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: depth.then_some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    })
}

impl RainPass {
    /// Creates the pipelines; buffers are made by [`Self::prepare`] when a scene has rain.
    pub fn new(
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        atmosphere_layout: &wgpu::BindGroupLayout,
        stratus_layout: &wgpu::BindGroupLayout,
    ) -> Self {
        use wgpu::BufferBindingType::{Storage, Uniform};
        let compute = wgpu::ShaderStages::COMPUTE;
        let draw = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let uniform_size = std::mem::size_of::<RainUniform>() as u64;
        let step_size = std::mem::size_of::<RainStepUniform>() as u64;
        let segment_size = std::mem::size_of::<RainSegmentUniform>() as u64;
        let read = Storage { read_only: true };
        let write = Storage { read_only: false };
        let depth_texture =
            |binding: u32, visibility: wgpu::ShaderStages| wgpu::BindGroupLayoutEntry {
                binding,
                visibility,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
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
                buffer_entry(1, read, 4, wgpu::ShaderStages::FRAGMENT),
                depth_texture(2, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let simulate = compute_pipeline(
            device,
            "rain simulation",
            simulation_shader_source(),
            "simulate",
            &[Some(frame_layout), Some(&simulation_layout)],
        );
        let cull = compute_pipeline(
            device,
            "rain visibility",
            visibility_shader_source(),
            "cull",
            &[Some(frame_layout), Some(&visibility_layout)],
        );
        let streaks_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("rain streaks"),
            source: wgpu::ShaderSource::Wgsl(streaks_shader_source().into()),
        });
        let draw_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("rain draw"),
            bind_group_layouts: &[
                Some(frame_layout),
                Some(&draw_layout),
                Some(atmosphere_layout),
                Some(stratus_layout),
            ],
            immediate_size: 0,
        });
        let streaks = draw_pipeline(
            device,
            "rain streaks",
            &streaks_module,
            "streak_vertex_main",
            "streak_fragment",
            &draw_pipeline_layout,
            OVER,
            true,
        );
        let splash = draw_pipeline(
            device,
            "rain splashes",
            &streaks_module,
            "splash_vertex_main",
            "streak_fragment",
            &draw_pipeline_layout,
            OVER,
            true,
        );
        let mist_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("rain mist"),
            source: wgpu::ShaderSource::Wgsl(mist_shader_source().into()),
        });
        let mist_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("rain mist"),
            bind_group_layouts: &[
                Some(frame_layout),
                Some(&mist_layout),
                Some(atmosphere_layout),
                Some(stratus_layout),
            ],
            immediate_size: 0,
        });
        let mist = draw_pipeline(
            device,
            "rain mist",
            &mist_module,
            "mist_vertex",
            "mist_fragment",
            &mist_pipeline_layout,
            ATTENUATE_AND_ADD,
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
        Self {
            device: device.clone(),
            uniform,
            steps,
            occlusion_uniform,
            occlusion_group,
            simulation_layout,
            visibility_layout,
            draw_layout,
            mist_layout,
            simulate,
            cull,
            streaks,
            splash,
            mist,
            occluders_module,
            occluders_layout,
            occluders: Vec::new(),
            occlusion_texture,
            state: None,
            plan: FramePlan::default(),
            settings: None,
            drops_per_buffer_cap: None,
            drop: DropTransfer::water(),
        }
    }

    /// The rain shadow map's depth-only pipeline for vertices of `stride` bytes.
    fn occluder_pipeline(&self, device: &wgpu::Device, stride: u64) -> wgpu::RenderPipeline {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("rain shadow map"),
            layout: Some(&self.occluders_layout),
            vertex: wgpu::VertexState {
                module: &self.occluders_module,
                entry_point: Some("occluder_vertex"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: stride,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &crate::occluders::POSITION_ATTRIBUTES,
                })],
            },
            fragment: None,
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            multiview_mask: None,
            cache: None,
        })
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

/// The rain box of the scene's settings at the camera.
pub fn rain_box(settings: &RainSettings, camera: &Camera) -> RainBox {
    let forward = camera.forward.as_vec3();
    let right = forward.cross(camera.up.as_vec3()).normalize_or(Vec3::X);
    let up = right.cross(forward);
    let r = settings.box_radius_m as f32;
    let shape = match settings.box_shape {
        RainBoxKind::Sphere => RainBoxShape::Sphere { radius_m: r },
        RainBoxKind::Box => RainBoxShape::Box {
            half_extent_m: Vec3::splat(r),
        },
        RainBoxKind::Frustum => RainBoxShape::Frustum {
            near_m: crate::frame::NEAR_PLANE_M as f32,
            far_m: r,
            tan_half_fov_y: (0.5 * camera.fov_y_rad as f32).tan(),
            aspect: camera.aspect as f32,
        },
    };
    RainBox::at_rest(shape, camera.position_m.as_vec3(), [right, up, forward])
}

/// The physics crate's parameters of the scene's rain.
pub fn rain_params(scene: &Scene, settings: &RainSettings) -> RainParams {
    RainParams {
        intensity_mm_h: settings.intensity_mm_h as f32,
        min_diameter_mm: settings.min_diameter_mm as f32,
        max_diameter_mm: settings.max_diameter_mm as f32,
        max_drops: settings.max_drops.min(u32::MAX as u64) as u32,
        ceiling_m: scene.rain_ceiling_m() as f32,
    }
}

/// Where it rains: the scene's areas and, with `under_clouds`, where the
/// stratus layer is thicker than the threshold and under the cumulus'
/// footprints (given as (x, z, radius) in m), all with soft edges; rain
/// everywhere when the scene names neither.
pub fn rain_zones(
    scene: &Scene,
    settings: &RainSettings,
    time_s: f64,
    cumulus_footprints_m: &[[f32; 3]],
) -> RainZones {
    if settings.areas.is_empty() && !settings.under_clouds {
        return RainZones::everywhere();
    }
    let areas: Vec<RainArea> = settings
        .areas
        .iter()
        .map(|a| RainArea {
            center_m: [a.center_m[0] as f32, a.center_m[1] as f32],
            radius_m: a.radius_m as f32,
            edge_m: a.edge_m as f32,
        })
        .collect();
    let stratus = scene
        .stratus
        .as_ref()
        .filter(|_| settings.under_clouds)
        .map(|s| crate::stratus::cloud_layer_field(scene, s));
    let threshold = settings.cloud_threshold_m as f32;
    let cumulus: &[[f32; 3]] = if settings.under_clouds {
        cumulus_footprints_m
    } else {
        &[]
    };
    let side = scene.terrain.extent_m as f32;
    let drift = scene.cloud_drift_m(time_s);
    RainZones::from_fn([0.0, 0.0], side, ZONE_MAP_SIZE, |x, z| {
        let mut factor = areas
            .iter()
            .map(|a| a.factor_at(x, z))
            .fold(0.0f32, f32::max);
        if let Some(field) = &stratus {
            let h = field.thickness_with_drift_m(x as f64, z as f64, drift, time_s) as f32;
            // A soft edge over a third of the threshold (Puig-Centelles et al. 2009).
            factor = factor.max(smoothstep(threshold * 0.67, threshold, h));
        }
        for &[cx, cz, r] in cumulus {
            let d = ((x - cx).powi(2) + (z - cz).powi(2)).sqrt();
            factor = factor.max(1.0 - smoothstep(0.6 * r, r, d));
        }
        factor
    })
}

/// Mean direction of the rain (unit, world): the velocity of a drop of the
/// mean sampled diameter in the mean wind (Blanchard 2023, §4.2.5: the rain
/// shadow map is drawn along it).
pub fn mean_rain_direction(params: &RainParams, wind_mean_m_s: Vec3) -> Vec3 {
    let d = mean_sampled_diameter_mm(
        params.intensity_mm_h.max(0.1) as f64,
        params.min_diameter_mm as f64,
        params.max_diameter_mm as f64,
    ) as f32;
    (wind_mean_m_s - Vec3::Y * terminal_speed_m_s_f32(d)).normalize_or(Vec3::NEG_Y)
}

/// Clip space of the rain shadow map from world: an orthographic view along
/// `direction` of the square of side `2·radius` around `centre`, reaching
/// `reach_above` beyond the box on the upstream side. Depth 0 upstream, 1 downstream.
pub fn occlusion_from_world(
    centre: Vec3,
    direction: Vec3,
    radius_m: f32,
    reach_above_m: f32,
) -> Mat4 {
    let (right, up) = orthonormal_basis(direction);
    let eye = centre - direction * (radius_m + reach_above_m);
    let view = Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        direction.extend(0.0),
        Vec3::ZERO.extend(1.0),
    )
    .transpose()
        * Mat4::from_translation(-eye);
    let depth_range = 2.0 * radius_m + reach_above_m;
    // x, y in [−1, 1] over the square; z in [0, 1] along the rain.
    let projection = Mat4::from_cols_array(&[
        1.0 / radius_m,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0 / radius_m,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0 / depth_range,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
    ]);
    projection * view
}

impl RainPass {
    fn create_state(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        key: RainKey,
        capacity: u32,
        wind: WindField,
        (zones_key, zone_map): (ZonesKey, RainZones),
    ) -> RainState {
        use wgpu::util::DeviceExt;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let splashes = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain splashes"),
            size: SPLASH_CAPACITY as u64 * SPLASH_BYTES,
            usage: storage,
            mapped_at_creation: false,
        });
        queue.write_buffer(
            &splashes,
            0,
            &vec![0u8; (SPLASH_CAPACITY as u64 * SPLASH_BYTES) as usize],
        );
        let splash_head = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rain splash head"),
            contents: bytemuck::bytes_of(&0u32),
            usage: storage,
        });
        let grid_data: Vec<[f32; 4]> = wind
            .grid
            .as_ref()
            .map(|t| t.velocities_m_s.clone())
            .unwrap_or_else(|| vec![[0.0; 4]]);
        let wind_grid = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rain wind grid"),
            contents: bytemuck::cast_slice(&grid_data),
            usage: storage,
        });
        // Room for the largest map, so that a new map needs no new bindings.
        let zones = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain zones"),
            size: ZONE_MAP_SIZE as u64 * ZONE_MAP_SIZE as u64 * 4,
            usage: storage,
            mapped_at_creation: false,
        });
        queue.write_buffer(&zones, 0, bytemuck::cast_slice(&zone_map.factors));
        let shared = SharedBuffers {
            splashes,
            splash_head,
            wind_grid,
            zones,
            occlusion_view: self.occlusion_texture.create_view(&Default::default()),
        };
        RainState {
            key,
            zones_key,
            drops: self.create_drop_buffers(device, &shared, capacity),
            shared,
            zone_map,
            wind,
            occlusion_drawn: None,
            dispatched: 0,
            time_s: f32::NEG_INFINITY,
            step: 0,
            camera_m: Vec3::ZERO,
            forward: Vec3::NEG_Z,
            warned_cap: false,
        }
    }

    /// Buffers for `capacity` drops, split by [`drops_per_buffer`], bound
    /// with the rain's other buffers.
    fn create_drop_buffers(
        &self,
        device: &wgpu::Device,
        shared: &SharedBuffers,
        capacity: u32,
    ) -> DropBuffers {
        use wgpu::util::DeviceExt;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let per_buffer = drops_per_buffer(&device.limits(), self.drops_per_buffer_cap);
        let buffers = capacity.max(1).div_ceil(per_buffer);
        let draw_args_stride = (device.limits().min_storage_buffer_offset_alignment as u64).max(16);
        let draw_args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain draw arguments"),
            size: draw_args_stride * buffers as u64,
            usage: storage | wgpu::BufferUsages::INDIRECT,
            mapped_at_creation: false,
        });
        let segments = (0..buffers)
            .map(|index| {
                let first_drop = index * per_buffer;
                let held = per_buffer.min(capacity.max(1) - first_drop);
                let drops = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("rain drops"),
                    size: held as u64 * DROP_BYTES,
                    usage: storage | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let visible = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("rain visible drops"),
                    size: held as u64 * 4,
                    usage: storage,
                    mapped_at_creation: false,
                });
                let segment = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("rain drops' range"),
                    contents: bytemuck::bytes_of(&RainSegmentUniform {
                        range: [first_drop, held, 0, 0],
                    }),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                let simulation_group = binding::sequential_bind_group(
                    device,
                    "rain simulation",
                    &self.simulation_layout,
                    vec![
                        self.uniform.as_entire_binding(),
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &self.steps,
                            offset: 0,
                            size: wgpu::BufferSize::new(
                                std::mem::size_of::<RainStepUniform>() as u64
                            ),
                        }),
                        drops.as_entire_binding(),
                        shared.wind_grid.as_entire_binding(),
                        shared.zones.as_entire_binding(),
                        wgpu::BindingResource::TextureView(&shared.occlusion_view),
                        shared.splashes.as_entire_binding(),
                        shared.splash_head.as_entire_binding(),
                        segment.as_entire_binding(),
                    ],
                );
                let visibility_group = binding::sequential_bind_group(
                    device,
                    "rain visibility",
                    &self.visibility_layout,
                    vec![
                        self.uniform.as_entire_binding(),
                        drops.as_entire_binding(),
                        visible.as_entire_binding(),
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &draw_args,
                            offset: index as u64 * draw_args_stride,
                            size: wgpu::BufferSize::new(16),
                        }),
                        segment.as_entire_binding(),
                    ],
                );
                DropSegment {
                    first_drop,
                    capacity: held,
                    drops,
                    visible,
                    simulation_group,
                    visibility_group,
                }
            })
            .collect();
        DropBuffers {
            capacity,
            segments,
            draw_args,
            draw_args_stride,
        }
    }

    /// Replaces the drops' buffers by ones for `capacity` drops, copying
    /// the drops over: the rain goes on where it was, the new drops dead
    /// until they enter at the box's upstream side.
    fn grow_drop_buffers(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, capacity: u32) {
        let Some(state) = &self.state else { return };
        let grown = self.create_drop_buffers(device, &state.shared, capacity);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("rain buffers grown"),
        });
        // Buffers hold the same drops per buffer whatever the capacity:
        // buffer i of the old drops goes to the start of buffer i.
        for (from, to) in state.drops.segments.iter().zip(&grown.segments) {
            encoder.copy_buffer_to_buffer(&from.drops, 0, &to.drops, 0, from.drops.size());
        }
        queue.submit([encoder.finish()]);
        if let Some(state) = &mut self.state {
            state.drops = grown;
        }
    }

    /// Updates the simulation's inputs for a frame at `time_s`: the steps
    /// to run since the last frame, the box, wind and zones, and whether
    /// the rain shadow map must be redrawn.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        camera: &Camera,
        time_s: f32,
        cumulus_footprints_m: &[[f32; 3]],
        occluder_generation: (u64, u64),
        occluder_strides: &[u64],
    ) -> Result<(), RenderError> {
        for &stride in occluder_strides {
            if !self.occluders.iter().any(|(s, _)| *s == stride) {
                let pipeline = self.occluder_pipeline(device, stride);
                self.occluders.push((stride, pipeline));
            }
        }
        let Some(settings) = scene.rain.clone() else {
            self.settings = None;
            self.state = None;
            return Ok(());
        };
        let key = RainKey::new(scene, &settings);
        let params = rain_params(scene, &settings);
        let mut rain_box = rain_box(&settings, camera);
        let volume = rain_box.volume_m3();
        let max_drops = settings.max_drops.min(u32::MAX as u64) as u32;
        let target = target_drop_count(&params, params.intensity_mm_h, volume);
        // Buffers for the drops this intensity asks for with a margin, up to
        // the cap; a larger count later grows them, keeping the drops.
        let capacity = ((target as u64 * 5 / 4).max(4096) as u32).min(max_drops);
        let zones_key = ZonesKey::new(scene, &settings, time_s as f64, cumulus_footprints_m);
        let zone_map = || rain_zones(scene, &settings, time_s as f64, cumulus_footprints_m);
        if self.state.as_ref().map(|s| &s.key) != Some(&key) {
            self.state = None;
            let wind = scene.wind_field().map_err(RainError::WindField)?;
            if let Some(grid) = &wind.grid {
                let bytes = std::mem::size_of_val(grid.velocities_m_s.as_slice()) as u64;
                Renderer::check_buffer_size(device, "wind.field.file", bytes)?;
            }
            let zones = (zones_key.clone(), zone_map());
            self.state = Some(self.create_state(device, queue, key, capacity, wind, zones));
        } else if self
            .state
            .as_ref()
            .is_some_and(|s| target > s.drops.capacity && s.drops.capacity < max_drops)
        {
            self.grow_drop_buffers(device, queue, capacity);
        }
        self.settings = Some(settings.clone());
        let Some(state) = self.state.as_mut() else {
            return Ok(());
        };
        // The wind's mean and primitives follow the scene (keyframed wind);
        // its grid is the key's.
        let wind = scene
            .wind
            .as_ref()
            .map(crate::scene::WindSettings::field_without_grid)
            .unwrap_or_default();
        state.wind.mean_m_s = wind.mean_m_s;
        state.wind.primitives = wind.primitives;
        if state.zones_key != zones_key {
            state.zone_map = zone_map();
            let factors = bytemuck::cast_slice(&state.zone_map.factors);
            queue.write_buffer(&state.shared.zones, 0, factors);
            state.zones_key = zones_key;
        }
        let wanted = nimbus_physics::rain::simulation::expected_drop_count(
            params.intensity_mm_h,
            params.min_diameter_mm,
            volume,
        );
        if wanted > max_drops as f64 && !state.warned_cap {
            eprintln!(
                "nimbus: warning: {} mm/h in a {:.0} m³ rain box asks for {wanted:.0} drops; capped at rain.max_drops = {max_drops}",
                settings.intensity_mm_h, volume
            );
            state.warned_cap = true;
        }
        // Start anew on the first frame, when time runs backwards, or when
        // the camera jumps farther than the box.
        let jumped = (rain_box.center_m - state.camera_m).length() > rain_box.bounding_radius_m();
        let restart = !state.time_s.is_finite() || time_s < state.time_s - STEP_S || jumped;
        let mut steps: Vec<RainStepUniform> = Vec::new();
        // Time since the last frame (none after a restart: the box does not move).
        let frame_dt = if restart { 0.0 } else { time_s - state.time_s };
        if restart {
            state.dispatched = target;
            // Place the drops a few steps early, so that splashes are under
            // way in the first frame.
            let warm_up = MAX_STEPS_PER_FRAME - 1;
            state.time_s = time_s - warm_up as f32 * STEP_S;
            state.camera_m = rain_box.center_m;
            state.forward = rain_box.basis[2];
            state.step += 1;
            steps.push(step_uniform(&rain_box, state.time_s, state.step, true));
            queue.write_buffer(&state.shared.splash_head, 0, bytemuck::bytes_of(&0u32));
            queue.write_buffer(
                &state.shared.splashes,
                0,
                &vec![0u8; (SPLASH_CAPACITY as u64 * SPLASH_BYTES) as usize],
            );
        } else {
            state.dispatched = state.dispatched.max(target);
            // The box moves and turns with the camera between frames.
            if frame_dt > 0.0 {
                rain_box.velocity_m_s = (rain_box.center_m - state.camera_m) / frame_dt;
                let turn = state.forward.cross(rain_box.basis[2]);
                let angle = state.forward.dot(rain_box.basis[2]).clamp(-1.0, 1.0).acos();
                rain_box.angular_velocity_rad_s = turn.normalize_or_zero() * (angle / frame_dt);
            }
        }
        let available = ((time_s - state.time_s) / STEP_S).floor().max(0.0) as u32;
        let count = available.min(MAX_STEPS_PER_FRAME - steps.len() as u32);
        if available > count {
            // A long gap (a slow frame, a jump in an animation): skip time.
            state.time_s = time_s - count as f32 * STEP_S;
        }
        let start_m = state.camera_m;
        let start_time = state.time_s;
        for k in 1..=count {
            let t = start_time + k as f32 * STEP_S;
            let fraction = if frame_dt > 0.0 {
                ((t - (time_s - frame_dt)) / frame_dt).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let mut b = rain_box;
            b.center_m = start_m.lerp(rain_box.center_m, fraction);
            state.step += 1;
            steps.push(step_uniform(&b, t, state.step, false));
        }
        state.time_s = start_time + count as f32 * STEP_S;
        state.camera_m = rain_box.center_m;
        state.forward = rain_box.basis[2];
        for (i, s) in steps.iter().enumerate() {
            queue.write_buffer(&self.steps, i as u64 * STEP_STRIDE, bytemuck::bytes_of(s));
        }
        // The rain shadow map: redrawn when the rain's direction, the box's
        // neighbourhood (snapped to a quarter of its radius) or the scene changes.
        let direction = mean_rain_direction(&params, state.wind.mean_m_s);
        let snap = (rain_box.bounding_radius_m() * 0.25).max(1.0);
        let snapped = (rain_box.center_m / snap).round();
        let view = OcclusionView {
            centre_m: [snapped.x as i32, snapped.y as i32, snapped.z as i32],
            direction: direction.to_array(),
            objects_generation: occluder_generation.0,
            terrain: occluder_generation.1,
        };
        let redraw_occlusion = state.occlusion_drawn != Some(view);
        let occlusion_radius = rain_box.bounding_radius_m() * 1.25 + snap;
        let occlusion = occlusion_from_world(
            snapped * snap,
            direction,
            occlusion_radius,
            OCCLUSION_REACH_ABOVE_M,
        );
        if redraw_occlusion {
            queue.write_buffer(
                &self.occlusion_uniform,
                0,
                bytemuck::bytes_of(&occlusion.to_cols_array_2d()),
            );
            state.occlusion_drawn = Some(view);
        }
        let uniform = rain_uniform(
            &settings, &params, &rain_box, state, camera, occlusion, &self.drop,
        );
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        // The indirect draws' arguments: 6 vertices, instances counted by the cull.
        for index in 0..state.drops.segments.len() as u64 {
            queue.write_buffer(
                &state.drops.draw_args,
                index * state.drops.draw_args_stride,
                bytemuck::cast_slice(&[6u32, 0, 0, 0]),
            );
        }
        self.plan = FramePlan {
            steps,
            redraw_occlusion,
        };
        Ok(())
    }

    /// Records the rain shadow map (when it must be redrawn), the
    /// simulation's steps and the visibility list.
    pub fn encode_simulation(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &wgpu::BindGroup,
        occluders: &[OccluderGeometry<'_>],
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let Some(state) = &self.state else { return };
        if self.plan.redraw_occlusion {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("rain shadow map"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &state.shared.occlusion_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.occlusion_group, &[]);
            for geometry in occluders {
                let pipeline = self
                    .occluders
                    .iter()
                    .find(|(stride, _)| *stride == geometry.vertex_stride);
                if let Some((_, pipeline)) = pipeline {
                    pass.set_pipeline(pipeline);
                    geometry.draw(&mut pass);
                }
            }
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("rain simulation"),
            timestamp_writes: timestamps,
        });
        // Workgroups per buffer (a buffer holds at most one dispatch row's).
        let groups: Vec<(&DropSegment, u32)> = state
            .drops
            .segments
            .iter()
            .map(|segment| {
                let drops = segment.dispatched(state.dispatched);
                (segment, drops.div_ceil(WORKGROUP_SIZE))
            })
            .filter(|&(_, groups)| groups > 0)
            .collect();
        pass.set_pipeline(&self.simulate);
        pass.set_bind_group(0, frame, &[]);
        for i in 0..self.plan.steps.len() {
            for &(segment, groups) in &groups {
                pass.set_bind_group(
                    1,
                    &segment.simulation_group,
                    &[(i as u64 * STEP_STRIDE) as u32],
                );
                pass.dispatch_workgroups(groups, 1, 1);
            }
        }
        pass.set_pipeline(&self.cull);
        pass.set_bind_group(0, frame, &[]);
        for &(segment, groups) in &groups {
            pass.set_bind_group(1, &segment.visibility_group, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
    }

    /// The bind group of the draws of one drops' buffer, with the frame's
    /// depth (read-only).
    fn draw_group(
        &self,
        state: &RainState,
        segment: &DropSegment,
        depth: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        binding::sequential_bind_group(
            &self.device,
            "rain draw",
            &self.draw_layout,
            vec![
                self.uniform.as_entire_binding(),
                segment.drops.as_entire_binding(),
                segment.visible.as_entire_binding(),
                state.shared.splashes.as_entire_binding(),
                wgpu::BindingResource::TextureView(depth),
            ],
        )
    }

    /// Draws the streaks and splashes into `pass` (whose depth attachment is
    /// `depth`, read-only: the streaks fade where they meet surfaces).
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        depth: &wgpu::TextureView,
        [frame, atmosphere, stratus]: [&wgpu::BindGroup; 3],
    ) {
        let Some(state) = &self.state else {
            return;
        };
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(2, atmosphere, &[]);
        pass.set_bind_group(3, stratus, &[]);
        pass.set_pipeline(&self.streaks);
        for (index, segment) in state.drops.segments.iter().enumerate() {
            if index > 0 && segment.dispatched(state.dispatched) == 0 {
                break;
            }
            pass.set_bind_group(1, &self.draw_group(state, segment, depth), &[]);
            pass.draw_indirect(
                &state.drops.draw_args,
                index as u64 * state.drops.draw_args_stride,
            );
        }
        if self.settings.as_ref().is_some_and(|s| s.splashes) {
            // The splashes read no drops: the last buffer's group, still
            // bound, serves them.
            pass.set_pipeline(&self.splash);
            pass.draw(0..6, 0..SPLASH_CAPACITY * SPLASH_DROPLETS);
        }
    }

    /// Draws the mist over the frame (full screen, no depth attachment; the
    /// frame's depth is read as a texture).
    pub fn draw_mist(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        depth: &wgpu::TextureView,
        [frame, atmosphere, stratus]: [&wgpu::BindGroup; 3],
    ) {
        let Some(state) = &self.state else { return };
        let group = binding::sequential_bind_group(
            &self.device,
            "rain mist",
            &self.mist_layout,
            vec![
                self.uniform.as_entire_binding(),
                state.shared.zones.as_entire_binding(),
                wgpu::BindingResource::TextureView(depth),
            ],
        );
        pass.set_pipeline(&self.mist);
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(1, &group, &[]);
        pass.set_bind_group(2, atmosphere, &[]);
        pass.set_bind_group(3, stratus, &[]);
        pass.draw(0..3, 0..1);
    }
}

fn step_uniform(b: &RainBox, time_s: f32, index: u32, initialise: bool) -> RainStepUniform {
    RainStepUniform {
        box_center: b.center_m.extend(time_s).to_array(),
        box_velocity: b.velocity_m_s.extend(STEP_S).to_array(),
        index: [index, initialise as u32, 0, 0],
        _padding: [0; 52],
    }
}

fn rain_uniform(
    settings: &RainSettings,
    params: &RainParams,
    rain_box: &RainBox,
    state: &RainState,
    camera: &Camera,
    occlusion: Mat4,
    drop: &DropTransfer,
) -> RainUniform {
    let [right, up, forward] = rain_box.basis;
    let (shape, near, far, size) = match rain_box.shape {
        RainBoxShape::Sphere { radius_m } => (0.0, 0.0, 0.0, Vec3::new(radius_m, 0.0, 0.0)),
        RainBoxShape::Box { half_extent_m } => (1.0, 0.0, 0.0, half_extent_m),
        RainBoxShape::Frustum {
            near_m,
            far_m,
            tan_half_fov_y,
            aspect,
        } => (2.0, near_m, far_m, Vec3::new(tan_half_fov_y, aspect, 0.0)),
    };
    let wind = &state.wind;
    let mut primitives = [WindPrimitiveUniform::default(); MAX_WIND_PRIMITIVES];
    for (gpu, p) in primitives.iter_mut().zip(&wind.primitives) {
        let [center, axis, drift, gust] = p.to_gpu();
        *gpu = WindPrimitiveUniform {
            center,
            axis,
            drift,
            gust,
        };
    }
    let grid = wind.grid.as_ref();
    let zones = &state.zone_map;
    // The first mist layer ends where the largest drops' streaks shrink below a pixel.
    let pixel_angle = (2.0 * (0.5 * camera.fov_y_rad).tan() / camera.height_px as f64) as f32;
    let longest_streak_m =
        terminal_speed_m_s_f32(params.max_diameter_mm) * settings.exposure_s as f32;
    let layer_end = (longest_streak_m / pixel_angle).max(rain_box.bounding_radius_m());
    RainUniform {
        box_right: right.extend(shape).to_array(),
        box_up: up.extend(near).to_array(),
        box_forward: forward.extend(far).to_array(),
        box_size: size.extend(rain_box.volume_m3()).to_array(),
        box_angular_velocity: rain_box
            .angular_velocity_rad_s
            .extend(rain_box.bounding_radius_m())
            .to_array(),
        wind_mean: wind
            .mean_m_s
            .extend(grid.map_or(1.0, |g| g.cell_m))
            .to_array(),
        drops: [
            params.intensity_mm_h,
            params.min_diameter_mm,
            params.max_diameter_mm,
            params.ceiling_m.min(1e9),
        ],
        zones: [
            zones.origin_m[0],
            zones.origin_m[1],
            zones.texel_m,
            settings.exposure_s as f32,
        ],
        counts: [
            state.dispatched,
            state.drops.capacity,
            wind.primitives.len().min(MAX_WIND_PRIMITIVES) as u32,
            u32::from(grid.is_some()),
        ],
        flags: [zones.size, SPLASH_CAPACITY, 1, settings.splashes as u32],
        occlusion_from_world: occlusion.to_cols_array_2d(),
        camera_velocity: rain_box
            .velocity_m_s
            .extend(settings.min_streak_width_px as f32)
            .to_array(),
        mist: [
            rain_box.bounding_radius_m(),
            layer_end,
            settings.splash_radius_m as f32,
            settings.mist as u32 as f32,
        ],
        wind_grid: grid.map_or([0; 4], |g| {
            [g.cells[0], g.cells[1], g.cells[2], u32::from(g.carried)]
        }),
        wind_grid_origin: grid.map_or([0.0; 4], |g| g.origin_m.extend(0.0).to_array()),
        drop_sh_weights: [
            drop.band_weights[0] as f32,
            drop.band_weights[1] as f32,
            drop.band_weights[2] as f32,
            0.0,
        ],
        drop_kernel: std::array::from_fn(|i| {
            std::array::from_fn(|k| drop.kernel_per_sr[4 * i + k] as f32)
        }),
        primitives,
    }
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
