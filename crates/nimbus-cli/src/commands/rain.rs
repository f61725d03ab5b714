//! `nimbus rain`: raindrop fall speeds beside Gunn & Kinzer's measurements,
//! and the statistics of the CPU rain simulation (drop count against the
//! Marshall–Palmer expectation, mean diameter and velocity, recycling,
//! stability). The science is in `nimbus_physics::rain`; see docs/rain.md.

use crate::progress::Progress;
use clap::{Args, Subcommand};
use glam::Vec3;
use nimbus_physics::rain::drag::{GUNN_KINZER_1949, drag_coefficient, terminal_speed_m_s};
use nimbus_physics::rain::dsd::mean_sampled_diameter_mm;
use nimbus_physics::rain::rain_box::{RainBox, RainBoxShape};
use nimbus_physics::rain::simulation::{
    RainParams, STEP_S, Simulation, expected_drop_count, target_drop_count,
};
use nimbus_physics::rain::wind::{WindField, WindGrid, WindPrimitive, WindPrimitiveKind};
use nimbus_physics::rain::zones::RainZones;
use serde::Serialize;

/// Most drops `nimbus rain stats` simulates (about 0.6 GB of drops): the
/// documented limit on the input-derived count.
pub const MAX_STATS_DROPS: u32 = 20_000_000;
/// Most diameters in one `terminal-velocity` call.
const MAX_DIAMETERS: usize = 10_000;
/// Largest diameter accepted, mm (raindrops break up well below it).
const MAX_DIAMETER_MM: f64 = 8.0;
/// Smallest diameter of `terminal-velocity`, mm: a 10 µm cloud droplet
/// (the drag law's Stokes end); smaller ones overflow the drag coefficient.
const MIN_DIAMETER_MM: f64 = 0.01;
/// Largest rain intensity accepted, mm/h (beyond the heaviest measured rain rates).
const MAX_INTENSITY_MM_H: f64 = 300.0;
/// Longest simulated time, s.
const MAX_SECONDS: f64 = 3600.0;
/// Rain-box radius range, m.
const BOX_RADIUS_RANGE_M: (f64, f64) = (0.5, 50.0);
/// Largest wind speed accepted, m/s.
const MAX_WIND_M_S: f64 = 100.0;
/// Height of the rain box's centre above the (absent) ground, m.
const BOX_HEIGHT_M: f32 = 100.0;

/// Arguments of `nimbus rain`.
#[derive(Debug, Args)]
pub struct RainArgs {
    #[command(subcommand)]
    command: RainCommand,
}

#[derive(Debug, Subcommand)]
enum RainCommand {
    /// Terminal fall speed in still air (fit of Atlas, Srivastava & Sekhon
    /// 1973), the drag coefficient it implies, and Gunn & Kinzer's (1949)
    /// measurement where the diameter is in their table.
    TerminalVelocity(TerminalVelocityArgs),
    /// Runs the CPU rain simulation (a sphere of drops 100 m above a world
    /// without ground, rain everywhere, a uniform wind) and reports its drop
    /// count against the Marshall–Palmer expectation, mean diameter and
    /// velocity, recycling rate and non-finite values.
    Stats(StatsArgs),
}

/// Arguments of `nimbus rain terminal-velocity`.
#[derive(Debug, Args)]
struct TerminalVelocityArgs {
    /// Drop diameters, mm, comma-separated, each in (0, 8].
    #[arg(
        long,
        default_value = "0.5,1,2,3,4,5",
        value_name = "MM,…",
        allow_hyphen_values = true
    )]
    diameter_mm: String,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
}

/// Arguments of `nimbus rain stats`.
#[derive(Debug, Args)]
struct StatsArgs {
    /// Rain intensity, mm/h, in [0, 300].
    #[arg(long, value_name = "MM_H", allow_negative_numbers = true)]
    intensity_mm_h: f64,
    /// Simulated time, s, in (0, 3600] (rounded to whole steps of 1/120 s).
    #[arg(
        long,
        default_value_t = 5.0,
        value_name = "S",
        allow_negative_numbers = true
    )]
    seconds: f64,
    /// Mean wind X,Y,Z, m/s (east, up, south), each finite, |W| ≤ 100.
    #[arg(
        long,
        default_value = "0,0,0",
        value_name = "X,Y,Z",
        allow_hyphen_values = true
    )]
    wind_m_s: String,
    /// Radius of the spherical rain box, m, in [0.5, 50].
    #[arg(
        long,
        default_value_t = 5.0,
        value_name = "M",
        allow_negative_numbers = true
    )]
    box_radius_m: f64,
    /// Smallest simulated drop diameter, mm (> 0, below the largest).
    #[arg(
        long,
        default_value_t = 0.5,
        value_name = "MM",
        allow_negative_numbers = true
    )]
    min_diameter_mm: f64,
    /// Largest drop diameter, mm (≤ 8; the distribution is clamped there).
    #[arg(
        long,
        default_value_t = 6.0,
        value_name = "MM",
        allow_negative_numbers = true
    )]
    max_diameter_mm: f64,
    /// Add gust fronts (10 m/s along the wind, every 4 s) and turbulence
    /// (2 m/s RMS) to the mean wind, to check the simulation's stability.
    #[arg(long)]
    gusts: bool,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
}

/// Runs the subcommand.
pub fn run(args: &RainArgs) -> anyhow::Result<()> {
    match &args.command {
        RainCommand::TerminalVelocity(a) => run_terminal_velocity(a),
        RainCommand::Stats(a) => run_stats(a),
    }
}

/// Parses a comma-separated list of numbers given to `flag`.
fn parse_list(flag: &str, text: &str) -> anyhow::Result<Vec<f64>> {
    text.split(',')
        .map(|item| {
            let item = item.trim();
            item.parse::<f64>().map_err(|_| {
                anyhow::anyhow!(
                    "--{flag} {text}: `{item}` is not a number (give comma-separated numbers)"
                )
            })
        })
        .collect()
}

#[derive(Debug, Serialize)]
struct SpeedRow {
    diameter_mm: f64,
    speed_m_s: f64,
    /// Gunn & Kinzer (1949), Table 2, where the diameter is tabulated.
    gunn_kinzer_m_s: Option<f64>,
    drag_coefficient: f64,
}

/// Gunn & Kinzer's measured speed at `d_mm`, if it is in their table.
fn gunn_kinzer_m_s(d_mm: f64) -> Option<f64> {
    GUNN_KINZER_1949
        .iter()
        .find(|(d, _)| (d - d_mm).abs() < 1e-9)
        .map(|&(_, v)| v)
}

fn run_terminal_velocity(args: &TerminalVelocityArgs) -> anyhow::Result<()> {
    let diameters = parse_list("diameter-mm", &args.diameter_mm)?;
    anyhow::ensure!(
        diameters.len() <= MAX_DIAMETERS,
        "--diameter-mm: {} diameters; at most {MAX_DIAMETERS}",
        diameters.len()
    );
    for &d in &diameters {
        anyhow::ensure!(
            d.is_finite() && (MIN_DIAMETER_MM..=MAX_DIAMETER_MM).contains(&d),
            "--diameter-mm {d}: must be a diameter in [{MIN_DIAMETER_MM}, {MAX_DIAMETER_MM}] mm"
        );
    }
    let rows: Vec<SpeedRow> = diameters
        .iter()
        .map(|&d| SpeedRow {
            diameter_mm: d,
            speed_m_s: terminal_speed_m_s(d),
            gunn_kinzer_m_s: gunn_kinzer_m_s(d),
            drag_coefficient: drag_coefficient(d),
        })
        .collect();
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    outln!("D (mm)   v_t (m/s)   Gunn & Kinzer (m/s)   difference   C_d");
    for r in &rows {
        let (measured, difference) = match r.gunn_kinzer_m_s {
            Some(g) => (
                format!("{g:.2}"),
                format!("{:+.1} %", 100.0 * (r.speed_m_s - g) / g),
            ),
            None => ("–".to_owned(), "–".to_owned()),
        };
        outln!(
            "{:>6}   {:>9.3}   {measured:>19}   {difference:>10}   {:.3}",
            r.diameter_mm,
            r.speed_m_s,
            r.drag_coefficient
        );
    }
    Ok(())
}

#[derive(Debug, Serialize)]
struct StatsReport {
    intensity_mm_h: f64,
    box_radius_m: f64,
    box_volume_m3: f64,
    min_diameter_mm: f64,
    max_diameter_mm: f64,
    /// Marshall–Palmer expectation in the box (uncapped, fractional).
    expected_drops: f64,
    /// Drops alive or leaving at the end.
    simulated_drops: u64,
    /// (simulated − expected)/expected; null when no drops are expected.
    relative_error: Option<f64>,
    /// Mean of the sampled (clamped) distribution; null without rain.
    expected_mean_diameter_mm: Option<f64>,
    /// Null without drops, as are the mean velocities.
    mean_diameter_mm: Option<f64>,
    /// Mean [x, z] velocity of the drops.
    mean_horizontal_velocity_m_s: Option<[f64; 2]>,
    mean_vertical_velocity_m_s: Option<f64>,
    wind_m_s: [f64; 3],
    gusts: bool,
    /// Drops re-entering per second, as a fraction of the drops.
    recycled_per_second: Option<f64>,
    splashes: u64,
    non_finite_values: u64,
    /// Simulated time, s (whole steps).
    seconds: f64,
    steps: u32,
}

/// Checks that `value` is finite and in [lo, hi].
fn check_range(flag: &str, value: f64, lo: f64, hi: f64, unit: &str) -> anyhow::Result<()> {
    anyhow::ensure!(
        value.is_finite() && (lo..=hi).contains(&value),
        "--{flag} {value}: must be a finite number in [{lo}, {hi}] {unit}"
    );
    Ok(())
}

/// The validated inputs of `nimbus rain stats`.
struct StatsInputs {
    wind_m_s: Vec3,
    steps: u32,
    params: RainParams,
    rain_box: RainBox,
}

fn validate_stats(args: &StatsArgs) -> anyhow::Result<StatsInputs> {
    check_range(
        "intensity-mm-h",
        args.intensity_mm_h,
        0.0,
        MAX_INTENSITY_MM_H,
        "mm/h",
    )?;
    anyhow::ensure!(
        args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= MAX_SECONDS,
        "--seconds {}: must be a finite number in (0, {MAX_SECONDS}] s",
        args.seconds
    );
    let (lo, hi) = BOX_RADIUS_RANGE_M;
    check_range("box-radius-m", args.box_radius_m, lo, hi, "m")?;
    anyhow::ensure!(
        args.min_diameter_mm.is_finite() && args.min_diameter_mm > 0.0,
        "--min-diameter-mm {}: must be a finite diameter above 0 mm",
        args.min_diameter_mm
    );
    anyhow::ensure!(
        args.max_diameter_mm.is_finite()
            && args.max_diameter_mm > args.min_diameter_mm
            && args.max_diameter_mm <= MAX_DIAMETER_MM,
        "--max-diameter-mm {}: must be above --min-diameter-mm ({}) and at most {MAX_DIAMETER_MM} mm",
        args.max_diameter_mm,
        args.min_diameter_mm
    );
    let wind = parse_list("wind-m-s", &args.wind_m_s)?;
    anyhow::ensure!(
        wind.len() == 3,
        "--wind-m-s {}: give three components X,Y,Z in m/s, e.g. 8,0,0",
        args.wind_m_s
    );
    anyhow::ensure!(
        wind.iter().all(|w| w.is_finite()),
        "--wind-m-s {}: components must be finite numbers",
        args.wind_m_s
    );
    let speed = wind.iter().map(|w| w * w).sum::<f64>().sqrt();
    anyhow::ensure!(
        speed <= MAX_WIND_M_S,
        "--wind-m-s {}: speed {speed:.1} m/s; at most {MAX_WIND_M_S} m/s",
        args.wind_m_s
    );

    let rain_box = RainBox::at_rest(
        RainBoxShape::Sphere {
            radius_m: args.box_radius_m as f32,
        },
        Vec3::new(0.0, BOX_HEIGHT_M, 0.0),
        [Vec3::X, Vec3::Y, Vec3::NEG_Z],
    );
    let mut params = RainParams {
        intensity_mm_h: args.intensity_mm_h as f32,
        min_diameter_mm: args.min_diameter_mm as f32,
        max_diameter_mm: args.max_diameter_mm as f32,
        max_drops: u32::MAX,
        ceiling_m: f32::INFINITY,
    };
    let count = target_drop_count(&params, params.intensity_mm_h, rain_box.volume_m3());
    anyhow::ensure!(
        count <= MAX_STATS_DROPS,
        "--intensity-mm-h {} with --box-radius-m {} and --min-diameter-mm {} needs {count} drops; \
         at most {MAX_STATS_DROPS} (lower the intensity or the radius, or raise the minimum diameter)",
        args.intensity_mm_h,
        args.box_radius_m,
        args.min_diameter_mm
    );
    params.max_drops = MAX_STATS_DROPS;
    let steps = ((args.seconds / STEP_S as f64).round() as u32).max(1);
    Ok(StatsInputs {
        wind_m_s: Vec3::new(wind[0] as f32, wind[1] as f32, wind[2] as f32),
        steps,
        params,
        rain_box,
    })
}

/// The mean wind, with gust fronts and turbulence when `gusts`.
fn wind_field(mean_m_s: Vec3, gusts: bool) -> WindField {
    let mut field = WindField::uniform(mean_m_s);
    if gusts {
        let horizontal = Vec3::new(mean_m_s.x, 0.0, mean_m_s.z);
        let axis = horizontal.try_normalize().unwrap_or(Vec3::X);
        // A front crosses the box's centre every 4 s, the first at 2 s.
        field.primitives.push(WindPrimitive {
            kind: WindPrimitiveKind::GustFront,
            center_m: Vec3::new(0.0, BOX_HEIGHT_M, 0.0),
            drift_m_s: Vec3::ZERO,
            axis,
            speed_m_s: 10.0,
            radius_m: 10.0,
            period_s: 4.0,
            front_speed_m_s: 15.0,
        });
        field.grid = Some(WindGrid::turbulence(16, 64.0, 2.0, 1));
    }
    field
}

fn run_stats(args: &StatsArgs) -> anyhow::Result<()> {
    let inputs = validate_stats(args)?;
    let wind = wind_field(inputs.wind_m_s, args.gusts);
    let mut simulation = Simulation::new(
        inputs.params,
        wind,
        RainZones::everywhere(),
        inputs.rain_box,
        f32::NEG_INFINITY,
    );
    let progress = Progress::new("rain stats: steps", u64::from(inputs.steps));
    for done in 1..=inputs.steps {
        simulation.step(inputs.rain_box);
        progress.update(u64::from(done));
    }
    progress.finish();

    let s = simulation.statistics();
    // Whole steps of 1/120 s (STEP_S, an f32, is 1/120 within 1e-7).
    let seconds = inputs.steps as f64 / (1.0 / STEP_S as f64).round();
    let volume = inputs.rain_box.volume_m3();
    let expected = expected_drop_count(
        inputs.params.intensity_mm_h,
        inputs.params.min_diameter_mm,
        volume,
    );
    let has_drops = s.drops > 0;
    let drops = s.drops as f64;
    let report = StatsReport {
        intensity_mm_h: args.intensity_mm_h,
        box_radius_m: args.box_radius_m,
        box_volume_m3: volume as f64,
        min_diameter_mm: args.min_diameter_mm,
        max_diameter_mm: args.max_diameter_mm,
        expected_drops: expected,
        simulated_drops: s.drops,
        relative_error: (expected > 0.0).then(|| (drops - expected) / expected),
        expected_mean_diameter_mm: (args.intensity_mm_h > 0.0).then(|| {
            mean_sampled_diameter_mm(
                args.intensity_mm_h,
                args.min_diameter_mm,
                args.max_diameter_mm,
            )
        }),
        mean_diameter_mm: has_drops.then_some(s.mean_diameter_mm),
        mean_horizontal_velocity_m_s: has_drops
            .then_some([s.mean_velocity_m_s[0], s.mean_velocity_m_s[2]]),
        mean_vertical_velocity_m_s: has_drops.then_some(s.mean_velocity_m_s[1]),
        wind_m_s: inputs.wind_m_s.to_array().map(f64::from),
        gusts: args.gusts,
        recycled_per_second: has_drops.then(|| simulation.recycled as f64 / seconds / drops),
        splashes: simulation.splashes,
        non_finite_values: s.non_finite_values,
        seconds,
        steps: inputs.steps,
    };
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    print_stats(&report);
    Ok(())
}

fn print_stats(r: &StatsReport) {
    let or_dash =
        |v: Option<f64>, digits: usize| v.map_or("–".to_owned(), |v| format!("{v:.digits$}"));
    outln!(
        "rain             {} mm/h, drops {}–{} mm, {} s ({} steps){}",
        r.intensity_mm_h,
        r.min_diameter_mm,
        r.max_diameter_mm,
        r.seconds,
        r.steps,
        if r.gusts { ", gusts" } else { "" }
    );
    outln!(
        "box              sphere of {} m, {:.1} m³",
        r.box_radius_m,
        r.box_volume_m3
    );
    outln!(
        "drops            {} simulated, {:.1} expected (Marshall–Palmer), error {}",
        r.simulated_drops,
        r.expected_drops,
        r.relative_error
            .map_or("–".to_owned(), |e| format!("{:+.2} %", 100.0 * e))
    );
    outln!(
        "mean diameter    {} mm (expected {} mm)",
        or_dash(r.mean_diameter_mm, 3),
        or_dash(r.expected_mean_diameter_mm, 3)
    );
    let [wx, wy, wz] = r.wind_m_s;
    outln!(
        "mean velocity    horizontal {} m/s, vertical {} m/s (wind {wx}, {wy}, {wz} m/s)",
        r.mean_horizontal_velocity_m_s
            .map_or("–".to_owned(), |[x, z]| format!("({x:.3}, {z:.3})")),
        or_dash(r.mean_vertical_velocity_m_s, 3)
    );
    outln!(
        "recycled         {} of the drops per second",
        or_dash(r.recycled_per_second, 3)
    );
    outln!(
        "splashes         {}, non-finite values {}",
        r.splashes,
        r.non_finite_values
    );
}
