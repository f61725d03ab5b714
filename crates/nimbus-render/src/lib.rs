//! The nimbus renderer on wgpu.
//!
//! Embed it in a wgpu program: create a [`Renderer`] on your device, call
//! [`Renderer::prepare`] with the [`Scene`] each frame, then
//! [`Renderer::encode`] to draw the sky, terrain, clouds and rain into your
//! colour and depth targets. [`headless::HeadlessRenderer`] does the same
//! offscreen with a device of its own (the `nimbus` CLI, tests, benchmarks).
//!
//! # Layers
//!
//! Each module imports only those above it in this list (checked by
//! `tests/integration/layering.rs`):
//!
//! 1. [`core`]: GPU context, targets, timing, binding and pipeline helpers,
//!    device limits, the cache directory.
//! 2. [`shader`]: WGSL composition (`// import` lines) and the WGSL library
//!    shared by several passes.
//! 3. [`scene`]: the scene's settings, their validation and their conversion
//!    to the physics crate's types.
//! 4. [`frame`]: the frame uniform and every resource the whole frame
//!    reads (atmosphere lookups, cloud lighting, cloud shadow map,
//!    occluders), handed to the passes as [`frame::FrameBindings`].
//! 5. [`passes`]: one module per pass ([`passes::atmosphere`],
//!    [`passes::sky`], [`passes::terrain`], [`passes::objects`],
//!    [`passes::composite`] (the caller's frame in `LinearHdr` output),
//!    [`passes::stratus`] with its radiosity, [`passes::cumulus`],
//!    [`passes::rain`], [`passes::exposure`], [`passes::tonemap`]): its
//!    settings, GPU resources, encode step and WGSL side by side. A pass
//!    never imports another.
//! 6. [`renderer`]: the frame's order of passes and the registry of every
//!    shader module.
//! 7. [`headless`]: offscreen rendering on a device of its own.
//! 8. [`export`]: the scene for other tools without a GPU (binary glTF of
//!    the cumulus field and the terrain, for Blender).
//!
//! The paths of earlier versions (`nimbus_render::stratus`, `::gpu`, ...)
//! are kept as re-exports.

pub mod core;
pub mod export;
pub mod frame;
pub mod headless;
pub mod passes;
pub mod renderer;
pub mod scene;
pub mod shader;

pub use self::core::{binding, cache, fault, gpu, targets, timing};
pub use frame::occluders;
pub use passes::stratus::radiosity;
pub use passes::{atmosphere, cumulus, exposure, objects, rain, sky, stratus, terrain, tonemap};

pub use self::core::fault::GpuFault;
pub use self::core::gpu::{AdapterPreference, GpuContext, GpuError};
pub use frame::{DepthConvention, Projection, View};
pub use renderer::{
    FrameTargets, OccluderDepth, OutputMode, PASS_NAMES, PassId, Precompute, RenderError, Renderer,
    RendererDescriptor, TargetLoad,
};
pub use scene::{Scene, SceneError};
