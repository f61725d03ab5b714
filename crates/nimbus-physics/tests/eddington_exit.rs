//! How the in-layer march's P1 light leaves a thick cloud slab and how a
//! beam enters it, against the slab photon tracer (Henyey–Greenstein
//! g = 0.85, as the march's droplets): marching the P1 source out of a slab
//! gives Eddington's emergent distribution (2 + 3μ)/4 of the flux per π,
//! the tracer's light leaves by the escape function (3/7)(1 + 2μ); the
//! ratio of the two, `diffusion::escape_over_eddington`, is what
//! nimbus-render's `in_layer.wgsl` multiplies the P1 light by when the
//! camera is above or below the layer, and the P1 light a beam at that
//! cosine puts into the slab (reciprocity).

use nimbus_physics::transport::diffusion::{
    collimated_net_flux, delta_eddington_beam_rate, escape_over_eddington,
};
use nimbus_physics::transport::monte_carlo::{SlabMedium, TraceResult, TraceSettings, trace};
use nimbus_physics::transport::phase_model::PhaseModel;

const ASYMMETRY: f64 = 0.85;
const OPTICAL_DEPTH: f64 = 18.4;
const ZENITH_BINS: usize = 18;

fn traced(sun_zenith_deg: f64, photons: u64) -> TraceResult {
    let medium = SlabMedium {
        optical_depth: OPTICAL_DEPTH,
        single_scattering_albedo: 1.0,
        phase: PhaseModel::HenyeyGreenstein { g: ASYMMETRY },
    };
    let settings = TraceSettings {
        photons,
        seed: 7,
        sun_zenith_deg,
        views: Vec::new(),
        zenith_bins: ZENITH_BINS,
        azimuth_bins: 6,
        ..TraceSettings::default()
    };
    trace(&medium, &settings, &|_| {})
}

/// The transmitted light of a 45° sun by exit angle (azimuth-averaged, all
/// scattered orders), against the diffuse transmittance T sent out by
/// Eddington's distribution T (2 + 3μ)/(4π) and by it times the ratio,
/// T (3/7)(1 + 2μ)/π: from the normal out to 82.5°, Eddington's is 6 %
/// bright 70–80° from the normal and 19 % at 82.5°, the corrected within
/// 3.5 % out to 77.5° and 7 % at 82.5° (400 000 photons).
#[test]
fn p1_light_leaves_a_thick_slab_by_the_escape_function_once_corrected() {
    let result = traced(45.0, 400_000);
    let binned = &result.transmitted;
    let diffuse_transmittance =
        result.transmittance.total.value - result.transmittance.order0.value;
    let (mut worst_p1, mut worst_corrected) = (0.0f64, 0.0f64);
    for zenith_bin in 0..ZENITH_BINS - 1 {
        let exit_deg = (zenith_bin as f64 + 0.5) * 90.0 / ZENITH_BINS as f64;
        let mu = exit_deg.to_radians().cos();
        let bins = zenith_bin * binned.azimuth_bins..(zenith_bin + 1) * binned.azimuth_bins;
        let traced: f64 = (1..4)
            .map(|order| binned.radiance[order][bins.clone()].iter().sum::<f64>())
            .sum::<f64>()
            / binned.azimuth_bins as f64;
        let p1 = diffuse_transmittance * (2.0 + 3.0 * mu) / (4.0 * std::f64::consts::PI);
        let corrected = p1 * escape_over_eddington(mu);
        worst_p1 = worst_p1.max((p1 / traced - 1.0).abs());
        worst_corrected = worst_corrected.max((corrected / traced - 1.0).abs());
        assert!(
            (corrected / traced - 1.0).abs() < 0.08,
            "exit {exit_deg}°: traced {traced:.4}, P1 {p1:.4}, corrected {corrected:.4}"
        );
    }
    assert!(
        worst_p1 > 0.08 && worst_corrected < 0.5 * worst_p1,
        "P1 worst {worst_p1:.3}, corrected worst {worst_corrected:.3}"
    );
}

/// What a beam puts through a thick slab by its cosine μ₀, relative to an
/// overhead beam's: the tracer's total transmittance against δ-Eddington's
/// (the march's, `collimated_net_flux` at the base plus the direct beam) and
/// against it times the ratio of μ₀: from μ₀ = 0.24 up, δ-Eddington is up
/// to 10 % high (a sun 14° high) and the corrected within 2.5 %.
#[test]
fn a_beam_enters_a_thick_slab_by_the_escape_function_once_corrected() {
    let rate = delta_eddington_beam_rate(ASYMMETRY);
    let total = (1.0 - ASYMMETRY) * OPTICAL_DEPTH;
    let p1 = |mu0: f64| {
        (collimated_net_flux(total, total, mu0, rate) + mu0 * (-rate * total / mu0).exp()) / mu0
    };
    let overhead = traced(0.0, 200_000).transmittance.total.value;
    let (mut worst_p1, mut worst_corrected) = (0.0f64, 0.0f64);
    for sun_zenith_deg in [76.0, 66.0, 54.0, 40.0, 26.0] {
        let mu0 = f64::cos(f64::to_radians(sun_zenith_deg));
        let traced = traced(sun_zenith_deg, 200_000).transmittance.total.value / overhead;
        let model = p1(mu0) / p1(1.0);
        let corrected = model * escape_over_eddington(mu0) / escape_over_eddington(1.0);
        worst_p1 = worst_p1.max((model / traced - 1.0).abs());
        worst_corrected = worst_corrected.max((corrected / traced - 1.0).abs());
        assert!(
            (corrected / traced - 1.0).abs() < 0.04,
            "μ₀ {mu0:.3}: traced {traced:.4}, δ-Eddington {model:.4}, corrected {corrected:.4}"
        );
    }
    assert!(
        worst_p1 > 0.06 && worst_corrected < 0.5 * worst_p1,
        "δ-Eddington worst {worst_p1:.3}, corrected worst {worst_corrected:.3}"
    );
}
