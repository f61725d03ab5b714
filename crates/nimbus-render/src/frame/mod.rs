//! The frame: the per-frame uniform shared by every pass (WGSL `Frame` in
//! `shader/common.wgsl`: camera transforms, sun direction, exposure and
//! time), the camera model that produces the transforms, and every
//! frame-wide resource ([`FrameResources`]: atmosphere lookups, cloud
//! lighting, cloud shadow map; [`occluders`]), handed to the passes as
//! [`FrameLayouts`] and [`FrameBindings`].

pub mod atmosphere;
mod bindings;
pub mod cloud_lighting;
pub mod cloud_shadow;
pub mod occluders;
mod view;

pub use bindings::{
    ATMOSPHERE_GROUP, CLOUD_LIGHTING_GROUP, FRAME_GROUP, FrameBindings, FrameLayouts,
    FrameResources, PASS_GROUP, SetBindGroup,
};

pub use view::{DepthConvention, MIN_FOV_Y_RAD, Projection, View, ViewError};

use crate::scene::{CameraSettings, Scene};
use bytemuck::{Pod, Zeroable};
use glam::{DMat4, DVec3, Mat4};
use nimbus_physics::photometry::exposure_scale_from_ev100;
use nimbus_physics::sky::SOLAR_DISK_ANGULAR_RADIUS_RAD;

/// Distance of the near clip plane, m. With reverse-Z and an infinite far
/// plane, depth precision is ample from here to the horizon.
pub const NEAR_PLANE_M: f64 = 0.5;

/// Largest pre-exposed value written to the half-float HDR target (the
/// largest finite f16 is 65504).
pub const MAX_PRE_EXPOSED: f32 = 60_000.0;

/// GPU layout of the frame uniform (WGSL `Frame`). Its layout is checked
/// against naga's layout of the WGSL struct by a unit test.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameUniform {
    /// Clip space from world space (reverse-Z, infinite far plane).
    pub clip_from_world: [[f32; 4]; 4],
    /// World space from clip space.
    pub world_from_clip: [[f32; 4]; 4],
    /// Camera position, world metres.
    pub camera_position_m: [f32; 3],
    /// Animation time, s.
    pub time_s: f32,
    /// Unit vector towards the sun.
    pub sun_direction: [f32; 3],
    /// Radiance-to-target scale (see [`exposure_scale_from_ev100`]).
    pub exposure_scale: f32,
    /// Viewport size, pixels.
    pub viewport_size_px: [f32; 2],
    /// Angle subtended by one pixel at the image centre, rad (for filtering).
    pub pixel_angle_rad: f32,
    /// Cosine of the solar disk's angular radius.
    pub sun_cos_angular_radius: f32,
    /// Clamp of pre-exposed values, see [`MAX_PRE_EXPOSED`].
    pub max_pre_exposed: f32,
    /// 1 for automatic exposure.
    pub auto_exposure: u32,
    /// Exposure compensation, EV (positive is brighter).
    pub exposure_compensation_ev: f32,
    /// Adaptation time constant, s.
    pub adaptation_time_s: f32,
    /// Unit view direction, world space.
    pub view_forward: [f32; 3],
    /// Side of a pixel, m, for an orthographic view; 0 for a perspective one.
    pub orthographic_pixel_m: f32,
}

/// A pinhole camera in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position, world metres.
    pub position_m: DVec3,
    /// Unit view direction.
    pub forward: DVec3,
    /// Unit vector that points up in the image (orthogonal to `forward`).
    pub up: DVec3,
    /// Vertical field of view, rad.
    pub fov_y_rad: f64,
    /// Width over height.
    pub aspect: f64,
    /// Image height, pixels.
    pub height_px: u32,
}

/// Unit vector for a heading (clockwise from north = −Z) and an elevation, degrees.
pub fn direction_from_yaw_pitch(yaw_deg: f64, pitch_deg: f64) -> DVec3 {
    let (y, p) = (yaw_deg.to_radians(), pitch_deg.to_radians());
    DVec3::new(p.cos() * y.sin(), p.sin(), -p.cos() * y.cos())
}

impl Camera {
    /// The camera of a scene's settings for an image of the given size.
    pub fn from_settings(settings: &CameraSettings, width: u32, height: u32) -> Self {
        let position_m = DVec3::from_array(settings.position_m);
        let forward = match settings.look_at_m {
            Some(target) => (DVec3::from_array(target) - position_m).normalize(),
            None => direction_from_yaw_pitch(
                settings.yaw_deg.unwrap_or(0.0),
                settings.pitch_deg.unwrap_or(0.0),
            ),
        };
        Self {
            position_m,
            forward,
            up: up_for(forward),
            fov_y_rad: settings.fov_deg.to_radians(),
            aspect: width as f64 / height.max(1) as f64,
            height_px: height.max(1),
        }
    }

    /// The camera that sees one face of a cube map around `position_m`: a
    /// square image whose central `face_px` pixels span exactly the face
    /// (90°), with `overscan_px` more on every side so that resampling
    /// never reads past an edge. The image is `face_px + 2·overscan_px` square.
    pub fn cube_face(position_m: DVec3, face: CubeFace, face_px: u32, overscan_px: u32) -> Self {
        let (forward, up) = face.forward_up();
        let side_px = face_px + 2 * overscan_px;
        let half_extent = f64::from(side_px) / f64::from(face_px.max(1));
        Self {
            position_m,
            forward,
            up,
            fov_y_rad: 2.0 * half_extent.atan(),
            aspect: 1.0,
            height_px: side_px.max(1),
        }
    }

    /// View space (right-handed, looking down −Z) from world space.
    pub fn view_from_world(&self) -> DMat4 {
        DMat4::look_to_rh(self.position_m, self.forward, self.up)
    }

    /// Clip space from view space: reverse-Z with the far plane at infinity.
    pub fn clip_from_view(&self) -> DMat4 {
        DMat4::perspective_infinite_reverse_rh(self.fov_y_rad, self.aspect, NEAR_PLANE_M)
    }

    /// Clip space from world space.
    pub fn clip_from_world(&self) -> DMat4 {
        self.clip_from_view() * self.view_from_world()
    }
}

/// The image's up vector for a view direction: world up projected onto the
/// image plane, or north (−Z) when looking straight up or down.
fn up_for(forward: DVec3) -> DVec3 {
    let up = DVec3::Y - forward * forward.dot(DVec3::Y);
    if up.length_squared() > 1e-12 {
        up.normalize()
    } else {
        // Straight up: north at the top of the image; straight down: south.
        DVec3::NEG_Z * forward.y.signum()
    }
}

/// The six faces of a cube map, in the order +X, −X, +Y, −Y, +Z, −Z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CubeFace {
    /// East.
    PositiveX,
    /// West.
    NegativeX,
    /// Zenith.
    PositiveY,
    /// Nadir.
    NegativeY,
    /// South.
    PositiveZ,
    /// North.
    NegativeZ,
}

impl CubeFace {
    /// All faces.
    pub const ALL: [CubeFace; 6] = [
        CubeFace::PositiveX,
        CubeFace::NegativeX,
        CubeFace::PositiveY,
        CubeFace::NegativeY,
        CubeFace::PositiveZ,
        CubeFace::NegativeZ,
    ];

    /// The face's view direction and its image's up vector.
    pub fn forward_up(self) -> (DVec3, DVec3) {
        match self {
            CubeFace::PositiveX => (DVec3::X, DVec3::Y),
            CubeFace::NegativeX => (DVec3::NEG_X, DVec3::Y),
            CubeFace::PositiveY => (DVec3::Y, DVec3::Z),
            CubeFace::NegativeY => (DVec3::NEG_Y, DVec3::NEG_Z),
            CubeFace::PositiveZ => (DVec3::Z, DVec3::Y),
            CubeFace::NegativeZ => (DVec3::NEG_Z, DVec3::Y),
        }
    }

    /// The face a direction falls on (its largest component) and the
    /// direction's coordinates on that face's image plane at unit distance:
    /// `(right, up)`, each in [−1, 1], right and up as in the face's image.
    pub fn project(direction: DVec3) -> (CubeFace, f64, f64) {
        let a = direction.abs();
        let face = if a.x >= a.y && a.x >= a.z {
            if direction.x >= 0.0 {
                CubeFace::PositiveX
            } else {
                CubeFace::NegativeX
            }
        } else if a.y >= a.z {
            if direction.y >= 0.0 {
                CubeFace::PositiveY
            } else {
                CubeFace::NegativeY
            }
        } else if direction.z >= 0.0 {
            CubeFace::PositiveZ
        } else {
            CubeFace::NegativeZ
        };
        let (forward, up) = face.forward_up();
        let right = forward.cross(up);
        let depth = direction.dot(forward);
        (
            face,
            direction.dot(right) / depth,
            direction.dot(up) / depth,
        )
    }
}

/// The direction seen at a point of an equirectangular (latitude–longitude)
/// image, from its normalised coordinates `u`, `v` in [0, 1] (0 at the left
/// and top edges): longitude `(u − ½)·360°` clockwise from north, so north is
/// at the image's centre, east to its right and south at both edges;
/// latitude `90° − v·180°`, the zenith along the top edge.
pub fn equirectangular_direction(u: f64, v: f64) -> DVec3 {
    direction_from_yaw_pitch((u - 0.5) * 360.0, 90.0 - v * 180.0)
}

/// The inverse of [`equirectangular_direction`]: `(u, v)` of a direction,
/// `u` in [0, 1).
pub fn equirectangular_uv(direction: DVec3) -> (f64, f64) {
    let d = direction.normalize();
    let longitude = d.x.atan2(-d.z);
    let latitude = d.y.clamp(-1.0, 1.0).asin();
    let u = (longitude / std::f64::consts::TAU + 0.5).rem_euclid(1.0);
    (u, 0.5 - latitude / std::f64::consts::PI)
}

impl FrameUniform {
    /// The uniform for a scene's camera, sun and exposure, for an image of
    /// the given size at time `time_s`.
    pub fn new(scene: &Scene, width: u32, height: u32, time_s: f32) -> Self {
        let camera = Camera::from_settings(&scene.camera, width, height);
        Self::with_camera(scene, &camera, width, height, time_s)
    }

    /// The uniform for a given camera (its pose and field of view) with the
    /// scene's sun and exposure.
    pub fn with_camera(
        scene: &Scene,
        camera: &Camera,
        width: u32,
        height: u32,
        time_s: f32,
    ) -> Self {
        Self::with_view(scene, &View::from_camera(camera), width, height, time_s)
    }

    /// The uniform for the caller's view with the scene's sun and exposure:
    /// nimbus's clip space (reverse-Z, infinite far plane for a perspective
    /// view) whatever the caller's depth convention.
    pub fn with_view(scene: &Scene, view: &View, width: u32, height: u32, time_s: f32) -> Self {
        let clip_from_world = view.nimbus_clip_from_world();
        let sun = scene.sun.direction();
        let pixel_size = view.pixel_size(height) as f32;
        let orthographic = view.is_orthographic();
        Self {
            clip_from_world: clip_from_world.as_mat4().to_cols_array_2d(),
            world_from_clip: clip_from_world.inverse().as_mat4().to_cols_array_2d(),
            camera_position_m: view.position_m().as_vec3().to_array(),
            time_s,
            sun_direction: sun.map(|c| c as f32),
            exposure_scale: exposure_scale_from_ev100(scene.camera.exposure_ev100) as f32,
            viewport_size_px: [width as f32, height as f32],
            // An orthographic pixel subtends no angle; the shaders that
            // filter by footprint read `orthographic_pixel_m` instead.
            pixel_angle_rad: if orthographic { 0.0 } else { pixel_size },
            sun_cos_angular_radius: SOLAR_DISK_ANGULAR_RADIUS_RAD.cos() as f32,
            max_pre_exposed: MAX_PRE_EXPOSED,
            auto_exposure: u32::from(scene.camera.auto_exposure),
            exposure_compensation_ev: scene.camera.exposure_compensation_ev as f32,
            adaptation_time_s: scene.camera.adaptation_time_s as f32,
            view_forward: view.forward().as_vec3().to_array(),
            orthographic_pixel_m: if orthographic { pixel_size } else { 0.0 },
        }
    }

    /// The clip-from-world transform as a matrix.
    pub fn clip_from_world(&self) -> Mat4 {
        Mat4::from_cols_array_2d(&self.clip_from_world)
    }
}

/// GPU resources of the frame uniform (group 0 of every pass).
pub type FrameBinding = crate::core::binding::UniformBinding<FrameUniform>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_pitch_follow_the_world_convention() {
        assert!((direction_from_yaw_pitch(0.0, 0.0) - DVec3::NEG_Z).length() < 1e-12);
        assert!((direction_from_yaw_pitch(90.0, 0.0) - DVec3::X).length() < 1e-12);
        assert!((direction_from_yaw_pitch(0.0, 89.0).y - 89f64.to_radians().sin()).abs() < 1e-12);
    }

    #[test]
    fn projection_is_reverse_z_and_centres_the_view_axis() {
        let settings = CameraSettings {
            position_m: [10.0, 50.0, 20.0],
            ..CameraSettings::default()
        };
        let cam = Camera::from_settings(&settings, 160, 90);
        let m = cam.clip_from_world();
        let ahead = m * (cam.position_m + cam.forward * 1000.0).extend(1.0);
        let (ndc_x, ndc_y, depth) = (ahead.x / ahead.w, ahead.y / ahead.w, ahead.z / ahead.w);
        assert!(ndc_x.abs() < 1e-9 && ndc_y.abs() < 1e-9);
        assert!(
            (depth - NEAR_PLANE_M / 1000.0).abs() < 1e-9,
            "reverse-Z depth {depth}"
        );
        let near = m * (cam.position_m + cam.forward * NEAR_PLANE_M).extend(1.0);
        assert!((near.z / near.w - 1.0).abs() < 1e-9);
    }

    #[test]
    fn cube_faces_tile_the_sphere_and_project_back() {
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..1000 {
            let d = DVec3::new(next(), next(), next());
            if d.length() < 1e-3 {
                continue;
            }
            let d = d.normalize();
            let (face, s, t) = CubeFace::project(d);
            assert!(s.abs() <= 1.0 + 1e-12 && t.abs() <= 1.0 + 1e-12);
            // The face's camera puts the direction at the same image point.
            let cam = Camera::cube_face(DVec3::ZERO, face, 64, 0);
            let clip = cam.clip_from_world() * (d * 100.0).extend(1.0);
            assert!((clip.x / clip.w - s).abs() < 1e-9, "{face:?} {d}");
            assert!((clip.y / clip.w - t).abs() < 1e-9, "{face:?} {d}");
        }
    }

    #[test]
    fn equirectangular_puts_north_at_the_centre_and_east_to_its_right() {
        assert!((equirectangular_direction(0.5, 0.5) - DVec3::NEG_Z).length() < 1e-12);
        assert!((equirectangular_direction(0.75, 0.5) - DVec3::X).length() < 1e-12);
        assert!((equirectangular_direction(0.0, 0.5) - DVec3::Z).length() < 1e-12);
        assert!((equirectangular_direction(0.3, 0.0) - DVec3::Y).length() < 1e-12);
        for (u, v) in [(0.1, 0.2), (0.5, 0.5), (0.9, 0.7), (0.6, 0.99)] {
            let (u2, v2) = equirectangular_uv(equirectangular_direction(u, v));
            assert!((u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12);
        }
    }

    #[test]
    fn straight_down_views_have_an_up_vector() {
        let settings = CameraSettings {
            position_m: [0.0, 100.0, 0.0],
            look_at_m: Some([0.0, 0.0, 0.0]),
            ..CameraSettings::default()
        };
        let cam = Camera::from_settings(&settings, 100, 100);
        assert!(cam.view_from_world().is_finite());
    }

    #[test]
    fn look_at_points_the_camera_at_the_target() {
        let settings = CameraSettings {
            position_m: [0.0, 100.0, 0.0],
            look_at_m: Some([1000.0, 100.0, 0.0]),
            ..CameraSettings::default()
        };
        let cam = Camera::from_settings(&settings, 100, 100);
        assert!((cam.forward - DVec3::X).length() < 1e-12);
    }
}
