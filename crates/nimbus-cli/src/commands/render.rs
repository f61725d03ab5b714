//! `nimbus render`: one still image.

use crate::output::{ImageFormat, write_exr_layers, write_png};
use clap::Args;
use nimbus_render::headless::HeadlessRenderer;
use std::path::PathBuf;

/// Arguments of `nimbus render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    frame: super::FrameArgs,
    /// Output image: .png (tone-mapped sRGB) or .exr (linear radiance,
    /// W·sr⁻¹·m⁻², with the layers Z (distance along the view ray, m),
    /// cloud.A (the clouds' opacity) and sky.RGB (without clouds and rain)).
    #[arg(short, long, default_value = "nimbus.png")]
    output: PathBuf,
    /// Animation time, s: the scene's keyframed weather at that time, the
    /// clouds carried by the wind, the water's ripples.
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    time_s: f32,
}

/// Runs the subcommand.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let format = ImageFormat::from_path(&args.output)?;
    super::check_output_dir(&args.output)?;
    anyhow::ensure!(
        args.time_s.is_finite(),
        "--time-s {}: must be a finite number",
        args.time_s
    );
    let (scene, width, height) = args.frame.scene_and_size()?;
    // The keyframed weather at that time.
    let scene = scene.at_time(f64::from(args.time_s));
    let mut headless = HeadlessRenderer::new(args.frame.adapter)?;
    eprintln!(
        "nimbus: rendering {width}×{height} on {}",
        headless.gpu.adapter_summary()
    );
    match format {
        ImageFormat::Png => write_png(
            &args.output,
            &headless.render_rgba8(&scene, width, height, args.time_s)?,
        )?,
        ImageFormat::Exr => write_exr_layers(
            &args.output,
            &headless.render_layers(&scene, width, height, args.time_s)?,
        )?,
    }
    eprintln!("nimbus: wrote {}", args.output.display());
    Ok(())
}
