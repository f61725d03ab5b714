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

// A value towards `direction` (unit) from its values towards the six axes,
// +x, +y, +z in `positive` and −x, −y, −z in `negative`: Σ_a Ω_a² D(±a),
// the ambient cube (McTaggart 2004). Twin of
// nimbus_physics::cumulus::interior::ambient_cube.
fn ambient_cube(positive: vec3<f32>, negative: vec3<f32>, direction: vec3<f32>) -> f32 {
    let side = select(negative, positive, direction >= vec3<f32>(0.0));
    return dot(direction * direction, side);
}

// The part of the forward lobe towards `direction` that its own ambient cube
// does not hold (zero on the axes).
fn lobe_beyond_cube(direction: vec3<f32>, beam_travel: vec3<f32>, optical_depth: f32, asymmetry: f32) -> f32 {
    let side = select(vec3<f32>(-1.0), vec3<f32>(1.0), direction >= vec3<f32>(0.0));
    let on_axes = vec3<f32>(
        forward_orders_lobe(optical_depth, side.x * beam_travel.x, asymmetry),
        forward_orders_lobe(optical_depth, side.y * beam_travel.y, asymmetry),
        forward_orders_lobe(optical_depth, side.z * beam_travel.z, asymmetry));
    return forward_orders_lobe(optical_depth, dot(direction, beam_travel), asymmetry)
        - dot(direction * direction, on_axes);
}

// How the excess of the sun's light along the beam over its cube spreads to
// `toward`: as the forward lobe's excess over its own cube, relative to its
// value along the beam. Twin of
// nimbus_physics::cumulus::interior::sun_cube_excess_shape.
fn sun_cube_excess_shape(toward: vec3<f32>, beam_travel: vec3<f32>, optical_depth: f32, asymmetry: f32) -> f32 {
    let at_beam = lobe_beyond_cube(beam_travel, beam_travel, optical_depth, asymmetry);
    if (abs(at_beam) <= 1e-3) {
        return 0.0;
    }
    return clamp(lobe_beyond_cube(toward, beam_travel, optical_depth, asymmetry) / at_beam, 0.0, 1.0);
}

// The sun's directional fluence towards `toward` from a sun cube's values
// and its excess along the beam. Twin of
// nimbus_physics::cumulus::interior::sun_cube_toward.
fn sun_cube_toward(positive: vec3<f32>, negative: vec3<f32>, excess: f32, toward: vec3<f32>, shape: f32) -> f32 {
    return max(ambient_cube(positive, negative, toward) + excess * shape, 0.0);
}

// Henyey–Greenstein's phase function relative to isotropic, 4π HG(g, cos θ).
fn henyey_greenstein_relative(g: f32, cos_theta: f32) -> f32 {
    let d = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (d * sqrt(d));
}
