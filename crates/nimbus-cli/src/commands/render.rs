//! `nimbus render`: one still image.

use crate::output::{ImageFormat, write_exr_layers, write_png};
use crate::progress::Progress;
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
    // The same bound as `animate --start-s` and keyframe times: beyond it
    // the f32 time of the shaders (ripples, rain steps) loses its seconds.
    anyhow::ensure!(
        args.time_s.is_finite() && (0.0..=1.0e7).contains(&args.time_s),
        "--time-s {}: must be a number of seconds in [0, 10000000]",
        args.time_s
    );
    let (scene, width, height) = args.frame.scene_and_size()?;
    // The keyframed weather at that time.
    let scene = scene.at_time(f64::from(args.time_s));
    let mut headless = HeadlessRenderer::new(args.frame.adapter())?;
    eprintln!(
        "nimbus: rendering {width}×{height} on {}",
        headless.gpu.adapter_summary()
    );
    // The frame's precomputation (atmosphere tables, cloud meshes, terrain)
    // and its passes have no known total: a spinner with the time taken.
    let progress = Progress::spinner("render");
    match format {
        ImageFormat::Png => {
            let image = headless.render_rgba8(&scene, width, height, args.time_s)?;
            progress.finish();
            write_png(&args.output, &image)?;
        }
        ImageFormat::Exr => {
            let image = headless.render_layers(&scene, width, height, args.time_s)?;
            progress.finish();
            write_exr_layers(&args.output, &image)?;
        }
    }
    eprintln!("nimbus: wrote {}", args.output.display());
    Ok(())
}
