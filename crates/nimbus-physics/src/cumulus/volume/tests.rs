//! Tests of the cumulus extinction grid (`super`): the shader's core and
//! corona (Bouthors 2004, eqs 5.31–5.32), conservation of the optical mass,
//! the analytic optical depth of one blob, determinism and Mitsuba's format.

use super::*;
use crate::cumulus::field::{Blob, Floor, LevelBlend};
use crate::cumulus::hierarchy::{self, Cumulus, CumulusParams, RootBlob, Roots};
use crate::cumulus::mesh::surface_seeds;
use crate::cumulus::sampler::project_to_surface;
use crate::cumulus::shading::chord_density_integral_m;
use std::sync::OnceLock;

const ALPHA: f64 = 0.075;
const CORONA: f64 = 10.0;

/// One round blob of radius `r` at (0, 500, 0), no floor in reach:
/// f = exp(1 − d/R).
fn blob_field(radius_m: f64) -> BlobField {
    let mut field = BlobField::new(Floor {
        height_m: -1e6,
        stiffness_m: 100.0,
    });
    let blend = LevelBlend {
        furrow_offset: 0.5,
        blending: 0.0,
        blend_sharpness: 10.0,
    };
    let blob = Blob {
        centre_m: DVec3::new(0.0, 500.0, 0.0),
        radius_m,
        flattening: 0.0,
    };
    field.push_level(vec![blob], blend);
    field
}

/// Two roots and one generated level (~33 blobs of ~50 m, the paper's
/// finest scale), seeded.
fn cloud_params(seed: u64) -> CumulusParams {
    let root = |centre_m, radius_m, flattening| RootBlob {
        centre_m,
        radius_m,
        flattening,
    };
    CumulusParams {
        roots: Roots::Given(vec![
            root([0.0, 150.0, 0.0], 160.0, 0.3),
            root([200.0, 120.0, 30.0], 120.0, 0.5),
        ]),
        generated_levels: 1,
        seed,
        ..CumulusParams::default()
    }
}

fn cloud() -> &'static (Cumulus, ExtinctionGrid) {
    static CLOUD: OnceLock<(Cumulus, ExtinctionGrid)> = OnceLock::new();
    CLOUD.get_or_init(|| {
        let c = hierarchy::build(&cloud_params(1), |_| {}).expect("build");
        let grid = extinction_grid(&c.field, &VolumeParams::default()).expect("grid");
        (c, grid)
    })
}

fn centre_of(grid: &ExtinctionGrid, [i, j, k]: [usize; 3]) -> DVec3 {
    grid.origin_m + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * grid.cell_m
}

/// The core (depth ≥ r) holds exactly α_ρ, the shader's density_per_m.
#[test]
fn core_equals_alpha_rho() {
    let params = VolumeParams::default();
    assert_eq!(params.density_per_m, ALPHA);
    let field = blob_field(100.0);
    let grid = extinction_grid(&field, &params).expect("grid");
    let centre = DVec3::new(0.0, 500.0, 0.0);
    for p in [centre, centre + DVec3::X * 50.0, centre - DVec3::Y * 89.0] {
        assert_eq!(extinction_per_m(&field, &params, p), ALPHA);
    }
    for (n, &v) in grid.values_per_m.iter().enumerate() {
        let [nx, ny, _] = grid.dims;
        let p = centre_of(&grid, [n % nx, (n / nx) % ny, n / (nx * ny)]);
        if p.distance(centre) <= 100.0 - CORONA - 1e-6 {
            assert_eq!(v, ALPHA as f32, "{p}");
        }
    }
    // Generated cloud: the roots' centres are deep in the core.
    let (c, _) = cloud();
    for b in c.field.blobs(0) {
        assert_eq!(extinction_per_m(&c.field, &params, b.centre_m), ALPHA);
    }
}

/// σ_t = 0 wherever f_L ≤ 1 (outside the mesh's surface) and far away;
/// the grid's outer layer is 0, so Mitsuba's clamped lookups give 0
/// beyond it.
#[test]
fn zero_outside_the_surface() {
    let (c, grid) = cloud();
    let last = c.field.level_count() - 1;
    let [nx, ny, _] = grid.dims;
    let mut outside = 0;
    for n in (0..grid.values_per_m.len()).step_by(7) {
        let cell = [n % nx, (n / nx) % ny, n / (nx * ny)];
        if c.field.sample(last, centre_of(grid, cell)).potential.value <= 1.0 {
            assert_eq!(grid.values_per_m[n], 0.0, "{cell:?}");
            outside += 1;
        }
        if cell
            .iter()
            .zip(grid.dims)
            .any(|(&i, d)| i == 0 || i + 1 == d)
        {
            assert_eq!(grid.values_per_m[n], 0.0, "edge cell {cell:?}");
        }
    }
    assert!(outside > 1000, "{outside}");
    let far = grid.max_corner_m() + DVec3::splat(500.0);
    assert_eq!(
        extinction_per_m(&c.field, &VolumeParams::default(), far),
        0.0
    );
    assert_eq!(grid.lookup_per_m(far), 0.0);
}

/// The corona: α_ρ saturate(δ/r), the shader's saturate((R − s)/r)
/// (shading::chord_density_integral_m's integrand). One round blob,
/// exactly and monotone, also for a scaled instance (the corona stays
/// r in world metres); a generated cloud, along the inward normal of
/// points projected on S_L, within 0.5 m of depth at 90 % of them.
#[test]
fn corona_profile_matches_the_shader() {
    let field = blob_field(100.0);
    let centre = DVec3::new(0.0, 500.0, 0.0);
    for scale in [1.0, 2.0] {
        let params = VolumeParams {
            scale,
            ..VolumeParams::default()
        };
        let big_r = 100.0 * scale;
        let mut previous = 0.0;
        for n in 0..=60 {
            let depth = -5.0 + n as f64 * 0.25;
            let dir = DVec3::new(0.3, -0.8, 0.52).normalize();
            let v = extinction_per_m(&field, &params, centre * scale + dir * (big_r - depth));
            let shader = ALPHA * ((big_r - (big_r - depth)) / CORONA).clamp(0.0, 1.0);
            assert!((v - shader).abs() < 1e-9, "depth {depth}: {v} vs {shader}");
            assert!(v >= previous);
            previous = v;
        }
    }
    let (c, _) = cloud();
    let last = c.field.level_count() - 1;
    let potential = |p: DVec3| c.field.sample(last, p).potential;
    let params = VolumeParams::default();
    let mut errors: Vec<Vec<f64>> = vec![Vec::new(); 4];
    for seed in surface_seeds(&c.field, last, 1.0) {
        let Some(p) = project_to_surface(&potential, seed, 20.0) else {
            continue;
        };
        let inward = potential(p).gradient.normalize();
        for (k, depth) in [2.5, 5.0, 7.5, 15.0].into_iter().enumerate() {
            let v = extinction_per_m(&c.field, &params, p + inward * depth);
            errors[k].push((v / ALPHA - (depth / CORONA).min(1.0)).abs());
        }
    }
    for (k, mut e) in errors.into_iter().enumerate() {
        assert!(e.len() >= 20, "{} surface points", e.len());
        e.sort_by(f64::total_cmp);
        let p90 = e[e.len() * 9 / 10];
        assert!(p90 < 0.05, "depth #{k}: 90th percentile error {p90}");
    }
}

/// Σ σ_t ΔV of the generated cloud changes by less than 2 % when the
/// cell halves (from twice the default to the default), and that of one
/// blob of R = 100 m on cells of 10 m is within 1 % of
/// α_ρ ∫ saturate((R − s)/r) 4πs² ds.
#[test]
fn optical_mass_converges() {
    let (c, fine) = cloud();
    let coarse = VolumeParams {
        cell_m: Some(2.0 * fine.cell_m),
        ..VolumeParams::default()
    };
    let coarse = extinction_grid(&c.field, &coarse).expect("coarse");
    let (a, b) = (coarse.optical_mass_m2(), fine.optical_mass_m2());
    assert!((a / b - 1.0).abs() < 0.02, "{a} vs {b}");
    let (big_r, r) = (100.0f64, CORONA);
    let a0 = big_r - r;
    let shell =
        (big_r * (big_r.powi(3) - a0.powi(3)) / 3.0 - (big_r.powi(4) - a0.powi(4)) / 4.0) / r;
    let exact = ALPHA * 4.0 * std::f64::consts::PI * (a0.powi(3) / 3.0 + shell);
    let params = VolumeParams {
        cell_m: Some(10.0),
        ..VolumeParams::default()
    };
    let mass = extinction_grid(&blob_field(big_r), &params)
        .expect("grid")
        .optical_mass_m2();
    assert!((mass / exact - 1.0).abs() < 0.01, "{mass} vs {exact}");
}

/// One blob of R = 100 m: the optical depth through its centre, read
/// as Mitsuba interpolates the grid, is α_ρ (2R − r), the shader's
/// chord integral at impact 0, within α_ρ × one cell (the edge is
/// resolved to a cell) at the default cell (R/4), and within 1 % at R/20.
#[test]
fn optical_depth_through_one_blob() {
    let field = blob_field(100.0);
    let analytic = ALPHA * chord_density_integral_m(0.0, 100.0, CORONA);
    assert!((analytic - ALPHA * (200.0 - CORONA)).abs() < 1e-9);
    let centre = DVec3::new(0.0, 500.0, 0.0);
    for (cell, tolerance) in [(None, ALPHA * 25.0), (Some(5.0), 0.01 * analytic)] {
        let params = VolumeParams {
            cell_m: cell,
            ..VolumeParams::default()
        };
        let grid = extinction_grid(&field, &params).expect("grid");
        for dir in [DVec3::X, DVec3::new(0.0, 0.6, 0.8)] {
            let tau = grid.optical_depth(centre - dir * 200.0, centre + dir * 200.0, 4000);
            assert!(
                (tau - analytic).abs() < tolerance,
                "cell {}: τ {tau} vs {analytic}",
                grid.cell_m
            );
        }
    }
}

/// The same seed gives the same grid, bit for bit; another seed another.
#[test]
fn deterministic_by_seed() {
    let (_, a) = cloud();
    let params = VolumeParams {
        cell_m: Some(2.0 * a.cell_m),
        ..VolumeParams::default()
    };
    let again = hierarchy::build(&cloud_params(1), |_| {}).expect("build");
    let b = extinction_grid(
        &again.field,
        &VolumeParams {
            cell_m: Some(a.cell_m),
            ..params
        },
    );
    assert_eq!(Some(a), b.as_ref().ok());
    let other = hierarchy::build(&cloud_params(2), |_| {}).expect("build");
    let c = extinction_grid(
        &other.field,
        &VolumeParams {
            cell_m: Some(a.cell_m),
            ..params
        },
    );
    assert_ne!(Some(a), c.as_ref().ok());
}

/// Mitsuba 3's `.vol` (src/volumes/grid.cpp): "VOL", 3, encoding 1,
/// x, y, z resolutions, 1 channel, the bounding box, then 4 bytes a cell
/// in x-fastest order.
#[test]
fn mitsuba_vol_header_and_length() {
    let grid = ExtinctionGrid {
        origin_m: DVec3::new(-10.0, 0.0, 5.0),
        cell_m: 2.0,
        dims: [3, 2, 4],
        values_per_m: (0..24).map(|n| n as f32 * 0.5).collect(),
        coarsened: false,
    };
    let bytes = grid.to_mitsuba_vol();
    assert_eq!(bytes.len(), 48 + 4 * 24);
    assert_eq!(&bytes[..4], b"VOL\x03");
    let i32_at =
        |o: usize| i32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let f32_at =
        |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    assert_eq!(
        [i32_at(4), i32_at(8), i32_at(12), i32_at(16), i32_at(20)],
        [1, 3, 2, 4, 1]
    );
    let bbox: Vec<f32> = (0..6).map(|k| f32_at(24 + 4 * k)).collect();
    assert_eq!(bbox, [-10.0, 0.0, 5.0, -4.0, 4.0, 13.0]);
    // data[((z ysize + y) xsize + x)]: cell (1, 1, 2) is element 16, 8.0.
    assert_eq!(f32_at(48 + 4 * ((2 * 2 + 1) * 3 + 1)), 8.0);
    assert_eq!(grid.value_per_m([1, 1, 2]), 8.0);
}

/// Bad parameters are refused with their name; a tight cap coarsens
/// the cell instead of failing; an empty field is an error.
#[test]
fn parameters_are_checked_and_the_cap_coarsens() {
    let field = blob_field(100.0);
    let bad = VolumeParams {
        corona_thickness_m: f64::NAN,
        ..VolumeParams::default()
    };
    let e = extinction_grid(&field, &bad).expect_err("error");
    assert!(e.to_string().starts_with("corona_thickness_m = NaN"), "{e}");
    let bad = VolumeParams {
        max_cells: MAX_CELLS_LIMIT + 1,
        ..VolumeParams::default()
    };
    assert!(matches!(
        extinction_grid(&field, &bad),
        Err(VolumeError::OutOfRange {
            key: "max_cells",
            ..
        })
    ));
    let capped = VolumeParams {
        max_cells: 200,
        ..VolumeParams::default()
    };
    let grid = extinction_grid(&field, &capped).expect("grid");
    assert!(grid.coarsened && grid.cell_m > 25.0, "{}", grid.cell_m);
    assert!(
        grid.dims.iter().product::<usize>() <= 200,
        "{:?}",
        grid.dims
    );
    assert!(grid.optical_mass_m2() > 0.0);
    let empty = BlobField::new(Floor {
        height_m: 0.0,
        stiffness_m: 100.0,
    });
    assert_eq!(
        extinction_grid(&empty, &VolumeParams::default()),
        Err(VolumeError::EmptyField)
    );
}

/// With the bump on, σ_t = α_ρ (1 − α_b h(x)) in the core, h the
/// shader's bump noise (shading::bump_height) at the renderer's noise
/// coordinates.
#[test]
fn bump_modulates_the_core() {
    let field = blob_field(100.0);
    let bump = BumpModulation {
        amplitude: 0.25,
        wavelength_m: 30.0,
        object_origin_m: DVec3::new(0.0, 400.0, 0.0),
        offset: 37.31,
        lacunarity: 3.0,
        octaves: 3,
    };
    let params = VolumeParams {
        bump: Some(bump),
        ..VolumeParams::default()
    };
    let mut seen = Vec::new();
    for n in 0..20 {
        let p = DVec3::new(n as f64 * 3.7 - 35.0, 480.0 + n as f64, 10.0);
        let x = (p - bump.object_origin_m) / 30.0 + DVec3::splat(37.31);
        let expected = ALPHA * (1.0 - 0.25 * bump_height(x, 3.0, 3));
        let v = extinction_per_m(&field, &params, p);
        assert!(
            (v - expected).abs() < 1e-12 && v >= 0.75 * ALPHA,
            "{v} vs {expected}"
        );
        seen.push(v);
    }
    assert!(seen.iter().any(|&v| (v - seen[0]).abs() > 1e-3 * ALPHA));
}

#[test]
fn trimming_keeps_the_non_zero_cells_and_one_layer_around_them() {
    let grid_with = |cells: &[[usize; 3]]| {
        let mut values = vec![0.0f32; 1000];
        for &[i, j, k] in cells {
            values[(k * 10 + j) * 10 + i] = 0.05;
        }
        ExtinctionGrid {
            origin_m: DVec3::new(100.0, 200.0, 300.0),
            cell_m: 10.0,
            dims: [10, 10, 10],
            values_per_m: values,
            coarsened: false,
        }
    };
    let full = grid_with(&[[3, 4, 5], [5, 4, 6]]);
    let trimmed = full.clone().trimmed();
    assert_eq!(trimmed.dims, [5, 3, 4]);
    assert_eq!(trimmed.origin_m, DVec3::new(120.0, 230.0, 340.0));
    assert_eq!(trimmed.optical_mass_m2(), full.optical_mass_m2());
    // The same medium wherever the trimmed grid reaches.
    for p in [
        DVec3::new(135.0, 245.0, 355.0),
        DVec3::new(151.0, 247.0, 362.0),
        DVec3::new(128.0, 241.0, 349.0),
    ] {
        let (a, b) = (trimmed.lookup_per_m(p), full.lookup_per_m(p));
        assert!(b > 0.0 && (a - b).abs() < 1e-9, "{p}: {a} against {b}");
    }
    // At the grid's edge there is no layer to keep; an empty grid stays.
    assert_eq!(grid_with(&[[0, 9, 0]]).trimmed().dims, [2, 2, 2]);
    assert_eq!(grid_with(&[]).trimmed().dims, [10, 10, 10]);
}
