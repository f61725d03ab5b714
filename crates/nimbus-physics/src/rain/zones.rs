//! Where it rains: a map of rain factors in [0, 1] over the ground, scaling
//! the scene's intensity. Blanchard (2023, §5) proposes rain only under the
//! clouds; Puig-Centelles, Ripolles & Chover ("Creation and control of rain
//! in virtual environments", The Visual Computer 25, 2009) define rain
//! areas with gradual transitions at their borders, which is what the
//! smooth edges here do.
//!
//! The map is a grid of factors over a square of the ground, sampled
//! bilinearly (texel centres at (i + ½)·texel, clamped at the edges): the
//! GPU samples the same grid the same way.

/// A circular rain area with a soft edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RainArea {
    /// Centre (x, z), m.
    pub center_m: [f32; 2],
    /// Radius where the factor has fallen to 0, m.
    pub radius_m: f32,
    /// Width of the transition inside the radius, m.
    pub edge_m: f32,
}

/// Smooth Hermite step from 0 at `a` to 1 at `b`.
pub fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl RainArea {
    /// The area's factor at (x, z).
    pub fn factor_at(&self, x_m: f32, z_m: f32) -> f32 {
        let r = ((x_m - self.center_m[0]).powi(2) + (z_m - self.center_m[1]).powi(2)).sqrt();
        1.0 - smoothstep(self.radius_m - self.edge_m.max(1e-3), self.radius_m, r)
    }
}

/// The map of rain factors.
#[derive(Clone, Debug, PartialEq)]
pub struct RainZones {
    /// (x, z) of the map's corner, m.
    pub origin_m: [f32; 2],
    /// Texel size, m.
    pub texel_m: f32,
    /// Texels per side.
    pub size: u32,
    /// Factors, row-major (x fastest), in [0, 1].
    pub factors: Vec<f32>,
}

impl RainZones {
    /// Rain everywhere (a 1×1 map of 1).
    pub fn everywhere() -> Self {
        Self {
            origin_m: [0.0, 0.0],
            texel_m: 1.0,
            size: 1,
            factors: vec![1.0],
        }
    }

    /// A map of `size`² texels over the square of side `side_m` centred on
    /// `center_m`, each texel the value of `factor(x, z)` at its centre
    /// (rows in parallel: the renderer rebuilds the map as clouds drift).
    pub fn from_fn(
        center_m: [f32; 2],
        side_m: f32,
        size: u32,
        factor: impl Fn(f32, f32) -> f32 + Sync,
    ) -> Self {
        use rayon::prelude::*;
        let size = size.max(1);
        let texel_m = side_m / size as f32;
        let origin_m = [center_m[0] - 0.5 * side_m, center_m[1] - 0.5 * side_m];
        let mut factors = vec![0.0; (size * size) as usize];
        factors
            .par_chunks_mut(size as usize)
            .enumerate()
            .for_each(|(j, row)| {
                let z = origin_m[1] + (j as f32 + 0.5) * texel_m;
                for (i, texel) in row.iter_mut().enumerate() {
                    let x = origin_m[0] + (i as f32 + 0.5) * texel_m;
                    *texel = factor(x, z).clamp(0.0, 1.0);
                }
            });
        Self {
            origin_m,
            texel_m,
            size,
            factors,
        }
    }

    /// The factor at (x, z), bilinear between texel centres, clamped at the edges.
    pub fn factor_at(&self, x_m: f32, z_m: f32) -> f32 {
        let n = self.size as i32;
        let gx = (x_m - self.origin_m[0]) / self.texel_m - 0.5;
        let gz = (z_m - self.origin_m[1]) / self.texel_m - 0.5;
        let (fx, fz) = (gx.floor(), gz.floor());
        let (tx, tz) = (gx - fx, gz - fz);
        let at =
            |i: i32, j: i32| self.factors[(i.clamp(0, n - 1) + n * j.clamp(0, n - 1)) as usize];
        let (i, j) = (fx as i32, fz as i32);
        let a = at(i, j) + (at(i + 1, j) - at(i, j)) * tx;
        let b = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * tx;
        a + (b - a) * tz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn areas_have_soft_edges_and_the_map_interpolates_them() {
        let area = RainArea {
            center_m: [100.0, -50.0],
            radius_m: 500.0,
            edge_m: 200.0,
        };
        assert_eq!(area.factor_at(100.0, -50.0), 1.0);
        assert_eq!(area.factor_at(700.0, -50.0), 0.0);
        let mid = area.factor_at(500.0, -50.0);
        assert!((mid - 0.5).abs() < 1e-5, "{mid}");
        let map = RainZones::from_fn([0.0, 0.0], 2000.0, 128, |x, z| area.factor_at(x, z));
        for (x, z) in [
            (100.0, -50.0),
            (430.0, 80.0),
            (-300.0, 10.0),
            (520.0, -60.0),
        ] {
            let (a, b) = (area.factor_at(x, z), map.factor_at(x, z));
            assert!((a - b).abs() < 0.02, "({x}, {z}): {a} vs {b}");
        }
        assert_eq!(RainZones::everywhere().factor_at(1e6, -1e6), 1.0);
    }
}
