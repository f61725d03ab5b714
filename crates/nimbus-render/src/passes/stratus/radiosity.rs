//! The ground–cloud radiosity pass (Bouthors et al. 2006, §5) in compute
//! shaders: MIP pyramids of the light each plane emits and the ring-integral
//! gather, alternating ground → cloud → ground. The CPU reference is
//! [`nimbus_physics::radiosity`]; the order of operations and the sampling
//! convention (bilinear, texel centres, clamp to edge) are the same, so the
//! two agree to f32 rounding.
//!
//! Fields live in storage buffers of `vec4<f32>` (RGB and an unused lane),
//! row-major, `size` × `size` texels of side h (the layer's height above the
//! ground). A pyramid buffer holds MIP levels 0 to 3 one after the other.

use crate::core::binding::{buffer_entry, uniform_layout_entry};
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};
use nimbus_physics::radiosity::{MIN_SIZE, PlaneField};

/// The pass's WGSL.
pub const RADIOSITY_WGSL: WgslFile = WgslFile {
    name: "passes/stratus/radiosity.wgsl",
    source: include_str!("radiosity.wgsl"),
};

/// The composed shader source.
pub fn shader_source() -> String {
    shader::compose(&[RADIOSITY_WGSL])
}

/// GPU layout of WGSL `RadiosityStep`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RadiosityStep {
    /// Texels per side of the level written (downsample) or of level 0 (gather).
    pub size: u32,
    /// Source level's offset in texels (downsample).
    pub source_offset: u32,
    /// Destination level's offset in texels (downsample).
    pub destination_offset: u32,
    /// 1 for the initial gather.
    pub initial: u32,
    /// Offset of level 1 in a pyramid.
    pub level1_offset: u32,
    /// Offset of level 3 in a pyramid.
    pub level3_offset: u32,
    /// Padding.
    pub _padding: [u32; 2],
}

/// The inputs, one value per texel (RGB), as in
/// [`nimbus_physics::radiosity::RadiosityInputs`].
#[derive(Clone, Debug)]
pub struct RadiosityFields {
    /// ρ_G.
    pub ground_reflectance: Vec<[f32; 3]>,
    /// ρ_C.
    pub cloud_reflectance: Vec<[f32; 3]>,
    /// S_C, the cloud base's own exitance.
    pub cloud_source: Vec<[f32; 3]>,
    /// S_G^d, the sun's direct irradiance on the ground.
    pub ground_direct: Vec<[f32; 3]>,
    /// S_G^sky, the sky's irradiance on the ground.
    pub ground_sky: Vec<[f32; 3]>,
}

impl RadiosityFields {
    /// The inputs of the CPU reference, converted.
    pub fn from_reference(inputs: &nimbus_physics::radiosity::RadiosityInputs) -> Self {
        let f = |p: &PlaneField| -> Vec<[f32; 3]> {
            p.texels
                .iter()
                .map(|t| [t[0] as f32, t[1] as f32, t[2] as f32])
                .collect()
        };
        Self {
            ground_reflectance: f(&inputs.ground_reflectance),
            cloud_reflectance: f(&inputs.cloud_reflectance),
            cloud_source: f(&inputs.cloud_source),
            ground_direct: f(&inputs.ground_direct),
            ground_sky: f(&inputs.ground_sky),
        }
    }
}

/// Offsets of MIP levels 0..=4 (the last is the total) in a pyramid of
/// `size` texels per side.
fn level_offsets(size: u32) -> [u32; 5] {
    let mut offsets = [0; 5];
    for level in 1..5 {
        let side = size >> (level - 1);
        offsets[level] = offsets[level - 1] + side * side;
    }
    offsets
}

/// The input buffers of the pass, one `vec4<f32>` (RGB, unused) per texel,
/// row-major.
#[derive(Clone, Copy, Debug)]
pub struct RadiosityInputBuffers<'a> {
    /// ρ_G.
    pub ground_reflectance: &'a wgpu::Buffer,
    /// ρ_C.
    pub cloud_reflectance: &'a wgpu::Buffer,
    /// S_G^d + S_G^sky: the ground's own light before the first bounce.
    pub ground_extra: &'a wgpu::Buffer,
    /// R_G, starting at S_G^sky.
    pub ground_received: &'a wgpu::Buffer,
    /// R_C, starting at 0.
    pub cloud_received: &'a wgpu::Buffer,
    /// The cloud's pyramid; its level 0 (the first size² texels) starts at S_C.
    pub cloud_emitted: &'a wgpu::Buffer,
}

/// R_G and R_C read back, one `[R, G, B, unused]` per texel.
pub type ReadBack = (Vec<[f32; 4]>, Vec<[f32; 4]>);

/// The pass: buffers, pipelines and bind groups for one field size.
#[derive(Debug)]
pub struct RadiosityPass {
    size: u32,
    downsample: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    ground_reflectance: wgpu::Buffer,
    cloud_reflectance: wgpu::Buffer,
    ground_extra: wgpu::Buffer,
    ground_received: wgpu::Buffer,
    cloud_received: wgpu::Buffer,
    ground_pyramid: wgpu::Buffer,
    cloud_pyramid: wgpu::Buffer,
    /// [pyramid: ground, cloud][step: downsample 0→1, 1→2, 2→3, initial gather, gather].
    step_groups: [[wgpu::BindGroup; 5]; 2],
    /// [receiver: ground, cloud].
    receiver_groups: [wgpu::BindGroup; 2],
}

/// Errors of the pass.
#[derive(Debug, thiserror::Error)]
pub enum RadiosityError {
    /// The field size is not a power of two of at least 8.
    #[error("radiosity field size {0}: must be a power of two, at least {MIN_SIZE}")]
    Size(u32),
    /// An input has the wrong number of texels.
    #[error("radiosity input {name}: {got} texels, expected {expected}")]
    Texels {
        /// The input.
        name: &'static str,
        /// Its length.
        got: usize,
        /// size².
        expected: usize,
    },
}

impl RadiosityPass {
    /// Creates the pass for fields of `size` × `size` texels.
    pub fn new(device: &wgpu::Device, size: u32) -> Result<Self, RadiosityError> {
        if !size.is_power_of_two() || (size as usize) < MIN_SIZE {
            return Err(RadiosityError::Size(size));
        }
        let texel = std::mem::size_of::<[f32; 4]>() as u64;
        let field_bytes = u64::from(size * size) * texel;
        let pyramid_bytes = u64::from(level_offsets(size)[4]) * texel;
        let storage = |label: &str, bytes: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let ground_reflectance = storage("radiosity ground reflectance", field_bytes);
        let cloud_reflectance = storage("radiosity cloud reflectance", field_bytes);
        let ground_extra = storage("radiosity ground direct + sky", field_bytes);
        let ground_received = storage("radiosity ground received", field_bytes);
        let cloud_received = storage("radiosity cloud received", field_bytes);
        let ground_pyramid = storage("radiosity ground pyramid", pyramid_bytes);
        let cloud_pyramid = storage("radiosity cloud pyramid", pyramid_bytes);

        let compute = wgpu::ShaderStages::COMPUTE;
        let step_size = std::mem::size_of::<RadiosityStep>() as u64;
        let step_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("radiosity step"),
            entries: &[
                uniform_layout_entry(0, compute, step_size),
                buffer_entry(
                    1,
                    wgpu::BufferBindingType::Storage { read_only: false },
                    texel,
                    compute,
                ),
            ],
        });
        let read_only = wgpu::BufferBindingType::Storage { read_only: true };
        let read_write = wgpu::BufferBindingType::Storage { read_only: false };
        let receiver_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("radiosity receiver"),
            entries: &[
                buffer_entry(0, read_only, texel, compute),
                buffer_entry(1, read_only, texel, compute),
                buffer_entry(2, read_write, texel, compute),
                buffer_entry(3, read_write, texel, compute),
            ],
        });
        let module = shader::create_module(device, "radiosity", &shader_source());
        let pipeline = |label: &str, entry: &str, layouts: &[Option<&wgpu::BindGroupLayout>]| {
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
        };
        let downsample = pipeline("radiosity downsample", "downsample", &[Some(&step_layout)]);
        let gather = pipeline(
            "radiosity gather",
            "gather",
            &[Some(&step_layout), Some(&receiver_layout)],
        );

        let offsets = level_offsets(size);
        let mut steps: Vec<RadiosityStep> = (0..3)
            .map(|level| RadiosityStep {
                size: size >> (level + 1),
                source_offset: offsets[level],
                destination_offset: offsets[level + 1],
                ..RadiosityStep::default()
            })
            .collect();
        for initial in [1, 0] {
            steps.push(RadiosityStep {
                size,
                initial,
                level1_offset: offsets[1],
                level3_offset: offsets[3],
                ..RadiosityStep::default()
            });
        }
        let step_buffers: Vec<wgpu::Buffer> = steps
            .iter()
            .map(|step| {
                wgpu::util::DeviceExt::create_buffer_init(
                    device,
                    &wgpu::util::BufferInitDescriptor {
                        label: Some("radiosity step"),
                        contents: bytemuck::bytes_of(step),
                        usage: wgpu::BufferUsages::UNIFORM,
                    },
                )
            })
            .collect();
        let step_group = |pyramid: &wgpu::Buffer, k: usize| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("radiosity step"),
                layout: &step_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: step_buffers[k].as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: pyramid.as_entire_binding(),
                    },
                ],
            })
        };
        let step_groups = [&ground_pyramid, &cloud_pyramid]
            .map(|pyramid| std::array::from_fn(|k| step_group(pyramid, k)));
        let receiver_group = |buffers: [&wgpu::Buffer; 4]| {
            let entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(binding, buffer)| wgpu::BindGroupEntry {
                    binding: binding as u32,
                    resource: buffer.as_entire_binding(),
                })
                .collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("radiosity receiver"),
                layout: &receiver_layout,
                entries: &entries,
            })
        };
        let receiver_groups = [
            receiver_group([
                &ground_reflectance,
                &ground_extra,
                &ground_received,
                &ground_pyramid,
            ]),
            // The cloud's gathers are never initial: `extra` is bound but unread.
            receiver_group([
                &cloud_reflectance,
                &ground_extra,
                &cloud_received,
                &cloud_pyramid,
            ]),
        ];
        Ok(Self {
            size,
            downsample,
            gather,
            ground_reflectance,
            cloud_reflectance,
            ground_extra,
            ground_received,
            cloud_received,
            ground_pyramid,
            cloud_pyramid,
            step_groups,
            receiver_groups,
        })
    }

    /// Texels per side.
    pub fn size(&self) -> u32 {
        self.size
    }

    /// Uploads the inputs and resets the accumulators: R_G = S_G^sky,
    /// R_C = 0, the cloud pyramid's level 0 = S_C.
    pub fn upload(
        &self,
        queue: &wgpu::Queue,
        fields: &RadiosityFields,
    ) -> Result<(), RadiosityError> {
        let expected = (self.size * self.size) as usize;
        let check = |name: &'static str, v: &Vec<[f32; 3]>| {
            if v.len() == expected {
                Ok(())
            } else {
                Err(RadiosityError::Texels {
                    name,
                    got: v.len(),
                    expected,
                })
            }
        };
        check("ground_reflectance", &fields.ground_reflectance)?;
        check("cloud_reflectance", &fields.cloud_reflectance)?;
        check("cloud_source", &fields.cloud_source)?;
        check("ground_direct", &fields.ground_direct)?;
        check("ground_sky", &fields.ground_sky)?;
        let padded = |v: &[[f32; 3]]| -> Vec<[f32; 4]> {
            v.iter().map(|t| [t[0], t[1], t[2], 0.0]).collect()
        };
        let write = |buffer: &wgpu::Buffer, texels: &[[f32; 4]]| {
            queue.write_buffer(buffer, 0, bytemuck::cast_slice(texels));
        };
        write(
            &self.ground_reflectance,
            &padded(&fields.ground_reflectance),
        );
        write(&self.cloud_reflectance, &padded(&fields.cloud_reflectance));
        let extra: Vec<[f32; 4]> = fields
            .ground_direct
            .iter()
            .zip(&fields.ground_sky)
            .map(|(d, s)| [d[0] + s[0], d[1] + s[1], d[2] + s[2], 0.0])
            .collect();
        write(&self.ground_extra, &extra);
        write(&self.ground_received, &padded(&fields.ground_sky));
        write(&self.cloud_received, &vec![[0.0; 4]; expected]);
        write(&self.cloud_pyramid, &padded(&fields.cloud_source));
        Ok(())
    }

    /// Records the initialisation and `iterations` ground → cloud → ground
    /// iterations in a compute pass of its own.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, iterations: u32) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("radiosity"),
            timestamp_writes: None,
        });
        self.encode_into(&mut pass, iterations);
    }

    /// Records the initialisation and `iterations` ground → cloud → ground
    /// iterations into `pass` (the inputs must have been written before,
    /// by [`Self::upload`] or a shader writing [`Self::input_buffers`]).
    pub fn encode_into(&self, pass: &mut wgpu::ComputePass<'_>, iterations: u32) {
        const GROUND: usize = 0;
        const CLOUD: usize = 1;
        let groups = |side: u32| side.div_ceil(8);
        // MIP levels 1..=3 of the emitter's pyramid, then the gather into
        // the receiver; `step` 3 is the initial gather, 4 the others.
        let mut exchange = |emitter: usize, receiver: usize, gather_step: usize| {
            pass.set_pipeline(&self.downsample);
            for level in 0..3 {
                pass.set_bind_group(0, &self.step_groups[emitter][level], &[]);
                let side = self.size >> (level + 1);
                pass.dispatch_workgroups(groups(side), groups(side), 1);
            }
            pass.set_pipeline(&self.gather);
            pass.set_bind_group(0, &self.step_groups[emitter][gather_step], &[]);
            pass.set_bind_group(1, &self.receiver_groups[receiver], &[]);
            pass.dispatch_workgroups(groups(self.size), groups(self.size), 1);
        };
        exchange(CLOUD, GROUND, 3);
        for _ in 0..iterations {
            exchange(GROUND, CLOUD, 4);
            exchange(CLOUD, GROUND, 4);
        }
    }

    /// The buffers a shader writes to set the inputs up on the GPU (the
    /// same state [`Self::upload`] leaves).
    pub fn input_buffers(&self) -> RadiosityInputBuffers<'_> {
        RadiosityInputBuffers {
            ground_reflectance: &self.ground_reflectance,
            cloud_reflectance: &self.cloud_reflectance,
            ground_extra: &self.ground_extra,
            ground_received: &self.ground_received,
            cloud_received: &self.cloud_received,
            cloud_emitted: &self.cloud_pyramid,
        }
    }

    /// R_G: the ground's accumulated indirect irradiance.
    pub fn ground_received(&self) -> &wgpu::Buffer {
        &self.ground_received
    }

    /// The light the ground emits at the next iteration (dR_G), level 0 of
    /// its pyramid followed by levels 1–3.
    pub fn ground_emitted(&self) -> &wgpu::Buffer {
        &self.ground_pyramid
    }

    /// R_C: the cloud base's accumulated irradiance.
    pub fn cloud_received(&self) -> &wgpu::Buffer {
        &self.cloud_received
    }

    /// Runs the pass on `gpu` and reads R_G and R_C back (tests, tools).
    pub fn run_and_read(
        &self,
        gpu: &crate::core::gpu::GpuContext,
        fields: &RadiosityFields,
        iterations: u32,
    ) -> Result<ReadBack, String> {
        self.upload(&gpu.queue, fields).map_err(|e| e.to_string())?;
        let bytes = u64::from(self.size * self.size) * 16;
        let staging = |label| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let (ground, cloud) = (
            staging("radiosity ground readback"),
            staging("radiosity cloud readback"),
        );
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.encode(&mut encoder, iterations);
        encoder.copy_buffer_to_buffer(&self.ground_received, 0, &ground, 0, bytes);
        encoder.copy_buffer_to_buffer(&self.cloud_received, 0, &cloud, 0, bytes);
        gpu.queue.submit([encoder.finish()]);
        let read = |b: &wgpu::Buffer| -> Result<Vec<[f32; 4]>, String> {
            let raw = crate::core::binding::read_mapped(&gpu.device, b)?;
            Ok(bytemuck::cast_slice(&raw).to_vec())
        };
        let read_back = (read(&ground)?, read(&cloud)?);
        // A lost device or an error of this work (recorded, not panicked)
        // leaves the read-back meaningless.
        gpu.faults.check().map_err(|e| e.to_string())?;
        Ok(read_back)
    }
}
