//! What the `nimbus` binary's integration tests share: running it, scratch
//! directories, and the one-line error check. Each test file uses a part.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Runs `nimbus ARGS` in `dir`, standard input closed.
pub fn nimbus(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nimbus"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("run nimbus")
}

/// Runs `nimbus ARGS` in `dir` as on a machine without a display: no
/// `XDG_RUNTIME_DIR`, `WAYLAND_DISPLAY` or `DISPLAY`.
pub fn nimbus_without_display(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nimbus"))
        .args(args)
        .current_dir(dir)
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("DISPLAY")
        .stdin(Stdio::null())
        .output()
        .expect("run nimbus")
}

/// An empty scratch directory for one test (`group` names the test file).
pub fn temp_dir(group: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nimbus-{group}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The names in `dir`, sorted.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// nimbus's own lines of standard error (wgpu's Vulkan loader may print
/// unrelated environment notices).
pub fn stderr_lines(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| l.starts_with("nimbus:"))
        .map(str::to_owned)
        .collect()
}

/// The run succeeded (else its standard error is shown).
pub fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Asserts a failure with exactly one error line containing every
/// fragment, and no panic.
pub fn assert_fails_with(out: &Output, fragments: &[&str]) {
    assert!(
        !out.status.success(),
        "expected failure, got {:?}",
        out.status
    );
    let errors: Vec<String> = stderr_lines(out)
        .into_iter()
        .filter(|l| l.starts_with("nimbus: error: "))
        .collect();
    assert_eq!(errors.len(), 1, "expected one error line, got {errors:?}");
    for fragment in fragments {
        assert!(
            errors[0].contains(fragment),
            "`{}` does not mention `{fragment}`",
            errors[0]
        );
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
}
