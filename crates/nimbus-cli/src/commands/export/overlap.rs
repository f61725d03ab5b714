//! Cumulus whose boxes overlap, merged into one medium.
//!
//! Mitsuba 3's volumetric path tracer follows one medium at a time: a ray
//! inside cloud A that enters cloud B's box takes B's medium, and when it
//! leaves B's box (still inside A's) it is in no medium at all. Where two
//! placed clouds' boxes overlap, the reference therefore lost the part of
//! each cloud that lies in or behind the other's box: cumulus-field's
//! export has 42 pairs of overlapping boxes among its 80 clouds, and the
//! missing parts were the largest block errors of that scene against
//! nimbus. Clouds whose boxes overlap (directly or through a chain) are
//! written as one grid instead, aligned with the world's axes, holding the
//! sum of their extinctions: the medium both clouds together make.

use glam::{DMat4, DVec3};
use nimbus_physics::cumulus::volume::ExtinctionGrid;

/// Most cells of a merged grid (4 bytes each in the `.vol` file): a
/// larger group is resampled on coarser cells.
pub const MAX_MERGED_CELLS: usize = 1 << 26;

/// One placed cloud: its variant's grid and the world transform of the
/// grid's unit cube ([0, 1]³ → world, m).
#[derive(Clone, Copy)]
pub struct PlacedGrid<'a> {
    /// The variant's extinction grid (its own frame).
    pub grid: &'a ExtinctionGrid,
    /// World from the grid's unit cube.
    pub world_from_unit: DMat4,
}

/// Whether two boxes, each the image of the unit cube [0, 1]³ under an
/// affine map with orthogonal axes, overlap (separating-axis test over the
/// 15 axes of two oriented boxes; touching counts as apart).
pub fn boxes_overlap(a_from_unit: &DMat4, b_from_unit: &DMat4) -> bool {
    let half_axes = |m: &DMat4| {
        [
            0.5 * m.x_axis.truncate(),
            0.5 * m.y_axis.truncate(),
            0.5 * m.z_axis.truncate(),
        ]
    };
    let (ha, hb) = (half_axes(a_from_unit), half_axes(b_from_unit));
    let centre = |m: &DMat4| m.transform_point3(DVec3::splat(0.5));
    let d = centre(b_from_unit) - centre(a_from_unit);
    let mut axes: Vec<DVec3> = ha.iter().chain(hb.iter()).copied().collect();
    for u in ha {
        for v in hb {
            axes.push(u.cross(v));
        }
    }
    axes.into_iter()
        .filter(|axis| axis.length_squared() > 1e-12 * (1.0 + d.length_squared()))
        .all(|axis| {
            let axis = axis.normalize();
            let radius = |h: &[DVec3; 3]| h.iter().map(|e| e.dot(axis).abs()).sum::<f64>();
            d.dot(axis).abs() < radius(&ha) + radius(&hb)
        })
}

/// The clouds grouped by overlap: each group lists indices into `boxes`
/// (unit-cube transforms) whose boxes are connected by overlaps, in
/// ascending order; groups ordered by their first index. A cloud that
/// overlaps none is a group of one.
pub fn overlap_groups(boxes: &[DMat4]) -> Vec<Vec<usize>> {
    // Union–find with path halving.
    let mut parent: Vec<usize> = (0..boxes.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for i in 0..boxes.len() {
        for j in i + 1..boxes.len() {
            if boxes_overlap(&boxes[i], &boxes[j]) {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                parent[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut group_of_root = vec![usize::MAX; boxes.len()];
    for i in 0..boxes.len() {
        let r = root(&mut parent, i);
        if group_of_root[r] == usize::MAX {
            group_of_root[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[group_of_root[r]].push(i);
    }
    groups
}

/// The smallest axis-aligned box, world metres, holding the unit cube's
/// image under `world_from_unit`: its lowest and highest corner.
fn world_bounds(world_from_unit: &DMat4) -> (DVec3, DVec3) {
    (0..8).fold(
        (DVec3::INFINITY, DVec3::NEG_INFINITY),
        |(lo, hi), corner| {
            let unit = DVec3::new(
                f64::from(corner & 1),
                f64::from((corner >> 1) & 1),
                f64::from((corner >> 2) & 1),
            );
            let p = world_from_unit.transform_point3(unit);
            (lo.min(p), hi.max(p))
        },
    )
}

/// σ_t of one placed cloud at the world point `p_m`, m⁻¹, as Mitsuba
/// samples that cloud's medium alone: trilinear between its cell centres
/// inside its box, nothing outside.
fn placed_extinction_per_m(placed: &PlacedGrid, unit_from_world: &DMat4, p_m: DVec3) -> f64 {
    let u = unit_from_world.transform_point3(p_m);
    if u.min_element() < 0.0 || u.max_element() > 1.0 {
        return 0.0;
    }
    let grid = placed.grid;
    let p_grid_m = grid.origin_m + u * (grid.max_corner_m() - grid.origin_m);
    grid.lookup_per_m(p_grid_m)
}

/// The clouds of `members` as one grid in the world's axes: its box the
/// smallest holding every member's, its cells the finest member's world
/// cell (coarser if that would pass `max_cells`), each cell the sum of
/// the members' σ_t at its centre, trimmed to its non-zero cells and one
/// layer of zeros around them. The grid's `origin_m` is in world
/// metres; returns it with the world transform of its unit cube.
pub fn merged_grid(members: &[PlacedGrid], max_cells: usize) -> (ExtinctionGrid, DMat4) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut cell_m = f64::INFINITY;
    for member in members {
        let (member_lo, member_hi) = world_bounds(&member.world_from_unit);
        lo = lo.min(member_lo);
        hi = hi.max(member_hi);
        // The unit cube's x edge spans the grid's dims[0] cells.
        let world_cell_m =
            member.world_from_unit.x_axis.truncate().length() / member.grid.dims[0].max(1) as f64;
        cell_m = cell_m.min(world_cell_m);
    }
    let extent = hi - lo;
    let dims_for = |cell_m: f64| -> [usize; 3] {
        std::array::from_fn(|a| ((extent[a] / cell_m).ceil() as usize).max(1))
    };
    let mut dims = dims_for(cell_m);
    let cells = dims.iter().product::<usize>();
    let coarsened = cells > max_cells;
    if coarsened {
        cell_m *= (cells as f64 / max_cells as f64).cbrt() * 1.001;
        dims = dims_for(cell_m);
    }
    let [nx, ny, nz] = dims;
    let mut values_per_m = vec![0.0f32; nx * ny * nz];
    // Each member adds its σ_t to the cells whose centres its box's
    // bounding box holds (the rest of the grid is outside its box).
    for member in members {
        let unit_from_world = member.world_from_unit.inverse();
        let (member_lo, member_hi) = world_bounds(&member.world_from_unit);
        let first = ((member_lo - lo) / cell_m - DVec3::splat(0.5))
            .floor()
            .max(DVec3::ZERO);
        let last = ((member_hi - lo) / cell_m - DVec3::splat(0.5)).ceil();
        let range = |a: usize| {
            let n = dims[a];
            (first[a] as usize).min(n)..((last[a].max(0.0) as usize) + 1).min(n)
        };
        for k in range(2) {
            for j in range(1) {
                for i in range(0) {
                    let p = lo + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * cell_m;
                    let value = placed_extinction_per_m(member, &unit_from_world, p);
                    values_per_m[(k * ny + j) * nx + i] += value as f32;
                }
            }
        }
    }
    let grid = ExtinctionGrid {
        origin_m: lo,
        cell_m,
        dims,
        values_per_m,
        coarsened,
    }
    .trimmed();
    let size = grid.max_corner_m() - grid.origin_m;
    let world_from_unit = DMat4::from_translation(grid.origin_m) * DMat4::from_scale(size);
    (grid, world_from_unit)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of `n`³ cells of 10 m holding a ball of σ_t = 0.05 m⁻¹ of
    /// radius 0.4 n cells about its centre.
    fn ball_grid(n: usize) -> ExtinctionGrid {
        let c = 0.5 * n as f64;
        let mut values = vec![0.0f32; n * n * n];
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let d = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5)
                        - DVec3::splat(c);
                    if d.length() < 0.4 * n as f64 {
                        values[(k * n + j) * n + i] = 0.05;
                    }
                }
            }
        }
        ExtinctionGrid {
            origin_m: DVec3::ZERO,
            cell_m: 10.0,
            dims: [n, n, n],
            values_per_m: values,
            coarsened: false,
        }
    }

    fn placed(grid: &ExtinctionGrid, centre_m: DVec3, yaw_rad: f64, scale: f64) -> DMat4 {
        let size = grid.max_corner_m() - grid.origin_m;
        DMat4::from_translation(centre_m)
            * DMat4::from_rotation_y(yaw_rad)
            * DMat4::from_scale(DVec3::splat(scale))
            * DMat4::from_translation(-0.5 * size)
            * DMat4::from_scale(size)
    }

    #[test]
    fn rotated_boxes_overlap_only_where_they_do() {
        let grid = ball_grid(10); // a box of 100 m
        let a = placed(&grid, DVec3::ZERO, 0.0, 1.0);
        // Side by side with a gap, apart.
        assert!(!boxes_overlap(
            &a,
            &placed(&grid, DVec3::new(105.0, 0.0, 0.0), 0.0, 1.0)
        ));
        // Overlapping by 5 m.
        assert!(boxes_overlap(
            &a,
            &placed(&grid, DVec3::new(95.0, 0.0, 0.0), 0.0, 1.0)
        ));
        // Turned 45°: its corner reaches 70.7 m from its centre, so at 115 m
        // it overlaps the first box's face at 50 m, at 125 m it does not.
        let turn = std::f64::consts::FRAC_PI_4;
        assert!(boxes_overlap(
            &a,
            &placed(&grid, DVec3::new(115.0, 0.0, 0.0), turn, 1.0)
        ));
        assert!(!boxes_overlap(
            &a,
            &placed(&grid, DVec3::new(125.0, 0.0, 0.0), turn, 1.0)
        ));
        // Diagonal neighbours whose bounding boxes overlap but whose turned
        // boxes do not (the axis-aligned test would merge them).
        let b = placed(&grid, DVec3::new(100.0, 0.0, 100.0), turn, 1.0);
        assert!(!boxes_overlap(&a, &b));
        // Above, one over the other's top.
        assert!(!boxes_overlap(
            &a,
            &placed(&grid, DVec3::new(0.0, 101.0, 0.0), 0.3, 1.0)
        ));
        assert!(boxes_overlap(
            &a,
            &placed(&grid, DVec3::new(0.0, 60.0, 0.0), 0.3, 0.5)
        ));
    }

    #[test]
    fn groups_follow_chains_of_overlaps() {
        let grid = ball_grid(10);
        let at = |x: f64| placed(&grid, DVec3::new(x, 0.0, 0.0), 0.0, 1.0);
        // 0–1 overlap, 1–2 overlap (0–2 do not), 3 alone, 4–5 overlap.
        let boxes = [
            at(0.0),
            at(90.0),
            at(180.0),
            at(400.0),
            at(600.0),
            at(650.0),
        ];
        assert_eq!(
            overlap_groups(&boxes),
            vec![vec![0, 1, 2], vec![3], vec![4, 5]]
        );
    }

    #[test]
    fn a_merged_grid_holds_the_sum_of_its_members() {
        let grid = ball_grid(24);
        let a = PlacedGrid {
            grid: &grid,
            world_from_unit: placed(&grid, DVec3::new(0.0, 100.0, 0.0), 0.4, 1.0),
        };
        let b = PlacedGrid {
            grid: &grid,
            world_from_unit: placed(&grid, DVec3::new(150.0, 130.0, 40.0), 1.3, 1.2),
        };
        assert!(boxes_overlap(&a.world_from_unit, &b.world_from_unit));
        let (merged, _) = merged_grid(&[a, b], MAX_MERGED_CELLS);
        assert!(!merged.coarsened);
        assert!(
            (merged.cell_m - 10.0).abs() < 1e-9,
            "the finer member's cells"
        );
        // Optical mass (Σ σ_t ΔV) kept: the members' world masses add.
        let mass = |g: &ExtinctionGrid, scale: f64| g.optical_mass_m2() * scale.powi(3);
        let members_mass = mass(&grid, 1.0) + mass(&grid, 1.2);
        let merged_mass = merged.optical_mass_m2();
        assert!(
            (merged_mass / members_mass - 1.0).abs() < 0.03,
            "merged {merged_mass:.0} against {members_mass:.0} m²"
        );
        // Optical depth along rays through both balls' overlap and through
        // each alone: the merged medium's is the sum of the members'.
        let inverse = [a.world_from_unit.inverse(), b.world_from_unit.inverse()];
        let members_tau = |from: DVec3, to: DVec3| -> f64 {
            let steps = 2000;
            let h = (to - from) / steps as f64;
            (0..steps)
                .map(|n| {
                    let p = from + h * (n as f64 + 0.5);
                    placed_extinction_per_m(&a, &inverse[0], p)
                        + placed_extinction_per_m(&b, &inverse[1], p)
                })
                .sum::<f64>()
                * h.length()
        };
        let merged_tau = |from: DVec3, to: DVec3| merged.optical_depth(from, to, 2000);
        for (from, to) in [
            (
                DVec3::new(-300.0, 110.0, 10.0),
                DVec3::new(400.0, 120.0, 30.0),
            ),
            (
                DVec3::new(80.0, -100.0, 20.0),
                DVec3::new(70.0, 400.0, 20.0),
            ),
            (
                DVec3::new(150.0, 130.0, -300.0),
                DVec3::new(150.0, 130.0, 300.0),
            ),
        ] {
            let (want, got) = (members_tau(from, to), merged_tau(from, to));
            assert!(want > 1.0, "the ray crosses a ball (τ {want})");
            assert!(
                (got / want - 1.0).abs() < 0.03,
                "τ {got:.3} against the members' {want:.3}"
            );
        }
    }

    #[test]
    fn a_large_group_is_resampled_within_the_cell_budget() {
        let grid = ball_grid(16);
        let members = [
            PlacedGrid {
                grid: &grid,
                world_from_unit: placed(&grid, DVec3::ZERO, 0.0, 1.0),
            },
            PlacedGrid {
                grid: &grid,
                world_from_unit: placed(&grid, DVec3::new(120.0, 0.0, 0.0), 0.7, 1.0),
            },
        ];
        let (merged, _) = merged_grid(&members, 5_000);
        assert!(merged.coarsened);
        assert!(merged.dims.iter().product::<usize>() <= 5_000);
        let mass = 2.0 * grid.optical_mass_m2();
        assert!((merged.optical_mass_m2() / mass - 1.0).abs() < 0.1);
    }
}
