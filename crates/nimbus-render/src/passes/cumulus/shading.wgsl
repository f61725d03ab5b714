// import shader/cloud_layer_lookup.wgsl
// import shader/diffusion.wgsl
// The phenomenological cumulus shader (Bouthors 2004, §5.10, eqs 5.31–5.43,
// after Neyret 2000): the terms as pure functions of a surface point, the
// GPU twin of nimbus_physics::cumulus::shading (whose documentation gives
// the formulas, the choices where the paper is garbled and their reasons).
// Needs shader/cloud_layer_field.wgsl (gradient_noise_3d).

struct Cumulus {
    // α_a, α_l, α_f, α_t.
    weights: vec4<f32>,
    // α_g, Trans, α_ρ (m⁻¹), corona thickness r (m).
    corona: vec4<f32>,
    // α_b, α_w, α_d, α_h.
    detail: vec4<f32>,
    // Neyret's k, lacunarity of the bump octaves, octaves, unused.
    noise: vec4<f32>,
    // Terms on (bits: ambient 1, bump 2, light traps 4, corona 8, shadow 16),
    // light-trap model (0 furrows, 1 arctan), unused, unused.
    flags: vec4<u32>,
    // The sun's radiance C_s = E_sun/π at the cloud bases (RGB) and their
    // height (m); its change per metre of height (RGB).
    sun_at_base: vec4<f32>,
    sun_per_m: vec4<f32>,
    // Extensions of the paper's model: α_δ (diffusion through the cores),
    // α_p (small-angle forward scattering), unused, unused.
    extension: vec4<f32>,
    // The forward-peak table's grid: θ_max (rad), τ_max, angles, depths.
    peak_grid: vec4<f32>,
    // The transport model: ln of the transfer's smallest scale, 1/ln of its
    // largest over its smallest (0: one scale), the droplets' δ-M factor
    // 1 − f (550 nm), texels of the phase table.
    transport: vec4<f32>,
}

@group(1) @binding(0) var<uniform> cumulus: Cumulus;
// F(θ, τ) per channel, sr⁻¹ (nimbus_physics::cumulus::forward_peak): x the
// angle index (quadratic in θ), y the depth index (uniform in τ).
@group(1) @binding(1) var cumulus_forward_peak_table: texture_2d<f32>;
// The droplets' phase function without its forward peak, P_S(Θ) per
// channel, sr⁻¹, uniform in Θ over 0–180° (one row).
@group(1) @binding(2) var cumulus_phase_table: texture_2d<f32>;

const CUMULUS_AMBIENT: u32 = 1u;
const CUMULUS_BUMP: u32 = 2u;
const CUMULUS_LIGHT_TRAPS: u32 = 4u;
const CUMULUS_CORONA: u32 = 8u;
const CUMULUS_SHADOW: u32 = 16u;
// flags.z: the transport model's transfer is bound and ready.
const CUMULUS_TRANSPORT: u32 = 1u;
// Fragments at least this opaque are drawn in the opaque pass (depth
// written); the others in the order-independent fringe pass.
const CUMULUS_OPAQUE_ALPHA: f32 = 0.995;
// Forward differences of the bump noise, in noise coordinates.
const CUMULUS_BUMP_STEP: f32 = 0.05;

fn cumulus_term_on(term: u32) -> bool {
    return (cumulus.flags.x & term) != 0u;
}

// What the shader reads at a surface point, world space.
struct CumulusPoint {
    // Interpolated surface normal N (unit).
    normal: vec3<f32>,
    // Radius of the point's blob, m.
    blob_radius_m: f32,
    // Normals of S_{l−1}, S_{l−2}, S_{l−3} (unit; N where the level is absent).
    base_normals: array<vec3<f32>, 3>,
    // δ_j, distances to S_{l−j} over that level's mean radius (large where absent).
    base_distances: vec3<f32>,
    // Mean radii of the lower levels, m (0 where absent).
    base_radii_m: vec3<f32>,
    // Unit vector from the blob's centre to the point.
    blob_up: vec3<f32>,
    // Bump height h ∈ [0, 1] and its gradient in noise coordinates.
    bump_height: f32,
    bump_gradient: vec3<f32>,
}

struct CumulusTerms {
    smoothed_normal: vec3<f32>,
    lambert: f32,
    light_traps: f32,
    forward: f32,
    // Optical depth of the chord behind the point (a large value with the corona off).
    optical_depth: f32,
    // D: the light diffused through the cores leaves every face alike (1);
    // the shadow E at the point sets how much reached it.
    diffusion: f32,
    // P = π F(θ, τ) per channel.
    forward_peak: vec3<f32>,
}

// F(θ, τ): bilinear in the table's indices (√θ and τ), 0 beyond its range.
// Twin of nimbus_physics::cumulus::forward_peak::ForwardPeakTable::at.
fn cumulus_forward_peak(angle_rad: f32, depth: f32) -> vec3<f32> {
    return cumulus_peak_table_at(angle_rad, depth, 0);
}

// H(θ, τ), the peak's source by the last scattering from a beam that has
// crossed τ (sr⁻¹ per unit optical depth), the table's rows after F's.
// Twin of ForwardPeakTable::last_scattering_at.
fn cumulus_forward_peak_source(angle_rad: f32, depth: f32) -> vec3<f32> {
    return cumulus_peak_table_at(angle_rad, depth, i32(cumulus.peak_grid.w));
}

fn cumulus_peak_table_at(angle_rad: f32, depth: f32, row: i32) -> vec3<f32> {
    let grid = cumulus.peak_grid;
    if (!(angle_rad < grid.x && depth < grid.y) || depth < 0.0) {
        return vec3<f32>(0.0);
    }
    let x = sqrt(max(angle_rad, 0.0) / grid.x) * (grid.z - 1.0);
    let y = depth / grid.y * (grid.w - 1.0);
    let i = min(i32(floor(x)), i32(grid.z) - 2);
    let j = min(i32(floor(y)), i32(grid.w) - 2) + row;
    let t = vec2<f32>(x - f32(i), y - f32(j - row));
    let a = textureLoad(cumulus_forward_peak_table, vec2<i32>(i, j), 0).rgb;
    let b = textureLoad(cumulus_forward_peak_table, vec2<i32>(i + 1, j), 0).rgb;
    let c = textureLoad(cumulus_forward_peak_table, vec2<i32>(i, j + 1), 0).rgb;
    let d = textureLoad(cumulus_forward_peak_table, vec2<i32>(i + 1, j + 1), 0).rgb;
    return mix(mix(a, b, t.x), mix(c, d, t.x), t.y);
}

// ∫ρ ds along the chord at impact b through a sphere of radius R whose
// density is saturate((R − s)/r) (nimbus_physics::cumulus::shading::
// chord_density_integral_m, which derives it).
fn cumulus_chord_m(impact_m: f32, radius_m: f32, corona_m: f32) -> f32 {
    let b = abs(impact_m);
    let big_r = max(radius_m, 0.0);
    if (b >= big_r) {
        return 0.0;
    }
    let t_r = sqrt(max(big_r * big_r - b * b, 0.0));
    let r = max(corona_m, 1e-6);
    let core = max(big_r - r, 0.0);
    var t_c = 0.0;
    var s_c = b;
    if (b < core) {
        t_c = sqrt(core * core - b * b);
        s_c = core;
    }
    var log_term = 0.0;
    if (b > 0.0) {
        log_term = b * b * log((t_r + big_r) / (t_c + s_c));
    }
    let shell = big_r * (t_r - t_c) - 0.5 * (t_r * big_r - t_c * s_c) - 0.5 * log_term;
    return 2.0 * (t_c + shell / r);
}

fn cumulus_sphere_chord_m(n: vec3<f32>, o: vec3<f32>, radius_m: f32) -> f32 {
    let c = saturate(dot(n, o));
    return cumulus_chord_m(radius_m * sqrt(max(1.0 - c * c, 0.0)), radius_m, cumulus.corona.w);
}

// Optical depth of the cloud behind the point seen along `o`: the blob and
// the lower levels' surfaces, modulated by the bump.
fn cumulus_optical_depth(p: CumulusPoint, o: vec3<f32>, bump_on: bool) -> f32 {
    var q = cumulus_sphere_chord_m(p.normal, o, p.blob_radius_m);
    for (var j = 0; j < 3; j += 1) {
        q += cumulus_sphere_chord_m(p.base_normals[j], o, p.base_radii_m[j]);
    }
    var modulation = 1.0;
    if (bump_on) {
        modulation = 1.0 - cumulus.detail.x * p.bump_height;
    }
    return cumulus.corona.z * modulation * q;
}

// Bump height h = ½ + ½ Σ_k g^k n(x λ^k) / Σ_k g^k, g = 1/λ (the octaves of
// the unmodelled levels, each a lacunarity λ smaller and fainter), and its
// gradient by forward differences. Twin of
// nimbus_physics::cumulus::shading::bump_height_and_gradient.
fn cumulus_bump_height(x: vec3<f32>) -> f32 {
    let lacunarity = cumulus.noise.y;
    let octaves = u32(cumulus.noise.z);
    var sum = 0.0;
    var norm = 0.0;
    var amplitude = 1.0;
    var frequency = 1.0;
    for (var k = 0u; k < octaves; k += 1u) {
        sum += amplitude * gradient_noise_3d(x * frequency, 0x5eedu + k * 7919u);
        norm += amplitude;
        amplitude /= lacunarity;
        frequency *= lacunarity;
    }
    if (norm <= 0.0) {
        return 0.5;
    }
    return clamp(0.5 + 0.5 * sum / norm, 0.0, 1.0);
}

fn cumulus_bump_gradient(x: vec3<f32>, h: f32) -> vec3<f32> {
    let e = CUMULUS_BUMP_STEP;
    return vec3<f32>(
        cumulus_bump_height(x + vec3<f32>(e, 0.0, 0.0)) - h,
        cumulus_bump_height(x + vec3<f32>(0.0, e, 0.0)) - h,
        cumulus_bump_height(x + vec3<f32>(0.0, 0.0, e)) - h,
    ) / e;
}

// The terms of eqs 5.34–5.41 at a point seen along `o` and lit along `l`.
fn cumulus_shade_terms(p: CumulusPoint, o: vec3<f32>, l: vec3<f32>) -> CumulusTerms {
    var out: CumulusTerms;
    // Smoothed normal (eq 5.34).
    var sum = vec3<f32>(0.0);
    for (var j = 0; j < 3; j += 1) {
        let w = saturate(cumulus.detail.y * p.base_distances[j]);
        sum += w * p.normal + (1.0 - w) * p.base_normals[j];
    }
    var n_smooth = p.normal;
    if (dot(sum, sum) > 1e-12) {
        n_smooth = normalize(sum);
    }
    out.smoothed_normal = n_smooth;
    let bump_on = cumulus_term_on(CUMULUS_BUMP);
    // Bump (eq 5.35) and Lambert (eq 5.41).
    var n_bump = n_smooth;
    if (bump_on) {
        let g = p.bump_gradient;
        let tangential = g - dot(g, n_smooth) * n_smooth;
        let perturbed = n_smooth - cumulus.detail.x * tangential;
        if (dot(perturbed, perturbed) > 1e-12) {
            n_bump = normalize(perturbed);
        }
    }
    out.lambert = saturate(dot(n_bump, l));
    // Light traps (eqs 5.37–5.39, or Neyret §4.3).
    out.light_traps = 0.0;
    if (cumulus_term_on(CUMULUS_LIGHT_TRAPS)) {
        if (cumulus.flags.y == 0u) {
            var lower = 0.0;
            for (var j = 0; j < 3; j += 1) {
                lower += saturate(1.0 - cumulus.detail.z * p.base_distances[j]) * saturate(dot(p.base_normals[j], l));
            }
            var h = 1.0;
            if (bump_on) {
                h = p.bump_height;
            }
            out.light_traps = lower + saturate(cumulus.detail.w - h) * saturate(dot(n_smooth, l));
        } else {
            let under = p.base_normals[0];
            let height = saturate(dot(under, p.blob_up));
            let k = cumulus.noise.x;
            out.light_traps = saturate(dot(under, l)) * atan(k * (1.0 - height)) / atan(k);
        }
    }
    // Density, forward scattering (eqs 5.31, 5.32, 5.40 corrected).
    out.forward = 0.0;
    out.optical_depth = 1e30;
    out.forward_peak = vec3<f32>(0.0);
    out.diffusion = 1.0;
    if (cumulus_term_on(CUMULUS_CORONA)) {
        let tau = cumulus_optical_depth(p, o, bump_on);
        let rho = max(saturate(tau), 1e-4);
        let cos_theta = saturate(-dot(o, l));
        let lobe = pow(cos_theta, cumulus.corona.x / rho);
        out.forward = saturate(cumulus.corona.y * (1.0 - rho) * (1.0 - rho) * lobe);
        out.optical_depth = tau;
        out.forward_peak = PI * cumulus_forward_peak(acos(clamp(-dot(o, l), -1.0, 1.0)), tau);
    }
    return out;
}

// Opacity A = 1 − e^{−τ}.
fn cumulus_opacity(terms: CumulusTerms) -> f32 {
    return 1.0 - exp(-min(terms.optical_depth, 80.0));
}

// C_s at a height: linear between the clouds' base and 2 km above it,
// computed on the CPU from the atmosphere (nimbus_physics::atmosphere), as
// the sun's transmittance changes slowly over a cloud's height.
fn cumulus_sun_radiance(height_m: f32) -> vec3<f32> {
    let above = clamp(height_m - cumulus.sun_at_base.w, 0.0, 2000.0);
    return max(cumulus.sun_at_base.rgb + cumulus.sun_per_m.rgb * above, vec3<f32>(0.0));
}

// I of eq 5.42 from the terms, the environment's radiance C_c, the sun's C_s,
// the shadow E at the point and E at the far end of the blob's chord, where
// the light that the corona scatters forwards enters it (all radiances,
// W·sr⁻¹·m⁻²).
fn cumulus_radiance(terms: CumulusTerms, ambient: vec3<f32>, sun: vec3<f32>, shadow: vec3<f32>, forward_shadow: vec3<f32>) -> vec3<f32> {
    var a = 0.0;
    if (cumulus_term_on(CUMULUS_AMBIENT)) {
        a = cumulus.weights.x;
    }
    // Reflected and diffused light is shadowed at the point; light scattered
    // forwards through the chord where it enters the chord.
    let direct = cumulus.weights.z * terms.light_traps + cumulus.weights.y * terms.lambert
        + cumulus.extension.x * terms.diffusion;
    let through = cumulus.weights.w * terms.forward + cumulus.extension.y * terms.forward_peak;
    return a * ambient + sun * (shadow * direct + forward_shadow * through);
}

// ---- The transport model (nimbus_physics::cumulus::transport) ----

// The precomputed transfer at a point as a function of direction,
// c + b·s + sᵀAs (SphericalQuadratic): (c, b), (A_xx, A_yy, A_zz, A_xy),
// (A_yz, A_xz, unused, unused).
struct CumulusTransfer {
    c_b: vec4<f32>,
    diagonal_xy: vec4<f32>,
    yz_xz: vec4<f32>,
}

fn cumulus_transport_on() -> bool {
    return cumulus.flags.z == CUMULUS_TRANSPORT;
}

// f(s). Twin of SphericalQuadratic::value.
fn cumulus_transfer_value(f: CumulusTransfer, s: vec3<f32>) -> f32 {
    let a = f.diagonal_xy;
    let o = f.yz_xz;
    return f.c_b.x + dot(f.c_b.yzw, s) + a.x * s.x * s.x + a.y * s.y * s.y + a.z * s.z * s.z
        + 2.0 * (a.w * s.x * s.y + o.x * s.y * s.z + o.y * s.x * s.z);
}

// ∫ f L over the sphere for the environment's SH radiance L: f's SH
// coefficients (SphericalQuadratic::to_sh) dotted with L's (orthonormal).
fn cumulus_transfer_environment(f: CumulusTransfer, l: Lighting) -> vec3<f32> {
    let b = f.c_b.yzw;
    let a = f.diagonal_xy;
    let o = f.yz_xz;
    let trace = a.x + a.y + a.z;
    let band1 = 0.488603 * 4.18879020;
    let band2 = 1.092548 * 1.67551608;
    var e = 0.282095 * (12.56637061 * f.c_b.x + 4.18879020 * trace) * l.sh[0].xyz;
    e += band1 * (b.y * l.sh[1].xyz + b.z * l.sh[2].xyz + b.x * l.sh[3].xyz);
    e += band2 * (a.w * l.sh[4].xyz + o.x * l.sh[5].xyz + o.y * l.sh[7].xyz);
    e += 0.315392 * 0.83775804 * (6.0 * a.z - 2.0 * trace) * l.sh[6].xyz;
    e += 0.546274 * 1.67551608 * (a.x - a.y) * l.sh[8].xyz;
    return e;
}

// P_S(Θ) per channel, sr⁻¹, linear between the table's texels.
fn cumulus_phase(cos_theta: f32) -> vec3<f32> {
    let n = cumulus.transport.w;
    let x = acos(clamp(cos_theta, -1.0, 1.0)) / PI * (n - 1.0);
    let i = min(i32(floor(x)), i32(n) - 2);
    let t = x - f32(i);
    let a = textureLoad(cumulus_phase_table, vec2<i32>(i, 0), 0).rgb;
    let b = textureLoad(cumulus_phase_table, vec2<i32>(i + 1, 0), 0).rgb;
    return mix(a, b, t);
}

// (e^{−a/μ_v} − e^{−a/μ_l}) / (μ_v − μ_l), finite as μ_v → μ_l. Twin of
// nimbus_physics::transport::stratus::exp_difference_quotient.
fn cumulus_exp_difference_quotient(a: f32, mu_v: f32, mu_l: f32) -> f32 {
    let z = a * (mu_v - mu_l) / (mu_v * mu_l);
    if (abs(z) > 0.5) {
        return (exp(-a / mu_v) - exp(-a / mu_l)) / (mu_v - mu_l);
    }
    var ratio = 1.0 + 0.5 * z + z * z / 6.0;
    if (abs(z) > 1e-3) {
        ratio = (exp(z) - 1.0) / z;
    }
    return exp(-a / mu_l) * ratio * a / (mu_v * mu_l);
}

// S: single scattering of a slab whose optical depth along the view is
// τ_v, lit at cos μ₀ from the normal (negative: from behind) and seen at
// cos μ, per unit ϖ P E_sun. Twin of
// nimbus_physics::cumulus::transport::single_scattering_factor.
fn cumulus_single_scattering(mu0: f32, mu_in: f32, tau_view: f32) -> f32 {
    let mu = max(mu_in, 1e-3);
    let tau_normal = tau_view * mu;
    if (mu0 > 1e-3) {
        return mu0 / (mu0 + mu) * (1.0 - exp(-tau_view * (1.0 + mu / mu0)));
    }
    let back = max(-mu0, 1e-3);
    return back * cumulus_exp_difference_quotient(tau_normal, back, mu);
}

// I of the transport model: single scattering of the sun through the
// phase function without its peak, P_S, and the slab factor S; the forward
// peak P as in the phenomenological model (the shadows `direct` and
// `forward_direct` are the direct beam's transmittance at the point and
// where the chord behind it enters; `forward_shadow` the phenomenological
// model's for P); the multiply scattered light of
// the precomputed transfer lit by the sun (E_sun = π C_s, shadowed by the
// layer above only: the cloud's own shadow is in the transfer) and by the
// environment, leaving by the escape function about `exit_normal` (the
// macroscopic surface's: the multiply scattered light leaves the cloud's
// shape smoothed over a transport mean free path, not its blobs). Twin of
// nimbus_physics::cumulus::transport::transport_radiance.
fn cumulus_transport_radiance(
    terms: CumulusTerms,
    exit_normal: vec3<f32>,
    transfer: CumulusTransfer,
    o: vec3<f32>,
    l: vec3<f32>,
    environment: vec3<f32>,
    sun: vec3<f32>,
    layer_shadow: vec3<f32>,
    direct: vec3<f32>,
    forward_direct: vec3<f32>,
    forward_shadow: vec3<f32>,
) -> vec3<f32> {
    let n = terms.smoothed_normal;
    let mu = saturate(dot(n, o));
    let mu0 = dot(n, l);
    let tau = min(terms.optical_depth, 1e4) * cumulus.transport.z;
    let single = cumulus_single_scattering(mu0, mu, tau);
    let exit_mu = saturate(dot(exit_normal, o));
    let lit = select(forward_direct, direct, mu0 > 0.0);
    let single_radiance = PI * sun * lit * cumulus_phase(-dot(o, l)) * single;
    let multiple = PI * sun * layer_shadow * max(cumulus_transfer_value(transfer, l), 0.0)
        + max(environment, vec3<f32>(0.0));
    let multiple_radiance = escape_function(exit_mu) / PI * multiple;
    let peak = cumulus.extension.y * forward_shadow * sun * terms.forward_peak;
    return single_radiance + multiple_radiance + peak;
}
