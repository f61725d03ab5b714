//! A spatial hash of points: all points within a radius in O(1) expected
//! time (Teschner et al. 2003's hashing of a uniform grid), for the blob
//! field's neighbours and the particle sampler's.

use glam::DVec3;
use rustc_hash::FxHashMap;

/// Points bucketed in cubic cells of a fixed side.
#[derive(Clone, Debug)]
pub struct PointGrid {
    cell_m: f64,
    /// Keyed by Fx's multiply-rotate hash (rustc's own), not std's SipHash:
    /// the keys are the grid's own cell coordinates, not an adversary's, and
    /// the lookups, one per cell near every point the blob field is
    /// evaluated at, were the larger part of voxelising a cloud (SipHash
    /// alone 8 % of a sun cube's precomputation, profiled).
    cells: FxHashMap<[i32; 3], Vec<u32>>,
}

impl PointGrid {
    /// A grid of cubic cells of side `cell_m` (> 0) holding `points`,
    /// identified by their index.
    pub fn new(cell_m: f64, points: impl IntoIterator<Item = DVec3>) -> Self {
        let mut grid = Self {
            cell_m,
            cells: FxHashMap::default(),
        };
        for (i, p) in points.into_iter().enumerate() {
            grid.insert(i as u32, p);
        }
        grid
    }

    /// Side of the cells, m.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }

    fn key(&self, p: DVec3) -> [i32; 3] {
        let c = (p / self.cell_m).floor();
        [c.x as i32, c.y as i32, c.z as i32]
    }

    /// Adds point `id` at `p`.
    pub fn insert(&mut self, id: u32, p: DVec3) {
        self.cells.entry(self.key(p)).or_default().push(id);
    }

    /// Calls `visit` with the id of every point in the cells that a ball of
    /// `radius_m` around `p` touches (a superset of the points within
    /// `radius_m`; the caller tests the distance).
    pub fn for_each_near(&self, p: DVec3, radius_m: f64, mut visit: impl FnMut(u32)) {
        let lo = self.key(p - DVec3::splat(radius_m));
        let hi = self.key(p + DVec3::splat(radius_m));
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    if let Some(ids) = self.cells.get(&[x, y, z]) {
                        ids.iter().for_each(|&id| visit(id));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_every_point_within_the_radius() {
        let points: Vec<DVec3> = (0..500)
            .map(|i| {
                let t = i as f64;
                DVec3::new(
                    (t * 12.9898).sin() * 50.0,
                    (t * 78.233).sin() * 50.0,
                    (t * 37.719).sin() * 50.0,
                )
            })
            .collect();
        let grid = PointGrid::new(7.0, points.iter().copied());
        let q = DVec3::new(3.0, -4.0, 10.0);
        let mut found = Vec::new();
        grid.for_each_near(q, 15.0, |id| {
            if points[id as usize].distance(q) <= 15.0 {
                found.push(id)
            }
        });
        found.sort();
        let expected: Vec<u32> = (0..points.len() as u32)
            .filter(|&i| points[i as usize].distance(q) <= 15.0)
            .collect();
        assert_eq!(found, expected);
        assert!(!expected.is_empty());
    }
}
