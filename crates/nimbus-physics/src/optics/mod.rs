//! Cloud droplet optics: Lorenz–Mie scattering by spheres, the refractive
//! index of water, droplet size distributions and the phase functions built
//! from them (Bouthors, Neyret & Lefebvre 2006, §3 and §4.1).

pub mod angular;
pub mod chebyshev;
pub mod dsd;
pub mod mie;
pub mod phase;
pub mod quadrature;
pub mod resonance;
pub mod sampling;
pub mod special;
pub mod spectral;
pub mod tables;
pub mod water;
