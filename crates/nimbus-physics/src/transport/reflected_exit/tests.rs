use super::*;
use crate::transport::test_media::default_droplets_slab;

/// The table is what the tracer gives now: a fresh trace (other seed, fewer
/// photons) at two sun nodes agrees with it at every view node within four
/// standard errors or 8 %, whichever is larger.
#[test]
fn the_table_matches_a_fresh_trace() {
    let medium = default_droplets_slab(TABLE_THICKNESS_M);
    let views = node_views();
    for sun in [3, 7] {
        let settings = TraceSettings {
            photons: 60_000,
            seed: 977,
            sun_zenith_deg: sun as f64 * ZENITH_STEP_DEG,
            views: views.clone(),
            zenith_bins: 1,
            azimuth_bins: 1,
            ..TraceSettings::default()
        };
        let traced = trace(&medium, &settings, &|_| {});
        let lambertian = traced.reflectance.order3plus.value / std::f64::consts::PI;
        for (v, estimate) in traced.radiance.iter().enumerate() {
            let (j, k) = (v / AZIMUTH_NODES, v % AZIMUTH_NODES);
            let fresh = estimate.order3plus.value / lambertian;
            let error = estimate.order3plus.std_error / lambertian;
            let stored = f64::from(REFLECTED_SHAPE[table_index(sun, j, k)]);
            assert!(
                (fresh - stored).abs() <= (4.0 * error).max(0.08 * stored),
                "sun node {sun}, view node {j}, azimuth node {k}: traced {fresh:.3} ± {error:.3}, table {stored:.3}"
            );
        }
    }
}

/// The shape moves the reflected orders 3+ without changing their flux:
/// ∫ A(θ_l, θ_v, φ) cos θ_v dω over the upper hemisphere is π (within 6 %:
/// the table's interpolation and its noise) at every sun angle.
#[test]
fn the_shape_keeps_the_flux() {
    for sun_zenith_deg in [0.0, 30.0, 60.0, 75.0, 85.0] {
        let (n_theta, n_phi) = (90, 72);
        let mut integral = 0.0;
        for a in 0..n_theta {
            let theta = (a as f64 + 0.5) * std::f64::consts::FRAC_PI_2 / n_theta as f64;
            for b in 0..n_phi {
                let phi = (b as f64 + 0.5) * 360.0 / n_phi as f64;
                let shape = reflected_shape(sun_zenith_deg, theta.to_degrees(), phi);
                integral += shape * theta.cos() * theta.sin();
            }
        }
        integral *=
            std::f64::consts::FRAC_PI_2 / n_theta as f64 * std::f64::consts::TAU / n_phi as f64;
        let ratio = integral / std::f64::consts::PI;
        assert!(
            (ratio - 1.0).abs() < 0.06,
            "sun {sun_zenith_deg}°: ∫ A μ dω / π = {ratio:.3}"
        );
    }
}

/// Interpolation returns the nodes, folds the azimuth and clamps the zenith.
#[test]
fn the_lookup_returns_the_nodes() {
    let node = |i: usize, j: usize, k: usize| f64::from(REFLECTED_SHAPE[table_index(i, j, k)]);
    assert!((reflected_shape(33.0, 44.0, 60.0) - node(3, 4, 2)).abs() < 1e-6);
    assert!((reflected_shape(33.0, 44.0, -60.0) - node(3, 4, 2)).abs() < 1e-6);
    assert!((reflected_shape(33.0, 44.0, 300.0) - node(3, 4, 2)).abs() < 1e-6);
    assert!((reflected_shape(89.9, 95.0, 180.0) - node(8, 8, 6)).abs() < 1e-6);
}

/// Regenerates [`REFLECTED_SHAPE`] (prints the Rust array) and reports how
/// much the shape moves with the slab's thickness (150 m and 600 m against
/// the table's 300 m). About a minute on two cores in release.
#[test]
#[ignore = "regenerates the table: cargo test --release -p nimbus-physics regenerate_the_reflected_shape_table -- --ignored --nocapture"]
fn regenerate_the_reflected_shape_table() {
    let (values, errors) =
        trace_reflected_shape(&default_droplets_slab(TABLE_THICKNESS_M), 400_000, 1);
    println!("pub const REFLECTED_SHAPE: [f32; TABLE_VALUES] = [");
    for i in 0..ZENITH_NODES {
        println!("    // sun zenith {}°", i as f64 * ZENITH_STEP_DEG);
        for j in 0..ZENITH_NODES {
            let row: Vec<String> = (0..AZIMUTH_NODES)
                .map(|k| format!("{:.4}", values[table_index(i, j, k)]))
                .collect();
            println!("    {},", row.join(", "));
        }
    }
    println!("];");
    let worst_error = values
        .iter()
        .zip(&errors)
        .map(|(v, e)| e / v.max(1e-9))
        .fold(0.0f64, f64::max);
    println!("largest relative standard error {worst_error:.3}");
    for thickness_m in [150.0, 600.0] {
        let (other, _) = trace_reflected_shape(&default_droplets_slab(thickness_m), 100_000, 5);
        let worst = other
            .iter()
            .zip(&values)
            .map(|(a, b)| (a / b - 1.0).abs())
            .fold(0.0f64, f64::max);
        let mean = other
            .iter()
            .zip(&values)
            .map(|(a, b)| (a / b - 1.0).abs())
            .sum::<f64>()
            / values.len() as f64;
        println!(
            "{thickness_m} m against {TABLE_THICKNESS_M} m: mean |ratio − 1| {mean:.3}, largest {worst:.3}"
        );
    }
}
