//! Pipeline-building helpers shared by the passes.

/// Premultiplied-alpha "over" blending of colour and alpha: what a pass
/// that draws a translucent medium (its in-scattered radiance and
/// 1 − transmittance) over the frame uses.
pub const PREMULTIPLIED_OVER: wgpu::BlendState = wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING;
