//! The command-line conventions of the `nimbus` binary: one-line errors
//! that keep clap's suggestions and list the allowed values, shell
//! completions, standard output holding only results (with `--json`, one
//! JSON document), and progress drawn on standard error only when it is a
//! terminal. None of these needs a GPU.

use crate::support::*;
use std::process::{Command, Output, Stdio};

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The one error line of a failed run: standard error holds exactly one
/// line, it is nimbus's error line, and standard output is empty.
fn error_line(out: &Output) -> String {
    assert!(!out.status.success(), "expected a failure: {out:?}");
    assert!(out.stdout.is_empty(), "stdout: {}", text(&out.stdout));
    let stderr = text(&out.stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "expected one line, got {lines:?}");
    assert!(lines[0].starts_with("nimbus: error: "), "{}", lines[0]);
    lines[0].to_owned()
}

/// Every flag that takes one of a set refuses another value in one line
/// that lists the allowed ones, with clap's usage status 2.
#[test]
fn a_value_outside_a_set_is_refused_with_the_allowed_values() {
    let dir = temp_dir("conventions", "value-enum");
    let cases: [(&[&str], &str, &str); 7] = [
        (
            &["render", "--adapter", "quantum"],
            "'quantum' for '--adapter <ADAPTER>'",
            "[possible values: auto, hardware, software]",
        ),
        (
            &["view", "--adapter", "gpu"],
            "'gpu' for '--adapter <ADAPTER>'",
            "[possible values: auto, hardware, software]",
        ),
        (
            &["completions", "tcsh"],
            "'tcsh' for '<SHELL>'",
            "[possible values: bash, elvish, fish, powershell, zsh]",
        ),
        (
            &[
                "slab",
                "--optical-depth",
                "1",
                "--sun-zenith-deg",
                "0",
                "--view-zenith-deg",
                "0",
                "--method",
                "exact",
            ],
            "'exact' for '--method <METHOD>'",
            "[possible values: analytic, monte-carlo]",
        ),
        (
            &[
                "slab",
                "--optical-depth",
                "1",
                "--sun-zenith-deg",
                "0",
                "--view-zenith-deg",
                "0",
                "--phase",
                "rayleigh",
            ],
            "'rayleigh' for '--phase <PHASE>'",
            "mie, isotropic or hg:G",
        ),
        (
            &["compare", "a.exr", "b.exr", "--mask", "sky"],
            "'sky' for '--mask <MASK>'",
            "[possible values: cloud, all]",
        ),
        (
            &[
                "slab",
                "plot",
                "--thickness-m",
                "100",
                "--sun-zenith-deg",
                "0",
                "--out",
                "fig.png",
                "--side",
                "top",
            ],
            "'top' for '--side <SIDE>'",
            "[possible values: reflection, transmission]",
        ),
    ];
    for (args, value, allowed) in cases {
        let out = nimbus(args, &dir);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let line = error_line(&out);
        assert!(
            line.contains(value) && line.contains(allowed),
            "{args:?}: {line}"
        );
    }
}

/// A misspelt flag's error keeps clap's suggestion, in the one line.
#[test]
fn a_misspelt_flag_keeps_the_suggestion() {
    let dir = temp_dir("conventions", "misspelt");
    let out = nimbus(&["render", "--widht", "16"], &dir);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        error_line(&out),
        "nimbus: error: unexpected argument '--widht' found \
         (tip: a similar argument exists: '--width')"
    );
    let line = error_line(&nimbus(&["rain", "stats", "--intensity-mm", "1"], &dir));
    assert!(
        line.contains("'--intensity-mm'")
            && line.contains("(tip: a similar argument exists: '--intensity-mm-h')"),
        "{line}"
    );
}

/// --help and --version go to standard output with success, as clap's do.
#[test]
fn help_and_version_go_to_standard_output() {
    let dir = temp_dir("conventions", "help");
    for args in [&["--help"][..], &["--version"], &["completions", "--help"]] {
        let out = nimbus(args, &dir);
        assert!(out.status.success(), "{args:?}: {out:?}");
        assert!(!out.stdout.is_empty(), "{args:?}");
        assert!(out.stderr.is_empty(), "{args:?}: {}", text(&out.stderr));
    }
    let help = text(&nimbus(&["--help"], &dir).stdout);
    assert!(help.contains("completions"), "{help}");
    let help = text(&nimbus(&["render", "--help"], &dir).stdout);
    assert!(help.contains("software"), "{help}");
}

/// `nimbus completions SHELL` prints the shell's script for nimbus.
#[test]
fn completions_are_printed_for_every_shell() {
    let dir = temp_dir("conventions", "completions");
    let out = nimbus(&["completions", "bash"], &dir);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(out.stderr.is_empty(), "{}", text(&out.stderr));
    let script = text(&out.stdout);
    assert!(script.contains("_nimbus()"), "{script}");
    assert!(script.contains("complete -F _nimbus"), "{script}");
    for word in ["render", "optics", "slab", "--adapter", "completions"] {
        assert!(script.contains(word), "bash completions lack {word}");
    }
    for shell in ["zsh", "fish", "elvish", "powershell"] {
        let out = nimbus(&["completions", shell], &dir);
        assert!(out.status.success(), "{shell}: {}", text(&out.stderr));
        let script = text(&out.stdout);
        assert!(
            script.contains("nimbus") && script.contains("render"),
            "{shell}: {script}"
        );
    }
    let line = error_line(&nimbus(&["completions"], &dir));
    assert!(line.contains("<SHELL>"), "{line}");
}

const FIT_ARGS: [&str; 10] = [
    "slab",
    "fit",
    "--out",
    "table.toml",
    "--photons",
    "4096",
    "--sun-zenith-deg",
    "0,60",
    "--thickness-m",
    "2,20,200,2000",
];

/// With --json, standard output holds one JSON document and nothing else;
/// without it, results only: the file written is reported on standard error.
#[test]
fn slab_fit_keeps_standard_output_for_results() {
    let dir = temp_dir("conventions", "slab-fit");
    let mut args = FIT_ARGS.to_vec();
    args.push("--json");
    let out = nimbus(&args, &dir);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    // serde_json refuses anything but whitespace after the document.
    let report: serde_json::Value = match serde_json::from_str(&stdout) {
        Ok(report) => report,
        Err(error) => panic!("stdout is not one JSON document ({error}): {stdout}"),
    };
    assert!(report["beta"].is_f64(), "{report}");
    assert!(
        text(&out.stderr).contains("nimbus: wrote table.toml"),
        "{}",
        text(&out.stderr)
    );

    let out = nimbus(&FIT_ARGS, &dir);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.starts_with("beta "), "{stdout}");
    assert!(!stdout.contains("wrote"), "status on stdout: {stdout}");
    assert!(text(&out.stderr).contains("nimbus: wrote table.toml"));
}

/// `cumulus` without --json: its report on standard output, the files it
/// wrote on standard error.
#[test]
fn cumulus_reports_on_standard_output_and_status_on_standard_error() {
    let dir = temp_dir("conventions", "cumulus");
    let out = nimbus(
        &["cumulus", "--levels", "0", "--lods", "1", "-o", "cloud.glb"],
        &dir,
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.starts_with("level 0: 6 blobs"), "{stdout}");
    assert!(stdout.contains("\nmesh: "), "{stdout}");
    assert!(!stdout.contains("wrote"), "{stdout}");
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("nimbus: wrote cloud.glb and cloud.hierarchy.json"),
        "{stderr}"
    );
}

const RAIN_ARGS: [&str; 8] = [
    "rain",
    "stats",
    "--intensity-mm-h",
    "50",
    "--seconds",
    "3",
    "--box-radius-m",
    "3",
];

/// What a progress bar leaves in a byte stream: a carriage return, an
/// escape sequence, or the bar's own text.
fn has_progress(bytes: &[u8]) -> bool {
    let s = text(bytes);
    s.contains('\r') || s.contains('\x1b') || s.contains("rain stats: steps")
}

/// A long command whose standard error is not a terminal (a pipe here)
/// draws no progress there; the same command on a terminal does.
#[test]
fn progress_is_drawn_only_on_a_terminal() {
    let dir = temp_dir("conventions", "progress");
    let out = nimbus(&RAIN_ARGS, &dir);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        !has_progress(&out.stderr),
        "progress on a pipe: {:?}",
        text(&out.stderr)
    );
    assert!(!has_progress(&out.stdout), "{:?}", text(&out.stdout));
    assert!(text(&out.stdout).starts_with("rain "));

    // The same run on a pseudo-terminal (util-linux `script`), which is
    // what makes the check above mean something.
    let command = std::iter::once(env!("CARGO_BIN_EXE_nimbus"))
        .chain(RAIN_ARGS)
        .map(|word| format!("'{word}'"))
        .collect::<Vec<_>>()
        .join(" ");
    let terminal = Command::new("script")
        .args(["--quiet", "--return", "--command", &command, "/dev/null"])
        .current_dir(&dir)
        .stdin(Stdio::null())
        .output()
        .expect("`script` (util-linux) runs a command on a pseudo-terminal: install util-linux");
    assert!(terminal.status.success(), "{terminal:?}");
    assert!(
        text(&terminal.stdout).contains("nimbus: rain stats: steps ["),
        "no progress on a terminal: {:?}",
        text(&terminal.stdout)
    );
}
