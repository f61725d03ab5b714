//! The `nimbus` command-line tool: a thin layer of argument parsing and
//! output over `nimbus-render` and `nimbus-physics`. Errors are reported
//! once, here, as one line on standard error.

#[macro_use]
mod stdout;

mod commands;
mod output;
mod plot;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// nimbus: real-time cloudy and rainy skies, from physics and phenomenology.
#[derive(Debug, Parser)]
#[command(name = "nimbus", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Render a scene to a PNG (tone-mapped sRGB) or EXR (linear radiance and layers) image.
    Render(commands::render::RenderArgs),
    /// Render a scene's keyframed weather as a PNG sequence or an .mp4 video.
    Animate(commands::animate::AnimateArgs),
    /// Open a window on a scene: fly and orbit cameras, a panel of every
    /// parameter, hot reload of the scene file and the shaders.
    View(commands::view::ViewArgs),
    /// Render frames repeatedly and report per-pass GPU times.
    Bench(commands::bench::BenchArgs),
    /// Print or check scene files.
    Scene(commands::scene::SceneArgs),
    /// The sun's position for a date, time and place (NREL SPA).
    Sun(commands::sun::SunArgs),
    /// Cloud droplet optics: Mie scattering and droplet size distributions.
    Optics(commands::optics::OpticsArgs),
    /// Light through a homogeneous cloud slab lit by the sun: the analytic
    /// stratiform model or Monte-Carlo photon tracing. Radiance is per unit
    /// flux incident on the slab's top (1/sr); fluxes are fractions of it.
    Slab(commands::slab::SlabCommand),
    /// Generate a cumulus: blob hierarchy by particle sampling, one closed
    /// mesh with the shader's attributes, exported as binary glTF (.glb)
    /// with the hierarchy as JSON.
    Cumulus(commands::cumulus::CumulusArgs),
    /// Rain: drop sizes and fall speeds, and the CPU rain simulation's statistics.
    Rain(commands::rain::RainArgs),
    /// Compare a real-time EXR with a path-traced reference: HDR-FLIP,
    /// luminance RMSE and PSNR, mean luminance and colour, over the cloud
    /// pixels or the whole image.
    Compare(commands::compare::CompareArgs),
    /// Export a scene as nimbus draws it to the Mitsuba 3 path tracer
    /// (scene.xml and assets), for path-traced references.
    Export(commands::export::ExportArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => {
            use clap::error::ErrorKind;
            if matches!(
                error.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                let _ = error.print();
                return if error.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                    ExitCode::from(2)
                } else {
                    ExitCode::SUCCESS
                };
            }
            // One line: clap's message without its usage block (the lines
            // before the first blank one, e.g. a missing argument's name).
            let text = error.to_string();
            let message: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
                .collect();
            let message = message.join(" ");
            eprintln!("nimbus: error: {}", message.trim_start_matches("error: "));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Render(args) => commands::render::run(&args),
        Command::Animate(args) => commands::animate::run(&args),
        Command::View(args) => commands::view::run(&args),
        Command::Bench(args) => commands::bench::run(&args),
        Command::Scene(args) => commands::scene::run(&args),
        Command::Sun(args) => commands::sun::run(&args),
        Command::Optics(args) => commands::optics::run(&args),
        Command::Slab(args) => commands::slab::run(&args),
        Command::Cumulus(args) => commands::cumulus::run(&args),
        Command::Rain(args) => commands::rain::run(&args),
        Command::Compare(args) => commands::compare::run(&args),
        Command::Export(args) => commands::export::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            let message = format!("{error:#}");
            eprintln!(
                "nimbus: error: {}",
                message.lines().collect::<Vec<_>>().join(" ")
            );
            ExitCode::FAILURE
        }
    }
}
