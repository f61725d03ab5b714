//! The radiosity grid of the layer over the terrain and the ground's reflectance on it (Bouthors et al. 2006, §5.3).

use super::{MAX_RADIOSITY_SIZE, MIN_RADIOSITY_TEXEL_M};
use nimbus_physics::terrain::Terrain;

/// The radiosity grid of a layer over a terrain: square texels as large as
/// the layer is high above the mean ground (§5.3), a power of two of them
/// per side covering the terrain, centred on the origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiosityGrid {
    /// Texels per side.
    pub size: u32,
    /// Texel side, m.
    pub texel_m: f64,
    /// Mean ground height, m.
    pub ground_height_m: f64,
}

impl RadiosityGrid {
    /// The grid for a layer whose mid-plane is at `mid_plane_m` over `terrain`.
    pub fn new(terrain: &Terrain, mid_plane_m: f64) -> Self {
        let water = terrain.params.water_level_m;
        let heights = &terrain.surface_height_m;
        let ground_height_m = heights.iter().map(|h| (*h as f64).max(water)).sum::<f64>()
            / heights.len().max(1) as f64;
        let texel_m = (mid_plane_m - ground_height_m).max(MIN_RADIOSITY_TEXEL_M);
        let size = ((terrain.params.extent_m / texel_m).ceil() as u32)
            .next_power_of_two()
            .clamp(
                nimbus_physics::radiosity::MIN_SIZE as u32,
                MAX_RADIOSITY_SIZE,
            );
        Self {
            size,
            texel_m,
            ground_height_m,
        }
    }

    /// World (x, z) of the grid's min corner, m.
    pub fn origin_m(&self) -> [f64; 2] {
        let half = 0.5 * self.size as f64 * self.texel_m;
        [-half, -half]
    }

    /// ρ_G: the ground's mean diffuse reflectance in each texel (row-major,
    /// z rows). Open water adds its mean Fresnel reflectance for diffuse
    /// light (`WATER_DIFFUSE_FRESNEL`, 0.066).
    /// Texels beyond the terrain take `beyond_terrain_reflectance`: the
    /// open sea, or a flat ground continued.
    pub fn ground_reflectance(&self, terrain: &Terrain) -> Vec<[f32; 3]> {
        let n = self.size as usize;
        let mut sums = vec![[0.0f64; 4]; n * n];
        let side = terrain.vertices_per_side();
        let water = terrain.params.water_level_m as f32;
        let origin = self.origin_m();
        for j in 0..side {
            for i in 0..side {
                let k = j * side + i;
                let mut rho = terrain.albedo[k];
                if terrain.ground_height_m[k] < water {
                    rho = rho.map(|a| a + WATER_DIFFUSE_FRESNEL);
                }
                let (x, z) = terrain.vertex_xz_m(i, j);
                let u = ((x - origin[0]) / self.texel_m).floor();
                let v = ((z - origin[1]) / self.texel_m).floor();
                if u < 0.0 || v < 0.0 || u >= n as f64 || v >= n as f64 {
                    continue;
                }
                let cell = &mut sums[v as usize * n + u as usize];
                for c in 0..3 {
                    cell[c] += rho[c] as f64;
                }
                cell[3] += 1.0;
            }
        }
        let beyond = beyond_terrain_reflectance(terrain);
        sums.iter()
            .map(|s| {
                if s[3] > 0.0 {
                    [0, 1, 2].map(|c| (s[c] / s[3]) as f32)
                } else {
                    beyond
                }
            })
            .collect()
    }
}

/// Mean Fresnel reflectance of a flat water surface for diffuse light
/// (0.066 for a uniform sky; Cox & Munk 1954's flat-sea value), added to deep
/// water's diffuse albedo.
const WATER_DIFFUSE_FRESNEL: f32 = 0.066;

/// ρ_G beyond the terrain's square: what the renderer draws there, as the
/// path-traced references have it (`nimbus export`'s sea plane or flat
/// ground). A generated relief sinks below the water level over its outer
/// fifth and the sky pass draws the open sea beyond it to the horizon: deep
/// water's albedo plus its Fresnel reflectance. A flat ground
/// (`ground.terrain = false`) has no water; it continues with its own (mean)
/// albedo, which [`nimbus_physics::terrain::flat`] keeps as the water class's.
pub fn beyond_terrain_reflectance(terrain: &Terrain) -> [f32; 3] {
    let water = terrain.params.albedo.water;
    let border_under_water = terrain
        .ground_height_m
        .first()
        .is_some_and(|h| f64::from(*h) < terrain.params.water_level_m);
    if border_under_water {
        water.map(|a| a + WATER_DIFFUSE_FRESNEL)
    } else {
        water
    }
}
