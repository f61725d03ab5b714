use super::*;
use crate::transport::interior_source::{node_directions, walk};
use crate::transport::rng::Rng;
use crate::transport::test_media::{default_droplets_of_depth, write_generated_table};

/// The table's slab at thickness node `t`: the default droplets.
fn table_slab(t: usize) -> SlabMedium {
    default_droplets_of_depth(THICKNESS_NODES[t])
}

/// Regenerates [`SKY_SOURCE`] (src/transport/sky_source_table.in).
#[test]
#[ignore = "regenerates the table: cargo test --release -p nimbus-physics regenerate_the_sky_source_table -- --ignored --nocapture"]
fn regenerate_the_sky_source_table() {
    let mut table = Vec::with_capacity(TABLE_VALUES);
    for t in 0..THICKNESS_NODES.len() {
        table.extend(solve_sky_source(&table_slab(t), table_settings()));
    }
    write_generated_table(
        "sky_source_table.in",
        "regenerate_the_sky_source_table",
        "[thickness][band][depth][cosine]",
        &table,
        COSINE_NODES,
    );
}

/// The table is what the solver gives now (the thinnest slab, solved
/// again: the solver is deterministic, so to the table's printed digits).
#[test]
fn the_table_matches_a_fresh_solve() {
    let values = solve_sky_source(&table_slab(0), table_settings());
    for (v, value) in values.iter().enumerate() {
        let tabled = f64::from(SKY_SOURCE[v]);
        assert!(
            (value - tabled).abs() <= 1e-4 * tabled.abs().max(1e-3),
            "value {v}: solved {value:.6}, table {tabled:.6}"
        );
    }
}

/// S by a photon tracer: photons enter the top from `band` (their incident
/// cosine drawn in proportion to itself, the azimuth uniform: a band of
/// uniform radiance), the light they carry unscattered to each plane
/// added by its expected value (e^{−z/μ′}/μ′ per unit flux), the scattered
/// flights' crossings by the walk of the sun's table; averaged over the
/// node azimuths. The values at the slab's depth planes × cosine nodes and
/// their standard errors from the batches.
fn traced_sky_source(
    medium: &SlabMedium,
    band: usize,
    photons: u64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    let directions = node_directions();
    let azimuths = directions.len() / COSINE_NODES;
    let planes = depth_planes(medium.optical_depth);
    let (lo, hi) = (BAND_EDGES[band], BAND_EDGES[band + 1]);
    let batches = 8u64;
    let per_batch = photons / batches;
    let mut means = Vec::new();
    for batch in 0..batches {
        let mut rng = Rng::new(seed, batch);
        let mut sums = vec![0.0; planes.len() * directions.len()];
        for _ in 0..per_batch {
            let mu = (lo * lo + rng.uniform() * (hi * hi - lo * lo))
                .sqrt()
                .max(1e-6);
            let phi = 2.0 * std::f64::consts::PI * rng.uniform();
            let sin = (1.0 - mu * mu).max(0.0).sqrt();
            let incident = [sin * phi.cos(), sin * phi.sin(), mu];
            for (d, &z) in planes.iter().enumerate() {
                let fluence = (-z / mu).exp() / mu;
                for (n, w) in directions.iter().enumerate() {
                    let cos = incident[0] * w[0] + incident[1] * w[1] + incident[2] * w[2];
                    sums[d * directions.len() + n] += fluence * medium.phase.value(cos);
                }
            }
            walk(medium, incident, &planes, &directions, &mut rng, &mut sums);
        }
        let mean: Vec<f64> = (0..planes.len() * COSINE_NODES)
            .map(|v| {
                let (d, k) = (v / COSINE_NODES, v % COSINE_NODES);
                let row = &sums[d * directions.len() + k * azimuths..][..azimuths];
                row.iter().sum::<f64>() / (azimuths as f64 * per_batch as f64)
            })
            .collect();
        means.push(mean);
    }
    let n = batches as f64;
    let values: Vec<f64> = (0..means[0].len())
        .map(|v| means.iter().map(|m| m[v]).sum::<f64>() / n)
        .collect();
    let errors = (0..values.len())
        .map(|v| {
            let variance = means
                .iter()
                .map(|m| (m[v] - values[v]).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            (variance / n).sqrt()
        })
        .collect();
    (values, errors)
}

/// The solver against an independent estimator of the same field: a photon
/// tracer agrees with the table at every node of the horizon's and the high
/// sky's bands, in a thin slab and in one 4 deep, within five standard
/// errors or 7 %, whichever is larger (most nodes agree within 2–3 %; the
/// largest differences, 3–6 %, are in the faint light travelling back up,
/// which is the phase function's backscatter of the field going down).
#[test]
fn the_table_matches_a_photon_tracer() {
    for (t, band) in [(1usize, 0usize), (1, 3), (2, 0)] {
        let (values, errors) = traced_sky_source(&table_slab(t), band, 16_000, 5 + band as u64);
        for (v, (value, error)) in values.iter().zip(&errors).enumerate() {
            let (depth, cosine) = (v / COSINE_NODES, v % COSINE_NODES);
            let tabled = f64::from(SKY_SOURCE[table_index(t, band, depth, cosine)]);
            let allowed = (5.0 * error).max(0.07 * tabled);
            assert!(
                (value - tabled).abs() <= allowed,
                "thickness node {t}, band {band}, depth {depth}, cosine {:.1}: traced {value:.4} ± {error:.4}, table {tabled:.4}",
                cosine_node(cosine)
            );
        }
    }
}

/// The sky's light near the top keeps the direction it came from: from the
/// horizon's band, 0.1 below the top of a thick slab, the light travelling
/// at grazing angles (cosine 0.2 to the inward normal) is several times
/// the light travelling straight down, where the high sky's light is
/// strongest straight down; and under an isotropic sky (the bands'
/// irradiances in proportion to their share of it) the light travelling up
/// out of the top at a grazing angle is at least the light going up
/// steeply, where the P1 field with the escape function darkens it.
#[test]
fn the_sky_light_near_the_top_keeps_its_direction() {
    let thick = 12.0;
    let at = |band, cos| sky_source(thick, band, DEPTH_NODES[0], cos);
    assert!(
        at(0, 0.2) > 3.0 * at(0, 1.0),
        "horizon: grazing {:.4}, down {:.4}",
        at(0, 0.2),
        at(0, 1.0)
    );
    assert!(
        at(3, 1.0) > at(3, 0.2),
        "high sky: down {:.4}, grazing {:.4}",
        at(3, 1.0),
        at(3, 0.2)
    );
    let isotropic = |cos: f64| {
        (0..BANDS)
            .map(|b| (BAND_EDGES[b + 1].powi(2) - BAND_EDGES[b].powi(2)) * at(b, cos))
            .sum::<f64>()
    };
    assert!(
        isotropic(-0.2) >= isotropic(-1.0),
        "isotropic sky: up grazing {:.4}, up steep {:.4}",
        isotropic(-0.2),
        isotropic(-1.0)
    );
}

/// Between the nodes the lookup is the nodes' blend: at a node it is the
/// node's value, cosines beyond ±1 are clamped, and a slab thicker than
/// the last node reads the last.
#[test]
fn the_lookup_interpolates_the_nodes() {
    let last = THICKNESS_NODES.len() - 1;
    for (band, depth, cosine) in [(0usize, 0usize, 3usize), (2, 4, 10), (3, 6, 0)] {
        let node = f64::from(SKY_SOURCE[table_index(last, band, depth, cosine)]);
        let read = sky_source(
            THICKNESS_NODES[last],
            band,
            DEPTH_NODES[depth],
            cosine_node(cosine),
        );
        assert!((read - node).abs() < 1e-6, "node {read} against {node}");
        assert_eq!(
            sky_source(40.0, band, DEPTH_NODES[depth], cosine_node(cosine)),
            read
        );
    }
    assert_eq!(sky_source(12.0, 1, 0.5, 1.7), sky_source(12.0, 1, 0.5, 1.0));
    let k = 4;
    let between = sky_source(12.0, 1, DEPTH_NODES[2], cosine_node(k) + 0.1);
    let expected = 0.5
        * (f64::from(SKY_SOURCE[table_index(last, 1, 2, k)])
            + f64::from(SKY_SOURCE[table_index(last, 1, 2, k + 1)]));
    assert!(
        (between - expected).abs() < 1e-6,
        "{between} against {expected}"
    );
}
