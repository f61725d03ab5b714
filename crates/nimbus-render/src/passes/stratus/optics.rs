//! The layer's optical tables (Mie phase functions and the fitted 1-D model, computed from the droplet distribution and cached on disk).

use super::{FORWARD_PEAK_DEG, PEAK_TEXELS, PHASE_TEXELS};
use crate::scene::StratusSettings;
use nimbus_physics::optics::dsd::SizeDistribution;
use nimbus_physics::optics::tables::{CloudOpticsParams, CloudOpticsTables};
use std::path::PathBuf;

/// Where the optical tables are cached (see [`crate::core::cache::cache_dir`]).
pub fn optics_cache_dir() -> PathBuf {
    crate::core::cache::cache_dir()
}

/// The optical-table parameters of a layer's droplets.
pub fn optics_params(settings: &StratusSettings) -> CloudOpticsParams {
    CloudOpticsParams {
        dsd: SizeDistribution::ModifiedGamma {
            number_density_per_m3: settings.droplet_concentration_cm3 * 1e6,
            gamma: 2.0,
            effective_radius_m: settings.effective_radius_um * 1e-6,
        },
        forward_peak_deg: FORWARD_PEAK_DEG,
        texels: PHASE_TEXELS,
        peak_texels: PEAK_TEXELS,
        tolerance: 1e-3,
    }
}

/// A layer's optical tables: loaded from the cache or computed (and
/// cached; a cache that cannot be written only costs the computation).
pub fn load_optics(params: &CloudOpticsParams) -> CloudOpticsTables {
    CloudOpticsTables::load_or_compute(&optics_cache_dir(), params)
        .unwrap_or_else(|_| CloudOpticsTables::compute(params))
}

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
