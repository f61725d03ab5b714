// The diffuse light of a rain mist between the ground and a cloud deck's
// base, solved as a plane-parallel slab (adding–doubling, in the physics
// crate) and read from its table: the source S(d) = ∫ p(ω·d) L(ω) dω the
// mist scatters towards an eye looking along d. CPU twin and notes:
// nimbus_physics::rain::mist_slab (diffuse_source_in_mist), whose table
// MIST_SLAB_TABLE this buffer holds, laid out
// [column][height][view][escape, uniform], then [column][R_e, T_e, R_u, T_u].

@group(1) @binding(5) var<storage, read> mist_slab: array<f32>;

const MIST_SLAB_MAX_OPTICAL_DEPTH: f32 = 16.0;
const MIST_SLAB_COLUMN_NODES: u32 = 16u;
const MIST_SLAB_HEIGHT_NODES: u32 = 17u;
const MIST_SLAB_VIEW_NODES: u32 = 33u;
const MIST_SLAB_FLUXES_OFFSET: u32 = 16u * 17u * 33u * 2u;

// Fractional table coordinates: column, height, view.
fn mist_slab_coordinates(column_tau: f32, height_fraction: f32, view_y: f32) -> vec3<f32> {
    let u = min(sqrt(max(column_tau, 0.0) / MIST_SLAB_MAX_OPTICAL_DEPTH), 1.0);
    return vec3<f32>(
        u * f32(MIST_SLAB_COLUMN_NODES - 1u),
        clamp(height_fraction, 0.0, 1.0) * f32(MIST_SLAB_HEIGHT_NODES - 1u),
        (clamp(view_y, -1.0, 1.0) + 1.0) * 0.5 * f32(MIST_SLAB_VIEW_NODES - 1u));
}

// Lower node of a fractional coordinate on a grid of `nodes`.
fn mist_slab_node(x: f32, nodes: u32) -> u32 {
    return min(u32(max(floor(x), 0.0)), nodes - 2u);
}

// The sources (escape, uniform) at a point, trilinear.
fn mist_slab_sources(at: vec3<f32>) -> vec2<f32> {
    let c = mist_slab_node(at.x, MIST_SLAB_COLUMN_NODES);
    let h = mist_slab_node(at.y, MIST_SLAB_HEIGHT_NODES);
    let v = mist_slab_node(at.z, MIST_SLAB_VIEW_NODES);
    let f = clamp(at - vec3<f32>(f32(c), f32(h), f32(v)), vec3<f32>(0.0), vec3<f32>(1.0));
    var out = vec2<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        let dc = k >> 2u;
        let dh = (k >> 1u) & 1u;
        let dv = k & 1u;
        let w = select(1.0 - f.x, f.x, dc == 1u) * select(1.0 - f.y, f.y, dh == 1u)
            * select(1.0 - f.z, f.z, dv == 1u);
        let index = (((c + dc) * MIST_SLAB_HEIGHT_NODES + h + dh) * MIST_SLAB_VIEW_NODES + v + dv) * 2u;
        out += w * vec2<f32>(mist_slab[index], mist_slab[index + 1u]);
    }
    return out;
}

// The column's fluxes (R_e, T_e, R_u, T_u), linear.
fn mist_slab_fluxes(at: vec3<f32>) -> vec4<f32> {
    let c = mist_slab_node(at.x, MIST_SLAB_COLUMN_NODES);
    let f = clamp(at.x - f32(c), 0.0, 1.0);
    let i0 = MIST_SLAB_FLUXES_OFFSET + 4u * c;
    let i1 = i0 + 4u;
    let lower = vec4<f32>(mist_slab[i0], mist_slab[i0 + 1u], mist_slab[i0 + 2u], mist_slab[i0 + 3u]);
    let upper = vec4<f32>(mist_slab[i1], mist_slab[i1 + 1u], mist_slab[i1 + 2u], mist_slab[i1 + 3u]);
    return mix(lower, upper, f);
}

// S(d), W·sr⁻¹·m⁻², at height `height_fraction` (0 ground, 1 base) of a
// column of optical depth `column_tau`, for an eye looking along a
// direction of vertical component `view_y`: the deck sends its own
// R_G(1 − ρR_c) (R_G `clear_column`, the ground's irradiance without mist)
// by the escape function or, with `uniform_emission`, uniformly; base and
// ground (albedo ρ `ground_albedo`, base reflectance R_c
// `deck_reflectance`) are coupled by flux adding; `scattered_sun`, the
// sun's light the column scatters, enters the top uniformly; the ground
// adds `sunlit_ground` of its own (ρ times the sun's irradiance on it).
fn mist_slab_source(column_tau: f32, height_fraction: f32, view_y: f32, ground_albedo: vec3<f32>,
    deck_reflectance: f32, uniform_emission: bool, clear_column: vec3<f32>, scattered_sun: vec3<f32>,
    sunlit_ground: vec3<f32>) -> vec3<f32> {
    let rho = clamp(ground_albedo, vec3<f32>(0.0), vec3<f32>(1.0));
    let deck = clamp(deck_reflectance, 0.0, 1.0);
    let emitted = clear_column * (1.0 - rho * deck);
    let here = mist_slab_coordinates(column_tau, height_fraction, view_y);
    let mirrored = mist_slab_coordinates(column_tau, 1.0 - height_fraction, -view_y);
    let fluxes = mist_slab_fluxes(here);
    let sources = mist_slab_sources(here);
    let s_ground = mist_slab_sources(mirrored).y;
    var r_emit = fluxes.x;
    var t_emit = fluxes.y;
    var s_emit = sources.x;
    if (uniform_emission) {
        r_emit = fluxes.z;
        t_emit = fluxes.w;
        s_emit = sources.y;
    }
    let r_u = fluxes.z;
    let t_u = fluxes.w;
    // (1 − R_u R_c) U − T_u ρ D = R_e E₀ + R_u F + T_u G,
    // −T_u R_c U + (1 − R_u ρ) D = T_e E₀ + T_u F + R_u G.
    let a11 = 1.0 - r_u * deck;
    let a12 = -t_u * rho;
    let b1 = r_emit * emitted + r_u * scattered_sun + t_u * sunlit_ground;
    let a21 = -t_u * deck;
    let a22 = 1.0 - r_u * rho;
    let b2 = t_emit * emitted + t_u * scattered_sun + r_u * sunlit_ground;
    let determinant = max(a11 * a22 - a12 * a21, vec3<f32>(1e-9));
    let up = (b1 * a22 - a12 * b2) / determinant;
    let down = (a11 * b2 - a21 * b1) / determinant;
    return emitted * s_emit + (scattered_sun + deck * up) * sources.y + (rho * down + sunlit_ground) * s_ground;
}
