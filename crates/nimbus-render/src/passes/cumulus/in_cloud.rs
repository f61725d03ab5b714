//! The camera inside a cumulus (`in_cloud.wgsl`): for the cloud whose box
//! holds the camera (or nearly), the cloud drawn as the participating
//! medium its mesh stands for, marched from the camera, instead of its
//! mesh, which fades out over [`HANDOVER_M`] as the camera nears the box.
//!
//! Why a march here and a mesh elsewhere: from outside, a cumulus core
//! (visibility ~13 m) is opaque and the mesh with the precomputed transfer
//! costs one fetch per pixel; from inside there is no surface to shade.
//! The march reads the same density as the references and the transport
//! model (the extinction grid, coarsened to ≤ [`interior::EXTINCTION_CELLS`]
//! per side) and the same light (the tracer's scattered fluence inside,
//! [`interior`]), so the handover changes how the cloud is drawn, not what
//! it is. Nothing of it runs while the camera is farther than
//! [`HANDOVER_M`] from every cloud's box.
//!
//! Per frame, when active: `cumulus_in_cloud_light` renders the light of
//! the active instance (its scale and yaw, this frame's sun and sky) into
//! an atlas of its cells; `cumulus_in_cloud` marches every pixel from the
//! camera to the first opaque depth or out of the box and blends the
//! fog's light over the frame, attenuating everything behind it.
//!
//! The sun's scattered light towards the camera comes from the active
//! instance's sun cube ([`interior::SunCubeKey`]), traced on a worker thread
//! for its variant, scale and the sun's direction in its frame. Until the
//! first is ready (a real-time caller's first frames near a cloud), the
//! march takes that light as isotropic with a forward lobe; while the sun
//! turns, the cube of the previous direction serves until the next is.

use super::interior::{self, InteriorParams, SunCubeKey, VariantInterior, VariantSunCube};
use super::variants::{CumulusVariant, VariantError};
use super::{FieldCloud, SHADING};
use crate::core::background::{Deferred, Precompute};
use crate::core::binding;
use crate::core::pipeline::{DrawPipeline, PREMULTIPLIED_OVER};
use crate::frame::{FrameBindings, FrameLayouts};
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use nimbus_physics::optics::tables::CloudOpticsParams;
use std::sync::{Arc, Mutex};

/// The march's shader.
pub const IN_CLOUD_WGSL: WgslFile = WgslFile {
    name: "passes/cumulus/in_cloud.wgsl",
    source: include_str!("in_cloud.wgsl"),
};

/// The composed WGSL of the in-cloud passes.
pub fn in_cloud_shader_source() -> String {
    shader::compose(&[SHADING, super::CUMULUS_WGSL, IN_CLOUD_WGSL])
}

/// Distance from a cloud's box over which its mesh hands over to the
/// march, m: the march's weight rises from 0 there to 1 on the box.
pub const HANDOVER_M: f64 = 150.0;
/// Steps of the march per pixel.
pub const MARCH_STEPS: u32 = 48;
/// How far the sun (in the cloud's frame) may be from the direction the
/// cube on the GPU was traced for while the next is traced, degrees: a
/// sun turning in real time keeps its cube, one that jumps (a new scene,
/// another cloud's yaw) falls back to the isotropic light until its own.
const MAX_SUN_CUBE_LAG_DEG: f64 = 10.0;
/// Format of the light atlas.
const LIGHT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// GPU layout of WGSL `InCloud`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct InCloudUniform {
    /// World position of the variant's origin, m, and the cloud's scale.
    pub offset_scale: [f32; 4],
    /// cos yaw, sin yaw, the march's weight, steps.
    pub rotation: [f32; 4],
    /// The extinction's box, object frame (min, m), and δ-M's 1 − f.
    pub extinction_min: [f32; 4],
    /// Its size, m, and the light's weight between its two scales.
    pub extinction_size: [f32; 4],
    /// The light's box, object frame (min, m), unused.
    pub light_min: [f32; 4],
    /// Its size, m, unused.
    pub light_size: [f32; 4],
    /// The light's cells along x, y, z, and 1 when the sun cube (over the
    /// light's box) is this instance's, else 0.
    pub light_dims: [u32; 4],
}

/// What the interiors are computed for.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct InteriorKey {
    pub params: InteriorParams,
    pub optics: CloudOpticsParams,
}

type InteriorsResult = Result<Vec<Arc<VariantInterior>>, VariantError>;
type SunCubeResult = Result<Arc<VariantSunCube>, VariantError>;

#[derive(Debug)]
struct GpuInterior {
    interior: Arc<VariantInterior>,
    extinction: wgpu::TextureView,
    light: wgpu::TextureView,
    forms: wgpu::Buffer,
}

/// The instance the march draws this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Active {
    /// Index of the cloud in the frame's field.
    pub cloud: usize,
    variant: usize,
    /// The march's weight (1 − the mesh's opacity factor).
    pub fade: f32,
}

/// Bind groups and what they were made for: (depth view, variant, sun
/// cube), light group, march group.
type GroupsCache = (
    (wgpu::TextureView, usize, Option<[wgpu::TextureView; 2]>),
    wgpu::BindGroup,
    wgpu::BindGroup,
);

/// The in-cloud passes' state.
#[derive(Debug)]
pub struct InCloud {
    device: wgpu::Device,
    uniform: wgpu::Buffer,
    march_layout: wgpu::BindGroupLayout,
    light_layout: wgpu::BindGroupLayout,
    march_pipeline: wgpu::RenderPipeline,
    light_pipeline: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
    /// The cumulus group's textures (bindings 1 and 2).
    forward_peak: wgpu::TextureView,
    phase: wgpu::TextureView,
    interiors: Deferred<InteriorKey, InteriorsResult>,
    uploaded: Option<(InteriorKey, Vec<GpuInterior>)>,
    sun_cubes: Deferred<SunCubeKey, SunCubeResult>,
    /// The sun cube on the GPU, its key, and whether the active instance
    /// reads it this frame.
    sun_cube: Option<(SunCubeKey, [wgpu::TextureView; 2])>,
    sun_cube_active: bool,
    /// A texel of zeros bound while no sun cube is.
    no_sun_cube: wgpu::TextureView,
    active: Option<Active>,
    /// The groups of the last (depth view, variant, sun cube) drawn.
    groups: Mutex<Option<GroupsCache>>,
}

impl InCloud {
    /// Creates the pipelines.
    pub fn new(
        device: &wgpu::Device,
        frame: &FrameLayouts<'_>,
        cumulus_uniform_size: u64,
        forward_peak: wgpu::TextureView,
        phase: wgpu::TextureView,
    ) -> Self {
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let uniform_size = std::mem::size_of::<InCloudUniform>() as u64;
        let common = [
            binding::uniform_layout_entry(
                0,
                wgpu::ShaderStages::VERTEX_FRAGMENT,
                cumulus_uniform_size,
            ),
            binding::texture_entry(1, wgpu::TextureViewDimension::D2, false, fragment),
            binding::texture_entry(2, wgpu::TextureViewDimension::D2, false, fragment),
            binding::uniform_layout_entry(3, fragment, uniform_size),
        ];
        let mut march_entries = common.to_vec();
        march_entries.extend([
            binding::texture_entry(4, wgpu::TextureViewDimension::D3, true, fragment),
            binding::texture_entry(5, wgpu::TextureViewDimension::D2, true, fragment),
            binding::sampler_entry(6, fragment),
            binding::depth_texture_entry(7, wgpu::TextureViewDimension::D2, fragment),
            binding::texture_entry(9, wgpu::TextureViewDimension::D3, true, fragment),
            binding::texture_entry(10, wgpu::TextureViewDimension::D3, true, fragment),
        ]);
        let march_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cumulus in-cloud march"),
            entries: &march_entries,
        });
        let mut light_entries = common.to_vec();
        light_entries.push(binding::buffer_entry(
            8,
            wgpu::BufferBindingType::Storage { read_only: true },
            96,
            fragment,
        ));
        let light_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cumulus in-cloud light"),
            entries: &light_entries,
        });
        let module = shader::create_module(device, "cumulus in-cloud", &in_cloud_shader_source());
        let pipeline = |label: &str,
                        layout: &wgpu::BindGroupLayout,
                        entry: &str,
                        target: wgpu::ColorTargetState| {
            let layout = frame.pipeline_layout(device, label, Some(layout));
            DrawPipeline {
                label,
                layout: &layout,
                module: &module,
                vertex_entry: "fullscreen_vertex",
                fragment_entry: Some(entry),
                vertex_buffers: &[],
                cull_mode: None,
                depth: None,
                targets: &[Some(target)],
            }
            .create(device)
        };
        let march_pipeline = pipeline(
            "cumulus in-cloud",
            &march_layout,
            "in_cloud_fragment",
            wgpu::ColorTargetState {
                format: crate::core::targets::HDR_FORMAT,
                blend: Some(PREMULTIPLIED_OVER),
                write_mask: wgpu::ColorWrites::ALL,
            },
        );
        let light_pipeline = pipeline(
            "cumulus in-cloud light",
            &light_layout,
            "in_cloud_light_fragment",
            wgpu::ColorTargetState {
                format: LIGHT_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            },
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("cumulus in-cloud"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Self {
            device: device.clone(),
            uniform: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cumulus in-cloud"),
                size: uniform_size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            march_layout,
            light_layout,
            march_pipeline,
            light_pipeline,
            sampler,
            forward_peak,
            phase,
            interiors: Deferred::new("cumulus interior light"),
            uploaded: None,
            sun_cubes: Deferred::new("cumulus sun cube"),
            sun_cube: None,
            sun_cube_active: false,
            no_sun_cube: crate::core::targets::zero_texel(
                device,
                "cumulus in-cloud no sun cube",
                wgpu::TextureDimension::D3,
                LIGHT_FORMAT,
            ),
            active: None,
            groups: Mutex::new(None),
        }
    }

    /// The work under way on a worker thread.
    pub fn pending(&self) -> Option<&'static str> {
        self.interiors.pending().or(self.sun_cubes.pending())
    }

    /// Blocks until the work under way has finished.
    pub fn wait(&mut self) {
        self.interiors.wait();
        self.sun_cubes.wait();
    }

    /// No instance drawn by the march (until the next [`Self::prepare`]).
    pub(super) fn clear(&mut self) {
        self.active = None;
    }

    /// The instance drawn by the march this frame, if any.
    pub(super) fn active(&self) -> Option<Active> {
        self.active
    }

    /// Chooses the instance the march draws this frame (the cloud whose
    /// box is nearest the camera, within [`HANDOVER_M`]), computing the
    /// interiors when the camera first comes near a cloud and its sun cube
    /// for `to_sun` (world, towards the sun), and writes the uniform.
    /// `truncation`: δ-M's 1 − f of the droplets.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        camera_m: DVec3,
        clouds: &[FieldCloud],
        shapes: &[Arc<CumulusVariant>],
        key: InteriorKey,
        to_sun: DVec3,
        truncation: f32,
        precompute: Precompute,
    ) -> Result<(), VariantError> {
        self.active = None;
        self.sun_cube_active = false;
        let near = clouds
            .iter()
            .any(|c| c.centre_m.distance(camera_m) < c.radius_m + HANDOVER_M);
        if !near {
            return Ok(());
        }
        if self.uploaded.as_ref().map(|u| &u.0) != Some(&key) {
            let Some(result) = self.interiors.request_current(&key, precompute, || {
                let shapes = shapes.to_vec();
                let job = key.clone();
                move || {
                    let optics = crate::frame::cloud_lighting::load_optics(&job.optics);
                    interior::load_or_compute(
                        &crate::core::cache::cache_dir(),
                        &job.params,
                        &shapes,
                        &optics,
                    )
                }
            }) else {
                return Ok(());
            };
            let interiors = result.clone()?;
            let gpu = interiors
                .into_iter()
                .map(|i| self.upload(queue, i))
                .collect();
            self.uploaded = Some((key.clone(), gpu));
        }
        let Some((key, gpu)) = &self.uploaded else {
            return Ok(());
        };
        // The nearest box within the handover distance.
        let mut best: Option<(usize, f64)> = None;
        for (index, cloud) in clouds.iter().enumerate() {
            let Some(g) = gpu.get(cloud.variant) else {
                continue;
            };
            let d = box_distance_m(cloud, &g.interior, camera_m);
            if d < HANDOVER_M && best.is_none_or(|(_, b)| d < b) {
                best = Some((index, d));
            }
        }
        let Some((index, distance_m)) = best else {
            return Ok(());
        };
        let cloud = &clouds[index];
        let x = (1.0 - distance_m / HANDOVER_M).clamp(0.0, 1.0);
        let fade = (x * x * (3.0 - 2.0 * x)) as f32;
        if fade <= 0.0 {
            return Ok(());
        }
        let scales = key.params.scales;
        let scale = f64::from(cloud.instance.offset_scale[3]);
        let span = (scales[1] / scales[0]).ln();
        let scale_weight = if span > 1e-9 {
            ((scale / scales[0]).ln() / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let rotation = cloud.instance.rotation_noise;
        let cube_key = SunCubeKey::new(
            key.params.clone(),
            cloud.variant as u32,
            cloud.instance.offset_scale[3],
            object_direction(rotation, to_sun),
        );
        let optics = key.optics.clone();
        let sun_cube_active = self.update_sun_cube(queue, cube_key, shapes, &optics, precompute)?;
        let Some((_, gpu)) = &self.uploaded else {
            return Ok(());
        };
        let g = &gpu[cloud.variant];
        let i = &g.interior;
        let e = &i.extinction;
        let size = e.max_corner_m() - e.origin_m;
        let uniform = InCloudUniform {
            offset_scale: cloud.instance.offset_scale,
            rotation: [rotation[0], rotation[1], fade, MARCH_STEPS as f32],
            extinction_min: [
                e.origin_m.x as f32,
                e.origin_m.y as f32,
                e.origin_m.z as f32,
                truncation,
            ],
            extinction_size: [
                size.x as f32,
                size.y as f32,
                size.z as f32,
                scale_weight as f32,
            ],
            light_min: [
                i.light_origin_m[0],
                i.light_origin_m[1],
                i.light_origin_m[2],
                0.0,
            ],
            light_size: [
                i.light_extent_m[0],
                i.light_extent_m[1],
                i.light_extent_m[2],
                0.0,
            ],
            light_dims: [
                i.light_dims[0],
                i.light_dims[1],
                i.light_dims[2],
                u32::from(sun_cube_active),
            ],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        self.active = Some(Active {
            cloud: index,
            variant: cloud.variant,
            fade,
        });
        self.sun_cube_active = sun_cube_active;
        Ok(())
    }

    /// Requests the sun cube of `key` and uploads it once traced; whether
    /// the cube on the GPU serves this frame: `key`'s, or, while that is
    /// under way, one of the same variant and scale for a sun a few degrees
    /// off.
    fn update_sun_cube(
        &mut self,
        queue: &wgpu::Queue,
        key: SunCubeKey,
        shapes: &[Arc<CumulusVariant>],
        optics: &CloudOpticsParams,
        precompute: Precompute,
    ) -> Result<bool, VariantError> {
        let Some(shape) = shapes.get(key.variant as usize) else {
            return Ok(false);
        };
        let ready = self.sun_cubes.request(key.clone(), precompute, || {
            let shape = shape.clone();
            let job = key.clone();
            let optics = optics.clone();
            move || {
                let optics = crate::frame::cloud_lighting::load_optics(&optics);
                interior::load_or_compute_sun_cube(
                    &crate::core::cache::cache_dir(),
                    &job,
                    &shape,
                    &optics,
                )
                .map(Arc::new)
            }
        });
        let Some((ready_key, result)) = ready else {
            return Ok(false);
        };
        if self.sun_cube.as_ref().map(|(k, ..)| k) != Some(ready_key) {
            let (ready_key, cube) = (ready_key.clone(), result.clone()?);
            let views = upload_sun_cube(&self.device, queue, &cube);
            self.sun_cube = Some((ready_key, views));
        }
        let serves = |k: &SunCubeKey| {
            k.variant == key.variant
                && k.scale() == key.scale()
                && k.params == key.params
                && k.to_sun().angle_between(key.to_sun()).to_degrees() < MAX_SUN_CUBE_LAG_DEG
        };
        Ok(self.sun_cube.as_ref().is_some_and(|(k, ..)| serves(k)))
    }

    fn upload(&self, queue: &wgpu::Queue, interior: Arc<VariantInterior>) -> GpuInterior {
        use wgpu::util::DeviceExt;
        let device = &self.device;
        let e = &interior.extinction;
        let halves: Vec<half::f16> = e
            .values_per_m
            .iter()
            .map(|&v| half::f16::from_f32(v))
            .collect();
        let extinction = device
            .create_texture_with_data(
                queue,
                &wgpu::TextureDescriptor {
                    label: Some("cumulus in-cloud extinction"),
                    size: wgpu::Extent3d {
                        width: e.dims[0] as u32,
                        height: e.dims[1] as u32,
                        depth_or_array_layers: e.dims[2] as u32,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D3,
                    format: wgpu::TextureFormat::R16Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(&halves),
            )
            .create_view(&Default::default());
        let [nx, ny, nz] = interior.light_dims;
        let light = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("cumulus in-cloud light"),
                size: wgpu::Extent3d {
                    width: nx,
                    height: ny * nz,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: LIGHT_FORMAT,
                usage: wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default());
        let forms = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cumulus in-cloud light forms"),
            contents: bytemuck::cast_slice(&interior.light_forms),
            usage: wgpu::BufferUsages::STORAGE,
        });
        GpuInterior {
            interior,
            extinction,
            light,
            forms,
        }
    }

    /// Records the light atlas of the active instance and the march over
    /// `hdr` (nothing when none is active). `cumulus_uniform`: the cumulus
    /// group's binding 0.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        hdr: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
        cumulus_uniform: &wgpu::Buffer,
        light_timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
        march_timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let (Some(active), Some((_, gpu))) = (self.active, &self.uploaded) else {
            return;
        };
        let Some(g) = gpu.get(active.variant) else {
            return;
        };
        let sun_cube = self
            .sun_cube
            .as_ref()
            .filter(|_| self.sun_cube_active)
            .map(|(_, views)| views.clone());
        let made_for = (depth.clone(), active.variant, sun_cube);
        let (light_group, march_group) = {
            let mut cached = self
                .groups
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            match &*cached {
                Some((key, l, m)) if *key == made_for => (l.clone(), m.clone()),
                _ => {
                    let none = [&self.no_sun_cube, &self.no_sun_cube];
                    let cube = made_for.2.as_ref().map_or(none, |[p, n]| [p, n]);
                    let groups = self.make_groups(g, depth, cube, cumulus_uniform);
                    *cached = Some((made_for.clone(), groups.0.clone(), groups.1.clone()));
                    groups
                }
            }
        };
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cumulus in-cloud light"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &g.light,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: light_timestamps,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.light_pipeline);
            frame.set_on(&mut pass, Some(&light_group));
            pass.draw(0..3, 0..1);
        }
        let mut pass = crate::core::targets::colour_pass(
            encoder,
            "cumulus in-cloud",
            hdr,
            None,
            march_timestamps,
        );
        pass.set_pipeline(&self.march_pipeline);
        frame.set_on(&mut pass, Some(&march_group));
        pass.draw(0..3, 0..1);
    }

    fn make_groups(
        &self,
        g: &GpuInterior,
        depth: &wgpu::TextureView,
        sun_cube: [&wgpu::TextureView; 2],
        cumulus_uniform: &wgpu::Buffer,
    ) -> (wgpu::BindGroup, wgpu::BindGroup) {
        let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
        let common = || {
            vec![
                entry(0, cumulus_uniform.as_entire_binding()),
                entry(1, wgpu::BindingResource::TextureView(&self.forward_peak)),
                entry(2, wgpu::BindingResource::TextureView(&self.phase)),
                entry(3, self.uniform.as_entire_binding()),
            ]
        };
        let mut light = common();
        light.push(entry(8, g.forms.as_entire_binding()));
        let mut march = common();
        march.extend([
            entry(4, wgpu::BindingResource::TextureView(&g.extinction)),
            entry(5, wgpu::BindingResource::TextureView(&g.light)),
            entry(6, wgpu::BindingResource::Sampler(&self.sampler)),
            entry(7, wgpu::BindingResource::TextureView(depth)),
            entry(9, wgpu::BindingResource::TextureView(sun_cube[0])),
            entry(10, wgpu::BindingResource::TextureView(sun_cube[1])),
        ]);
        let group = |label, layout, entries: &[wgpu::BindGroupEntry<'_>]| {
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries,
            })
        };
        (
            group("cumulus in-cloud light", &self.light_layout, &light),
            group("cumulus in-cloud march", &self.march_layout, &march),
        )
    }
}

/// The sun cube on the GPU: two 3D textures of f16 (as the light's), the
/// values towards +x, +y, +z with the excess along the beam and towards
/// −x, −y, −z with Φ, filtered trilinearly by the sampler.
fn upload_sun_cube(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    cube: &VariantSunCube,
) -> [wgpu::TextureView; 2] {
    use wgpu::util::DeviceExt;
    let [nx, ny, nz] = cube.dims;
    let cells = (nx * ny * nz) as usize;
    std::array::from_fn(|half| {
        let texels: Vec<half::f16> = cube.texels[half * cells..(half + 1) * cells]
            .iter()
            .flatten()
            .map(|&v| half::f16::from_f32(v))
            .collect();
        device
            .create_texture_with_data(
                queue,
                &wgpu::TextureDescriptor {
                    label: Some("cumulus in-cloud sun cube"),
                    size: wgpu::Extent3d {
                        width: nx,
                        height: ny,
                        depth_or_array_layers: nz,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D3,
                    format: LIGHT_FORMAT,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(&texels),
            )
            .create_view(&Default::default())
    })
}

/// A world direction in a cloud's object frame (turned by its yaw, as
/// WGSL `in_cloud_object_direction`, unscaled).
fn object_direction(rotation_noise: [f32; 4], world: DVec3) -> DVec3 {
    let [c, s, ..] = rotation_noise.map(f64::from);
    DVec3::new(
        c * world.x - s * world.z,
        world.y,
        s * world.x + c * world.z,
    )
}

/// Distance from the camera to a cloud's extinction box, world m (0 inside).
fn box_distance_m(cloud: &FieldCloud, interior: &VariantInterior, camera_m: DVec3) -> f64 {
    let [ox, oy, oz, scale] = cloud.instance.offset_scale.map(f64::from);
    let object = object_direction(
        cloud.instance.rotation_noise,
        camera_m - DVec3::new(ox, oy, oz),
    ) / scale.max(1e-9);
    let e = &interior.extinction;
    let outside = (e.origin_m - object)
        .max(object - e.max_corner_m())
        .max(DVec3::ZERO);
    outside.length() * scale
}
