//! Light transport in cloud layers: phase-function models for tracing, a
//! Monte-Carlo photon tracer for plane-parallel slabs, and the analytic
//! stratiform model of Bouthors, Neyret & Lefebvre (2006, §4 and
//! appendices A–B) that the tracer validates.

pub mod adding_doubling;
pub mod diffusion;
pub mod fit;
pub mod monte_carlo;
pub mod phase_model;
pub mod reflected_exit;
pub mod rng;
pub mod stratus;
