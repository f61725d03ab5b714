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
use crate::transport::sky_source::{self, BANDS as SKY_BANDS};

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
    /// C_sky split by the zenith angle the light arrives from, in the bands
    /// of [`crate::transport::sky_source::BAND_EDGES`] (their sum is
    /// [`Self::sky_irradiance_up`]): what the cloud layer's traced sky
    /// light is weighted by, W·m⁻².
    pub sky_irradiance_bands: [[f64; 3]; SKY_BANDS],
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
        let sky = |d: [f64; 3]| sky_radiance(tables, r, sun, solar_irradiance_top, d);
        let directions: Vec<[f64; 3]> = (0..LIGHTING_DIRECTIONS)
            .map(|k| fibonacci_sphere(k, LIGHTING_DIRECTIONS))
            .collect();
        let weight = 4.0 * std::f64::consts::PI / f64::from(LIGHTING_DIRECTIONS);
        let mut sky_irradiance_up = [0.0; 3];
        let mut sky_irradiance_bands = [[0.0; 3]; SKY_BANDS];
        for d in directions.iter().filter(|d| d[1] > 0.0) {
            let l = sky(*d);
            let band = sky_source::band_of(d[1]).unwrap_or(SKY_BANDS - 1);
            for c in 0..3 {
                sky_irradiance_up[c] += l[c] * d[1] * weight;
                sky_irradiance_bands[band][c] += l[c] * d[1] * weight;
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
            sky_irradiance_bands,
            ground_radiance,
            sh: coefficients,
        }
    }

    /// Irradiance from the environment (not the sun) on a surface of unit
    /// normal `n`, W·m⁻².
    pub fn environment_irradiance(&self, n: [f64; 3]) -> [f64; 3] {
        sh::irradiance(&self.sh, n)
    }

    /// The environment as an observer at `observer_m` (world position, y
    /// up, m) sees it, as order-2 SH (the sun's disc excluded, its glint on
    /// the sea included): what lights clouds a kilometre or more above a
    /// camera near the ground, whose lower hemisphere is not the camera's.
    /// Above the observer's horizon, the sky as the camera at
    /// `camera_height_m` sees it (the sky-view LUT's); below it the surface
    /// `below` describes, seen from the observer through the air between
    /// them (or without it, [`GroundBelow::through_air`]): within the near
    /// ground's square the Lambertian ground of [`Self::ground_radiance`],
    /// beyond it the open sea: the sky's specular reflection
    /// ([`sea_specular_reflectance`]: Fresnel and the microfacets' masking)
    /// and the water body's diffuse light, as nimbus's sea
    /// (`shader/water.wgsl`), and the sun's specular glint as a point of
    /// irradiance ρ·C_sun (the order-2 SH blur the GGX lobe away).
    /// The ground and sea lie on the planet's surface and are lit by the
    /// sun and sky at the camera ([`Self::sun_irradiance`],
    /// [`Self::sky_irradiance_up`]). The CPU twin of the GPU lighting
    /// pass's `clouds_sh`, which integrates the same 1024 directions.
    pub fn environment_at(
        &self,
        tables: &AtmosphereTables,
        camera_height_m: f64,
        observer_m: [f64; 3],
        solar_irradiance_top: [f64; 3],
        below: &GroundBelow,
    ) -> [[f64; 3]; 9] {
        let p = &tables.params;
        let camera_r = p.bottom_radius_m + camera_height_m.max(0.0);
        let observer_r = p.bottom_radius_m + observer_m[1].max(1.0);
        let sun = self.sun_direction;
        let sky = |d: [f64; 3]| sky_radiance(tables, camera_r, sun, solar_irradiance_top, d);
        let water_irradiance =
            [0, 1, 2].map(|c| self.sun_irradiance[c] * sun[1].max(0.0) + self.sky_irradiance_up[c]);
        // Where a ray from the observer meets the ground, and what leaves the
        // ground there towards it (radiance), or None past the horizon.
        let surface = |d: [f64; 3]| -> Option<(f64, [f64; 3], bool)> {
            if !p.ray_hits_ground(observer_r, d[1]) {
                return None;
            }
            let length_m = p.distance_to_bottom(observer_r, d[1]);
            let on_sea = !below.holds_near_ground(
                observer_m[0] + d[0] * length_m,
                observer_m[2] + d[2] * length_m,
            );
            if !on_sea {
                return Some((length_m, self.ground_radiance, false));
            }
            // The cosine between the reversed ray and the local vertical
            // where it meets the (spherical) surface.
            let cos_surface = ((observer_r * -d[1] - length_m) / p.bottom_radius_m).clamp(0.0, 1.0);
            let fresnel = sea_specular_reflectance(cos_surface, below.water_ggx_alpha);
            let sky_reflected = sky([d[0], -d[1], d[2]]);
            let radiance = [0, 1, 2].map(|c| {
                fresnel * sky_reflected[c]
                    + (1.0 - fresnel) * below.water_albedo[c] / std::f64::consts::PI
                        * water_irradiance[c]
            });
            Some((length_m, radiance, true))
        };
        // The air between the observer and the ground: what it scatters
        // towards the observer and its transmittance.
        let air = |d: [f64; 3], length_m: f64| -> ([f64; 3], [f64; 3]) {
            if !below.through_air {
                return ([0.0; 3], [1.0; 3]);
            }
            let (luminance, transmittance) =
                tables.scatter_along(observer_r, d, sun, length_m, CLOUDS_AIR_STEPS);
            (
                [0, 1, 2].map(|c| luminance[c] * solar_irradiance_top[c]),
                transmittance,
            )
        };
        let directions: Vec<[f64; 3]> = (0..LIGHTING_DIRECTIONS)
            .map(|k| fibonacci_sphere(k, LIGHTING_DIRECTIONS))
            .collect();
        let mut coefficients = sh::project(&directions, |d| match surface(d) {
            None => sky(d),
            Some((length_m, radiance, _)) => {
                let (scattered, transmittance) = air(d, length_m);
                [0, 1, 2].map(|c| scattered[c] + transmittance[c] * radiance[c])
            }
        });
        // The sun's glint where its mirror direction meets the sea.
        let glint = [sun[0], -sun[1], sun[2]];
        if sun[1] > 0.0
            && let Some((_, _, true)) = surface(glint)
        {
            let transmittance = if below.through_air {
                ground_transmittance(p, observer_r, glint[1])
            } else {
                [1.0; 3]
            };
            let fresnel = sea_specular_reflectance(sun[1], below.water_ggx_alpha);
            for (k, y) in sh::basis(glint).iter().enumerate() {
                for c in 0..3 {
                    coefficients[k][c] += fresnel * self.sun_irradiance[c] * transmittance[c] * y;
                }
            }
        }
        coefficients
    }
}

/// March steps of the air between the clouds' observer and the ground
/// ([`SkyLighting::environment_at`]; WGSL `CLOUDS_AIR_STEPS`).
pub const CLOUDS_AIR_STEPS: u32 = 16;

/// What lies under an observer above the scene ([`SkyLighting::environment_at`]):
/// a square of near ground (the terrain) centred on the world's origin, the
/// open sea beyond it, and whether the air between scatters and attenuates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundBelow {
    /// Half the side of the near ground's square (x and z about the origin),
    /// m; beyond it the sea. [`f64::INFINITY`]: ground everywhere.
    pub near_ground_half_extent_m: f64,
    /// Diffuse albedo of the sea's water body under its surface.
    pub water_albedo: [f64; 3],
    /// GGX roughness α of the sea's surface (its microfacets' shadowing
    /// and masking dim the reflection at grazing angles).
    pub water_ggx_alpha: f64,
    /// Whether the air between the observer and the ground is drawn
    /// (`camera.aerial_perspective`).
    pub through_air: bool,
}

impl GroundBelow {
    /// Whether the ground at (x, z), m, is the near ground (not the sea).
    pub fn holds_near_ground(&self, x_m: f64, z_m: f64) -> bool {
        x_m.abs() <= self.near_ground_half_extent_m && z_m.abs() <= self.near_ground_half_extent_m
    }
}

/// Schlick's (1994) approximation of water's Fresnel reflectance at the
/// cosine `cos_theta` of incidence, with F₀ = 0.02 (n = 1.33); WGSL
/// `water_fresnel` in `shader/water.wgsl`.
pub fn water_fresnel(cos_theta: f64) -> f64 {
    let m = 1.0 - cos_theta.clamp(0.0, 1.0);
    0.02 + 0.98 * m.powi(5)
}

/// The share of light a GGX water surface of roughness `alpha` reflects
/// specularly at the cosine `cos_theta` of incidence, near the mirror
/// direction: Schlick's Fresnel ([`water_fresnel`]) times the
/// height-correlated Smith shadowing-masking G₂ = 1/(1 + Λ(θᵢ) + Λ(θₒ))
/// with θₒ = θᵢ (Heitz 2014, "Understanding the masking-shadowing function
/// in microfacet-based BRDFs", eqs. 72 and 99): a lobe narrow enough to be
/// taken at the mirror angle. It dims a calm sea's glint and sky at the
/// grazing angles a cloud sees it from (0.77 → 0.51 at 3° with α = 0.06),
/// as the references' rough dielectric sea does. WGSL
/// `clouds_sea_reflectance` in the lighting pass.
pub fn sea_specular_reflectance(cos_theta: f64, alpha: f64) -> f64 {
    let mu = cos_theta.clamp(1e-4, 1.0);
    let tan2 = (1.0 - mu * mu) / (mu * mu);
    let lambda = 0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0);
    water_fresnel(mu) / (1.0 + 2.0 * lambda)
}

/// The sky's radiance along `d` (unit, y up) at radius `r`, from the
/// sky-view integral, W·sr⁻¹·m⁻² for the given solar irradiance at the top.
fn sky_radiance(
    tables: &AtmosphereTables,
    r: f64,
    sun: [f64; 3],
    solar_irradiance_top: [f64; 3],
    d: [f64; 3],
) -> [f64; 3] {
    let sun_horizontal = (sun[0] * sun[0] + sun[2] * sun[2]).sqrt();
    let zenith = d[1].clamp(-1.0, 1.0).acos();
    let horizontal = (d[0] * d[0] + d[2] * d[2]).sqrt();
    let cos_azimuth = if horizontal > 1e-9 && sun_horizontal > 1e-9 {
        (d[0] * sun[0] + d[2] * sun[2]) / (horizontal * sun_horizontal)
    } else {
        1.0
    };
    let l = tables.sky_view_luminance(r, zenith, cos_azimuth, sun[1]);
    [0, 1, 2].map(|c| l[c] * solar_irradiance_top[c])
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

    fn down_irradiance(sh: &[[f64; 3]; 9]) -> [f64; 3] {
        sh::irradiance(sh, [0.0, -1.0, 0.0])
    }

    /// Over ground everywhere, through the air, an observer at the camera's
    /// own height sees the camera's environment: the two integrals differ
    /// only in how they march the air to the ground (16 steps against the
    /// sky-view integral's 32 and the exact transmittance).
    #[test]
    fn at_the_cameras_height_over_ground_the_clouds_see_the_cameras_environment() {
        let tables = AtmosphereTables::new(&AtmosphereParams::default());
        let e = 30f64.to_radians();
        let sun = [e.cos(), e.sin(), 0.0];
        let camera = SkyLighting::at(&tables, 800.0, sun, [1.0; 3], [0.12, 0.13, 0.08]);
        let below = GroundBelow {
            near_ground_half_extent_m: f64::INFINITY,
            water_albedo: [0.02; 3],
            water_ggx_alpha: 0.06,
            through_air: true,
        };
        let clouds =
            camera.environment_at(&tables, 800.0, [300.0, 800.0, -200.0], [1.0; 3], &below);
        for n in [
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.6, -0.8],
        ] {
            let (a, b) = (sh::irradiance(&clouds, n), camera.environment_irradiance(n));
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() < 0.02 * b[c],
                    "normal {n:?}, channel {c}: {} vs {}",
                    a[c],
                    b[c]
                );
            }
        }
    }

    /// Far out at sea without air, what an observer sees below is the sky's
    /// reflection (Fresnel and the microfacets' masking), the water body's
    /// diffuse light and the sun's glint: the downward irradiance against a direct quadrature of those
    /// (the order-2 SH carry a hemisphere's irradiance to a few per cent),
    /// and far below a land's.
    #[test]
    fn over_the_open_sea_the_light_from_below_is_the_skys_reflection_and_the_glint() {
        let tables = AtmosphereTables::new(&AtmosphereParams::default());
        let e = 40f64.to_radians();
        let sun = [0.0, e.sin(), -e.cos()];
        let camera = SkyLighting::at(&tables, 100.0, sun, [1.0; 3], [0.15; 3]);
        let water_albedo = [0.01, 0.02, 0.03];
        let sea = GroundBelow {
            near_ground_half_extent_m: 10.0,
            water_albedo,
            water_ggx_alpha: 0.06,
            through_air: false,
        };
        let observer = [50_000.0, 1500.0, 0.0];
        let clouds = camera.environment_at(&tables, 100.0, observer, [1.0; 3], &sea);
        // Quadrature over the lower hemisphere in the cosine of the nadir angle.
        let r = tables.params.bottom_radius_m + 100.0;
        let mut expected = [0.0; 3];
        let (nu, nphi) = (200, 96);
        for i in 0..nu {
            let mu = (f64::from(i) + 0.5) / f64::from(nu);
            for j in 0..nphi {
                let phi = 2.0 * std::f64::consts::PI * (f64::from(j) + 0.5) / f64::from(nphi);
                let s = (1.0 - mu * mu).sqrt();
                let up = [s * phi.cos(), mu, s * phi.sin()];
                let l = sky_radiance(&tables, r, sun, [1.0; 3], up);
                let f = sea_specular_reflectance(mu, 0.06);
                let w = mu * 2.0 * std::f64::consts::PI / f64::from(nu * nphi);
                for c in 0..3 {
                    let e_water = camera.sun_irradiance[c] * sun[1] + camera.sky_irradiance_up[c];
                    expected[c] += w
                        * (f * l[c] + (1.0 - f) * water_albedo[c] / std::f64::consts::PI * e_water);
                }
            }
        }
        let glint = sea_specular_reflectance(sun[1], 0.06) * sun[1];
        for (e, sun_e) in expected.iter_mut().zip(camera.sun_irradiance) {
            *e += glint * sun_e;
        }
        let got = down_irradiance(&clouds);
        for c in 0..3 {
            assert!(
                (got[c] - expected[c]).abs() < 0.08 * expected[c],
                "channel {c}: SH {} vs quadrature {}",
                got[c],
                expected[c]
            );
        }
        let land = GroundBelow {
            near_ground_half_extent_m: f64::INFINITY,
            ..sea
        };
        let over_land =
            down_irradiance(&camera.environment_at(&tables, 100.0, observer, [1.0; 3], &land));
        assert!(
            got[1] < 0.5 * over_land[1],
            "sea {got:?} vs land {over_land:?}"
        );
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
