//! How orders 3+ leave a thick stratus slab: the analytic model's
//! [`DiffuseExit`] against nimbus's Monte-Carlo slab with the same droplets
//! (modified Mie phase function P_S and extinction κ_S, as the analytic
//! model's orders 1–3+ see them), by angle below the slab.

use nimbus_physics::optics::dsd::{SizeDistribution, bulk_optics};
use nimbus_physics::optics::phase::PhaseTable;
use nimbus_physics::optics::tables::computation_angles;
use nimbus_physics::optics::water::water_refractive_index;
use nimbus_physics::transport::monte_carlo::{SlabMedium, TraceSettings, ViewDirection, trace};
use nimbus_physics::transport::phase_model::PhaseModel;
use nimbus_physics::transport::stratus::{
    DiffuseExit, StratusModel, StratusOptics, escape_function,
};

/// The transmitted and reflected radiance of orders 3+ of a 500 m slab of the default
/// droplets (r_e 7 µm, γ 2, 300 cm⁻³, 550 nm) under a 45° sun, by exit
/// angle, per unit flux on the top: the Monte-Carlo slab's binned radiance
/// (averaged over azimuth: these orders have forgotten the sun's azimuth)
/// against the analytic model with each diffuse exit. Transmitted: the
/// escape function is within 12 % at every angle from 2.5° to 87.5° from
/// the normal, the paper's Lambertian exit 30 % off or more at the ends.
/// Reflected: the Lambertian exit is within 10 % up to 70° from the normal,
/// where the escape function is 30 % off or more (so reflection keeps it).
#[test]
fn diffuse_light_leaves_by_the_escape_function() {
    let forward_peak_deg = 5.0;
    let dsd = SizeDistribution::ModifiedGamma {
        number_density_per_m3: 300e6,
        gamma: 2.0,
        effective_radius_m: 7e-6,
    };
    let optics = bulk_optics(
        &dsd,
        550.0,
        water_refractive_index(550.0),
        &computation_angles(forward_peak_deg),
        1e-3,
    );
    let phase = PhaseTable::new(optics.angles_deg.clone(), optics.phase.clone());
    let thickness_m = 500.0;
    let sun_zenith_deg = 45.0;
    let model = StratusModel::new(StratusOptics::from_phase(
        &phase,
        optics.extinction_per_m,
        forward_peak_deg,
    ));
    let modified_extinction = model.optics.modified_extinction_per_m();
    let medium = SlabMedium {
        optical_depth: modified_extinction * thickness_m,
        single_scattering_albedo: optics.single_scattering_albedo(),
        phase: PhaseModel::tabulated(&phase.peak_removed(forward_peak_deg)),
    };
    let settings = TraceSettings {
        photons: 400_000,
        seed: 42,
        sun_zenith_deg,
        views: Vec::new(),
        zenith_bins: 18,
        azimuth_bins: 6,
        ..TraceSettings::default()
    };
    let traced = trace(&medium, &settings, &|_| {});
    let escape = model.clone().with_diffuse_exit(DiffuseExit::EscapeFunction);
    for (side, binned) in [
        ("transmitted", &traced.transmitted),
        ("reflected", &traced.reflected),
    ] {
        let order3plus = &binned.radiance[3];
        let mut lambertian_worst = 0.0f64;
        let mut worst_escape = 0.0f64;
        for zenith_bin in 0..settings.zenith_bins {
            // Bin centre: exit angle from the slab's outward normal.
            let exit_deg = (zenith_bin as f64 + 0.5) * 90.0 / settings.zenith_bins as f64;
            let row = &order3plus
                [zenith_bin * settings.azimuth_bins..(zenith_bin + 1) * settings.azimuth_bins];
            let traced_radiance = row.iter().sum::<f64>() / row.len() as f64;
            let view = ViewDirection {
                zenith_deg: if side == "reflected" {
                    exit_deg
                } else {
                    180.0 - exit_deg
                },
                relative_azimuth_deg: 90.0,
            };
            let with_escape = escape
                .radiance(thickness_m, sun_zenith_deg, view)
                .order3plus;
            let lambertian = model.radiance(thickness_m, sun_zenith_deg, view).order3plus;
            let error = with_escape / traced_radiance - 1.0;
            let lambertian_error = lambertian / traced_radiance - 1.0;
            if side == "reflected" {
                // Reflection keeps the Lambertian exit: within 10 % up to
                // 70° from the normal, where the escape function is not.
                if exit_deg < 70.0 {
                    assert!(
                        lambertian_error.abs() < 0.1,
                        "reflected, {exit_deg}°: Monte Carlo {traced_radiance:.4}, Lambertian {lambertian:.4}"
                    );
                    // What the escape function would give (the model
                    // applies it to transmission only).
                    let escaped = escape_function(exit_deg.to_radians().cos()) * lambertian;
                    worst_escape = worst_escape.max((escaped / traced_radiance - 1.0).abs());
                }
                continue;
            }
            assert!(
                error.abs() < 0.12,
                "{side}, {exit_deg}° from the normal: Monte Carlo {traced_radiance:.4} sr⁻¹, \
                 escape function {with_escape:.4} ({:+.1} %), Lambertian {lambertian:.4}",
                100.0 * error
            );
            lambertian_worst = lambertian_worst.max(lambertian_error.abs());
        }
        if side == "reflected" {
            assert!(
                worst_escape > 0.3,
                "reflected: the escape function is within {:.1} % up to 70°: the test does not tell them apart",
                100.0 * worst_escape
            );
        } else {
            assert!(
                lambertian_worst > 0.3,
                "transmitted: the Lambertian exit is within {:.1} % everywhere: the test does not tell them apart",
                100.0 * lambertian_worst
            );
        }
    }
}

/// The escape function carries unit flux, so it moves light between angles
/// without changing the layer's transmittance and reflectance.
#[test]
fn escape_function_is_normalised() {
    let n = 100_000;
    let integral: f64 = (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            escape_function(mu) * 2.0 * mu / n as f64
        })
        .sum();
    assert!((integral - 1.0).abs() < 1e-6, "{integral}");
    assert_eq!(DiffuseExit::Lambertian.weight(0.3), 1.0);
}
