//! The science of nimbus, free of GPU code.
//!
//! Every module here is plain CPU code that can be tested alone: it computes
//! the quantities the renderer uploads (terrain heights and albedo, sky
//! radiance, sun irradiance) and serves as the CPU reference for each GPU
//! algorithm. Units are SI unless a name says otherwise; radiance is carried
//! per linear Rec.709 channel as described in [`photometry`].

pub mod atmosphere;
pub mod cloud_layer;
pub mod cumulus;
pub mod glb;
pub mod io;
pub mod noise;
pub mod optics;
pub mod photometry;
pub mod radiosity;
pub mod rain;
pub mod sh;
pub mod sky;
pub mod terrain;
pub mod transport;
