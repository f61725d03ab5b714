//! The `nimbus` command-line tool: a thin layer of argument parsing and
//! output over `nimbus-render` and `nimbus-physics`. Errors are reported
//! once, here, as one line on standard error.

#[macro_use]
mod stdout;

mod commands;
mod output;
mod plot;
mod progress;

use clap::{CommandFactory, Parser, Subcommand};
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
    /// Render frames repeatedly and report per-pass GPU times; `bench
    /// table` makes a Markdown table of such reports.
    Bench(commands::bench::BenchCommand),
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
    /// (scene.xml and assets), for path-traced references, and/or its
    /// cumulus field and terrain as binary glTF (.glb) for Blender.
    Export(commands::export::ExportArgs),
    /// Print a shell completion script for nimbus on standard output, e.g.
    /// `nimbus completions bash > ~/.local/share/bash-completion/completions/nimbus`.
    Completions(commands::completions::CompletionsArgs),
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
            eprintln!("nimbus: error: {}", one_line(&error.to_string()));
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
        Command::Completions(args) => commands::completions::run(&args, Cli::command()),
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

/// A clap error in one line: its message (the lines before the first blank
/// one, e.g. a missing argument's name or the possible values) and its
/// tips in parentheses ("a similar argument exists: '--width'"), without
/// the usage block and the pointer to --help.
fn one_line(text: &str) -> String {
    let mut lines = text.lines().map(str::trim);
    let message: Vec<&str> = lines
        .by_ref()
        .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
        .collect();
    let tips: Vec<&str> = lines.filter(|l| l.starts_with("tip:")).collect();
    let mut line = message.join(" ").trim_start_matches("error: ").to_owned();
    if !tips.is_empty() {
        line.push_str(&format!(" ({})", tips.join("; ")));
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_error(args: &[&str]) -> String {
        match Cli::try_parse_from(args) {
            Ok(cli) => panic!("{args:?} parsed as {cli:?}"),
            Err(error) => one_line(&error.to_string()),
        }
    }

    #[test]
    fn a_misspelt_flag_keeps_clap_s_suggestion_in_one_line() {
        let line = parse_error(&["nimbus", "render", "--widht", "16"]);
        assert_eq!(
            line,
            "unexpected argument '--widht' found (tip: a similar argument exists: '--width')"
        );
    }

    #[test]
    fn a_value_outside_a_set_lists_the_allowed_values_in_one_line() {
        let line = parse_error(&["nimbus", "render", "--adapter", "quantum"]);
        assert!(
            line.starts_with("invalid value 'quantum' for '--adapter <ADAPTER>'")
                && line.contains("[possible values: auto, hardware, software]")
                && !line.contains('\n'),
            "{line}"
        );
    }

    #[test]
    fn the_command_line_definition_is_consistent() {
        Cli::command().debug_assert();
    }
}
