//! `nimbus bench`: per-pass GPU times, and the CPU time of the renderer's
//! per-frame calls, over many frames; `nimbus bench table`: a Markdown
//! table of such reports.

mod table;

use crate::progress::Progress;
use clap::{Args, Subcommand};
use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::{PASS_NAMES, PassId, Precompute};
use serde::Serialize;

/// Largest frame count of one benchmark.
const MAX_FRAMES: u32 = 100_000;

/// `nimbus bench`: one benchmark, or a subcommand. No `help` subcommand:
/// beside the scene argument it would only shadow a scene file named so.
#[derive(Debug, Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    disable_help_subcommand = true
)]
pub struct BenchCommand {
    #[command(subcommand)]
    action: Option<BenchAction>,
    #[command(flatten)]
    run: BenchArgs,
}

#[derive(Debug, Subcommand)]
enum BenchAction {
    /// Read `nimbus bench --json` reports (and the embedding example's) and
    /// print a Markdown table of them, one row per report: scene,
    /// resolution, adapter, per-pass GPU medians, GPU total and wall time.
    Table(table::TableArgs),
}

/// Runs `nimbus bench` or its subcommand.
pub fn run(command: &BenchCommand) -> anyhow::Result<()> {
    match &command.action {
        Some(BenchAction::Table(args)) => table::run(args),
        None => run_benchmark(&command.run),
    }
}

/// Arguments of `nimbus bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    frame: super::FrameArgs,
    /// Number of measured frames (after one warm-up frame).
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAMES as i64))]
    frames: u32,
    /// Recompute every atmosphere LUT and redraw the cloud shadow map each
    /// frame (by default the transmittance and multiple-scattering LUTs run
    /// only when the atmosphere changes, the view-dependent ones when the
    /// camera or sun moves, the shadow map when the clouds' shapes or the
    /// sun change).
    #[arg(long)]
    update_luts: bool,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
}

/// Median, 95th percentile and largest value of a series, ms.
#[derive(Debug, Serialize)]
struct Stats {
    median_ms: f64,
    p95_ms: f64,
    max_ms: f64,
}

impl Stats {
    fn of(values: &[f64]) -> Self {
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        // Nearest-rank percentiles.
        let rank =
            |p: f64| sorted[((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1];
        Self {
            median_ms: rank(0.5),
            p95_ms: rank(0.95),
            max_ms: rank(1.0),
        }
    }
}

#[derive(Debug, Serialize)]
struct PassReport {
    name: &'static str,
    /// Frames in which the pass ran (LUT passes run only when their inputs change).
    frames: usize,
    #[serde(flatten)]
    stats: Option<Stats>,
}

#[derive(Debug, Serialize)]
struct Report {
    /// The scene file's name without `.toml`; `default` for the embedded scene.
    scene: String,
    adapter: String,
    backend: String,
    device_type: String,
    driver: String,
    width: u32,
    height: u32,
    frames: u32,
    /// Rain drops simulated and drawn in the last frame (absent without rain).
    #[serde(skip_serializing_if = "Option::is_none")]
    rain_drops: Option<u32>,
    timestamps_supported: bool,
    /// Per-pass GPU time from timestamp queries (empty when unsupported).
    passes: Vec<PassReport>,
    /// Sum of the passes' GPU times per frame.
    gpu_total: Option<Stats>,
    /// Wall-clock time from submission to completion of each frame.
    frame_wall: Stats,
    /// CPU time of `Renderer::prepare` per frame (the render thread's
    /// share: uniforms, changed resources, CPU-side updates).
    cpu_prepare: Stats,
    /// CPU time of `Renderer::encode` and finishing the command buffer.
    cpu_encode: Stats,
    /// The two together, per frame.
    cpu_total: Stats,
    note: Option<String>,
}

/// Runs one benchmark.
fn run_benchmark(args: &BenchArgs) -> anyhow::Result<()> {
    let (scene, width, height) = args.frame.scene_and_size()?;
    let mut headless = HeadlessRenderer::new(args.frame.adapter())?;
    eprintln!(
        "nimbus: benchmarking {} frames at {width}×{height} on {}",
        args.frames,
        headless.gpu.adapter_summary()
    );
    // Warm-up: builds the terrain and the pipelines' first use (blocking,
    // so that every part is ready). Then precomputation moves off the render
    // thread, as in an application: the CPU times are its render thread's.
    let progress = Progress::new("bench: frames", u64::from(args.frames));
    progress.set_message("warm-up frame (precomputation)");
    headless.render_frame(&scene, width, height, 0.0)?;
    progress.set_message("");
    headless.renderer.set_precompute(Precompute::Background);
    let mut wall_ms = Vec::new();
    let mut per_pass: Vec<Vec<f64>> = vec![Vec::new(); PASS_NAMES.len()];
    let mut totals = Vec::new();
    let (mut prepare_ms, mut encode_ms, mut cpu_ms) = (Vec::new(), Vec::new(), Vec::new());
    for frame in 0..args.frames {
        if args.update_luts {
            headless.renderer.invalidate_atmosphere();
            headless.renderer.invalidate_cloud_shadow();
        }
        let seconds = headless.render_frame(&scene, width, height, frame as f32 / 60.0)?;
        wall_ms.push(seconds * 1e3);
        let cpu = headless.last_frame_cpu_times();
        prepare_ms.push(cpu.prepare_s * 1e3);
        encode_ms.push(cpu.encode_s * 1e3);
        cpu_ms.push((cpu.prepare_s + cpu.encode_s) * 1e3);
        if let Some(times) = headless.renderer.read_pass_times_ms() {
            for (series, t) in per_pass.iter_mut().zip(&times) {
                series.extend(*t);
            }
            totals.push(times.iter().flatten().sum());
        }
        // Reading the timestamps back waits for the device as well, and
        // reads as no times when it fails: a device lost there ends the run
        // with the loss, not with a report short of frames.
        headless.gpu.faults.check()?;
        progress.update(u64::from(frame) + 1);
    }
    progress.finish();
    let timestamps = headless.renderer.has_timestamps() && !totals.is_empty();
    let info = &headless.gpu.adapter_info;
    let report = Report {
        scene: args.frame.scene_name(),
        adapter: info.name.clone(),
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: format!("{} {}", info.driver, info.driver_info).trim().to_owned(),
        width,
        height,
        frames: args.frames,
        rain_drops: {
            let rain = headless.renderer.rain();
            rain.enabled().then(|| rain.dispatched_drops())
        },
        timestamps_supported: timestamps,
        passes: if timestamps {
            PASS_NAMES
                .iter()
                .zip(&per_pass)
                .zip(PassId::ALL)
                // The bench draws a finished picture (Display): the passes of
                // a caller's frame (LinearHdr) never run, so are not listed.
                .filter(|(_, id)| !id.only_in_linear_hdr())
                .map(|((name, series), _)| PassReport {
                    name,
                    frames: series.len(),
                    stats: (!series.is_empty()).then(|| Stats::of(series)),
                })
                .collect()
        } else {
            Vec::new()
        },
        gpu_total: timestamps.then(|| Stats::of(&totals)),
        frame_wall: Stats::of(&wall_ms),
        cpu_prepare: Stats::of(&prepare_ms),
        cpu_encode: Stats::of(&encode_ms),
        cpu_total: Stats::of(&cpu_ms),
        note: (!timestamps).then(|| "this adapter does not support timestamp queries: only wall-clock frame times are reported".to_owned()),
    };
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        outln!(
            "adapter   {} ({}, {})",
            report.adapter,
            report.backend,
            report.device_type
        );
        outln!("size      {width}×{height}, {} frames", report.frames);
        if let Some(drops) = report.rain_drops {
            outln!("rain      {drops} drops");
        }
        for pass in &report.passes {
            match &pass.stats {
                Some(stats) => outln!(
                    "{:<20} median {:8.3} ms   p95 {:8.3} ms   ({} frames)",
                    pass.name,
                    stats.median_ms,
                    stats.p95_ms,
                    pass.frames
                ),
                None => outln!(
                    "{:<20} not run (its inputs did not change{})",
                    pass.name,
                    if PassId::ATMOSPHERE.map(PassId::name).contains(&pass.name) {
                        "; --update-luts to measure"
                    } else {
                        ""
                    }
                ),
            }
        }
        if let Some(total) = &report.gpu_total {
            outln!(
                "{:<20} median {:8.3} ms   p95 {:8.3} ms",
                "gpu total",
                total.median_ms,
                total.p95_ms
            );
        }
        outln!(
            "{:<20} median {:8.3} ms   p95 {:8.3} ms",
            "wall",
            report.frame_wall.median_ms,
            report.frame_wall.p95_ms
        );
        // The render thread's share: a rare spike matters to a game.
        for (name, stats) in [
            ("cpu prepare", &report.cpu_prepare),
            ("cpu encode", &report.cpu_encode),
            ("cpu total", &report.cpu_total),
        ] {
            outln!(
                "{:<20} median {:8.3} ms   p95 {:8.3} ms   max {:8.3} ms",
                name,
                stats.median_ms,
                stats.p95_ms,
                stats.max_ms
            );
        }
        if let Some(note) = &report.note {
            outln!("note      {note}");
        }
    }
    Ok(())
}
