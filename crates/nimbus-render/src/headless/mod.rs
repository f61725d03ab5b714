//! Headless rendering: a device of its own, offscreen targets, and read-back
//! of the tone-mapped (RGBA8, sRGB) or HDR (linear radiance) image. Used by
//! the CLI, the tests and the benchmarks.

mod layers;
pub mod panorama;

pub use layers::{ImageLayers, SKY_DISTANCE_M};

use crate::core::fault::{FaultScope, GpuFault, wait_for_device};
use crate::core::gpu::{AdapterPreference, GpuContext, GpuError};
use crate::core::targets::{DEPTH_FORMAT, Target};
use crate::frame::{Camera, View};
use crate::renderer::{
    FrameTargets, Precompute, RenderError, Renderer, RendererDescriptor, TargetLoad,
};
use crate::scene::{Projection, Scene};

/// Format of the tone-mapped output.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Why a headless render failed.
#[derive(Debug, thiserror::Error)]
pub enum HeadlessError {
    /// No adapter or device.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The frame could not be prepared.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// Reading the image back failed.
    #[error("reading the image back from the GPU failed: {0}")]
    Readback(String),
    /// The device was lost, ran out of memory or refused the work: the
    /// frame or read-back did not complete and its result was not returned.
    #[error(transparent)]
    Fault(#[from] GpuFault),
}

/// A tone-mapped image: sRGB-encoded RGBA8, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgba8Image {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Pixels, 4 bytes each.
    pub pixels: Vec<u8>,
}

/// How an image differs from its golden image, the test suites' perceptual
/// comparison: CIE76 ΔE per pixel
/// ([`nimbus_physics::photometry::delta_e76`]). It passes when the mean ΔE
/// is at most [`Self::MAX_MEAN`] and at most [`Self::MAX_LARGE_FRACTION`] of
/// the pixels differ by more than [`Self::LARGE`] (about a just-noticeable
/// difference on average; isolated edge pixels may move between adapters).
#[derive(Clone, Debug, PartialEq)]
pub struct GoldenDifference {
    /// ΔE of each pixel, rows top to bottom.
    pub delta_e: Vec<f64>,
    /// Their mean.
    pub mean: f64,
    /// Fraction of pixels with ΔE over [`Self::LARGE`].
    pub large_fraction: f64,
}

impl GoldenDifference {
    /// Largest mean ΔE that passes.
    pub const MAX_MEAN: f64 = 1.5;
    /// ΔE above which a pixel counts as visibly different.
    pub const LARGE: f64 = 10.0;
    /// Largest fraction of visibly different pixels that passes.
    pub const MAX_LARGE_FRACTION: f64 = 0.01;

    /// Compares two RGBA8 sRGB pixel buffers of the same size (alpha ignored).
    pub fn between(golden: &[u8], actual: &[u8]) -> Self {
        let delta_e: Vec<f64> = golden
            .chunks(4)
            .zip(actual.chunks(4))
            .map(|(a, b)| {
                nimbus_physics::photometry::delta_e76([a[0], a[1], a[2]], [b[0], b[1], b[2]])
            })
            .collect();
        let n = delta_e.len().max(1) as f64;
        let mean = delta_e.iter().sum::<f64>() / n;
        let large_fraction = delta_e.iter().filter(|d| **d > Self::LARGE).count() as f64 / n;
        Self {
            delta_e,
            mean,
            large_fraction,
        }
    }

    /// Whether the difference is within the tolerance.
    pub fn passes(&self) -> bool {
        self.mean <= Self::MAX_MEAN && self.large_fraction <= Self::MAX_LARGE_FRACTION
    }
}

/// An HDR image: linear radiance per RGB channel, W·sr⁻¹·m⁻², rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// RGB radiance per pixel.
    pub pixels: Vec<[f32; 3]>,
}

/// A renderer with its own device and offscreen targets.
#[derive(Debug)]
pub struct HeadlessRenderer {
    /// The device.
    pub gpu: GpuContext,
    /// The renderer.
    pub renderer: Renderer,
    targets: Option<(Target, Target)>,
    last_cpu: FrameCpuTimes,
}

/// CPU time the last frame spent in the renderer's two per-frame calls: what
/// an embedder's render thread pays each frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCpuTimes {
    /// [`Renderer::prepare_with_camera`] (uniforms, resources that changed,
    /// CPU-side updates), s.
    pub prepare_s: f64,
    /// [`Renderer::encode`] and finishing the command buffer, s.
    pub encode_s: f64,
}

impl HeadlessRenderer {
    /// Opens an adapter of the preferred kind and creates the renderer.
    pub fn new(preference: AdapterPreference) -> Result<Self, HeadlessError> {
        let gpu = GpuContext::new(preference)?;
        let scope = FaultScope::push(&gpu.device);
        let renderer = Renderer::new(
            &gpu.device,
            &gpu.queue,
            &RendererDescriptor::display(OUTPUT_FORMAT)
                .with_timestamps(true)
                .with_precompute(Precompute::Blocking),
        );
        settle(
            &gpu,
            scope.pop("creating the renderer's pipelines and resources"),
            Ok(()),
        )?;
        Ok(Self {
            gpu,
            renderer,
            targets: None,
            last_cpu: FrameCpuTimes::default(),
        })
    }

    /// Renders one frame and waits for it; returns the wall-clock time from
    /// submission to completion, s.
    pub fn render_frame(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<f64, HeadlessError> {
        let camera = Camera::from_settings(&scene.camera, width, height);
        self.render_frame_with_camera(scene, &camera, width, height, time_s)
    }

    /// [`Self::render_frame`] seen by a given camera.
    pub fn render_frame_with_camera(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<f64, HeadlessError> {
        self.render_frame_with_view(scene, &View::from_camera(camera), width, height, time_s)
    }

    /// [`Self::render_frame`] seen by a caller's view ([`Renderer::prepare_view`]).
    pub fn render_frame_with_view(
        &mut self,
        scene: &Scene,
        view: &View,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<f64, HeadlessError> {
        // A device lost since the last frame (or an error of work outside
        // the frames) stops here, before any work.
        self.gpu.faults.check()?;
        // Everything the frame creates, records and submits, and the wait
        // for it; a fault stops the frame there, before anything is read back.
        let scope = FaultScope::push(&self.gpu.device);
        let prepare_start = std::time::Instant::now();
        self.renderer
            .prepare_view(scene, view, width, height, time_s)?;
        let prepare_s = prepare_start.elapsed().as_secs_f64();
        if self.targets.as_ref().map(|(o, _)| o.size()) != Some((width, height)) {
            let output = Target::new(
                &self.gpu.device,
                "output",
                OUTPUT_FORMAT,
                width,
                height,
                wgpu::TextureUsages::COPY_SRC,
            );
            let depth = Target::new(
                &self.gpu.device,
                "depth",
                DEPTH_FORMAT,
                width,
                height,
                // The rain's streaks and mist read the depth; the EXR's
                // distance layer copies it.
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            );
            self.targets = Some((output, depth));
        }
        let Some((output, depth)) = &self.targets else {
            unreachable!("targets were just created")
        };
        let encode_start = std::time::Instant::now();
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.renderer.encode(
            &mut encoder,
            &FrameTargets {
                output: &output.view,
                depth: &depth.view,
                load: TargetLoad::Clear,
            },
        );
        let commands = encoder.finish();
        self.last_cpu = FrameCpuTimes {
            prepare_s,
            encode_s: encode_start.elapsed().as_secs_f64(),
        };
        let start = std::time::Instant::now();
        self.gpu.queue.submit([commands]);
        let waited = wait_for_device(&self.gpu.device);
        let scoped = scope.pop(&format!("rendering a {width}×{height} frame"));
        settle(&self.gpu, scoped, waited)?;
        Ok(start.elapsed().as_secs_f64())
    }

    /// CPU time of the last [`Self::render_frame`]'s `prepare` and `encode`.
    pub fn last_frame_cpu_times(&self) -> FrameCpuTimes {
        self.last_cpu
    }

    /// Renders a scene and returns the tone-mapped image.
    pub fn render_rgba8(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<Rgba8Image, HeadlessError> {
        if scene.camera.projection == Projection::Equirectangular {
            return self.render_equirectangular_rgba8(scene, width, height, time_s);
        }
        check_readback(&self.gpu, width, height, 4)?;
        self.render_frame(scene, width, height, time_s)?;
        let Some((output, _)) = &self.targets else {
            unreachable!("render_frame creates the targets")
        };
        let pixels = read_texture(&self.gpu, &output.texture, 4)?;
        Ok(Rgba8Image {
            width,
            height,
            pixels,
        })
    }

    /// Renders a scene and returns the linear HDR radiance (exposure undone),
    /// in the scene camera's projection.
    pub fn render_hdr(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<HdrImage, HeadlessError> {
        if scene.camera.projection == Projection::Equirectangular {
            let layers = self.render_layers_selected(scene, width, height, time_s, false)?;
            return Ok(HdrImage {
                width,
                height,
                pixels: layers.radiance,
            });
        }
        let camera = Camera::from_settings(&scene.camera, width, height);
        let view = View::from_camera(&camera);
        let (pixels, _) = self.render_view_hdr(scene, &view, width, height, time_s, false)?;
        Ok(HdrImage {
            width,
            height,
            pixels,
        })
    }

    /// Renders a scene seen by a caller's view and returns its linear HDR
    /// radiance (exposure undone) and nimbus's depth buffer (reverse-Z, 0 at
    /// the far plane), both row-major.
    pub fn render_view(
        &mut self,
        scene: &Scene,
        view: &View,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Result<(HdrImage, Vec<f32>), HeadlessError> {
        let (pixels, depth) = self.render_view_hdr(scene, view, width, height, time_s, true)?;
        let image = HdrImage {
            width,
            height,
            pixels,
        };
        Ok((image, depth.unwrap_or_default()))
    }

    /// Renders one view and reads back its radiance (exposure undone) and,
    /// when asked, its depth buffer (reverse-Z values, 0 at the far plane).
    #[allow(clippy::type_complexity)] // a pair of row-major buffers, named at the call sites
    fn render_view_hdr(
        &mut self,
        scene: &Scene,
        view: &View,
        width: u32,
        height: u32,
        time_s: f32,
        with_depth: bool,
    ) -> Result<(Vec<[f32; 3]>, Option<Vec<f32>>), HeadlessError> {
        check_readback(&self.gpu, width, height, 8)?;
        self.render_frame_with_view(scene, view, width, height, time_s)?;
        let depth = if with_depth {
            let Some((_, depth)) = &self.targets else {
                unreachable!("render_frame creates the targets")
            };
            let bytes = read_texture(&self.gpu, &depth.texture, 4)?;
            Some(bytemuck::pod_collect_to_vec(&bytes))
        } else {
            None
        };
        let Some(hdr) = self.renderer.hdr_target() else {
            unreachable!("prepare creates the HDR target")
        };
        let bytes = read_texture(&self.gpu, &hdr.texture, 8)?;
        let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
        // The drawing passes wrote radiance times the frame's pre-exposure.
        let lighting: crate::passes::atmosphere::LightingUniform =
            self.read_buffer(&self.renderer.frame_resources().atmosphere.lighting)?;
        let inverse_exposure = 1.0 / lighting.exposure[0];
        let pixels = halves
            .chunks_exact(4)
            .map(|p| {
                [
                    p[0].to_f32() * inverse_exposure,
                    p[1].to_f32() * inverse_exposure,
                    p[2].to_f32() * inverse_exposure,
                ]
            })
            .collect();
        Ok((pixels, depth))
    }
}

fn padded_row_bytes(width: u32, bytes_per_pixel: u32) -> u32 {
    (width * bytes_per_pixel).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

/// The outcome of GPU work on `gpu`: what its error scope caught and the
/// wait for it (or its read-back), against what the device recorded. Out of
/// memory first (a device that ran out may be lost as well, and the errors
/// on the resources it could not create follow from it), then the loss (the
/// errors after it are its consequences), then the errors.
fn settle<T>(
    gpu: &GpuContext,
    scoped: Result<(), GpuFault>,
    waited: Result<T, String>,
) -> Result<T, HeadlessError> {
    if let Err(fault @ GpuFault::OutOfMemory { .. }) = scoped {
        return Err(fault.into());
    }
    gpu.faults.check()?;
    scoped?;
    waited.map_err(HeadlessError::Readback)
}

/// Checks, before rendering, that the image can be read back on this device.
fn check_readback(
    gpu: &GpuContext,
    width: u32,
    height: u32,
    bytes_per_pixel: u32,
) -> Result<(), HeadlessError> {
    Renderer::check_size(&gpu.device, width, height)?;
    let bytes = padded_row_bytes(width, bytes_per_pixel) as u64 * height as u64;
    let what = format!("reading back a {width}×{height} image");
    Renderer::check_buffer_size(&gpu.device, &what, bytes)?;
    Ok(())
}

impl HeadlessRenderer {
    /// Reads a GPU buffer holding one `T` (e.g. the lighting inputs or the exposure state).
    pub fn read_buffer<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer) -> Result<T, HeadlessError> {
        let bytes = self.read_buffer_bytes(buffer, std::mem::size_of::<T>() as u64)?;
        Ok(bytemuck::pod_read_unaligned(&bytes))
    }

    /// Reads the first `count` elements of a GPU buffer of `T`s (e.g. a
    /// field of `[f32; 4]` texels).
    pub fn read_buffer_elements<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        count: usize,
    ) -> Result<Vec<T>, HeadlessError> {
        let bytes = self.read_buffer_bytes(buffer, (count * std::mem::size_of::<T>()) as u64)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// Copies the first `size` bytes of a buffer to the CPU.
    fn read_buffer_bytes(
        &self,
        buffer: &wgpu::Buffer,
        size: u64,
    ) -> Result<Vec<u8>, HeadlessError> {
        let scope = FaultScope::push(&self.gpu.device);
        let staging = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("buffer readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        self.gpu.queue.submit([encoder.finish()]);
        let bytes = crate::core::binding::read_mapped(&self.gpu.device, &staging);
        let scoped = scope.pop(&format!("reading back {size} bytes of a buffer"));
        settle(&self.gpu, scoped, bytes)
    }

    /// The exposure the last frame applied.
    pub fn exposure_state(&self) -> Result<crate::passes::exposure::ExposureState, HeadlessError> {
        self.read_buffer(self.renderer.exposure().state_buffer())
    }
}

/// Copies a 2D or 3D texture to the CPU, rows and layers tightly packed.
pub fn read_texture(
    gpu: &GpuContext,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, HeadlessError> {
    let (width, height) = (texture.width(), texture.height());
    let layers = texture.depth_or_array_layers();
    let row_bytes = width * bytes_per_pixel;
    let padded_row = padded_row_bytes(width, bytes_per_pixel);
    let scope = FaultScope::push(&gpu.device);
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded_row as u64 * height as u64 * layers as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: layers,
        },
    );
    gpu.queue.submit([encoder.finish()]);
    let bytes = crate::core::binding::read_mapped(&gpu.device, &buffer);
    let scoped = scope.pop(&format!("reading back a {width}×{height}×{layers} texture"));
    let bytes = settle(gpu, scoped, bytes)?;
    let mut out = Vec::with_capacity((row_bytes * height * layers) as usize);
    for row in bytes.chunks(padded_row as usize) {
        out.extend_from_slice(&row[..row_bytes as usize]);
    }
    Ok(out)
}
