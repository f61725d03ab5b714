//! The weather's sun on Bevy's lights.
//!
//! nimbus's sun after the atmosphere ([`nimbus_render::atmosphere::sky_lighting`]:
//! the sun's direction and its irradiance C_sun at the observer, the clear
//! sky's irradiance C_sky on an upward surface, per RGB channel, in
//! nimbus's luminous-equivalent W·m⁻²: 683 lm·W⁻¹ turns them into lux)
//! becomes:
//!
//! - the [`NimbusSun`]'s `DirectionalLight`: pointing along −sun direction,
//!   `colour × illuminance = 683 · C_sun` per channel (colour normalised to
//!   a largest channel of 1), so that Bevy's Lambert term
//!   `albedo/π · illuminance · colour · cos θ` is nimbus's
//!   `albedo/π · C_sun · cos θ` in cd·m⁻² (Bevy's unit) — the same radiance
//!   nimbus gives its own surfaces in the sun;
//! - Bevy's `GlobalAmbientLight`: `colour × brightness = 683 · C_sky / π`
//!   (cd·m⁻²), the radiance of a white upward surface lit by the clear sky
//!   alone (Bevy's ambient term is `albedo · brightness · colour`). Bevy
//!   gives that light to every normal alike.
//!
//! `sky_lighting` takes 0.15 s (optimised): it runs on Bevy's async
//! compute pool whenever the sun, the atmosphere or the camera's height in
//! the weather change, and the lights follow when it is done; the first
//! one is waited for, so that the first frame is lit.

use crate::NimbusFrame;
use crate::cloud_shadows::NimbusAmbientProbe;
use bevy::color::{Color, LinearRgba};
use bevy::ecs::prelude::*;
use bevy::light::{DirectionalLight, GlobalAmbientLight};
use bevy::math::Vec3;
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on, futures_lite::future};
use bevy::transform::components::Transform;
use nimbus_physics::photometry::MAX_LUMINOUS_EFFICACY_LM_PER_W;
use nimbus_render::Scene;
use nimbus_render::atmosphere::{SkyLighting, sky_lighting};

/// Marks the directional light that nimbus's sun drives: its rotation,
/// illuminance and colour are set from the weather every time the sun
/// moves; with `drive_ambient`, Bevy's `GlobalAmbientLight` follows the
/// clear sky's irradiance.
#[derive(Component, Clone, Copy, Debug)]
#[require(DirectionalLight)]
pub struct NimbusSun {
    /// Set `GlobalAmbientLight` from the sky's irradiance too.
    pub drive_ambient: bool,
}

impl Default for NimbusSun {
    fn default() -> Self {
        Self {
            drive_ambient: true,
        }
    }
}

/// Bevy's lights for nimbus's sun and sky ([`sun_light`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunLight {
    /// Unit vector towards the sun (world space, +Y up).
    pub to_sun: Vec3,
    /// `DirectionalLight::illuminance`, lux: 683 × the largest channel of C_sun.
    pub illuminance_lux: f32,
    /// `DirectionalLight::color`, linear, largest channel 1 (white when dark).
    pub color: LinearRgba,
    /// `GlobalAmbientLight::brightness`, cd·m⁻²: 683 × the largest channel of C_sky / π.
    pub ambient_brightness_cd_m2: f32,
    /// `GlobalAmbientLight::color`, linear, largest channel 1.
    pub ambient_color: LinearRgba,
}

impl SunLight {
    /// The directional light's linear colour times its illuminance, lux
    /// per channel (what Bevy's shaders multiply).
    pub fn illuminance_rgb_lux(&self) -> [f32; 3] {
        let c = self.color;
        [c.red, c.green, c.blue].map(|v| v * self.illuminance_lux)
    }

    /// The light's `Transform`: looking along −[`Self::to_sun`] (a
    /// directional light shines along its forward, −Z).
    pub fn transform(&self) -> Transform {
        let forward = -self.to_sun;
        // Any up that is not along the light: the sun at the zenith looks
        // straight down.
        let up = if forward.y.abs() > 0.999 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        Transform::IDENTITY.looking_to(forward, up)
    }
}

/// A colour of largest channel 1 and that largest channel (0 and white for
/// black or non-finite input).
fn normalised(rgb: [f64; 3]) -> (LinearRgba, f64) {
    let peak = rgb.iter().copied().fold(0.0, f64::max);
    if !(peak.is_finite() && peak > 0.0) {
        return (LinearRgba::WHITE, 0.0);
    }
    let [r, g, b] = rgb.map(|c| (c.max(0.0) / peak) as f32);
    (LinearRgba::rgb(r, g, b), peak)
}

/// Bevy's lights for nimbus's sun and sky, from nimbus's CPU sky lighting
/// (see the module's documentation for the units).
pub fn sun_light(lighting: &SkyLighting) -> SunLight {
    let [x, y, z] = lighting.sun_direction.map(|c| c as f32);
    let to_sun = Vec3::new(x, y, z).normalize_or(Vec3::Y);
    let (color, sun_peak) = normalised(lighting.sun_irradiance);
    let (ambient_color, sky_peak) = normalised(lighting.sky_irradiance_up);
    SunLight {
        to_sun,
        illuminance_lux: (MAX_LUMINOUS_EFFICACY_LM_PER_W * sun_peak) as f32,
        color,
        ambient_brightness_cd_m2: (MAX_LUMINOUS_EFFICACY_LM_PER_W * sky_peak / std::f64::consts::PI)
            as f32,
        ambient_color,
    }
}

/// What the sky lighting depends on: the sun, the atmosphere and the
/// observer's height.
#[derive(Clone, Debug, PartialEq)]
struct SunKey {
    sun_direction: [f64; 3],
    atmosphere: nimbus_physics::atmosphere::AtmosphereParams,
    height_m: f64,
}

impl SunKey {
    fn of(scene: &Scene) -> Self {
        Self {
            sun_direction: scene.sun.direction(),
            atmosphere: scene.atmosphere.clone(),
            height_m: scene.camera.position_m[1],
        }
    }
}

/// The sun's lights, the one being computed, and what they were computed for.
#[derive(Resource, Default)]
pub(crate) struct SunState {
    /// The key of the lights last applied.
    applied: Option<SunKey>,
    /// The computation under way.
    pending: Option<(SunKey, Task<SunLight>)>,
    /// The lights last computed.
    light: Option<SunLight>,
}

/// Starts the sky lighting's computation when the sun, atmosphere or
/// height change, and sets the lights when it is done.
pub(crate) fn drive_sun(
    frame: Res<NimbusFrame>,
    mut state: ResMut<SunState>,
    mut suns: Query<(&NimbusSun, &mut DirectionalLight, &mut Transform)>,
    ambient: Option<ResMut<GlobalAmbientLight>>,
    probe: Option<Res<NimbusAmbientProbe>>,
) {
    let Some(scene) = &frame.scene else {
        return;
    };
    let key = SunKey::of(scene);
    let wanted_known = state.applied.as_ref() == Some(&key)
        || state.pending.as_ref().is_some_and(|(k, _)| *k == key);
    if !wanted_known && state.pending.is_none() {
        let mut scene = scene.clone();
        // Only what sky_lighting reads matters; a cheap copy for the task.
        scene.keyframes.clear();
        let task =
            AsyncComputeTaskPool::get().spawn(async move { sun_light(&sky_lighting(&scene)) });
        state.pending = Some((key.clone(), task));
    }
    if let Some((pending_key, mut task)) = state.pending.take() {
        // The first lights are waited for; later ones arrive when ready.
        let done = if state.light.is_none() {
            Some(block_on(&mut task))
        } else {
            block_on(future::poll_once(&mut task))
        };
        match done {
            Some(light) => {
                state.light = Some(light);
                state.applied = Some(pending_key);
            }
            None => state.pending = Some((pending_key, task)),
        }
    }
    let Some(light) = state.light else {
        return;
    };
    let mut drive_ambient = false;
    for (sun, mut directional, mut transform) in &mut suns {
        let new_transform = light.transform();
        if transform.rotation != new_transform.rotation {
            transform.rotation = new_transform.rotation;
        }
        let color = Color::LinearRgba(light.color);
        if directional.illuminance != light.illuminance_lux || directional.color != color {
            directional.illuminance = light.illuminance_lux;
            directional.color = color;
        }
        drive_ambient |= sun.drive_ambient;
    }
    if drive_ambient && let Some(mut ambient) = ambient {
        // Under the stratus layer the light is the deck's (nimbus's
        // radiosity, read back from the GPU): the clear sky's would leave
        // Bevy's meshes dark once the layer's shadow takes the sun.
        let under_layer = scene
            .stratus
            .is_some()
            .then(|| probe.as_ref().and_then(|p| p.latest()))
            .flatten()
            .filter(|reading| reading.under_layer);
        let (ambient_color, brightness) = match under_layer {
            Some(reading) => {
                let (color, peak) = normalised(reading.irradiance_up.map(f64::from));
                (
                    color,
                    (MAX_LUMINOUS_EFFICACY_LM_PER_W * peak / std::f64::consts::PI) as f32,
                )
            }
            None => (light.ambient_color, light.ambient_brightness_cd_m2),
        };
        let color = Color::LinearRgba(ambient_color);
        if ambient.brightness != brightness || ambient.color != color {
            ambient.brightness = brightness;
            ambient.color = color;
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // channels of three arrays side by side
mod tests {
    use super::*;

    fn lighting_of(azimuth_deg: f64, elevation_deg: f64) -> (Scene, SkyLighting) {
        let mut scene = Scene::default();
        scene.sun.azimuth_deg = Some(azimuth_deg);
        scene.sun.elevation_deg = Some(elevation_deg);
        scene.sun.time_utc = None;
        scene.camera.position_m = [0.0, 2.0, 0.0];
        let lighting = sky_lighting(&scene);
        (scene, lighting)
    }

    /// Bevy's Lambert term with the converted light equals nimbus's sunlit
    /// Lambert radiance (albedo/π · C_sun · cos θ, in cd·m⁻² through 683 lm/W)
    /// per channel, and the light points away from nimbus's sun.
    #[test]
    fn directional_light_matches_nimbus_sky_lighting() {
        for (azimuth, elevation) in [(200.0, 30.0), (90.0, 60.0), (270.0, 4.0), (10.0, 89.9)] {
            let (scene, lighting) = lighting_of(azimuth, elevation);
            let light = sun_light(&lighting);
            // Direction: nimbus's sun, and the transform's forward is away from it.
            let d = scene.sun.direction();
            let to_sun = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32);
            assert!(
                light.to_sun.distance(to_sun) < 1e-5,
                "{azimuth}/{elevation}"
            );
            let forward = light.transform().forward();
            assert!(
                forward.distance(-to_sun) < 1e-4,
                "forward {forward:?} for {to_sun}"
            );
            // Radiance of a grey Lambertian surface tilted 40° from the sun.
            let albedo = 0.4f64;
            let cos_theta = 40f64.to_radians().cos();
            let bevy = light
                .illuminance_rgb_lux()
                .map(|e| albedo / std::f64::consts::PI * f64::from(e) * cos_theta);
            for c in 0..3 {
                let nimbus =
                    683.0 * albedo / std::f64::consts::PI * lighting.sun_irradiance[c] * cos_theta;
                assert!(
                    (bevy[c] - nimbus).abs() <= 1e-5 * nimbus.max(1e-3),
                    "channel {c} at {elevation}°: Bevy {} cd/m², nimbus {nimbus}",
                    bevy[c]
                );
            }
            // Ambient: a white upward surface under the clear sky.
            let ambient = [
                light.ambient_color.red,
                light.ambient_color.green,
                light.ambient_color.blue,
            ];
            for c in 0..3 {
                let bevy = f64::from(ambient[c] * light.ambient_brightness_cd_m2);
                let nimbus = 683.0 * lighting.sky_irradiance_up[c] / std::f64::consts::PI;
                assert!(
                    (bevy - nimbus).abs() <= 1e-5 * nimbus.max(1e-3),
                    "ambient {c}: {bevy} vs {nimbus}"
                );
            }
        }
    }

    /// The physics shows through: a high sun gives daylight illuminance
    /// (clear sky, tens of klx), a low sun is dimmer and redder, and a sun
    /// below the horizon gives no light.
    #[test]
    fn sun_light_follows_the_atmosphere() {
        let high = sun_light(&lighting_of(180.0, 60.0).1);
        assert!(
            (60_000.0..120_000.0).contains(&high.illuminance_lux),
            "noon sun {} lx",
            high.illuminance_lux
        );
        let low = sun_light(&lighting_of(270.0, 3.0).1);
        assert!(low.illuminance_lux < 0.5 * high.illuminance_lux);
        let redness = |l: &SunLight| l.color.red / l.color.blue.max(1e-6);
        assert!(
            redness(&low) > 1.5 * redness(&high),
            "low sun {:?}, high sun {:?}",
            low.color,
            high.color
        );
        let night = sun_light(&lighting_of(0.0, -10.0).1);
        assert!(
            night.illuminance_lux < 1.0,
            "night sun {} lx",
            night.illuminance_lux
        );
    }
}
