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
//!    then the [`RadiosityPass`] iterations.
//! 3. The terrain binds [`StratusPass::lookup_group`]: its sun light is
//!    shadowed by T_C at the sun ray's crossing of the layer and its
//!    indirect light is R_G.
//! 4. `layer` (draw): a grid over the window displaced to the face the
//!    camera sees, shaded per pixel by the analytic slab model (single,
//!    double, 3+ scattering, the forward peak, sky and ground light) and
//!    blended with alpha 1 − τ(H_v).
//!
//! The phase tables (P_S, P², P_F per RGB channel) come from
//! [`CloudOpticsTables`], computed from the scene's droplet distribution and
//! cached on disk ([`optics_cache_dir`]).

use crate::binding;
use crate::radiosity::{RadiosityError, RadiosityPass};
use crate::scene::{Scene, StratusSettings};
use crate::shader::{self, WgslFile};
use crate::targets::{DEPTH_FORMAT, HDR_FORMAT};
use bytemuck::{Pod, Zeroable};
use nimbus_physics::cloud_layer::CloudLayerField;
use nimbus_physics::optics::dsd::SizeDistribution;
use nimbus_physics::optics::tables::{CloudOpticsParams, CloudOpticsTables};
use nimbus_physics::terrain::Terrain;
use nimbus_physics::transport::stratus::OneDimensionalTable;
use std::path::PathBuf;
use wgpu::util::DeviceExt;

/// Shared declarations: the uniform, the field and the 1-D model.
pub const FIELD: WgslFile = WgslFile {
    name: "stratus/field.wgsl",
    source: include_str!("field.wgsl"),
};
/// Group-3 bindings and lookups for the passes that draw.
pub const LOOKUP: WgslFile = WgslFile {
    name: "stratus/lookup.wgsl",
    source: include_str!("lookup.wgsl"),
};
const LAYER_WGSL: WgslFile = WgslFile {
    name: "stratus/layer.wgsl",
    source: include_str!("layer.wgsl"),
};
const COMPUTE_WGSL: WgslFile = WgslFile {
    name: "stratus/compute.wgsl",
    source: include_str!("compute.wgsl"),
};

/// The files a drawing pass that reads the layer appends after
/// [`shader::DRAWING_LIBRARIES`].
pub const DRAWING_LIBRARIES: [WgslFile; 2] = [FIELD, LOOKUP];

/// The composed WGSL of the layer's draw.
pub fn layer_shader_source() -> String {
    let mut files = shader::DRAWING_LIBRARIES.to_vec();
    files.extend(DRAWING_LIBRARIES);
    files.extend(crate::cumulus::SHADOW_LIBRARIES);
    files.push(LAYER_WGSL);
    shader::compose(&files)
}

/// The composed WGSL of the pass's compute shaders.
pub fn compute_shader_source() -> String {
    let mut files = shader::DRAWING_LIBRARIES.to_vec();
    files.extend([FIELD, COMPUTE_WGSL]);
    shader::compose(&files)
}

/// The thickness field of a scene's stratus layer, carried by its wind
/// (the CPU twin of `field.wgsl`; the rain zones read it too).
pub fn cloud_layer_field(
    scene: &Scene,
    settings: &crate::scene::StratusSettings,
) -> CloudLayerField {
    let wind = scene
        .wind
        .as_ref()
        .map_or([0.0, 0.0], |w| w.velocity_xz_m_s());
    CloudLayerField {
        max_thickness_m: settings.thickness_m,
        coverage: settings.coverage,
        feature_size_m: settings.feature_size_m,
        octaves: settings.detail,
        seed: settings.seed,
        wind_velocity_m_s: wind,
        evolution_time_s: settings.evolution_time_s,
    }
}

/// Texels of the P_S and P² tables over 0–180°.
pub const PHASE_TEXELS: usize = 1024;
/// Texels of the P_F table over 0–θ_f.
pub const PEAK_TEXELS: usize = 256;
/// Half-angle θ_f of the forward peak, degrees (Bouthors 2006, §4.1).
pub const FORWARD_PEAK_DEG: f64 = 5.0;
/// Largest radiosity grid, texels per side.
pub const MAX_RADIOSITY_SIZE: u32 = 256;
/// Smallest height of the layer above the ground used for the radiosity
/// texel size, m.
pub const MIN_RADIOSITY_TEXEL_M: f64 = 100.0;

/// GPU layout of WGSL `Stratus` (`stratus/field.wgsl`); see it for each field.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct StratusUniform {
    /// 1/feature size (1/m), edge threshold n_c, ramp width, thickest cells (m).
    pub shape: [f32; 4],
    /// Wind drift (x, z) m ([`Scene::cloud_drift_m`]), 1/evolution time (1/s), time (s).
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
    /// P_S/P² texels, P_F texels, radiosity texels per side, both faces drawn (0/1).
    pub sizes: [u32; 4],
}

/// Where the optical tables are cached: `$NIMBUS_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/nimbus`, else `$HOME/.cache/nimbus`, else the system's
/// temporary directory.
pub fn optics_cache_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("NIMBUS_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("nimbus");
    }
    if let Some(home) = std::env::var_os("HOME") {
        return PathBuf::from(home).join(".cache/nimbus");
    }
    std::env::temp_dir().join("nimbus")
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

/// A layer's optical tables: loaded from the cache or computed (and
/// cached; a cache that cannot be written only costs the computation).
pub fn load_optics(params: &CloudOpticsParams) -> CloudOpticsTables {
    CloudOpticsTables::load_or_compute(&optics_cache_dir(), params)
        .unwrap_or_else(|_| CloudOpticsTables::compute(params))
}

/// Mean square angle of a forward-peak table sampled uniformly over
/// 0–θ_f (per channel, interleaved RGB), rad²: ∫ P θ² dΩ / ∫ P dΩ.
fn forward_peak_mean_square_rad2(peak: &[f32], forward_peak_deg: f64) -> [f32; 3] {
    let texels = peak.len() / 3;
    let step = forward_peak_deg.to_radians() / (texels - 1) as f64;
    let mut out = [0.0f32; 3];
    for (c, value) in out.iter_mut().enumerate() {
        let (mut weighted, mut total) = (0.0, 0.0);
        for i in 0..texels {
            let theta = i as f64 * step;
            let w = peak[3 * i + c] as f64 * theta.sin();
            weighted += w * theta * theta;
            total += w;
        }
        *value = (weighted / total.max(1e-300)) as f32;
    }
    out
}

/// The radiosity grid of a layer over a terrain: square texels as large as
/// the layer is high above the mean ground (§5.3), a power of two of them
/// per side covering the terrain, centred on the origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiosityGrid {
    /// Texels per side.
    pub size: u32,
    /// Texel side, m.
    pub texel_m: f64,
    /// Mean ground height, m.
    pub ground_height_m: f64,
}

impl RadiosityGrid {
    /// The grid for a layer whose mid-plane is at `mid_plane_m` over `terrain`.
    pub fn new(terrain: &Terrain, mid_plane_m: f64) -> Self {
        let water = terrain.params.water_level_m;
        let heights = &terrain.surface_height_m;
        let ground_height_m = heights.iter().map(|h| (*h as f64).max(water)).sum::<f64>()
            / heights.len().max(1) as f64;
        let texel_m = (mid_plane_m - ground_height_m).max(MIN_RADIOSITY_TEXEL_M);
        let size = ((terrain.params.extent_m / texel_m).ceil() as u32)
            .next_power_of_two()
            .clamp(
                nimbus_physics::radiosity::MIN_SIZE as u32,
                MAX_RADIOSITY_SIZE,
            );
        Self {
            size,
            texel_m,
            ground_height_m,
        }
    }

    /// World (x, z) of the grid's min corner, m.
    pub fn origin_m(&self) -> [f64; 2] {
        let half = 0.5 * self.size as f64 * self.texel_m;
        [-half, -half]
    }

    /// ρ_G: the ground's mean diffuse reflectance in each texel (row-major,
    /// z rows). Open water adds its mean Fresnel reflectance for diffuse
    /// light (0.066; Cox & Munk's flat-sea value is 0.066 for a uniform sky).
    /// Texels beyond the terrain take the terrain's mean.
    pub fn ground_reflectance(&self, terrain: &Terrain) -> Vec<[f32; 3]> {
        const WATER_DIFFUSE_FRESNEL: f32 = 0.066;
        let n = self.size as usize;
        let mut sums = vec![[0.0f64; 4]; n * n];
        let side = terrain.vertices_per_side();
        let water = terrain.params.water_level_m as f32;
        let origin = self.origin_m();
        let mut mean = [0.0f64; 3];
        for j in 0..side {
            for i in 0..side {
                let k = j * side + i;
                let mut rho = terrain.albedo[k];
                if terrain.ground_height_m[k] < water {
                    rho = rho.map(|a| a + WATER_DIFFUSE_FRESNEL);
                }
                for c in 0..3 {
                    mean[c] += rho[c] as f64;
                }
                let (x, z) = terrain.vertex_xz_m(i, j);
                let u = ((x - origin[0]) / self.texel_m).floor();
                let v = ((z - origin[1]) / self.texel_m).floor();
                if u < 0.0 || v < 0.0 || u >= n as f64 || v >= n as f64 {
                    continue;
                }
                let cell = &mut sums[v as usize * n + u as usize];
                for c in 0..3 {
                    cell[c] += rho[c] as f64;
                }
                cell[3] += 1.0;
            }
        }
        let count = (side * side).max(1) as f64;
        let mean = mean.map(|m| m / count);
        sums.iter()
            .map(|s| {
                if s[3] > 0.0 {
                    [0, 1, 2].map(|c| (s[c] / s[3]) as f32)
                } else {
                    mean.map(|m| m as f32)
                }
            })
            .collect()
    }
}

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
    lookup_group: wgpu::BindGroup,
    compute_group: wgpu::BindGroup,
    thickness: wgpu::Texture,
    indices: wgpu::Buffer,
    index_count: u32,
    /// Per-channel optics of the current tables: κ, P_f, ⟨θ²⟩ of P_F.
    optics: Option<([f32; 3], [f32; 3], [f32; 3])>,
}

/// The stratus pass.
#[derive(Debug)]
pub struct StratusPass {
    uniform: wgpu::Buffer,
    lookup_layout: wgpu::BindGroupLayout,
    compute_layout: wgpu::BindGroupLayout,
    thickness_pipeline: wgpu::ComputePipeline,
    inputs_pipeline: wgpu::ComputePipeline,
    layer_pipeline: wgpu::RenderPipeline,
    resources: Option<Resources>,
    /// The scene's layer, when it has one.
    settings: Option<StratusSettings>,
    /// The uniform as last written.
    current: StratusUniform,
    /// The camera's height this frame, m.
    camera_height_m: f64,
}

/// Errors of the pass.
#[derive(Debug, thiserror::Error)]
pub enum StratusError {
    /// The radiosity grid could not be built.
    #[error(transparent)]
    Radiosity(#[from] RadiosityError),
}

impl StratusPass {
    /// Creates the pipelines; resources are built by [`Self::prepare`].
    pub fn new(
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        atmosphere_layout: &wgpu::BindGroupLayout,
        cloud_shadow_layout: &wgpu::BindGroupLayout,
    ) -> Self {
        let uniform_size = std::mem::size_of::<StratusUniform>() as u64;
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stratus uniform"),
            size: uniform_size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let draw = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let compute = wgpu::ShaderStages::COMPUTE;
        let storage_read = wgpu::BufferBindingType::Storage { read_only: true };
        let storage_write = wgpu::BufferBindingType::Storage { read_only: false };
        let vec4 = 16;
        let lookup_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stratus lookup"),
            entries: &[
                // The layer's shape is also for compute passes (and the
                // tests' kernels) that need to know where the cloud is.
                binding::uniform_layout_entry(0, draw | compute, uniform_size),
                binding::texture_entry(1, wgpu::TextureViewDimension::D2, false, draw | compute),
                binding::buffer_entry(2, storage_read, vec4, draw),
                binding::buffer_entry(3, storage_read, vec4, wgpu::ShaderStages::FRAGMENT),
                binding::buffer_entry(4, storage_read, vec4, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let compute_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stratus compute"),
            entries: &[
                binding::uniform_layout_entry(0, compute, uniform_size),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: compute,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::R32Float,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
                binding::buffer_entry(2, storage_write, vec4, compute),
                binding::buffer_entry(3, storage_write, vec4, compute),
                binding::buffer_entry(4, storage_write, vec4, compute),
                binding::buffer_entry(5, storage_write, vec4, compute),
                binding::buffer_entry(6, storage_write, vec4, compute),
            ],
        });
        let compute_module =
            shader::create_module(device, "stratus compute", &compute_shader_source());
        let compute_layout_full = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stratus compute"),
            bind_group_layouts: &[
                Some(frame_layout),
                Some(&compute_layout),
                Some(atmosphere_layout),
            ],
            immediate_size: 0,
        });
        let compute_pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&compute_layout_full),
                module: &compute_module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let thickness_pipeline = compute_pipeline("thickness_field");
        let inputs_pipeline = compute_pipeline("radiosity_inputs");

        let layer_module = shader::create_module(device, "stratus layer", &layer_shader_source());
        let layer_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stratus layer"),
            bind_group_layouts: &[
                Some(frame_layout),
                Some(cloud_shadow_layout),
                Some(atmosphere_layout),
                Some(&lookup_layout),
            ],
            immediate_size: 0,
        });
        let premultiplied = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
            operation: wgpu::BlendOperation::Add,
        };
        let layer_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("stratus layer"),
            layout: Some(&layer_layout),
            vertex: wgpu::VertexState {
                module: &layer_module,
                entry_point: Some("layer_vertex"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &layer_module,
                entry_point: Some("layer_fragment"),
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
            lookup_layout,
            compute_layout,
            thickness_pipeline,
            inputs_pipeline,
            layer_pipeline,
            resources: None,
            settings: None,
            current: StratusUniform::default(),
            camera_height_m: 0.0,
        }
    }

    /// Layout of the group the passes that draw bind at index 3.
    pub fn lookup_layout(&self) -> &wgpu::BindGroupLayout {
        &self.lookup_layout
    }

    /// The group-3 bind group (valid after [`Self::prepare`]).
    pub fn lookup_group(&self) -> Option<&wgpu::BindGroup> {
        self.resources.as_ref().map(|r| &r.lookup_group)
    }

    /// The radiosity pass of the current grid.
    pub fn radiosity(&self) -> Option<&RadiosityPass> {
        self.resources.as_ref().map(|r| &r.radiosity)
    }

    /// The thickness window (R32Float, m), written by the frame's compute.
    pub fn thickness_texture(&self) -> Option<&wgpu::Texture> {
        self.resources.as_ref().map(|r| &r.thickness)
    }

    /// The uniform as last written.
    pub fn uniform(&self) -> &StratusUniform {
        &self.current
    }

    /// Faces to draw: the one towards the camera, and the other too while
    /// the camera is level with the layer (within half the thickest cell of
    /// its mid-plane, plus a margin), where slopes of both face it.
    fn face_count(&self) -> u32 {
        let Some(settings) = &self.settings else {
            return 0;
        };
        let mid = self.current.window[0] as f64;
        let reach = 0.5 * settings.thickness_m + 50.0;
        if (self.camera_height_m - mid).abs() <= reach {
            2
        } else {
            1
        }
    }

    /// Whether the scene has a layer to draw.
    pub fn enabled(&self) -> bool {
        self.settings.is_some()
    }

    /// Builds what changed and writes the frame's uniform: the layer's
    /// field at `time_s`, the window around the camera, the 1-D model at
    /// the sun's zenith angle.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        terrain: &Terrain,
        time_s: f32,
    ) -> Result<(), StratusError> {
        self.settings = scene.stratus.clone();
        self.camera_height_m = scene.camera.position_m[1];
        let settings = self.settings.clone();
        let mid_plane_m = settings
            .as_ref()
            .map(|s| s.base_m + 0.5 * s.thickness_m)
            .unwrap_or(0.0);
        let key = ResourceKey {
            // Without a layer, the smallest resources keep the bindings valid.
            resolution: settings.as_ref().map_or(16, |s| s.resolution),
            mid_plane_m: settings.as_ref().map(|_| mid_plane_m),
            optics: settings.as_ref().map(optics_params),
            terrain: settings.as_ref().map(|_| terrain.params.clone()),
        };
        if self.resources.as_ref().map(|r| &r.key) != Some(&key) {
            self.resources = Some(self.build(device, queue, key, terrain)?);
        }
        let Some(resources) = &self.resources else {
            return Ok(());
        };
        let Some(settings) = settings else {
            self.current = StratusUniform::default();
            queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.current));
            return Ok(());
        };
        let field = cloud_layer_field(scene, &settings);
        let drift = scene.cloud_drift_m(f64::from(time_s));
        let (threshold, ramp) = field.threshold_and_ramp();
        // Window: `extent_m` square around the camera, its corner snapped to
        // whole texels so that the grid does not swim as the camera moves.
        let n = settings.resolution;
        let texel = settings.extent_m / n as f64;
        let camera = scene.camera.position_m;
        let corner =
            [camera[0], camera[2]].map(|c| ((c - 0.5 * settings.extent_m) / texel).floor() * texel);
        let sun = scene.sun.direction();
        let sun_zenith_deg = sun[1].clamp(-1.0, 1.0).acos().to_degrees();
        let table = OneDimensionalTable::bouthors_2006();
        let p = table.at(sun_zenith_deg);
        let beta = table.beta;
        let grid = resources.grid.unwrap_or(RadiosityGrid {
            size: 8,
            texel_m: 1.0,
            ground_height_m: 0.0,
        });
        let origin = grid.origin_m();
        let (extinction, forward, spread) = resources.optics.unwrap_or_default();
        let clamp_inf = |x: f64| x.clamp(-1e30, 1e30) as f32;
        self.current = StratusUniform {
            shape: [
                (1.0 / settings.feature_size_m) as f32,
                clamp_inf(threshold),
                ramp as f32,
                settings.thickness_m as f32,
            ],
            motion: [
                drift[0] as f32,
                drift[1] as f32,
                (1.0 / settings.evolution_time_s) as f32,
                time_s,
            ],
            window: [
                mid_plane_m as f32,
                settings.extent_m as f32,
                corner[0] as f32,
                corner[1] as f32,
            ],
            extinction: [
                extinction[0],
                extinction[1],
                extinction[2],
                FORWARD_PEAK_DEG.to_radians() as f32,
            ],
            forward_fraction: [forward[0], forward[1], forward[2], 0.0],
            forward_spread: [spread[0], spread[1], spread[2], 0.0],
            slab: [p.b as f32, p.c as f32, p.kappa_c as f32, p.t as f32],
            slab_r_beta: [p.r as f32, beta as f32, 0.0, 0.0],
            radiosity: [
                origin[0] as f32,
                origin[1] as f32,
                grid.texel_m as f32,
                grid.ground_height_m as f32,
            ],
            flags: [1, field.fractal().octaves, settings.seed, n],
            sizes: [PHASE_TEXELS as u32, PEAK_TEXELS as u32, grid.size, 0],
        };
        self.current.sizes[3] = u32::from(self.face_count() == 2);
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.current));
        Ok(())
    }

    fn build(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        key: ResourceKey,
        terrain: &Terrain,
    ) -> Result<Resources, StratusError> {
        let n = key.resolution;
        let thickness = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("stratus thickness"),
            size: wgpu::Extent3d {
                width: n,
                height: n,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let thickness_view = thickness.create_view(&Default::default());
        // The grid sums the terrain's heights: built here, when its inputs
        // change, not every frame.
        let grid = key
            .mid_plane_m
            .map(|mid_plane_m| RadiosityGrid::new(terrain, mid_plane_m));
        let radiosity_size = grid.map_or(8, |g| g.size);
        let radiosity = RadiosityPass::new(device, radiosity_size)?;
        if let Some(grid) = &grid {
            let rho: Vec<[f32; 4]> = grid
                .ground_reflectance(terrain)
                .iter()
                .map(|r| [r[0], r[1], r[2], 0.0])
                .collect();
            queue.write_buffer(
                radiosity.input_buffers().ground_reflectance,
                0,
                bytemuck::cast_slice(&rho),
            );
        }
        let (phase, optics) = match &key.optics {
            Some(params) => {
                let tables = load_optics(params);
                let mut texels: Vec<[f32; 4]> = Vec::new();
                for table in [
                    &tables.peak_removed,
                    &tables.double_scattering,
                    &tables.forward_peak,
                ] {
                    texels.extend(table.chunks(3).map(|c| [c[0], c[1], c[2], 0.0]));
                }
                let spread = forward_peak_mean_square_rad2(&tables.forward_peak, FORWARD_PEAK_DEG);
                (
                    texels,
                    Some((tables.extinction_per_m, tables.forward_fraction, spread)),
                )
            }
            None => (vec![[0.0; 4]; 2 * PHASE_TEXELS + PEAK_TEXELS], None),
        };
        let phase_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("stratus phase tables"),
            contents: bytemuck::cast_slice(&phase),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let inputs = radiosity.input_buffers();
        let view = || wgpu::BindingResource::TextureView(&thickness_view);
        let lookup_group = binding::sequential_bind_group(
            device,
            "stratus lookup",
            &self.lookup_layout,
            vec![
                self.uniform.as_entire_binding(),
                view(),
                phase_buffer.as_entire_binding(),
                inputs.ground_received.as_entire_binding(),
                inputs.cloud_received.as_entire_binding(),
            ],
        );
        let compute_group = binding::sequential_bind_group(
            device,
            "stratus compute",
            &self.compute_layout,
            vec![
                self.uniform.as_entire_binding(),
                view(),
                inputs.cloud_reflectance.as_entire_binding(),
                inputs.ground_extra.as_entire_binding(),
                inputs.ground_received.as_entire_binding(),
                inputs.cloud_received.as_entire_binding(),
                inputs.cloud_emitted.as_entire_binding(),
            ],
        );
        let indices = crate::terrain::grid_indices(n);
        let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("stratus grid indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        Ok(Resources {
            key,
            grid,
            radiosity,
            lookup_group,
            compute_group,
            thickness,
            indices: index_buffer,
            index_count: indices.len() as u32,
            optics,
        })
    }

    /// Records the compute work of the frame (thickness window, radiosity
    /// inputs and iterations) into `pass`; nothing without a layer.
    pub fn encode_compute(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        frame: &wgpu::BindGroup,
        atmosphere: &wgpu::BindGroup,
    ) {
        let (Some(resources), Some(settings)) = (&self.resources, &self.settings) else {
            return;
        };
        let n = settings.resolution;
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(1, &resources.compute_group, &[]);
        pass.set_bind_group(2, atmosphere, &[]);
        pass.set_pipeline(&self.thickness_pipeline);
        pass.dispatch_workgroups(n.div_ceil(8), n.div_ceil(8), 1);
        let size = resources.radiosity.size();
        pass.set_pipeline(&self.inputs_pipeline);
        pass.dispatch_workgroups(size.div_ceil(8), size.div_ceil(8), 1);
        resources
            .radiosity
            .encode_into(pass, settings.radiosity_iterations);
    }

    /// Records the layer's draw into `pass` (after the opaque passes, depth-tested).
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        frame: &wgpu::BindGroup,
        atmosphere: &wgpu::BindGroup,
        cloud_shadow: &wgpu::BindGroup,
    ) {
        let (Some(resources), Some(_)) = (&self.resources, &self.settings) else {
            return;
        };
        pass.set_pipeline(&self.layer_pipeline);
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(1, cloud_shadow, &[]);
        pass.set_bind_group(2, atmosphere, &[]);
        pass.set_bind_group(3, &resources.lookup_group, &[]);
        pass.set_index_buffer(resources.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..resources.index_count, 0, 0..self.face_count());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radiosity_grid_covers_the_terrain_with_texels_the_layer_height() {
        let terrain = nimbus_physics::terrain::generate(&nimbus_physics::terrain::TerrainParams {
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
