//! GPU layouts of the cumulus uniform, vertices and instances, and the placement of a cloud in the world.

use super::variants::CumulusVertex;
use crate::scene::CumulusSettings;
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use nimbus_physics::atmosphere::AtmosphereParams;
use nimbus_physics::cumulus::forward_peak;
use nimbus_physics::cumulus::shading::LightTrapModel;

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
    /// α_δ (diffusion through the cores), α_p (forward peak), unused, unused.
    pub extension: [f32; 4],
    /// The forward-peak table's grid: θ_max (rad), τ_max, angles, depths.
    pub peak_grid: [f32; 4],
    /// The transport model: ln of the transfer's smallest scale, 1/ln of its
    /// largest over its smallest (0: one scale), δ-M's 1 − f (550 nm),
    /// texels of the phase table.
    pub transport: [f32; 4],
}

impl CumulusUniform {
    /// The uniform without the sun's radiance (`sun_at_base`'s colour,
    /// `sun_per_m`): what the shadow map's drawing reads of it.
    pub fn without_sun(&self) -> Self {
        Self {
            sun_at_base: [0.0, 0.0, 0.0, self.sun_at_base[3]],
            sun_per_m: [0.0; 4],
            ..*self
        }
    }

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
        let top = crate::frame::atmosphere::solar_irradiance_top();
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
            extension: [s.diffusion as f32, s.forward_peak as f32, 0.0, 0.0],
            peak_grid: [
                forward_peak::ANGLE_MAX_RAD as f32,
                forward_peak::DEPTH_MAX as f32,
                forward_peak::ANGLES as f32,
                forward_peak::DEPTHS as f32,
            ],
            transport: [0.0, 0.0, 1.0, PHASE_TEXELS as f32],
        }
    }
}

/// Texels of the transport model's phase table P_S over 0–180° (group 1,
/// binding 2; [`super::PHASE_TEXTURE`]).
pub const PHASE_TEXELS: usize = 512;

/// Lacunarity of the bump octaves: the hierarchy's radius ratio is 1/3.
pub const BUMP_LACUNARITY: f32 = 3.0;

/// A cloud as placed in the world: a variant's shape (object space: origin
/// at the centre of its base) scaled, turned about the vertical and moved:
/// world = base_centre + scale · R(yaw) · object, where
/// R(yaw)·(x, y, z) = (x cos yaw + z sin yaw, y, −x sin yaw + z cos yaw).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudPlacement {
    /// Index of the variant (see `VariantParams::hierarchy` in the pass's `variants` module).
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
    /// cos yaw, sin yaw, noise offset, and the mesh's fade as the in-cloud
    /// march takes the instance over (0 in the field's own data).
    pub rotation_noise: [f32; 4],
    /// Lower levels' mean radii and the bump's first wavelength, object m.
    pub radii_wavelength: [f32; 4],
}

pub(super) const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 6] = wgpu::vertex_attr_array![
    0 => Float32x4, 1 => Float32x4, 2 => Float32x4, 3 => Float32x4, 4 => Float32x4, 5 => Float32x4
];
pub(super) const INSTANCE_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![6 => Float32x4, 7 => Float32x4, 8 => Float32x4];

pub(super) const TRANSFER_ATTRIBUTES: [wgpu::VertexAttribute; 6] = wgpu::vertex_attr_array![
    9 => Float32x4, 10 => Float32x4, 11 => Float32x4, 12 => Float32x4, 13 => Float32x4, 14 => Float32x4
];

/// The camera's pipelines' buffers: the shadow map's plus the transport
/// model's transfer (buffer 2, per vertex).
pub(super) fn draw_vertex_layouts() -> [wgpu::VertexBufferLayout<'static>; 3] {
    let [vertices, instances] = vertex_layouts();
    [
        vertices,
        instances,
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<super::transfer::TransferVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &TRANSFER_ATTRIBUTES,
        },
    ]
}

pub(super) fn vertex_layouts() -> [wgpu::VertexBufferLayout<'static>; 2] {
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
