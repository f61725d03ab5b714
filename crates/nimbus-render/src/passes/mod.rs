//! The render passes, one module each: settings, GPU resources, the encode
//! step and the WGSL side by side. A pass imports the layers below it
//! (core, shader, scene, frame) and never another pass; the frame's order
//! of passes is `renderer::Renderer::encode`.

pub mod atmosphere;
pub mod composite;
pub mod cumulus;
pub mod exposure;
pub mod objects;
pub mod rain;
pub mod sky;
pub mod stratus;
pub mod terrain;
pub mod tonemap;
