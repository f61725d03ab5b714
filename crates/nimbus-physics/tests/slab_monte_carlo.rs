//! The slab photon tracer against DISORT's published test problems
//! (Stamnes et al. 1988; expected values from DISOTEST.f, DISORT 1.2,
//! `BLOCK DATA CHEKDO`, which its authors checked against van de Hulst 1980
//! tables 12 and 35 and against the C port's tests, cdisort 2.1
//! `test_cdisort.c`, checked against van de Hulst table 37), against
//! van de Hulst's HG slab as reproduced by Wang, Jacques & Zheng (MCML,
//! Comput. Methods Programs Biomed. 47, 1995), and against conservation and
//! the single-scattering limit.

use nimbus_physics::transport::monte_carlo::{SlabMedium, TraceSettings, ViewDirection, trace};
use nimbus_physics::transport::phase_model::PhaseModel;

fn run(
    optical_depth: f64,
    albedo: f64,
    phase: PhaseModel,
    sun_zenith_deg: f64,
    photons: u64,
    views: Vec<ViewDirection>,
) -> nimbus_physics::transport::monte_carlo::TraceResult {
    let medium = SlabMedium {
        optical_depth,
        single_scattering_albedo: albedo,
        phase,
    };
    let settings = TraceSettings {
        photons,
        seed: 20061,
        sun_zenith_deg,
        views,
        ..TraceSettings::default()
    };
    trace(&medium, &settings, &|_| {})
}

/// |value − expected| within four standard errors plus a small allowance
/// for the reference's own rounding.
fn assert_close(name: &str, value: f64, std_error: f64, expected: f64) {
    let allowed = 4.0 * std_error + 2e-4;
    assert!(
        (value - expected).abs() <= allowed,
        "{name}: {value:.5} ± {std_error:.5}, expected {expected:.5}"
    );
}

#[test]
fn fluxes_match_disort_test_problems() {
    // (name, τ, ϖ, phase, μ0, R, T (total, direct included)).
    let mu0_01 = 0.1f64.acos().to_degrees();
    let cases = [
        (
            "1a",
            0.03125,
            0.2,
            PhaseModel::Isotropic,
            mu0_01,
            0.02545,
            0.75689,
        ),
        (
            "1b",
            0.03125,
            1.0,
            PhaseModel::Isotropic,
            mu0_01,
            0.13462,
            0.86538,
        ),
        ("1d", 32.0, 0.2, PhaseModel::Isotropic, mu0_01, 0.08266, 0.0),
        (
            "1e",
            32.0,
            1.0,
            PhaseModel::Isotropic,
            mu0_01,
            0.97845,
            0.02155,
        ),
        (
            "3a",
            1.0,
            0.2,
            PhaseModel::HenyeyGreenstein { g: 0.75 },
            mu0_01,
            0.05410,
            0.01502,
        ),
        (
            "3b",
            1.0,
            1.0,
            PhaseModel::HenyeyGreenstein { g: 0.75 },
            mu0_01,
            0.58152,
            0.41848,
        ),
        (
            "3e",
            8.0,
            1.0,
            PhaseModel::HenyeyGreenstein { g: 0.75 },
            mu0_01,
            0.81157,
            0.18843,
        ),
        (
            "c3a",
            1.0,
            1.0,
            PhaseModel::HenyeyGreenstein { g: 0.75 },
            0.0,
            0.07874,
            0.92126,
        ),
        (
            "c3b",
            8.0,
            1.0,
            PhaseModel::HenyeyGreenstein { g: 0.75 },
            0.0,
            0.50642,
            0.49358,
        ),
        (
            "mcml",
            2.0,
            0.9,
            PhaseModel::HenyeyGreenstein { g: 0.75 },
            0.0,
            0.09739,
            0.66096,
        ),
    ];
    for (name, tau, albedo, phase, sun, r, t) in cases {
        let result = run(tau, albedo, phase, sun, 100_000, Vec::new());
        let (rr, tt) = (result.reflectance.total, result.transmittance.total);
        assert_close(&format!("{name} R"), rr.value, rr.std_error, r);
        assert_close(&format!("{name} T"), tt.value, tt.std_error, t);
    }
}

#[test]
fn direct_transmittance_is_the_beers_law_fraction() {
    // DISORT 1a/1b: rfldir / (μ0 F) = e^{−τ/μ0} = 0.73162.
    let result = run(
        0.03125,
        1.0,
        PhaseModel::Isotropic,
        0.1f64.acos().to_degrees(),
        100_000,
        Vec::new(),
    );
    let direct = result.transmittance.order0;
    assert_close("direct", direct.value, direct.std_error, (-0.3125f64).exp());
}

#[test]
fn local_estimates_match_disort_intensities() {
    // Isotropic scattering has no azimuthal dependence, so DISORT's
    // azimuthal means apply at any azimuth. uu / (μ0 F) with μ0 F = π.
    let mu0 = 0.1f64.acos().to_degrees();
    let views: Vec<ViewDirection> = [1.0f64, 0.5, 0.1]
        .iter()
        .map(|mu| ViewDirection {
            zenith_deg: mu.acos().to_degrees(),
            relative_azimuth_deg: 37.0,
        })
        .chain([1.0f64, 0.5].iter().map(|mu| ViewDirection {
            zenith_deg: 180.0 - mu.acos().to_degrees(),
            relative_azimuth_deg: 37.0,
        }))
        .collect();
    let pi = std::f64::consts::PI;
    // 1e (τ = 32, conservative): top at μ = 1, 0.5, 0.1; bottom at μ = 1, 0.5
    // (DISORT lists the bottom at umu = −1, −0.5, −0.1).
    let expected = [0.797199, 1.02732, 1.93321, 0.0271316, 0.0187805];
    let result = run(32.0, 1.0, PhaseModel::Isotropic, mu0, 40_000, views.clone());
    for (i, e) in expected.iter().enumerate() {
        let total = result.radiance[i].total;
        // Relative allowance for the deep-slab case.
        let allowed = 4.0 * total.std_error + 0.01 * e / pi;
        assert!(
            (total.value - e / pi).abs() <= allowed,
            "1e view {i}: {} ± {} vs {}",
            total.value,
            total.std_error,
            e / pi
        );
    }
}

#[test]
fn conservative_slabs_conserve_energy_and_seeds_reproduce() {
    for tau in [0.5, 5.0, 50.0] {
        let result = run(
            tau,
            1.0,
            PhaseModel::HenyeyGreenstein { g: 0.85 },
            60.0,
            20_000,
            Vec::new(),
        );
        let sum = result.reflectance.total.value + result.transmittance.total.value;
        assert!((sum - 1.0).abs() < 1e-12, "τ {tau}: R + T = {sum}");
    }
    let a = run(
        3.0,
        0.99,
        PhaseModel::HenyeyGreenstein { g: 0.85 },
        30.0,
        8192,
        Vec::new(),
    );
    let b = run(
        3.0,
        0.99,
        PhaseModel::HenyeyGreenstein { g: 0.85 },
        30.0,
        8192,
        Vec::new(),
    );
    assert_eq!(a.reflectance, b.reflectance);
    assert_eq!(a.scattering_events, b.scattering_events);
}

/// In a thin slab the analytic single-scattering radiance (§4.3,
/// reconstructed without the misprinted κ) is the tracer's order 1, for
/// reflection and transmission. The double-scattering reconstruction (§4.4)
/// only has the right order of magnitude: it keeps the second event on the
/// singly scattered path, while in a thin slab the intermediate path runs
/// mostly sideways, so it underestimates the tracer's order 2 by a factor of
/// about 2 (within a factor of 3 is checked).
#[test]
fn thin_slab_single_scattering_matches_the_analytic_model() {
    use nimbus_physics::optics::phase::PhaseTable;
    use nimbus_physics::transport::stratus::{StratusModel, StratusOptics};
    let g = 0.7;
    let phase = PhaseModel::HenyeyGreenstein { g };
    let table: PhaseTable = phase.to_table(3601);
    // κ = 1 m⁻¹, so H in metres is the optical depth; no peak split.
    let model = StratusModel::new(StratusOptics::from_phase(&table, 1.0, 0.0));
    let tau = 0.05;
    let sun = 40.0;
    let views = vec![
        ViewDirection {
            zenith_deg: 20.0,
            relative_azimuth_deg: 0.0,
        },
        ViewDirection {
            zenith_deg: 60.0,
            relative_azimuth_deg: 120.0,
        },
        ViewDirection {
            zenith_deg: 150.0,
            relative_azimuth_deg: 180.0,
        },
        ViewDirection {
            zenith_deg: 120.0,
            relative_azimuth_deg: 60.0,
        },
    ];
    let result = run(tau, 1.0, phase, sun, 150_000, views.clone());
    for (view, mc) in views.iter().zip(&result.radiance) {
        let analytic = model.radiance(tau, sun, *view);
        let allowed = 4.0 * mc.order1.std_error + 1e-3 * analytic.order1;
        assert!(
            (mc.order1.value - analytic.order1).abs() <= allowed,
            "{view:?}: order 1 MC {} ± {} vs analytic {}",
            mc.order1.value,
            mc.order1.std_error,
            analytic.order1
        );
        assert!(
            analytic.order2 > mc.order2.value / 3.0 && analytic.order2 < mc.order2.value * 3.0,
            "{view:?}: order 2 MC {} ± {} vs analytic {}",
            mc.order2.value,
            mc.order2.std_error,
            analytic.order2
        );
    }
}

/// The acceptance sweep of the slab issue: Henyey–Greenstein g = 0.85,
/// optical depths 0.5–50, sun zenith angles 0–80°, against the
/// adding–doubling solver (itself checked against DISORT's published test
/// problems to 1e-4 in its unit tests). The Monte-Carlo fluxes must agree
/// within four standard errors plus 2e-4; `NIMBUS_SWEEP_PHOTONS` raises the
/// photon count (the release-mode run with 10⁶ photons is recorded in
/// docs/PERFORMANCE.md).
#[test]
fn henyey_greenstein_sweep_matches_adding_doubling() {
    use nimbus_physics::transport::adding_doubling::{DoublingSettings, slab_fluxes};
    let photons = std::env::var("NIMBUS_SWEEP_PHOTONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1 << 15);
    let phase = PhaseModel::HenyeyGreenstein { g: 0.85 };
    let mut worst: f64 = 0.0;
    for tau in [0.5, 2.0, 8.0, 50.0] {
        for sun in [0.0, 40.0, 80.0] {
            let exact = slab_fluxes(tau, 1.0, &phase, sun, DoublingSettings::default());
            let mc = run(tau, 1.0, phase.clone(), sun, photons, Vec::new());
            for (name, value, expected) in [
                ("R", mc.reflectance.total, exact.reflectance),
                ("T", mc.transmittance.total, exact.transmittance),
            ] {
                let error = (value.value - expected).abs();
                worst = worst.max(error);
                println!(
                    "τ {tau:5} θ₀ {sun:2}° {name}: MC {:.5} ± {:.5}, adding–doubling {expected:.5}",
                    value.value, value.std_error
                );
                assert!(
                    error <= 4.0 * value.std_error + 2e-4,
                    "τ {tau} θ₀ {sun} {name}: {:.5} ± {:.5} vs {expected:.5}",
                    value.value,
                    value.std_error
                );
            }
        }
    }
    println!("largest |MC − adding–doubling|: {worst:.5}");
}
