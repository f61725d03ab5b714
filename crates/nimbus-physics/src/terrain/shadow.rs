//! Sun visibility on the terrain: which parts of the heightfield see the sun.
//!
//! For every grid vertex, the heightfield is marched towards the sun, one
//! grid cell of horizontal distance per step, and the largest elevation angle
//! of the terrain ahead (the horizon in the sun's azimuth) is compared with
//! the sun's elevation. The visible fraction of the solar disk is taken as a
//! smooth step over the disk's angular diameter; between vertices the
//! renderer interpolates, which softens shadow edges over one grid cell.
//! Horizon-angle shadowing of heightfields follows Max,
//! "Horizon mapping: shadows for bump-mapped surfaces", The Visual Computer 4,
//! 1988.

use super::Terrain;
use crate::sky::SOLAR_DISK_ANGULAR_RADIUS_RAD;
use rayon::prelude::*;

fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Fraction of the solar disk visible from each vertex of the rendered
/// surface (water surface included), in [0, 1], for a unit sun direction.
pub fn sun_visibility(terrain: &Terrain, sun_direction: [f64; 3]) -> Vec<f32> {
    let n = terrain.vertices_per_side();
    let [dx, dy, dz] = sun_direction;
    let sun_elevation = dy.clamp(-1.0, 1.0).asin();
    let horizontal = (dx * dx + dz * dz).sqrt();
    if sun_elevation < -SOLAR_DISK_ANGULAR_RADIUS_RAD {
        return vec![0.0; n * n];
    }
    if horizontal < 1e-9 {
        return vec![1.0; n * n];
    }
    let (ux, uz) = (dx / horizontal, dz / horizontal);
    let cell = terrain.cell_size_m();
    let max_height = terrain
        .surface_height_m
        .iter()
        .cloned()
        .fold(f32::MIN, f32::max) as f64;
    let half = terrain.params.extent_m * 0.5;

    (0..n * n)
        .into_par_iter()
        .map(|k| {
            let (x0, z0) = terrain.vertex_xz_m(k % n, k / n);
            let y0 = terrain.surface_height_m[k] as f64;
            let mut horizon = f64::NEG_INFINITY;
            let mut step = 1;
            loop {
                let distance = step as f64 * cell;
                let (x, z) = (x0 + ux * distance, z0 + uz * distance);
                if x.abs() > half || z.abs() > half {
                    break;
                }
                let angle = ((terrain.surface_height_at(x, z) - y0) / distance).atan();
                horizon = horizon.max(angle);
                // Past this distance nothing can rise above the current horizon or the sun.
                let needed = horizon.max(sun_elevation - 2.0 * SOLAR_DISK_ANGULAR_RADIUS_RAD);
                if max_height - y0 < distance * needed.tan() && needed > 0.0 {
                    break;
                }
                step += 1;
            }
            if horizon == f64::NEG_INFINITY {
                return 1.0;
            }
            let r = SOLAR_DISK_ANGULAR_RADIUS_RAD;
            smoothstep(-r, r, sun_elevation - horizon) as f32
        })
        .collect()
}

/// Texels per side of [`sun_shadow_ceiling_m`]'s grid over the terrain's
/// square (94 m texels over the default 24 km: the clouds it shades are
/// hundreds of metres across, and it is recomputed whenever the sun moves).
pub const SHADOW_CEILING_TEXELS: usize = 256;

/// The terrain's shadow in the air: for each texel of a
/// [`SHADOW_CEILING_TEXELS`]² grid over the terrain's square (texel centres
/// at −½ extent + (i + ½) · extent / n, i along X, row j along Z), the
/// height, m, above which the vertical line there sees the centre of the
/// sun's disk over the relief, for a unit sun direction:
/// h_c = max(T(x), max_{d > 0} T(x + d û) − d tan θ), with T the rendered
/// surface's height, û the sun's horizontal direction and θ its elevation.
/// A point (x, y) in the air is in the terrain's shadow when y < h_c: a
/// cloud behind a ridge at a low sun (the heightfield shadow volume of
/// Max's horizon mapping, "Horizon mapping: shadows for bump-mapped
/// surfaces", The Visual Computer 4, 1988, taken at every height). The
/// march steps half a terrain cell along the sun's azimuth and stops where
/// nothing ahead can rise above the ceiling found; it leaves the square at
/// its edge (beyond it the open sea, which shades nothing). With the sun
/// below the horizon every texel's ceiling is +∞ (the whole air is dark to
/// the sun); with it at the zenith the ceiling is the surface.
pub fn sun_shadow_ceiling_m(terrain: &Terrain, sun_direction: [f64; 3]) -> Vec<f32> {
    let n = SHADOW_CEILING_TEXELS;
    let [dx, dy, dz] = sun_direction;
    if dy <= 0.0 {
        return vec![f32::INFINITY; n * n];
    }
    let half = terrain.params.extent_m * 0.5;
    let texel = terrain.params.extent_m / n as f64;
    let centre = |i: usize| -half + (i as f64 + 0.5) * texel;
    let horizontal = (dx * dx + dz * dz).sqrt();
    if horizontal < 1e-9 {
        return (0..n * n)
            .map(|k| terrain.surface_height_at(centre(k % n), centre(k / n)) as f32)
            .collect();
    }
    let (ux, uz) = (dx / horizontal, dz / horizontal);
    let slope = dy / horizontal;
    let step = 0.5 * terrain.cell_size_m();
    let max_height = terrain
        .surface_height_m
        .iter()
        .cloned()
        .fold(f32::MIN, f32::max) as f64;
    (0..n * n)
        .into_par_iter()
        .map(|k| {
            let (x0, z0) = (centre(k % n), centre(k / n));
            let mut ceiling = terrain.surface_height_at(x0, z0);
            let mut distance = step;
            loop {
                // Past here nothing can rise above the ceiling found.
                if max_height - distance * slope <= ceiling {
                    break;
                }
                let (x, z) = (x0 + ux * distance, z0 + uz * distance);
                if x.abs() > half || z.abs() > half {
                    break;
                }
                ceiling = ceiling.max(terrain.surface_height_at(x, z) - distance * slope);
                distance += step;
            }
            ceiling as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::sun_direction;
    use crate::terrain::{TerrainParams, generate};

    /// Flat ground, 1 km across in 32 cells of 31.25 m.
    fn flat() -> Terrain {
        let mut t = generate(&TerrainParams {
            resolution: 32,
            extent_m: 1000.0,
            ..TerrainParams::default()
        });
        t.surface_height_m.iter_mut().for_each(|h| *h = 0.0);
        t
    }

    #[test]
    fn flat_ground_is_lit_by_any_sun_above_the_horizon_and_dark_below() {
        let t = flat();
        for elevation in [2.0, 30.0, 89.0] {
            assert!(
                sun_visibility(&t, sun_direction(123.0, elevation))
                    .iter()
                    .all(|v| *v == 1.0)
            );
        }
        assert!(
            sun_visibility(&t, sun_direction(0.0, -3.0))
                .iter()
                .all(|v| *v == 0.0)
        );
        assert!(
            sun_visibility(&t, [0.0, 1.0, 0.0])
                .iter()
                .all(|v| *v == 1.0)
        );
    }

    #[test]
    fn over_flat_ground_the_shadow_ceiling_is_the_ground() {
        let t = flat();
        for elevation in [2.0, 30.0, 90.0] {
            let ceiling = sun_shadow_ceiling_m(&t, sun_direction(123.0, elevation));
            assert_eq!(ceiling.len(), SHADOW_CEILING_TEXELS * SHADOW_CEILING_TEXELS);
            assert!(ceiling.iter().all(|h| *h == 0.0), "{elevation}°");
        }
        assert!(
            sun_shadow_ceiling_m(&t, sun_direction(0.0, -1.0))
                .iter()
                .all(|h| h.is_infinite())
        );
    }

    #[test]
    fn a_wall_shades_the_air_behind_it_below_the_line_to_the_sun() {
        // A 100 m wall along x = 0, three vertices wide (its top from
        // x = −31.25 to 31.25 m); the sun in the east (+X) 30° high: west of
        // the wall the air is dark up to 100 m − d tan 30° at a distance d
        // from its western crest.
        let mut t = flat();
        let n = t.vertices_per_side();
        for j in 0..n {
            for i in n / 2 - 1..=n / 2 + 1 {
                t.surface_height_m[j * n + i] = 100.0;
            }
        }
        let ceiling = sun_shadow_ceiling_m(&t, sun_direction(90.0, 30.0));
        let m = SHADOW_CEILING_TEXELS;
        let texel = 1000.0 / m as f64;
        let row = m / 2;
        let tan = 30f64.to_radians().tan();
        for i in 0..m {
            let x = -500.0 + (i as f64 + 0.5) * texel;
            let h = ceiling[row * m + i] as f64;
            if x > 63.0 {
                // East of the wall, in the sun: the ceiling is the ground.
                assert_eq!(h, 0.0, "x = {x}");
            } else if x < -32.0 {
                // Half a cell's march step misses the crest by at most
                // 15.6 m along the sun's azimuth.
                let expected = (100.0 + (x + 31.25) * tan).max(0.0);
                assert!(
                    (h - expected).abs() < 15.625 * tan + 1e-6,
                    "x = {x}: {h} against {expected}"
                );
            } else if x.abs() < 30.0 {
                assert_eq!(h, 100.0, "x = {x}");
            }
        }
    }

    #[test]
    fn a_wall_casts_a_shadow_of_the_expected_length() {
        // A 100 m wall along x = 0 on flat ground; the sun in the east (+X) at
        // 45° elevation shades the strip up to 100 m west of the wall.
        let mut t = flat();
        let n = t.vertices_per_side();
        let cell = t.cell_size_m();
        let wall_i = n / 2;
        for j in 0..n {
            t.surface_height_m[j * n + wall_i] = 100.0;
        }
        let vis = sun_visibility(&t, sun_direction(90.0, 45.0));
        let j = n / 2;
        let shadow_cells = (100.0 / cell).floor() as usize;
        assert_eq!(shadow_cells, 3);
        for di in 1..=shadow_cells {
            assert!(
                vis[j * n + wall_i - di] < 0.05,
                "cell {di} west of the wall is lit"
            );
        }
        // Well beyond the shadow's tip, and on the sunny side, the ground is lit.
        assert!(vis[j * n + wall_i - shadow_cells - 2] > 0.95);
        assert!(vis[j * n + wall_i + 2] > 0.95);
        // The sun behind the viewer's side: the west side is lit, the east is shaded.
        let vis_west_sun = sun_visibility(&t, sun_direction(270.0, 45.0));
        assert!(vis_west_sun[j * n + wall_i - 2] > 0.95 && vis_west_sun[j * n + wall_i + 1] < 0.05);
    }
}
