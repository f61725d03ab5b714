//! The renderer: owns the passes and runs them in the frame's order.
//!
//! The frame's pass order lives in [`Renderer::encode`] and nowhere else:
//! the atmosphere's LUTs and lighting inputs (when their inputs changed),
//! the stratus layer's field and radiosity, the cumulus shadow map, sky,
//! terrain, the static objects, the cumulus bodies and fringes, the stratus layer, the cumulus
//! fringes' composite, exposure, then tone mapping into the caller's output
//! target. Every pass writes GPU timestamps when the device supports them.

mod encode;
mod pass_id;
mod registry;

pub use pass_id::{PASS_NAMES, PassId, PassSet};
pub use registry::{all_modules, map_error_positions};

pub use crate::core::background::Precompute;
use crate::core::limits::{self, LimitError};
use crate::core::mesh::IndexedMesh;
use crate::core::targets::{DEPTH_FORMAT, HDR_FORMAT, Target};
use crate::core::timing::GpuTimer;
use crate::frame::cloud_shadow::CloudShadowMap;
use crate::frame::occluders::OccluderGeometry;
use crate::frame::{FrameResources, FrameUniform, View};
use crate::passes::atmosphere::{AtmospherePass, CloudsGround};
use crate::passes::composite::CompositePass;
use crate::passes::cumulus::CumulusPass;
use crate::passes::exposure::ExposurePass;
use crate::passes::objects::ObjectsPass;
use crate::passes::rain::RainPass;
use crate::passes::sky::{SkyPass, SkySettings};
use crate::passes::stratus::StratusPass;
use crate::passes::terrain::{Ground, TerrainPass};
use crate::passes::tonemap::TonemapPass;
use crate::scene::Scene;
use std::sync::atomic::{AtomicU32, Ordering};

/// What the renderer writes into the caller's output target.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OutputMode {
    /// A finished picture: nimbus draws the whole frame, exposes it and tone
    /// maps it into the output (any renderable colour format; 8-bit unorm
    /// formats get sRGB encoding and dithering in the shader). The depth
    /// target is nimbus's, reverse-Z ([`FrameTargets::depth`]).
    #[default]
    Display,
    /// Linear radiance for the caller's HDR pipeline: W·sr⁻¹·m⁻² per
    /// channel times the pre-exposure ([`Renderer::set_pre_exposure`]),
    /// composited over what the caller drew in its `Rgba16Float` (or, on a
    /// device with [`wgpu::Features::FLOAT32_BLENDABLE`], `Rgba32Float`)
    /// target: the sky where the caller's depth is at its far plane, the
    /// clouds, rain and mist and the air in front of the caller's surfaces by
    /// depth. The caller's depth is read in its own convention (the
    /// [`crate::frame::View`] given to [`Renderer::prepare_view`]) and never
    /// written; pixels nimbus does not draw over keep their value. No
    /// exposure metering, no tone mapping.
    LinearHdr,
}

/// How the renderer is set up.
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct RendererDescriptor {
    /// Format of the caller's output target.
    pub output_format: wgpu::TextureFormat,
    /// What is written there.
    pub mode: OutputMode,
    /// Write per-pass GPU timestamps when the device supports them.
    pub timestamps: bool,
    /// Where precomputation (cumulus shapes, optics tables, terrain) runs:
    /// on worker threads by default, so that `prepare` never stalls.
    pub precompute: Precompute,
}

impl RendererDescriptor {
    /// A finished, tone-mapped picture in `output_format` ([`OutputMode::Display`]).
    pub fn display(output_format: wgpu::TextureFormat) -> Self {
        Self {
            output_format,
            mode: OutputMode::Display,
            timestamps: false,
            precompute: Precompute::Background,
        }
    }

    /// Linear radiance composited into the caller's HDR target of
    /// `output_format` ([`OutputMode::LinearHdr`]).
    pub fn linear_hdr(output_format: wgpu::TextureFormat) -> Self {
        Self {
            output_format,
            mode: OutputMode::LinearHdr,
            timestamps: false,
            precompute: Precompute::Background,
        }
    }

    /// The same, with per-pass GPU timestamps written or not.
    pub fn with_timestamps(mut self, timestamps: bool) -> Self {
        self.timestamps = timestamps;
        self
    }

    /// The same, with precomputation on worker threads or inline.
    pub fn with_precompute(mut self, precompute: Precompute) -> Self {
        self.precompute = precompute;
        self
    }
}

/// Whether a frame starts from cleared targets or keeps what the caller drew.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TargetLoad {
    /// Clear the HDR target and the depth buffer (to the far plane, 0 under reverse-Z).
    #[default]
    Clear,
    /// Keep the caller's depth (and anything drawn into [`Renderer::hdr_target`]):
    /// the sky fills only pixels still at the far plane and the terrain is depth-tested.
    Keep,
}

/// The caller's targets for one frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameTargets<'a> {
    /// Output colour view, of the descriptor's `output_format` and the prepared size.
    pub output: &'a wgpu::TextureView,
    /// Depth view of the same size. [`OutputMode::Display`]: nimbus's depth
    /// buffer, [`crate::core::targets::DEPTH_FORMAT`], reverse-Z (1 near, 0
    /// far), written. [`OutputMode::LinearHdr`]: the caller's depth buffer,
    /// in the convention of the view given to [`Renderer::prepare_view`],
    /// any depth format (the view of its depth aspect), bound as a texture
    /// (`TEXTURE_BINDING` usage) and only read.
    pub depth: &'a wgpu::TextureView,
    /// [`OutputMode::Display`]: clear or keep the previous contents.
    /// [`OutputMode::LinearHdr`] always keeps the caller's.
    pub load: TargetLoad,
}

/// The caller's depth buffer of its world seen from above
/// ([`Renderer::set_occluder_depth`]).
#[derive(Clone, Copy, Debug)]
pub struct OccluderDepth<'a> {
    /// The view of the depth aspect of the caller's depth texture.
    pub depth: &'a wgpu::TextureView,
    /// Its width, texels.
    pub width: u32,
    /// Its height, texels.
    pub height: u32,
    /// The view it was rendered through (pose, projection, depth convention).
    pub view: View,
}

/// Why a frame cannot be prepared.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The image or a buffer exceeds the device's limits.
    #[error(transparent)]
    Limit(#[from] LimitError),
    /// The stratus layer's resources could not be built.
    #[error(transparent)]
    Stratus(#[from] crate::passes::stratus::StratusError),
    /// The cumulus shapes could not be made.
    #[error(transparent)]
    Cumulus(#[from] crate::passes::cumulus::CumulusError),
    /// The static objects' geometry could not be built.
    #[error(transparent)]
    Objects(#[from] crate::passes::objects::ObjectsError),
    /// The rain cannot be simulated on this device.
    #[error(transparent)]
    Rain(#[from] crate::passes::rain::RainError),
    /// The scene has a value outside its documented range
    /// ([`crate::scene::Scene::check`]).
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// The caller's view cannot be drawn ([`crate::frame::View::check`]).
    #[error(transparent)]
    View(#[from] crate::frame::ViewError),
    /// The output format cannot be used in the descriptor's mode on this device.
    #[error("output: {0}")]
    Output(String),
    /// The caller's occluders are malformed ([`Renderer::set_occluders`]).
    #[error("occluders: {0}")]
    Occluders(String),
    /// A shader or pipeline failed validation (WGSL read from disk by
    /// [`crate::shader::set_source_dir`] that does not compile).
    #[error("the renderer's shaders do not compile: {0}")]
    Shaders(String),
}

/// The nimbus renderer: owns the passes and the frame-wide resources and
/// records a frame in [`Renderer::encode`].
#[derive(Debug)]
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Every frame-wide resource: frame uniform, atmosphere lookups, cloud lighting.
    frame: FrameResources,
    atmosphere: AtmospherePass,
    exposure: ExposurePass,
    sky: SkyPass,
    terrain: TerrainPass,
    objects: ObjectsPass,
    stratus: StratusPass,
    cumulus: CumulusPass,
    rain: RainPass,
    tonemap: TonemapPass,
    /// The caller's frame in [`OutputMode::LinearHdr`] (depth import, air
    /// in front of the caller's surfaces, export); `None` in `Display`.
    composite: Option<CompositePass>,
    mode: OutputMode,
    output_format: wgpu::TextureFormat,
    /// Pre-exposure of [`OutputMode::LinearHdr`] output.
    pre_exposure: f32,
    hdr: Option<Target>,
    /// nimbus's own depth target in [`OutputMode::LinearHdr`] (the caller's
    /// depth translated), recreated on resize.
    own_depth: Option<Target>,
    timer: Option<GpuTimer>,
    /// Pre-exposed value the background (sky, terrain, objects) is replaced
    /// with before the clouds are drawn, if any ([`Self::set_background_override`]).
    background_override: Option<f32>,
    /// Which passes the last [`Renderer::encode`] recorded ([`PassSet`] bits).
    passes_run: AtomicU32,
    /// Set by [`Renderer::encode_lighting`] for the next [`Renderer::encode`]:
    /// a flag bit and the lighting passes it ran.
    lighting_recorded: AtomicU32,
    /// The caller's occluders ([`Self::set_occluders`]), positions only.
    caller_occluders: Option<IndexedMesh>,
    /// Counts the calls of [`Self::set_occluders`] (the rain redraws its
    /// occlusion map when it changes).
    caller_occluders_generation: u64,
    /// Where precomputation runs ([`RendererDescriptor::precompute`]).
    precompute: Precompute,
    /// The terrain pass's shadow ceiling last written to the cloud
    /// lighting (its generation; 0: none yet).
    terrain_shadow_written: u64,
}

impl Renderer {
    /// Creates the passes on the caller's device.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        descriptor: &RendererDescriptor,
    ) -> Self {
        let frame = FrameResources::new(device, queue);
        let layouts = frame.layouts();
        let atmosphere = AtmospherePass::new(device, &layouts, &frame.atmosphere);
        let sky = SkyPass::new(device, &layouts);
        let stratus = StratusPass::new(device, &layouts, &frame.cloud_lighting);
        let terrain = TerrainPass::new(device, &layouts);
        let objects = ObjectsPass::new(device, &layouts);
        let cumulus = CumulusPass::new(device, &layouts, frame.cloud_lighting.shadow());
        let rain = RainPass::new(device, &layouts);
        let tonemap = TonemapPass::new(device, queue, descriptor.output_format);
        let exposure = ExposurePass::new(device, layouts.frame);
        let composite = (descriptor.mode == OutputMode::LinearHdr)
            .then(|| CompositePass::new(device, &layouts, descriptor.output_format));
        let timer = if descriptor.timestamps {
            GpuTimer::new(device, queue, PASS_NAMES.len() as u32)
        } else {
            None
        };
        Self {
            device: device.clone(),
            queue: queue.clone(),
            frame,
            atmosphere,
            exposure,
            sky,
            terrain,
            objects,
            stratus,
            cumulus,
            rain,
            tonemap,
            composite,
            mode: descriptor.mode,
            output_format: descriptor.output_format,
            pre_exposure: 1.0,
            hdr: None,
            own_depth: None,
            timer,
            background_override: None,
            passes_run: AtomicU32::new(0),
            lighting_recorded: AtomicU32::new(0),
            caller_occluders: None,
            caller_occluders_generation: 0,
            precompute: descriptor.precompute,
            terrain_shadow_written: 0,
        }
    }

    /// The caller's own geometry that stops the rain (and casts its rain
    /// shadow), beside nimbus's terrain and `[[objects]]`: world-space
    /// positions in metres and a triangle list of indices into them (both
    /// faces count). Replaces the previous set; empty slices remove it.
    /// Errors: an index count not a multiple of 3, an index past the
    /// positions, a position not finite, or buffers over the device's limits.
    pub fn set_occluders(
        &mut self,
        positions_m: &[[f32; 3]],
        indices: &[u32],
    ) -> Result<(), RenderError> {
        if !indices.len().is_multiple_of(3) {
            return Err(RenderError::Occluders(format!(
                "{} indices: must be a multiple of 3 (a triangle list)",
                indices.len()
            )));
        }
        if let Some((i, index)) = indices
            .iter()
            .enumerate()
            .find(|(_, index)| **index as usize >= positions_m.len())
        {
            return Err(RenderError::Occluders(format!(
                "index {i} is {index}: must be less than the {} positions",
                positions_m.len()
            )));
        }
        if let Some(i) = positions_m
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(RenderError::Occluders(format!(
                "position {i} is {:?}: must be finite",
                positions_m[i]
            )));
        }
        Self::check_buffer_size(
            &self.device,
            "occluder positions",
            std::mem::size_of_val(positions_m) as u64,
        )?;
        Self::check_buffer_size(
            &self.device,
            "occluder indices",
            std::mem::size_of_val(indices) as u64,
        )?;
        self.caller_occluders = (!indices.is_empty())
            .then(|| IndexedMesh::upload(&self.device, "caller occluders", positions_m, indices));
        self.caller_occluders_generation += 1;
        Ok(())
    }

    /// The caller's world as a depth buffer seen from above, stopping the
    /// rain and casting its rain shadow beside nimbus's terrain, the
    /// `[[objects]]` and [`Self::set_occluders`]' triangles: `depth` (the
    /// view of a depth texture's depth aspect, any depth format, with
    /// `TEXTURE_BINDING` usage) of `width` × `height` texels, rendered
    /// through `view` (typically orthographic, straight down, over the
    /// rain's surroundings; any projection and depth convention). Texels at
    /// the view's far plane are open sky; the rest is a height field, so
    /// what is under an overhang counts as solid. Call again whenever its
    /// contents change (the rain shadow map is redrawn); `None` removes it.
    /// Errors: a view that cannot be drawn, a size under 2 × 2.
    pub fn set_occluder_depth(
        &mut self,
        depth: Option<OccluderDepth<'_>>,
    ) -> Result<(), RenderError> {
        if let Some(d) = &depth {
            d.view.check()?;
            if d.width < 2 || d.height < 2 {
                return Err(RenderError::Occluders(format!(
                    "depth from above of {} × {} texels: must be at least 2 × 2",
                    d.width, d.height
                )));
            }
        }
        self.rain.set_depth_occluder(
            &self.queue,
            depth
                .as_ref()
                .map(|d| (d.depth, &d.view, d.width, d.height)),
        );
        self.caller_occluders_generation += 1;
        Ok(())
    }

    /// The value radiance is multiplied by in [`OutputMode::LinearHdr`]
    /// output (e.g. the caller's exposure of the previous frame, to keep
    /// values well inside half-float range); 1 by default. Takes effect at
    /// the next [`Self::prepare_view`]. Ignored in `Display` mode, whose
    /// exposure is the scene's.
    pub fn set_pre_exposure(&mut self, pre_exposure: f32) {
        self.pre_exposure = pre_exposure;
    }

    /// The output mode the renderer was created with.
    pub fn output_mode(&self) -> OutputMode {
        self.mode
    }

    /// Replaces, from the next [`Self::encode`] on, what the sky, terrain
    /// and objects drew by a constant grey of this pre-exposed value (the
    /// depth they wrote is kept) before the clouds are drawn over it; `None`
    /// draws the frame normally. Two frames with different values give the
    /// clouds' transmittance of each pixel (the cloud passes blend linearly
    /// over what is behind them); used for the `cloud.A` layer of EXR output.
    pub fn set_background_override(&mut self, pre_exposed: Option<f32>) {
        self.background_override = pre_exposed;
    }

    /// Like [`Self::new`], but catches validation errors of the shaders and
    /// pipelines instead of leaving them to the device's error handler: for
    /// shader development, where the WGSL comes from disk
    /// ([`crate::shader::set_source_dir`]) and may not compile.
    pub fn try_new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        descriptor: &RendererDescriptor,
    ) -> Result<Self, RenderError> {
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let renderer = Self::new(device, queue, descriptor);
        match pollster::block_on(scope.pop()) {
            None => Ok(renderer),
            Some(error) => Err(RenderError::Shaders(map_error_positions(
                &error.to_string(),
            ))),
        }
    }

    /// Whether per-pass GPU timestamps are recorded.
    pub fn has_timestamps(&self) -> bool {
        self.timer.is_some()
    }

    /// Checks an image size against the device's limits.
    pub fn check_size(device: &wgpu::Device, width: u32, height: u32) -> Result<(), RenderError> {
        Ok(limits::check_image_size(device, width, height)?)
    }

    /// Checks that a buffer of `bytes` fits the device's limit.
    pub fn check_buffer_size(
        device: &wgpu::Device,
        what: &str,
        bytes: u64,
    ) -> Result<(), RenderError> {
        Ok(limits::check_buffer_size(device, what, bytes)?)
    }

    /// Updates everything a frame needs: the frame uniform, the atmosphere
    /// and the terrain (recomputed only when their inputs change), and the
    /// HDR target (recreated on resize). The scene is checked first
    /// ([`crate::scene::Scene::check`]): a value outside its documented range is
    /// [`RenderError::Scene`], with the line a scene file's would have.
    pub fn prepare(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<(), RenderError> {
        let camera = crate::frame::Camera::from_settings(&scene.camera, width, height);
        self.prepare_with_camera(scene, &camera, width, height, time_s)
    }

    /// [`Self::prepare`] with a camera of the caller's instead of the
    /// scene's (its pose and field of view; the exposure stays the scene's):
    /// e.g. the six faces of a panorama.
    pub fn prepare_with_camera(
        &mut self,
        scene: &Scene,
        camera: &crate::frame::Camera,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<(), RenderError> {
        self.prepare_view(scene, &View::from_camera(camera), width, height, time_s)
    }

    /// [`Self::prepare`] seen through the caller's view: its pose (any
    /// orientation) and projection (perspective or orthographic, finite or
    /// infinite far plane, standard or reverse depth; [`View`]). The scene's
    /// camera settings other than exposure are not used.
    pub fn prepare_view(
        &mut self,
        scene: &Scene,
        view: &View,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<(), RenderError> {
        // The same checks as a scene file's: a scene built in code gets the
        // same one-line errors instead of NaNs or a device error.
        scene.check()?;
        view.check()?;
        Self::check_size(&self.device, width, height)?;
        self.check_output()?;
        let camera = &view.pinhole(height);
        if self.hdr.as_ref().map(Target::size) != Some((width, height)) {
            // A software driver may end the process where it runs out of
            // memory: the targets are refused first where they cannot fit.
            limits::check_frame_memory(&self.device, width, height)?;
            let hdr = Target::new(
                &self.device,
                "hdr colour",
                HDR_FORMAT,
                width,
                height,
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            );
            self.exposure
                .set_input(&self.device, &hdr.view, &self.frame.atmosphere.lighting);
            self.tonemap
                .set_input(&self.device, &hdr.view, self.exposure.state_buffer());
            self.hdr = Some(hdr);
        }
        let mut frame = FrameUniform::with_view(scene, view, width, height, time_s);
        if let Some(composite) = &mut self.composite {
            // The caller exposes its frame: nimbus's radiance only pre-exposed.
            frame.exposure_scale = self.pre_exposure;
            frame.auto_exposure = 0;
            composite.prepare(&self.queue, view);
            if self.own_depth.as_ref().map(Target::size) != Some((width, height)) {
                let own_depth = Target::new(
                    &self.device,
                    "nimbus depth",
                    DEPTH_FORMAT,
                    width,
                    height,
                    wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
                );
                // The HDR target was resized with it, just above.
                if let Some(hdr) = &self.hdr {
                    composite.set_targets(&self.device, &own_depth.view, &hdr.view);
                }
                self.own_depth = Some(own_depth);
            }
        }
        self.frame.write_uniform(&self.queue, &frame);
        self.sky.prepare(
            &self.queue,
            SkySettings {
                water_level_m: scene.terrain.water_level_m as f32,
                water_albedo: scene.terrain.albedo.water,
                terrain_half_extent_m: if scene.ground.terrain {
                    (0.5 * scene.terrain.extent_m) as f32
                } else {
                    0.0
                },
            },
        );
        let ground = if scene.ground.terrain {
            Ground::Relief(scene.terrain.clone())
        } else {
            Ground::Flat {
                extent_m: scene.terrain.extent_m,
                height_m: scene.ground.height_m,
                albedo: scene.ground.albedo.map(|c| c as f32),
                albedo_map: scene.ground.albedo_map.clone(),
            }
        };
        let precompute = self.precompute;
        self.terrain
            .prepare(&self.device, &self.queue, &ground, precompute)?;
        self.terrain
            .prepare_sun(&self.queue, scene.sun.direction(), precompute);
        // The terrain's shadow in the air, for the clouds and the rain
        // behind its ridges (the frame's group 3).
        if let Some((ceiling, half_extent_m, generation)) = self.terrain.sun_shadow_ceiling()
            && generation != self.terrain_shadow_written
        {
            self.frame
                .cloud_lighting
                .write_terrain_shadow(&self.queue, ceiling, half_extent_m);
            self.terrain_shadow_written = generation;
        }
        // The near ground's albedo lights the clouds from below; until the
        // terrain is generated (in the background), the atmosphere's.
        let near_ground_albedo = self
            .terrain
            .mean_albedo()
            .unwrap_or(scene.atmosphere.ground_albedo);
        self.objects.prepare(&self.device, scene)?;
        self.stratus.prepare(
            &self.device,
            &self.queue,
            scene,
            self.terrain.terrain(),
            time_s,
            &mut self.frame.cloud_lighting,
            precompute,
        )?;
        self.cumulus.prepare(
            &self.device,
            &self.queue,
            scene,
            &frame,
            self.frame.cloud_lighting.shadow(),
            width,
            height,
            precompute,
        )?;
        // The clouds' environment is taken at their mean centre (at the
        // camera before any cumulus is drawn).
        let clouds_observer_m = self
            .cumulus
            .mean_centre_m()
            .unwrap_or(scene.camera.position_m);
        self.atmosphere.prepare(
            &self.queue,
            &scene.atmosphere,
            scene.camera.aerial_perspective,
            near_ground_albedo,
            &CloudsGround::of_scene(scene, clouds_observer_m),
            &frame,
        );
        let occluders = self.occluders();
        let strides: Vec<u64> = occluders.iter().map(|g| g.vertex_stride).collect();
        let generation = [
            self.objects.generation(),
            self.terrain.generation(),
            self.caller_occluders_generation,
        ];
        let footprints = self.cumulus.footprints_m();
        self.rain.prepare(
            &self.device,
            &self.queue,
            scene,
            camera,
            time_s,
            &footprints,
            generation,
            &strides,
            self.terrain.terrain(),
            precompute,
        )?;
        Ok(())
    }

    /// The precomputation under way on worker threads, by name (e.g.
    /// "cumulus shapes", "stratus optics", "terrain"): empty once every
    /// part of the last prepared scene is drawn as it should be. Under
    /// [`Precompute::Background`] a frame prepared while work is pending
    /// leaves out what is not ready (no cumulus before its shapes, no layer
    /// before its optics, no terrain before it is generated) and the next
    /// [`Self::prepare_view`] after it finishes picks it up.
    pub fn pending_work(&self) -> Vec<&'static str> {
        self.terrain
            .pending()
            .chain(self.stratus.pending())
            .chain(self.cumulus.pending())
            .chain(self.rain.pending())
            .collect()
    }

    /// Whether nothing is pending ([`Self::pending_work`] is empty).
    pub fn is_ready(&self) -> bool {
        self.pending_work().is_empty()
    }

    /// Blocks until the work under way has finished. Work that depends on
    /// it (the terrain's sun visibility, the layer's radiosity grid) starts
    /// at the next prepare: to render one complete frame, repeat
    /// `prepare_view`, `wait_for_precompute` until [`Self::is_ready`] (or
    /// create the renderer with [`Precompute::Blocking`]).
    pub fn wait_for_precompute(&mut self) {
        self.terrain.wait();
        self.stratus.wait();
        self.cumulus.wait();
        self.rain.wait();
    }

    /// Where the next frames' precomputation runs.
    pub fn set_precompute(&mut self, precompute: Precompute) {
        self.precompute = precompute;
    }

    /// Checks that the output format suits the mode on this device.
    fn check_output(&self) -> Result<(), RenderError> {
        if self.mode != OutputMode::LinearHdr {
            return Ok(());
        }
        match self.output_format {
            wgpu::TextureFormat::Rgba16Float => Ok(()),
            wgpu::TextureFormat::Rgba32Float
                if self
                    .device
                    .features()
                    .contains(wgpu::Features::FLOAT32_BLENDABLE) =>
            {
                Ok(())
            }
            wgpu::TextureFormat::Rgba32Float => Err(RenderError::Output(
                "LinearHdr into Rgba32Float needs the device feature FLOAT32_BLENDABLE (nimbus blends over the caller's colour); use Rgba16Float or request the feature".into(),
            )),
            format => Err(RenderError::Output(format!(
                "LinearHdr into {format:?}: must be Rgba16Float or Rgba32Float"
            ))),
        }
    }

    /// What stops the rain: the terrain, the static objects and the
    /// caller's occluders.
    fn occluders(&self) -> Vec<crate::frame::occluders::OccluderGeometry<'_>> {
        [
            self.terrain.occluder_geometry(),
            self.objects.occluder_geometry(),
            self.caller_occluders
                .as_ref()
                .map(OccluderGeometry::of_mesh::<[f32; 3]>),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    /// After the frame's submission: waits for it and returns each pass's GPU
    /// time in ms, in [`PASS_NAMES`] order, `None` for passes the frame did
    /// not need (their inputs were unchanged). `None` overall without
    /// timestamp support.
    pub fn read_pass_times_ms(&self) -> Option<Vec<Option<f64>>> {
        let times = self
            .timer
            .as_ref()
            .and_then(|t| t.read_ms(&self.device).ok())?;
        let run = PassSet::from_bits(self.passes_run.load(Ordering::Relaxed));
        Some(
            times
                .into_iter()
                .zip(PassId::ALL)
                .map(|(t, id)| run.contains(id).then_some(t))
                .collect(),
        )
    }

    /// Makes the next frame recompute every atmosphere LUT (for benchmarks).
    pub fn invalidate_atmosphere(&self) {
        self.atmosphere.invalidate();
    }

    /// Makes the next frame redraw the cloud shadow map even where what it
    /// shows has not changed (for benchmarks).
    pub fn invalidate_cloud_shadow(&self) {
        self.cumulus.invalidate_shadow();
    }

    /// The exposure pass (its state buffer holds the applied EV100).
    pub fn exposure(&self) -> &ExposurePass {
        &self.exposure
    }

    /// The atmosphere pass (LUTs and lighting inputs).
    pub fn atmosphere(&self) -> &AtmospherePass {
        &self.atmosphere
    }

    /// The HDR colour target (pre-exposed linear radiance), once prepared.
    pub fn hdr_target(&self) -> Option<&Target> {
        self.hdr.as_ref()
    }

    /// The cumulus pass.
    pub fn cumulus(&self) -> &CumulusPass {
        &self.cumulus
    }

    /// The cloud shadow map.
    pub fn cloud_shadow(&self) -> &CloudShadowMap {
        self.frame.cloud_lighting.shadow()
    }

    /// The frame-wide resources (frame uniform, atmosphere lookups, cloud
    /// lighting), e.g. for a caller's pipelines that read them.
    pub fn frame_resources(&self) -> &FrameResources {
        &self.frame
    }

    /// The stratus pass (its radiosity and uniform).
    pub fn stratus(&self) -> &StratusPass {
        &self.stratus
    }

    /// The rain pass.
    pub fn rain(&self) -> &RainPass {
        &self.rain
    }

    /// The rain pass, to change how it lays out its buffers.
    pub fn rain_mut(&mut self) -> &mut RainPass {
        &mut self.rain
    }

    /// The static objects' pass (their occluder geometry and bounds).
    pub fn objects(&self) -> &ObjectsPass {
        &self.objects
    }

    /// The terrain pass (its occluder geometry).
    pub fn terrain(&self) -> &TerrainPass {
        &self.terrain
    }

    /// The terrain's albedo map (RGB albedo, A water mask), once prepared.
    pub fn terrain_albedo_view(&self) -> Option<&wgpu::TextureView> {
        self.terrain.albedo_view()
    }

    /// The terrain's albedo texture, once prepared.
    pub fn terrain_albedo_texture(&self) -> Option<&wgpu::Texture> {
        self.terrain.albedo_texture()
    }
}
