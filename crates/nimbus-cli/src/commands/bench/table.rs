//! `nimbus bench table`: the JSON reports of `nimbus bench --json` (and of
//! the embedding example's `--json`) as one Markdown table, one row per
//! report, for docs/PERFORMANCE.md. Needs no GPU, Python or jq: the GPU
//! benchmark kit (`tools/gpu-bench/`) runs it on the machine it measured.

use clap::Args;
use nimbus_physics::io::{read_text_bounded, shown_text};
use nimbus_render::PASS_NAMES;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Largest report read, bytes (a report of every pass is about 5 kB).
const MAX_REPORT_BYTES: u64 = 1 << 20;

/// Most reports in one table.
const MAX_REPORTS: usize = 1000;

/// Most characters of a name from a report (scene, adapter, driver) shown in a cell.
const MAX_CELL_CHARS: usize = 80;

/// The passes given a column unless `--passes` says otherwise: those that
/// cost most in the benchmark scenes' steady frames, in frame order (the
/// cumulus shadow map is redrawn only when its clouds or the sun change, so
/// `all` shows it where it ran).
const DEFAULT_PASSES: &str =
    "rain_simulation,sky,terrain,cumulus,cumulus_fringes,stratus,rain_mist,rain";

/// Arguments of `nimbus bench table`.
#[derive(Debug, Args)]
pub struct TableArgs {
    /// Reports written by `nimbus bench --json` or `embed_world --json`, one
    /// row each, in this order (at most 1000, of at most 1 MiB each).
    #[arg(value_name = "REPORT.json", required = true, num_args = 1..)]
    reports: Vec<PathBuf>,
    /// The passes given a column (their GPU median), comma-separated, in
    /// this order; `all`: every pass that any report measured, in frame order.
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_value = DEFAULT_PASSES)]
    passes: Vec<String>,
}

/// A series' statistics as a report gives them, ms.
#[derive(Debug, Deserialize)]
struct Stats {
    median_ms: f64,
    p95_ms: Option<f64>,
}

/// One pass of a report (without statistics when it did not run).
#[derive(Debug, Deserialize)]
struct Pass {
    name: String,
    median_ms: Option<f64>,
}

/// What the table takes of a report; other keys are ignored.
#[derive(Debug, Deserialize)]
struct Report {
    /// The scene (absent from reports of older versions: the file's name stands in).
    scene: Option<String>,
    adapter: String,
    #[serde(default)]
    driver: String,
    width: u32,
    height: u32,
    frames: u32,
    rain_drops: Option<u64>,
    #[serde(default)]
    passes: Vec<Pass>,
    gpu_total: Option<Stats>,
    frame_wall: Option<Stats>,
}

impl Report {
    /// The times, checked: finite (JSON has no NaN) and not negative.
    fn check(&self) -> Result<(), String> {
        let mut times: Vec<(String, f64)> = Vec::new();
        for (i, pass) in self.passes.iter().enumerate() {
            times.extend(
                pass.median_ms
                    .map(|t| (format!("passes[{i}].median_ms"), t)),
            );
        }
        for (key, stats) in [
            ("gpu_total", &self.gpu_total),
            ("frame_wall", &self.frame_wall),
        ] {
            if let Some(stats) = stats {
                times.push((format!("{key}.median_ms"), stats.median_ms));
                times.extend(stats.p95_ms.map(|t| (format!("{key}.p95_ms"), t)));
            }
        }
        match times
            .into_iter()
            .find(|(_, t)| !(t.is_finite() && *t >= 0.0))
        {
            Some((key, t)) => Err(format!("{key} = {t}: must be a time in ms, ≥ 0")),
            None => Ok(()),
        }
    }

    /// The median of a pass, when the report measured it.
    fn pass_median(&self, name: &str) -> Option<f64> {
        self.passes
            .iter()
            .find(|p| p.name == name)
            .and_then(|p| p.median_ms)
    }
}

/// Reads and checks one report; errors name the file (and the key).
fn read_report(path: &Path) -> anyhow::Result<Report> {
    let text = read_text_bounded(path, MAX_REPORT_BYTES)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let report: Report = serde_path_to_error::deserialize(&mut serde_json::Deserializer::from_str(
        &text,
    ))
    .map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        if key.is_empty() || key == "." {
            anyhow::anyhow!("{}: not a benchmark report: {inner}", path.display())
        } else {
            anyhow::anyhow!("{}: not a benchmark report: {key}: {inner}", path.display())
        }
    })?;
    report
        .check()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(report)
}

/// Text from a report as a Markdown cell: terminal controls escaped,
/// bounded, and `|` escaped so that it stays one cell.
fn cell(text: &str) -> String {
    shown_text(text.trim(), MAX_CELL_CHARS).replace('|', "\\|")
}

/// A time, ms, to about three significant digits.
fn ms(t: f64) -> String {
    if t >= 100.0 {
        format!("{t:.1}")
    } else if t >= 1.0 {
        format!("{t:.2}")
    } else {
        format!("{t:.3}")
    }
}

/// A drop count: millions with two decimals from 100 000 on.
fn drops(n: u64) -> String {
    if n >= 100_000 {
        format!("{:.2} M", n as f64 / 1e6)
    } else {
        n.to_string()
    }
}

/// The pass columns: `--passes` checked against the pass names, or, for
/// `all`, every pass that a report measured (in frame order, then any name
/// this version does not know, in order of appearance).
fn columns(requested: &[String], reports: &[(PathBuf, Report)]) -> anyhow::Result<Vec<String>> {
    if requested.iter().any(|p| p == "all") {
        anyhow::ensure!(
            requested.len() == 1,
            "--passes: `all` stands alone, without other names"
        );
        let measured = |name: &str| reports.iter().any(|(_, r)| r.pass_median(name).is_some());
        let mut names: Vec<String> = PASS_NAMES
            .iter()
            .filter(|n| measured(n))
            .map(|n| (*n).to_owned())
            .collect();
        for (_, report) in reports {
            for pass in &report.passes {
                if pass.median_ms.is_some() && !names.contains(&pass.name) {
                    names.push(pass.name.clone());
                }
            }
        }
        return Ok(names);
    }
    let mut names: Vec<String> = Vec::new();
    for name in requested {
        anyhow::ensure!(
            PASS_NAMES.contains(&name.as_str()),
            "--passes: `{}` is not a pass; passes: {}, or `all`",
            shown_text(name, MAX_CELL_CHARS),
            PASS_NAMES.join(", ")
        );
        if !names.contains(name) {
            names.push(name.clone());
        }
    }
    Ok(names)
}

/// The table, caption first.
fn table(reports: &[(PathBuf, Report)], passes: &[String]) -> String {
    let mut out = String::from(
        "Per-pass GPU time from timestamp queries, median over the measured frames, ms; \
         GPU total: the passes' sum per frame, median / p95; wall: submission to completion \
         of a frame, median; —: not run or not measured.\n\n",
    );
    let mut header = vec!["scene", "resolution", "adapter", "frames", "drops"];
    header.extend(passes.iter().map(String::as_str));
    header.extend(["GPU total", "wall"]);
    let _ = writeln!(out, "| {} |", header.join(" | "));
    let _ = writeln!(out, "|{}", "---|".repeat(header.len()));
    let dash = || "—".to_owned();
    for (path, report) in reports {
        let scene = report.scene.clone().unwrap_or_else(|| {
            path.file_stem()
                .unwrap_or(path.as_os_str())
                .to_string_lossy()
                .into_owned()
        });
        let adapter = if report.driver.trim().is_empty() {
            cell(&report.adapter)
        } else {
            format!("{}, {}", cell(&report.adapter), cell(&report.driver))
        };
        let mut row = vec![
            cell(&scene),
            format!("{}×{}", report.width, report.height),
            adapter,
            report.frames.to_string(),
            report.rain_drops.map_or_else(dash, drops),
        ];
        row.extend(
            passes
                .iter()
                .map(|p| report.pass_median(p).map_or_else(dash, ms)),
        );
        row.push(
            report
                .gpu_total
                .as_ref()
                .map_or_else(dash, |s| match s.p95_ms {
                    Some(p95) => format!("{} / {}", ms(s.median_ms), ms(p95)),
                    None => ms(s.median_ms),
                }),
        );
        row.push(
            report
                .frame_wall
                .as_ref()
                .map_or_else(dash, |s| ms(s.median_ms)),
        );
        let _ = writeln!(out, "| {} |", row.join(" | "));
    }
    out
}

/// Runs `nimbus bench table`.
pub fn run(args: &TableArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.reports.len() <= MAX_REPORTS,
        "{} reports: at most {MAX_REPORTS} make one table",
        args.reports.len()
    );
    let reports = args
        .reports
        .iter()
        .map(|path| read_report(path).map(|r| (path.clone(), r)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let passes = columns(&args.passes, &reports)?;
    out!("{}", table(&reports, &passes));
    Ok(())
}
