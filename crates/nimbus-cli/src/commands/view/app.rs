//! The viewer's window and frame loop (winit 0.30's application handler):
//! the surface, the renderer and egui on one device; input to the camera;
//! hot reload; screenshots.

use super::camera::{CameraMode, MoveInput, ViewerCamera};
use super::editor::{SceneEditor, keyed_value_changed};
use super::panel::{self, Clock, PanelState, PassTimes};
use super::watch::FileWatch;
use anyhow::Context as _;
use nimbus_render::headless::Rgba8Image;
use nimbus_render::targets::{DEPTH_FORMAT, Target};
use nimbus_render::{
    AdapterPreference, FrameTargets, GpuContext, Renderer, RendererDescriptor, Scene, TargetLoad,
};
use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// How often the scene file and the shaders are checked for changes.
const WATCH_INTERVAL: Duration = Duration::from_millis(500);

/// How long a status message stays on screen.
const STATUS_DURATION: Duration = Duration::from_secs(4);

/// What the viewer starts with.
#[derive(Debug)]
pub struct Options {
    /// The scene.
    pub scene: Scene,
    /// The scene file to watch, if any.
    pub scene_file: Option<PathBuf>,
    /// Where "Save" writes (the scene file when one was given).
    pub save_path: Option<PathBuf>,
    /// Window size, pixels.
    pub size_px: [u32; 2],
    /// Adapter preference.
    pub adapter: AdapterPreference,
    /// WGSL directory to watch and compose from.
    pub shader_dir: Option<PathBuf>,
    /// Quit after this many frames.
    pub frames: Option<u64>,
    /// Screenshot file (with `frames`) or directory.
    pub screenshot: Option<PathBuf>,
    /// Show the panel.
    pub show_panel: bool,
}

/// Opens the window and runs until it is closed (or `frames` are drawn).
pub fn run(options: Options) -> anyhow::Result<()> {
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow::anyhow!(
            "cannot open a window: {e} (nimbus view needs a display: an X11 server or XWayland; set DISPLAY)"
        )
    })?;
    let mut app = App {
        options: Some(options),
        viewer: None,
        error: None,
    };
    event_loop
        .run_app(&mut app)
        .context("the window's event loop failed")?;
    match app.error {
        Some(error) => Err(error),
        None => Ok(()),
    }
}

/// The winit application: creates the viewer when the window can be made.
struct App {
    options: Option<Options>,
    viewer: Option<Viewer>,
    error: Option<anyhow::Error>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        let Some(options) = self.options.take() else {
            return;
        };
        match Viewer::new(event_loop, options) {
            Ok(viewer) => self.viewer = Some(viewer),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(viewer) = &mut self.viewer else {
            return;
        };
        if let Err(e) = viewer.window_event(event_loop, &event) {
            self.error = Some(e);
            event_loop.exit();
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(viewer) = &self.viewer {
            viewer.window.request_redraw();
        }
    }
}

/// Everything the viewer holds while its window is open.
struct Viewer {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: GpuContext,
    renderer: Renderer,
    depth: Target,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    editor: SceneEditor,
    panel: PanelState,
    camera: ViewerCamera,
    clock: Clock,
    keys: HashSet<KeyCode>,
    /// Cursor position while the left button drags the view.
    drag_from: Option<(f64, f64)>,
    cursor: (f64, f64),
    last_frame: Instant,
    times: Option<PassTimes>,
    scene_watch: Option<FileWatch>,
    shader_watch: Option<FileWatch>,
    last_watch: Instant,
    /// Why the last shader reload was refused (the previous shaders are in use).
    shader_error: Option<String>,
    /// Why the last frame could not be prepared.
    render_error: Option<String>,
    /// Errors wgpu reported outside any error scope.
    device_errors: Arc<Mutex<Option<String>>>,
    status: Option<(String, Instant)>,
    /// File the next frame's picture (without the panel) is written to.
    screenshot_to: Option<PathBuf>,
    screenshots_taken: u32,
    frames_drawn: u64,
    options: Options,
    show_panel: bool,
}

/// The surface format the renderer draws to: 8-bit unorm where offered
/// (the tone mapper encodes sRGB and dithers), else the first.
fn pick_format(formats: &[wgpu::TextureFormat]) -> Option<wgpu::TextureFormat> {
    use wgpu::TextureFormat::{Bgra8Unorm, Rgba8Unorm};
    formats
        .iter()
        .copied()
        .find(|f| matches!(f, Bgra8Unorm | Rgba8Unorm))
        .or_else(|| formats.first().copied())
}

impl Viewer {
    fn new(event_loop: &ActiveEventLoop, options: Options) -> anyhow::Result<Self> {
        let [width, height] = options.size_px;
        let title = match &options.scene_file {
            Some(f) => format!("nimbus — {}", f.display()),
            None => "nimbus — default scene".to_owned(),
        };
        let window = Arc::new(
            event_loop
                .create_window(
                    Window::default_attributes()
                        .with_title(title)
                        .with_inner_size(winit::dpi::PhysicalSize::new(width, height)),
                )
                .context("cannot create the window")?,
        );
        let instance = GpuContext::instance();
        let surface = instance
            .create_surface(window.clone())
            .context("cannot create a drawing surface for the window")?;
        let gpu = GpuContext::with_instance(&instance, options.adapter, Some(&surface))?;
        eprintln!("nimbus: viewer on {}", gpu.adapter_summary());
        let capabilities = surface.get_capabilities(&gpu.adapter);
        let format = pick_format(&capabilities.formats)
            .context("the window's surface offers no format on this adapter")?;
        // Screenshots copy the surface texture when it allows it.
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | (capabilities.usages & wgpu::TextureUsages::COPY_SRC);
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: capabilities
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        let device_errors = Arc::new(Mutex::new(None));
        let sink = device_errors.clone();
        gpu.device
            .on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
                if let Ok(mut slot) = sink.lock() {
                    *slot = Some(error.to_string());
                }
            }));
        nimbus_render::shader::set_source_dir(options.shader_dir.clone());
        let descriptor = renderer_descriptor(format);
        let mut shader_error = None;
        let renderer = match Renderer::try_new(&gpu.device, &gpu.queue, &descriptor) {
            Ok(renderer) => renderer,
            Err(e) => {
                // The WGSL on disk does not compile: start from the embedded shaders.
                eprintln!("nimbus: {e}");
                shader_error = Some(e.to_string());
                nimbus_render::shader::set_source_dir(None);
                let renderer = Renderer::new(&gpu.device, &gpu.queue, &descriptor);
                nimbus_render::shader::set_source_dir(options.shader_dir.clone());
                renderer
            }
        };
        let depth = depth_target(&gpu.device, config.width, config.height);
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer =
            egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        let camera = ViewerCamera::from_settings(&options.scene.camera);
        let editor = SceneEditor::new(options.scene.clone(), options.scene_file.clone())
            .map_err(|e| anyhow::anyhow!(e))?;
        let save_path = options
            .save_path
            .clone()
            .unwrap_or_else(|| PathBuf::from("nimbus-scene.toml"));
        let scene_watch = options.scene_file.clone().map(|f| FileWatch::new([f]));
        let shader_watch = options.shader_dir.as_deref().map(FileWatch::wgsl_under);
        if let Some(watch) = &shader_watch {
            eprintln!("nimbus: watching {} WGSL files for changes", watch.len());
        }
        let times = renderer.has_timestamps().then(PassTimes::default);
        Ok(Self {
            window,
            surface,
            config,
            gpu,
            renderer,
            depth,
            egui_ctx,
            egui_state,
            egui_renderer,
            editor,
            panel: PanelState::new(save_path.display().to_string()),
            camera,
            clock: Clock {
                time_s: 0.0,
                playing: true,
                keyframes: true,
            },
            keys: HashSet::new(),
            drag_from: None,
            cursor: (0.0, 0.0),
            last_frame: Instant::now(),
            times,
            scene_watch,
            shader_watch,
            last_watch: Instant::now(),
            shader_error,
            render_error: None,
            device_errors,
            status: None,
            screenshot_to: None,
            screenshots_taken: 0,
            frames_drawn: 0,
            show_panel: options.show_panel,
            options,
        })
    }

    fn set_status(&mut self, message: String) {
        eprintln!("nimbus: {message}");
        self.status = Some((message, Instant::now()));
    }

    fn window_event(
        &mut self,
        event_loop: &ActiveEventLoop,
        event: &WindowEvent,
    ) -> anyhow::Result<()> {
        let response = self.egui_state.on_window_event(&self.window, event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) if size.width > 0 && size.height > 0 => {
                self.config.width = size.width;
                self.config.height = size.height;
                self.surface.configure(&self.gpu.device, &self.config);
                self.depth = depth_target(&self.gpu.device, size.width, size.height);
            }
            WindowEvent::RedrawRequested => {
                self.frame()?;
                if self.options.frames.is_some_and(|n| self.frames_drawn >= n) {
                    event_loop.exit();
                }
            }
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    match event.state {
                        ElementState::Released => {
                            self.keys.remove(&code);
                        }
                        ElementState::Pressed if !response.consumed => {
                            let repeat = event.repeat;
                            self.keys.insert(code);
                            if !repeat {
                                self.key_pressed(code);
                            }
                        }
                        ElementState::Pressed => {}
                    }
                }
            }
            WindowEvent::MouseInput { state, button, .. } if *button == MouseButton::Left => {
                self.drag_from = match state {
                    ElementState::Pressed if !response.consumed => Some(self.cursor),
                    _ => None,
                };
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = (position.x, position.y);
                if let Some((x, y)) = self.drag_from {
                    self.camera.drag(position.x - x, position.y - y);
                    self.drag_from = Some(self.cursor);
                }
            }
            WindowEvent::MouseWheel { delta, .. } if !response.consumed => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(*y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.camera.scroll(lines);
            }
            WindowEvent::Focused(false) => self.keys.clear(),
            _ => {}
        }
        Ok(())
    }

    fn key_pressed(&mut self, code: KeyCode) {
        let ctrl =
            self.keys.contains(&KeyCode::ControlLeft) || self.keys.contains(&KeyCode::ControlRight);
        match code {
            KeyCode::Tab => self.camera.set_mode(match self.camera.mode {
                CameraMode::Fly => CameraMode::Orbit,
                CameraMode::Orbit => CameraMode::Fly,
            }),
            KeyCode::Space => self.clock.playing = !self.clock.playing,
            KeyCode::F1 => self.show_panel = !self.show_panel,
            KeyCode::F12 => self.request_screenshot(),
            KeyCode::KeyS if ctrl => self.save(),
            _ => {}
        }
    }

    fn request_screenshot(&mut self) {
        let dir = self
            .options
            .screenshot
            .clone()
            .unwrap_or_else(|| PathBuf::from("."));
        // The first free numbered name.
        let path = loop {
            self.screenshots_taken += 1;
            let path = dir.join(format!(
                "nimbus-screenshot-{:03}.png",
                self.screenshots_taken
            ));
            if !path.exists() {
                break path;
            }
        };
        self.screenshot_to = Some(path);
    }

    fn save(&mut self) {
        let path = PathBuf::from(self.panel.save_path.trim());
        match self.editor.save(&path, &self.camera) {
            Ok(()) => {
                // Our own write is not a change to reload.
                if let Some(watch) = &mut self.scene_watch {
                    watch.changed();
                }
                self.set_status(format!("saved {}", path.display()));
            }
            Err(e) => self.set_status(e),
        }
    }

    /// Checks the watched files; reloads the scene or rebuilds the renderer.
    fn poll_watches(&mut self) {
        if self.last_watch.elapsed() < WATCH_INTERVAL {
            return;
        }
        self.last_watch = Instant::now();
        if self.scene_watch.as_mut().is_some_and(FileWatch::changed) {
            if self.editor.reload() {
                self.set_status("scene file reloaded".to_owned());
            } else if let Some(error) = self.editor.error.clone() {
                self.set_status(format!("scene file not reloaded: {error}"));
            }
        }
        if self.shader_watch.as_mut().is_some_and(FileWatch::changed) {
            let descriptor = renderer_descriptor(self.config.format);
            match Renderer::try_new(&self.gpu.device, &self.gpu.queue, &descriptor) {
                Ok(renderer) => {
                    self.renderer = renderer;
                    self.shader_error = None;
                    self.set_status("shaders reloaded".to_owned());
                }
                Err(e) => {
                    eprintln!("nimbus: {e}");
                    self.shader_error = Some(e.to_string());
                }
            }
        }
    }

    fn move_input(&self) -> MoveInput {
        let held = |a: KeyCode, b: KeyCode| {
            f64::from(u8::from(self.keys.contains(&a)))
                - f64::from(u8::from(self.keys.contains(&b)))
        };
        MoveInput {
            forward: held(KeyCode::KeyW, KeyCode::KeyS),
            right: held(KeyCode::KeyD, KeyCode::KeyA),
            up: held(KeyCode::KeyE, KeyCode::KeyQ),
            fast: self.keys.contains(&KeyCode::ShiftLeft)
                || self.keys.contains(&KeyCode::ShiftRight),
        }
    }

    /// One frame: input, hot reload, the scene, the panel, present.
    fn frame(&mut self) -> anyhow::Result<()> {
        let now = Instant::now();
        let frame_s = now.duration_since(self.last_frame).as_secs_f64();
        self.last_frame = now;
        if let Some(times) = &mut self.times {
            times.add_frame(frame_s);
        }
        // A slow frame (a reload, a regenerated field) must not throw the
        // camera or the clock far ahead.
        let dt_s = frame_s.min(0.25);
        if !self.egui_ctx.egui_wants_keyboard_input() {
            self.camera.update(self.move_input(), dt_s);
        } else {
            self.keys.clear();
        }
        if self.clock.playing {
            self.clock.time_s += dt_s;
        }
        self.poll_watches();
        if self
            .options
            .frames
            .is_some_and(|n| self.frames_drawn + 1 == n)
            && let Some(path) = self.options.screenshot.clone()
        {
            self.screenshot_to = Some(path);
        }

        let surface_texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.gpu.device, &self.config);
                return Ok(());
            }
            // Minimised or busy: try again next frame.
            _ => return Ok(()),
        };
        let view = surface_texture
            .texture
            .create_view(&wgpu::TextureViewDescriptor::default());
        let (width, height) = (self.config.width, self.config.height);

        // The scene: the last valid one, posed by the camera, at the clock's time.
        let scene = self
            .editor
            .scene_at(&self.camera, self.clock.time_s, self.clock.keyframes);
        let prepared = self
            .renderer
            .prepare(&scene, width, height, self.clock.time_s as f32);
        self.render_error = prepared.err().map(|e| e.to_string());

        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("viewer frame"),
            });
        if self.render_error.is_none() {
            self.renderer.encode(
                &mut encoder,
                &FrameTargets {
                    output: &view,
                    depth: &self.depth.view,
                    load: TargetLoad::Clear,
                },
            );
        } else {
            // The scene cannot be drawn: a dark window under the panel and the error.
            window_pass(
                &mut encoder,
                &view,
                "clear",
                wgpu::LoadOp::Clear(wgpu::Color {
                    r: 0.05,
                    g: 0.05,
                    b: 0.06,
                    a: 1.0,
                }),
            );
        }

        // The panel and the overlays; left out of screenshots.
        let screenshot = self.screenshot_to.take();
        let raw_input = self.egui_state.take_egui_input(&self.window);
        let egui_ctx = self.egui_ctx.clone();
        let mut full_output = egui_ctx.run_ui(raw_input, |ui| self.ui(ui));
        let platform_output = std::mem::take(&mut full_output.platform_output);
        self.egui_state
            .handle_platform_output(&self.window, platform_output);
        let pixels_per_point = full_output.pixels_per_point;
        let paint_jobs = self
            .egui_ctx
            .tessellate(full_output.shapes, pixels_per_point);
        for (id, delta) in &full_output.textures_delta.set {
            self.egui_renderer
                .update_texture(&self.gpu.device, &self.gpu.queue, *id, delta);
        }
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [width, height],
            pixels_per_point,
        };
        if screenshot.is_none() {
            let extra = self.egui_renderer.update_buffers(
                &self.gpu.device,
                &self.gpu.queue,
                &mut encoder,
                &paint_jobs,
                &screen,
            );
            let mut pass =
                window_pass(&mut encoder, &view, "egui", wgpu::LoadOp::Load).forget_lifetime();
            self.egui_renderer.render(&mut pass, &paint_jobs, &screen);
            drop(pass);
            self.gpu
                .queue
                .submit(extra.into_iter().chain([encoder.finish()]));
        } else {
            self.gpu.queue.submit([encoder.finish()]);
        }
        for id in &full_output.textures_delta.free {
            self.egui_renderer.free_texture(id);
        }
        if let Some(path) = screenshot {
            let result = self.write_screenshot(&surface_texture.texture, &path);
            match result {
                Ok(()) => self.set_status(format!("wrote {}", path.display())),
                Err(e) if self.options.frames.is_some() => return Err(e),
                Err(e) => self.set_status(format!("screenshot failed: {e:#}")),
            }
        }
        self.window.pre_present_notify();
        surface_texture.present();
        if self.render_error.is_none()
            && let (Some(times), Some(frame)) =
                (&mut self.times, self.renderer.read_pass_times_ms())
        {
            times.add(&frame);
        }
        self.frames_drawn += 1;
        Ok(())
    }

    /// The egui content of a frame.
    fn ui(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        if self.show_panel {
            let mut actions = panel::PanelActions::default();
            egui::Panel::left("scene panel")
                .resizable(true)
                .default_size(340.0)
                .show(ui, |ui| {
                    actions = panel::scene_panel(
                        ui,
                        &mut self.editor,
                        &mut self.panel,
                        &mut self.camera,
                        &mut self.clock,
                    );
                });
            if actions.edited {
                let before = self.editor.scene.clone();
                if self.editor.apply()
                    && self.clock.keyframes
                    && keyed_value_changed(&before, &self.editor.scene)
                {
                    // The keyframes would undo the edit at once.
                    self.clock.keyframes = false;
                    self.set_status(
                        "keyframes off: a keyed value was edited (Animation turns them back on)"
                            .to_owned(),
                    );
                }
            }
            if actions.save {
                self.save();
            }
            if actions.reload {
                self.editor.reload();
            }
            if actions.screenshot {
                self.request_screenshot();
            }
        }
        panel::timing_overlay(&ctx, self.times.as_ref(), &self.gpu.adapter_summary());
        let device_error = self.device_errors.lock().ok().and_then(|e| e.clone());
        let errors: Vec<String> = [
            self.shader_error
                .as_ref()
                .map(|e| format!("Shader reload refused (the last good shaders are in use): {e}")),
            self.render_error
                .as_ref()
                .map(|e| format!("Cannot draw this scene: {e}")),
            device_error.map(|e| format!("GPU error: {e}")),
        ]
        .into_iter()
        .flatten()
        .collect();
        if !errors.is_empty() {
            egui::Window::new("Errors")
                .anchor(egui::Align2::CENTER_BOTTOM, egui::vec2(0.0, -8.0))
                .resizable(true)
                .collapsible(true)
                .show(&ctx, |ui| {
                    egui::ScrollArea::vertical()
                        .max_height(300.0)
                        .show(ui, |ui| {
                            for error in &errors {
                                ui.colored_label(
                                    egui::Color32::from_rgb(255, 110, 90),
                                    egui::RichText::new(plain_text(error)).monospace(),
                                );
                            }
                        });
                });
        }
        if let Some((message, since)) = &self.status
            && since.elapsed() < STATUS_DURATION
        {
            egui::Area::new(egui::Id::new("nimbus status"))
                .anchor(egui::Align2::RIGHT_BOTTOM, egui::vec2(-8.0, -8.0))
                .show(&ctx, |ui| {
                    egui::Frame::popup(ui.style()).show(ui, |ui| ui.label(message));
                });
        }
    }

    /// Copies the surface texture (drawn without the panel) to a PNG.
    fn write_screenshot(
        &self,
        texture: &wgpu::Texture,
        path: &std::path::Path,
    ) -> anyhow::Result<()> {
        anyhow::ensure!(
            texture.usage().contains(wgpu::TextureUsages::COPY_SRC),
            "this adapter cannot read back the window's surface; use `nimbus render` for stills"
        );
        let swap_red_blue = match texture.format() {
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb => true,
            wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb => false,
            other => {
                anyhow::bail!("the window's surface format {other:?} is not 8-bit RGBA or BGRA")
            }
        };
        let mut pixels = nimbus_render::headless::read_texture(&self.gpu, texture, 4)?;
        for pixel in pixels.chunks_exact_mut(4) {
            if swap_red_blue {
                pixel.swap(0, 2);
            }
            // The window is opaque whatever its alpha holds.
            pixel[3] = 255;
        }
        crate::output::write_png(
            path,
            &Rgba8Image {
                width: texture.width(),
                height: texture.height(),
                pixels,
            },
        )
    }
}

/// The text with box-drawing characters (naga's source snippets) in ASCII,
/// which egui's fonts have.
fn plain_text(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            '│' | '┃' | '╵' | '╷' => '|',
            '─' | '━' => '-',
            '\u{2500}'..='\u{257F}' => '+',
            c => c,
        })
        .collect()
}

fn depth_target(device: &wgpu::Device, width: u32, height: u32) -> Target {
    Target::new(
        device,
        "viewer depth",
        DEPTH_FORMAT,
        width,
        height,
        // The rain's streaks and mist read the depth.
        wgpu::TextureUsages::TEXTURE_BINDING,
    )
}

/// The renderer's set-up for a window of the given surface format.
fn renderer_descriptor(format: wgpu::TextureFormat) -> RendererDescriptor {
    RendererDescriptor::display(format).with_timestamps(true)
}

/// A render pass on the window's colour alone (the panel, or clearing it).
fn window_pass<'a>(
    encoder: &'a mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    label: &str,
    load: wgpu::LoadOp<wgpu::Color>,
) -> wgpu::RenderPass<'a> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}
