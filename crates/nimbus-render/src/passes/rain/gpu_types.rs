//! GPU layouts of the rain's uniforms and drops (twins of `rain_types.wgsl`), and how many drops a buffer holds.

use super::{DROP_BYTES, MAX_WORKGROUPS_PER_DISPATCH, WORKGROUP_SIZE};
use bytemuck::{Pod, Zeroable};
use nimbus_physics::rain::drop_optics::KERNEL_BINS;
use nimbus_physics::rain::wind::MAX_WIND_PRIMITIVES;

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
    /// The ground's height under the camera, m, and its albedo around it.
    pub mist_ground: [f32; 4],
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
