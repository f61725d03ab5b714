//! `nimbus slab fit`: traces slabs over grids of thickness and sun angle
//! with the modified Mie model and fits the 1-D model's parameters to the
//! fluxes (Bouthors et al. 2006, appendix B), writing a table file that
//! `OneDimensionalTable::from_file` reads.

use super::{DropletArgs, check_photons};
use crate::progress::Progress;
use clap::Args;
use nimbus_physics::transport::fit::{FluxSample, fit_one_dimensional};
use nimbus_physics::transport::monte_carlo::{BATCH_PHOTONS, TraceSettings, trace};
use nimbus_physics::transport::stratus::{OneDimensionalParams, OneDimensionalTable};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `nimbus slab fit`.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// The table file to write (TOML).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Thicknesses to trace, m, comma-separated.
    #[arg(
        long,
        value_name = "M,…",
        default_value = "1,2,5,10,20,50,100,200,500,1000,2000"
    )]
    thickness_m: String,
    /// Sun zenith angles to fit, degrees in [0, 89], comma-separated.
    #[arg(
        long,
        value_name = "DEG,…",
        default_value = "0,10,20,30,40,50,60,70,80"
    )]
    sun_zenith_deg: String,
    /// Photons per slab.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    photons: u64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print the fitted table, its residuals and the paper's table as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    droplets: DropletArgs,
}

/// Parses a comma-separated list of numbers within `range`.
fn parse_list(flag: &str, text: &str, range: (f64, f64)) -> anyhow::Result<Vec<f64>> {
    let mut values = Vec::new();
    for item in text.split(',') {
        let v: f64 = item
            .trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("{flag} {text}: '{item}' is not a number"))?;
        anyhow::ensure!(
            v.is_finite() && v >= range.0 && v <= range.1,
            "{flag} {text}: {v} is outside [{}, {}]",
            range.0,
            range.1
        );
        values.push(v);
    }
    values.sort_by(f64::total_cmp);
    values.dedup();
    Ok(values)
}

#[derive(Serialize)]
struct Row {
    sun_zenith_deg: f64,
    b: f64,
    c: f64,
    kappa_c: f64,
    t: f64,
    r: f64,
    rms_transmittance: f64,
    rms_orders: f64,
}

impl Row {
    fn new(p: &OneDimensionalParams, rms_transmittance: f64, rms_orders: f64) -> Self {
        Self {
            sun_zenith_deg: p.sun_zenith_deg,
            b: p.b,
            c: p.c,
            kappa_c: p.kappa_c,
            t: p.t,
            r: p.r,
            rms_transmittance,
            rms_orders,
        }
    }
}

#[derive(Serialize)]
struct Report {
    beta: f64,
    rows: Vec<Row>,
    paper: Vec<Row>,
    paper_beta: f64,
    photons_per_slab: u64,
    thicknesses_m: Vec<f64>,
}

/// Runs the command.
pub fn run(args: &FitArgs) -> anyhow::Result<()> {
    args.droplets.check()?;
    check_photons(args.photons)?;
    let thicknesses = parse_list("--thickness-m", &args.thickness_m, (0.01, 100_000.0))?;
    let angles = parse_list("--sun-zenith-deg", &args.sun_zenith_deg, (0.0, 89.0))?;
    anyhow::ensure!(
        thicknesses.len() >= 4,
        "--thickness-m {}: at least 4 thicknesses are needed to fit 5 parameters per angle from 5 fluxes each",
        args.thickness_m
    );
    super::super::check_output_dir(&args.out)?;

    let droplets = args.droplets.mie();
    let theta_f = args.droplets.forward_peak_deg;
    let per_slab = args.photons.div_ceil(BATCH_PHOTONS) * BATCH_PHOTONS;
    let runs = thicknesses.len() * angles.len();
    let traced = droplets.traced(Some(theta_f));
    let progress = Progress::new("slab fit: photons", per_slab * runs as u64);
    let mut samples = Vec::with_capacity(runs);
    for (i, sun) in angles.iter().enumerate() {
        for (j, h) in thicknesses.iter().enumerate() {
            let medium = traced.slab(*h);
            let settings = TraceSettings {
                photons: args.photons,
                // A distinct stream family per slab keeps the runs independent.
                seed: args
                    .seed
                    .wrapping_mul(1_000_003)
                    .wrapping_add((i * 1000 + j) as u64),
                sun_zenith_deg: *sun,
                ..TraceSettings::default()
            };
            let offset = (i * thicknesses.len() + j) as u64 * per_slab;
            let result = trace(&medium, &settings, &|done| progress.update(offset + done));
            samples.push(FluxSample {
                thickness_m: *h,
                sun_zenith_deg: *sun,
                transmittance: result.transmittance.total.value,
                t1: result.transmittance.order1.value,
                t2: result.transmittance.order2.value,
                r1: result.reflectance.order1.value,
                r2: result.reflectance.order2.value,
            });
        }
    }
    progress.finish();
    let fit = fit_one_dimensional(&samples);
    let list = |v: &[f64]| {
        format!(
            "[{}]",
            v.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let source = [
        (
            "effective_radius_um",
            format!("{}", args.droplets.effective_radius_um),
        ),
        ("gamma", format!("{}", args.droplets.gamma)),
        (
            "number_density_cm3",
            format!("{}", args.droplets.number_density_cm3),
        ),
        ("wavelength_nm", format!("{}", args.droplets.wavelength_nm)),
        ("forward_peak_deg", format!("{theta_f}")),
        ("photons_per_slab", format!("{per_slab}")),
        ("seed", format!("{}", args.seed)),
        ("thicknesses_m", list(&thicknesses)),
    ];
    let text = fit.table.to_toml(&source);
    crate::output::write_bytes_atomically(&args.out, "--out", text.as_bytes())?;

    let paper = OneDimensionalTable::bouthors_2006();
    let rows: Vec<Row> = fit
        .table
        .rows
        .iter()
        .zip(fit.rms_transmittance.iter().zip(&fit.rms_orders))
        .map(|(p, (rt, ro))| Row::new(p, *rt, *ro))
        .collect();
    if args.json {
        let report = Report {
            beta: fit.table.beta,
            paper: paper
                .rows
                .iter()
                .map(|p| Row::new(p, f64::NAN, f64::NAN))
                .collect(),
            rows,
            paper_beta: paper.beta,
            photons_per_slab: per_slab,
            thicknesses_m: thicknesses,
        };
        outln!("{}", serde_json::to_string(&report)?);
    } else {
        outln!(
            "beta {:.5} (paper {:.4}); fitted / paper, rms residuals of T_ms and of T1 R1 T2 R2:",
            fit.table.beta,
            paper.beta
        );
        outln!(
            "{:>5}  {:>15}  {:>15}  {:>15}  {:>15}  {:>15}  {:>8}  {:>8}",
            "sun",
            "b",
            "c",
            "kappa_c",
            "t",
            "r",
            "rms T",
            "rms 1-2"
        );
        for row in &rows {
            let p = paper.at(row.sun_zenith_deg);
            outln!(
                "{:>5.1}  {:>7.4}/{:<7.4}  {:>7.4}/{:<7.4}  {:>7.4}/{:<7.4}  {:>7.4}/{:<7.4}  {:>7.4}/{:<7.4}  {:>8.1e}  {:>8.1e}",
                row.sun_zenith_deg,
                row.b,
                p.b,
                row.c,
                p.c,
                row.kappa_c,
                p.kappa_c,
                row.t,
                p.t,
                row.r,
                p.r,
                row.rms_transmittance,
                row.rms_orders
            );
        }
    }
    eprintln!("nimbus: wrote {}", args.out.display());
    Ok(())
}
