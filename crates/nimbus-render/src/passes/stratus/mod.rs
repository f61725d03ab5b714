//! Stratus pass: a stratiform cloud layer after Bouthors, Neyret & Lefebvre
//! (2006), with ground–cloud radiosity.
//!
//! Per frame, on the GPU:
//! 1. `thickness_field` (compute): the layer's thickness over a square window
//!    around the camera, evaluated from the procedural field
//!    ([`nimbus_physics::cloud_layer`]) at the frame's time, so the
//!    wind-advected layer animates without uploads.
//! 2. `radiosity_inputs` (compute): ρ_C, S_C and the shadowed sun light S_G^d
//!    over the radiosity grid (texels as large as the layer is high, §5.3),
//!    each the mean over 4 × 4 columns of the texel (the sun's light by
//!    columns tilted along its beam), then the [`RadiosityPass`] iterations.
//! 3. The drawing passes read the layer through the frame's group 3
//!    ([`crate::frame::cloud_lighting`], whose layer-sized parts this pass
//!    hands in): the terrain's sun light is shadowed by T_C at the sun ray's
//!    crossing of the layer and its indirect light is R_G.
//! 4. `layer` (draw): a grid over the window displaced to the face the
//!    camera sees, shaded per pixel by the analytic slab model (single,
//!    double, 3+ scattering, the forward peak, sky and ground light) and
//!    blended with alpha 1 − τ(H_v).
//! 5. `stratus_in_layer` (only with the camera inside a cell, or within
//!    [`IN_LAYER_HANDOVER_M`] of its top or base; from every camera with
//!    `stratus.model = "volume"`): the layer marched from where each ray
//!    first enters a cell as the volume it stands for, lit by its cells'
//!    diffusion light ([`nimbus_physics::transport::diffusion`]), over
//!    everything (from below the layer with `"volume"`: where the faces
//!    are drawn, under the rain's mist); the faces (or the level view) fade
//!    out as the march takes over.
//!
//! The phase tables (P_S, P², P_F per RGB channel) come from
//! [`nimbus_physics::optics::tables::CloudOpticsTables`], computed from the scene's droplet distribution and
//! cached on disk ([`optics_cache_dir`]).

pub mod radiosity;

use crate::core::background::Deferred;
use crate::passes::stratus::radiosity::{RadiosityError, RadiosityPass};
use crate::scene::StratusSettings;
use crate::shader::{self, WgslFile};
use nimbus_physics::optics::tables::{CloudOpticsParams, CloudOpticsTables};
use std::sync::Arc;

pub use crate::frame::cloud_lighting::{PEAK_TEXELS, PHASE_TEXELS, StratusUniform};

pub use crate::shader::{CLOUD_LAYER_FIELD as FIELD, CLOUD_LAYER_LOOKUP as LOOKUP};
const LAYER_WGSL: WgslFile = WgslFile {
    name: "passes/stratus/layer.wgsl",
    source: include_str!("layer.wgsl"),
};
const IN_LAYER_WGSL: WgslFile = WgslFile {
    name: "passes/stratus/in_layer.wgsl",
    source: include_str!("in_layer.wgsl"),
};
const COMPUTE_WGSL: WgslFile = WgslFile {
    name: "passes/stratus/compute.wgsl",
    source: include_str!("compute.wgsl"),
};

/// The files a drawing pass that reads the layer appends after
/// [`shader::DRAWING_LIBRARIES`].
pub const DRAWING_LIBRARIES: [WgslFile; 2] = [FIELD, LOOKUP];

/// The composed WGSL of the layer's draw.
pub fn layer_shader_source() -> String {
    shader::compose(&[LAYER_WGSL])
}

/// The composed WGSL of the in-layer march.
pub fn in_layer_shader_source() -> String {
    shader::compose(&[IN_LAYER_WGSL])
}

/// Distance from a cell's top or base over which the layer's faces hand
/// over to the in-layer march, m: the march's weight rises from 0 that far
/// above the top (below the base) of the cell over the camera to 1 on it.
pub const IN_LAYER_HANDOVER_M: f64 = 100.0;

/// The composed WGSL of the pass's compute shaders.
pub fn compute_shader_source() -> String {
    shader::compose(&[COMPUTE_WGSL])
}

pub use crate::scene::cloud_layer_field;

mod grid;
mod node;
mod optics;
mod prepare;
mod resources;

pub use grid::RadiosityGrid;
pub use optics::{forward_peak_mean_square_rad2, load_optics, optics_cache_dir, optics_params};

pub use crate::frame::cloud_lighting::FORWARD_PEAK_DEG;
/// Largest radiosity grid, texels per side.
pub const MAX_RADIOSITY_SIZE: u32 = 256;
/// Smallest height of the layer above the ground used for the radiosity
/// texel size, m.
pub const MIN_RADIOSITY_TEXEL_M: f64 = 100.0;

/// What the GPU resources were built for; rebuilt when it changes.
#[derive(Clone, Debug, PartialEq)]
struct ResourceKey {
    resolution: u32,
    /// The layer's mid-plane height, m: with the terrain, it sets the radiosity grid.
    mid_plane_m: Option<f64>,
    optics: Option<CloudOpticsParams>,
    terrain: Option<nimbus_physics::terrain::TerrainParams>,
}

/// GPU resources for one [`ResourceKey`].
#[derive(Debug)]
struct Resources {
    key: ResourceKey,
    /// The radiosity grid of the layer over the terrain (None without a layer).
    grid: Option<RadiosityGrid>,
    radiosity: RadiosityPass,
    compute_group: wgpu::BindGroup,
    thickness: wgpu::Texture,
    /// Its view, the same for the compute that writes it and group 3.
    thickness_view: wgpu::TextureView,
    indices: wgpu::Buffer,
    index_count: u32,
    /// Per-channel optics of the current tables: κ, P_f, ⟨θ²⟩ of P_F.
    optics: Option<([f32; 3], [f32; 3], [f32; 3])>,
}

/// The stratus pass.
#[derive(Debug)]
pub struct StratusPass {
    /// The layer's uniform, owned by the frame's cloud lighting.
    uniform: wgpu::Buffer,
    compute_layout: wgpu::BindGroupLayout,
    thickness_pipeline: wgpu::ComputePipeline,
    inputs_pipeline: wgpu::ComputePipeline,
    layer_pipeline: wgpu::RenderPipeline,
    /// The layer seen by a camera level with it (full screen, marched).
    level_pipeline: wgpu::RenderPipeline,
    /// The same without writing the entry's depth (while the in-layer
    /// march fades in).
    level_blend_pipeline: wgpu::RenderPipeline,
    /// The layer marched from a camera in (or near) a cell.
    in_layer_pipeline: wgpu::RenderPipeline,
    in_layer_layout: wgpu::BindGroupLayout,
    /// Group 1 of the march (the depth it reads), per depth view.
    in_layer_groups: crate::core::binding::PerViewGroups<wgpu::BindGroup>,
    device: wgpu::Device,
    resources: Option<Resources>,
    /// The scene's layer, when it has one.
    settings: Option<StratusSettings>,
    /// The uniform as last written.
    current: StratusUniform,
    /// The camera's height this frame, m.
    camera_height_m: f64,
    /// The in-layer march's weight this frame (0: not drawn, 1: the faces
    /// not drawn).
    in_layer_weight: f32,
    /// The layer's droplet optics (Mie tables; seconds when not cached).
    optics_tables: Deferred<CloudOpticsParams, Arc<CloudOpticsTables>>,
}

/// Errors of the pass.
#[derive(Debug, thiserror::Error)]
pub enum StratusError {
    /// The radiosity grid could not be built.
    #[error(transparent)]
    Radiosity(#[from] RadiosityError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use nimbus_physics::terrain::{TerrainParams, generate};

    #[test]
    fn radiosity_grid_covers_the_terrain_with_texels_the_layer_height() {
        let terrain = generate(&TerrainParams {
            resolution: 32,
            ..Default::default()
        });
        let grid = RadiosityGrid::new(&terrain, 2500.0);
        assert!(grid.size.is_power_of_two());
        assert!(grid.size as f64 * grid.texel_m >= terrain.params.extent_m);
        assert!((grid.texel_m - (2500.0 - grid.ground_height_m)).abs() < 1e-9);
        let rho = grid.ground_reflectance(&terrain);
        assert_eq!(rho.len(), (grid.size * grid.size) as usize);
        assert!(rho.iter().flatten().all(|r| (0.0..=1.0).contains(r)));
    }

    #[test]
    fn radiosity_grid_beyond_the_terrain_is_what_the_renderer_draws_there() {
        // A generated relief ends in open sea: texels beyond it are sea.
        let terrain = generate(&TerrainParams {
            resolution: 32,
            extent_m: 20_000.0,
            ..Default::default()
        });
        let grid = RadiosityGrid::new(&terrain, 1300.0);
        // The grid's corner texel lies wholly beyond the terrain.
        assert!(grid.size as f64 * grid.texel_m > terrain.params.extent_m + 2.0 * grid.texel_m);
        let rho = grid.ground_reflectance(&terrain);
        let water = terrain.params.albedo.water;
        let sea = water.map(|a| a + 0.066);
        assert_eq!(rho[0], sea, "the grid's corner lies beyond the terrain");
        assert_eq!(grid::beyond_terrain_reflectance(&terrain), sea);
        // A flat ground continues with its own albedo.
        let flat = nimbus_physics::terrain::flat(20_000.0, 16, 50.0, [0.3, 0.2, 0.1]);
        let grid = RadiosityGrid::new(&flat, 1500.0);
        assert_eq!(grid.ground_reflectance(&flat)[0], [0.3, 0.2, 0.1]);
    }

    #[test]
    fn forward_peak_spread_of_a_gaussian_table() {
        // A narrow Gaussian exp(−θ²/s²) has ⟨θ²⟩ = s² (small angles).
        let s: f64 = 1.0f64.to_radians();
        let texels = 256;
        let table: Vec<f32> = (0..texels)
            .flat_map(|i| {
                let theta = i as f64 * 5f64.to_radians() / (texels - 1) as f64;
                let v = (-(theta / s).powi(2)).exp() as f32;
                [v, v, v]
            })
            .collect();
        let m = forward_peak_mean_square_rad2(&table, 5.0);
        assert!((m[0] as f64 / (s * s) - 1.0).abs() < 0.01, "{m:?}");
    }
}
