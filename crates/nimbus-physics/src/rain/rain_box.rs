//! The rain box (Blanchard 2023, §4.2.1 and §4.2.5; Rousseau et al. 2008):
//! the region around the camera where drops are simulated, and the
//! recycling of drops that leave it.
//!
//! A drop that leaves re-enters on the side the flow comes from, so that
//! drops seem to arrive from outside the view instead of appearing out of
//! nothing. What crosses a piece of the boundary per unit time is the flux
//! of drops through it, area × max(0, −n·u) for the drop's velocity u
//! relative to that piece of boundary (which moves with the camera). The
//! seed picks a face with a CDF of the clamped cosines; weighting them by
//! area as well (its §4.2.5) and measuring u relative to the moving box
//! (its Fig. 33: no empty band on the side the camera moves to) makes the
//! CDF exactly that flux, so the box stays uniformly filled. For the
//! sphere, sampling a disc perpendicular to u uniformly and projecting it
//! onto the upstream hemisphere gives the same flux-weighted density
//! (cosine-weighted by construction). The new drop is then moved into the
//! box along u by a random fraction of one step's travel, so that drops
//! entering in the same step do not line up on the boundary.
//!
//! Shapes: a sphere centred on the camera (the default; turning the camera
//! changes nothing), an axis-aligned box, and the view frustum (fewest
//! drops for a given density; its faces sweep through space when the
//! camera turns, and the flux through a moving face accounts for that).

use glam::Vec3;

/// Shape and size of the rain box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RainBoxShape {
    /// A ball of `radius_m` around the camera.
    Sphere {
        /// Radius, m.
        radius_m: f32,
    },
    /// An axis-aligned box centred on the camera.
    Box {
        /// Half its sides, m.
        half_extent_m: Vec3,
    },
    /// The view frustum from `near_m` to `far_m`.
    Frustum {
        /// Near distance along the view axis, m.
        near_m: f32,
        /// Far distance along the view axis, m.
        far_m: f32,
        /// tan of half the vertical field of view.
        tan_half_fov_y: f32,
        /// Width over height.
        aspect: f32,
    },
}

/// The rain box at one instant: its shape placed at the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RainBox {
    /// Shape and size.
    pub shape: RainBoxShape,
    /// The camera position (the box's origin), m.
    pub center_m: Vec3,
    /// Camera basis (frustum only): right, up, forward (unit vectors).
    pub basis: [Vec3; 3],
    /// Velocity of the box (the camera's), m/s.
    pub velocity_m_s: Vec3,
    /// Angular velocity of the box (the camera's turning; frustum only), rad/s.
    pub angular_velocity_rad_s: Vec3,
}

/// One planar face: its corners (a quad, counter-clockwise seen from
/// outside) and outward unit normal.
#[derive(Clone, Copy, Debug)]
struct Face {
    corners: [Vec3; 4],
    normal: Vec3,
}

fn triangle_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    0.5 * (b - a).cross(c - a).length()
}

impl Face {
    fn area(&self) -> f32 {
        let [a, b, c, d] = self.corners;
        triangle_area(a, b, c) + triangle_area(a, c, d)
    }

    fn centroid(&self) -> Vec3 {
        (self.corners[0] + self.corners[1] + self.corners[2] + self.corners[3]) * 0.25
    }

    /// A point uniform on the quad from three uniforms (one picks the triangle).
    fn sample(&self, u0: f32, u1: f32, u2: f32) -> Vec3 {
        let [a, b, c, d] = self.corners;
        let first = triangle_area(a, b, c);
        let total = first + triangle_area(a, c, d);
        let (p, q, r) = if u0 * total < first {
            (a, b, c)
        } else {
            (a, c, d)
        };
        // Uniform in a triangle: fold the unit square's upper half.
        let (mut s, mut t) = (u1, u2);
        if s + t > 1.0 {
            s = 1.0 - s;
            t = 1.0 - t;
        }
        p + (q - p) * s + (r - p) * t
    }
}

/// A unit vector orthogonal to `n`, and a second one completing the frame
/// (Duff et al., "Building an orthonormal basis, revisited", JCGT 6(1), 2017).
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

impl RainBox {
    /// A box with no motion.
    pub fn at_rest(shape: RainBoxShape, center_m: Vec3, basis: [Vec3; 3]) -> Self {
        Self {
            shape,
            center_m,
            basis,
            velocity_m_s: Vec3::ZERO,
            angular_velocity_rad_s: Vec3::ZERO,
        }
    }

    /// Volume, m³.
    pub fn volume_m3(&self) -> f32 {
        match self.shape {
            RainBoxShape::Sphere { radius_m } => {
                4.0 / 3.0 * std::f32::consts::PI * radius_m.powi(3)
            }
            RainBoxShape::Box { half_extent_m } => {
                8.0 * half_extent_m.x * half_extent_m.y * half_extent_m.z
            }
            RainBoxShape::Frustum {
                near_m,
                far_m,
                tan_half_fov_y,
                aspect,
            } => {
                4.0 * tan_half_fov_y * tan_half_fov_y * aspect * (far_m.powi(3) - near_m.powi(3))
                    / 3.0
            }
        }
    }

    /// Radius of the smallest ball about the camera holding the box, m.
    pub fn bounding_radius_m(&self) -> f32 {
        match self.shape {
            RainBoxShape::Sphere { radius_m } => radius_m,
            RainBoxShape::Box { half_extent_m } => half_extent_m.length(),
            RainBoxShape::Frustum {
                far_m,
                tan_half_fov_y,
                aspect,
                ..
            } => far_m * (1.0 + tan_half_fov_y * tan_half_fov_y * (1.0 + aspect * aspect)).sqrt(),
        }
    }

    /// Whether `p` is inside the box.
    pub fn contains(&self, p: Vec3) -> bool {
        let d = p - self.center_m;
        match self.shape {
            RainBoxShape::Sphere { radius_m } => d.length_squared() <= radius_m * radius_m,
            RainBoxShape::Box { half_extent_m } => {
                d.x.abs() <= half_extent_m.x
                    && d.y.abs() <= half_extent_m.y
                    && d.z.abs() <= half_extent_m.z
            }
            RainBoxShape::Frustum {
                near_m,
                far_m,
                tan_half_fov_y,
                aspect,
            } => {
                let [right, up, forward] = self.basis;
                let z = d.dot(forward);
                z >= near_m
                    && z <= far_m
                    && d.dot(right).abs() <= z * tan_half_fov_y * aspect
                    && d.dot(up).abs() <= z * tan_half_fov_y
            }
        }
    }

    /// The box's faces (box and frustum), counter-clockwise from outside.
    fn faces(&self) -> [Face; 6] {
        let c = self.center_m;
        let corners: [Vec3; 8] = match self.shape {
            RainBoxShape::Box { half_extent_m: h } => {
                // Index bits: x (1), y (2), z (4).
                std::array::from_fn(|i| {
                    c + Vec3::new(
                        if i & 1 == 0 { -h.x } else { h.x },
                        if i & 2 == 0 { -h.y } else { h.y },
                        if i & 4 == 0 { -h.z } else { h.z },
                    )
                })
            }
            RainBoxShape::Frustum {
                near_m,
                far_m,
                tan_half_fov_y,
                aspect,
            } => {
                let [right, up, forward] = self.basis;
                std::array::from_fn(|i| {
                    let z = if i & 4 == 0 { near_m } else { far_m };
                    let x = if i & 1 == 0 { -1.0 } else { 1.0 } * z * tan_half_fov_y * aspect;
                    let y = if i & 2 == 0 { -1.0 } else { 1.0 } * z * tan_half_fov_y;
                    c + right * x + up * y + forward * z
                })
            }
            RainBoxShape::Sphere { .. } => [c; 8],
        };
        // Each face as four corner indices; the normal is taken from the
        // corners and turned outwards by comparing with the centroid.
        const QUADS: [[usize; 4]; 6] = [
            [0, 2, 6, 4], // −x
            [1, 5, 7, 3], // +x
            [0, 4, 5, 1], // −y
            [2, 3, 7, 6], // +y
            [0, 1, 3, 2], // −z
            [4, 6, 7, 5], // +z
        ];
        let middle = corners.iter().copied().sum::<Vec3>() / 8.0;
        QUADS.map(|q| {
            let quad = q.map(|i| corners[i]);
            let mut normal = (quad[2] - quad[0])
                .cross(quad[3] - quad[1])
                .normalize_or_zero();
            let centroid = (quad[0] + quad[1] + quad[2] + quad[3]) * 0.25;
            if normal.dot(centroid - middle) < 0.0 {
                normal = -normal;
            }
            Face {
                corners: quad,
                normal,
            }
        })
    }

    /// Velocity of the box's boundary at `p` (translation and turning), m/s.
    fn boundary_velocity_m_s(&self, p: Vec3) -> Vec3 {
        self.velocity_m_s + self.angular_velocity_rad_s.cross(p - self.center_m)
    }

    /// A point uniform in the box from three uniforms.
    pub fn sample_inside(&self, u: [f32; 3]) -> Vec3 {
        let c = self.center_m;
        match self.shape {
            RainBoxShape::Sphere { radius_m } => {
                let z = 1.0 - 2.0 * u[0];
                let ring = (1.0 - z * z).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * u[1];
                let r = radius_m * u[2].cbrt();
                c + Vec3::new(ring * phi.cos(), z, ring * phi.sin()) * r
            }
            RainBoxShape::Box { half_extent_m } => {
                c + (Vec3::from_array(u) * 2.0 - Vec3::ONE) * half_extent_m
            }
            RainBoxShape::Frustum {
                near_m,
                far_m,
                tan_half_fov_y,
                aspect,
            } => {
                // Depth with density ∝ z² (the cross-section's area), by
                // inverting its CDF; then uniform across the section.
                let (n3, f3) = (near_m.powi(3), far_m.powi(3));
                let z = (n3 + u[2] * (f3 - n3)).cbrt();
                let [right, up, forward] = self.basis;
                c + right * ((2.0 * u[0] - 1.0) * z * tan_half_fov_y * aspect)
                    + up * ((2.0 * u[1] - 1.0) * z * tan_half_fov_y)
                    + forward * z
            }
        }
    }

    /// Rate at which drops moving at `velocity_m_s` (world) cross into the
    /// box per unit of their density, m³/s: ∫ max(0, −n·u) dA over the
    /// boundary, u the velocity relative to the boundary.
    pub fn inflow_rate_m3_s(&self, velocity_m_s: Vec3) -> f32 {
        match self.shape {
            RainBoxShape::Sphere { radius_m } => {
                std::f32::consts::PI
                    * radius_m
                    * radius_m
                    * (velocity_m_s - self.velocity_m_s).length()
            }
            _ => self
                .faces()
                .iter()
                .map(|f| {
                    let u = velocity_m_s - self.boundary_velocity_m_s(f.centroid());
                    f.area() * (-f.normal.dot(u)).max(0.0)
                })
                .sum(),
        }
    }

    /// Where a drop moving at `velocity_m_s` (world) re-enters: a point on
    /// the boundary drawn with the density of the drops' flux through it,
    /// then moved inwards along the relative velocity by `u[3]` of one
    /// step's travel (`dt_s`). `None` when nothing flows in (a drop at rest
    /// relative to the box). The point may lie outside again when a step's
    /// travel exceeds the box; the caller tests it.
    pub fn sample_inflow(&self, velocity_m_s: Vec3, u: [f32; 4], dt_s: f32) -> Option<Vec3> {
        match self.shape {
            RainBoxShape::Sphere { radius_m } => {
                let relative = velocity_m_s - self.velocity_m_s;
                let speed = relative.length();
                if speed < 1e-6 {
                    return None;
                }
                let flow = relative / speed;
                let (t1, t2) = orthonormal_basis(flow);
                let r = radius_m * u[0].sqrt();
                let phi = std::f32::consts::TAU * u[1];
                let disc = t1 * (r * phi.cos()) + t2 * (r * phi.sin());
                let depth = (radius_m * radius_m - r * r).max(0.0).sqrt();
                Some(self.center_m + disc - flow * depth + relative * (u[3] * dt_s))
            }
            _ => {
                let faces = self.faces();
                let weights = faces.map(|f| {
                    let relative = velocity_m_s - self.boundary_velocity_m_s(f.centroid());
                    (f.area() * (-f.normal.dot(relative)).max(0.0), relative)
                });
                let total: f32 = weights.iter().map(|w| w.0).sum();
                if total <= 0.0 {
                    return None;
                }
                // The discrete CDF over the faces (Blanchard 2023, Fig. 32),
                // and a remapped uniform to place the point on the face.
                let target = u[0] * total;
                let mut cumulative = 0.0;
                for (face, (weight, relative)) in faces.iter().zip(weights) {
                    if weight <= 0.0 {
                        continue;
                    }
                    if target <= cumulative + weight {
                        let within = ((target - cumulative) / weight).clamp(0.0, 1.0);
                        let p = face.sample(within, u[1], u[2]);
                        return Some(p + relative * (u[3] * dt_s));
                    }
                    cumulative += weight;
                }
                // Rounding left the target past the last positive weight.
                let (face, (_, relative)) = faces
                    .iter()
                    .zip(weights)
                    .rev()
                    .find(|(_, (w, _))| *w > 0.0)?;
                Some(face.sample(0.5, u[1], u[2]) + relative * (u[3] * dt_s))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rain::random::uniform;

    fn boxes() -> Vec<RainBox> {
        let basis = [Vec3::X, Vec3::Y, -Vec3::Z];
        let c = Vec3::new(10.0, 50.0, -3.0);
        vec![
            RainBox::at_rest(RainBoxShape::Sphere { radius_m: 12.0 }, c, basis),
            RainBox::at_rest(
                RainBoxShape::Box {
                    half_extent_m: Vec3::new(8.0, 5.0, 11.0),
                },
                c,
                basis,
            ),
            RainBox::at_rest(
                RainBoxShape::Frustum {
                    near_m: 1.0,
                    far_m: 20.0,
                    tan_half_fov_y: 0.5,
                    aspect: 1.6,
                },
                c,
                basis,
            ),
        ]
    }

    #[test]
    fn volumes_match_monte_carlo_and_samples_are_inside() {
        for b in boxes() {
            let r = b.bounding_radius_m();
            let n = 1_000_000;
            let mut inside = 0;
            for i in 0..n {
                let p = b.center_m
                    + Vec3::new(uniform(i, 0, 0), uniform(i, 0, 1), uniform(i, 0, 2)) * 2.0 * r
                    - Vec3::splat(r);
                inside += b.contains(p) as u32;
                let q = b.sample_inside([uniform(i, 1, 0), uniform(i, 1, 1), uniform(i, 1, 2)]);
                assert!(
                    b.contains(q + (b.center_m - q) * 1e-5),
                    "{:?}: {q}",
                    b.shape
                );
            }
            let estimate = inside as f32 / n as f32 * (2.0 * r).powi(3);
            let exact = b.volume_m3();
            assert!(
                (estimate - exact).abs() < 0.02 * exact,
                "{:?}: {estimate} vs {exact}",
                b.shape
            );
        }
    }

    #[test]
    fn inflow_points_lie_on_the_upstream_boundary() {
        let wind = Vec3::new(4.0, -7.0, 1.5);
        for b in boxes() {
            for i in 0..2000 {
                let u = [0, 1, 2, 3].map(|k| uniform(i, 9, k));
                let on_boundary = b
                    .sample_inflow(wind, [u[0], u[1], u[2], 0.0], 0.01)
                    .expect("inflow");
                // Just outside along −wind, just inside along +wind.
                assert!(
                    !b.contains(on_boundary - wind * 1e-5),
                    "{:?}: {on_boundary}",
                    b.shape
                );
                assert!(
                    b.contains(on_boundary + wind * 1e-5),
                    "{:?}: {on_boundary} {u:?}",
                    b.shape
                );
            }
        }
    }

    #[test]
    fn inflow_rate_is_the_flux_through_the_boundary() {
        // Uniform flow through a convex body: the inflow rate is the
        // body's area projected on the plane normal to the flow, times the speed.
        let v = Vec3::new(0.0, -6.0, 0.0);
        let [sphere, aabb, _] = boxes().try_into().expect("three boxes");
        let expected_sphere = std::f32::consts::PI * 144.0 * 6.0;
        assert!((sphere.inflow_rate_m3_s(v) - expected_sphere).abs() < 1e-2 * expected_sphere);
        let expected_box = 16.0 * 22.0 * 6.0;
        assert!((aabb.inflow_rate_m3_s(v) - expected_box).abs() < 1e-3 * expected_box);
    }
}
