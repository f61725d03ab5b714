//! Look-up-table parametrisations shared by the CPU reference and the GPU
//! passes: each maps a texel's unit coordinates to the physical quantities it
//! stores, and back.
//!
//! - Transmittance (r, μ): Bruneton 2017, `GetTransmittanceTextureUvFromRMu`;
//!   covers the rays that do not meet the ground.
//! - Multiple scattering (r, μ_s): linear in μ_s and altitude (Hillaire 2020, §5.5).
//! - Sky view (view zenith, azimuth from the sun) for one observer altitude:
//!   Hillaire 2020, §5.3, with the latitude mapping squared towards the
//!   horizon and the longitude squared towards the sun.
//! - Aerial perspective: depth slices quadratic in distance up to
//!   [`AERIAL_PERSPECTIVE_MAX_DISTANCE_M`].
//!
//! Unit coordinates x ∈ [0, 1] map to texture coordinates with half-texel
//! margins (`sub_uv_from_unit`), so that x = 0 and x = 1 fall on texel centres.

use super::AtmosphereParams;

/// Transmittance LUT size (μ, r).
pub const TRANSMITTANCE_LUT_SIZE: [u32; 2] = [256, 64];
/// Multiple-scattering LUT size (μ_s, altitude).
pub const MULTIPLE_SCATTERING_LUT_SIZE: [u32; 2] = [64, 32];
/// Sky-view LUT size (azimuth, zenith).
pub const SKY_VIEW_LUT_SIZE: [u32; 2] = [192, 108];
/// Aerial-perspective volume size (x, y, depth slices).
pub const AERIAL_PERSPECTIVE_SIZE: [u32; 3] = [32, 32, 32];
/// Distance covered by the aerial-perspective volume, m.
pub const AERIAL_PERSPECTIVE_MAX_DISTANCE_M: f64 = 128_000.0;

/// Unit coordinate of a texture coordinate with half-texel margins.
pub fn unit_from_sub_uv(u: f64, size: u32) -> f64 {
    (u - 0.5 / size as f64) / (1.0 - 1.0 / size as f64)
}

/// Texture coordinate of a unit coordinate with half-texel margins.
pub fn sub_uv_from_unit(x: f64, size: u32) -> f64 {
    0.5 / size as f64 + x * (1.0 - 1.0 / size as f64)
}

/// Unit coordinate of texel `index` of `size` (its centre).
pub fn unit_of_texel(index: u32, size: u32) -> f64 {
    unit_from_sub_uv((index as f64 + 0.5) / size as f64, size)
}

impl AtmosphereParams {
    fn horizon_length(&self) -> f64 {
        (self.top_radius_m * self.top_radius_m - self.bottom_radius_m * self.bottom_radius_m).sqrt()
    }

    /// Unit coordinates (x_μ, x_r) of the transmittance LUT for (r, μ).
    pub fn transmittance_unit_from_r_mu(&self, r: f64, mu: f64) -> (f64, f64) {
        let h = self.horizon_length();
        let rho = (r * r - self.bottom_radius_m * self.bottom_radius_m)
            .max(0.0)
            .sqrt();
        let d = self.distance_to_top(r, mu);
        let d_min = self.top_radius_m - r;
        let d_max = rho + h;
        ((d - d_min) / (d_max - d_min), rho / h)
    }

    /// (r, μ) of the transmittance LUT's unit coordinates.
    pub fn transmittance_r_mu_from_unit(&self, x_mu: f64, x_r: f64) -> (f64, f64) {
        let h = self.horizon_length();
        let rho = h * x_r;
        let r = (rho * rho + self.bottom_radius_m * self.bottom_radius_m).sqrt();
        let d_min = self.top_radius_m - r;
        let d_max = rho + h;
        let d = d_min + x_mu * (d_max - d_min);
        let mu = if d == 0.0 {
            1.0
        } else {
            ((h * h - rho * rho - d * d) / (2.0 * r * d)).clamp(-1.0, 1.0)
        };
        (r, mu)
    }

    /// (r, μ_s) of the multiple-scattering LUT's unit coordinates.
    pub fn multiple_scattering_r_mu_s_from_unit(&self, x_mu_s: f64, x_h: f64) -> (f64, f64) {
        (
            self.bottom_radius_m + x_h * (self.top_radius_m - self.bottom_radius_m),
            2.0 * x_mu_s - 1.0,
        )
    }

    /// Unit coordinates of the multiple-scattering LUT for (r, μ_s).
    pub fn multiple_scattering_unit_from_r_mu_s(&self, r: f64, mu_s: f64) -> (f64, f64) {
        (
            (0.5 * mu_s + 0.5).clamp(0.0, 1.0),
            ((r - self.bottom_radius_m) / (self.top_radius_m - self.bottom_radius_m))
                .clamp(0.0, 1.0),
        )
    }

    /// Zenith angle of the horizon seen from radius r, rad (π/2 on the ground, more above it).
    pub fn horizon_zenith_angle(&self, r: f64) -> f64 {
        let cos_beta = ((r * r - self.bottom_radius_m * self.bottom_radius_m).max(0.0)).sqrt() / r;
        std::f64::consts::PI - cos_beta.clamp(-1.0, 1.0).acos()
    }

    /// (view zenith angle in rad, cosine of the azimuth from the sun) of the
    /// sky-view LUT's unit coordinates, for an observer at radius r.
    pub fn sky_view_angles_from_unit(&self, r: f64, x_azimuth: f64, x_zenith: f64) -> (f64, f64) {
        let horizon = self.horizon_zenith_angle(r);
        let beta = std::f64::consts::PI - horizon;
        let zenith = if x_zenith < 0.5 {
            let c = 1.0 - 2.0 * x_zenith;
            horizon * (1.0 - c * c)
        } else {
            let c = 2.0 * x_zenith - 1.0;
            horizon + beta * c * c
        };
        (zenith, 1.0 - 2.0 * x_azimuth * x_azimuth)
    }

    /// Unit coordinates of the sky-view LUT for a view zenith angle (rad) and
    /// the cosine of the view's azimuth from the sun.
    pub fn sky_view_unit_from_angles(&self, r: f64, zenith: f64, cos_azimuth: f64) -> (f64, f64) {
        let horizon = self.horizon_zenith_angle(r);
        let beta = std::f64::consts::PI - horizon;
        let x_zenith = if zenith < horizon {
            0.5 * (1.0 - (1.0 - zenith / horizon).max(0.0).sqrt())
        } else {
            0.5 * (1.0 + ((zenith - horizon) / beta).clamp(0.0, 1.0).sqrt())
        };
        (
            ((1.0 - cos_azimuth.clamp(-1.0, 1.0)) * 0.5).sqrt(),
            x_zenith,
        )
    }
}

/// Distance (m) of an aerial-perspective depth coordinate w ∈ [0, 1].
pub fn aerial_perspective_distance_m(w: f64) -> f64 {
    AERIAL_PERSPECTIVE_MAX_DISTANCE_M * w * w
}

/// Depth coordinate w ∈ [0, 1] of a distance (m) in the aerial-perspective volume.
pub fn aerial_perspective_depth_from_distance(distance_m: f64) -> f64 {
    (distance_m / AERIAL_PERSPECTIVE_MAX_DISTANCE_M)
        .clamp(0.0, 1.0)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transmittance_mapping_round_trips_and_spans_zenith_to_horizon() {
        let p = AtmosphereParams::default();
        for &x_r in &[0.0, 0.1, 0.5, 1.0] {
            for &x_mu in &[0.0, 0.3, 0.7, 1.0] {
                let (r, mu) = p.transmittance_r_mu_from_unit(x_mu, x_r);
                let (a, b) = p.transmittance_unit_from_r_mu(r, mu);
                assert!(
                    (a - x_mu).abs() < 1e-6 && (b - x_r).abs() < 1e-9,
                    "({x_mu}, {x_r}) → ({a}, {b})"
                );
            }
        }
        let (r, mu) = p.transmittance_r_mu_from_unit(0.0, 0.0);
        assert!((r - p.bottom_radius_m).abs() < 1e-6 && (mu - 1.0).abs() < 1e-9);
        let (r, mu) = p.transmittance_r_mu_from_unit(1.0, 0.0);
        assert!(
            (r - p.bottom_radius_m).abs() < 1e-6 && mu.abs() < 1e-9,
            "ground horizon μ = {mu}"
        );
    }

    #[test]
    fn sky_view_mapping_round_trips_and_puts_the_horizon_in_the_middle() {
        let p = AtmosphereParams::default();
        for r in [p.bottom_radius_m + 1.0, p.bottom_radius_m + 10_000.0] {
            let horizon = p.horizon_zenith_angle(r);
            let (zenith, _) = p.sky_view_angles_from_unit(r, 0.0, 0.5);
            assert!((zenith - horizon).abs() < 1e-12);
            for &x in &[0.0, 0.2, 0.45, 0.55, 0.8, 1.0] {
                for &y in &[0.0, 0.3, 0.5, 1.0] {
                    let (zenith, cos_az) = p.sky_view_angles_from_unit(r, x, y);
                    let (a, b) = p.sky_view_unit_from_angles(r, zenith, cos_az);
                    assert!(
                        (a - x).abs() < 1e-9 && (b - y).abs() < 1e-9,
                        "({x}, {y}) → ({a}, {b})"
                    );
                }
            }
        }
    }

    #[test]
    fn sub_uv_mapping_round_trips_and_hits_texel_centres() {
        assert!((sub_uv_from_unit(0.0, 32) - 0.5 / 32.0).abs() < 1e-15);
        assert!((sub_uv_from_unit(1.0, 32) - 31.5 / 32.0).abs() < 1e-15);
        assert_eq!(unit_of_texel(0, 32), 0.0);
        assert!((unit_of_texel(31, 32) - 1.0).abs() < 1e-12);
        assert!((unit_from_sub_uv(sub_uv_from_unit(0.37, 64), 64) - 0.37).abs() < 1e-12);
        assert!(
            (aerial_perspective_depth_from_distance(aerial_perspective_distance_m(0.4)) - 0.4)
                .abs()
                < 1e-12
        );
    }
}
