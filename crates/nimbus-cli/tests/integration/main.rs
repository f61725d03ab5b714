//! The `nimbus` binary's integration tests, one module per subject, in one
//! test binary (each binary of its own was built and linked again, a share
//! of CI's build time). They run the binary the package builds
//! (`CARGO_BIN_EXE_nimbus`) and share `support`.
//!
//! Run one subject with its module path, e.g.
//! `cargo test -p nimbus-sky --test integration realism::`.

mod support;

mod bench_table;
mod cli;
mod conventions;
mod export_gltf;
mod export_mitsuba;
mod plots;
mod realism;
// Runs the binary under `ulimit -v` through `sh`.
#[cfg(unix)]
mod reliability;
mod view;
