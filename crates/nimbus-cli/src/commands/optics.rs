//! `nimbus optics`: Mie scattering by one sphere, and the bulk optics of a
//! droplet size distribution.

use crate::output::write_bytes_atomically;
use crate::progress::Progress;
use clap::{Args, Subcommand};
use nimbus_physics::optics::dsd::{BulkOptics, SizeDistribution, bulk_optics_observed};
use nimbus_physics::optics::mie::{MAX_SIZE_PARAMETER, MieCoefficients};
use nimbus_physics::optics::spectral::{spectral_grid, to_rgb};
use nimbus_physics::optics::water::{VALID_WAVELENGTH_NM, water_refractive_index};
use num_complex::Complex64;
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `nimbus optics`.
#[derive(Debug, Args)]
pub struct OpticsArgs {
    #[command(subcommand)]
    command: OpticsCommand,
}

#[derive(Debug, Subcommand)]
enum OpticsCommand {
    /// Lorenz–Mie scattering by one homogeneous sphere in air. The phase
    /// function is in 1/sr, normalised to 1 over the sphere (∫ p dΩ = 1).
    Mie(MieArgs),
    /// Bulk optics of a droplet size distribution (modified gamma or log-normal)
    /// per wavelength: extinction, g, forward fraction and phase function
    /// (1/sr, normalised to 1 over the sphere).
    Dsd(DsdArgs),
}

/// Arguments of `nimbus optics mie`.
#[derive(Debug, Args)]
struct MieArgs {
    /// Sphere radius, µm.
    #[arg(long, value_name = "UM", allow_negative_numbers = true)]
    radius_um: f64,
    /// Vacuum wavelength, nm.
    #[arg(long, value_name = "NM", allow_negative_numbers = true)]
    wavelength_nm: f64,
    /// Complex refractive index as N,K (K ≥ 0 absorbs); water at the wavelength when omitted.
    #[arg(long, value_name = "N,K", allow_hyphen_values = true)]
    refractive_index: Option<String>,
    /// Angular step of the phase function, degrees, in (0, 180].
    #[arg(long, default_value_t = 1.0, value_name = "DEG")]
    angle_step_deg: f64,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
}

/// Arguments of `nimbus optics dsd`.
#[derive(Debug, Args)]
struct DsdArgs {
    /// Effective radius r_e, µm.
    #[arg(long, default_value_t = 7.0, value_name = "UM")]
    effective_radius_um: f64,
    /// Shape parameter γ of the modified gamma distribution.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    gamma: f64,
    /// Use a log-normal distribution of this geometric standard deviation
    /// instead of the modified gamma (its median radius follows from r_e).
    #[arg(long, value_name = "SIGMA")]
    lognormal_sigma: Option<f64>,
    /// Droplet number density N₀, cm⁻³.
    #[arg(long, default_value_t = 300.0, value_name = "PER_CM3")]
    number_density_cm3: f64,
    /// Vacuum wavelengths, nm, comma-separated.
    #[arg(long, default_value = "650,550,450", value_name = "NM,…")]
    wavelength_nm: String,
    /// Integrate 380–780 nm every 20 nm and report Rec.709 RGB phase functions
    /// (CIE 1931 colour matching, equal-energy light) instead of wavelengths.
    #[arg(long)]
    spectral_rgb: bool,
    /// Angular step of the phase function, degrees, in (0, 180].
    #[arg(long, default_value_t = 0.5, value_name = "DEG")]
    angle_step_deg: f64,
    /// Relative convergence tolerance of the radius integral.
    #[arg(long, default_value_t = 1e-4)]
    tolerance: f64,
    /// Half-angle of the forward peak for `forward_fraction`, degrees.
    #[arg(long, default_value_t = 5.0, value_name = "DEG")]
    forward_peak_deg: f64,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
    /// Write the table (angle, phase per wavelength) as CSV.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Draw the phase functions on a log scale against angle into a figure:
    /// .png or .svg.
    #[arg(long, value_name = "FILE.png|FILE.svg")]
    plot: Option<PathBuf>,
    /// Report the computation time of each wavelength on standard error.
    #[arg(long)]
    timing: bool,
}

/// Runs the subcommand.
pub fn run(args: &OpticsArgs) -> anyhow::Result<()> {
    match &args.command {
        OpticsCommand::Mie(a) => run_mie(a),
        OpticsCommand::Dsd(a) => run_dsd(a),
    }
}

fn angles(step_deg: f64) -> anyhow::Result<Vec<f64>> {
    anyhow::ensure!(
        step_deg.is_finite() && step_deg > 0.0 && step_deg <= 180.0,
        "--angle-step-deg {step_deg}: must be in (0, 180]"
    );
    anyhow::ensure!(
        180.0 / step_deg <= 1_000_000.0,
        "--angle-step-deg {step_deg}: at most 1 000 000 angles"
    );
    let count = (180.0 / step_deg).floor() as usize;
    let mut a: Vec<f64> = (0..=count)
        .map(|i| (i as f64 * step_deg).min(180.0))
        .collect();
    if *a.last().unwrap_or(&0.0) < 180.0 - 1e-9 {
        a.push(180.0);
    }
    Ok(a)
}

pub(crate) fn check_wavelength(nm: f64) -> anyhow::Result<()> {
    let (lo, hi) = VALID_WAVELENGTH_NM;
    anyhow::ensure!(
        nm.is_finite() && (lo..=hi).contains(&nm),
        "--wavelength-nm {nm}: must be in [{lo}, {hi}] (water's tabulated index)"
    );
    Ok(())
}

fn parse_index(text: &str) -> anyhow::Result<Complex64> {
    let bad = || {
        anyhow::anyhow!(
            "--refractive-index {text}: must be N,K with N in [0.1, 10] and K in [0, 10], e.g. 1.333,1e-9"
        )
    };
    let (n, k) = text.split_once(',').ok_or_else(bad)?;
    let (n, k): (f64, f64) = (
        n.trim().parse().map_err(|_| bad())?,
        k.trim().parse().map_err(|_| bad())?,
    );
    // Usable limits (issue 28): N → 0 sends the Mie series to NaN, and no
    // material of interest lies outside these.
    if !(n.is_finite() && k.is_finite() && (0.1..=10.0).contains(&n) && (0.0..=10.0).contains(&k)) {
        return Err(bad());
    }
    Ok(Complex64::new(n, k))
}

#[derive(Serialize)]
struct MieReport {
    q_ext: f64,
    q_sca: f64,
    q_back: f64,
    q_abs: f64,
    g: f64,
    size_parameter: f64,
    refractive_index: [f64; 2],
    angles_deg: Vec<f64>,
    phase: Vec<f64>,
}

fn run_mie(args: &MieArgs) -> anyhow::Result<()> {
    check_wavelength(args.wavelength_nm)?;
    let x = 2.0 * std::f64::consts::PI * args.radius_um * 1e3 / args.wavelength_nm;
    anyhow::ensure!(
        args.radius_um.is_finite() && args.radius_um > 0.0 && x <= MAX_SIZE_PARAMETER,
        "--radius-um {}: must be positive with size parameter 2πr/λ at most {MAX_SIZE_PARAMETER} (here {x:.1})",
        args.radius_um
    );
    let m = match &args.refractive_index {
        Some(text) => parse_index(text)?,
        None => water_refractive_index(args.wavelength_nm),
    };
    let angles = angles(args.angle_step_deg)?;
    let c = MieCoefficients::new(x, m);
    let e = c.efficiencies();
    let mu: Vec<f64> = angles.iter().map(|a| a.to_radians().cos()).collect();
    let report = MieReport {
        q_ext: e.q_ext,
        q_sca: e.q_sca,
        q_back: e.q_back,
        q_abs: e.q_abs,
        g: e.g,
        size_parameter: x,
        refractive_index: [m.re, m.im],
        phase: c.phase_function(&mu),
        angles_deg: angles,
    };
    if args.json {
        outln!("{}", serde_json::to_string(&report)?);
    } else {
        outln!("size parameter {:.6}, m = {:.6} + {:.3e}i", x, m.re, m.im);
        outln!(
            "Q_ext {:.8}  Q_sca {:.8}  Q_abs {:.3e}  Q_back {:.8}  g {:.8}",
            e.q_ext,
            e.q_sca,
            e.q_abs,
            e.q_back,
            e.g
        );
        outln!("{:>10} {:>16}", "angle_deg", "phase_per_sr");
        for (a, p) in report.angles_deg.iter().zip(&report.phase) {
            outln!("{a:>10.3} {p:>16.8e}");
        }
    }
    Ok(())
}

#[derive(Serialize)]
struct DsdEntry {
    /// Wavelength in nm, or the channel name in spectral RGB mode.
    wavelength_nm: Option<f64>,
    channel: Option<&'static str>,
    extinction_per_m: f64,
    scattering_per_m: f64,
    single_scattering_albedo: f64,
    mean_free_path_m: f64,
    g: f64,
    forward_fraction_5deg: f64,
    radius_nodes: usize,
    angles_deg: Vec<f64>,
    phase: Vec<f64>,
}

fn entry(optics: &BulkOptics, forward_peak_deg: f64) -> DsdEntry {
    DsdEntry {
        wavelength_nm: Some(optics.wavelength_nm),
        channel: None,
        extinction_per_m: optics.extinction_per_m,
        scattering_per_m: optics.scattering_per_m,
        single_scattering_albedo: optics.single_scattering_albedo(),
        mean_free_path_m: optics.mean_free_path_m(),
        g: optics.g,
        forward_fraction_5deg: optics.forward_fraction(forward_peak_deg),
        radius_nodes: optics.radius_intervals,
        angles_deg: optics.angles_deg.clone(),
        phase: optics.phase.clone(),
    }
}

/// Checks the droplet-population flags that `optics dsd` and `slab` share:
/// the effective radius against `radius_range_um`, γ and N₀.
pub(crate) fn check_droplet_flags(
    effective_radius_um: f64,
    radius_range_um: (f64, f64),
    gamma: f64,
    number_density_cm3: f64,
) -> anyhow::Result<()> {
    let (lo, hi) = radius_range_um;
    anyhow::ensure!(
        effective_radius_um.is_finite() && (lo..=hi).contains(&effective_radius_um),
        "--effective-radius-um {effective_radius_um}: must be in [{lo}, {hi}]"
    );
    anyhow::ensure!(
        gamma.is_finite() && (0.5..=50.0).contains(&gamma),
        "--gamma {gamma}: must be in [0.5, 50]"
    );
    anyhow::ensure!(
        number_density_cm3.is_finite() && number_density_cm3 > 0.0 && number_density_cm3 <= 1e5,
        "--number-density-cm3 {number_density_cm3}: must be in (0, 100000]"
    );
    Ok(())
}

fn run_dsd(args: &DsdArgs) -> anyhow::Result<()> {
    check_droplet_flags(
        args.effective_radius_um,
        (0.1, 100.0),
        args.gamma,
        args.number_density_cm3,
    )?;
    anyhow::ensure!(
        args.tolerance.is_finite() && (1e-6..=0.1).contains(&args.tolerance),
        "--tolerance {}: must be in [1e-6, 0.1]",
        args.tolerance
    );
    anyhow::ensure!(
        args.forward_peak_deg.is_finite()
            && args.forward_peak_deg > 0.0
            && args.forward_peak_deg <= 15.0,
        "--forward-peak-deg {}: must be in (0, 15]",
        args.forward_peak_deg
    );
    for path in args.csv.iter().chain(&args.plot) {
        super::check_output_dir(path)?;
    }
    if let Some(path) = &args.plot {
        crate::plot::FigureFormat::from_path(path, "--plot")?;
    }
    let n0 = args.number_density_cm3 * 1e6;
    let dsd = match args.lognormal_sigma {
        Some(sigma) => {
            anyhow::ensure!(
                // Below 1.001 the distribution is narrower than the radius
                // quadrature resolves and the integrals come out NaN.
                sigma.is_finite() && (1.001..=5.0).contains(&sigma),
                "--lognormal-sigma {sigma}: must be in [1.001, 5]"
            );
            let median = args.effective_radius_um * 1e-6 / (2.5 * sigma.ln().powi(2)).exp();
            SizeDistribution::LogNormal {
                number_density_per_m3: n0,
                median_radius_m: median,
                geometric_std: sigma,
            }
        }
        None => SizeDistribution::ModifiedGamma {
            number_density_per_m3: n0,
            gamma: args.gamma,
            effective_radius_m: args.effective_radius_um * 1e-6,
        },
    };
    let angles = angles(args.angle_step_deg)?;
    let wavelengths: Vec<f64> = if args.spectral_rgb {
        spectral_grid(20.0).iter().map(|(l, _)| *l).collect()
    } else {
        args.wavelength_nm
            .split(',')
            .map(|t| {
                t.trim().parse::<f64>().map_err(|_| {
                    anyhow::anyhow!(
                        "--wavelength-nm {}: must be numbers in nm separated by commas",
                        args.wavelength_nm
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?
    };
    anyhow::ensure!(
        !wavelengths.is_empty() && wavelengths.len() <= 100,
        "--wavelength-nm {}: give 1 to 100 wavelengths",
        args.wavelength_nm
    );
    for wl in &wavelengths {
        check_wavelength(*wl)?;
    }
    let total_start = std::time::Instant::now();
    let mut results = Vec::new();
    let progress = Progress::new("optics: wavelengths", wavelengths.len() as u64);
    for (i, wl) in wavelengths.iter().enumerate() {
        let start = std::time::Instant::now();
        let optics = bulk_optics_observed(
            &dsd,
            *wl,
            water_refractive_index(*wl),
            &angles,
            args.tolerance,
            &mut |nodes| progress.set_message(format!("{wl} nm: {nodes} radius nodes")),
        );
        progress.update(i as u64 + 1);
        if args.timing {
            progress.eprintln(&format!(
                "nimbus: timing: {wl} nm: {:.3} s ({} radius nodes, {} angles)",
                start.elapsed().as_secs_f64(),
                optics.radius_intervals,
                angles.len()
            ));
        }
        results.push(optics);
    }
    progress.finish();
    if args.timing {
        eprintln!(
            "nimbus: timing: total {:.3} s for {} wavelengths",
            total_start.elapsed().as_secs_f64(),
            wavelengths.len()
        );
    }
    let entries: Vec<DsdEntry> = if args.spectral_rgb {
        rgb_entries(&results, args.forward_peak_deg)
    } else {
        results
            .iter()
            .map(|o| entry(o, args.forward_peak_deg))
            .collect()
    };
    if let Some(path) = &args.csv {
        write_csv(path, &entries)?;
    }
    if let Some(path) = &args.plot {
        crate::plot::write_phase_plot(
            path,
            "--plot",
            &entries
                .iter()
                .map(|e| (e.label(), e.angles_deg.clone(), e.phase.clone()))
                .collect::<Vec<_>>(),
        )?;
    }
    if args.json {
        outln!(
            "{}",
            serde_json::to_string(
                &serde_json::json!({ "effective_radius_um": args.effective_radius_um, "number_density_cm3": args.number_density_cm3, "results": entries })
            )?
        );
    } else {
        for e in &entries {
            outln!(
                "{:>8}  κ {:.6e} m⁻¹  mean free path {:.3} m  g {:.6}  P_f({}°) {:.4}",
                e.label(),
                e.extinction_per_m,
                e.mean_free_path_m,
                e.g,
                args.forward_peak_deg,
                e.forward_fraction_5deg
            );
        }
    }
    Ok(())
}

impl DsdEntry {
    fn label(&self) -> String {
        match (self.channel, self.wavelength_nm) {
            (Some(c), _) => c.to_owned(),
            (None, Some(wl)) => format!("{wl} nm"),
            (None, None) => String::new(),
        }
    }
}

/// Spectral results to R, G, B entries: scattering-weighted phase functions
/// (p σ_sca integrated with the colour-matching functions, divided by the
/// same for σ_sca), and coefficients integrated likewise.
fn rgb_entries(results: &[BulkOptics], forward_peak_deg: f64) -> Vec<DsdEntry> {
    let grid = spectral_grid(20.0);
    let angles = results[0].angles_deg.clone();
    let per_lambda = |f: &dyn Fn(&BulkOptics) -> Vec<f64>| -> Vec<[f64; 3]> {
        to_rgb(&grid, &results.iter().map(f).collect::<Vec<_>>())
    };
    let scattered = per_lambda(&|o| o.phase.iter().map(|p| p * o.scattering_per_m).collect());
    let scalars = per_lambda(&|o| {
        vec![
            o.extinction_per_m,
            o.scattering_per_m,
            o.g * o.scattering_per_m,
            o.forward_fraction(forward_peak_deg) * o.scattering_per_m,
        ]
    });
    ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let (ext, sca, g_sca, pf_sca) =
                (scalars[0][c], scalars[1][c], scalars[2][c], scalars[3][c]);
            let phase: Vec<f64> = scattered.iter().map(|v| v[c] / sca).collect();
            DsdEntry {
                wavelength_nm: None,
                channel: Some(name),
                extinction_per_m: ext,
                scattering_per_m: sca,
                single_scattering_albedo: sca / ext,
                mean_free_path_m: 1.0 / ext,
                g: g_sca / sca,
                forward_fraction_5deg: pf_sca / sca,
                radius_nodes: results
                    .iter()
                    .map(|o| o.radius_intervals)
                    .max()
                    .unwrap_or(0),
                angles_deg: angles.clone(),
                phase,
            }
        })
        .collect()
}

fn write_csv(path: &std::path::Path, entries: &[DsdEntry]) -> anyhow::Result<()> {
    let mut text = String::from("angle_deg");
    for e in entries {
        text.push_str(&format!(",phase_per_sr_{}", e.label().replace(' ', "")));
    }
    text.push('\n');
    for (k, a) in entries[0].angles_deg.iter().enumerate() {
        text.push_str(&format!("{a}"));
        for e in entries {
            text.push_str(&format!(",{:.9e}", e.phase[k]));
        }
        text.push('\n');
    }
    write_bytes_atomically(path, "--csv", text.as_bytes())
}
