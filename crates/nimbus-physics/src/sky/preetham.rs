//! Preetham's analytic clear-sky model.
//!
//! Reference: Preetham, Shirley & Smits, "A Practical Analytic Model for
//! Daylight", SIGGRAPH 1999. Sky luminance and chromaticity follow the Perez
//! all-weather distribution (eq. 3 of the paper):
//!
//! F(θ, γ) = (1 + A e^{B / cos θ}) (1 + C e^{D γ} + E cos² γ),
//! Y(θ, γ) = Y_z F(θ, γ) / F(0, θ_s), and likewise for x and y,
//!
//! with θ the view zenith angle, γ the angle between the view and the sun,
//! θ_s the sun zenith angle (all rad); the coefficients A…E are linear in the
//! turbidity T (appendix A.2), the zenith luminance Y_z (kcd/m²) and zenith
//! chromaticities x_z, y_z are given in appendix A.2 as well.
//!
//! The model is fitted for the sun above the horizon; below it nimbus holds
//! the sun at the horizon and fades the sky over 8° of civil twilight (an
//! approximation until the physically based atmosphere lands).

use crate::photometry::{MAX_LUMINOUS_EFFICACY_LM_PER_W, rec709_from_xyz, xyz_from_xy_y};

/// Perez coefficients A…E of one quantity (Y, x or y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerezCoefficients(pub [f64; 5]);

impl PerezCoefficients {
    /// The Perez function F(θ, γ) for cos θ and γ (rad).
    pub fn perez(&self, cos_theta: f64, gamma_rad: f64) -> f64 {
        let [a, b, c, d, e] = self.0;
        // At and below the horizon the sky repeats its horizon value; the
        // guard keeps B / cos θ finite (B < 0, so the term tends to zero).
        let cos_theta = cos_theta.max(1e-4);
        let cos_gamma = gamma_rad.cos();
        (1.0 + a * (b / cos_theta).exp())
            * (1.0 + c * (d * gamma_rad).exp() + e * cos_gamma * cos_gamma)
    }
}

/// The Preetham sky for one sun position and turbidity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreethamSky {
    /// Unit vector towards the sun.
    pub sun_direction: [f64; 3],
    /// Atmospheric turbidity T (2 = very clear, 10 = hazy).
    pub turbidity: f64,
    /// Perez coefficients for luminance Y and chromaticities x, y.
    pub coefficients: [PerezCoefficients; 3],
    /// Y_z / F(0, θ_s) (cd/m²), x_z / F(0, θ_s), y_z / F(0, θ_s): the
    /// per-quantity factors that multiply F(θ, γ).
    pub zenith_over_perez: [f64; 3],
    /// Twilight fade factor in [0, 1] applied to the whole sky.
    pub twilight_fade: f64,
}

impl PreethamSky {
    /// Builds the sky for a sun direction (unit vector, world frame) and turbidity in [1.7, 10].
    pub fn new(sun_direction: [f64; 3], turbidity: f64) -> Self {
        let t = turbidity;
        let sun_elevation = sun_direction[1].clamp(-1.0, 1.0).asin();
        // Hold the sun just above the horizon for the fit; fade the sky through twilight.
        let theta_s =
            (std::f64::consts::FRAC_PI_2 - sun_elevation).min(std::f64::consts::FRAC_PI_2 - 1e-3);
        let twilight_fade = ((sun_elevation.to_degrees() + 8.0) / 8.0)
            .clamp(0.0, 1.0)
            .powi(2);

        let coeff_y = PerezCoefficients([
            0.1787 * t - 1.4630,
            -0.3554 * t + 0.4275,
            -0.0227 * t + 5.3251,
            0.1206 * t - 2.5771,
            -0.0670 * t + 0.3703,
        ]);
        let coeff_x = PerezCoefficients([
            -0.0193 * t - 0.2592,
            -0.0665 * t + 0.0008,
            -0.0004 * t + 0.2125,
            -0.0641 * t - 0.8989,
            -0.0033 * t + 0.0452,
        ]);
        let coeff_yc = PerezCoefficients([
            -0.0167 * t - 0.2608,
            -0.0950 * t + 0.0092,
            -0.0079 * t + 0.2102,
            -0.0441 * t - 1.6537,
            -0.0109 * t + 0.0529,
        ]);

        // Zenith luminance (kcd/m²) and chromaticity, appendix A.2.
        let chi = (4.0 / 9.0 - t / 120.0) * (std::f64::consts::PI - 2.0 * theta_s);
        let zenith_luminance_cd_m2 =
            1000.0 * ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192);
        let th = [theta_s.powi(3), theta_s.powi(2), theta_s, 1.0];
        let dot = |v: [f64; 4]| v.iter().zip(th).map(|(a, b)| a * b).sum::<f64>();
        let zenith_x = t * t * dot([0.00166, -0.00375, 0.00209, 0.0])
            + t * dot([-0.02903, 0.06377, -0.03202, 0.00394])
            + dot([0.11693, -0.21196, 0.06052, 0.25886]);
        let zenith_y = t * t * dot([0.00275, -0.00610, 0.00317, 0.0])
            + t * dot([-0.04214, 0.08970, -0.04153, 0.00516])
            + dot([0.15346, -0.26756, 0.06670, 0.26688]);

        let coefficients = [coeff_y, coeff_x, coeff_yc];
        let zenith = [zenith_luminance_cd_m2.max(0.0), zenith_x, zenith_y];
        let mut zenith_over_perez = [0.0; 3];
        for k in 0..3 {
            zenith_over_perez[k] = zenith[k] / coefficients[k].perez(1.0, theta_s);
        }
        Self {
            sun_direction,
            turbidity,
            coefficients,
            zenith_over_perez,
            twilight_fade,
        }
    }

    /// Sky luminance (cd/m²) and chromaticity (x, y) seen in a unit direction.
    pub fn luminance_xy(&self, direction: [f64; 3]) -> (f64, f64, f64) {
        let cos_theta = direction[1];
        let cos_gamma = (direction[0] * self.sun_direction[0]
            + direction[1] * self.sun_direction[1]
            + direction[2] * self.sun_direction[2])
            .clamp(-1.0, 1.0);
        let gamma = cos_gamma.acos();
        let [fy, fx, fyc] = [0, 1, 2]
            .map(|k| self.zenith_over_perez[k] * self.coefficients[k].perez(cos_theta, gamma));
        (fy * self.twilight_fade, fx, fyc)
    }

    /// Sky radiance per RGB channel in a unit direction, W·sr⁻¹·m⁻².
    pub fn radiance_rgb(&self, direction: [f64; 3]) -> [f64; 3] {
        let (luminance, x, y) = self.luminance_xy(direction);
        rec709_from_xyz(xyz_from_xy_y(x, y, luminance))
            .map(|c| c.max(0.0) / MAX_LUMINOUS_EFFICACY_LM_PER_W)
    }

    /// Irradiance from the sky dome (sun excluded) on an upward-facing
    /// horizontal surface, per RGB channel, W·m⁻²: the midpoint-rule integral
    /// of L cos θ dω over the upper hemisphere.
    pub fn horizontal_irradiance_rgb(&self) -> [f64; 3] {
        let (n_theta, n_phi) = (64, 128);
        let d_theta = std::f64::consts::FRAC_PI_2 / n_theta as f64;
        let d_phi = std::f64::consts::TAU / n_phi as f64;
        let mut sum = [0.0; 3];
        for i in 0..n_theta {
            let theta = (i as f64 + 0.5) * d_theta;
            let (sin_t, cos_t) = theta.sin_cos();
            for j in 0..n_phi {
                let phi = (j as f64 + 0.5) * d_phi;
                let l = self.radiance_rgb([sin_t * phi.cos(), cos_t, sin_t * phi.sin()]);
                for c in 0..3 {
                    sum[c] += l[c] * cos_t * sin_t * d_theta * d_phi;
                }
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::illuminance_lux;
    use crate::sky::sun_direction;

    #[test]
    fn zenith_radiance_equals_the_zenith_model() {
        // Y(0, θ_s) = Y_z by construction of eq. 3; check it through the full evaluation.
        let sky = PreethamSky::new(sun_direction(100.0, 35.0), 3.0);
        let (lum, _, _) = sky.luminance_xy([0.0, 1.0, 0.0]);
        let t: f64 = 3.0;
        let theta_s = 55f64.to_radians();
        let chi = (4.0 / 9.0 - t / 120.0) * (std::f64::consts::PI - 2.0 * theta_s);
        let yz = 1000.0 * ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192);
        assert!((lum - yz).abs() < 1e-6 * yz);
    }

    #[test]
    fn sky_is_brightest_around_the_sun_and_blue_overhead() {
        let sun = sun_direction(180.0, 40.0);
        let sky = PreethamSky::new(sun, 2.5);
        let near_sun = sky.radiance_rgb(sun_direction(180.0, 45.0));
        let away = sky.radiance_rgb(sun_direction(0.0, 45.0));
        assert!(near_sun[1] > 2.0 * away[1]);
        let zenith = sky.radiance_rgb([0.0, 1.0, 0.0]);
        assert!(zenith[2] > zenith[0], "zenith {zenith:?} should be blue");
    }

    #[test]
    fn diffuse_horizontal_illuminance_matches_clear_sky_measurements() {
        // CIE 110-1994 / Krochmann & Seidl (1974) clear-sky diffuse horizontal
        // illuminance: E_d = 0.8 + 15.5 (sin h)^0.5 klx, h the solar elevation.
        // Preetham's model is known to be too bright against measured skies
        // (Zotti, Wilkie & Purgathofer, "A Critical Review of the Preetham
        // Skylight Model", WSCG 2007); here it gives about 1.9× the CIE value.
        // The test pins that known bias so that it cannot silently grow; the
        // physically based atmosphere is to replace this model.
        for elevation in [20.0f64, 40.0, 60.0] {
            let sky = PreethamSky::new(sun_direction(0.0, elevation), 2.5);
            let lux = illuminance_lux(sky.horizontal_irradiance_rgb());
            let reference = 1000.0 * (0.8 + 15.5 * elevation.to_radians().sin().sqrt());
            let ratio = lux / reference;
            assert!(
                (0.9..2.2).contains(&ratio),
                "h = {elevation}°: {lux:.0} lx vs {reference:.0} lx"
            );
        }
    }

    #[test]
    fn night_sky_is_dark() {
        let sky = PreethamSky::new(sun_direction(0.0, -12.0), 2.5);
        assert_eq!(sky.radiance_rgb([0.0, 1.0, 0.0]), [0.0; 3]);
    }
}
