//! The layer's optical tables (Mie phase functions and the fitted 1-D model,
//! computed from the droplet distribution and cached on disk; shared with the
//! cumulus pass's forward peak, so they live in `frame::cloud_lighting`).

pub use crate::frame::cloud_lighting::{load_optics, optics_cache_dir, optics_params};

/// Mean square angle of a forward-peak table sampled uniformly over
/// 0–θ_f (per channel, interleaved RGB), rad²: ∫ P θ² dΩ / ∫ P dΩ.
pub fn forward_peak_mean_square_rad2(peak: &[f32], forward_peak_deg: f64) -> [f32; 3] {
    let texels = peak.len() / 3;
    let step = forward_peak_deg.to_radians() / (texels - 1) as f64;
    let mut out = [0.0f32; 3];
    for (c, value) in out.iter_mut().enumerate() {
        let (mut weighted, mut total) = (0.0, 0.0);
        for i in 0..texels {
            let theta = i as f64 * step;
            let w = peak[3 * i + c] as f64 * theta.sin();
            weighted += w * theta * theta;
            total += w;
        }
        *value = (weighted / total.max(1e-300)) as f32;
    }
    out
}
