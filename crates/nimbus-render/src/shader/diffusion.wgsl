// import shader/common.wgsl
// The angular distribution of the light scattered inside a cloud (the
// in-cloud marches of the cumulus and of the stratus layer).

// Eddington's radiance (Φ + 3 μ F)/(4π), at least 0: Φ the fluence, F the
// net flux along an axis, μ the cosine of the light's travel to that axis.
// Twin of nimbus_physics::transport::diffusion::eddington_radiance.
fn eddington_radiance(fluence: vec3<f32>, net_flux: vec3<f32>, mu: f32) -> vec3<f32> {
    return max(fluence + 3.0 * mu * net_flux, vec3<f32>(0.0)) / (4.0 * PI);
}

// The light of that P1 field scattered towards a direction at cosine `mu`
// to the axis by droplets of asymmetry `asymmetry`, per unit scattering
// optical depth: (Φ + 3 g μ F)/(4π). Twin of nimbus_physics::transport::
// diffusion::eddington_source.
fn eddington_source(fluence: vec3<f32>, net_flux: vec3<f32>, mu: f32, asymmetry: f32) -> vec3<f32> {
    return eddington_radiance(fluence, asymmetry * net_flux, mu);
}

// Orders summed by forward_orders_lobe (nimbus_physics::cumulus::interior::
// FORWARD_ORDERS).
const FORWARD_ORDERS: u32 = 16u;

// The sun's light scattered towards a direction at cosine `cos_theta` to
// the beam's travel, at optical depth `optical_depth` along the beam, per
// unit solid angle relative to isotropic: Σ_{n≥1} w_n 4π HG(g^{n+1}, cos θ),
// w_n the Poisson orders of the light that left the beam. Twin of
// nimbus_physics::cumulus::interior::forward_orders_lobe.
fn forward_orders_lobe(optical_depth: f32, cos_theta: f32, asymmetry: f32) -> f32 {
    let tau = max(optical_depth, 0.0);
    // Σ_{n≥1} τⁿ/n! = e^τ − 1: the series itself below τ = 1 (where the
    // terms beyond the 16th are below 1e-14 and e^τ − 1 cancels in f32).
    var term = 1.0;
    var g = asymmetry;
    var series = 0.0;
    var sum = 0.0;
    for (var n = 1u; n <= FORWARD_ORDERS; n += 1u) {
        term *= tau / f32(n);
        g *= asymmetry;
        series += term;
        sum += term * henyey_greenstein_relative(g, cos_theta);
    }
    if (series <= 0.0) {
        // τ = 0: the first order alone, HG(g²).
        return henyey_greenstein_relative(asymmetry * asymmetry, cos_theta);
    }
    let normalisation = select(exp(tau) - 1.0, series, tau < 1.0);
    return sum / normalisation + max(1.0 - series / normalisation, 0.0);
}

// Henyey–Greenstein's phase function relative to isotropic, 4π HG(g, cos θ).
fn henyey_greenstein_relative(g: f32, cos_theta: f32) -> f32 {
    let d = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (d * sqrt(d));
}
