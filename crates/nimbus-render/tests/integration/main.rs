//! nimbus-render's integration tests, one module per subject, in one test
//! binary: each binary of its own linked the whole renderer (wgpu, naga)
//! again, which was a large share of CI's build time. Two tests keep a
//! process of their own: the memory test (`tests/memory.rs`) reads the
//! resident size, which other tests' allocations would move, and the
//! precompute test (`tests/precompute.rs`) points the process's on-disk
//! cache at an empty directory.
//!
//! Run one subject with its module path, e.g.
//! `cargo test -p nimbus-render --test integration gpu::`.

mod common;
mod support;

mod atmosphere;
mod cumulus;
mod embedding;
mod export;
mod exposure;
mod faults;
mod flight;
mod gpu;
mod layering;
mod objects;
mod packaging;
mod radiosity;
mod rain;
mod scene_schema;
mod settings;
mod shaders;
mod stratus;
mod terrain_shadow;
