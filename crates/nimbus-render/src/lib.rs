//! The nimbus renderer on wgpu.
//!
//! Embed it in a wgpu program: create a [`Renderer`] on your device, call
//! [`Renderer::prepare`] with the [`Scene`] each frame, then
//! [`Renderer::encode`] to draw the sky and terrain into your colour and
//! depth targets. [`headless::HeadlessRenderer`] does the same offscreen with a
//! device of its own (the `nimbus` CLI, tests, benchmarks).
//!
//! One module per pass ([`sky`], [`terrain`], [`stratus`], [`cumulus`], [`tonemap`]): its settings,
//! GPU resources, draw function and WGSL side by side. The order of the
//! passes in a frame is in [`Renderer::encode`].

pub mod atmosphere;
pub mod binding;
pub mod cumulus;
pub mod exposure;
pub mod frame;
pub mod gpu;
pub mod headless;
pub mod objects;
pub mod occluders;
pub mod radiosity;
pub mod rain;
pub mod renderer;
pub mod scene;
pub mod shader;
pub mod sky;
pub mod stratus;
pub mod targets;
pub mod terrain;
pub mod timing;
pub mod tonemap;

pub use gpu::{AdapterPreference, GpuContext, GpuError};
pub use renderer::{
    FrameTargets, PASS_NAMES, RenderError, Renderer, RendererDescriptor, TargetLoad,
};
pub use scene::{Scene, SceneError};
