// import shader/atmosphere_lookup.wgsl
// The stratiform layer's parameters (WGSL twin of `stratus::StratusUniform`)
// and the pure functions every stratus-aware pass shares: the thickness
// field (twin of nimbus_physics::cloud_layer, itself built on
// nimbus_physics::noise::gradient_noise_3d) and the 1-D slab model of
// Bouthors et al. 2006, appendix A (twin of
// nimbus_physics::transport::stratus::one_dimensional). Needs common.wgsl.

struct Stratus {
    // x: 1 / feature size (1/m); y: noise value at the cloud edge n_c;
    // z: ramp width to full thickness (noise units); w: thickest cells, m.
    shape: vec4<f32>,
    // xy: distance the wind has carried the layer (x east, z south), m;
    // z: 1 / evolution time (1/s); w: the layer's time, s.
    motion: vec4<f32>,
    // x: mid-plane height, m; y: side of the thickness window, m; zw: the
    // window's min corner (x, z), m.
    window: vec4<f32>,
    // RGB: extinction κ, 1/m; w: half-angle θ_f of the forward peak, rad.
    extinction: vec4<f32>,
    // RGB: forward-peak weight P_f; w: unused.
    forward_fraction: vec4<f32>,
    // RGB: mean square angle of P_F, rad²; w: unused.
    forward_spread: vec4<f32>,
    // The 1-D model at the sun's zenith angle: b, c (1/m), κ_c (1/m), t.
    slab: vec4<f32>,
    // x: r; y: β; zw: unused.
    slab_r_beta: vec4<f32>,
    // xy: radiosity grid's min corner (x, z), m; z: its texel size, m;
    // w: mean ground height under it, m.
    radiosity: vec4<f32>,
    // x: 1 when the layer exists; y: octaves; z: seed; w: thickness-window
    // texels per side.
    flags: vec4<u32>,
    // x: texels of P_S and P² over 0–180°; y: texels of P_F over 0–θ_f;
    // z: radiosity texels per side; w: unused.
    sizes: vec4<u32>,
    // x: 1 when the view and sun paths are marched through the field
    // (stratus.model = "marched" and "volume"), 0 for the paper's slab
    // (bnl2006); y: 1 when the layer is drawn as a volume ("volume");
    // zw: unused.
    model: vec4<u32>,
}

// ---- 3-D gradient noise (Perlin 2002), integer-hashed lattice.

fn noise_hash(v: u32) -> u32 {
    var x = v;
    x = x ^ (x >> 16u);
    x = x * 0x7feb352du;
    x = x ^ (x >> 15u);
    x = x * 0x846ca68bu;
    x = x ^ (x >> 16u);
    return x;
}

fn noise_hash_cell_3d(c: vec3<i32>, seed: u32) -> u32 {
    return noise_hash(bitcast<u32>(c.x)
        ^ noise_hash(bitcast<u32>(c.y) ^ noise_hash(bitcast<u32>(c.z) ^ noise_hash(seed + 0x9e3779b9u))));
}

fn noise_edge_gradient(h: u32) -> vec3<f32> {
    switch (h % 12u) {
        case 0u: { return vec3<f32>(1.0, 1.0, 0.0); }
        case 1u: { return vec3<f32>(-1.0, 1.0, 0.0); }
        case 2u: { return vec3<f32>(1.0, -1.0, 0.0); }
        case 3u: { return vec3<f32>(-1.0, -1.0, 0.0); }
        case 4u: { return vec3<f32>(1.0, 0.0, 1.0); }
        case 5u: { return vec3<f32>(-1.0, 0.0, 1.0); }
        case 6u: { return vec3<f32>(1.0, 0.0, -1.0); }
        case 7u: { return vec3<f32>(-1.0, 0.0, -1.0); }
        case 8u: { return vec3<f32>(0.0, 1.0, 1.0); }
        case 9u: { return vec3<f32>(0.0, -1.0, 1.0); }
        case 10u: { return vec3<f32>(0.0, 1.0, -1.0); }
        default: { return vec3<f32>(0.0, -1.0, -1.0); }
    }
}

fn noise_corner(cell: vec3<i32>, corner: vec3<i32>, f: vec3<f32>, seed: u32) -> f32 {
    let g = noise_edge_gradient(noise_hash_cell_3d(cell + corner, seed));
    return dot(g, f - vec3<f32>(corner));
}

fn gradient_noise_3d(p: vec3<f32>, seed: u32) -> f32 {
    let p0 = floor(p);
    let cell = vec3<i32>(p0);
    let f = p - p0;
    let u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    let x00 = mix(noise_corner(cell, vec3<i32>(0, 0, 0), f, seed), noise_corner(cell, vec3<i32>(1, 0, 0), f, seed), u.x);
    let x10 = mix(noise_corner(cell, vec3<i32>(0, 1, 0), f, seed), noise_corner(cell, vec3<i32>(1, 1, 0), f, seed), u.x);
    let x01 = mix(noise_corner(cell, vec3<i32>(0, 0, 1), f, seed), noise_corner(cell, vec3<i32>(1, 0, 1), f, seed), u.x);
    let x11 = mix(noise_corner(cell, vec3<i32>(0, 1, 1), f, seed), noise_corner(cell, vec3<i32>(1, 1, 1), f, seed), u.x);
    return mix(mix(x00, x10, u.y), mix(x01, x11, u.y), u.z);
}

// Fractal sum normalised to about [−1, 1]: lacunarity 2, gain ½, octaves
// rotated in (x, y) by (0.8, 0.6) like nimbus_physics::noise::fbm_3d.
fn fbm_3d(p_in: vec3<f32>, seed: u32, octaves: u32) -> f32 {
    var p = p_in;
    var sum = 0.0;
    var amplitude = 1.0;
    var norm = 0.0;
    for (var octave = 0u; octave < octaves; octave = octave + 1u) {
        sum += amplitude * gradient_noise_3d(p, seed + octave * 7919u);
        norm += amplitude;
        amplitude *= 0.5;
        p = vec3<f32>(0.8 * p.x - 0.6 * p.y, 0.6 * p.x + 0.8 * p.y, p.z) * 2.0;
    }
    return sum / max(norm, 1e-6);
}

// ---- The thickness field.

// Cloud thickness at world (x, z), m, at the layer's time.
fn layer_thickness_m(s: Stratus, xz: vec2<f32>) -> f32 {
    if (s.flags.x == 0u) {
        return 0.0;
    }
    // Overcast and clear are exact (the threshold is ∓1e30).
    if (s.shape.y < -1e29) {
        return s.shape.w;
    }
    if (s.shape.y > 1e29) {
        return 0.0;
    }
    let t = s.motion.w;
    let uv = (xz - s.motion.xy) * s.shape.x;
    let n = fbm_3d(vec3<f32>(uv, t * s.motion.z), s.flags.z, s.flags.y);
    let d = clamp((n - s.shape.y) / s.shape.z, 0.0, 1.0);
    return s.shape.w * (1.0 - (1.0 - d) * (1.0 - d));
}

// ---- The 1-D model (appendix A), per unit incident flux on the top.

// T_ms(H) = (b + (1 − b) e^{−cH}) β / (H − (H − 1) β).
fn slab_t_ms(s: Stratus, h: f32) -> f32 {
    let beta = s.slab_r_beta.y;
    let isotropic = beta / (h - (h - 1.0) * beta);
    return clamp((s.slab.x + (1.0 - s.slab.x) * exp(-s.slab.y * h)) * isotropic, 0.0, 1.0);
}

// T₁ + T₂ (T₂ = T_2a + T_2b): the singly and doubly scattered transmitted
// flux, mostly forward (Bouthors 2006, §5.1: "directional").
fn slab_t12(s: Stratus, h: f32) -> f32 {
    let k = s.slab.z;
    let t = s.slab.w;
    let r = s.slab_r_beta.x;
    let e = exp(-k * h);
    let x = 2.0 * k * h;
    let t1 = t * k * h * e;
    let t2a = 0.5 * (k * t * h) * (k * t * h) * e;
    let t2b = 0.25 * r * r * e * max(x - 1.0 + exp(-x), 0.0);
    return t1 + t2a + t2b;
}

// R₁ + R₂.
fn slab_r12(s: Stratus, h: f32) -> f32 {
    let k = s.slab.z;
    let t = s.slab.w;
    let r = s.slab_r_beta.x;
    let x = 2.0 * k * h;
    let r1 = 0.5 * r * (1.0 - exp(-x));
    let r2 = 0.5 * r * t * max(1.0 - (1.0 + x) * exp(-x), 0.0);
    return r1 + r2;
}

// The layer's fluxes for thickness h under the sun at cosine mu_l.
struct SlabFluxes {
    // T_ms and R_ms = 1 − T_ms.
    transmittance: f32,
    reflectance: f32,
    // T₀ per channel (the direct beam, unmodified extinction).
    t0: vec3<f32>,
    // T₁ + T₂ and R₁ + R₂.
    t12: f32,
    r12: f32,
    // T₃₊ and R₃₊ per channel (T₀ differs by channel).
    t3plus: vec3<f32>,
    r3plus: f32,
}

fn slab_fluxes(s: Stratus, h: f32, mu_l: f32) -> SlabFluxes {
    var f: SlabFluxes;
    f.transmittance = slab_t_ms(s, h);
    f.reflectance = 1.0 - f.transmittance;
    f.t0 = exp(-s.extinction.rgb * h / max(mu_l, 1.745e-3));
    f.t12 = slab_t12(s, h);
    f.r12 = slab_r12(s, h);
    f.t3plus = max(vec3<f32>(f.transmittance - f.t12) - f.t0, vec3<f32>(0.0));
    f.r3plus = max(f.reflectance - f.r12, 0.0);
    return f;
}

// T_C: the directional transmittance T₀ + T₁ + T₂ that casts the layer's
// sharp sun shadows (§5.1).
fn slab_directional_transmittance(s: Stratus, h: f32, mu_l: f32) -> vec3<f32> {
    return min(exp(-s.extinction.rgb * h / max(mu_l, 1.745e-3)) + slab_t12(s, h), vec3<f32>(1.0));
}
