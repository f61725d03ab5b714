//! Atmosphere passes (Hillaire 2020): the transmittance and
//! multiple-scattering LUTs (recomputed only when the atmosphere changes),
//! the sky-view LUT, the aerial-perspective volume and the lighting inputs
//! (recomputed when the camera or the sun moves). The CPU reference of every
//! integral is `nimbus_physics::atmosphere`.
//!
//! The LUTs, the atmosphere uniform and the lighting buffer belong to the
//! frame ([`AtmosphereLookups`]); this pass writes them. Later passes bind
//! them at group 2 ([`crate::frame::FrameBindings`]) and import
//! `shader/atmosphere_lookup.wgsl` to read the sky radiance, the sun's
//! transmittance, the aerial perspective and the [`LightingUniform`].

use crate::core::binding::{buffer_entry, sampler_entry, storage_texture_entry, texture_entry};
use crate::core::timing::GpuTimer;
use crate::shader::{self, WgslFile};
use nimbus_physics::atmosphere::{
    AERIAL_PERSPECTIVE_SIZE, AtmosphereParams, MULTIPLE_SCATTERING_LUT_SIZE, SKY_VIEW_LUT_SIZE,
    TRANSMITTANCE_LUT_SIZE,
};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

pub use crate::frame::atmosphere::{
    AtmosphereLookups, AtmosphereUniform, CloudsGround, LightingUniform, clouds_environment,
    sky_lighting, solar_irradiance_top,
};
pub use nimbus_physics::atmosphere::SkyLighting;

pub use crate::shader::{ATMOSPHERE, ATMOSPHERE_LOOKUP as LOOKUP, LIGHTING_TYPES};

const BINDINGS_WGSL: WgslFile = WgslFile {
    name: "passes/atmosphere/bindings.wgsl",
    source: include_str!("bindings.wgsl"),
};
const TRANSMITTANCE_WGSL: WgslFile = WgslFile {
    name: "passes/atmosphere/transmittance.wgsl",
    source: include_str!("transmittance.wgsl"),
};
const MULTIPLE_SCATTERING_WGSL: WgslFile = WgslFile {
    name: "passes/atmosphere/multiple_scattering.wgsl",
    source: include_str!("multiple_scattering.wgsl"),
};
const SKY_VIEW_WGSL: WgslFile = WgslFile {
    name: "passes/atmosphere/sky_view.wgsl",
    source: include_str!("sky_view.wgsl"),
};
const AERIAL_PERSPECTIVE_WGSL: WgslFile = WgslFile {
    name: "passes/atmosphere/aerial_perspective.wgsl",
    source: include_str!("aerial_perspective.wgsl"),
};
const LIGHTING_WGSL: WgslFile = WgslFile {
    name: "passes/atmosphere/lighting.wgsl",
    source: include_str!("lighting.wgsl"),
};

/// Composed WGSL of each compute pass, by name.
pub fn shader_sources() -> Vec<(&'static str, String)> {
    let with = |file| shader::compose(&[BINDINGS_WGSL, file]);
    vec![
        ("atmosphere/transmittance", with(TRANSMITTANCE_WGSL)),
        (
            "atmosphere/multiple_scattering",
            with(MULTIPLE_SCATTERING_WGSL),
        ),
        ("atmosphere/sky_view", with(SKY_VIEW_WGSL)),
        (
            "atmosphere/aerial_perspective",
            with(AERIAL_PERSPECTIVE_WGSL),
        ),
        ("atmosphere/lighting", with(LIGHTING_WGSL)),
    ]
}

/// Names of the atmosphere's passes, in the order they run.
pub const PASS_NAMES: [&str; 5] = [
    "transmittance",
    "multiple_scattering",
    "sky_view",
    "aerial_perspective",
    "lighting",
];

struct ComputeStep {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    workgroups: [u32; 3],
}

/// What the view-dependent passes depend on: the frame uniform without its time.
type ViewKey = crate::frame::FrameUniform;

/// The atmosphere pass: the compute steps that fill the frame's
/// [`AtmosphereLookups`] (which it writes but does not own).
pub struct AtmospherePass {
    uniform: wgpu::Buffer,
    textures: [wgpu::Texture; 4],
    aerial_perspective_parts: [wgpu::Texture; 3],
    lighting: wgpu::Buffer,
    steps: [ComputeStep; 5],
    /// The parameters, the aerial-perspective switch and the near ground's
    /// albedo last uploaded.
    params: Option<(AtmosphereParams, bool, [f64; 3])>,
    /// The ground under the clouds and where they are, last uploaded.
    clouds: Option<CloudsGround>,
    view: Option<ViewKey>,
    luts_pending: AtomicBool,
    view_pending: AtomicBool,
    lighting_pending: AtomicBool,
    /// How many times the lighting step has been recorded: what the passes
    /// that cache work derived from `Lighting` compare.
    lighting_generation: AtomicU64,
}

impl std::fmt::Debug for AtmospherePass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AtmospherePass")
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

/// A bind-group resource of a step's group 1.
enum Resource<'a> {
    Buffer(&'a wgpu::Buffer),
    Sampler(&'a wgpu::Sampler),
    View(wgpu::TextureView),
}

/// Group-1 bindings of `passes/atmosphere/bindings.wgsl` (inputs) and of
/// each step's output.
mod slot {
    pub const ATMOSPHERE: u32 = 0;
    pub const SAMPLER: u32 = 1;
    pub const TRANSMITTANCE: u32 = 2;
    pub const MULTIPLE_SCATTERING: u32 = 3;
    pub const SKY_VIEW: u32 = 4;
    pub const OUTPUT: u32 = 8;
    /// The aerial perspective's parts, after its volume (bindings 9–11).
    pub const AERIAL_PERSPECTIVE_PARTS: u32 = 9;
}

impl AtmospherePass {
    /// Creates the compute pipelines that write `lookups`.
    pub fn new(
        device: &wgpu::Device,
        frame: &crate::frame::FrameLayouts<'_>,
        lookups: &AtmosphereLookups,
    ) -> Self {
        use wgpu::TextureViewDimension as Dim;
        let uniform_size = std::mem::size_of::<AtmosphereUniform>() as u64;
        let lighting_size = std::mem::size_of::<LightingUniform>() as u64;
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let compute = wgpu::ShaderStages::COMPUTE;
        let sampled = |binding, texture: &wgpu::Texture| {
            (
                texture_entry(binding, Dim::D2, true, compute),
                Resource::View(view(texture)),
            )
        };
        let atmosphere = || {
            (
                buffer_entry(
                    slot::ATMOSPHERE,
                    wgpu::BufferBindingType::Uniform,
                    uniform_size,
                    compute,
                ),
                Resource::Buffer(&lookups.uniform),
            )
        };
        let sampler = || {
            (
                sampler_entry(slot::SAMPLER, compute),
                Resource::Sampler(&lookups.sampler),
            )
        };
        let written_at = |binding, texture: &wgpu::Texture, dimension| {
            (
                storage_texture_entry(binding, dimension),
                Resource::View(view(texture)),
            )
        };
        let written =
            |texture: &wgpu::Texture, dimension| written_at(slot::OUTPUT, texture, dimension);

        // Each compute step: its WGSL, and its group 1 as (layout entry,
        // resource) pairs of the bindings its entry point uses.
        let make = |name: &str,
                    file: WgslFile,
                    entry: &str,
                    bindings: Vec<(wgpu::BindGroupLayoutEntry, Resource<'_>)>,
                    workgroups: [u32; 3]| {
            let (entries, resources): (Vec<_>, Vec<_>) = bindings.into_iter().unzip();
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(name),
                entries: &entries,
            });
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(name),
                layout: &layout,
                entries: &entries
                    .iter()
                    .zip(&resources)
                    .map(|(entry, resource)| wgpu::BindGroupEntry {
                        binding: entry.binding,
                        resource: match resource {
                            Resource::Buffer(b) => b.as_entire_binding(),
                            Resource::Sampler(s) => wgpu::BindingResource::Sampler(s),
                            Resource::View(v) => wgpu::BindingResource::TextureView(v),
                        },
                    })
                    .collect::<Vec<_>>(),
            });
            let module =
                shader::create_module(device, name, &shader::compose(&[BINDINGS_WGSL, file]));
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(name),
                bind_group_layouts: &[Some(frame.frame), Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
            ComputeStep {
                pipeline,
                bind_group,
                workgroups,
            }
        };

        let [tw, th] = TRANSMITTANCE_LUT_SIZE;
        let [mw, mh] = MULTIPLE_SCATTERING_LUT_SIZE;
        let [sw, sh] = SKY_VIEW_LUT_SIZE;
        let [aw, ah, ad] = AERIAL_PERSPECTIVE_SIZE;
        let steps = [
            make(
                "transmittance",
                TRANSMITTANCE_WGSL,
                "transmittance_main",
                vec![atmosphere(), written(&lookups.transmittance, Dim::D2)],
                [tw.div_ceil(8), th.div_ceil(8), 1],
            ),
            make(
                "multiple_scattering",
                MULTIPLE_SCATTERING_WGSL,
                "multiple_scattering_main",
                vec![
                    atmosphere(),
                    sampler(),
                    sampled(slot::TRANSMITTANCE, &lookups.transmittance),
                    written(&lookups.multiple_scattering, Dim::D2),
                ],
                [mw.div_ceil(8), mh.div_ceil(8), 1],
            ),
            make(
                "sky_view",
                SKY_VIEW_WGSL,
                "sky_view_main",
                vec![
                    atmosphere(),
                    sampler(),
                    sampled(slot::TRANSMITTANCE, &lookups.transmittance),
                    sampled(slot::MULTIPLE_SCATTERING, &lookups.multiple_scattering),
                    written(&lookups.sky_view, Dim::D2),
                ],
                [sw.div_ceil(8), sh.div_ceil(8), 1],
            ),
            make(
                "aerial_perspective",
                AERIAL_PERSPECTIVE_WGSL,
                "aerial_perspective_main",
                vec![
                    atmosphere(),
                    sampler(),
                    sampled(slot::TRANSMITTANCE, &lookups.transmittance),
                    sampled(slot::MULTIPLE_SCATTERING, &lookups.multiple_scattering),
                    written(&lookups.aerial_perspective, Dim::D3),
                    written_at(
                        slot::AERIAL_PERSPECTIVE_PARTS,
                        &lookups.aerial_perspective_parts[0],
                        Dim::D3,
                    ),
                    written_at(
                        slot::AERIAL_PERSPECTIVE_PARTS + 1,
                        &lookups.aerial_perspective_parts[1],
                        Dim::D3,
                    ),
                    written_at(
                        slot::AERIAL_PERSPECTIVE_PARTS + 2,
                        &lookups.aerial_perspective_parts[2],
                        Dim::D3,
                    ),
                ],
                [aw.div_ceil(4), ah.div_ceil(4), ad.div_ceil(4)],
            ),
            make(
                "lighting",
                LIGHTING_WGSL,
                "lighting_main",
                vec![
                    atmosphere(),
                    sampler(),
                    sampled(slot::TRANSMITTANCE, &lookups.transmittance),
                    sampled(slot::MULTIPLE_SCATTERING, &lookups.multiple_scattering),
                    sampled(slot::SKY_VIEW, &lookups.sky_view),
                    (
                        buffer_entry(
                            slot::OUTPUT,
                            wgpu::BufferBindingType::Storage { read_only: false },
                            lighting_size,
                            compute,
                        ),
                        Resource::Buffer(&lookups.lighting),
                    ),
                ],
                [1, 1, 1],
            ),
        ];
        Self {
            uniform: lookups.uniform.clone(),
            textures: [
                lookups.transmittance.clone(),
                lookups.multiple_scattering.clone(),
                lookups.sky_view.clone(),
                lookups.aerial_perspective.clone(),
            ],
            aerial_perspective_parts: lookups.aerial_perspective_parts.clone(),
            lighting: lookups.lighting.clone(),
            steps,
            params: None,
            clouds: None,
            view: None,
            luts_pending: AtomicBool::new(true),
            view_pending: AtomicBool::new(true),
            lighting_pending: AtomicBool::new(true),
            lighting_generation: AtomicU64::new(0),
        }
    }

    /// Uploads the atmosphere when it changed, and marks what the next
    /// [`Self::encode`] must recompute.
    /// Without `aerial_perspective` the aerial-perspective volume holds no
    /// air (nothing scattered in, transmittance 1). `near_ground_albedo`:
    /// the mean albedo of the ground the scene draws
    /// ([`crate::frame::atmosphere::ground_albedo`]). `clouds`: the ground
    /// under the clouds and where their environment is taken (a change of
    /// ground, or a move beyond
    /// [`crate::frame::atmosphere::CLOUDS_OBSERVER_TOLERANCE_M`], recomputes
    /// only the lighting inputs).
    pub fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        params: &AtmosphereParams,
        aerial_perspective: bool,
        near_ground_albedo: [f64; 3],
        clouds: &CloudsGround,
        frame: &crate::frame::FrameUniform,
    ) {
        let state = (params.clone(), aerial_perspective, near_ground_albedo);
        let params_changed = self.params.as_ref() != Some(&state);
        // The clouds drift with the wind: their environment is taken again
        // once they have moved far enough to change it (not every frame).
        let clouds_changed = !self
            .clouds
            .as_ref()
            .is_some_and(|taken| taken.stands_for(clouds));
        if params_changed || clouds_changed {
            let f = |a: [f64; 3]| a.map(|c| c as f32);
            let uniform = AtmosphereUniform {
                aerial_perspective_scale: if aerial_perspective { 1.0 } else { 0.0 },
                near_ground_albedo: f(near_ground_albedo),
                clouds_observer_m: f(clouds.observer_m),
                near_ground_half_extent_m: clouds.below.near_ground_half_extent_m.min(1e30) as f32,
                water_albedo: f(clouds.below.water_albedo),
                water_ggx_alpha: clouds.below.water_ggx_alpha as f32,
                ..AtmosphereUniform::from(params)
            };
            queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
            self.params = Some(state);
            self.clouds = Some(*clouds);
            self.lighting_pending.store(true, Ordering::Relaxed);
        }
        if params_changed {
            self.luts_pending.store(true, Ordering::Relaxed);
            self.view_pending.store(true, Ordering::Relaxed);
        }
        let key = ViewKey {
            time_s: 0.0,
            ..*frame
        };
        if self.view != Some(key) {
            self.view = Some(key);
            self.view_pending.store(true, Ordering::Relaxed);
        }
    }

    /// Counts the lighting step's recordings ([`Self::encode`]): it changes
    /// whenever the `Lighting` buffer (the sun, the sky's and the clouds'
    /// SH) may have.
    pub fn lighting_generation(&self) -> u64 {
        self.lighting_generation.load(Ordering::Relaxed)
    }

    /// Forces every LUT to be recomputed by the next [`Self::encode`] (benchmarks).
    pub fn invalidate(&self) {
        self.luts_pending.store(true, Ordering::Relaxed);
        self.view_pending.store(true, Ordering::Relaxed);
        self.lighting_pending.store(true, Ordering::Relaxed);
    }

    /// The ground under the clouds and where their environment was last
    /// taken (None before the first [`Self::prepare`]).
    pub fn clouds_ground(&self) -> Option<&CloudsGround> {
        self.clouds.as_ref()
    }

    /// Records the passes whose inputs changed; `first_timer_index` is the
    /// timer slot of the first atmosphere pass. Returns which passes ran.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &wgpu::BindGroup,
        timer: Option<&GpuTimer>,
        first_timer_index: u32,
    ) -> [bool; 5] {
        let luts = self.luts_pending.swap(false, Ordering::Relaxed);
        let view = self.view_pending.swap(false, Ordering::Relaxed) || luts;
        let lighting = self.lighting_pending.swap(false, Ordering::Relaxed) || view;
        if lighting {
            self.lighting_generation.fetch_add(1, Ordering::Relaxed);
        }
        let run = [luts, luts, view, view, lighting];
        for (k, step) in self.steps.iter().enumerate() {
            if !run[k] {
                continue;
            }
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(PASS_NAMES[k]),
                timestamp_writes: timer
                    .map(|t| t.compute_pass_writes(first_timer_index + k as u32)),
            });
            pass.set_pipeline(&step.pipeline);
            pass.set_bind_group(0, frame, &[]);
            pass.set_bind_group(1, &step.bind_group, &[]);
            let [x, y, z] = step.workgroups;
            pass.dispatch_workgroups(x, y, z);
        }
        run
    }

    /// The LUT textures, for tests and tools: transmittance, multiple
    /// scattering, sky view, aerial perspective.
    pub fn textures(&self) -> [&wgpu::Texture; 4] {
        let [t, m, s, a] = &self.textures;
        [t, m, s, a]
    }

    /// The aerial perspective's parts, for tests and tools: the sun's single
    /// scattering and the air's weights for a diffuse field
    /// ([`AtmosphereLookups::aerial_perspective_parts`]).
    pub fn aerial_perspective_parts(&self) -> [&wgpu::Texture; 3] {
        self.aerial_perspective_parts.each_ref()
    }

    /// The lighting-inputs buffer ([`LightingUniform`]).
    pub fn lighting_buffer(&self) -> &wgpu::Buffer {
        &self.lighting
    }
}
