//! The clear sky's lighting at an observer: the sun's irradiance after the
//! atmosphere, the sky's irradiance on an upward surface, the radiance of a
//! Lambertian ground under both, and the whole environment as order-2 real
//! spherical harmonics (Ramamoorthi & Hanrahan 2001). What a renderer that
//! embeds nimbus needs for its own lights and image-based lighting to match
//! nimbus's sky; the CPU twin of the GPU lighting pass
//! (`nimbus-render/src/passes/atmosphere/lighting.wgsl`), which integrates
//! the same 1024 Fibonacci directions from its LUTs.
//!
//! Units: irradiances W·m⁻², radiances W·sr⁻¹·m⁻², per RGB channel, for a
//! given solar irradiance at the top of the atmosphere.

use super::{AtmosphereTables, fibonacci_sphere};
use crate::sh;

/// Directions integrated over the sphere (as the GPU lighting pass).
pub const LIGHTING_DIRECTIONS: u32 = 1024;

/// The clear sky's lighting at one observer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyLighting {
    /// Unit vector towards the sun (y up).
    pub sun_direction: [f64; 3],
    /// C_sun: the sun's irradiance on a surface facing it, after the
    /// atmosphere's transmittance to the observer, W·m⁻².
    pub sun_irradiance: [f64; 3],
    /// C_sky: the sky's irradiance on an upward surface (no sun), W·m⁻².
    pub sky_irradiance_up: [f64; 3],
    /// C_ground: radiance of a Lambertian ground of the given albedo (the
    /// ground under the observer) lit by that sun and sky, W·sr⁻¹·m⁻².
    pub ground_radiance: [f64; 3],
    /// The environment's radiance (the sky above the horizon; below it
    /// C_ground through the air and the air's own light; the sun's disc
    /// excluded) as order-2 real SH coefficients
    /// ([`crate::sh`]); [`sh::irradiance`] gives the irradiance on a normal.
    pub sh: [[f64; 3]; 9],
}

impl SkyLighting {
    /// The lighting at `observer_height_m` above the ground, the sun along
    /// `sun_direction` (unit, y up) with `solar_irradiance_top` (W·m⁻² per
    /// channel) at the top of the atmosphere, over a Lambertian ground of
    /// `ground_albedo`: the ground the observer sees below the horizon (a
    /// renderer's terrain), which need not be the atmosphere's
    /// `ground_albedo`, the planet's far ground that the sky's multiple
    /// scattering sees.
    pub fn at(
        tables: &AtmosphereTables,
        observer_height_m: f64,
        sun_direction: [f64; 3],
        solar_irradiance_top: [f64; 3],
        ground_albedo: [f64; 3],
    ) -> Self {
        let p = &tables.params;
        let r = p.bottom_radius_m + observer_height_m.max(0.0);
        let sun = sun_direction;
        let mu_s = sun[1];
        let sun_horizontal = (sun[0] * sun[0] + sun[2] * sun[2]).sqrt();
        let sky = |d: [f64; 3]| {
            let zenith = d[1].clamp(-1.0, 1.0).acos();
            let horizontal = (d[0] * d[0] + d[2] * d[2]).sqrt();
            let cos_azimuth = if horizontal > 1e-9 && sun_horizontal > 1e-9 {
                (d[0] * sun[0] + d[2] * sun[2]) / (horizontal * sun_horizontal)
            } else {
                1.0
            };
            let l = tables.sky_view_luminance(r, zenith, cos_azimuth, mu_s);
            [0, 1, 2].map(|c| l[c] * solar_irradiance_top[c])
        };
        let directions: Vec<[f64; 3]> = (0..LIGHTING_DIRECTIONS)
            .map(|k| fibonacci_sphere(k, LIGHTING_DIRECTIONS))
            .collect();
        let weight = 4.0 * std::f64::consts::PI / f64::from(LIGHTING_DIRECTIONS);
        let mut sky_irradiance_up = [0.0; 3];
        for d in directions.iter().filter(|d| d[1] > 0.0) {
            let l = sky(*d);
            for c in 0..3 {
                sky_irradiance_up[c] += l[c] * d[1] * weight;
            }
        }
        let transmittance = p.transmittance_to_top(r, mu_s);
        let sun_irradiance = [0, 1, 2].map(|c| solar_irradiance_top[c] * transmittance[c]);
        let ground_radiance = [0, 1, 2].map(|c| {
            ground_albedo[c] / std::f64::consts::PI
                * (sun_irradiance[c] * mu_s.max(0.0) + sky_irradiance_up[c])
        });
        // Below the horizon the ground through the air, and the air's own
        // light (the sky-view integral ends on the ground).
        let coefficients = sh::project(&directions, |d| {
            let mut radiance = sky(d);
            if p.ray_hits_ground(r, d[1]) {
                let t = ground_transmittance(p, r, d[1]);
                for c in 0..3 {
                    radiance[c] += t[c] * ground_radiance[c];
                }
            }
            radiance
        });
        Self {
            sun_direction,
            sun_irradiance,
            sky_irradiance_up,
            ground_radiance,
            sh: coefficients,
        }
    }

    /// Irradiance from the environment (not the sun) on a surface of unit
    /// normal `n`, W·m⁻².
    pub fn environment_irradiance(&self, n: [f64; 3]) -> [f64; 3] {
        sh::irradiance(&self.sh, n)
    }
}

/// The air's transmittance from radius `r` along a ray of cosine `mu` that
/// hits the ground, to the ground (twin of WGSL `ground_transmittance` in
/// nimbus-render's lighting pass, which reads it from the transmittance LUT).
pub fn ground_transmittance(p: &super::AtmosphereParams, r: f64, mu: f64) -> [f64; 3] {
    let length = p.distance_to_bottom(r, mu);
    p.optical_depth(r, mu, length, 200).map(|tau| (-tau).exp())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::atmosphere::AtmosphereParams;

    fn lighting(sun_elevation_deg: f64) -> SkyLighting {
        let tables = AtmosphereTables::new(&AtmosphereParams::default());
        let e = sun_elevation_deg.to_radians();
        SkyLighting::at(
            &tables,
            200.0,
            [e.cos(), e.sin(), 0.0],
            [1.0; 3],
            tables.params.ground_albedo,
        )
    }

    /// The SH reproduce the directly integrated sky irradiance on an upward
    /// surface (order-2 SH carry irradiance to a few per cent: Ramamoorthi &
    /// Hanrahan 2001, ≤ 3 % for typical lighting; the horizon's step to the
    /// ground is the hardest case), and the sky is blue: more blue than red
    /// on an upward surface at a high sun.
    #[test]
    fn sh_irradiance_matches_the_integral_and_the_sky_is_blue() {
        let l = lighting(45.0);
        let up = l.environment_irradiance([0.0, 1.0, 0.0]);
        for (c, (sh, integral)) in up.iter().zip(l.sky_irradiance_up).enumerate() {
            let relative = (sh - integral).abs() / integral;
            assert!(relative < 0.08, "channel {c}: SH {sh} vs {integral}");
        }
        assert!(l.sky_irradiance_up[2] > 1.5 * l.sky_irradiance_up[0]);
    }

    /// At a low sun the direct beam crosses ~10× the air mass of a high one:
    /// its red/blue ratio rises, and the ground below is darker.
    #[test]
    fn a_low_sun_is_redder_and_dimmer() {
        let (high, low) = (lighting(60.0), lighting(5.0));
        let red_over_blue = |l: &SkyLighting| l.sun_irradiance[0] / l.sun_irradiance[2];
        assert!(red_over_blue(&low) > 1.5 * red_over_blue(&high));
        assert!(low.ground_radiance[1] < 0.3 * high.ground_radiance[1]);
        // Below the horizon no direct sun reaches the ground term.
        let night = lighting(-10.0);
        assert!(night.ground_radiance[1] < 0.05 * high.ground_radiance[1]);
    }
}
