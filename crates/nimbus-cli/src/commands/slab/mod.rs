//! `nimbus slab`: light transport through a homogeneous cloud slab lit by
//! the sun, by the analytic stratiform model (Bouthors et al. 2006, §4) or
//! by Monte-Carlo photon tracing.

mod fit;
mod plot;

use crate::progress::Progress;
use clap::{Args, Subcommand, ValueEnum};
use nimbus_physics::optics::dsd::{SizeDistribution, bulk_optics};
use nimbus_physics::optics::phase::PhaseTable;
use nimbus_physics::optics::tables::computation_angles;
use nimbus_physics::optics::water::water_refractive_index;
use nimbus_physics::transport::monte_carlo::{
    BATCH_PHOTONS, ByOrder, SlabMedium, TraceSettings, ViewDirection, trace,
};
use nimbus_physics::transport::phase_model::PhaseModel;
use nimbus_physics::transport::stratus::{StratusModel, StratusOptics};
use serde::Serialize;

/// `nimbus slab`: one slab and view direction, or a subcommand.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SlabCommand {
    #[command(subcommand)]
    action: Option<SlabAction>,
    #[command(flatten)]
    point: SlabArgs,
}

#[derive(Debug, Subcommand)]
enum SlabAction {
    /// Fit the 1-D model's parameters (β; b, c, κ_c, t, r per sun angle) to
    /// Monte-Carlo fluxes over grids of thickness and sun angle, like the
    /// paper's appendix B, and write them as a table file.
    Fit(fit::FitArgs),
    /// Plot radiance against view angle in the sun's plane, stacked per
    /// scattering order, analytic against Monte-Carlo (like the paper's
    /// figs 6 and 9).
    Plot(plot::PlotArgs),
}

/// The droplet population and the forward-peak split, shared by the slab
/// commands.
#[derive(Clone, Debug, Args)]
struct DropletArgs {
    /// Effective radius r_e of the modified gamma distribution, µm.
    #[arg(long, default_value_t = 7.0, value_name = "UM")]
    effective_radius_um: f64,
    /// Shape parameter γ of the modified gamma distribution.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    gamma: f64,
    /// Droplet number density N₀, cm⁻³.
    #[arg(long, default_value_t = 300.0, value_name = "PER_CM3")]
    number_density_cm3: f64,
    /// Vacuum wavelength, nm.
    #[arg(long, default_value_t = 550.0, value_name = "NM")]
    wavelength_nm: f64,
    /// Half-angle θ_f of the forward peak folded into extinction, degrees
    /// (analytic model and the modified Mie model of Monte-Carlo tracing).
    #[arg(long, default_value_t = 5.0, value_name = "DEG")]
    forward_peak_deg: f64,
}

impl DropletArgs {
    /// Checks the flags' ranges.
    fn check(&self) -> anyhow::Result<()> {
        super::optics::check_droplet_flags(
            self.effective_radius_um,
            (0.5, 50.0),
            self.gamma,
            self.number_density_cm3,
        )?;
        super::optics::check_wavelength(self.wavelength_nm)?;
        anyhow::ensure!(
            self.forward_peak_deg.is_finite() && (0.0..=15.0).contains(&self.forward_peak_deg),
            "--forward-peak-deg {}: must be in [0, 15]",
            self.forward_peak_deg
        );
        Ok(())
    }

    /// The population's phase function (normalised to 1 over the sphere)
    /// and extinction at the wavelength.
    fn mie(&self) -> DropletOptics {
        let dsd = SizeDistribution::ModifiedGamma {
            number_density_per_m3: self.number_density_cm3 * 1e6,
            gamma: self.gamma,
            effective_radius_m: self.effective_radius_um * 1e-6,
        };
        let o = bulk_optics(
            &dsd,
            self.wavelength_nm,
            water_refractive_index(self.wavelength_nm),
            &computation_angles(self.forward_peak_deg.max(5.0)),
            1e-3,
        );
        DropletOptics {
            albedo: o.single_scattering_albedo(),
            phase: PhaseTable::new(o.angles_deg, o.phase),
            extinction_per_m: o.extinction_per_m,
        }
    }
}

/// What the slab commands need of the droplets' optics.
struct DropletOptics {
    phase: PhaseTable,
    extinction_per_m: f64,
    albedo: f64,
}

impl DropletOptics {
    /// The Monte-Carlo medium: full Mie (phase function and κ) or modified
    /// (P_S and κ_S = (1 − P_f) κ, §4.1). Building the phase function's
    /// sampler takes a while, so it is done once for all slabs.
    fn traced(&self, modified_peak_deg: Option<f64>) -> TracedMedium {
        match modified_peak_deg {
            Some(theta_f) => TracedMedium {
                extinction_per_m: self.extinction_per_m
                    * (1.0 - self.phase.forward_fraction(theta_f)),
                albedo: self.albedo,
                phase: PhaseModel::tabulated(&self.phase.peak_removed(theta_f)),
            },
            None => TracedMedium {
                extinction_per_m: self.extinction_per_m,
                albedo: self.albedo,
                phase: PhaseModel::tabulated(&self.phase),
            },
        }
    }
}

/// A medium ready for tracing slabs of any thickness.
struct TracedMedium {
    phase: PhaseModel,
    /// Extinction as traced (κ or κ_S), m⁻¹.
    extinction_per_m: f64,
    albedo: f64,
}

impl TracedMedium {
    /// A slab of `thickness_m`.
    fn slab(&self, thickness_m: f64) -> SlabMedium {
        SlabMedium {
            optical_depth: self.extinction_per_m * thickness_m,
            single_scattering_albedo: self.albedo,
            phase: self.phase.clone(),
        }
    }
}

/// Arguments of `nimbus slab` for one slab and view direction.
#[derive(Debug, Args)]
struct SlabArgs {
    /// Geometric thickness H, m (the extinction comes from the droplet size
    /// distribution at the wavelength).
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        conflicts_with = "optical_depth",
        required_unless_present = "optical_depth"
    )]
    thickness_m: Option<f64>,
    /// Optical depth κH, set directly.
    #[arg(long, value_name = "TAU", allow_negative_numbers = true)]
    optical_depth: Option<f64>,
    /// Sun zenith angle, degrees in [0, 89].
    #[arg(
        long,
        value_name = "DEG",
        allow_negative_numbers = true,
        required = true
    )]
    sun_zenith_deg: Option<f64>,
    /// Zenith angle of the direction from the slab to the viewer, degrees:
    /// below 90 the viewer is above the slab (reflection), above 90 below it
    /// (transmission).
    #[arg(
        long,
        value_name = "DEG",
        allow_negative_numbers = true,
        required = true
    )]
    view_zenith_deg: Option<f64>,
    /// Azimuth of the viewer relative to the sun's, degrees: 0 with the sun
    /// behind the viewer (glory at view zenith = sun zenith), 180 opposite.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    relative_azimuth_deg: f64,
    /// Phase function: mie (the droplet size distribution's), hg:G
    /// (Henyey–Greenstein with asymmetry G) or isotropic.
    #[arg(long, default_value = "mie", value_parser = parse_phase)]
    phase: PhaseChoice,
    #[command(flatten)]
    droplets: DropletArgs,
    /// analytic (§4 model) or monte-carlo (photon tracing).
    #[arg(long, value_enum, default_value_t = Method::Analytic)]
    method: Method,
    /// Monte-Carlo phase function: full (the Mie phase function and κ) or
    /// modified (forward peak folded into extinction, §4.1: P_S and κ_S).
    #[arg(long, value_enum, default_value_t = MieMode::Full)]
    mie_mode: MieMode,
    /// Monte-Carlo photons.
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    photons: u64,
    /// Monte-Carlo random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
    /// Report the run time and scattering events per second on standard error.
    #[arg(long)]
    timing: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Method {
    Analytic,
    MonteCarlo,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum MieMode {
    Full,
    Modified,
}

/// The parsed `--phase` (not a `ValueEnum`: hg carries its asymmetry).
#[derive(Clone, Copy, Debug, PartialEq)]
enum PhaseChoice {
    Mie,
    HenyeyGreenstein(f64),
    Isotropic,
}

/// Parses `--phase`; clap reports the error with the flag and the value.
fn parse_phase(text: &str) -> Result<PhaseChoice, String> {
    let bad = || "must be mie, isotropic or hg:G with −1 < G < 1".to_owned();
    match text {
        "mie" => Ok(PhaseChoice::Mie),
        "isotropic" => Ok(PhaseChoice::Isotropic),
        _ => {
            let g: f64 = text
                .strip_prefix("hg:")
                .ok_or_else(bad)?
                .trim()
                .parse()
                .map_err(|_| bad())?;
            if g.is_finite() && g.abs() < 1.0 {
                Ok(PhaseChoice::HenyeyGreenstein(g))
            } else {
                Err(bad())
            }
        }
    }
}

#[derive(Serialize, Default)]
struct Orders {
    order0: f64,
    order1: f64,
    order2: f64,
    order3plus: f64,
    total: f64,
}

#[derive(Serialize)]
struct Errors {
    reflectance: f64,
    transmittance: f64,
    direct_transmittance: f64,
    radiance: Orders,
}

#[derive(Serialize)]
struct Report {
    method: &'static str,
    optical_depth: f64,
    thickness_m: Option<f64>,
    single_scattering_albedo: f64,
    scattering_angle_deg: f64,
    reflectance: f64,
    transmittance: f64,
    direct_transmittance: f64,
    radiance: Orders,
    std_error: Option<Errors>,
    photons: Option<u64>,
    scattering_events: Option<u64>,
}

fn orders_value(o: &ByOrder) -> Orders {
    Orders {
        order0: o.order0.value,
        order1: o.order1.value,
        order2: o.order2.value,
        order3plus: o.order3plus.value,
        total: o.total.value,
    }
}

fn orders_error(o: &ByOrder) -> Orders {
    Orders {
        order0: o.order0.std_error,
        order1: o.order1.std_error,
        order2: o.order2.std_error,
        order3plus: o.order3plus.std_error,
        total: o.total.std_error,
    }
}

/// Runs the command.
pub fn run(command: &SlabCommand) -> anyhow::Result<()> {
    match &command.action {
        Some(SlabAction::Fit(args)) => fit::run(args),
        Some(SlabAction::Plot(args)) => plot::run(args),
        None => run_point(&command.point),
    }
}

/// Checks a sun zenith angle flag: [0, 89]°.
fn check_sun_zenith(deg: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        deg.is_finite() && (0.0..=89.0).contains(&deg),
        "--sun-zenith-deg {deg}: must be in [0, 89]"
    );
    Ok(())
}

/// Checks a photon-count flag.
fn check_photons(photons: u64) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=10_000_000_000).contains(&photons),
        "--photons {photons}: must be in [1, 10000000000]"
    );
    Ok(())
}

/// Checks a thickness flag, m.
fn check_thickness(flag: &str, h: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        h.is_finite() && h > 0.0 && h <= 100_000.0,
        "{flag} {h}: must be in (0, 100000]"
    );
    Ok(())
}

fn run_point(args: &SlabArgs) -> anyhow::Result<()> {
    // Both are required by the parser unless a subcommand is given.
    let missing = |flag: &str| anyhow::anyhow!("{flag} is required");
    let sun_zenith_deg = args
        .sun_zenith_deg
        .ok_or_else(|| missing("--sun-zenith-deg"))?;
    let view_zenith_deg = args
        .view_zenith_deg
        .ok_or_else(|| missing("--view-zenith-deg"))?;
    check_sun_zenith(sun_zenith_deg)?;
    anyhow::ensure!(
        view_zenith_deg.is_finite()
            && (0.0..=180.0).contains(&view_zenith_deg)
            && (view_zenith_deg - 90.0).abs() >= 0.1,
        "--view-zenith-deg {}: must be in [0, 89.9] (reflection) or [90.1, 180] (transmission)",
        view_zenith_deg
    );
    anyhow::ensure!(
        args.relative_azimuth_deg.is_finite() && args.relative_azimuth_deg.abs() <= 360.0,
        "--relative-azimuth-deg {}: must be in [−360, 360]",
        args.relative_azimuth_deg
    );
    args.droplets.check()?;
    check_photons(args.photons)?;
    if let Some(h) = args.thickness_m {
        check_thickness("--thickness-m", h)?;
    }
    if let Some(t) = args.optical_depth {
        anyhow::ensure!(
            t.is_finite() && t > 0.0 && t <= 10_000.0,
            "--optical-depth {t}: must be in (0, 10000]"
        );
    }
    let choice = args.phase;
    // The droplet population's optics at the wavelength (needed for the Mie
    // phase function and for converting a thickness into an optical depth).
    let needs_mie = matches!(choice, PhaseChoice::Mie) || args.thickness_m.is_some();
    let mie = needs_mie.then(|| args.droplets.mie());
    let (phase_table, extinction_per_m, albedo) = match (&choice, &mie) {
        (PhaseChoice::Mie, Some(o)) => (o.phase.clone(), o.extinction_per_m, o.albedo),
        (PhaseChoice::HenyeyGreenstein(g), _) => (
            PhaseModel::HenyeyGreenstein { g: *g }.to_table(3601),
            mie.as_ref().map_or(1.0, |o| o.extinction_per_m),
            1.0,
        ),
        _ => (
            PhaseModel::Isotropic.to_table(181),
            mie.as_ref().map_or(1.0, |o| o.extinction_per_m),
            1.0,
        ),
    };
    let optical_depth = args
        .optical_depth
        .unwrap_or_else(|| extinction_per_m * args.thickness_m.unwrap_or(0.0));
    let thickness_m = optical_depth / extinction_per_m;
    let view = ViewDirection {
        zenith_deg: view_zenith_deg,
        relative_azimuth_deg: args.relative_azimuth_deg,
    };
    let scattering_angle_deg =
        nimbus_physics::transport::monte_carlo::scattering_cosine(sun_zenith_deg, view)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
    let is_mie = matches!(choice, PhaseChoice::Mie);
    let report = match args.method {
        Method::Analytic => {
            let theta_f = if is_mie {
                args.droplets.forward_peak_deg
            } else {
                0.0
            };
            let model = StratusModel::new(StratusOptics::from_phase(
                &phase_table,
                extinction_per_m,
                theta_f,
            ));
            let radiance = model.radiance(thickness_m, sun_zenith_deg, view);
            let fluxes = model.fluxes(thickness_m, sun_zenith_deg);
            Report {
                method: "analytic",
                optical_depth,
                thickness_m: Some(thickness_m),
                single_scattering_albedo: albedo,
                scattering_angle_deg,
                reflectance: fluxes.reflectance,
                transmittance: fluxes.transmittance,
                direct_transmittance: fluxes.t0,
                radiance: Orders {
                    order0: radiance.order0,
                    order1: radiance.order1,
                    order2: radiance.order2,
                    order3plus: radiance.order3plus,
                    total: radiance.total,
                },
                std_error: None,
                photons: None,
                scattering_events: None,
            }
        }
        Method::MonteCarlo => {
            let modified = is_mie && args.mie_mode == MieMode::Modified;
            let medium = match (&choice, &mie) {
                (PhaseChoice::Mie, Some(o)) => o
                    .traced(modified.then_some(args.droplets.forward_peak_deg))
                    .slab(thickness_m),
                (PhaseChoice::HenyeyGreenstein(g), _) => SlabMedium {
                    optical_depth,
                    single_scattering_albedo: albedo,
                    phase: PhaseModel::HenyeyGreenstein { g: *g },
                },
                _ => SlabMedium {
                    optical_depth,
                    single_scattering_albedo: albedo,
                    phase: PhaseModel::Isotropic,
                },
            };
            let depth = medium.optical_depth;
            let settings = TraceSettings {
                photons: args.photons,
                seed: args.seed,
                sun_zenith_deg,
                views: vec![view],
                ..TraceSettings::default()
            };
            let start = std::time::Instant::now();
            let progress = Progress::new(
                "slab: photons",
                args.photons.div_ceil(BATCH_PHOTONS) * BATCH_PHOTONS,
            );
            let result = trace(&medium, &settings, &|done| progress.update(done));
            progress.finish();
            let seconds = start.elapsed().as_secs_f64();
            if args.timing {
                let threads = nimbus_physics::transport::monte_carlo::worker_threads();
                eprintln!(
                    "nimbus: timing: {:.3} s, {} scattering events, {:.2e} events/s on {threads} threads ({:.2e} per thread)",
                    seconds,
                    result.scattering_events,
                    result.scattering_events as f64 / seconds,
                    result.scattering_events as f64 / seconds / threads as f64
                );
            }
            let radiance = &result.radiance[0];
            Report {
                method: "monte-carlo",
                optical_depth: depth,
                thickness_m: args.thickness_m,
                single_scattering_albedo: albedo,
                scattering_angle_deg,
                reflectance: result.reflectance.total.value,
                transmittance: result.transmittance.total.value,
                direct_transmittance: result.transmittance.order0.value,
                radiance: orders_value(radiance),
                std_error: Some(Errors {
                    reflectance: result.reflectance.total.std_error,
                    transmittance: result.transmittance.total.std_error,
                    direct_transmittance: result.transmittance.order0.std_error,
                    radiance: orders_error(radiance),
                }),
                photons: Some(result.photons),
                scattering_events: Some(result.scattering_events),
            }
        }
    };
    if args.json {
        outln!("{}", serde_json::to_string(&report)?);
    } else {
        outln!(
            "{} slab, optical depth {:.4}, scattering angle {:.2}°",
            report.method,
            report.optical_depth,
            report.scattering_angle_deg
        );
        outln!(
            "reflectance {:.6}  transmittance {:.6}  direct {:.6}",
            report.reflectance,
            report.transmittance,
            report.direct_transmittance
        );
        let r = &report.radiance;
        outln!(
            "radiance (1/sr per unit incident flux): order 0 {:.6e}  1 {:.6e}  2 {:.6e}  3+ {:.6e}  total {:.6e}",
            r.order0,
            r.order1,
            r.order2,
            r.order3plus,
            r.total
        );
        if let Some(e) = &report.std_error {
            outln!(
                "standard errors: reflectance {:.2e}  transmittance {:.2e}  radiance total {:.2e}",
                e.reflectance,
                e.transmittance,
                e.radiance.total
            );
        }
    }
    Ok(())
}
