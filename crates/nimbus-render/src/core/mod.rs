//! The lowest layer: what every pass builds on and nothing nimbus-specific
//! above it. The GPU context and its targets, timestamp timing, bind-group
//! and pipeline helpers, the device-limit checks, GPU faults as typed
//! errors, and the on-disk cache.
//! Imports nothing of the crate's other layers (see `tests/integration/layering.rs`).

pub mod background;
pub mod binding;
pub mod cache;
pub mod fault;
pub mod gpu;
pub mod limits;
pub mod mesh;
pub mod pipeline;
pub mod targets;
pub mod timing;
