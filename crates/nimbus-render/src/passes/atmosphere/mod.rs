//! Atmosphere passes (Hillaire 2020): the transmittance and
//! multiple-scattering LUTs (recomputed only when the atmosphere changes),
//! the sky-view LUT, the aerial-perspective volume and the lighting inputs
//! (recomputed when the camera or the sun moves). The CPU reference of every
//! integral is `nimbus_physics::atmosphere`.
//!
//! Later passes bind [`AtmospherePass::lookup_bind_group`] at group 2 and
//! import `shader/atmosphere_lookup.wgsl` to read the sky radiance, the
//! sun's transmittance, the aerial perspective and the [`LightingUniform`].

use crate::core::binding::{
    buffer_entry, sampler_entry, sequential_bind_group, storage_texture_entry, texture_entry,
};
use crate::core::timing::GpuTimer;
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};
use nimbus_physics::atmosphere::{
    AERIAL_PERSPECTIVE_SIZE, AtmosphereParams, MULTIPLE_SCATTERING_LUT_SIZE, SKY_VIEW_LUT_SIZE,
    TRANSMITTANCE_LUT_SIZE,
};
use std::sync::atomic::{AtomicBool, Ordering};

pub use crate::frame::atmosphere::{LightingUniform, solar_irradiance_top};

pub use crate::shader::{ATMOSPHERE, ATMOSPHERE_LOOKUP as LOOKUP, LIGHTING_TYPES};

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
    let with = |file| shader::compose(&[file]);
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
        ("atmosphere/lighting", shader::compose(&[LIGHTING_WGSL])),
    ]
}

/// GPU layout of WGSL `Atmosphere`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AtmosphereUniform {
    /// Rayleigh scattering at sea level, m⁻¹.
    pub rayleigh_scattering: [f32; 3],
    /// Planet radius, m.
    pub bottom_radius_m: f32,
    /// Aerosol scattering at sea level, m⁻¹.
    pub mie_scattering: [f32; 3],
    /// Top of the atmosphere, m.
    pub top_radius_m: f32,
    /// Aerosol extinction at sea level, m⁻¹.
    pub mie_extinction: [f32; 3],
    /// Rayleigh scale height, m.
    pub rayleigh_scale_height_m: f32,
    /// Ozone absorption at the peak, m⁻¹.
    pub ozone_absorption: [f32; 3],
    /// Aerosol scale height, m.
    pub mie_scale_height_m: f32,
    /// Ground albedo.
    pub ground_albedo: [f32; 3],
    /// Aerosol asymmetry g.
    pub mie_asymmetry: f32,
    /// Solar irradiance at the top of the atmosphere, W·m⁻².
    pub sun_irradiance_top: [f32; 3],
    /// Ozone peak altitude, m.
    pub ozone_peak_altitude_m: f32,
    /// Ozone half width, m.
    pub ozone_half_width_m: f32,
    /// Padding.
    pub _padding0: f32,
    /// Padding.
    pub _padding1: f32,
    /// Padding.
    pub _padding2: f32,
}

impl From<&AtmosphereParams> for AtmosphereUniform {
    fn from(p: &AtmosphereParams) -> Self {
        let v = |a: [f64; 3]| a.map(|x| x as f32);
        Self {
            rayleigh_scattering: v(p.rayleigh_scattering_per_m),
            bottom_radius_m: p.bottom_radius_m as f32,
            mie_scattering: v(p.aerosol_scattering_per_m()),
            top_radius_m: p.top_radius_m as f32,
            mie_extinction: v(p.aerosol_extinction_per_m()),
            rayleigh_scale_height_m: p.rayleigh_scale_height_m as f32,
            ozone_absorption: v(p.ozone_absorption_per_m),
            mie_scale_height_m: p.aerosol_scale_height_m as f32,
            ground_albedo: v(p.ground_albedo),
            mie_asymmetry: p.aerosol_asymmetry as f32,
            sun_irradiance_top: solar_irradiance_top(),
            ozone_peak_altitude_m: p.ozone_peak_altitude_m as f32,
            ozone_half_width_m: p.ozone_half_width_m as f32,
            _padding0: 0.0,
            _padding1: 0.0,
            _padding2: 0.0,
        }
    }
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

/// GPU resources of the atmosphere.
pub struct AtmospherePass {
    uniform: wgpu::Buffer,
    transmittance: wgpu::Texture,
    multiple_scattering: wgpu::Texture,
    sky_view: wgpu::Texture,
    aerial_perspective: wgpu::Texture,
    lighting: wgpu::Buffer,
    steps: [ComputeStep; 5],
    lookup_layout: wgpu::BindGroupLayout,
    lookup_bind_group: wgpu::BindGroup,
    params: Option<AtmosphereParams>,
    view: Option<ViewKey>,
    luts_pending: AtomicBool,
    view_pending: AtomicBool,
}

impl std::fmt::Debug for AtmospherePass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AtmospherePass")
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

fn lut_texture(
    device: &wgpu::Device,
    label: &str,
    size: [u32; 3],
    dimension: wgpu::TextureDimension,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: size[2],
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension,
        format: wgpu::TextureFormat::Rgba16Float,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// A bind-group resource for each entry kind used here.
enum Resource<'a> {
    Buffer(&'a wgpu::Buffer),
    Sampler(&'a wgpu::Sampler),
    View(wgpu::TextureView),
}

impl AtmospherePass {
    /// Creates the LUTs, the lighting buffer and the compute pipelines.
    pub fn new(device: &wgpu::Device, frame_layout: &wgpu::BindGroupLayout) -> Self {
        use wgpu::TextureDimension::{D2, D3};
        use wgpu::TextureViewDimension as Dim;
        let uniform_size = std::mem::size_of::<AtmosphereUniform>() as u64;
        let lighting_size = std::mem::size_of::<LightingUniform>() as u64;
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("atmosphere uniform"),
            size: uniform_size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let lighting = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("lighting inputs"),
            size: lighting_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let [tw, th] = TRANSMITTANCE_LUT_SIZE;
        let [mw, mh] = MULTIPLE_SCATTERING_LUT_SIZE;
        let [sw, sh] = SKY_VIEW_LUT_SIZE;
        let [aw, ah, ad] = AERIAL_PERSPECTIVE_SIZE;
        let transmittance = lut_texture(device, "transmittance LUT", [tw, th, 1], D2);
        let multiple_scattering = lut_texture(device, "multiple-scattering LUT", [mw, mh, 1], D2);
        let sky_view = lut_texture(device, "sky-view LUT", [sw, sh, 1], D2);
        let aerial_perspective = lut_texture(device, "aerial-perspective volume", [aw, ah, ad], D3);
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("atmosphere LUTs"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let compute = wgpu::ShaderStages::COMPUTE;
        let uniform_entry =
            buffer_entry(0, wgpu::BufferBindingType::Uniform, uniform_size, compute);

        // Each compute step: its WGSL, layout entries and resources for group 1.
        let make = |name: &str,
                    file: WgslFile,
                    entry: &str,
                    entries: Vec<wgpu::BindGroupLayoutEntry>,
                    resources: Vec<Resource<'_>>,
                    workgroups: [u32; 3]| {
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(name),
                entries: &entries,
            });
            let bind_group = sequential_bind_group(
                device,
                name,
                &layout,
                resources
                    .iter()
                    .map(|r| match r {
                        Resource::Buffer(b) => b.as_entire_binding(),
                        Resource::Sampler(s) => wgpu::BindingResource::Sampler(s),
                        Resource::View(v) => wgpu::BindingResource::TextureView(v),
                    })
                    .collect(),
            );
            let source = if entry == "lighting_main" {
                shader::compose(&[shader::COMMON, ATMOSPHERE, LIGHTING_TYPES, file])
            } else {
                shader::compose(&[shader::COMMON, ATMOSPHERE, file])
            };
            let module = shader::create_module(device, name, &source);
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(name),
                bind_group_layouts: &[Some(frame_layout), Some(&layout)],
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

        let steps = [
            make(
                "transmittance",
                TRANSMITTANCE_WGSL,
                "transmittance_main",
                vec![uniform_entry, storage_texture_entry(1, Dim::D2)],
                vec![
                    Resource::Buffer(&uniform),
                    Resource::View(view(&transmittance)),
                ],
                [tw.div_ceil(8), th.div_ceil(8), 1],
            ),
            make(
                "multiple_scattering",
                MULTIPLE_SCATTERING_WGSL,
                "multiple_scattering_main",
                vec![
                    uniform_entry,
                    sampler_entry(1, compute),
                    texture_entry(2, Dim::D2, true, compute),
                    storage_texture_entry(3, Dim::D2),
                ],
                vec![
                    Resource::Buffer(&uniform),
                    Resource::Sampler(&sampler),
                    Resource::View(view(&transmittance)),
                    Resource::View(view(&multiple_scattering)),
                ],
                [mw.div_ceil(8), mh.div_ceil(8), 1],
            ),
            make(
                "sky_view",
                SKY_VIEW_WGSL,
                "sky_view_main",
                vec![
                    uniform_entry,
                    sampler_entry(1, compute),
                    texture_entry(2, Dim::D2, true, compute),
                    texture_entry(3, Dim::D2, true, compute),
                    storage_texture_entry(4, Dim::D2),
                ],
                vec![
                    Resource::Buffer(&uniform),
                    Resource::Sampler(&sampler),
                    Resource::View(view(&transmittance)),
                    Resource::View(view(&multiple_scattering)),
                    Resource::View(view(&sky_view)),
                ],
                [sw.div_ceil(8), sh.div_ceil(8), 1],
            ),
            make(
                "aerial_perspective",
                AERIAL_PERSPECTIVE_WGSL,
                "aerial_perspective_main",
                vec![
                    uniform_entry,
                    sampler_entry(1, compute),
                    texture_entry(2, Dim::D2, true, compute),
                    texture_entry(3, Dim::D2, true, compute),
                    storage_texture_entry(4, Dim::D3),
                ],
                vec![
                    Resource::Buffer(&uniform),
                    Resource::Sampler(&sampler),
                    Resource::View(view(&transmittance)),
                    Resource::View(view(&multiple_scattering)),
                    Resource::View(view(&aerial_perspective)),
                ],
                [aw.div_ceil(4), ah.div_ceil(4), ad.div_ceil(4)],
            ),
            make(
                "lighting",
                LIGHTING_WGSL,
                "lighting_main",
                vec![
                    uniform_entry,
                    sampler_entry(1, compute),
                    texture_entry(2, Dim::D2, true, compute),
                    texture_entry(3, Dim::D2, true, compute),
                    buffer_entry(
                        4,
                        wgpu::BufferBindingType::Storage { read_only: false },
                        lighting_size,
                        compute,
                    ),
                ],
                vec![
                    Resource::Buffer(&uniform),
                    Resource::Sampler(&sampler),
                    Resource::View(view(&transmittance)),
                    Resource::View(view(&sky_view)),
                    Resource::Buffer(&lighting),
                ],
                [1, 1, 1],
            ),
        ];

        let fragment =
            wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE;
        let lookup_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("atmosphere lookup"),
            entries: &[
                buffer_entry(0, wgpu::BufferBindingType::Uniform, uniform_size, fragment),
                sampler_entry(1, fragment),
                texture_entry(2, Dim::D2, true, fragment),
                texture_entry(3, Dim::D2, true, fragment),
                texture_entry(4, Dim::D3, true, fragment),
                buffer_entry(
                    5,
                    wgpu::BufferBindingType::Storage { read_only: true },
                    lighting_size,
                    fragment,
                ),
            ],
        });
        let lookup_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("atmosphere lookup"),
            layout: &lookup_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&view(&transmittance)),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&view(&sky_view)),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&view(&aerial_perspective)),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: lighting.as_entire_binding(),
                },
            ],
        });
        Self {
            uniform,
            transmittance,
            multiple_scattering,
            sky_view,
            aerial_perspective,
            lighting,
            steps,
            lookup_layout,
            lookup_bind_group,
            params: None,
            view: None,
            luts_pending: AtomicBool::new(true),
            view_pending: AtomicBool::new(true),
        }
    }

    /// Uploads the atmosphere when it changed, and marks what the next
    /// [`Self::encode`] must recompute.
    pub fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        params: &AtmosphereParams,
        frame: &crate::frame::FrameUniform,
    ) {
        if self.params.as_ref() != Some(params) {
            queue.write_buffer(
                &self.uniform,
                0,
                bytemuck::bytes_of(&AtmosphereUniform::from(params)),
            );
            self.params = Some(params.clone());
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

    /// Forces every LUT to be recomputed by the next [`Self::encode`] (benchmarks).
    pub fn invalidate(&self) {
        self.luts_pending.store(true, Ordering::Relaxed);
        self.view_pending.store(true, Ordering::Relaxed);
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
        let run = [luts, luts, view, view, view];
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

    /// Layout of the group-2 lookups of drawing passes.
    pub fn lookup_layout(&self) -> &wgpu::BindGroupLayout {
        &self.lookup_layout
    }

    /// The group-2 lookups of drawing passes.
    pub fn lookup_bind_group(&self) -> &wgpu::BindGroup {
        &self.lookup_bind_group
    }

    /// The LUT textures, for tests and tools: transmittance, multiple
    /// scattering, sky view, aerial perspective.
    pub fn textures(&self) -> [&wgpu::Texture; 4] {
        [
            &self.transmittance,
            &self.multiple_scattering,
            &self.sky_view,
            &self.aerial_perspective,
        ]
    }

    /// The lighting-inputs buffer ([`LightingUniform`]).
    pub fn lighting_buffer(&self) -> &wgpu::Buffer {
        &self.lighting
    }
}
