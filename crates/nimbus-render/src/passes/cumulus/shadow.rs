//! What the cloud shadow map holds, kept across frames: the map is redrawn
//! only when what it shows has changed, not every frame.
//!
//! Drawing the map is the cumulus pass's costliest step where fragments are
//! dear (each core fragment integrates the optical depth through its blob;
//! 2 × 2048² texels; on the software driver it was 354 ms of a 591 ms frame
//! of the default scene). Its content depends on the clouds' shapes, their
//! places relative to each other, the shader's parameters and the sun's
//! direction — not on where the wind has carried the field as a whole. So:
//!
//! - clouds that all moved by the frame's drift (the wind carries the whole
//!   field) keep the map: its transform is translated by the drift since it
//!   was drawn, which is exactly the transform a redraw would compute (the
//!   bounds move with the clouds) and leaves every texel as it was;
//! - a sun that moved by less than makes any shadow move by half a texel
//!   (over the map's largest extent) keeps the map;
//! - anything else — a cloud wrapped around the field, a new shape, level
//!   of detail or parameter, a larger sun move — redraws it.

use glam::{DMat4, DVec3, Mat4};

/// Largest mismatch between a cloud's move and the field's drift that still
/// counts as the same place, m (rounding of the drift; a cloud wrapped
/// around the field jumps by the field's side).
const SAME_PLACE_M: f64 = 0.01;

/// The inputs of the map that a redraw must follow exactly.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ShadowKey {
    /// The cumulus uniform with its sun-dependent fields cleared (those
    /// colour the clouds; the map reads the density, noise and terms).
    pub uniform: super::gpu_types::CumulusUniform,
    /// Per cloud, in the field's order: its variant and level of detail.
    pub shapes: Vec<(usize, usize)>,
}

/// What the map holds: drawn from `key`'s clouds at `centres_m`, with the
/// field drifted by `drift_m`, the sun towards `to_sun`, through
/// `clip_from_world` over `depth_m`.
#[derive(Clone, Debug)]
pub(super) struct ShadowContent {
    pub key: ShadowKey,
    pub centres_m: Vec<DVec3>,
    pub drift_m: [f64; 2],
    pub to_sun: DVec3,
    pub clip_from_world: Mat4,
    pub depth_m: f64,
}

impl ShadowContent {
    /// The transform under which this content is this frame's map (clouds
    /// at `centres_m` with the field drifted by `drift_m`, the sun towards
    /// `to_sun`), or `None` when the map must be redrawn.
    pub fn reused_transform(
        &self,
        key: &ShadowKey,
        centres_m: &[DVec3],
        drift_m: [f64; 2],
        to_sun: DVec3,
        map_side_texels: u32,
    ) -> Option<Mat4> {
        if *key != self.key || centres_m.len() != self.centres_m.len() {
            return None;
        }
        let moved = DVec3::new(
            drift_m[0] - self.drift_m[0],
            0.0,
            drift_m[1] - self.drift_m[1],
        );
        let same_places = centres_m
            .iter()
            .zip(&self.centres_m)
            .all(|(now, then)| (*now - (*then + moved)).length() <= SAME_PLACE_M);
        if !same_places {
            return None;
        }
        // The map's side, m: its first row is the light's right over half
        // the side.
        let half_m = 1.0 / self.clip_from_world.row(0).truncate().length() as f64;
        let texel_m = 2.0 * half_m / f64::from(map_side_texels);
        let extent_m = (2.0 * half_m).max(self.depth_m);
        let angle = self.to_sun.angle_between(to_sun);
        // (A NaN angle redraws.)
        let sun_kept = angle * extent_m <= 0.5 * texel_m;
        if !sun_kept {
            return None;
        }
        let translated = self.clip_from_world.as_dmat4() * DMat4::from_translation(-moved);
        Some(translated.as_mat4())
    }
}

#[cfg(test)]
mod tests {
    use super::super::field::shadow_clip_from_world;
    use super::*;
    use bytemuck::Zeroable;

    fn content(to_sun: DVec3, centres: &[DVec3]) -> (ShadowContent, Vec<(DVec3, f64)>) {
        let spheres: Vec<(DVec3, f64)> = centres.iter().map(|&c| (c, 600.0)).collect();
        let (clip_from_world, depth_m) = shadow_clip_from_world(to_sun, &spheres);
        let content = ShadowContent {
            key: key(),
            centres_m: centres.to_vec(),
            drift_m: [100.0, -50.0],
            to_sun,
            clip_from_world,
            depth_m,
        };
        (content, spheres)
    }

    fn key() -> ShadowKey {
        ShadowKey {
            uniform: super::super::gpu_types::CumulusUniform::zeroed(),
            shapes: vec![(0, 2), (1, 2)],
        }
    }

    const CENTRES: [DVec3; 2] = [
        DVec3::new(-2000.0, 1500.0, 800.0),
        DVec3::new(3000.0, 1700.0, -400.0),
    ];

    /// A field carried by the wind keeps its map, under the transform a
    /// redraw would have computed from the moved clouds.
    #[test]
    fn a_drifted_field_keeps_its_map_under_the_redraws_transform() {
        let to_sun = DVec3::new(0.4, 0.7, -0.3).normalize();
        let (held, _) = content(to_sun, &CENTRES);
        let drift = [100.0 + 37.5, -50.0 - 12.25];
        let moved: Vec<DVec3> = CENTRES
            .iter()
            .map(|c| *c + DVec3::new(37.5, 0.0, -12.25))
            .collect();
        let reused = held
            .reused_transform(&key(), &moved, drift, to_sun, 2048)
            .expect("the same clouds, moved by the drift");
        let spheres: Vec<(DVec3, f64)> = moved.iter().map(|&c| (c, 600.0)).collect();
        let (redrawn, _) = shadow_clip_from_world(to_sun, &spheres);
        let difference = (reused - redrawn).abs().to_cols_array();
        assert!(
            difference.iter().all(|d| *d < 1e-5),
            "{reused} vs {redrawn}"
        );
    }

    #[test]
    fn a_wrapped_cloud_another_shape_or_a_sun_moved_by_a_texel_redraw() {
        let to_sun = DVec3::new(0.4, 0.7, -0.3).normalize();
        let (held, _) = content(to_sun, &CENTRES);
        let drift = held.drift_m;
        // Unchanged: kept as it was.
        assert_eq!(
            held.reused_transform(&key(), &CENTRES, drift, to_sun, 2048),
            Some(held.clip_from_world)
        );
        // One cloud wrapped around a 20 km field.
        let wrapped = [CENTRES[0], CENTRES[1] + DVec3::new(-20_000.0, 0.0, 0.0)];
        assert_eq!(
            held.reused_transform(&key(), &wrapped, drift, to_sun, 2048),
            None
        );
        // Another level of detail.
        let mut other = key();
        other.shapes[1].1 = 1;
        assert_eq!(
            held.reused_transform(&other, &CENTRES, drift, to_sun, 2048),
            None
        );
        // The sun moved: by a hundredth of the half-texel angle it keeps
        // the map, by the half-texel angle it redraws it.
        let half_m = 1.0 / held.clip_from_world.row(0).truncate().length() as f64;
        let extent = (2.0 * half_m).max(held.depth_m);
        let half_texel_angle = 0.5 * (2.0 * half_m / 2048.0) / extent;
        let axis = to_sun.any_orthonormal_vector();
        let turned = |angle: f64| glam::DQuat::from_axis_angle(axis, angle) * to_sun;
        assert!(
            held.reused_transform(
                &key(),
                &CENTRES,
                drift,
                turned(0.01 * half_texel_angle),
                2048
            )
            .is_some()
        );
        assert_eq!(
            held.reused_transform(
                &key(),
                &CENTRES,
                drift,
                turned(1.01 * half_texel_angle),
                2048
            ),
            None
        );
    }
}
