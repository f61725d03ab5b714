//! `nimbus completions SHELL`: the shell's completion script for nimbus,
//! generated from the command-line definition by `clap_complete`.

use clap::Args;
use clap_complete::Shell;

/// Arguments of `nimbus completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell to complete nimbus's subcommands and flags in.
    #[arg(value_enum)]
    shell: Shell,
}

/// Writes the completion script for `command` (the whole `nimbus`
/// definition) to standard output.
pub fn run(args: &CompletionsArgs, mut command: clap::Command) -> anyhow::Result<()> {
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut command, "nimbus", &mut script);
    let written = std::io::Write::write_all(&mut std::io::stdout().lock(), &script);
    if let Err(error) = written {
        crate::stdout::write_failed(error);
    }
    Ok(())
}
