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
//! an atlas of its cells — only when one of those changed, the atlas being
//! kept between frames; `cumulus_in_cloud` marches every pixel from the
//! camera to the first opaque depth or out of the box and blends the
//! fog's light over the frame, attenuating everything behind it.
//!
//! With `cumulus.shading.model = "volume"` every cloud in view (the
//! nearest [`MAX_MARCHED_CLOUDS`]) is drawn so, from outside too, farthest
//! first, right after the meshes of the others and before the stratus
//! layer: each march writes the depth where the cloud becomes opaque
//! (its transmittance crosses ½), so that what is drawn after it (the
//! layer, the rain) is hidden behind its body as behind a mesh. The clouds
//! wholly between the camera and the layer's slab are marched after the
//! layer instead, over it ([`MarchGroup`]), so that their fog veils it.
//!
//! The sun's scattered light towards the camera comes from each marched
//! instance's sun cube ([`interior::SunCubeKey`]), traced on a worker thread
//! for its variant, scale and the sun's direction in its frame. Until the
//! first is ready (a real-time caller's first frames near a cloud), the
//! march takes that light as isotropic with a forward lobe; while the sun
//! turns, the cube of the previous direction serves until the next is.

use super::interior::{self, InteriorParams, SunCubeKey, VariantInterior, VariantSunCube};
use super::variants::{CumulusVariant, VariantError};
use super::{FieldCloud, SHADING, field::sphere_in_frustum};
use crate::core::background::{Deferred, Precompute};
use crate::core::binding;
use crate::core::pipeline::{DrawPipeline, PREMULTIPLIED_OVER};
use crate::frame::{FrameBindings, FrameLayouts};
use crate::shader::{self, WgslFile};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Mat4, Vec4};
pub use nimbus_physics::cumulus::shading::MAX_MARCHED_CLOUDS;
use nimbus_physics::optics::tables::CloudOpticsParams;
use std::collections::HashMap;
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
/// Format of the depth each march reads (a copy of the depth buffer's,
/// taken just before it: the volume marches write the depth they read).
const SCENE_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

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
    /// The light's box, object frame (min, m), and the weight of the sky's
    /// direct light and of its scattered light's net flux (1 in the volume
    /// model, else 0).
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
    forms: wgpu::Buffer,
}

/// An instance the march draws this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Active {
    /// Index of the cloud in the frame's field.
    pub cloud: usize,
    variant: usize,
    /// The march's weight (1 − the mesh's opacity factor).
    pub fade: f32,
    /// Drawn after the stratus layer ([`MarchGroup::InFrontOfLayer`]).
    in_front_of_layer: bool,
    /// The pixels its box may cover: x, y, width, height.
    scissor: [u32; 4],
    /// What its light atlas is rendered from besides `Lighting`: its
    /// uniform without what only the march reads (where the wind has
    /// carried it, its weight).
    light_inputs: InCloudUniform,
}

/// What the instances are chosen for: the model and the camera's view.
#[derive(Clone, Copy, Debug)]
pub(super) struct MarchView {
    /// `cumulus.shading.model = "volume"`: every cloud in view is marched.
    pub volume: bool,
    /// The camera's clip space from the world's.
    pub clip_from_world: Mat4,
    /// The target's size, pixels.
    pub size: (u32, u32),
    /// The stratus layer's slab (its cells' lowest base and highest top,
    /// m), if the scene has one: a volume march wholly between it and the
    /// camera is drawn after it ([`MarchGroup::InFrontOfLayer`]).
    pub layer_slab_m: Option<[f64; 2]>,
}

/// Which of the frame's marches a call of [`InCloud::encode`] records.
///
/// The volume model draws its marches before the stratus layer, each
/// writing the depth where its cloud is opaque, so that the layer is hidden
/// behind the bodies of clouds in front of it and drawn over clouds behind
/// it. The layer is blended over whatever its depth test passes, so where
/// a march in front of it is thinner than opaque (the fog around the
/// camera inside a cloud, a cloud's thin edge) the layer came out in front
/// of the fog: in the flight through a cumulus under a deck a hard-edged
/// region of the deck's base, sharp through the fog that should veil it,
/// opened where the fog's transmittance crossed ½ (docs/REALISM.md, "The
/// fog's hard edge under a deck"). A cloud wholly on the camera's side of
/// the layer's slab is in front of the layer along every ray (a ray leaves
/// the cloud's heights before it reaches the layer's), so its march is
/// drawn after the layer, over it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MarchGroup {
    /// Every march that is not in front of the layer (all of them outside
    /// the volume model), with every stale light atlas of the frame: the
    /// first call.
    BehindOrAmongLayer,
    /// The volume model's marches of clouds wholly between the camera and
    /// the layer's slab, after the layer.
    InFrontOfLayer,
}

/// Bind groups and what they were made for: (scene depth view, variant,
/// sun cube), light group, march group.
type GroupsCache = (
    (wgpu::TextureView, usize, Option<[wgpu::TextureView; 2]>),
    wgpu::BindGroup,
    wgpu::BindGroup,
);

/// What one marched instance holds on the GPU: its uniform, the light
/// atlas of its cells (its scale and yaw), its sun cube.
#[derive(Debug)]
struct Slot {
    uniform: wgpu::Buffer,
    /// The light atlas and the variant it was made for.
    light: Option<(usize, wgpu::TextureView)>,
    sun_cubes: Deferred<SunCubeKey, SunCubeResult>,
    /// The sun cube on the GPU and its key.
    sun_cube: Option<(SunCubeKey, [wgpu::TextureView; 2])>,
    /// Whether the instance reads it this frame.
    sun_cube_active: bool,
    /// The groups of the last (scene depth, variant, sun cube) drawn.
    groups: Mutex<Option<GroupsCache>>,
    /// What the light atlas holds now: rendered into which view, from which
    /// inputs, with which `Lighting` ([`LightMadeFor`]).
    light_made_for: Mutex<Option<LightMadeFor>>,
}

/// What a light atlas was rendered for: the atlas, the instance's
/// [`Active::light_inputs`], and the lighting step's generation
/// (`Atmosphere::lighting_generation`). The atlas depends on nothing else
/// (the sun and the clouds' SH are in `Lighting`), so while these hold it is
/// not rendered again: with a still sun and sky, only in the first frame.
type LightMadeFor = (wgpu::TextureView, InCloudUniform, u64);

/// The in-cloud passes' state.
#[derive(Debug)]
pub struct InCloud {
    device: wgpu::Device,
    march_layout: wgpu::BindGroupLayout,
    light_layout: wgpu::BindGroupLayout,
    march_pipeline: wgpu::RenderPipeline,
    /// The volume model's march: the same, writing the depth.
    volume_pipeline: wgpu::RenderPipeline,
    light_pipeline: wgpu::RenderPipeline,
    /// The copy of the depth buffer each march reads, its pipeline and
    /// the group reading the depth buffer (made for that view).
    scene_depth: Option<((u32, u32), wgpu::TextureView)>,
    scene_depth_layout: wgpu::BindGroupLayout,
    scene_depth_pipeline: wgpu::RenderPipeline,
    scene_depth_group: Mutex<Option<(wgpu::TextureView, wgpu::BindGroup)>>,
    sampler: wgpu::Sampler,
    /// The cumulus group's textures (bindings 1 and 2).
    forward_peak: wgpu::TextureView,
    phase: wgpu::TextureView,
    interiors: Deferred<InteriorKey, InteriorsResult>,
    uploaded: Option<(InteriorKey, Vec<GpuInterior>)>,
    /// Per marched cloud (its index in the field).
    slots: HashMap<usize, Slot>,
    /// A texel of zeros bound while no sun cube is.
    no_sun_cube: wgpu::TextureView,
    /// This frame's instances, farthest first.
    active: Vec<Active>,
    /// Whether they are the volume model's (drawn before the stratus
    /// layer, writing depth) or the one the camera is in or near (drawn
    /// over everything).
    volume: bool,
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
            binding::texture_entry(9, wgpu::TextureViewDimension::D3, true, fragment),
            binding::texture_entry(10, wgpu::TextureViewDimension::D3, true, fragment),
            binding::texture_entry(11, wgpu::TextureViewDimension::D2, false, fragment),
        ]);
        let march_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cumulus in-cloud march"),
            entries: &march_entries,
        });
        let mut light_entries = common.to_vec();
        light_entries.push(binding::buffer_entry(
            8,
            wgpu::BufferBindingType::Storage { read_only: true },
            std::mem::size_of::<super::interior::LightForms>() as u64,
            fragment,
        ));
        let light_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cumulus in-cloud light"),
            entries: &light_entries,
        });
        let scene_depth_layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cumulus in-cloud scene depth"),
                entries: &[binding::depth_texture_entry(
                    7,
                    wgpu::TextureViewDimension::D2,
                    fragment,
                )],
            });
        let module = shader::create_module(device, "cumulus in-cloud", &in_cloud_shader_source());
        let pipeline = |label: &str,
                        layout: &wgpu::BindGroupLayout,
                        entry: &str,
                        target: wgpu::ColorTargetState,
                        depth: Option<wgpu::DepthStencilState>| {
            let layout = frame.pipeline_layout(device, label, Some(layout));
            DrawPipeline {
                label,
                layout: &layout,
                module: &module,
                vertex_entry: "fullscreen_vertex",
                fragment_entry: Some(entry),
                vertex_buffers: &[],
                cull_mode: None,
                depth,
                targets: &[Some(target)],
            }
            .create(device)
        };
        let over_hdr = wgpu::ColorTargetState {
            format: crate::core::targets::HDR_FORMAT,
            blend: Some(PREMULTIPLIED_OVER),
            write_mask: wgpu::ColorWrites::ALL,
        };
        let march_pipeline = pipeline(
            "cumulus in-cloud",
            &march_layout,
            "in_cloud_fragment",
            over_hdr.clone(),
            None,
        );
        // Every fragment writes a depth: the body's where the cloud is
        // opaque, else the one read (the march's own input).
        let volume_pipeline = pipeline(
            "cumulus volume",
            &march_layout,
            "in_cloud_volume_fragment",
            over_hdr,
            Some(crate::core::pipeline::depth_state(
                true,
                wgpu::CompareFunction::Always,
            )),
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
            None,
        );
        let scene_depth_pipeline = pipeline(
            "cumulus in-cloud scene depth",
            &scene_depth_layout,
            "in_cloud_scene_depth_fragment",
            wgpu::ColorTargetState {
                format: SCENE_DEPTH_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            },
            None,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("cumulus in-cloud"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Self {
            device: device.clone(),
            march_layout,
            light_layout,
            march_pipeline,
            volume_pipeline,
            light_pipeline,
            scene_depth: None,
            scene_depth_layout,
            scene_depth_pipeline,
            scene_depth_group: Mutex::new(None),
            sampler,
            forward_peak,
            phase,
            interiors: Deferred::new("cumulus interior light"),
            uploaded: None,
            slots: HashMap::new(),
            no_sun_cube: crate::core::targets::zero_texel(
                device,
                "cumulus in-cloud no sun cube",
                wgpu::TextureDimension::D3,
                LIGHT_FORMAT,
            ),
            active: Vec::new(),
            volume: false,
        }
    }

    /// The work under way on a worker thread.
    pub fn pending(&self) -> Option<&'static str> {
        self.interiors
            .pending()
            .or_else(|| self.slots.values().find_map(|s| s.sun_cubes.pending()))
    }

    /// Blocks until the work under way has finished.
    pub fn wait(&mut self) {
        self.interiors.wait();
        for slot in self.slots.values_mut() {
            slot.sun_cubes.wait();
        }
    }

    /// No instance drawn by the march (until the next [`Self::prepare`]).
    pub(super) fn clear(&mut self) {
        self.active.clear();
    }

    /// The instances drawn by the march this frame.
    pub(super) fn active(&self) -> &[Active] {
        &self.active
    }

    /// Whether this frame's marches are the volume model's (drawn with
    /// the cloud bodies) rather than the camera's cloud (over everything).
    pub(super) fn volume(&self) -> bool {
        self.volume
    }

    /// Whether any of this frame's marches is drawn after the stratus layer.
    pub(super) fn any_in_front_of_layer(&self) -> bool {
        self.active.iter().any(|a| a.in_front_of_layer)
    }

    /// Chooses the instances the march draws this frame — with `view.volume`
    /// every cloud in view (the nearest [`MAX_MARCHED_CLOUDS`]), else the
    /// cloud whose box is nearest the camera within [`HANDOVER_M`] —
    /// computing the interiors when first needed and each instance's sun
    /// cube for `to_sun` (world, towards the sun), and writes their
    /// uniforms. `truncation`: δ-M's 1 − f of the droplets.
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
        view: &MarchView,
    ) -> Result<(), VariantError> {
        self.active.clear();
        self.volume = view.volume;
        let near = view.volume
            || clouds
                .iter()
                .any(|c| c.centre_m.distance(camera_m) < c.radius_m + HANDOVER_M);
        if !near {
            self.slots.clear();
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
            // The slots' groups, light atlases and sun cubes were made from
            // the interiors uploaded before.
            self.slots.clear();
        }
        let Some((key, gpu)) = &self.uploaded else {
            return Ok(());
        };
        // The instances: (cloud, distance to its box, the march's weight).
        let mut chosen: Vec<(usize, f64, f32)> = Vec::new();
        for (index, cloud) in clouds.iter().enumerate() {
            let Some(g) = gpu.get(cloud.variant) else {
                continue;
            };
            let d = box_distance_m(cloud, &g.interior, camera_m);
            if view.volume {
                let in_view = sphere_in_frustum(
                    &view.clip_from_world,
                    cloud.centre_m.as_vec3(),
                    cloud.radius_m as f32,
                );
                if in_view {
                    chosen.push((index, d, 1.0));
                }
            } else if d < HANDOVER_M && chosen.first().is_none_or(|&(_, b, _)| d < b) {
                let x = (1.0 - d / HANDOVER_M).clamp(0.0, 1.0);
                let fade = (x * x * (3.0 - 2.0 * x)) as f32;
                chosen = vec![(index, d, fade)];
            }
        }
        chosen.retain(|&(.., fade)| fade > 0.0);
        chosen.sort_by(|a, b| a.1.total_cmp(&b.1));
        chosen.truncate(MAX_MARCHED_CLOUDS);
        // Farthest first: each march is blended over the ones behind it.
        chosen.reverse();
        let (key, gpu) = (
            key.clone(),
            gpu.iter().map(|g| g.interior.clone()).collect::<Vec<_>>(),
        );
        self.slots
            .retain(|index, _| chosen.iter().any(|&(c, ..)| c == *index));
        for (index, _, fade) in chosen {
            let cloud = &clouds[index];
            let interior = &gpu[cloud.variant];
            let sun_cube_active = self.prepare_slot(
                queue, index, cloud, interior, &key, to_sun, shapes, precompute,
            )?;
            let uniform = instance_uniform(
                cloud,
                interior,
                &key,
                fade,
                truncation,
                sun_cube_active,
                view.volume,
            );
            let slot = &self.slots[&index];
            queue.write_buffer(&slot.uniform, 0, bytemuck::bytes_of(&uniform));
            let mut light_inputs = uniform;
            light_inputs.offset_scale[..3].fill(0.0);
            light_inputs.rotation[2] = 0.0;
            light_inputs.light_dims[3] = 0;
            let in_front_of_layer = view.volume
                && view.layer_slab_m.is_some_and(|slab| {
                    in_front_of_slab(box_heights_m(cloud, interior), camera_m.y, slab)
                });
            self.active.push(Active {
                cloud: index,
                variant: cloud.variant,
                fade,
                in_front_of_layer,
                scissor: box_scissor(cloud, interior, &view.clip_from_world, view.size),
                light_inputs,
            });
        }
        Ok(())
    }

    /// Makes sure the marched cloud `index` has its slot (uniform, light
    /// atlas for its variant) and requests its sun cube; whether the cube
    /// on the GPU serves this frame.
    #[allow(clippy::too_many_arguments)]
    fn prepare_slot(
        &mut self,
        queue: &wgpu::Queue,
        index: usize,
        cloud: &FieldCloud,
        interior: &VariantInterior,
        key: &InteriorKey,
        to_sun: DVec3,
        shapes: &[Arc<CumulusVariant>],
        precompute: Precompute,
    ) -> Result<bool, VariantError> {
        let device = &self.device;
        let slot = self.slots.entry(index).or_insert_with(|| Slot {
            uniform: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cumulus in-cloud"),
                size: std::mem::size_of::<InCloudUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            light: None,
            sun_cubes: Deferred::new("cumulus sun cube"),
            sun_cube: None,
            sun_cube_active: false,
            groups: Mutex::new(None),
            light_made_for: Mutex::new(None),
        });
        if slot.light.as_ref().map(|l| l.0) != Some(cloud.variant) {
            slot.light = Some((cloud.variant, light_atlas(device, interior.light_dims)));
        }
        let cube_key = SunCubeKey::new(
            key.params.clone(),
            cloud.variant as u32,
            cloud.instance.offset_scale[3],
            object_direction(cloud.instance.rotation_noise, to_sun),
        );
        let active = update_sun_cube(
            device,
            slot,
            queue,
            cube_key,
            shapes,
            &key.optics,
            precompute,
        )?;
        slot.sun_cube_active = active;
        Ok(active)
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
        let forms = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cumulus in-cloud light forms"),
            contents: bytemuck::cast_slice(&interior.light_forms),
            usage: wgpu::BufferUsages::STORAGE,
        });
        GpuInterior {
            interior,
            extinction,
            forms,
        }
    }

    /// Makes sure the copy of the depth buffer the marches read is of the
    /// target's size.
    pub(super) fn ensure_scene_depth(&mut self, (width, height): (u32, u32)) {
        if self.scene_depth.as_ref().map(|d| d.0) == Some((width, height)) {
            return;
        }
        let view = crate::core::targets::Target::new(
            &self.device,
            "cumulus in-cloud scene depth",
            SCENE_DEPTH_FORMAT,
            width,
            height,
            wgpu::TextureUsages::TEXTURE_BINDING,
        )
        .view;
        self.scene_depth = Some(((width, height), view));
    }

    /// What the light atlas of `active` must be rendered for this frame, or
    /// `None` if it holds that already.
    fn stale_light(&self, active: &Active, lighting_generation: u64) -> Option<LightMadeFor> {
        let slot = self.slots.get(&active.cloud)?;
        let (_, light) = slot.light.as_ref()?;
        let wanted = (light.clone(), active.light_inputs, lighting_generation);
        let made = slot
            .light_made_for
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        (made.as_ref() != Some(&wanted)).then_some(wanted)
    }

    /// Whether [`Self::encode`] will render any light atlas this frame (a
    /// new instance, a turned or rescaled one, or a new `Lighting`).
    pub(super) fn light_pending(&self, lighting_generation: u64) -> bool {
        // As `encode` draws them: not an instance whose box covers no pixel.
        self.active
            .iter()
            .filter(|a| a.scissor[2] > 0 && a.scissor[3] > 0)
            .any(|a| self.stale_light(a, lighting_generation).is_some())
    }

    /// Records, for each instance of this frame in `group` (farthest
    /// first), a copy of the depth over its box's pixels and its march over
    /// `hdr` — in the volume model writing `depth` where the cloud is
    /// opaque; with [`MarchGroup::BehindOrAmongLayer`] (the first call),
    /// before them every instance's light atlas where it is stale (new, or
    /// the lighting, its scale or yaw changed). `cumulus_uniform`: the
    /// cumulus group's binding 0; `lighting_generation`: the atmosphere's
    /// count of lighting steps recorded. The timers span both calls: the
    /// first march's start, the last's end.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        hdr: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        frame: &FrameBindings<'_>,
        cumulus_uniform: &wgpu::Buffer,
        lighting_generation: u64,
        group: MarchGroup,
        light_timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
        march_timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let (Some((_, gpu)), Some((_, scene_depth))) = (&self.uploaded, &self.scene_depth) else {
            return;
        };
        let depth_group = {
            let mut cached = self
                .scene_depth_group
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            match &*cached {
                Some((view, group)) if view == depth => group.clone(),
                _ => {
                    let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("cumulus in-cloud scene depth"),
                        layout: &self.scene_depth_layout,
                        entries: &[wgpu::BindGroupEntry {
                            binding: 7,
                            resource: wgpu::BindingResource::TextureView(depth),
                        }],
                    });
                    *cached = Some((depth.clone(), group.clone()));
                    group
                }
            }
        };
        // The timestamps span every instance's passes: the first's start,
        // the last's end.
        fn span<'q>(
            writes: &Option<wgpu::RenderPassTimestampWrites<'q>>,
            first: bool,
            last: bool,
        ) -> Option<wgpu::RenderPassTimestampWrites<'q>> {
            let w = writes.as_ref()?;
            let beginning = w.beginning_of_pass_write_index.filter(|_| first);
            let end = w.end_of_pass_write_index.filter(|_| last);
            (beginning.is_some() || end.is_some()).then_some(wgpu::RenderPassTimestampWrites {
                query_set: w.query_set,
                beginning_of_pass_write_index: beginning,
                end_of_pass_write_index: end,
            })
        }
        // Each instance's light atlas, groups and pixels, in the order of
        // both calls: those behind or among the layer, then those in front.
        let mut drawn = Vec::with_capacity(self.active.len());
        let order = self
            .active
            .iter()
            .filter(|a| !a.in_front_of_layer)
            .chain(self.active.iter().filter(|a| a.in_front_of_layer));
        for active in order {
            let (Some(g), Some(slot)) = (gpu.get(active.variant), self.slots.get(&active.cloud))
            else {
                continue;
            };
            let Some((_, light)) = &slot.light else {
                continue;
            };
            if active.scissor[2] == 0 || active.scissor[3] == 0 {
                continue;
            }
            let sun_cube = slot
                .sun_cube
                .as_ref()
                .filter(|_| slot.sun_cube_active)
                .map(|(_, views)| views.clone());
            let made_for = (scene_depth.clone(), active.variant, sun_cube);
            let mut cached = slot
                .groups
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            let groups = match &*cached {
                Some((key, l, m)) if *key == made_for => (l.clone(), m.clone()),
                _ => {
                    let none = [&self.no_sun_cube, &self.no_sun_cube];
                    let cube = made_for.2.as_ref().map_or(none, |[p, n]| [p, n]);
                    let groups =
                        self.make_groups(g, slot, light, scene_depth, cube, cumulus_uniform);
                    *cached = Some((made_for.clone(), groups.0.clone(), groups.1.clone()));
                    groups
                }
            };
            drop(cached);
            let stale = self.stale_light(active, lighting_generation);
            if let Some(wanted) = &stale {
                *slot
                    .light_made_for
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(wanted.clone());
            }
            drawn.push((
                light,
                groups,
                active.scissor,
                stale.is_some(),
                active.in_front_of_layer,
            ));
        }
        let count = drawn.len();
        // The first call renders the stale atlases (marked fresh above, so
        // the second finds none).
        let lights: Vec<_> = drawn
            .iter()
            .filter(|d| d.3 && group == MarchGroup::BehindOrAmongLayer)
            .map(|(light, (light_group, _), ..)| (light, light_group))
            .collect();
        // The stale light atlases first, then the marches (farthest first),
        // so that each timer spans its own passes.
        let light_count = lights.len();
        for (k, (light, light_group)) in lights.into_iter().enumerate() {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("cumulus in-cloud light"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: light,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: span(&light_timestamps, k == 0, k + 1 == light_count),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.light_pipeline);
            frame.set_on(&mut pass, Some(light_group));
            pass.draw(0..3, 0..1);
        }
        for (k, (_, (_, march_group), [x, y, w, h], _, in_front)) in drawn.iter().enumerate() {
            if *in_front != (group == MarchGroup::InFrontOfLayer) {
                continue;
            }
            let (x, y, w, h) = (*x, *y, *w, *h);
            // The march's timer starts with its first copy of the depth.
            let start = span(&march_timestamps, k == 0, false);
            let end = span(&march_timestamps, false, k + 1 == count);
            {
                let mut pass = crate::core::targets::colour_pass(
                    encoder,
                    "cumulus in-cloud scene depth",
                    scene_depth,
                    None,
                    start,
                );
                pass.set_pipeline(&self.scene_depth_pipeline);
                frame.set_on(&mut pass, Some(&depth_group));
                pass.set_scissor_rect(x, y, w, h);
                pass.draw(0..3, 0..1);
            }
            let mut pass = if self.volume {
                encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("cumulus volume"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: hdr,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Load,
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: depth,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Load,
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: end,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
            } else {
                crate::core::targets::colour_pass(encoder, "cumulus in-cloud", hdr, None, end)
            };
            pass.set_pipeline(if self.volume {
                &self.volume_pipeline
            } else {
                &self.march_pipeline
            });
            frame.set_on(&mut pass, Some(march_group));
            pass.set_scissor_rect(x, y, w, h);
            pass.draw(0..3, 0..1);
        }
    }

    fn make_groups(
        &self,
        g: &GpuInterior,
        slot: &Slot,
        light: &wgpu::TextureView,
        scene_depth: &wgpu::TextureView,
        sun_cube: [&wgpu::TextureView; 2],
        cumulus_uniform: &wgpu::Buffer,
    ) -> (wgpu::BindGroup, wgpu::BindGroup) {
        let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
        let common = || {
            vec![
                entry(0, cumulus_uniform.as_entire_binding()),
                entry(1, wgpu::BindingResource::TextureView(&self.forward_peak)),
                entry(2, wgpu::BindingResource::TextureView(&self.phase)),
                entry(3, slot.uniform.as_entire_binding()),
            ]
        };
        let mut light_entries = common();
        light_entries.push(entry(8, g.forms.as_entire_binding()));
        let mut march = common();
        march.extend([
            entry(4, wgpu::BindingResource::TextureView(&g.extinction)),
            entry(5, wgpu::BindingResource::TextureView(light)),
            entry(6, wgpu::BindingResource::Sampler(&self.sampler)),
            entry(9, wgpu::BindingResource::TextureView(sun_cube[0])),
            entry(10, wgpu::BindingResource::TextureView(sun_cube[1])),
            entry(11, wgpu::BindingResource::TextureView(scene_depth)),
        ]);
        let group = |label, layout, entries: &[wgpu::BindGroupEntry<'_>]| {
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries,
            })
        };
        (
            group("cumulus in-cloud light", &self.light_layout, &light_entries),
            group("cumulus in-cloud march", &self.march_layout, &march),
        )
    }
}

/// Requests the sun cube of `key` for a slot and uploads it once traced;
/// whether the cube on the GPU serves this frame: `key`'s, or, while that
/// is under way, one of the same variant and scale for a sun a few degrees
/// off.
fn update_sun_cube(
    device: &wgpu::Device,
    slot: &mut Slot,
    queue: &wgpu::Queue,
    key: SunCubeKey,
    shapes: &[Arc<CumulusVariant>],
    optics: &CloudOpticsParams,
    precompute: Precompute,
) -> Result<bool, VariantError> {
    let Some(shape) = shapes.get(key.variant as usize) else {
        return Ok(false);
    };
    let ready = slot.sun_cubes.request(key.clone(), precompute, || {
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
    if slot.sun_cube.as_ref().map(|(k, ..)| k) != Some(ready_key) {
        let (ready_key, cube) = (ready_key.clone(), result.clone()?);
        let views = upload_sun_cube(device, queue, &cube);
        slot.sun_cube = Some((ready_key, views));
    }
    let serves = |k: &SunCubeKey| {
        k.variant == key.variant
            && k.scale() == key.scale()
            && k.params == key.params
            && k.to_sun().angle_between(key.to_sun()).to_degrees() < MAX_SUN_CUBE_LAG_DEG
    };
    Ok(slot.sun_cube.as_ref().is_some_and(|(k, ..)| serves(k)))
}

/// An instance's uniform: its transform, the variant's boxes, the light's
/// weight between the interiors' two scales.
fn instance_uniform(
    cloud: &FieldCloud,
    interior: &VariantInterior,
    key: &InteriorKey,
    fade: f32,
    truncation: f32,
    sun_cube_active: bool,
    sky_direct: bool,
) -> InCloudUniform {
    let scales = key.params.scales;
    let scale = f64::from(cloud.instance.offset_scale[3]);
    let span = (scales[1] / scales[0]).ln();
    let scale_weight = if span > 1e-9 {
        ((scale / scales[0]).ln() / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let rotation = cloud.instance.rotation_noise;
    let i = interior;
    let e = &i.extinction;
    let size = e.max_corner_m() - e.origin_m;
    InCloudUniform {
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
            f32::from(u8::from(sky_direct)),
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
    }
}

/// The light atlas of an instance: its cells as z slices stacked in y, the
/// scattered light's, the direct transmittance's (x + nx), the scattered
/// light's net flux with a unit ground's scattered fluence (x + 2 nx).
fn light_atlas(device: &wgpu::Device, [nx, ny, nz]: [u32; 3]) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("cumulus in-cloud light"),
            size: wgpu::Extent3d {
                width: interior::LIGHT_PARTS * nx,
                height: ny * nz,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: LIGHT_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

/// The pixels (x, y, width, height) a cloud's extinction box may cover:
/// its corners projected; the whole target when one is behind the camera.
fn box_scissor(
    cloud: &FieldCloud,
    interior: &VariantInterior,
    clip_from_world: &Mat4,
    (width, height): (u32, u32),
) -> [u32; 4] {
    let whole = [0, 0, width, height];
    let e = &interior.extinction;
    let (lo, hi) = (e.origin_m, e.max_corner_m());
    let [ox, oy, oz, scale] = cloud.instance.offset_scale.map(f64::from);
    let [c, s, ..] = cloud.instance.rotation_noise.map(f64::from);
    let (mut min, mut max) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
    for corner in 0..8 {
        let pick = |bit: usize, a: f64, b: f64| if corner & bit == 0 { a } else { b };
        let o = DVec3::new(
            pick(1, lo.x, hi.x),
            pick(2, lo.y, hi.y),
            pick(4, lo.z, hi.z),
        ) * scale;
        // cumulus_rotate: the inverse of `object_direction`'s turn.
        let world = DVec3::new(c * o.x + s * o.z + ox, o.y + oy, -s * o.x + c * o.z + oz);
        let clip =
            *clip_from_world * Vec4::new(world.x as f32, world.y as f32, world.z as f32, 1.0);
        if clip.w <= 1e-3 {
            return whole;
        }
        let ndc = glam::Vec2::new(clip.x, clip.y) / clip.w;
        min = min.min(ndc);
        max = max.max(ndc);
    }
    // NDC y up, pixels y down; a pixel of margin for the rasteriser.
    let to_px = |x: f32, size: u32| ((x * 0.5 + 0.5) * size as f32).clamp(0.0, size as f32);
    let x0 = to_px(min.x, width).floor().max(1.0) - 1.0;
    let x1 = (to_px(max.x, width).ceil() + 1.0).min(width as f32);
    let y0 = to_px(-max.y, height).floor().max(1.0) - 1.0;
    let y1 = (to_px(-min.y, height).ceil() + 1.0).min(height as f32);
    if x1 <= x0 || y1 <= y0 {
        return [0, 0, 0, 0];
    }
    [x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32]
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

/// The lowest and highest heights of a placed cloud's extinction box, m
/// (the clouds turn about the vertical only).
fn box_heights_m(cloud: &FieldCloud, interior: &VariantInterior) -> [f64; 2] {
    let [_, oy, _, scale] = cloud.instance.offset_scale.map(f64::from);
    let e = &interior.extinction;
    [oy + scale * e.origin_m.y, oy + scale * e.max_corner_m().y]
}

/// Whether a box spanning `heights_m` lies wholly between a camera at
/// `camera_y_m` and the slab `[base, top]` (m): both below its base or both
/// above its top. Along any ray from the camera the box's heights then come
/// before the slab's, so nothing of the slab is in front of the box.
fn in_front_of_slab(heights_m: [f64; 2], camera_y_m: f64, [base_m, top_m]: [f64; 2]) -> bool {
    (camera_y_m < base_m && heights_m[1] <= base_m) || (camera_y_m > top_m && heights_m[0] >= top_m)
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

#[cfg(test)]
mod tests {
    use super::in_front_of_slab;

    const SLAB_M: [f64; 2] = [2600.0, 3000.0];

    #[test]
    fn a_cloud_on_the_cameras_side_of_the_layer_is_in_front_of_it() {
        // Below the deck, the camera in a cumulus under it, or above it
        // over a cloud on its top.
        assert!(in_front_of_slab([1400.0, 2400.0], 2100.0, SLAB_M));
        assert!(in_front_of_slab([1400.0, 2600.0], 500.0, SLAB_M));
        assert!(in_front_of_slab([3000.0, 3800.0], 4000.0, SLAB_M));
    }

    #[test]
    fn a_cloud_across_or_beyond_the_layer_is_not() {
        // Reaching into the deck; above it seen from below; below it seen
        // from above; the camera within the slab.
        assert!(!in_front_of_slab([1400.0, 2700.0], 2100.0, SLAB_M));
        assert!(!in_front_of_slab([3100.0, 3800.0], 2100.0, SLAB_M));
        assert!(!in_front_of_slab([1400.0, 2400.0], 3500.0, SLAB_M));
        assert!(!in_front_of_slab([1400.0, 2400.0], 2800.0, SLAB_M));
    }
}
