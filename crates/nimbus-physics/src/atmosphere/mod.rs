//! Atmospheric scattering: the CPU reference of the physically based sky.
//!
//! Reference: Hillaire, "A Scalable and Production Ready Sky and Atmosphere
//! Rendering Technique", EGSR 2020 (CGF 39(4)); the LUT parametrisations
//! follow Bruneton, "Precomputed Atmospheric Scattering: a New
//! Implementation", 2017. The GPU passes in `nimbus-render/src/atmosphere`
//! compute the same integrals with the same sample positions; the tests
//! there compare them with this module.
//!
//! Geometry: positions relative to the planet's centre in metres; r is the
//! distance to the centre, μ the cosine of a direction's zenith angle there.
//! Radiances are given per unit solar irradiance at the top of the
//! atmosphere (multiply by the sun's irradiance, W·m⁻², to get W·sr⁻¹·m⁻²).
//! Phase functions are per steradian and integrate to 1 over the sphere.

mod lighting;
mod lut;
mod params;
mod scattering;
pub mod under_layer;

pub use lighting::{
    CLOUDS_AIR_STEPS, GroundBelow, LIGHTING_DIRECTIONS, SkyLighting, sea_specular_reflectance,
    water_fresnel,
};
pub use lut::*;
pub use params::AtmosphereParams;
pub use scattering::*;

/// Representative wavelengths of the R, G and B channels, µm (Bruneton 2017).
pub const RGB_WAVELENGTHS_UM: [f64; 3] = [0.680, 0.550, 0.440];

/// Densities (relative to sea level) of the three constituents at an altitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Densities {
    /// Air molecules (Rayleigh).
    pub rayleigh: f64,
    /// Aerosols (Mie).
    pub aerosol: f64,
    /// Ozone, relative to its peak.
    pub ozone: f64,
}

impl AtmosphereParams {
    /// Relative densities at altitude `h_m` above the surface.
    pub fn densities(&self, h_m: f64) -> Densities {
        let h = h_m.max(0.0);
        Densities {
            rayleigh: (-h / self.rayleigh_scale_height_m).exp(),
            aerosol: (-h / self.aerosol_scale_height_m).exp(),
            ozone: (1.0 - (h - self.ozone_peak_altitude_m).abs() / self.ozone_half_width_m)
                .max(0.0),
        }
    }

    /// Extinction coefficient per RGB channel at altitude `h_m`, m⁻¹.
    pub fn extinction_per_m(&self, h_m: f64) -> [f64; 3] {
        let d = self.densities(h_m);
        let mie = self.aerosol_extinction_per_m();
        [0, 1, 2].map(|c| {
            self.rayleigh_scattering_per_m[c] * d.rayleigh
                + mie[c] * d.aerosol
                + self.ozone_absorption_per_m[c] * d.ozone
        })
    }

    /// Rayleigh and aerosol scattering coefficients per RGB channel at altitude `h_m`, m⁻¹.
    pub fn scattering_per_m(&self, h_m: f64) -> ([f64; 3], [f64; 3]) {
        let d = self.densities(h_m);
        let mie = self.aerosol_scattering_per_m();
        (
            self.rayleigh_scattering_per_m.map(|s| s * d.rayleigh),
            mie.map(|s| s * d.aerosol),
        )
    }

    /// Distance from radius r along μ to the top of the atmosphere, m
    /// (Bruneton 2017, `DistanceToTopAtmosphereBoundary`).
    pub fn distance_to_top(&self, r: f64, mu: f64) -> f64 {
        let discriminant = r * r * (mu * mu - 1.0) + self.top_radius_m * self.top_radius_m;
        (-r * mu + discriminant.max(0.0).sqrt()).max(0.0)
    }

    /// Distance from radius r along μ to the ground, m (only meaningful when
    /// [`Self::ray_hits_ground`]).
    pub fn distance_to_bottom(&self, r: f64, mu: f64) -> f64 {
        let discriminant = r * r * (mu * mu - 1.0) + self.bottom_radius_m * self.bottom_radius_m;
        (-r * mu - discriminant.max(0.0).sqrt()).max(0.0)
    }

    /// Whether the ray from radius r along μ meets the ground.
    pub fn ray_hits_ground(&self, r: f64, mu: f64) -> bool {
        mu < 0.0 && r * r * (mu * mu - 1.0) + self.bottom_radius_m * self.bottom_radius_m >= 0.0
    }

    /// Distance to the end of the ray inside the atmosphere: the ground if it
    /// is hit, otherwise the top.
    pub fn distance_to_boundary(&self, r: f64, mu: f64) -> f64 {
        if self.ray_hits_ground(r, mu) {
            self.distance_to_bottom(r, mu)
        } else {
            self.distance_to_top(r, mu)
        }
    }

    /// Altitude (m) reached after travelling `t` metres from radius r along μ.
    pub fn altitude_along(&self, r: f64, mu: f64, t: f64) -> f64 {
        (t * t + 2.0 * r * mu * t + r * r).max(0.0).sqrt() - self.bottom_radius_m
    }

    /// Optical depth per RGB channel of the segment of length `length` from
    /// radius r along μ (composite Simpson rule with `steps` intervals).
    pub fn optical_depth(&self, r: f64, mu: f64, length: f64, steps: usize) -> [f64; 3] {
        let n = steps.max(2) + steps % 2;
        let dt = length / n as f64;
        let mut sum = [0.0; 3];
        for i in 0..=n {
            let weight = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let e = self.extinction_per_m(self.altitude_along(r, mu, i as f64 * dt));
            for c in 0..3 {
                sum[c] += weight * e[c];
            }
        }
        sum.map(|s| s * dt / 3.0)
    }

    /// Transmittance from radius r along μ to the top of the atmosphere
    /// (zero when the ray meets the ground), to 1e-6 relative accuracy.
    pub fn transmittance_to_top(&self, r: f64, mu: f64) -> [f64; 3] {
        if self.ray_hits_ground(r, mu) {
            return [0.0; 3];
        }
        self.optical_depth(r, mu, self.distance_to_top(r, mu), 2000)
            .map(|tau| (-tau).exp())
    }
}

/// Rayleigh phase function, sr⁻¹: 3 (1 + cos²θ) / (16π).
pub fn rayleigh_phase(cos_theta: f64) -> f64 {
    3.0 * (1.0 + cos_theta * cos_theta) / (16.0 * std::f64::consts::PI)
}

/// Cornette–Shanks aerosol phase function, sr⁻¹ (Cornette & Shanks, Applied
/// Optics 31, 1992, eq. 8; the form Hillaire 2020 uses):
/// 3 (1 − g²)(1 + cos²θ) / (8π (2 + g²)(1 + g² − 2g cos θ)^{3/2}).
pub fn cornette_shanks_phase(cos_theta: f64, g: f64) -> f64 {
    let g2 = g * g;
    3.0 * (1.0 - g2) * (1.0 + cos_theta * cos_theta)
        / (8.0 * std::f64::consts::PI * (2.0 + g2) * (1.0 + g2 - 2.0 * g * cos_theta).powf(1.5))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn integrate_phase(phase: impl Fn(f64) -> f64) -> f64 {
        // ∫ p dΩ = 2π ∫₋₁¹ p(μ) dμ, midpoint rule.
        let n = 200_000;
        (0..n)
            .map(|i| phase(-1.0 + (i as f64 + 0.5) * 2.0 / n as f64))
            .sum::<f64>()
            * 2.0
            / n as f64
            * std::f64::consts::TAU
    }

    #[test]
    fn phase_functions_are_normalised_per_steradian() {
        assert!((integrate_phase(rayleigh_phase) - 1.0).abs() < 1e-6);
        for g in [0.0, 0.5, 0.8] {
            assert!(
                (integrate_phase(|c| cornette_shanks_phase(c, g)) - 1.0).abs() < 1e-3,
                "g = {g}"
            );
        }
    }

    #[test]
    fn vertical_optical_depths_match_the_analytic_exponential_profiles() {
        // For an exponential profile the vertical optical depth is β₀ H (1 − e^{−Z/H}).
        let mut p = AtmosphereParams {
            ozone_absorption_per_m: [0.0; 3],
            ..AtmosphereParams::default()
        };
        let r = p.bottom_radius_m;
        let tau = p.optical_depth(r, 1.0, p.top_radius_m - r, 4000);
        let depth = p.top_radius_m - r;
        for (c, tau_c) in tau.iter().enumerate() {
            let rayleigh =
                p.rayleigh_scattering_per_m[c] * 8000.0 * (1.0 - (-depth / 8000.0f64).exp());
            let mie = p.aerosol_extinction_per_m()[c] * 1200.0 * (1.0 - (-depth / 1200.0f64).exp());
            assert!((tau_c - rayleigh - mie).abs() < 1e-6 * tau_c, "channel {c}");
        }
        // The aerosol optical depth at 550 nm is the parameter itself.
        p.rayleigh_scattering_per_m = [0.0; 3];
        let tau = p.optical_depth(r, 1.0, depth, 4000);
        assert!((tau[1] - p.aerosol_optical_depth).abs() < 1e-6);
        // Ozone: the tent profile's area is peak × width.
        let ozone_only = AtmosphereParams {
            rayleigh_scattering_per_m: [0.0; 3],
            aerosol_optical_depth: 0.0,
            ..AtmosphereParams::default()
        };
        let tau = ozone_only.optical_depth(r, 1.0, depth, 4000);
        assert!((tau[1] - 1.881e-6 * 15_000.0).abs() < 1e-4 * tau[1]);
    }

    #[test]
    fn rayleigh_optical_depth_of_the_default_air_is_close_to_bucholtz() {
        // Bucholtz (Applied Optics 34, 1995, table 5): τ_R(550 nm) = 0.0973,
        // τ_R(440 nm) = 0.2372. Hillaire's coefficients give 0.108 and 0.265:
        // within 12 %.
        let p = AtmosphereParams::default();
        for (c, reference) in [(1, 0.0973), (2, 0.2372)] {
            let tau = p.rayleigh_scattering_per_m[c] * p.rayleigh_scale_height_m;
            assert!((tau / reference - 1.0).abs() < 0.12, "channel {c}: {tau}");
        }
    }

    #[test]
    fn geometry_of_rays() {
        let p = AtmosphereParams::default();
        let r = p.bottom_radius_m + 1000.0;
        assert!((p.distance_to_top(r, 1.0) - (p.top_radius_m - r)).abs() < 1e-6);
        assert!(p.ray_hits_ground(r, -1.0));
        assert!((p.distance_to_bottom(r, -1.0) - 1000.0).abs() < 1e-6);
        assert!(!p.ray_hits_ground(r, 0.0));
        let mu_horizon = -(1.0 - (p.bottom_radius_m / r).powi(2)).sqrt();
        assert!(
            !p.ray_hits_ground(r, mu_horizon + 1e-9) && p.ray_hits_ground(r, mu_horizon - 1e-6)
        );
        assert_eq!(p.transmittance_to_top(r, -0.5), [0.0; 3]);
    }
}
