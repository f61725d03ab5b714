use super::*;
use crate::transport::monte_carlo::{TraceSettings, trace};
use crate::transport::test_media::{default_droplets_of_depth, write_generated_table};

/// The table's slab at thickness node `t`: the default droplets.
fn table_slab(t: usize) -> SlabMedium {
    default_droplets_of_depth(THICKNESS_NODES[t])
}

/// The seed of the trace at thickness node `t` and sun node `sun` (1–9 for
/// the thickest slab, the table's seeds before it had a thickness axis).
fn table_seed(t: usize, sun: usize) -> u64 {
    let thickest = THICKNESS_NODES.len() - 1;
    if t == thickest {
        1 + sun as u64
    } else {
        100 * (t as u64 + 1) + sun as u64
    }
}

/// Regenerates [`INTERIOR_SOURCE`] (src/transport/interior_source_table.in):
/// 4·10⁵ photons per sun node and thickness. About two minutes on two
/// cores.
#[test]
#[ignore = "regenerates the table: cargo test --release -p nimbus-physics regenerate_the_interior_source_table -- --ignored --nocapture"]
fn regenerate_the_interior_source_table() {
    let mut table = Vec::with_capacity(TABLE_VALUES);
    let mut worst = 0.0f64;
    for t in 0..THICKNESS_NODES.len() {
        let medium = table_slab(t);
        for sun in 0..SUN_NODES {
            let (values, errors) = trace_interior_source(
                &medium,
                sun as f64 * SUN_STEP_DEG,
                400_000,
                table_seed(t, sun),
            );
            for (v, e) in values.iter().zip(&errors) {
                // The relative error of values worth counting (the light
                // travelling back out of a thin slab's lit face is tiny).
                if *v > 1e-3 {
                    worst = worst.max(e / v);
                }
            }
            table.extend(values);
        }
    }
    write_generated_table(
        "interior_source_table.in",
        "regenerate_the_interior_source_table",
        "[thickness][sun][depth][cosine][azimuth]",
        &table,
        AZIMUTH_NODES,
    );
    println!("largest relative standard error {worst:.3}");
}

/// The table is what the tracer gives now: a fresh trace (another seed,
/// fewer photons) at two sun nodes of a thin and of the thickest slab
/// agrees with it at every node within five standard errors or 6 %,
/// whichever is larger.
#[test]
fn the_table_matches_a_fresh_trace() {
    for (t, sun) in [(3usize, 2usize), (3, 6), (1, 4)] {
        let (values, errors) =
            trace_interior_source(&table_slab(t), sun as f64 * SUN_STEP_DEG, 80_000, 977);
        for (v, (value, error)) in values.iter().zip(&errors).enumerate() {
            let tabled =
                f64::from(INTERIOR_SOURCE[t * THICKNESS_NODE_VALUES + sun * SUN_NODE_VALUES + v]);
            let allowed = (5.0 * error).max(0.06 * tabled);
            assert!(
                (value - tabled).abs() <= allowed,
                "thickness node {t}, sun node {sun}, value {v}: traced {value:.4} ± {error:.4}, table {tabled:.4}"
            );
        }
    }
}

/// A thin slab is not the top of a thick one: just above the base of a
/// slab 1.5 scattering optical depths thick under a 44° sun, the light
/// travelling down (out through the base) is 0.45–0.8 of the thick slab's
/// at that depth (what comes back up from below and turns down again is
/// missing), and the light travelling back up towards the lit face under a
/// fifth of it (nothing comes back from below).
#[test]
fn a_thin_slab_keeps_the_light_going_down_and_loses_the_light_coming_back() {
    let base = depth_planes(THICKNESS_NODES[1])[DEPTH_NODES.len() - 1];
    let down_thin = interior_source(THICKNESS_NODES[1], 44.0, base, 0.6, 90.0);
    let down_thick = interior_source(12.0, 44.0, base, 0.6, 90.0);
    let ratio = down_thin / down_thick;
    assert!(
        (0.45..0.8).contains(&ratio),
        "down: thin {down_thin:.4}, thick {down_thick:.4}"
    );
    let up_thin = interior_source(THICKNESS_NODES[1], 44.0, base, -0.6, 90.0);
    let up_thick = interior_source(12.0, 44.0, base, -0.6, 90.0);
    assert!(
        up_thin < 0.2 * up_thick,
        "up: thin {up_thin:.4}, thick {up_thick:.4}"
    );
}

/// Between the nodes the lookup is the nodes' multilinear blend: at a node
/// it is the node's value, and folded azimuths and clamped ranges agree.
#[test]
fn the_lookup_interpolates_the_nodes() {
    let at = |t: usize, i: usize, j: usize, k: usize, l: usize| {
        f64::from(INTERIOR_SOURCE[table_index(t, i, j, k, l)])
    };
    let node = interior_source(12.0, 33.0, DEPTH_NODES[3], cosine_node(7), 45.0);
    assert!((node - at(3, 3, 3, 7, 3)).abs() < 1e-6);
    let middle = interior_source(
        12.0,
        33.0,
        0.5 * (DEPTH_NODES[3] + DEPTH_NODES[4]),
        cosine_node(7),
        45.0,
    );
    assert!((middle - 0.5 * (at(3, 3, 3, 7, 3) + at(3, 3, 4, 7, 3))).abs() < 1e-6);
    assert_eq!(
        interior_source(12.0, 40.0, 1.0, 0.3, 100.0),
        interior_source(12.0, 40.0, 1.0, 0.3, 260.0)
    );
    assert_eq!(
        interior_source(12.0, 40.0, 9.0, 0.3, 100.0),
        interior_source(12.0, 40.0, DEPTH_NODES[6], 0.3, 100.0)
    );
    // Thicker than the last node: the last at the same depth; between two
    // nodes, linear in the logarithm (√(1.5 · 4) is half way), each node
    // slab read at the same fraction of its thickness; thinner than the
    // first, the first at that fraction scaled down linearly; below a thin
    // slab's base, its base.
    assert_eq!(
        interior_source(30.0, 40.0, 1.0, 0.3, 100.0),
        interior_source(12.0, 40.0, 1.0, 0.3, 100.0)
    );
    let fraction = 0.3;
    let half_way = interior_source(
        6f64.sqrt(),
        33.0,
        fraction * 6f64.sqrt(),
        cosine_node(7),
        45.0,
    );
    let node_slab = |t: usize| {
        interior_source_in_slab(t, 33.0, fraction * THICKNESS_NODES[t], cosine_node(7), 45.0)
    };
    assert!((half_way - 0.5 * (node_slab(1) + node_slab(2))).abs() < 1e-6);
    let thin = interior_source(0.2, 33.0, 0.04, cosine_node(7), 45.0);
    assert!((thin - 0.4 * at(0, 3, 0, 7, 3)).abs() < 1e-6);
    assert_eq!(
        interior_source(1.5, 40.0, 3.0, 0.3, 100.0),
        interior_source(1.5, 40.0, 2.0, 0.3, 100.0)
    );
}

/// The source's integral over directions is the scattered fluence (the
/// phase function is normalised): at three depths under a 44° sun it
/// agrees within 4 % with the slab tracer's own interior tally (the
/// radiance crossing the plane, summed over its bins), an independent
/// estimator of the same walk.
#[test]
fn the_source_integrates_to_the_tracers_fluence() {
    let thickest = THICKNESS_NODES.len() - 1;
    let medium = table_slab(thickest);
    let sun = 4usize;
    let mu0 = (sun as f64 * SUN_STEP_DEG).to_radians().cos();
    for depth in [1usize, 3, 5] {
        // ∫ S dΩ over the nodes: trapezoids in the cosine, azimuth folded.
        let mut integral = 0.0;
        for k in 0..COSINE_NODES {
            let wk = if k == 0 || k == COSINE_NODES - 1 {
                0.5
            } else {
                1.0
            } * 2.0
                / (COSINE_NODES - 1) as f64;
            for l in 0..AZIMUTH_NODES {
                let wl = if l == 0 || l == AZIMUTH_NODES - 1 {
                    0.5
                } else {
                    1.0
                } * 2.0
                    * AZIMUTH_STEP_DEG.to_radians();
                integral +=
                    wk * wl * f64::from(INTERIOR_SOURCE[table_index(thickest, sun, depth, k, l)]);
            }
        }
        let settings = TraceSettings {
            photons: 100_000,
            seed: 31,
            sun_zenith_deg: sun as f64 * SUN_STEP_DEG,
            interior_depth: Some(DEPTH_NODES[depth]),
            interior_cosine_bins: 40,
            ..TraceSettings::default()
        };
        let traced = trace(&medium, &settings, &|_| {});
        let bin = 4.0 * std::f64::consts::PI / 40.0;
        let fluence: f64 = traced.interior.iter().map(|e| e.value * bin).sum::<f64>() * mu0;
        assert!(
            (integral / fluence - 1.0).abs() < 0.04,
            "depth {}: ∫ S dΩ {integral:.4}, traced fluence {fluence:.4}",
            DEPTH_NODES[depth]
        );
    }
}
