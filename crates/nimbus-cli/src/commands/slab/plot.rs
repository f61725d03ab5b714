//! `nimbus slab plot`: radiance against view angle in the sun's plane,
//! stacked per scattering order, the analytic model (filled areas) against
//! Monte-Carlo tracing (lines), like Bouthors et al. (2006), figs 6 and 9;
//! a PNG or an SVG by the extension of `--out` (drawn by `crate::plot`).

use super::{
    DropletArgs, DropletOptics, Progress, check_photons, check_sun_zenith, check_thickness,
};
use crate::plot::{Area, Axis, Figure, FigureFormat, LegendPosition, Line, Marker, Rgb, Stroke};
use clap::{Args, ValueEnum};
use nimbus_physics::transport::monte_carlo::{
    BATCH_PHOTONS, TraceResult, TraceSettings, ViewDirection, scattering_cosine, trace,
};
use nimbus_physics::transport::stratus::{SlabRadiance, StratusModel, StratusOptics};
use std::path::PathBuf;

/// Arguments of `nimbus slab plot`.
#[derive(Debug, Args)]
pub struct PlotArgs {
    /// Geometric thickness H, m.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    thickness_m: f64,
    /// Sun zenith angle, degrees in [0, 89].
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    sun_zenith_deg: f64,
    /// The figure to write: .png or .svg.
    #[arg(long, value_name = "FIG.png|FIG.svg")]
    out: PathBuf,
    /// reflection (radiance leaving the top, as in the paper's figures) or
    /// transmission (leaving the bottom).
    #[arg(long, value_enum, default_value_t = Side::Reflection)]
    side: Side,
    /// Radiance axis: linear or log. Default: linear in reflection, log in
    /// transmission (where the forward peak is orders of magnitude above the
    /// rest).
    #[arg(long, value_enum)]
    scale: Option<Scale>,
    /// Step of the view angle, degrees in [0.25, 10].
    #[arg(long, default_value_t = 1.0, value_name = "DEG")]
    step_deg: f64,
    /// Monte-Carlo photons per tracing (two tracings: modified and full Mie).
    #[arg(long, default_value_t = 200_000, value_name = "N")]
    photons: u64,
    /// Monte-Carlo random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Also write the plotted values as CSV.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    #[command(flatten)]
    droplets: DropletArgs,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Scale {
    Linear,
    Log,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Side {
    Reflection,
    Transmission,
}

/// The view direction at signed angle `x_deg` in the sun's plane: positive
/// on the sun's side (relative azimuth 0), negative opposite; the zenith
/// angle is |x| above the slab or 180° − |x| below it.
fn view_at(x_deg: f64, side: Side) -> ViewDirection {
    ViewDirection {
        zenith_deg: match side {
            Side::Reflection => x_deg.abs(),
            Side::Transmission => 180.0 - x_deg.abs(),
        },
        relative_azimuth_deg: if x_deg >= 0.0 { 0.0 } else { 180.0 },
    }
}

/// Legend texts and colours of the analytic orders 0, 1, 2 and 3+.
const ANALYTIC_LABELS: [&str; 4] = [
    "analytic order 0 (forward peak)",
    "analytic order 1",
    "analytic order 2",
    "analytic order 3+",
];
const ANALYTIC_COLORS: [Rgb; 4] = [
    [205, 205, 205],
    [253, 196, 140],
    [170, 222, 160],
    [170, 198, 240],
];
/// Legend texts and colours of the traced cumulative sums.
const TRACED_LABELS: [&str; 3] = [
    "Monte-Carlo, modified Mie: order 1",
    "Monte-Carlo, modified Mie: orders 1–2",
    "Monte-Carlo, modified Mie: all orders",
];
const TRACED_COLORS: [Rgb; 3] = [[205, 95, 0], [25, 125, 35], [25, 65, 180]];

/// Runs the command.
pub fn run(args: &PlotArgs) -> anyhow::Result<()> {
    check_thickness("--thickness-m", args.thickness_m)?;
    check_sun_zenith(args.sun_zenith_deg)?;
    check_photons(args.photons)?;
    args.droplets.check()?;
    anyhow::ensure!(
        args.step_deg.is_finite() && (0.25..=10.0).contains(&args.step_deg),
        "--step-deg {}: must be in [0.25, 10]",
        args.step_deg
    );
    FigureFormat::from_path(&args.out, "--out")?;
    super::super::check_output_dir(&args.out)?;
    if let Some(csv) = &args.csv {
        super::super::check_output_dir(csv)?;
    }

    let droplets = args.droplets.mie();
    let theta_f = args.droplets.forward_peak_deg;
    let model = StratusModel::new(StratusOptics::from_phase(
        &droplets.phase,
        droplets.extinction_per_m,
        theta_f,
    ));
    // View angles from −89° to 89°, symmetric about 0.
    let half = (89.0 / args.step_deg).floor() as i64;
    let xs: Vec<f64> = (-half..=half).map(|k| k as f64 * args.step_deg).collect();
    let views: Vec<ViewDirection> = xs.iter().map(|x| view_at(*x, args.side)).collect();
    let analytic: Vec<SlabRadiance> = views
        .iter()
        .map(|v| model.radiance(args.thickness_m, args.sun_zenith_deg, *v))
        .collect();

    let per_trace = args.photons.div_ceil(BATCH_PHOTONS) * BATCH_PHOTONS;
    let progress = Progress::new("slab plot: photons", 2 * per_trace);
    let run_trace = |droplets: &DropletOptics, modified: bool, offset: u64| -> TraceResult {
        let medium = droplets
            .traced(modified.then_some(theta_f))
            .slab(args.thickness_m);
        let settings = TraceSettings {
            photons: args.photons,
            seed: args.seed,
            sun_zenith_deg: args.sun_zenith_deg,
            views: views.clone(),
            ..TraceSettings::default()
        };
        trace(&medium, &settings, &|done| progress.update(offset + done))
    };
    let modified = run_trace(&droplets, true, 0);
    let full = run_trace(&droplets, false, per_trace);
    progress.finish();

    // Cumulative sums: the analytic areas' upper edges and the traced lines.
    let analytic_stack: Vec<[f64; 4]> = analytic
        .iter()
        .map(|r| {
            let o0 = r.order0;
            [o0, o0 + r.order1, o0 + r.order1 + r.order2, r.total]
        })
        .collect();
    let traced_stack: Vec<[f64; 3]> = modified
        .radiance
        .iter()
        .map(|r| {
            let (o1, o2, o3) = (r.order1.value, r.order2.value, r.order3plus.value);
            [o1, o1 + o2, o1 + o2 + o3]
        })
        .collect();
    let full_total: Vec<f64> = full.radiance.iter().map(|r| r.total.value).collect();

    let log = args.scale.unwrap_or(match args.side {
        Side::Reflection => Scale::Linear,
        Side::Transmission => Scale::Log,
    }) == Scale::Log;
    let side = match args.side {
        Side::Reflection => "reflected",
        Side::Transmission => "transmitted",
    };
    let y_title = format!("{side} radiance per unit incident flux (sr⁻¹)");
    let y = if log {
        // Whole decades from the smallest first-order value to the peak.
        let (lo, hi) = analytic
            .iter()
            .map(|r| r.total)
            .chain(traced_stack.iter().flat_map(|s| [s[0], s[2]]))
            .chain(full_total.iter().copied())
            .filter(|v| v.is_finite() && *v > 0.0)
            .fold((f64::MAX, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        let hi = hi.max(1e-12);
        Axis::log_decades(
            lo.min(hi).max(hi * 1e-6).log10().floor() as i32,
            hi.log10().ceil() as i32,
            y_title,
        )
    } else {
        // The linear range leaves out the analytic forward peak (order 0),
        // which would flatten everything else; it is clipped at the top.
        let peak = analytic
            .iter()
            .map(|r| r.total - r.order0)
            .chain(traced_stack.iter().map(|s| s[2]))
            .chain(if args.side == Side::Reflection {
                full_total.clone()
            } else {
                Vec::new()
            })
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        let y_max = nice_ceiling(1.08 * peak.max(1e-12));
        let ticks = (0..=5).map(|k| k as f64 * y_max / 5.0).collect();
        Axis::linear(0.0, y_max, ticks, y_title)
    };

    // The analytic orders as stacked areas, each between the cumulative
    // sums below and including it; order 0 only in transmission (in
    // reflection it is zero).
    let first_order = usize::from(args.side == Side::Reflection);
    let areas = (first_order..ANALYTIC_LABELS.len())
        .map(|k| Area {
            label: Some(ANALYTIC_LABELS[k].to_owned()),
            color: ANALYTIC_COLORS[k],
            xs: xs.clone(),
            lower: analytic_stack
                .iter()
                .map(|s| if k == 0 { 0.0 } else { s[k - 1] })
                .collect(),
            upper: analytic_stack.iter().map(|s| s[k]).collect(),
        })
        .collect();
    let mut lines: Vec<Line> = TRACED_LABELS
        .iter()
        .zip(TRACED_COLORS)
        .enumerate()
        .map(|(k, (label, color))| Line {
            label: Some((*label).to_owned()),
            color,
            stroke: Stroke::Solid,
            points: xs
                .iter()
                .zip(&traced_stack)
                .map(|(x, s)| (*x, s[k]))
                .collect(),
        })
        .collect();
    lines.push(Line {
        label: Some("Monte-Carlo, full Mie: all orders".to_owned()),
        color: [0, 0, 0],
        stroke: Stroke::Dashed,
        points: xs.iter().copied().zip(full_total.iter().copied()).collect(),
    });
    let markers = feature_markers(&droplets, args.sun_zenith_deg, args.side, &xs)
        .into_iter()
        .map(|(x, label)| Marker {
            x,
            label,
            color: [120, 0, 120],
        })
        .collect();
    let figure = Figure {
        size: (1200, 640),
        caption: Some(format!(
            "H = {} m, sun zenith angle {}°, λ = {} nm, τ = {:.2}",
            args.thickness_m,
            args.sun_zenith_deg,
            args.droplets.wavelength_nm,
            droplets.extinction_per_m * args.thickness_m
        )),
        x: Axis::linear(
            -90.0,
            90.0,
            (-6..=6).map(|k| 15.0 * k as f64).collect(),
            "view zenith angle in the sun’s plane (°; > 0 on the sun’s side)",
        ),
        y,
        areas,
        lines,
        markers,
        // Where the curves leave room: reflected radiance rises towards
        // both horizons and stays low in the middle; transmitted radiance
        // peaks in the sun's direction (x < 0) and stays low on the other side.
        legend: match args.side {
            Side::Reflection => LegendPosition::UpperMiddle,
            Side::Transmission => LegendPosition::UpperRight,
        },
    };
    figure.write(&args.out, "--out")?;

    if let Some(path) = &args.csv {
        let mut text = String::from(
            "x_deg,view_zenith_deg,relative_azimuth_deg,scattering_angle_deg,\
             analytic_order0,analytic_order1,analytic_order2,analytic_order3plus,analytic_total,\
             mc_modified_order1,mc_modified_order2,mc_modified_order3plus,mc_modified_total,mc_modified_total_std_error,\
             mc_full_total,mc_full_total_std_error\n",
        );
        for (i, x) in xs.iter().enumerate() {
            let v = views[i];
            let theta = scattering_cosine(args.sun_zenith_deg, v)
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees();
            let a = &analytic[i];
            let m = &modified.radiance[i];
            let f = &full.radiance[i];
            text.push_str(&format!(
                "{x},{},{},{theta:.3},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.3e},{:.6e},{:.3e}\n",
                v.zenith_deg,
                v.relative_azimuth_deg,
                a.order0,
                a.order1,
                a.order2,
                a.order3plus,
                a.total,
                m.order1.value,
                m.order2.value,
                m.order3plus.value,
                m.total.value,
                m.total.std_error,
                f.total.value,
                f.total.std_error
            ));
        }
        crate::output::write_bytes_atomically(path, "--csv", text.as_bytes())?;
    }
    eprintln!(
        "nimbus: slab plot: wrote {} ({} view angles, {} photons per tracing)",
        args.out.display(),
        xs.len(),
        modified.photons
    );
    Ok(())
}

/// The smallest of 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 × 10ⁿ at or above `v`.
fn nice_ceiling(v: f64) -> f64 {
    let decade = 10f64.powf(v.log10().floor());
    [1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0]
        .iter()
        .map(|m| m * decade)
        .find(|c| *c >= v)
        .unwrap_or(10.0 * decade)
}

/// Where the glory (scattering angle 180°), the fogbow (the phase
/// function's maximum between 120° and 160°) and, in reflection, the
/// pseudo-specular direction (the sun's mirror image) fall on the plot.
fn feature_markers(
    droplets: &DropletOptics,
    sun_zenith_deg: f64,
    side: Side,
    xs: &[f64],
) -> Vec<(f64, String)> {
    let fogbow_deg = (1200..=1600)
        .map(|k| k as f64 * 0.1)
        .max_by(|a, b| droplets.phase.at(*a).total_cmp(&droplets.phase.at(*b)))
        .unwrap_or(140.0);
    let angle = |x: f64| {
        scattering_cosine(sun_zenith_deg, view_at(x, side))
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    };
    let mut markers = Vec::new();
    // Sign changes of Θ(x) − target between samples, interpolated.
    let mut crossings = |target: f64, label: &str| {
        for w in xs.windows(2) {
            let (a, b) = (angle(w[0]) - target, angle(w[1]) - target);
            if a == 0.0 || a * b < 0.0 {
                let x = w[0] + (w[1] - w[0]) * a / (a - b);
                markers.push((x, label.to_owned()));
            }
        }
    };
    crossings(fogbow_deg, &format!("B fogbow ({fogbow_deg:.0}°)"));
    if side == Side::Reflection {
        markers.push((sun_zenith_deg, "A glory".to_owned()));
        markers.push((-sun_zenith_deg, "C pseudo-specular".to_owned()));
    } else {
        markers.push((-sun_zenith_deg, "forward peak".to_owned()));
    }
    markers
}
