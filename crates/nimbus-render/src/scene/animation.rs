//! Keyframed weather (`[[keyframes]]`): the scene at any animation time.
//!
//! Each keyframe sets some of the animated values at one time; every value
//! is a track of its own through the keyframes that set it. Between keys a
//! track follows a monotone cubic Hermite curve (Fritsch & Carlson, "Monotone
//! piecewise cubic interpolation", SIAM J. Numer. Anal. 17, 1980): smooth
//! (continuous slope), and never outside the range of its two neighbouring
//! keys, so coverages stay in [0, 1] and intensities non-negative. Before
//! the first key and after the last, a track holds its end value. Angles
//! (sun azimuth, wind direction) turn the short way round.
//!
//! The clouds move with the wind: the distance the air has travelled is the
//! integral of the keyed wind velocity over time, so changing the wind
//! changes the clouds' speed, never their position, from one frame to the
//! next.

use super::Scene;
use super::SceneError;
use super::validate::Checker;
use nimbus_physics::sky::UtcDateTime;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Most keyframes in a scene.
pub const MAX_KEYFRAMES: usize = 1024;

/// One keyframe: the values that hold at `time_s` (keys left out are not keyed here).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct Keyframe {
    /// Animation time of the key, s, ≥ 0; keys in increasing order.
    pub time_s: f64,
    /// Date and time of the sun (ISO 8601 with a zone); needs the scene's sun
    /// given by `time_utc`, `latitude_deg` and `longitude_deg`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_time_utc: Option<String>,
    /// Sun azimuth, degrees clockwise from north, in [0, 360]; needs the
    /// scene's sun given by angles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_azimuth_deg: Option<f64>,
    /// Sun elevation, degrees, in [−90, 90]; needs the sun given by angles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_elevation_deg: Option<f64>,
    /// Wind speed, m/s, in [0, 100]; needs `[wind]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wind_speed_m_s: Option<f64>,
    /// Direction the wind blows from, degrees clockwise from north, in [0, 360]; needs `[wind]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wind_from_deg: Option<f64>,
    /// Rain intensity, mm/h, in [0, 200]; needs `[rain]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rain_intensity_mm_h: Option<f64>,
    /// Stratiform layer coverage, in [0, 1]; needs `[stratus]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stratus_coverage: Option<f64>,
    /// Camera position, world metres (x east, y up, z south), each
    /// coordinate in [−10⁶, 10⁶] and a track of its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_position_m: Option<[f64; 3]>,
    /// Point the camera looks at, world metres, each coordinate a track of
    /// its own; needs the scene's camera aimed by `look_at_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_look_at_m: Option<[f64; 3]>,
}

/// A track: (time, value) keys in increasing time.
type Track = Vec<(f64, f64)>;

/// The tracks of a keyframe list.
struct Tracks {
    sun_time_s: Track,
    sun_azimuth_deg: Track,
    sun_elevation_deg: Track,
    wind_speed_m_s: Track,
    wind_from_deg: Track,
    rain_intensity_mm_h: Track,
    stratus_coverage: Track,
    /// x, y, z of the camera's position, m.
    camera_position_m: [Track; 3],
    /// x, y, z of the point the camera looks at, m.
    camera_look_at_m: [Track; 3],
}

impl Tracks {
    /// Assumes validated keyframes (times parse).
    fn new(keys: &[Keyframe]) -> Self {
        let track = |value: &dyn Fn(&Keyframe) -> Option<f64>| -> Track {
            keys.iter()
                .filter_map(|k| value(k).map(|v| (k.time_s, v)))
                .collect()
        };
        Self {
            sun_time_s: track(&|k| {
                k.sun_time_utc
                    .as_deref()
                    .and_then(|t| UtcDateTime::parse(t).ok())
                    .map(|t| t.unix_seconds())
            }),
            sun_azimuth_deg: unwrap_degrees(track(&|k| k.sun_azimuth_deg)),
            sun_elevation_deg: track(&|k| k.sun_elevation_deg),
            wind_speed_m_s: track(&|k| k.wind_speed_m_s),
            wind_from_deg: unwrap_degrees(track(&|k| k.wind_from_deg)),
            rain_intensity_mm_h: track(&|k| k.rain_intensity_mm_h),
            stratus_coverage: track(&|k| k.stratus_coverage),
            camera_position_m: [0, 1, 2].map(|i| track(&|k| k.camera_position_m.map(|p| p[i]))),
            camera_look_at_m: [0, 1, 2].map(|i| track(&|k| k.camera_look_at_m.map(|p| p[i]))),
        }
    }
}

/// A keyed point (each coordinate a track of the same keys) at time `t`;
/// `None` when no key sets it.
fn evaluate_point(tracks: &[Track; 3], t: f64) -> Option<[f64; 3]> {
    let [x, y, z] = tracks.each_ref().map(|track| evaluate_track(track, t));
    Some([x?, y?, z?])
}

/// Why a camera at `position_m` cannot look at `target_m` (no horizon
/// direction: the target straight above or below it, or on it); `None`
/// when it can. The same test the scene's `[camera]` gets.
pub(super) fn degenerate_look_at(position_m: [f64; 3], target_m: [f64; 3]) -> Option<&'static str> {
    let d = [0, 1, 2].map(|k| target_m[k] - position_m[k]);
    let horizontal = (d[0] * d[0] + d[2] * d[2]).sqrt();
    (horizontal < 1e-3 * d[1].abs().max(1e-3)).then_some(
        "must not be straight above or below the camera's position (the view would have no horizon direction)",
    )
}

/// Points per stretch between camera keys at which the interpolated view is
/// checked (the monotone curves are smooth between keys; a look-at that
/// passes within a millimetre-wide cone above the eye is caught at this
/// spacing for any realistic flight, and rendering guards the rest).
const CAMERA_CHECKS_PER_STRETCH: usize = 64;

/// Shifts each angle by whole turns so that consecutive keys differ by at
/// most half a turn (the short way round).
fn unwrap_degrees(mut track: Track) -> Track {
    for i in 1..track.len() {
        let previous = track[i - 1].1;
        let step = (track[i].1 - previous + 180.0).rem_euclid(360.0) - 180.0;
        track[i].1 = previous + step;
    }
    track
}

/// The value of a track at time `t`: monotone cubic Hermite between keys
/// (Fritsch–Carlson tangents), held constant outside; `None` for no keys.
pub fn evaluate_track(track: &[(f64, f64)], t: f64) -> Option<f64> {
    let (first, last) = (track.first()?, track.last()?);
    if track.len() == 1 || t <= first.0 {
        return Some(first.1);
    }
    if t >= last.0 {
        return Some(last.1);
    }
    let i = track.partition_point(|k| k.0 <= t) - 1;
    let slope = |j: usize| (track[j + 1].1 - track[j].1) / (track[j + 1].0 - track[j].0);
    // Tangent at key j: zero at an extremum or a flat neighbour, else the
    // harmonic mean of the neighbouring slopes (Fritsch & Butland's form of
    // the Fritsch–Carlson condition), one-sided at the ends.
    let tangent = |j: usize| {
        if j == 0 {
            return slope(0);
        }
        if j == track.len() - 1 {
            return slope(j - 1);
        }
        let (a, b) = (slope(j - 1), slope(j));
        if a * b <= 0.0 {
            0.0
        } else {
            2.0 * a * b / (a + b)
        }
    };
    let ((t0, v0), (t1, v1)) = (track[i], track[i + 1]);
    let h = t1 - t0;
    let s = (t - t0) / h;
    let (s2, s3) = (s * s, s * s * s);
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = s3 - 2.0 * s2 + s;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = s3 - s2;
    Some(h00 * v0 + h10 * h * tangent(i) + h01 * v1 + h11 * h * tangent(i + 1))
}

/// Longest step of the wind integral, s.
const DRIFT_STEP_S: f64 = 0.25;

/// Most Simpson intervals per stretch between two wind keys.
const MAX_DRIFT_STEPS_PER_STRETCH: usize = 512;

/// ∫₀ᵗ v(τ) dτ of a keyed wind velocity `v`, whose tracks have keys at
/// `knots` (s, any order): between consecutive keys (and 0 and `time_s`)
/// Simpson's rule with steps of at most [`DRIFT_STEP_S`] up to
/// [`MAX_DRIFT_STEPS_PER_STRETCH`]; before the first key and after the last
/// the tracks hold their values, so the velocity is constant and the
/// integral exact. The cost grows with the number of keys, not with
/// `time_s` (a drift at 10⁹ s costs what one at 10 s does).
fn drift_integral(velocity: &dyn Fn(f64) -> [f64; 2], knots: &[f64], time_s: f64) -> [f64; 2] {
    let (lo, hi) = (time_s.min(0.0), time_s.max(0.0));
    let mut points: Vec<f64> = knots
        .iter()
        .copied()
        .filter(|k| *k > lo && *k < hi)
        .chain([0.0, time_s])
        .collect();
    points.sort_by(f64::total_cmp);
    points.dedup();
    if time_s < 0.0 {
        points.reverse();
    }
    let first_key = knots.iter().copied().fold(f64::INFINITY, f64::min);
    let last_key = knots.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut drift = [0.0, 0.0];
    for pair in points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let constant = a.min(b) >= last_key || a.max(b) <= first_key;
        let part = if constant {
            velocity(a).map(|v| v * (b - a))
        } else {
            let steps = ((((b - a).abs() / DRIFT_STEP_S).ceil() as usize).max(1) * 2)
                .min(MAX_DRIFT_STEPS_PER_STRETCH);
            let h = (b - a) / steps as f64;
            let mut sum = [0.0, 0.0];
            for j in 0..=steps {
                let weight = if j == 0 || j == steps {
                    1.0
                } else if j % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let v = velocity(a + j as f64 * h);
                sum[0] += weight * v[0];
                sum[1] += weight * v[1];
            }
            sum.map(|s| s * h / 3.0)
        };
        drift[0] += part[0];
        drift[1] += part[1];
    }
    drift
}

impl Scene {
    /// Whether the scene has keyframes.
    pub fn is_animated(&self) -> bool {
        !self.keyframes.is_empty()
    }

    /// The scene at animation time `time_s`: every keyed value set from its
    /// track, and the wind's drift (the distance the air has moved since
    /// time 0) integrated along the keyed wind. Scenes without keyframes are
    /// returned unchanged.
    pub fn at_time(&self, time_s: f64) -> Scene {
        let mut scene = self.clone();
        if self.keyframes.is_empty() {
            return scene;
        }
        let tracks = Tracks::new(&self.keyframes);
        let at = |track: &Track| evaluate_track(track, time_s);
        if let Some(seconds) = at(&tracks.sun_time_s) {
            scene.sun.time_utc = Some(UtcDateTime::from_unix_seconds(seconds).to_string());
        }
        if let Some(azimuth) = at(&tracks.sun_azimuth_deg) {
            scene.sun.azimuth_deg = Some(azimuth.rem_euclid(360.0));
        }
        if let Some(elevation) = at(&tracks.sun_elevation_deg) {
            scene.sun.elevation_deg = Some(elevation);
        }
        if let Some(wind) = &mut scene.wind {
            let keyed = !tracks.wind_speed_m_s.is_empty() || !tracks.wind_from_deg.is_empty();
            let base = (wind.speed_m_s, wind.from_deg);
            let velocity = |t: f64| {
                let mut w = super::WindSettings {
                    speed_m_s: evaluate_track(&tracks.wind_speed_m_s, t).unwrap_or(base.0),
                    from_deg: evaluate_track(&tracks.wind_from_deg, t).unwrap_or(base.1),
                    ..Default::default()
                };
                w.from_deg = w.from_deg.rem_euclid(360.0);
                w.velocity_xz_m_s()
            };
            if keyed {
                wind.speed_m_s = evaluate_track(&tracks.wind_speed_m_s, time_s).unwrap_or(base.0);
                wind.from_deg = evaluate_track(&tracks.wind_from_deg, time_s)
                    .unwrap_or(base.1)
                    .rem_euclid(360.0);
                let knots: Vec<f64> = tracks
                    .wind_speed_m_s
                    .iter()
                    .chain(&tracks.wind_from_deg)
                    .map(|k| k.0)
                    .collect();
                wind.drift_m = Some(drift_integral(&velocity, &knots, time_s));
            }
        }
        if let (Some(rain), Some(intensity)) = (&mut scene.rain, at(&tracks.rain_intensity_mm_h)) {
            rain.intensity_mm_h = intensity.max(0.0);
        }
        if let (Some(stratus), Some(coverage)) = (&mut scene.stratus, at(&tracks.stratus_coverage))
        {
            stratus.coverage = coverage.clamp(0.0, 1.0);
        }
        if let Some(position) = evaluate_point(&tracks.camera_position_m, time_s) {
            scene.camera.position_m = position;
        }
        if let Some(target) = evaluate_point(&tracks.camera_look_at_m, time_s) {
            scene.camera.look_at_m = Some(target);
        }
        scene
    }

    /// The horizontal distance (x, z), m, the air (and the clouds in it) has
    /// moved at animation time `time_s`: the integral of the keyed wind
    /// ([`Self::at_time`] sets it) or the constant wind velocity × time.
    pub fn cloud_drift_m(&self, time_s: f64) -> [f64; 2] {
        self.wind.as_ref().map_or([0.0, 0.0], |w| {
            w.drift_m
                .unwrap_or_else(|| w.velocity_xz_m_s().map(|v| v * time_s))
        })
    }

    pub(super) fn validate_keyframes(&self, c: &Checker<'_>) -> Result<(), SceneError> {
        if self.keyframes.len() > MAX_KEYFRAMES {
            return Err(c.invalid(
                "keyframes",
                format!("{} keyframes", self.keyframes.len()),
                format!("at most {MAX_KEYFRAMES}"),
            ));
        }
        let by_angles = self.sun.azimuth_deg.is_some() || self.sun.elevation_deg.is_some();
        let by_time = self.sun.time_utc.is_some();
        let mut previous: Option<f64> = None;
        for (i, key) in self.keyframes.iter().enumerate() {
            let name = |field: &str| format!("keyframes[{i}].{field}");
            c.closed(&name("time_s"), key.time_s, 0.0, 1.0e7)?;
            if let Some(p) = previous
                && key.time_s <= p
            {
                return Err(c.invalid(
                    &name("time_s"),
                    key.time_s,
                    format!("must be greater than the previous keyframe's time_s ({p})"),
                ));
            }
            previous = Some(key.time_s);
            let requires = |field: &str, present: bool, what: &str| {
                if present {
                    Ok(())
                } else {
                    Err(c.invalid(&name(field), "set", format!("needs {what}")))
                }
            };
            if let Some(text) = &key.sun_time_utc {
                requires(
                    "sun_time_utc",
                    by_time,
                    "the scene's sun given by time_utc, latitude_deg and longitude_deg",
                )?;
                UtcDateTime::parse(text).map_err(|e| c.invalid(&name("sun_time_utc"), text, e))?;
            }
            if let Some(azimuth) = key.sun_azimuth_deg {
                requires(
                    "sun_azimuth_deg",
                    by_angles,
                    "the scene's sun given by angles",
                )?;
                c.closed(&name("sun_azimuth_deg"), azimuth, 0.0, 360.0)?;
            }
            if let Some(elevation) = key.sun_elevation_deg {
                requires(
                    "sun_elevation_deg",
                    by_angles,
                    "the scene's sun given by angles",
                )?;
                c.closed(&name("sun_elevation_deg"), elevation, -90.0, 90.0)?;
            }
            if let Some(speed) = key.wind_speed_m_s {
                requires("wind_speed_m_s", self.wind.is_some(), "a [wind] section")?;
                c.closed(&name("wind_speed_m_s"), speed, 0.0, 100.0)?;
            }
            if let Some(from) = key.wind_from_deg {
                requires("wind_from_deg", self.wind.is_some(), "a [wind] section")?;
                c.closed(&name("wind_from_deg"), from, 0.0, 360.0)?;
            }
            if let Some(intensity) = key.rain_intensity_mm_h {
                requires(
                    "rain_intensity_mm_h",
                    self.rain.is_some(),
                    "a [rain] section",
                )?;
                c.closed(&name("rain_intensity_mm_h"), intensity, 0.0, 200.0)?;
            }
            if let Some(coverage) = key.stratus_coverage {
                requires(
                    "stratus_coverage",
                    self.stratus.is_some(),
                    "a [stratus] section",
                )?;
                c.closed(&name("stratus_coverage"), coverage, 0.0, 1.0)?;
            }
            if let Some(position) = &key.camera_position_m {
                c.vector(
                    &name("camera_position_m"),
                    position,
                    -super::validate::MAX_COORDINATE_M,
                    super::validate::MAX_COORDINATE_M,
                )?;
            }
            if let Some(target) = &key.camera_look_at_m {
                requires(
                    "camera_look_at_m",
                    self.camera.look_at_m.is_some(),
                    "the scene's camera aimed by look_at_m",
                )?;
                c.vector(
                    &name("camera_look_at_m"),
                    target,
                    -super::validate::MAX_COORDINATE_M,
                    super::validate::MAX_COORDINATE_M,
                )?;
            }
        }
        self.validate_camera_path(c)
    }

    /// The keyed camera never looks straight up or down: checked at every
    /// key and at [`CAMERA_CHECKS_PER_STRETCH`] points between keys.
    fn validate_camera_path(&self, c: &Checker<'_>) -> Result<(), SceneError> {
        let keyed = |k: &Keyframe| k.camera_position_m.is_some() || k.camera_look_at_m.is_some();
        if self.camera.look_at_m.is_none() || !self.keyframes.iter().any(keyed) {
            return Ok(());
        }
        let tracks = Tracks::new(&self.keyframes);
        let times: Vec<f64> = self.keyframes.iter().map(|k| k.time_s).collect();
        let mut samples = vec![times[0]];
        for pair in times.windows(2) {
            for j in 1..=CAMERA_CHECKS_PER_STRETCH {
                samples.push(
                    pair[0] + (pair[1] - pair[0]) * j as f64 / CAMERA_CHECKS_PER_STRETCH as f64,
                );
            }
        }
        for t in samples {
            let position =
                evaluate_point(&tracks.camera_position_m, t).unwrap_or(self.camera.position_m);
            let Some(target) =
                evaluate_point(&tracks.camera_look_at_m, t).or(self.camera.look_at_m)
            else {
                continue;
            };
            if let Some(why) = degenerate_look_at(position, target) {
                // The key at or after t, where the path goes wrong.
                let i = times.partition_point(|&k| k < t).min(times.len() - 1);
                return Err(c.invalid(
                    &format!("keyframes[{i}].camera_look_at_m"),
                    format!("{target:?} from {position:?} at time {t} s"),
                    why,
                ));
            }
        }
        Ok(())
    }

    /// The scene without its rain, and without the keyframes' rain
    /// intensities (which need a `[rain]` section): still a valid scene.
    pub fn without_rain(&self) -> Scene {
        let mut scene = self.clone();
        scene.rain = None;
        for key in &mut scene.keyframes {
            key.rain_intensity_mm_h = None;
        }
        scene
    }

    /// The clear sky of the scene: without stratus, cumulus and rain, and
    /// without the keyframed values of those parts (the EXR's `sky` layer,
    /// the exported environment map).
    pub fn clear_sky(&self) -> Scene {
        let mut scene = self.without_rain();
        scene.stratus = None;
        scene.cumulus = None;
        for key in &mut scene.keyframes {
            key.stratus_coverage = None;
        }
        scene
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracks_pass_through_their_keys_without_overshoot() {
        let track = [(0.0, 0.0), (1.0, 0.9), (2.0, 1.0), (4.0, 0.2)];
        for &(t, v) in &track {
            assert!((evaluate_track(&track, t).expect("keys") - v).abs() < 1e-12);
        }
        // Monotone between monotone keys, within each pair's range.
        let mut previous = 0.0;
        for i in 0..=200 {
            let t = i as f64 * 0.01;
            let v = evaluate_track(&track, t).expect("keys");
            assert!(
                v >= previous - 1e-12 && (0.0..=1.0).contains(&v),
                "t {t}: {v}"
            );
            previous = v;
        }
        for i in 200..=400 {
            let v = evaluate_track(&track, i as f64 * 0.01).expect("keys");
            assert!((0.2..=1.0).contains(&v));
        }
        // Held outside, smooth (no jump in slope) at an inner key.
        assert_eq!(evaluate_track(&track, -3.0), Some(0.0));
        assert_eq!(evaluate_track(&track, 9.0), Some(0.2));
        let e = 1e-6;
        let left = (evaluate_track(&track, 1.0).expect("k")
            - evaluate_track(&track, 1.0 - e).expect("k"))
            / e;
        let right = (evaluate_track(&track, 1.0 + e).expect("k")
            - evaluate_track(&track, 1.0).expect("k"))
            / e;
        assert!((left - right).abs() < 1e-4, "{left} vs {right}");
        assert_eq!(evaluate_track(&[], 1.0), None);
    }

    #[test]
    fn angles_turn_the_short_way() {
        let track = unwrap_degrees(vec![(0.0, 350.0), (1.0, 10.0)]);
        let mid = evaluate_track(&track, 0.5).expect("keys").rem_euclid(360.0);
        assert!(
            (mid - 0.0).abs() < 1e-9 || (mid - 360.0).abs() < 1e-9,
            "{mid}"
        );
    }

    fn scene(extra: &str) -> Result<Scene, SceneError> {
        Scene::from_toml_str(
            &format!(
                "[sun]\nazimuth_deg = 180.0\nelevation_deg = 30.0\n[wind]\nspeed_m_s = 10.0\nfrom_deg = 270.0\n[rain]\nintensity_mm_h = 1.0\n{extra}"
            ),
            "test.toml",
        )
    }

    #[test]
    fn keyed_values_follow_the_keys_and_the_drift_integrates_the_wind() {
        let s = scene(
            "[[keyframes]]\ntime_s = 0.0\nsun_elevation_deg = 30.0\nwind_speed_m_s = 10.0\nrain_intensity_mm_h = 1.0\n\
             [[keyframes]]\ntime_s = 10.0\nsun_elevation_deg = 2.0\nwind_speed_m_s = 0.0\nrain_intensity_mm_h = 20.0\n",
        )
        .expect("valid");
        let start = s.at_time(0.0);
        let end = s.at_time(10.0);
        assert_eq!(start.sun.elevation_deg, Some(30.0));
        assert_eq!(end.sun.elevation_deg, Some(2.0));
        assert_eq!(end.rain.as_ref().map(|r| r.intensity_mm_h), Some(20.0));
        // From the west (270°) the air moves east (+x): speed 10 → 0 along
        // a cubic with end slopes equal to the secant (two keys): linear, so
        // the air moves 50 m in 10 s, then stays.
        let drift = end.cloud_drift_m(10.0);
        assert!(
            (drift[0] - 50.0).abs() < 1e-6 && drift[1].abs() < 1e-6,
            "{drift:?}"
        );
        let later = s.at_time(20.0).cloud_drift_m(20.0);
        assert!((later[0] - 50.0).abs() < 1e-6, "{later:?}");
        // Far beyond the keys the air moves at the last key's velocity (here
        // none), whatever the time: no integration step per second
        // (issue 28: `--time-s 1e9` took minutes).
        let far = s.at_time(1.0e9).cloud_drift_m(1.0e9);
        assert!((far[0] - 50.0).abs() < 1e-6, "{far:?}");
        let steady = scene(
            "[[keyframes]]\ntime_s = 0.0\nwind_speed_m_s = 4.0\n\
             [[keyframes]]\ntime_s = 10.0\nwind_speed_m_s = 8.0\n",
        )
        .expect("valid");
        // 4 → 8 m/s linearly over 10 s (60 m), then 8 m/s: at 10⁹ s exact.
        let far = steady.at_time(1.0e9).cloud_drift_m(1.0e9);
        let expected = 60.0 + 8.0 * (1.0e9 - 10.0);
        assert!(
            (far[0] - expected).abs() < 1e-9 * expected && far[1].abs() < 1e-3,
            "{far:?} against {expected}"
        );
        // Between keys: the same integral as many small steps give.
        let mid = steady.at_time(7.3).cloud_drift_m(7.3);
        let exact = 4.0 * 7.3 + 0.2 * 7.3 * 7.3;
        assert!((mid[0] - exact).abs() < 1e-9, "{mid:?} against {exact}");
        // Without keyframes the drift is velocity × time.
        let plain = scene("").expect("valid");
        assert!((plain.cloud_drift_m(3.0)[0] - 30.0).abs() < 1e-9);
        assert_eq!(plain.at_time(5.0), plain);
    }

    #[test]
    fn bad_keyframes_are_rejected_with_their_key() {
        let message = |extra: &str| scene(extra).expect_err("invalid").to_string();
        let m = message("[[keyframes]]\ntime_s = 5.0\n[[keyframes]]\ntime_s = 5.0\n");
        assert!(
            m.contains("keyframes[1].time_s") && m.contains("greater"),
            "{m}"
        );
        let m = message("[[keyframes]]\ntime_s = 0.0\nstratus_coverage = 0.5\n");
        assert!(
            m.contains("keyframes[0].stratus_coverage") && m.contains("[stratus]"),
            "{m}"
        );
        let m = message("[[keyframes]]\ntime_s = 0.0\nsun_time_utc = \"2026-06-21T12:00:00Z\"\n");
        assert!(m.contains("sun_time_utc"), "{m}");
        let m = message("[[keyframes]]\ntime_s = 0.0\nrain_intensity_mm_h = -1.0\n");
        assert!(m.contains("rain_intensity_mm_h") && m.contains("-1"), "{m}");
    }

    #[test]
    fn the_camera_flies_along_its_keys() {
        let s = scene(
            "[camera]\nposition_m = [0.0, 100.0, 0.0]\nlook_at_m = [0.0, 100.0, -1000.0]\n\
             [[keyframes]]\ntime_s = 0.0\ncamera_position_m = [0.0, 100.0, 0.0]\n\
             [[keyframes]]\ntime_s = 5.0\ncamera_position_m = [500.0, 300.0, 0.0]\ncamera_look_at_m = [0.0, 2000.0, -1000.0]\n\
             [[keyframes]]\ntime_s = 10.0\ncamera_position_m = [1000.0, 100.0, 0.0]\n",
        )
        .expect("valid");
        assert_eq!(s.at_time(0.0).camera.position_m, [0.0, 100.0, 0.0]);
        assert_eq!(s.at_time(5.0).camera.position_m, [500.0, 300.0, 0.0]);
        assert_eq!(s.at_time(99.0).camera.position_m, [1000.0, 100.0, 0.0]);
        // One look-at key: held at every time.
        assert_eq!(
            s.at_time(0.0).camera.look_at_m,
            Some([0.0, 2000.0, -1000.0])
        );
        // x is monotone 0 → 1000; y rises to its key and back, never above it.
        let mut previous_x = -1.0;
        for i in 0..=100 {
            let p = s.at_time(i as f64 * 0.1).camera.position_m;
            assert!(
                p[0] >= previous_x && (100.0..=300.0).contains(&p[1]),
                "{p:?}"
            );
            previous_x = p[0];
        }
        // Between keys the camera moves every frame.
        let (a, b) = (s.at_time(2.0).camera, s.at_time(2.1).camera);
        let step: f64 = (0..3)
            .map(|k| (a.position_m[k] - b.position_m[k]).powi(2))
            .sum();
        assert!(step.sqrt() > 1.0, "{a:?} {b:?}");
    }

    #[test]
    fn camera_keys_are_checked_along_the_path() {
        let message = |extra: &str| scene(extra).expect_err("invalid").to_string();
        // A look-at key needs a camera aimed by look_at_m.
        let m = message("[[keyframes]]\ntime_s = 0.0\ncamera_look_at_m = [0.0, 0.0, -100.0]\n");
        assert!(
            m.contains("keyframes[0].camera_look_at_m") && m.contains("look_at_m"),
            "{m}"
        );
        let m = message("[[keyframes]]\ntime_s = 0.0\ncamera_position_m = [0.0, 1e9, 0.0]\n");
        assert!(m.contains("keyframes[0].camera_position_m"), "{m}");
        // Keys each fine, but the path between them passes straight under
        // the target: caught between the keys, at the key after.
        let m = message(
            "[camera]\nposition_m = [-100.0, 0.0, 0.0]\nlook_at_m = [0.0, 500.0, 0.0]\n\
             [[keyframes]]\ntime_s = 0.0\ncamera_position_m = [-100.0, 0.0, 0.0]\n\
             [[keyframes]]\ntime_s = 10.0\ncamera_position_m = [100.0, 0.0, 0.0]\n",
        );
        assert!(
            m.contains("keyframes[1].camera_look_at_m") && m.contains("straight above"),
            "{m}"
        );
    }
}
