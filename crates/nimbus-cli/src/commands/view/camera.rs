//! The viewer's cameras: a fly camera (walk with the keys, look with the
//! mouse) and an orbit camera (turn about a target point, zoom with the
//! wheel). Both reduce to a position and a heading and elevation, which is
//! what the scene's `[camera]` stores.

use glam::DVec3;
use nimbus_render::frame::direction_from_yaw_pitch;
use nimbus_render::scene::CameraSettings;

/// The steepest view the scene allows, degrees (`camera.pitch_deg` is in [−89, 89]).
pub const MAX_PITCH_DEG: f64 = 89.0;

/// Degrees of turn per pixel of mouse drag.
pub const DEGREES_PER_PIXEL: f64 = 0.2;

/// How far the orbit camera's target is put in front of a fly camera that
/// switches to orbiting, m.
pub const DEFAULT_ORBIT_DISTANCE_M: f64 = 1000.0;

/// Closest and farthest orbit distances, m.
pub const ORBIT_DISTANCE_RANGE_M: [f64; 2] = [5.0, 200_000.0];

/// How the mouse and keys move the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMode {
    /// WASD walks along the view, Q/E go down/up, dragging looks around.
    Fly,
    /// Dragging turns about a target, the wheel zooms, WASD moves the target.
    Orbit,
}

/// Keys held down this frame, as a direction in the camera's frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MoveInput {
    /// +1 forward (W), −1 back (S).
    pub forward: f64,
    /// +1 right (D), −1 left (A).
    pub right: f64,
    /// +1 up (E), −1 down (Q).
    pub up: f64,
    /// Shift: ten times faster.
    pub fast: bool,
}

/// The viewer's camera.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewerCamera {
    /// How input moves it.
    pub mode: CameraMode,
    /// Eye position, world m.
    pub position_m: DVec3,
    /// Heading, degrees clockwise from north.
    pub yaw_deg: f64,
    /// Elevation of the view, degrees.
    pub pitch_deg: f64,
    /// Point the orbit camera turns about, world m.
    pub target_m: DVec3,
    /// Fly speed, m/s (the wheel changes it in fly mode).
    pub speed_m_s: f64,
}

/// Heading (clockwise from north = −z) and elevation of a direction, degrees;
/// the inverse of [`direction_from_yaw_pitch`].
pub fn yaw_pitch_from_direction(direction: DVec3) -> (f64, f64) {
    let d = direction.normalize_or(DVec3::NEG_Z);
    let yaw = d.x.atan2(-d.z).to_degrees();
    let pitch = d.y.clamp(-1.0, 1.0).asin().to_degrees();
    (yaw.rem_euclid(360.0), pitch)
}

impl ViewerCamera {
    /// The camera of a scene, in fly mode.
    pub fn from_settings(camera: &CameraSettings) -> Self {
        let position_m = DVec3::from_array(camera.position_m);
        let (yaw_deg, pitch_deg) = match camera.look_at_m {
            Some(target) => yaw_pitch_from_direction(DVec3::from_array(target) - position_m),
            None => (
                camera.yaw_deg.unwrap_or(0.0),
                camera.pitch_deg.unwrap_or(0.0),
            ),
        };
        let pitch_deg = pitch_deg.clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
        let target_m =
            position_m + direction_from_yaw_pitch(yaw_deg, pitch_deg) * DEFAULT_ORBIT_DISTANCE_M;
        Self {
            mode: CameraMode::Fly,
            position_m,
            yaw_deg,
            pitch_deg,
            target_m,
            speed_m_s: 50.0,
        }
    }

    /// Unit view direction.
    pub fn forward(&self) -> DVec3 {
        direction_from_yaw_pitch(self.yaw_deg, self.pitch_deg)
    }

    /// Distance from the eye to the orbit target, m.
    pub fn orbit_distance_m(&self) -> f64 {
        self.position_m.distance(self.target_m)
    }

    /// Switches mode. Orbiting starts about the point the camera looks at,
    /// [`DEFAULT_ORBIT_DISTANCE_M`] ahead; flying starts where the orbit was.
    pub fn set_mode(&mut self, mode: CameraMode) {
        if mode == CameraMode::Orbit && self.mode == CameraMode::Fly {
            self.target_m = self.position_m + self.forward() * DEFAULT_ORBIT_DISTANCE_M;
        }
        self.mode = mode;
    }

    /// Applies a mouse drag of (dx, dy) pixels: looks around (fly) or turns
    /// about the target (orbit). Dragging right turns the view right; in
    /// orbit mode it carries the camera left round the target.
    pub fn drag(&mut self, dx_px: f64, dy_px: f64) {
        let yaw = (self.yaw_deg + dx_px * DEGREES_PER_PIXEL).rem_euclid(360.0);
        let pitch =
            (self.pitch_deg - dy_px * DEGREES_PER_PIXEL).clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
        match self.mode {
            CameraMode::Fly => {
                self.yaw_deg = yaw;
                self.pitch_deg = pitch;
            }
            CameraMode::Orbit => {
                let distance = self.orbit_distance_m();
                self.yaw_deg = yaw;
                self.pitch_deg = pitch;
                self.position_m = self.target_m - self.forward() * distance;
            }
        }
    }

    /// Applies `lines` of mouse wheel: faster or slower flight, or a zoom
    /// towards the target (up: closer).
    pub fn scroll(&mut self, lines: f64) {
        let factor = 1.15_f64.powf(lines);
        match self.mode {
            CameraMode::Fly => self.speed_m_s = (self.speed_m_s * factor).clamp(1.0, 10_000.0),
            CameraMode::Orbit => {
                let [near, far] = ORBIT_DISTANCE_RANGE_M;
                let distance = (self.orbit_distance_m() / factor).clamp(near, far);
                self.position_m = self.target_m - self.forward() * distance;
            }
        }
    }

    /// Moves by the held keys over `dt_s` seconds. Flying moves along the
    /// view; orbiting moves the target (and the eye with it) over the
    /// ground plane, at a speed that grows with the distance.
    pub fn update(&mut self, input: MoveInput, dt_s: f64) {
        let boost = if input.fast { 10.0 } else { 1.0 };
        let forward = self.forward();
        let right = forward.cross(DVec3::Y).normalize_or(DVec3::X);
        let step = match self.mode {
            CameraMode::Fly => {
                (forward * input.forward + right * input.right + DVec3::Y * input.up)
                    * self.speed_m_s
            }
            CameraMode::Orbit => {
                let ahead = DVec3::new(forward.x, 0.0, forward.z).normalize_or(DVec3::NEG_Z);
                (ahead * input.forward + right * input.right + DVec3::Y * input.up)
                    * self.orbit_distance_m()
                    * 0.5
            }
        } * boost
            * dt_s;
        self.position_m += step;
        if self.mode == CameraMode::Orbit {
            self.target_m += step;
        }
    }

    /// Writes the pose into scene camera settings (heading and elevation;
    /// `look_at_m` cleared).
    pub fn write_to(&self, camera: &mut CameraSettings) {
        camera.position_m = self.position_m.to_array();
        camera.look_at_m = None;
        // Round-trip through the file's ranges: heading in [0, 360), elevation in [−89, 89].
        camera.yaw_deg = Some(self.yaw_deg.rem_euclid(360.0));
        camera.pitch_deg = Some(self.pitch_deg.clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        a.distance(b) < 1e-9 * (1.0 + a.length())
    }

    #[test]
    fn yaw_pitch_inverts_the_frame_convention() {
        for (yaw, pitch) in [(0.0, 0.0), (90.0, 10.0), (200.0, -45.0), (359.0, 80.0)] {
            let (y, p) = yaw_pitch_from_direction(direction_from_yaw_pitch(yaw, pitch));
            assert!(
                (y - yaw).abs() < 1e-9 && (p - pitch).abs() < 1e-9,
                "{yaw} {pitch}: {y} {p}"
            );
        }
        // North is −z, east +x.
        assert!((yaw_pitch_from_direction(DVec3::X).0 - 90.0).abs() < 1e-12);
    }

    #[test]
    fn look_at_settings_give_the_same_view_direction() {
        let mut settings = CameraSettings::default();
        settings.position_m = [10.0, 200.0, -5.0];
        settings.look_at_m = Some([500.0, 900.0, -3000.0]);
        let camera = ViewerCamera::from_settings(&settings);
        let expected = nimbus_render::frame::Camera::from_settings(&settings, 16, 9).forward;
        assert!(close(camera.forward(), expected));
        let mut written = CameraSettings::default();
        camera.write_to(&mut written);
        let again = nimbus_render::frame::Camera::from_settings(&written, 16, 9);
        assert!(close(again.forward, expected));
        assert_eq!(again.position_m, DVec3::from_array(settings.position_m));
    }

    #[test]
    fn orbiting_keeps_the_distance_and_the_target_in_view() {
        let mut camera = ViewerCamera::from_settings(&CameraSettings::default());
        camera.set_mode(CameraMode::Orbit);
        let target = camera.target_m;
        for (dx, dy) in [(120.0, 0.0), (0.0, -300.0), (-1000.0, 900.0)] {
            camera.drag(dx, dy);
            assert!((camera.orbit_distance_m() - DEFAULT_ORBIT_DISTANCE_M).abs() < 1e-6);
            assert!(close(camera.position_m + camera.forward() * 1000.0, target));
            assert!(camera.pitch_deg.abs() <= MAX_PITCH_DEG);
        }
        camera.scroll(3.0);
        assert!((camera.orbit_distance_m() - 1000.0 / 1.15_f64.powi(3)).abs() < 1e-6);
        assert_eq!(camera.target_m, target);
    }

    #[test]
    fn flying_moves_along_the_view_and_upwards() {
        let mut settings = CameraSettings::default();
        settings.yaw_deg = Some(90.0);
        settings.pitch_deg = Some(0.0);
        let mut camera = ViewerCamera::from_settings(&settings);
        let start = camera.position_m;
        let input = MoveInput {
            forward: 1.0,
            up: 1.0,
            ..MoveInput::default()
        };
        camera.update(input, 2.0);
        // East at 50 m/s and up at 50 m/s for 2 s.
        assert!(close(
            camera.position_m - start,
            DVec3::new(100.0, 100.0, 0.0)
        ));
        camera.update(
            MoveInput {
                right: 1.0,
                fast: true,
                ..MoveInput::default()
            },
            0.1,
        );
        // Right of east is south (+z), ten times faster.
        assert!(close(
            camera.position_m - start,
            DVec3::new(100.0, 100.0, 50.0)
        ));
        // The wheel changes the speed in fly mode, within bounds.
        camera.scroll(-100.0);
        assert_eq!(camera.speed_m_s, 1.0);
    }

    #[test]
    fn drag_turns_right_and_clamps_the_pitch() {
        let mut camera = ViewerCamera::from_settings(&CameraSettings::default());
        camera.drag(100.0, -10_000.0);
        assert!((camera.yaw_deg - 20.0).abs() < 1e-9);
        assert_eq!(camera.pitch_deg, MAX_PITCH_DEG);
    }
}
