//! The caller's view: where the image is seen from and how it is projected,
//! in the caller's own conventions.
//!
//! An embedding renderer has a camera of its own: a world-from-view
//! transform (any orientation, straight up and down included) and a
//! projection matrix that may be perspective or orthographic, with a finite
//! or infinite far plane, writing depth 0 → 1 or reverse-Z 1 → 0. [`View`]
//! describes all of these. Inside, nimbus always draws with its own
//! convention, reverse-Z with the far plane at infinity for a perspective view
//! ([`View::nimbus_clip_from_view`]), and translates the caller's depth into
//! it ([`View::nimbus_depth_from_caller_depth`]); the scene file's camera is
//! one such view ([`View::from_camera`]).

use super::Camera;
use glam::{DMat4, DVec3, DVec4};

/// How a view projects onto the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// A pinhole camera.
    Perspective {
        /// Vertical field of view, rad, in (0, π).
        fov_y_rad: f64,
        /// Image width over height.
        aspect: f64,
        /// Distance of the near clip plane, m (> 0).
        near_m: f64,
        /// Distance of the far clip plane, m, or `None` for a plane at
        /// infinity. Only the caller's depth values depend on it: nimbus
        /// draws the sky and clouds to the horizon either way.
        far_m: Option<f64>,
    },
    /// Parallel rays along the view direction (e.g. a map seen from above).
    Orthographic {
        /// Height of the image, m.
        height_m: f64,
        /// Image width over height.
        aspect: f64,
        /// Distance of the near clip plane along the view direction, m (may be
        /// negative: the plane behind the view's origin).
        near_m: f64,
        /// Distance of the far clip plane, m (> `near_m`); nothing beyond is drawn.
        far_m: f64,
    },
}

/// Which depth values a projection writes at its near and far planes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DepthConvention {
    /// 0 at the near plane, 1 at the far plane (wgpu's and Direct3D's default).
    Standard,
    /// 1 at the near plane, 0 at the far plane: better precision far away;
    /// nimbus's own convention.
    #[default]
    Reverse,
}

/// The caller's view of one frame: pose, projection and depth convention.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// World space (metres, +Y up, the scene's frame) from view space
    /// (right-handed: +X right, +Y up in the image, looking down −Z). A rigid
    /// transform: rotation and translation, no scale.
    pub world_from_view: DMat4,
    /// The projection.
    pub projection: Projection,
    /// The depth values the caller's projection writes.
    pub depth: DepthConvention,
}

/// Why a [`View`] cannot be drawn.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("view: {0}")]
pub struct ViewError(String);

/// Largest deviation from a rigid world-from-view transform accepted (its
/// rotation part must be orthonormal to this tolerance).
const RIGID_TOLERANCE: f64 = 1e-3;

impl View {
    /// A perspective view from a pose (eye position and a world-from-view
    /// rotation given by the view direction and the image's up vector) with
    /// nimbus's depth convention (reverse-Z) and an infinite far plane.
    pub fn perspective(
        eye_m: DVec3,
        forward: DVec3,
        up: DVec3,
        fov_y_rad: f64,
        aspect: f64,
        near_m: f64,
    ) -> Self {
        Self {
            world_from_view: DMat4::look_to_rh(eye_m, forward, up).inverse(),
            projection: Projection::Perspective {
                fov_y_rad,
                aspect,
                near_m,
                far_m: None,
            },
            depth: DepthConvention::Reverse,
        }
    }

    /// The view of a scene camera (pinhole, reverse-Z, infinite far plane,
    /// near plane at [`super::NEAR_PLANE_M`]).
    pub fn from_camera(camera: &Camera) -> Self {
        Self::perspective(
            camera.position_m,
            camera.forward,
            camera.up,
            camera.fov_y_rad,
            camera.aspect,
            super::NEAR_PLANE_M,
        )
    }

    /// Checks that the view can be drawn: finite, rigid pose; field of view
    /// in (0, 179°]; positive aspect and sizes; near plane before the far one.
    pub fn check(&self) -> Result<(), ViewError> {
        let m = self.world_from_view;
        if !m.is_finite() {
            return Err(ViewError(
                "world_from_view has a value that is not finite".into(),
            ));
        }
        let (x, y, z) = (
            m.x_axis.truncate(),
            m.y_axis.truncate(),
            m.z_axis.truncate(),
        );
        let deviation = [
            x.length() - 1.0,
            y.length() - 1.0,
            z.length() - 1.0,
            x.dot(y),
            y.dot(z),
            z.dot(x),
            x.cross(y).dot(z) - 1.0,
        ]
        .into_iter()
        .fold(0.0f64, |a, d| a.max(d.abs()));
        if deviation > RIGID_TOLERANCE || m.row(3) != DVec4::W {
            return Err(ViewError(format!(
                "world_from_view is not a rotation and a translation (deviation {deviation:.3e}, allowed {RIGID_TOLERANCE:e})"
            )));
        }
        let positive = |name: &str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(ViewError(format!(
                    "{name} = {value}: must be finite and > 0"
                )))
            }
        };
        match self.projection {
            Projection::Perspective {
                fov_y_rad,
                aspect,
                near_m,
                far_m,
            } => {
                // Below 1e-4 rad the pinhole's f32 transforms lose the
                // pixel; such a view is a telescope's, not a sky renderer's.
                let max_fov = 179f64.to_radians();
                if !(MIN_FOV_Y_RAD..=max_fov).contains(&fov_y_rad) {
                    return Err(ViewError(format!(
                        "fov_y_rad = {fov_y_rad}: must be in [{MIN_FOV_Y_RAD:e}, {max_fov:.4}] (179°)"
                    )));
                }
                positive("aspect", aspect)?;
                positive("near_m", near_m)?;
                if let Some(far_m) = far_m
                    && !(far_m.is_finite() && far_m > near_m)
                {
                    return Err(ViewError(format!(
                        "far_m = {far_m}: must be finite and greater than near_m = {near_m} (None for infinity)"
                    )));
                }
            }
            Projection::Orthographic {
                height_m,
                aspect,
                near_m,
                far_m,
            } => {
                positive("height_m", height_m)?;
                positive("aspect", aspect)?;
                if !near_m.is_finite() {
                    return Err(ViewError(format!("near_m = {near_m}: must be finite")));
                }
                if !(far_m.is_finite() && far_m > near_m) {
                    return Err(ViewError(format!(
                        "far_m = {far_m}: must be finite and greater than near_m = {near_m}"
                    )));
                }
            }
        }
        Ok(())
    }

    /// The eye's position (the view's origin), world metres.
    pub fn position_m(&self) -> DVec3 {
        self.world_from_view.w_axis.truncate()
    }

    /// Unit view direction in world space (the view's −Z).
    pub fn forward(&self) -> DVec3 {
        -self.world_from_view.z_axis.truncate().normalize()
    }

    /// Unit vector pointing up in the image, world space (the view's +Y).
    pub fn up(&self) -> DVec3 {
        self.world_from_view.y_axis.truncate().normalize()
    }

    /// View space from world space.
    pub fn view_from_world(&self) -> DMat4 {
        self.world_from_view.inverse()
    }

    /// Whether the projection is orthographic.
    pub fn is_orthographic(&self) -> bool {
        matches!(self.projection, Projection::Orthographic { .. })
    }

    /// The caller's clip space from view space: the projection in the
    /// caller's depth convention.
    pub fn caller_clip_from_view(&self) -> DMat4 {
        self.clip_from_view_with(self.depth, false)
    }

    /// nimbus's clip space from view space: reverse-Z, and for a
    /// perspective view the far plane at infinity (the sky and clouds reach
    /// the horizon whatever the caller's far plane).
    pub fn nimbus_clip_from_view(&self) -> DMat4 {
        self.clip_from_view_with(DepthConvention::Reverse, true)
    }

    /// nimbus's clip space from world space.
    pub fn nimbus_clip_from_world(&self) -> DMat4 {
        self.nimbus_clip_from_view() * self.view_from_world()
    }

    fn clip_from_view_with(&self, depth: DepthConvention, infinite: bool) -> DMat4 {
        let reverse = depth == DepthConvention::Reverse;
        match self.projection {
            Projection::Perspective {
                fov_y_rad,
                aspect,
                near_m,
                far_m,
            } => match (far_m.filter(|_| !infinite), reverse) {
                (None, true) => DMat4::perspective_infinite_reverse_rh(fov_y_rad, aspect, near_m),
                (None, false) => DMat4::perspective_infinite_rh(fov_y_rad, aspect, near_m),
                // glam maps its first plane to 0 and its second to 1:
                // swapping them gives reverse-Z.
                (Some(far_m), true) => DMat4::perspective_rh(fov_y_rad, aspect, far_m, near_m),
                (Some(far_m), false) => DMat4::perspective_rh(fov_y_rad, aspect, near_m, far_m),
            },
            Projection::Orthographic {
                height_m,
                aspect,
                near_m,
                far_m,
            } => {
                let (half_w, half_h) = (0.5 * height_m * aspect, 0.5 * height_m);
                let (zero, one) = if reverse {
                    (far_m, near_m)
                } else {
                    (near_m, far_m)
                };
                DMat4::orthographic_rh(-half_w, half_w, -half_h, half_h, zero, one)
            }
        }
    }

    /// The depth the caller's projection writes at its far plane (what the
    /// caller clears its depth buffer to): 1, or 0 under reverse-Z.
    pub fn caller_far_depth(&self) -> f32 {
        match self.depth {
            DepthConvention::Standard => 1.0,
            DepthConvention::Reverse => 0.0,
        }
    }

    /// nimbus's clip space from the caller's clip space: maps a pixel's
    /// (x, y, caller depth, 1) to nimbus's homogeneous clip position, whose
    /// z / w is nimbus's depth of the same point.
    pub fn nimbus_clip_from_caller_clip(&self) -> DMat4 {
        self.nimbus_clip_from_view() * self.caller_clip_from_view().inverse()
    }

    /// nimbus's depth of the point the caller's depth buffer holds at
    /// normalised device coordinates `ndc_xy`; the caller's far plane (and
    /// anything beyond) maps to nimbus's far plane, 0. The CPU twin of
    /// `depth_import.wgsl`.
    pub fn nimbus_depth_from_caller_depth(&self, ndc_xy: [f64; 2], caller_depth: f64) -> f64 {
        if caller_depth == f64::from(self.caller_far_depth()) {
            return 0.0;
        }
        let p = self.nimbus_clip_from_caller_clip()
            * DVec4::new(ndc_xy[0], ndc_xy[1], caller_depth, 1.0);
        (p.z / p.w).clamp(0.0, 1.0)
    }

    /// A pinhole camera standing for this view where a pass needs one (the
    /// rain box around the eye, the level of detail of distant clouds): the
    /// view's own for a perspective view; for an orthographic view, one at
    /// its origin with a 60° field of view.
    pub fn pinhole(&self, height_px: u32) -> Camera {
        let (fov_y_rad, aspect) = match self.projection {
            Projection::Perspective {
                fov_y_rad, aspect, ..
            } => (fov_y_rad, aspect),
            Projection::Orthographic { aspect, .. } => (60f64.to_radians(), aspect),
        };
        Camera {
            position_m: self.position_m(),
            forward: self.forward(),
            up: self.up(),
            fov_y_rad,
            aspect,
            height_px: height_px.max(1),
        }
    }

    /// Angle subtended by one pixel at the image centre, rad (perspective),
    /// or the side of a pixel, m (orthographic).
    pub(crate) fn pixel_size(&self, height_px: u32) -> f64 {
        let height_px = f64::from(height_px.max(1));
        match self.projection {
            Projection::Perspective { fov_y_rad, .. } => 2.0 * (0.5 * fov_y_rad).tan() / height_px,
            Projection::Orthographic { height_m, .. } => height_m / height_px,
        }
    }
}

/// Smallest vertical field of view a [`View`] may have, rad.
pub const MIN_FOV_Y_RAD: f64 = 1e-4;

#[cfg(test)]
mod tests {
    use super::*;

    fn views() -> Vec<View> {
        let eye = DVec3::new(100.0, 1500.0, -40.0);
        let mut out = Vec::new();
        for depth in [DepthConvention::Standard, DepthConvention::Reverse] {
            for projection in [
                Projection::Perspective {
                    fov_y_rad: 1.0,
                    aspect: 1.5,
                    near_m: 0.1,
                    far_m: None,
                },
                Projection::Perspective {
                    fov_y_rad: 0.7,
                    aspect: 0.8,
                    near_m: 2.0,
                    far_m: Some(5000.0),
                },
                Projection::Orthographic {
                    height_m: 3000.0,
                    aspect: 1.2,
                    near_m: -100.0,
                    far_m: 4000.0,
                },
            ] {
                // Straight down, north at the top of the image.
                let mut view = View::perspective(eye, DVec3::NEG_Y, DVec3::NEG_Z, 1.0, 1.0, 1.0);
                view.projection = projection;
                view.depth = depth;
                out.push(view);
            }
        }
        out
    }

    #[test]
    fn caller_depth_translates_to_nimbus_depth_of_the_same_point() {
        for view in views() {
            view.check().expect("a valid view");
            let caller = view.caller_clip_from_view() * view.view_from_world();
            let nimbus = view.nimbus_clip_from_world();
            // Points straight below and off-axis, at distances inside the frustum.
            for (dx, dz, distance) in [(0.0, 0.0, 30.0), (50.0, -80.0, 900.0), (-10.0, 5.0, 3000.0)]
            {
                let p = view.position_m() + DVec3::new(dx, -distance, dz);
                let c = caller * p.extend(1.0);
                let n = nimbus * p.extend(1.0);
                let (ndc, caller_depth) = ([c.x / c.w, c.y / c.w], c.z / c.w);
                assert!(
                    (0.0..=1.0).contains(&caller_depth),
                    "{view:?} {caller_depth}"
                );
                // Same pixel in both conventions.
                assert!((n.x / n.w - ndc[0]).abs() < 1e-9 && (n.y / n.w - ndc[1]).abs() < 1e-9);
                let translated = view.nimbus_depth_from_caller_depth(ndc, caller_depth);
                assert!(
                    (translated - n.z / n.w).abs() < 1e-6,
                    "{view:?}: {translated} vs {}",
                    n.z / n.w
                );
            }
            assert_eq!(
                view.nimbus_depth_from_caller_depth(
                    [0.3, -0.2],
                    f64::from(view.caller_far_depth())
                ),
                0.0
            );
        }
    }

    #[test]
    fn nimbus_clip_space_is_reverse_z() {
        for view in views() {
            let m = view.nimbus_clip_from_view();
            let near = match view.projection {
                Projection::Perspective { near_m, .. }
                | Projection::Orthographic { near_m, .. } => near_m,
            };
            let p = m * DVec4::new(0.0, 0.0, -near, 1.0);
            assert!((p.z / p.w - 1.0).abs() < 1e-9, "{view:?}");
        }
    }

    #[test]
    fn the_scene_camera_is_a_view() {
        let settings = crate::scene::CameraSettings {
            position_m: [10.0, 50.0, 20.0],
            ..Default::default()
        };
        let camera = Camera::from_settings(&settings, 160, 90);
        let view = View::from_camera(&camera);
        view.check().expect("a valid view");
        let difference = (view.nimbus_clip_from_world() - camera.clip_from_world()).abs();
        assert!(difference.to_cols_array().iter().all(|d| *d < 1e-9));
        let pinhole = view.pinhole(90);
        assert!((pinhole.forward - camera.forward).length() < 1e-12);
        assert!((pinhole.up - camera.up).length() < 1e-12);
    }

    #[test]
    fn bad_views_are_refused_with_the_value() {
        let good = View::perspective(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y, 1.0, 1.0, 0.5);
        let mut scaled = good;
        scaled.world_from_view = DMat4::from_scale(DVec3::splat(2.0));
        assert!(
            scaled
                .check()
                .expect_err("refused")
                .to_string()
                .contains("rotation")
        );
        let mut wide = good;
        wide.projection = Projection::Perspective {
            fov_y_rad: 3.2,
            aspect: 1.0,
            near_m: 0.5,
            far_m: None,
        };
        assert!(
            wide.check()
                .expect_err("refused")
                .to_string()
                .contains("fov_y_rad = 3.2")
        );
        let mut tiny = good;
        tiny.projection = Projection::Perspective {
            fov_y_rad: 1e-200,
            aspect: 1.0,
            near_m: 0.5,
            far_m: None,
        };
        assert!(tiny.check().is_err());
        let mut inverted = good;
        inverted.projection = Projection::Orthographic {
            height_m: 10.0,
            aspect: 1.0,
            near_m: 5.0,
            far_m: 1.0,
        };
        assert!(
            inverted
                .check()
                .expect_err("refused")
                .to_string()
                .contains("far_m = 1")
        );
    }
}
