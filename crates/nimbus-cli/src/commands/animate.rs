//! `nimbus animate`: a scene's keyframed weather rendered as a PNG sequence
//! or, through ffmpeg, a video.
//!
//! A run that fails part-way (e.g. the GPU device lost, or out of memory)
//! stops at the frame that failed: the frames written before it stay in the
//! directory, each complete (every file is written atomically), and the
//! failed frame leaves nothing; a video is written only when every frame
//! was encoded.

use crate::output::{write_exr_layers, write_png};
use crate::progress::Progress;
use anyhow::Context;
use clap::Args;
use nimbus_render::headless::HeadlessRenderer;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// Most frames one run writes.
const MAX_FRAMES: u64 = 1_000_000;

/// Arguments of `nimbus animate`.
#[derive(Debug, Args)]
pub struct AnimateArgs {
    #[command(flatten)]
    frame: super::FrameArgs,
    /// Length of the animation, s.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    seconds: f64,
    /// Frames per second, in (0, 240].
    #[arg(
        long,
        default_value_t = 24.0,
        value_name = "FPS",
        allow_negative_numbers = true
    )]
    fps: f64,
    /// Animation time of the first frame, s.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "S",
        allow_negative_numbers = true
    )]
    start_s: f64,
    /// Output: a directory for frame_00000.png, frame_00001.png, … (created
    /// if missing), or a .mp4 file (H.264 through ffmpeg, which must be on
    /// the PATH).
    #[arg(short, long, value_name = "DIR|FILE.mp4")]
    output: PathBuf,
    /// Write the frames as OpenEXR files with their layers (linear
    /// radiance, Z, cloud.A, sky.RGB, as `render -o x.exr`) instead of PNG:
    /// DIR/frame_00000.exr, … (not with a .mp4 output).
    #[arg(long)]
    exr: bool,
}

/// Where the frames go.
enum Sink {
    Pngs(PathBuf),
    Exrs(PathBuf),
    Video(VideoWriter),
}

/// Runs the subcommand.
pub fn run(args: &AnimateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= 1.0e6,
        "--seconds {}: must be a number in (0, 1000000]",
        args.seconds
    );
    anyhow::ensure!(
        args.fps.is_finite() && args.fps > 0.0 && args.fps <= 240.0,
        "--fps {}: must be a number in (0, 240]",
        args.fps
    );
    anyhow::ensure!(
        args.start_s.is_finite() && (0.0..=1.0e7).contains(&args.start_s),
        "--start-s {}: must be a number in [0, 10000000]",
        args.start_s
    );
    let frames = (args.seconds * args.fps).round().max(1.0) as u64;
    anyhow::ensure!(
        frames <= MAX_FRAMES,
        "--seconds × --fps = {frames} frames: at most {MAX_FRAMES}"
    );
    let video = args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mp4"));
    anyhow::ensure!(
        !(video && args.exr),
        "--exr: writes a frame directory, not a video ({})",
        args.output.display()
    );
    let (scene, width, height) = args.frame.scene_and_size()?;
    if video {
        super::check_output_dir(&args.output)?;
        ffmpeg_available().with_context(|| {
            format!(
                "output {}: ffmpeg is not on the PATH (install it, or write a PNG sequence with -o DIR/)",
                args.output.display()
            )
        })?;
        anyhow::ensure!(
            width % 2 == 0 && height % 2 == 0,
            "output {}: H.264 needs an even width and height, got {width}×{height}",
            args.output.display()
        );
    } else {
        prepare_directory(&args.output)?;
    }
    let mut headless = HeadlessRenderer::new(args.frame.adapter())?;
    eprintln!(
        "nimbus: animating {frames} frames of {width}×{height} at {} fps on {}",
        args.fps,
        headless.gpu.adapter_summary()
    );
    let mut sink = if video {
        Sink::Video(VideoWriter::start(&args.output, width, height, args.fps)?)
    } else if args.exr {
        Sink::Exrs(args.output.clone())
    } else {
        Sink::Pngs(args.output.clone())
    };
    let progress = Progress::new("animate: frames", frames);
    for index in 0..frames {
        let time_s = args.start_s + index as f64 / args.fps;
        let frame_scene = scene.at_time(time_s);
        match &mut sink {
            Sink::Exrs(dir) => write_exr_layers(
                &dir.join(format!("frame_{index:05}.exr")),
                &headless.render_layers(&frame_scene, width, height, time_s as f32)?,
            )?,
            Sink::Pngs(dir) => write_png(
                &dir.join(format!("frame_{index:05}.png")),
                &headless.render_rgba8(&frame_scene, width, height, time_s as f32)?,
            )?,
            Sink::Video(writer) => writer.push(
                &headless
                    .render_rgba8(&frame_scene, width, height, time_s as f32)?
                    .pixels,
            )?,
        }
        progress.update(index + 1);
    }
    progress.finish();
    match sink {
        Sink::Pngs(dir) | Sink::Exrs(dir) => {
            eprintln!("nimbus: wrote {frames} frames to {}", dir.display())
        }
        Sink::Video(writer) => {
            writer.finish()?;
            eprintln!("nimbus: wrote {}", args.output.display());
        }
    }
    Ok(())
}

/// Creates the frame directory if needed (its parent must exist).
fn prepare_directory(dir: &Path) -> anyhow::Result<()> {
    match std::fs::metadata(dir) {
        Ok(meta) => {
            anyhow::ensure!(
                meta.is_dir(),
                "output {}: not a directory (give a directory for PNG frames or a .mp4 file)",
                dir.display()
            );
        }
        Err(_) => {
            super::check_output_dir(dir)?;
            std::fs::create_dir(dir).with_context(|| {
                format!("output {}: cannot create the directory", dir.display())
            })?;
        }
    }
    Ok(())
}

/// Whether `ffmpeg -version` runs.
fn ffmpeg_available() -> anyhow::Result<()> {
    let status = Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()?;
    anyhow::ensure!(status.success(), "ffmpeg -version failed");
    Ok(())
}

/// An ffmpeg process encoding raw RGBA frames from its standard input into a
/// temporary file, renamed into place when it succeeds.
struct VideoWriter {
    child: Child,
    temporary: PathBuf,
    output: PathBuf,
}

impl VideoWriter {
    fn start(output: &Path, width: u32, height: u32, fps: f64) -> anyhow::Result<Self> {
        let temporary = crate::output::temporary_path(output);
        let child = Command::new("ffmpeg")
            .args([
                "-loglevel",
                "error",
                "-y",
                "-f",
                "rawvideo",
                "-pix_fmt",
                "rgba",
            ])
            .args(["-s", &format!("{width}x{height}"), "-r", &fps.to_string()])
            .args([
                "-i", "-", "-c:v", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4",
            ])
            .arg(&temporary)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .with_context(|| format!("output {}: cannot start ffmpeg", output.display()))?;
        Ok(Self {
            child,
            temporary,
            output: output.to_path_buf(),
        })
    }

    fn push(&mut self, rgba: &[u8]) -> anyhow::Result<()> {
        let stdin = self
            .child
            .stdin
            .as_mut()
            .context("ffmpeg's input is closed")?;
        stdin.write_all(rgba).with_context(|| {
            format!(
                "output {}: ffmpeg stopped reading frames",
                self.output.display()
            )
        })
    }

    fn finish(mut self) -> anyhow::Result<()> {
        drop(self.child.stdin.take());
        let status = self.child.wait()?;
        if !status.success() {
            let _ = std::fs::remove_file(&self.temporary);
            anyhow::bail!("output {}: ffmpeg failed ({status})", self.output.display());
        }
        std::fs::rename(&self.temporary, &self.output).with_context(|| {
            format!(
                "output {}: cannot move the video into place",
                self.output.display()
            )
        })
    }
}

impl Drop for VideoWriter {
    /// An unfinished video (an error while rendering) leaves no file behind.
    fn drop(&mut self) {
        if self.child.stdin.is_some() {
            let _ = self.child.kill();
            let _ = self.child.wait();
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}
