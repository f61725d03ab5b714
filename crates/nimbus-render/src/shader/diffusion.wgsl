// import shader/common.wgsl
// import shader/lighting_types.wgsl
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

// The 38-point rule of Lebedev (1975): the octahedron's 6 vertices (weight
// 1/105), the cube's 8 vertices (9/280) and the 24 points (±p, ±q, 0) and
// their permutations (1/35), exact for polynomials of degree ≤ 9 on the
// sphere. Twin of nimbus_physics::cumulus::interior::lebedev_38 (same
// points, same order).
const LEBEDEV_CORNER: f32 = 0.57735027;
const LEBEDEV_P: f32 = 0.88807383;
const LEBEDEV_Q: f32 = 0.45970084;
fn lebedev_38(k: u32) -> vec4<f32> {
    if (k < 6u) {
        var d = vec3<f32>(0.0);
        d[k / 2u] = select(1.0, -1.0, (k & 1u) != 0u);
        return vec4<f32>(d, 1.0 / 105.0);
    }
    if (k < 14u) {
        let j = k - 6u;
        let d = vec3<f32>(
            select(LEBEDEV_CORNER, -LEBEDEV_CORNER, (j & 4u) != 0u),
            select(LEBEDEV_CORNER, -LEBEDEV_CORNER, (j & 2u) != 0u),
            select(LEBEDEV_CORNER, -LEBEDEV_CORNER, (j & 1u) != 0u));
        return vec4<f32>(d, 9.0 / 280.0);
    }
    // Per axis a: (u, v) = (p, q) then (q, p) on the two other axes, each
    // with the four sign pairs.
    let j = k - 14u;
    let a = j / 8u;
    let swap = (j & 4u) != 0u;
    let u = select(LEBEDEV_P, LEBEDEV_Q, swap);
    let v = select(LEBEDEV_Q, LEBEDEV_P, swap);
    var d = vec3<f32>(0.0);
    d[(a + 1u) % 3u] = select(u, -u, (j & 2u) != 0u);
    d[(a + 2u) % 3u] = select(v, -v, (j & 1u) != 0u);
    return vec4<f32>(d, 1.0 / 35.0);
}

// The seven real spherical harmonics of order 3 (twin of
// nimbus_physics::cumulus::interior::order_3_basis).
fn order_3_basis(d: vec3<f32>) -> array<f32, 7> {
    let x = d.x;
    let y = d.y;
    let z = d.z;
    return array<f32, 7>(
        0.590044 * y * (3.0 * x * x - y * y),
        2.890611 * x * y * z,
        0.457046 * y * (5.0 * z * z - 1.0),
        0.373176 * z * (5.0 * z * z - 3.0),
        0.457046 * x * (5.0 * z * z - 1.0),
        1.445306 * z * (x * x - y * y),
        0.590044 * x * (x * x - 3.0 * y * y));
}

// The sky's light scattered once towards the camera, for one view (twin of
// nimbus_physics::cumulus::interior::SkyDirectKernel): with the direct
// transmittance T known by its mean t̄ and first moment b, taken as the
// cap of open sky of transmittance_cap, the source per unit σ* is
// t̄ mean + b·(x, y, z) (the cap's orders ≤ 1) plus the cap's orders 2
// and 3 against order_2 (sh_basis's functions 4 … 8) and order_3
// (Funk–Hecke).
struct SkyDirectKernel {
    mean: vec3<f32>,
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
    order_2: array<vec3<f32>, 5>,
    order_3: array<vec3<f32>, 7>,
}

// The kernel of the sky of nine harmonics `sh` (radiance, rgb), droplets of
// peak-removed asymmetry `asymmetry` and the direction `toward` the camera:
// ∫ L(s) HG₃(−s·o) (1, s, Y₂(s), Y₃(s)) ds by the 38-point rule (exact:
// HG's orders ≤ 3, integrands of degree ≤ 8).
fn sky_direct_kernel(sh: array<vec4<f32>, 9>, asymmetry: f32, toward: vec3<f32>) -> SkyDirectKernel {
    var out: SkyDirectKernel;
    out.mean = vec3<f32>(0.0);
    out.x = vec3<f32>(0.0);
    out.y = vec3<f32>(0.0);
    out.z = vec3<f32>(0.0);
    for (var k = 0u; k < 5u; k += 1u) {
        out.order_2[k] = vec3<f32>(0.0);
    }
    for (var k = 0u; k < 7u; k += 1u) {
        out.order_3[k] = vec3<f32>(0.0);
    }
    let g = asymmetry;
    for (var k = 0u; k < 38u; k += 1u) {
        let point = lebedev_38(k);
        let s = point.xyz;
        // Unclamped: the rule is exact for the harmonics themselves.
        let l = sh_evaluate(sh, s, vec3<f32>(1.0));
        let mu = -dot(s, toward);
        let p2 = 0.5 * (3.0 * mu * mu - 1.0);
        let p3 = 0.5 * (5.0 * mu * mu * mu - 3.0 * mu);
        let phase = 1.0 + 3.0 * g * mu + 5.0 * g * g * p2 + 7.0 * g * g * g * p3;
        // 4π w p₃, p₃ = phase/(4π).
        let weighted = point.w * phase * l;
        out.mean += weighted;
        out.x += weighted * s.x;
        out.y += weighted * s.y;
        out.z += weighted * s.z;
        let y2 = sh_basis(s);
        for (var i = 0u; i < 5u; i += 1u) {
            out.order_2[i] += weighted * y2[4u + i];
        }
        let y3 = order_3_basis(s);
        for (var i = 0u; i < 7u; i += 1u) {
            out.order_3[i] += weighted * y3[i];
        }
    }
    return out;
}

// The cap of open sky with mean `mean` and first moment `gradient` (twin of
// nimbus_physics::cumulus::interior::transmittance_cap): its amplitude A,
// μ₀, its orders λ₂, λ₃ per unit amplitude, and its axis n; A = 0 where T
// has no direction.
struct TransmittanceCap {
    amplitude_cos_order_2_order_3: vec4<f32>,
    axis: vec3<f32>,
}

const CAP_MOMENT_RATIO_MAX: f32 = 2.9;

fn transmittance_cap(mean: f32, gradient: vec3<f32>) -> TransmittanceCap {
    var out: TransmittanceCap;
    out.amplitude_cos_order_2_order_3 = vec4<f32>(0.0, -1.0, 0.0, 0.0);
    out.axis = vec3<f32>(0.0, 1.0, 0.0);
    let length_b = length(gradient);
    if (mean <= 1e-9 || length_b <= 1e-9) {
        return out;
    }
    out.axis = gradient / length_b;
    let ratio = min(length_b / mean, CAP_MOMENT_RATIO_MAX);
    let m = 2.0 * ratio / 3.0 - 1.0;
    let pi = 3.14159265;
    out.amplitude_cos_order_2_order_3 = vec4<f32>(
        2.0 * mean / (1.0 - m),
        m,
        pi * m * (1.0 - m * m),
        0.25 * pi * (6.0 * m * m - 5.0 * m * m * m * m - 1.0));
    return out;
}

// The source per unit σ* of a point whose direct transmittance has mean
// and first moment (t̄, b) = (transmittance.x, transmittance.yzw), at least 0.
fn sky_direct_source(kernel: SkyDirectKernel, transmittance: vec4<f32>) -> vec3<f32> {
    let b = transmittance.yzw;
    var source = transmittance.x * kernel.mean + b.x * kernel.x + b.y * kernel.y + b.z * kernel.z;
    let cap = transmittance_cap(transmittance.x, b);
    let c = cap.amplitude_cos_order_2_order_3;
    if (c.x > 0.0) {
        let y2 = sh_basis(cap.axis);
        let y3 = order_3_basis(cap.axis);
        var k2 = vec3<f32>(0.0);
        for (var i = 0u; i < 5u; i += 1u) {
            k2 += kernel.order_2[i] * y2[4u + i];
        }
        var k3 = vec3<f32>(0.0);
        for (var i = 0u; i < 7u; i += 1u) {
            k3 += kernel.order_3[i] * y3[i];
        }
        source += c.x * (c.z * k2 + c.w * k3);
    }
    // Orders ≤ 3 of a narrow cap turned from the sky's light can dip below
    // zero, which light cannot.
    return max(source, vec3<f32>(0.0));
}

// The escape function u(μ) = (3/7)(1 + 2μ): the angular distribution of
// light leaving a thick scattering slab after many events, of unit flux
// (∫ u μ dμ = 1/2). Twin of nimbus_physics::transport::stratus::
// escape_function.
fn escape_function(mu: f32) -> f32 {
    return 3.0 / 7.0 * (1.0 + 2.0 * clamp(mu, 0.0, 1.0));
}

// The escape function over Eddington's emergent distribution (2 + 3μ)/4,
// both per unit flux: how the light leaving a thick slab at cosine μ to its
// normal (and, by reciprocity, the light a beam at cosine μ sends into it)
// differs from what the P1 field gives. Twin of nimbus_physics::transport::
// diffusion::escape_over_eddington.
fn escape_over_eddington(mu: f32) -> f32 {
    return escape_function(mu) / ((2.0 + 3.0 * clamp(mu, 0.0, 1.0)) / 4.0);
}
