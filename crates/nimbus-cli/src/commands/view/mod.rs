//! `nimbus view`: the interactive viewer. A winit window drawn by the
//! library's [`nimbus_render::Renderer`], fly and orbit cameras, an egui
//! panel over every scene parameter, hot reload of the scene file and the
//! WGSL shaders, screenshots and per-pass GPU times.

mod app;
mod camera;
mod editor;
mod panel;
mod watch;

use clap::Args;
use std::path::PathBuf;

/// Arguments of `nimbus view`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// Scene file (TOML); the embedded default scene when omitted. Reloaded when it changes.
    scene: Option<PathBuf>,
    /// Window width in pixels.
    #[arg(long, value_name = "PX", default_value_t = 1280, value_parser = clap::value_parser!(u32).range(64..=8192))]
    width: u32,
    /// Window height in pixels.
    #[arg(long, value_name = "PX", default_value_t = 720, value_parser = clap::value_parser!(u32).range(64..=8192))]
    height: u32,
    /// GPU adapter.
    #[arg(long, value_enum, default_value_t = super::Adapter::Auto)]
    adapter: super::Adapter,
    /// Directory of the renderer's WGSL files to watch and reload (default:
    /// `crates/nimbus-render/src` of the checkout nimbus was built from, when it exists).
    #[arg(long, value_name = "DIR")]
    shader_dir: Option<PathBuf>,
    /// Watch neither the scene file nor the shaders.
    #[arg(long)]
    no_watch: bool,
    /// Quit after this many frames (scripted captures, tests).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    frames: Option<u64>,
    /// Where screenshots go: with `--frames`, the last frame's file
    /// (.png); otherwise a directory for the screenshot key's numbered files.
    #[arg(long, value_name = "PATH")]
    screenshot: Option<PathBuf>,
    /// Start with the panel hidden (F1 shows it).
    #[arg(long)]
    hide_panel: bool,
}

/// Runs the subcommand.
pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let scene = super::load_scene(args.scene.as_deref())?;
    if let (Some(path), Some(_)) = (&args.screenshot, args.frames) {
        crate::output::ImageFormat::from_path(path)?;
        super::check_output_dir(path)?;
    } else if let Some(dir) = &args.screenshot {
        anyhow::ensure!(
            dir.is_dir(),
            "--screenshot {}: without --frames this is the directory screenshots go to, and it does not exist",
            dir.display()
        );
    }
    // The renderer's source directory holds `shader/common.wgsl`.
    let is_source_dir =
        |dir: &std::path::Path| dir.join(nimbus_render::shader::COMMON.name).is_file();
    let shader_dir = match &args.shader_dir {
        Some(dir) => {
            anyhow::ensure!(
                is_source_dir(dir),
                "--shader-dir {}: not the renderer's source directory (no shader/common.wgsl in it)",
                dir.display()
            );
            Some(dir.clone())
        }
        None => Some(PathBuf::from(nimbus_render::shader::CHECKOUT_SOURCE_DIR))
            .filter(|d| is_source_dir(d)),
    }
    .filter(|_| !args.no_watch);
    app::run(app::Options {
        scene,
        scene_file: args.scene.clone().filter(|_| !args.no_watch),
        save_path: args.scene.clone(),
        size_px: [args.width, args.height],
        adapter: args.adapter.into(),
        shader_dir,
        frames: args.frames,
        screenshot: args.screenshot.clone(),
        show_panel: !args.hide_panel,
    })
}
