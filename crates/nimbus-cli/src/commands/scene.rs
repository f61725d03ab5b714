//! `nimbus scene`: print the embedded default scene or the scene format's
//! JSON Schema, or check scene files.

use clap::Args;
use std::path::PathBuf;

/// Arguments of `nimbus scene`.
#[derive(Debug, Args)]
#[command(arg_required_else_help = true)]
pub struct SceneArgs {
    /// Print the embedded default scene (TOML) to standard output.
    #[arg(long)]
    print_default: bool,
    /// Print the JSON Schema (draft 7) of scene files to standard output:
    /// what `schemas/scene.schema.json` holds, for TOML editors.
    #[arg(long)]
    schema: bool,
    /// Check scene files: parse and validate each, report the first error.
    #[arg(long, value_name = "SCENE", num_args = 1..)]
    check: Vec<PathBuf>,
}

/// Runs the subcommand.
pub fn run(args: &SceneArgs) -> anyhow::Result<()> {
    if args.print_default {
        out!("{}", nimbus_render::scene::DEFAULT_SCENE_TOML);
    }
    if args.schema {
        out!("{}", nimbus_render::scene::json_schema_text());
    }
    for path in &args.check {
        super::load_scene(Some(path))?;
        eprintln!("{}: ok", path.display());
    }
    Ok(())
}
