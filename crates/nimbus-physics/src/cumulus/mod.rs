//! Cumulus shape: a hierarchy of implicit blobs placed by particle sampling
//! (Bouthors & Neyret 2004; Bouthors 2004, ch. 4), meshed as one watertight
//! surface with the attributes the cumulus shader needs, and exported.
//!
//! - [`field`]: the blob field f_l and its gradient.
//! - [`sampler`]: particles spread over an implicit surface (Witkin &
//!   Heckbert 1994, with per-particle radii and energies).
//! - [`hierarchy`]: the levels, from the roots to the last generated one.
//! - [`mesh`]: the surface of the last level as one closed triangle mesh.
//! - [`gltf`]: binary glTF export (on [`crate::glb`]).
//! - [`shading`]: the phenomenological shader (Bouthors 2004, ch. 5), CPU reference.
//! - [`forward_peak`]: small-angle multiple scattering in the diffraction
//!   peak, the silver lining's light.
//! - [`cloud_field`]: placement of many clouds from a coverage.
//! - [`volume`]: the extinction the shader assumes on a grid, for a path tracer.
//! - [`transport`]: multiply scattered light precomputed per shape (the
//!   `transport` shading model).

pub mod cloud_field;
pub mod dual;
pub mod field;
pub mod forward_peak;
pub mod gltf;
pub mod grid;
pub mod hierarchy;
pub mod interior;
pub mod mesh;
pub mod sampler;
pub mod shading;
pub mod surface;
pub mod transport;
pub mod volume;
