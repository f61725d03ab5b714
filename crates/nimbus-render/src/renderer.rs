//! The renderer: owns the passes and runs them in the frame's order.
//!
//! The frame's pass order lives in [`Renderer::encode`] and nowhere else:
//! the atmosphere's LUTs and lighting inputs (when their inputs changed),
//! the stratus layer's field and radiosity, the cumulus shadow map, sky,
//! terrain, the static objects, the cumulus bodies and fringes, the stratus layer, the cumulus
//! fringes' composite, exposure, then tone mapping into the caller's output
//! target. Every pass writes GPU timestamps when the device supports them.

use crate::atmosphere::AtmospherePass;
use crate::cumulus::{CloudShadowMap, CumulusPass};
use crate::exposure::ExposurePass;
use crate::frame::{FrameBinding, FrameUniform};
use crate::objects::ObjectsPass;
use crate::rain::RainPass;
use crate::scene::Scene;
use crate::sky::{SkyPass, SkySettings};
use crate::stratus::StratusPass;
use crate::targets::{FAR_DEPTH, HDR_FORMAT, Target};
use crate::terrain::TerrainPass;
use crate::timing::GpuTimer;
use crate::tonemap::TonemapPass;

/// Names of the passes in frame order, as reported by timings.
pub const PASS_NAMES: [&str; 19] = [
    "transmittance",
    "multiple_scattering",
    "sky_view",
    "aerial_perspective",
    "lighting",
    "stratus_lighting",
    "cumulus_shadow",
    "rain_simulation",
    "sky",
    "terrain",
    "objects",
    "cumulus",
    "cumulus_fringes",
    "stratus",
    "cumulus_composite",
    "rain_mist",
    "rain",
    "exposure",
    "tonemap",
];

/// Timer slots of the passes after the atmosphere's.
const STRATUS_LIGHTING_PASS_INDEX: u32 = crate::atmosphere::PASS_NAMES.len() as u32;
const CUMULUS_SHADOW_PASS_INDEX: u32 = STRATUS_LIGHTING_PASS_INDEX + 1;
const RAIN_SIMULATION_PASS_INDEX: u32 = CUMULUS_SHADOW_PASS_INDEX + 1;
const SKY_PASS_INDEX: u32 = RAIN_SIMULATION_PASS_INDEX + 1;
const TERRAIN_PASS_INDEX: u32 = SKY_PASS_INDEX + 1;
const OBJECTS_PASS_INDEX: u32 = TERRAIN_PASS_INDEX + 1;
const CUMULUS_PASS_INDEX: u32 = OBJECTS_PASS_INDEX + 1;
const CUMULUS_FRINGES_PASS_INDEX: u32 = CUMULUS_PASS_INDEX + 1;
const STRATUS_PASS_INDEX: u32 = CUMULUS_FRINGES_PASS_INDEX + 1;
const CUMULUS_COMPOSITE_PASS_INDEX: u32 = STRATUS_PASS_INDEX + 1;
const RAIN_MIST_PASS_INDEX: u32 = CUMULUS_COMPOSITE_PASS_INDEX + 1;
const RAIN_PASS_INDEX: u32 = RAIN_MIST_PASS_INDEX + 1;
const EXPOSURE_PASS_INDEX: u32 = RAIN_PASS_INDEX + 1;
const TONEMAP_PASS_INDEX: u32 = EXPOSURE_PASS_INDEX + 1;

/// How the renderer is set up.
#[derive(Clone, Copy, Debug)]
pub struct RendererDescriptor {
    /// Format of the caller's output target (any renderable colour format;
    /// 8-bit unorm formats get sRGB encoding and dithering in the shader).
    pub output_format: wgpu::TextureFormat,
    /// Write per-pass GPU timestamps when the device supports them.
    pub timestamps: bool,
}

/// Whether a frame starts from cleared targets or keeps what the caller drew.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TargetLoad {
    /// Clear the HDR target and the depth buffer (to the far plane, 0 under reverse-Z).
    #[default]
    Clear,
    /// Keep the caller's depth (and anything drawn into [`Renderer::hdr_view`]):
    /// the sky fills only pixels still at the far plane and the terrain is depth-tested.
    Keep,
}

/// The caller's targets for one frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameTargets<'a> {
    /// Output colour view, of the descriptor's `output_format` and the prepared size.
    pub output: &'a wgpu::TextureView,
    /// Depth view, [`crate::targets::DEPTH_FORMAT`], same size; reverse-Z (1 near, 0 far).
    pub depth: &'a wgpu::TextureView,
    /// Clear or keep the previous contents.
    pub load: TargetLoad,
}

/// Why a frame cannot be prepared.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The image is larger than the device allows.
    #[error(
        "image size {width}×{height}: each side must be in [1, {max}] on this device, and the area at most {max_pixels} pixels"
    )]
    ImageSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// The device's largest 2D texture side.
        max: u32,
        /// The largest area.
        max_pixels: u64,
    },
    /// A GPU buffer would exceed the device's limit.
    #[error("{what} needs a {bytes}-byte buffer; this device allows at most {max} bytes")]
    BufferTooLarge {
        /// What the buffer is for, naming the setting that sizes it.
        what: String,
        /// Bytes needed.
        bytes: u64,
        /// The device's `max_buffer_size`.
        max: u64,
    },
    /// The stratus layer's resources could not be built.
    #[error(transparent)]
    Stratus(#[from] crate::stratus::StratusError),
    /// The cumulus shapes could not be made.
    #[error(transparent)]
    Cumulus(#[from] crate::cumulus::CumulusError),
    /// The static objects' geometry could not be built.
    #[error(transparent)]
    Objects(#[from] crate::objects::ObjectsError),
    /// The rain cannot be simulated on this device.
    #[error(transparent)]
    Rain(#[from] crate::rain::RainError),
    /// A shader or pipeline failed validation (WGSL read from disk by
    /// [`crate::shader::set_source_dir`] that does not compile).
    #[error("the renderer's shaders do not compile: {0}")]
    Shaders(String),
}

/// Lighting depends only on these scene values; recomputed when they change.
/// The nimbus renderer.
#[derive(Debug)]
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    frame: FrameBinding,
    atmosphere: AtmospherePass,
    exposure: ExposurePass,
    sky: SkyPass,
    terrain: TerrainPass,
    objects: ObjectsPass,
    stratus: StratusPass,
    cloud_shadow: CloudShadowMap,
    cumulus: CumulusPass,
    rain: RainPass,
    tonemap: TonemapPass,
    hdr: Option<Target>,
    timer: Option<GpuTimer>,
    /// Pre-exposed value the background (sky, terrain, objects) is replaced
    /// with before the clouds are drawn, if any ([`Self::set_background_override`]).
    background_override: Option<f32>,
    /// Which passes the last [`Renderer::encode`] recorded, in [`PASS_NAMES`] order.
    passes_run: std::sync::Mutex<[bool; PASS_NAMES.len()]>,
}

impl Renderer {
    /// Creates the passes on the caller's device.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        descriptor: &RendererDescriptor,
    ) -> Self {
        let frame = FrameBinding::new(
            device,
            "frame uniform",
            wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        );
        let atmosphere = AtmospherePass::new(device, &frame.layout);
        let sky = SkyPass::new(device, &frame.layout, atmosphere.lookup_layout());
        let cloud_shadow = CloudShadowMap::new(device, queue);
        let stratus = StratusPass::new(
            device,
            &frame.layout,
            atmosphere.lookup_layout(),
            cloud_shadow.lookup_layout(),
        );
        let terrain = TerrainPass::new(
            device,
            &frame.layout,
            atmosphere.lookup_layout(),
            stratus.lookup_layout(),
        );
        let objects = ObjectsPass::new(
            device,
            &frame.layout,
            atmosphere.lookup_layout(),
            stratus.lookup_layout(),
        );
        let cumulus = CumulusPass::new(
            device,
            &frame.layout,
            atmosphere.lookup_layout(),
            stratus.lookup_layout(),
            &cloud_shadow,
        );
        let rain = RainPass::new(
            device,
            &frame.layout,
            atmosphere.lookup_layout(),
            stratus.lookup_layout(),
        );
        let tonemap = TonemapPass::new(device, queue, descriptor.output_format);
        let exposure = ExposurePass::new(device, &frame.layout);
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
            cloud_shadow,
            cumulus,
            rain,
            tonemap,
            hdr: None,
            timer,
            background_override: None,
            passes_run: std::sync::Mutex::new([false; PASS_NAMES.len()]),
        }
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
            Some(error) => Err(RenderError::Shaders(crate::shader::map_error_positions(
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
        let max = device
            .limits()
            .max_texture_dimension_2d
            .min(crate::scene::MAX_IMAGE_SIDE_PX);
        let max_pixels = crate::scene::MAX_IMAGE_PIXELS;
        if width == 0
            || height == 0
            || width > max
            || height > max
            || width as u64 * height as u64 > max_pixels
        {
            return Err(RenderError::ImageSize {
                width,
                height,
                max,
                max_pixels,
            });
        }
        Ok(())
    }

    /// Checks that a buffer of `bytes` fits the device's limit.
    pub fn check_buffer_size(
        device: &wgpu::Device,
        what: &str,
        bytes: u64,
    ) -> Result<(), RenderError> {
        let max = device.limits().max_buffer_size;
        if bytes > max {
            return Err(RenderError::BufferTooLarge {
                what: what.to_owned(),
                bytes,
                max,
            });
        }
        Ok(())
    }

    /// Updates everything a frame needs: the frame uniform, the atmosphere
    /// and the terrain (recomputed only when their inputs change), and the
    /// HDR target (recreated on resize).
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
        Self::check_size(&self.device, width, height)?;
        if self.hdr.as_ref().map(Target::size) != Some((width, height)) {
            let hdr = Target::new(
                &self.device,
                "hdr colour",
                HDR_FORMAT,
                width,
                height,
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            );
            self.exposure
                .set_input(&self.device, &hdr.view, self.atmosphere.lighting_buffer());
            self.tonemap
                .set_input(&self.device, &hdr.view, self.exposure.state_buffer());
            self.hdr = Some(hdr);
        }
        let frame = FrameUniform::with_camera(scene, camera, width, height, time_s);
        self.frame.write(&self.queue, &frame);
        self.atmosphere
            .prepare(&self.queue, &scene.atmosphere, &frame);
        self.sky.prepare(
            &self.queue,
            SkySettings {
                water_level_m: scene.terrain.water_level_m as f32,
                water_albedo: scene.terrain.albedo.water,
            },
        );
        self.terrain.prepare(
            &self.device,
            &self.queue,
            &scene.terrain,
            &self.cloud_shadow,
        )?;
        self.terrain.prepare_sun(&self.queue, scene.sun.direction());
        self.objects
            .prepare(&self.device, &self.queue, scene, &self.cloud_shadow)?;
        if let Some(terrain) = self.terrain.terrain() {
            self.stratus
                .prepare(&self.device, &self.queue, scene, terrain, time_s)?;
        }
        self.cumulus.prepare(
            &self.device,
            &self.queue,
            scene,
            &frame,
            &self.cloud_shadow,
            width,
            height,
        )?;
        let occluders = self.occluders();
        let strides: Vec<u64> = occluders.iter().map(|g| g.vertex_stride).collect();
        let generation = (self.objects.generation(), self.terrain.generation());
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
        )?;
        Ok(())
    }

    /// What stops the rain: the terrain and the static objects.
    fn occluders(&self) -> Vec<crate::occluders::OccluderGeometry<'_>> {
        [
            self.terrain.occluder_geometry(),
            self.objects.occluder_geometry(),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    /// Records the frame: atmosphere LUTs, sky, terrain, tone mapping. Call
    /// [`Self::prepare`] first.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, targets: &FrameTargets<'_>) {
        let Some(hdr) = &self.hdr else { return };
        let mut run = [true; PASS_NAMES.len()];
        // 1. Atmosphere: LUTs, aerial perspective and lighting inputs, where their inputs changed.
        let atmosphere_run =
            self.atmosphere
                .encode(encoder, &self.frame.bind_group, self.timer.as_ref(), 0);
        run[..atmosphere_run.len()].copy_from_slice(&atmosphere_run);
        let atmosphere = self.atmosphere.lookup_bind_group();
        let (color_load, depth_load) = match targets.load {
            TargetLoad::Clear => (
                wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                wgpu::LoadOp::Clear(FAR_DEPTH),
            ),
            TargetLoad::Keep => (wgpu::LoadOp::Load, wgpu::LoadOp::Load),
        };
        let frame = &self.frame.bind_group;
        let Some(stratus) = self.stratus.lookup_group() else {
            return;
        };
        // 2. The stratus layer's thickness field and ground–cloud radiosity.
        if self.stratus.enabled() {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("stratus lighting"),
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .map(|t| t.compute_pass_writes(STRATUS_LIGHTING_PASS_INDEX)),
            });
            self.stratus.encode_compute(&mut pass, frame, atmosphere);
        } else {
            run[STRATUS_LIGHTING_PASS_INDEX as usize] = false;
            run[STRATUS_PASS_INDEX as usize] = false;
        }
        // 3. The cumulus shadow map (cleared to "no cloud" when there is none).
        self.cumulus.encode_shadow(
            encoder,
            frame,
            &self.cloud_shadow,
            self.timer
                .as_ref()
                .map(|t| (t.query_set(), CUMULUS_SHADOW_PASS_INDEX)),
        );
        if !self.cumulus.shadow_enabled() {
            run[CUMULUS_SHADOW_PASS_INDEX as usize] = false;
        }
        // 3b. The rain: its shadow map when needed, the steps since the last
        // frame, and the list of drops in view.
        let rain = self.rain.enabled();
        if rain {
            self.rain.encode_simulation(
                encoder,
                frame,
                &self.occluders(),
                self.timer
                    .as_ref()
                    .map(|t| t.compute_pass_writes(RAIN_SIMULATION_PASS_INDEX)),
            );
        } else {
            for index in [RAIN_SIMULATION_PASS_INDEX, RAIN_PASS_INDEX] {
                run[index as usize] = false;
            }
        }
        if !self.rain.mist_enabled() {
            run[RAIN_MIST_PASS_INDEX as usize] = false;
        }
        let cumulus = self.cumulus.enabled();
        if !cumulus {
            for index in [
                CUMULUS_PASS_INDEX,
                CUMULUS_FRINGES_PASS_INDEX,
                CUMULUS_COMPOSITE_PASS_INDEX,
            ] {
                run[index as usize] = false;
            }
        }
        if !self.objects.enabled() {
            run[OBJECTS_PASS_INDEX as usize] = false;
        }
        if let Ok(mut last) = self.passes_run.lock() {
            *last = run;
        }
        // 4. Sky, sun and open sea, at the far plane.
        {
            let mut pass = self.hdr_pass(
                encoder,
                "sky",
                SKY_PASS_INDEX,
                hdr,
                targets.depth,
                color_load,
                depth_load,
            );
            self.sky.draw(&mut pass, frame, atmosphere);
        }
        // 5. Terrain, depth-tested.
        {
            let mut pass = self.hdr_pass(
                encoder,
                "terrain",
                TERRAIN_PASS_INDEX,
                hdr,
                targets.depth,
                wgpu::LoadOp::Load,
                wgpu::LoadOp::Load,
            );
            self.terrain.draw(&mut pass, frame, atmosphere, stratus);
        }
        // 5b. Static objects (boxes, glTF meshes), depth-tested like the terrain.
        if self.objects.enabled() {
            let mut pass = self.hdr_pass(
                encoder,
                "objects",
                OBJECTS_PASS_INDEX,
                hdr,
                targets.depth,
                wgpu::LoadOp::Load,
                wgpu::LoadOp::Load,
            );
            self.objects.draw(&mut pass, frame, atmosphere, stratus);
        }
        // 5c. For the cloud-opacity layer: the background replaced by a
        // known constant (the depth kept), so that the clouds' transmittance
        // can be read from two frames (see `headless::HeadlessRenderer::render_layers`).
        if let Some(value) = self.background_override {
            encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("background override"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: f64::from(value),
                            g: f64::from(value),
                            b: f64::from(value),
                            a: 0.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        }
        // 6. Cumulus: opaque bodies (depth written), then the fringes'
        // order-independent accumulation against that depth.
        if cumulus {
            {
                let mut pass = self.hdr_pass(
                    encoder,
                    "cumulus",
                    CUMULUS_PASS_INDEX,
                    hdr,
                    targets.depth,
                    wgpu::LoadOp::Load,
                    wgpu::LoadOp::Load,
                );
                self.cumulus
                    .draw_opaque(&mut pass, frame, atmosphere, stratus);
            }
            self.cumulus.encode_fringes(
                encoder,
                targets.depth,
                [frame, atmosphere, stratus],
                self.timer
                    .as_ref()
                    .map(|t| t.pass_writes(CUMULUS_FRINGES_PASS_INDEX)),
            );
        }
        // 7. The stratus layer, blended over sky, terrain and cumulus bodies, depth-tested.
        if self.stratus.enabled() {
            let mut pass = self.hdr_pass(
                encoder,
                "stratus",
                STRATUS_PASS_INDEX,
                hdr,
                targets.depth,
                wgpu::LoadOp::Load,
                wgpu::LoadOp::Load,
            );
            self.stratus.draw(
                &mut pass,
                frame,
                atmosphere,
                self.cloud_shadow.lookup_group(),
            );
        }
        // 8. The cumulus fringes over everything behind them.
        if cumulus {
            let mut pass = self.overlay_pass(
                encoder,
                "cumulus composite",
                CUMULUS_COMPOSITE_PASS_INDEX,
                hdr,
                None,
            );
            self.cumulus.draw_composite(&mut pass);
        }
        // 8b. Rain mist beyond the rain box, over everything (reads the depth).
        if self.rain.mist_enabled() {
            let mut pass = self.overlay_pass(encoder, "rain mist", RAIN_MIST_PASS_INDEX, hdr, None);
            self.rain
                .draw_mist(&mut pass, targets.depth, [frame, atmosphere, stratus]);
        }
        // 8c. Rain streaks and splashes, depth-tested against a read-only
        // depth that they also read, to fade where they meet surfaces.
        if rain {
            let mut pass =
                self.overlay_pass(encoder, "rain", RAIN_PASS_INDEX, hdr, Some(targets.depth));
            self.rain
                .draw(&mut pass, targets.depth, [frame, atmosphere, stratus]);
        }
        // 9. Exposure: meter the frame (automatic exposure) or pass the manual EV through.
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("exposure"),
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .map(|t| t.compute_pass_writes(EXPOSURE_PASS_INDEX)),
            });
            self.exposure.encode(&mut pass, frame);
        }
        // 10. Tone map into the caller's output.
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("tonemap"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: targets.output,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .map(|t| t.pass_writes(TONEMAP_PASS_INDEX)),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.tonemap.draw(&mut pass);
        }
        if let Some(timer) = &self.timer {
            timer.resolve(encoder);
        }
    }

    /// A pass drawing over the HDR target as it is (colour loaded and kept),
    /// with the depth attached read-only when given.
    fn overlay_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        index: u32,
        hdr: &Target,
        read_only_depth: Option<&wgpu::TextureView>,
    ) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &hdr.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: read_only_depth.map(|view| {
                wgpu::RenderPassDepthStencilAttachment {
                    view,
                    depth_ops: None,
                    stencil_ops: None,
                }
            }),
            timestamp_writes: self.timer.as_ref().map(|t| t.pass_writes(index)),
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn hdr_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        index: u32,
        hdr: &Target,
        depth: &wgpu::TextureView,
        color_load: wgpu::LoadOp<wgpu::Color>,
        depth_load: wgpu::LoadOp<f32>,
    ) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &hdr.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: color_load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: depth_load,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: self.timer.as_ref().map(|t| t.pass_writes(index)),
            occlusion_query_set: None,
            multiview_mask: None,
        })
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
        let run = self
            .passes_run
            .lock()
            .map(|r| *r)
            .unwrap_or([true; PASS_NAMES.len()]);
        Some(
            times
                .into_iter()
                .zip(run)
                .map(|(t, ran)| ran.then_some(t))
                .collect(),
        )
    }

    /// Makes the next frame recompute every atmosphere LUT (for benchmarks).
    pub fn invalidate_atmosphere(&self) {
        self.atmosphere.invalidate();
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
        &self.cloud_shadow
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
