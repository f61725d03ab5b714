//! Procedural terrain: a seeded heightfield and its surface-class albedo map.
//!
//! The heightfield is a sum of fractal noises (see [`crate::noise`]): broad
//! fBm hills, plus ridged-multifractal mountains where a low-frequency mask
//! allows them. Every grid vertex is classified into a surface class (water,
//! sand, grass, rock, snow) by height, slope and noise, and each class has a
//! broadband albedo. The albedo map is a first-class product: the renderer
//! shades the ground with it, and the stratiform ground–cloud radiosity and
//! rain collisions read it too.
//!
//! Coordinates: world metres, +Y up, east = +X, north = −Z; the grid covers
//! `[-extent/2, extent/2]²` in X and Z, row-major with rows along +Z.

mod params;
mod shadow;

pub use params::{SurfaceAlbedos, TerrainParams};
pub use shadow::{SHADOW_CEILING_TEXELS, sun_shadow_ceiling_m, sun_visibility};

use crate::noise::{Fractal, fbm, gradient_noise, ridged};
use crate::photometry::srgb_encode;
use rayon::prelude::*;

/// The surface classes of the terrain, in the order of the albedo-map codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SurfaceClass {
    /// Open water (sea or lake), at or below the water level.
    Water = 0,
    /// Beaches and dunes near the water line.
    Sand = 1,
    /// Vegetated ground.
    Grass = 2,
    /// Bare rock on steep slopes.
    Rock = 3,
    /// Snow above the snow line on gentle slopes.
    Snow = 4,
}

/// A generated terrain: heights, normals, surface classes and albedo, all on
/// the same `(resolution + 1)²` vertex grid.
#[derive(Clone, Debug)]
pub struct Terrain {
    /// Parameters the terrain was generated from.
    pub params: TerrainParams,
    /// Raw ground height of each vertex above the datum, m (the sea floor under water).
    pub ground_height_m: Vec<f32>,
    /// Height of the rendered surface, m: the ground, or the water surface where it is higher.
    pub surface_height_m: Vec<f32>,
    /// Unit normal of the rendered surface at each vertex.
    pub surface_normal: Vec<[f32; 3]>,
    /// Surface class of each vertex.
    pub surface_class: Vec<SurfaceClass>,
    /// Linear broadband albedo (Rec.709 RGB) of each vertex.
    pub albedo: Vec<[f32; 3]>,
}

impl Terrain {
    /// Number of vertices along one side of the grid.
    pub fn vertices_per_side(&self) -> usize {
        self.params.resolution as usize + 1
    }

    /// Spacing between grid vertices, m.
    pub fn cell_size_m(&self) -> f64 {
        self.params.extent_m / self.params.resolution as f64
    }

    /// World X and Z (m) of grid vertex (i, j), i along X, j along Z.
    pub fn vertex_xz_m(&self, i: usize, j: usize) -> (f64, f64) {
        let half = self.params.extent_m * 0.5;
        let cell = self.cell_size_m();
        (-half + i as f64 * cell, -half + j as f64 * cell)
    }

    /// Bilinearly interpolated rendered-surface height at world (x, z), m;
    /// clamped to the grid's edge outside it.
    pub fn surface_height_at(&self, x_m: f64, z_m: f64) -> f64 {
        let n = self.vertices_per_side();
        let half = self.params.extent_m * 0.5;
        let fx = ((x_m + half) / self.cell_size_m()).clamp(0.0, (n - 1) as f64);
        let fz = ((z_m + half) / self.cell_size_m()).clamp(0.0, (n - 1) as f64);
        let (i0, j0) = (
            (fx.floor() as usize).min(n - 2),
            (fz.floor() as usize).min(n - 2),
        );
        let (tx, tz) = (fx - i0 as f64, fz - j0 as f64);
        let h = |i: usize, j: usize| self.surface_height_m[j * n + i] as f64;
        let a = h(i0, j0) + tx * (h(i0 + 1, j0) - h(i0, j0));
        let b = h(i0, j0 + 1) + tx * (h(i0 + 1, j0 + 1) - h(i0, j0 + 1));
        a + tz * (b - a)
    }

    /// The mean linear albedo over the vertices (a uniform grid: the mean
    /// over the square), water included.
    pub fn mean_albedo(&self) -> [f64; 3] {
        mean_rgb(&self.albedo)
    }

    /// The mean linear albedo of the vertices within `radius_m` of world
    /// (x, z), water included; the nearest vertex's when the disc holds
    /// none (a radius below the cell size, or a point off the grid).
    pub fn mean_albedo_within(&self, x_m: f64, z_m: f64, radius_m: f64) -> [f64; 3] {
        let n = self.vertices_per_side();
        let half = self.params.extent_m * 0.5;
        let cell = self.cell_size_m();
        let index = |v: f64| ((v + half) / cell).round().clamp(0.0, (n - 1) as f64) as usize;
        let reach = (radius_m.max(0.0) / cell).ceil() as usize;
        let (ci, cj) = (index(x_m), index(z_m));
        let (mut sum, mut count) = ([0.0f64; 3], 0usize);
        for j in cj.saturating_sub(reach)..=(cj + reach).min(n - 1) {
            for i in ci.saturating_sub(reach)..=(ci + reach).min(n - 1) {
                let (x, z) = self.vertex_xz_m(i, j);
                if (x - x_m).powi(2) + (z - z_m).powi(2) <= radius_m * radius_m {
                    for (s, &c) in sum.iter_mut().zip(&self.albedo[j * n + i]) {
                        *s += f64::from(c);
                    }
                    count += 1;
                }
            }
        }
        if count == 0 {
            return self.albedo[cj * n + ci].map(f64::from);
        }
        sum.map(|s| s / count as f64)
    }

    /// The albedo map as RGBA8 texels: sRGB-encoded albedo in RGB and the
    /// water mask in alpha (255 = water), ready for an `Rgba8UnormSrgb` texture.
    pub fn albedo_rgba8(&self) -> Vec<[u8; 4]> {
        self.albedo
            .iter()
            .zip(&self.surface_class)
            .map(|(rgb, class)| {
                let enc = |c: f32| (srgb_encode(c as f64) * 255.0).round() as u8;
                let water = if *class == SurfaceClass::Water {
                    255
                } else {
                    0
                };
                [enc(rgb[0]), enc(rgb[1]), enc(rgb[2]), water]
            })
            .collect()
    }
}

/// Ground height of the procedural terrain at world (x, z), m.
///
/// Broad hills (fBm over 8 octaves at a wavelength of a quarter of the
/// extent) plus ridged mountains gated by a smooth low-frequency mask. The
/// result spans roughly `[-0.35, 1] × height_scale_m`. Over the outer 20 % of
/// each half-extent the relief sinks below the water level, so the terrain
/// ends in open sea that continues to the horizon.
pub fn ground_height_m(params: &TerrainParams, x_m: f64, z_m: f64) -> f64 {
    let half = 0.5 * params.extent_m;
    let edge = x_m.abs().max(z_m.abs()) / half;
    let inland = 1.0 - smoothstep(0.8, 1.0, edge);
    let sea_floor = params.water_level_m - 0.05 * params.height_scale_m - 1.0;
    sea_floor + inland * (relief_m(params, x_m, z_m) - sea_floor)
}

/// The relief before the sea margin is applied.
fn relief_m(params: &TerrainParams, x_m: f64, z_m: f64) -> f64 {
    let seed = params.seed as u32;
    let wavelength = params.feature_wavelength_m;
    let (u, v) = (x_m / wavelength, z_m / wavelength);
    let hills = fbm(
        u,
        v,
        seed,
        Fractal {
            octaves: 9,
            lacunarity: 2.03,
            gain: 0.5,
        },
    );
    let mask_raw = fbm(
        u * 0.35 + 17.3,
        v * 0.35 - 4.1,
        seed ^ 0x5bd1,
        Fractal {
            octaves: 3,
            ..Fractal::default()
        },
    );
    let mask = smoothstep(-0.15, 0.45, mask_raw);
    let mountains = ridged(
        u * 1.3 + 3.7,
        v * 1.3 + 1.9,
        seed ^ 0xa3c5,
        Fractal {
            octaves: 9,
            lacunarity: 2.1,
            gain: 0.5,
        },
    );
    params.height_scale_m * (0.32 * hills + mask * mountains.powf(1.6) * 1.1 - 0.04)
}

fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Vertices per side of the grid [`mean_albedo`] generates at most.
pub const MEAN_ALBEDO_RESOLUTION: u32 = 512;

/// The mean linear albedo of the terrain of `params` over its square, water
/// included: the ground that reflects light onto the clouds, the rain and
/// the air (nimbus-render's lighting). From the terrain generated at most
/// [`MEAN_ALBEDO_RESOLUTION`] cells a side (the default grid; a tenth of a
/// second), whose class fractions are within a few per cent of a finer
/// grid's (a coarser one's slopes are gentler: less rock).
pub fn mean_albedo(params: &TerrainParams) -> [f64; 3] {
    let coarse = TerrainParams {
        resolution: params.resolution.clamp(1, MEAN_ALBEDO_RESOLUTION),
        ..params.clone()
    };
    generate(&coarse).mean_albedo()
}

/// Generates the terrain described by `params` (deterministic for a given
/// seed; parallel over rows).
pub fn generate(params: &TerrainParams) -> Terrain {
    let n = params.resolution as usize + 1;
    let half = params.extent_m * 0.5;
    let cell = params.extent_m / params.resolution as f64;
    let xz = |i: usize, j: usize| (-half + i as f64 * cell, -half + j as f64 * cell);

    let ground_height_m: Vec<f32> = (0..n * n)
        .into_par_iter()
        .map(|k| {
            let (x, z) = xz(k % n, k / n);
            ground_height_m(params, x, z) as f32
        })
        .collect();
    let water_level = params.water_level_m as f32;
    let surface_height_m: Vec<f32> = ground_height_m.iter().map(|h| h.max(water_level)).collect();

    // Central differences (one-sided at the edges) of the rendered surface.
    let surface_normal: Vec<[f32; 3]> = (0..n * n)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let h = |i: usize, j: usize| surface_height_m[j * n + i] as f64;
            let (il, ir) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let (jd, ju) = (j.saturating_sub(1), (j + 1).min(n - 1));
            let dhdx = (h(ir, j) - h(il, j)) / ((ir - il) as f64 * cell);
            let dhdz = (h(i, ju) - h(i, jd)) / ((ju - jd) as f64 * cell);
            let len = (dhdx * dhdx + 1.0 + dhdz * dhdz).sqrt();
            [
                (-dhdx / len) as f32,
                (1.0 / len) as f32,
                (-dhdz / len) as f32,
            ]
        })
        .collect();

    let seed = params.seed as u32;
    let (surface_class, albedo): (Vec<SurfaceClass>, Vec<[f32; 3]>) = (0..n * n)
        .into_par_iter()
        .map(|k| {
            let (x, z) = xz(k % n, k / n);
            let class = classify(
                params,
                ground_height_m[k] as f64,
                surface_normal[k][1] as f64,
                x,
                z,
            );
            // Small-scale albedo variation (±15 %) so that zones are not flat colour.
            let variation = 1.0 + 0.15 * gradient_noise(x / 97.0, z / 97.0, seed ^ 0x1234) as f32;
            let base = params.albedo.of(class);
            let albedo = if class == SurfaceClass::Water {
                base
            } else {
                base.map(|c| (c * variation).clamp(0.0, 1.0))
            };
            (class, albedo)
        })
        .unzip();

    Terrain {
        params: params.clone(),
        ground_height_m,
        surface_height_m,
        surface_normal,
        surface_class,
        albedo,
    }
}

/// A map of linear albedo over a square ground: `width` × `height` texels,
/// row-major, row 0 at the smallest z (north), column 0 at the smallest x
/// (west), texel centres at (i + ½)/width of the side.
#[derive(Clone, Debug, PartialEq)]
pub struct AlbedoMap {
    /// Texels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Linear RGB albedo per texel, each in [0, 1].
    pub texels: Vec<[f32; 3]>,
}

/// The mean of RGB triples (0 for none).
fn mean_rgb(texels: &[[f32; 3]]) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for t in texels {
        for (s, &c) in sum.iter_mut().zip(t) {
            *s += f64::from(c);
        }
    }
    sum.map(|s| s / texels.len().max(1) as f64)
}

impl AlbedoMap {
    /// The mean albedo over the map's texels.
    pub fn mean(&self) -> [f64; 3] {
        mean_rgb(&self.texels)
    }

    /// Bilinear albedo at (u, v) ∈ [0, 1]² of the square (u along x, v along
    /// z), clamped to the edge texels' centres.
    pub fn sample(&self, u: f64, v: f64) -> [f32; 3] {
        let (w, h) = (self.width as usize, self.height as usize);
        let fx = (u * w as f64 - 0.5).clamp(0.0, (w - 1) as f64);
        let fy = (v * h as f64 - 0.5).clamp(0.0, (h - 1) as f64);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (tx, ty) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
        let at = |x: usize, y: usize| self.texels[y * w + x];
        let lerp = |a: [f32; 3], b: [f32; 3], t: f32| [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * t);
        lerp(
            lerp(at(x0, y0), at(x1, y0), tx),
            lerp(at(x0, y1), at(x1, y1), tx),
            ty,
        )
    }
}

/// [`flat`] with its albedo from `map` (bilinear, over the whole square)
/// instead of one value. `map` must have at least one texel and
/// `width × height` of them.
pub fn flat_with_albedo_map(
    extent_m: f64,
    resolution: u32,
    height_m: f64,
    map: &AlbedoMap,
) -> Terrain {
    let mean = map
        .texels
        .iter()
        .fold([0.0f64; 3], |m, t| {
            [0, 1, 2].map(|c| m[c] + f64::from(t[c]))
        })
        .map(|c| (c / map.texels.len().max(1) as f64) as f32);
    let mut terrain = flat(extent_m, resolution, height_m, mean);
    let side = terrain.vertices_per_side();
    for j in 0..side {
        for i in 0..side {
            let (u, v) = (i as f64 / (side - 1) as f64, j as f64 / (side - 1) as f64);
            terrain.albedo[j * side + i] = map.sample(u, v);
        }
    }
    terrain
}

/// A flat ground of one albedo: what lies under the clouds when no relief is
/// drawn (an embedder's own world). Heights are `height_m` everywhere (no
/// water: the water level sits below), normals point up, every vertex is
/// grass-classed with exactly `albedo`, over `extent_m` with `resolution`
/// cells per side. The radiosity and the ground light read it like a
/// generated terrain.
pub fn flat(extent_m: f64, resolution: u32, height_m: f64, albedo: [f32; 3]) -> Terrain {
    let params = TerrainParams {
        extent_m,
        height_scale_m: 0.0,
        resolution,
        water_level_m: height_m - 1.0,
        sand_band_m: 0.0,
        snow_line_m: f64::MAX,
        rock_slope_deg: 90.0,
        albedo: SurfaceAlbedos {
            water: albedo,
            sand: albedo,
            grass: albedo,
            rock: albedo,
            snow: albedo,
        },
        ..TerrainParams::default()
    };
    let n = (resolution as usize + 1).pow(2);
    Terrain {
        params,
        ground_height_m: vec![height_m as f32; n],
        surface_height_m: vec![height_m as f32; n],
        surface_normal: vec![[0.0, 1.0, 0.0]; n],
        surface_class: vec![SurfaceClass::Grass; n],
        albedo: vec![albedo; n],
    }
}

/// Surface class of a point from its ground height (m), the vertical
/// component of its normal, and its position (for noisy zone boundaries).
pub fn classify(
    params: &TerrainParams,
    ground_m: f64,
    normal_y: f64,
    x_m: f64,
    z_m: f64,
) -> SurfaceClass {
    if ground_m < params.water_level_m {
        return SurfaceClass::Water;
    }
    let seed = params.seed as u32;
    let jitter = fbm(
        x_m / 310.0,
        z_m / 310.0,
        seed ^ 0x77aa,
        Fractal {
            octaves: 4,
            ..Fractal::default()
        },
    );
    let slope_deg = normal_y.clamp(-1.0, 1.0).acos().to_degrees();
    let above_water = ground_m - params.water_level_m;
    if above_water < params.sand_band_m * (1.0 + 0.6 * jitter) && slope_deg < 20.0 {
        return SurfaceClass::Sand;
    }
    let snow_line = params.snow_line_m + 0.08 * params.height_scale_m * jitter;
    if ground_m > snow_line && slope_deg < params.rock_slope_deg + 10.0 {
        return SurfaceClass::Snow;
    }
    if slope_deg > params.rock_slope_deg + 6.0 * jitter {
        return SurfaceClass::Rock;
    }
    SurfaceClass::Grass
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mean albedo within a disc takes the vertices inside it: on a flat
    /// ground whose east half is bright, a disc on the seam sees half of
    /// each, one well inside a half sees that half's, and a disc smaller
    /// than a cell the nearest vertex's.
    #[test]
    fn the_mean_albedo_within_a_disc_takes_the_vertices_inside_it() {
        let mut terrain = flat(1000.0, 100, 0.0, [0.1, 0.1, 0.1]);
        let n = terrain.vertices_per_side();
        for j in 0..n {
            for i in 0..n {
                if terrain.vertex_xz_m(i, j).0 > 0.0 {
                    terrain.albedo[j * n + i] = [0.5, 0.3, 0.1];
                }
            }
        }
        let seam = terrain.mean_albedo_within(0.0, 0.0, 200.0);
        assert!(
            (seam[0] - 0.3).abs() < 0.01 && (seam[2] - 0.1).abs() < 1e-6,
            "{seam:?}"
        );
        assert_eq!(
            terrain.mean_albedo_within(-300.0, 0.0, 150.0),
            [0.1f32 as f64; 3]
        );
        let east = terrain.mean_albedo_within(300.0, 100.0, 150.0);
        assert!((east[0] - 0.5).abs() < 1e-6 && (east[1] - 0.3).abs() < 1e-6);
        assert_eq!(
            terrain.mean_albedo_within(251.0, 0.0, 1.0),
            [0.5f32 as f64, 0.3f32 as f64, 0.1f32 as f64]
        );
    }

    #[test]
    fn a_flat_grounds_albedo_follows_its_map() {
        // West half dark, east half bright (2 × 1 texels).
        let map = AlbedoMap {
            width: 2,
            height: 1,
            texels: vec![[0.05; 3], [0.85; 3]],
        };
        let t = flat_with_albedo_map(1000.0, 8, 12.0, &map);
        let side = t.vertices_per_side();
        let row = |j: usize| &t.albedo[j * side..(j + 1) * side];
        for j in 0..side {
            assert_eq!(row(j)[0], [0.05; 3]);
            assert_eq!(row(j)[side - 1], [0.85; 3]);
            // Half-way: the two texels' mean.
            assert!((row(j)[side / 2][0] - 0.45).abs() < 1e-6);
        }
        assert!(t.surface_height_m.iter().all(|h| *h == 12.0));
        // Bilinear between texel centres, clamped beyond them.
        assert_eq!(map.sample(0.25, 0.5), [0.05; 3]);
        assert!((map.sample(0.5, 0.5)[1] - 0.45).abs() < 1e-6);
        assert_eq!(map.sample(1.0, 0.0), [0.85; 3]);
    }

    /// The mean albedo lies between the classes' albedos, follows the
    /// snow line (all snow but the sea at the margins: near the snow's)
    /// and the capped grid's mean is a finer grid's within 3 %.
    #[test]
    fn the_mean_albedo_is_the_grounds() {
        let params = TerrainParams {
            resolution: 768,
            ..TerrainParams::default()
        };
        let full = generate(&params).mean_albedo();
        let coarse = mean_albedo(&params);
        for c in 0..3 {
            assert!(
                (coarse[c] / full[c] - 1.0).abs() < 0.03,
                "{coarse:?} vs {full:?}"
            );
            assert!(full[c] > 0.02 && full[c] < 0.5, "{full:?}");
        }
        let snow = TerrainParams {
            water_level_m: -1000.0,
            snow_line_m: -2000.0,
            rock_slope_deg: 90.0,
            ..params
        };
        let m = mean_albedo(&snow);
        let a = snow.albedo.snow;
        for c in 0..3 {
            let ratio = m[c] / f64::from(a[c]);
            assert!(ratio > 0.85 && ratio < 1.02, "{m:?} vs {a:?}");
        }
        let map = AlbedoMap {
            width: 2,
            height: 1,
            texels: vec![[0.05; 3], [0.85; 3]],
        };
        assert!((map.mean()[0] - 0.45).abs() < 1e-6);
    }

    fn small() -> TerrainParams {
        TerrainParams {
            resolution: 64,
            ..TerrainParams::default()
        }
    }

    #[test]
    fn generation_is_deterministic_and_seeded() {
        let a = generate(&small());
        let b = generate(&small());
        assert_eq!(a.ground_height_m, b.ground_height_m);
        assert_eq!(a.albedo, b.albedo);
        let c = generate(&TerrainParams {
            seed: 99,
            ..small()
        });
        assert_ne!(a.ground_height_m, c.ground_height_m);
    }

    #[test]
    fn normals_are_unit_and_water_is_flat() {
        let t = generate(&small());
        for (k, n) in t.surface_normal.iter().enumerate() {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-5);
            assert!(n[1] > 0.0);
            assert!(t.surface_height_m[k] >= t.params.water_level_m as f32);
        }
    }

    #[test]
    fn default_terrain_has_every_surface_class() {
        let t = generate(&TerrainParams {
            resolution: 128,
            ..TerrainParams::default()
        });
        for class in [
            SurfaceClass::Water,
            SurfaceClass::Sand,
            SurfaceClass::Grass,
            SurfaceClass::Rock,
            SurfaceClass::Snow,
        ] {
            let count = t.surface_class.iter().filter(|c| **c == class).count();
            assert!(count > 0, "no {class:?} in the default terrain");
        }
    }

    #[test]
    fn albedo_map_marks_water_in_alpha() {
        let t = generate(&small());
        for (texel, class) in t.albedo_rgba8().iter().zip(&t.surface_class) {
            assert_eq!(texel[3] == 255, *class == SurfaceClass::Water);
        }
    }

    #[test]
    fn terrain_edges_are_under_water() {
        let t = generate(&small());
        let n = t.vertices_per_side();
        for k in 0..n {
            for (i, j) in [(k, 0), (k, n - 1), (0, k), (n - 1, k)] {
                assert_eq!(t.surface_class[j * n + i], SurfaceClass::Water);
            }
        }
    }

    #[test]
    fn interpolated_height_matches_vertices() {
        let t = generate(&small());
        let n = t.vertices_per_side();
        for (i, j) in [(0, 0), (5, 9), (n - 1, n - 1), (30, 2)] {
            let (x, z) = t.vertex_xz_m(i, j);
            let h = t.surface_height_at(x, z);
            assert!((h - t.surface_height_m[j * n + i] as f64).abs() < 1e-3);
        }
    }
}
