// import shader/cloud_layer_field.wgsl
// What the passes that draw need of the stratiform layer (group 3): its
// thickness window, its optical tables, the radiosity result, and the
// layer's shadow and indirect light on the ground. Needs common.wgsl,
// the atmosphere lookups and shader/cloud_layer_field.wgsl.

@group(3) @binding(2) var<uniform> stratus: Stratus;
// Thickness of the layer, m, over the window around the camera (R32Float,
// texel centres at corner + (i + ½) · side / n).
@group(3) @binding(3) var stratus_thickness: texture_2d<f32>;
// Phase functions, RGB per texel, sr⁻¹: P_S over 0–180° (sizes.x texels),
// then P² over 0–180° (sizes.x), then P_F over 0–θ_f (sizes.y).
@group(3) @binding(4) var<storage, read> stratus_phase: array<vec4<f32>>;
// Radiosity result (Bouthors 2006, §5): R_G, the ground's indirect
// irradiance, and R_C, the irradiance the cloud base gets from the ground,
// W·m⁻², over the radiosity grid (row-major, z rows).
@group(3) @binding(5) var<storage, read> radiosity_ground: array<vec4<f32>>;
@group(3) @binding(6) var<storage, read> radiosity_cloud: array<vec4<f32>>;

fn stratus_enabled() -> bool {
    return stratus.flags.x != 0u;
}

// Thickness at world (x, z): bilinear from the window, the field itself
// beyond it (shadows and reflections reach far with a low sun).
fn stratus_thickness_at(xz: vec2<f32>) -> f32 {
    let n = i32(stratus.flags.w);
    let p = (xz - stratus.window.zw) / stratus.window.y * f32(n) - 0.5;
    if (any(p < vec2<f32>(0.0)) || any(p > vec2<f32>(f32(n - 1)))) {
        return layer_thickness_m(stratus, xz);
    }
    return load_bilinear_r(stratus_thickness, p, n);
}

// The march of stratus_view_path_m (twins of nimbus_physics::cloud_layer's
// VIEW_PATH_STEPS, VIEW_PATH_STEP_GROWTH and VIEW_PATH_REFINEMENTS).
const STRATUS_VIEW_PATH_STEPS: u32 = 12u;
const STRATUS_VIEW_PATH_STEP_GROWTH: f32 = 1.5;
const STRATUS_VIEW_PATH_REFINEMENTS: u32 = 5u;

// Signed distance inside the layer, h/2 − |y − y_mid|, of the point at
// `position_m`, with `offset_m` added to the thickness.
fn stratus_inside_m(position_m: vec3<f32>, offset_m: f32) -> f32 {
    return 0.5 * (stratus_thickness_at(position_m.xz) + offset_m) - abs(position_m.y - stratus.window.x);
}

// Where the signed distance along the ray crosses 0 between the distances
// a.x and b.x (their signed distances a.y, b.y), a inside when `a_inside`:
// bisected, then interpolated linearly (twin of
// nimbus_physics::cloud_layer's place_crossing).
fn stratus_place_crossing(start_m: vec3<f32>, direction: vec3<f32>, offset_m: f32, a_in: vec2<f32>, b_in: vec2<f32>, a_inside: bool, refinements: u32) -> f32 {
    var a = a_in;
    var b = b_in;
    for (var k = 0u; k < refinements; k = k + 1u) {
        let c = 0.5 * (a.x + b.x);
        let gc = stratus_inside_m(start_m + direction * c, offset_m);
        if ((gc > 0.0) == a_inside) {
            a = vec2<f32>(c, gc);
        } else {
            b = vec2<f32>(c, gc);
        }
    }
    let fraction = select(0.0, a.y / (a.y - b.y), a.y != b.y);
    return a.x + (b.x - a.x) * fraction;
}

// Length, m, of the straight path from `start_m` (where a ray enters the
// layer) along the unit `direction` until it first leaves the layer: the
// cloud's thickness along the ray, marched through the thickness window
// with `offset_m` added to it. GPU twin of
// nimbus_physics::cloud_layer::path_inside_layer_m (which explains why:
// the slab's H/μ_v fails on the clouds' sides).
fn stratus_view_path_m(start_m: vec3<f32>, direction: vec3<f32>, offset_m: f32, max_length_m: f32) -> f32 {
    let growth = STRATUS_VIEW_PATH_STEP_GROWTH;
    var step = max_length_m * (growth - 1.0) / (pow(growth, f32(STRATUS_VIEW_PATH_STEPS)) - 1.0);
    var s = 0.0;
    var g = max(stratus_inside_m(start_m, offset_m), 0.0);
    for (var i = 0u; i < STRATUS_VIEW_PATH_STEPS; i = i + 1u) {
        let next_s = min(s + step, max_length_m);
        let next_g = stratus_inside_m(start_m + direction * next_s, offset_m);
        if (next_g <= 0.0) {
            return stratus_place_crossing(start_m, direction, offset_m, vec2<f32>(s, g), vec2<f32>(next_s, next_g), true, STRATUS_VIEW_PATH_REFINEMENTS);
        }
        s = next_s;
        g = next_g;
        step = step * growth;
    }
    return max_length_m;
}

// The march of stratus_view_entry_m (twins of nimbus_physics::cloud_layer's
// ENTRY_STEPS, ENTRY_MEAN_STEP_M, ENTRY_STEP_GROWTH and ENTRY_REFINEMENTS).
const STRATUS_ENTRY_STEPS: u32 = 128u;
const STRATUS_ENTRY_MEAN_STEP_M: f32 = 150.0;
const STRATUS_ENTRY_STEP_GROWTH: f32 = 1.03;
const STRATUS_ENTRY_REFINEMENTS: u32 = 6u;

// Distance, m, along the unit `direction` from `start_m` to where the ray
// first enters the layer (its thickness plus `offset_m`) within
// `max_length_m`: 0 from inside it, −1 if it stays outside. How a camera
// level with the layer finds what each pixel sees (its tops and bases are
// edge-on there), and where the volume's march starts. GPU twin of
// nimbus_physics::cloud_layer::first_entry_m.
fn stratus_view_entry_m(start_m: vec3<f32>, direction: vec3<f32>, offset_m: f32, max_length_m: f32) -> f32 {
    let steps = u32(clamp(ceil(max_length_m / STRATUS_ENTRY_MEAN_STEP_M), 4.0, f32(STRATUS_ENTRY_STEPS)));
    let growth = STRATUS_ENTRY_STEP_GROWTH;
    var step = max_length_m * (growth - 1.0) / (pow(growth, f32(steps)) - 1.0);
    var s = 0.0;
    var g = stratus_inside_m(start_m, offset_m);
    if (g > 0.0) {
        return 0.0;
    }
    for (var i = 0u; i < steps; i = i + 1u) {
        let next_s = min(s + step, max_length_m);
        let next_g = stratus_inside_m(start_m + direction * next_s, offset_m);
        if (next_g > 0.0) {
            return stratus_place_crossing(start_m, direction, offset_m, vec2<f32>(s, g), vec2<f32>(next_s, next_g), false, STRATUS_ENTRY_REFINEMENTS);
        }
        s = next_s;
        g = next_g;
        step = step * growth;
    }
    return -1.0;
}

// The outward unit normal of the layer's surface over (or under) the point
// `position_m` near it: the top y = y_mid + h/2 above the mid-plane, the
// base y = y_mid − h/2 below it, h the window's relief, its slope by central
// differences over one texel: (−½∂h/∂x, ±1, −½∂h/∂z). GPU twin of
// nimbus_physics::cloud_layer::surface_normal.
fn stratus_surface_normal(position_m: vec3<f32>) -> vec3<f32> {
    let half_texel_m = 0.5 * stratus.window.y / f32(i32(stratus.flags.w));
    let dx = vec2<f32>(half_texel_m, 0.0);
    let dz = vec2<f32>(0.0, half_texel_m);
    let slope = vec2<f32>(
        stratus_thickness_at(position_m.xz + dx) - stratus_thickness_at(position_m.xz - dx),
        stratus_thickness_at(position_m.xz + dz) - stratus_thickness_at(position_m.xz - dz),
    ) / (2.0 * half_texel_m);
    let up = select(-1.0, 1.0, position_m.y >= stratus.window.x);
    return normalize(vec3<f32>(-0.5 * slope.x, up, -0.5 * slope.y));
}

// The march of stratus_cloud_along_ray_m (twins of nimbus_physics::cloud_layer's
// SUN_PATH_STEPS, SUN_PATH_MEAN_STEP_M and SUN_PATH_STEP_GROWTH).
const STRATUS_SUN_PATH_STEPS: u32 = 24u;
const STRATUS_SUN_PATH_MEAN_STEP_M: f32 = 60.0;
const STRATUS_SUN_PATH_STEP_GROWTH: f32 = 1.1;

// Total length, m, of cloud the straight path from `start_m` along the unit
// `direction` crosses within `max_length_m`, every cell on the way counted
// (not just the first): how much of the layer a point's sunlight has come
// through. GPU twin of nimbus_physics::cloud_layer::cloud_along_ray_m.
fn stratus_cloud_along_ray_m(start_m: vec3<f32>, direction: vec3<f32>, offset_m: f32, max_length_m: f32) -> f32 {
    let steps = u32(clamp(ceil(max_length_m / STRATUS_SUN_PATH_MEAN_STEP_M), 2.0, f32(STRATUS_SUN_PATH_STEPS)));
    let growth = STRATUS_SUN_PATH_STEP_GROWTH;
    var step = max_length_m * (growth - 1.0) / (pow(growth, f32(steps)) - 1.0);
    var s = 0.0;
    var g = stratus_inside_m(start_m, offset_m);
    var length_m = 0.0;
    for (var i = 0u; i < steps; i = i + 1u) {
        let next_s = min(s + step, max_length_m);
        let next_g = stratus_inside_m(start_m + direction * next_s, offset_m);
        length_m += (next_s - s) * inside_fraction(g, next_g);
        s = next_s;
        g = next_g;
        step = step * growth;
    }
    return length_m;
}

// The fraction of a step inside the layer, from the signed distances at its
// ends (linear between them).
fn inside_fraction(g0: f32, g1: f32) -> f32 {
    if (g0 > 0.0 && g1 > 0.0) {
        return 1.0;
    }
    if (g0 <= 0.0 && g1 <= 0.0) {
        return 0.0;
    }
    return max(g0, g1) / abs(g1 - g0);
}

// The fade of the drawn layer towards the edge of its window (1 inside the
// inner four fifths, 0 at the edge and beyond): what the camera sees of the
// layer, and so what water reflects.
fn stratus_window_fade(xz: vec2<f32>) -> f32 {
    let centre = stratus.window.zw + 0.5 * stratus.window.y;
    let r = length(xz - centre) / (0.5 * stratus.window.y);
    return 1.0 - smoothstep(0.8, 1.0, r);
}

// Linear interpolation in a uniformly sampled table of `count` texels
// starting at `offset`, at fraction x in [0, 1] of its range.
fn stratus_table(offset: u32, count: u32, x: f32) -> vec3<f32> {
    let p = clamp(x, 0.0, 1.0) * f32(count - 1u);
    let i = min(u32(p), count - 2u);
    let f = p - f32(i);
    return mix(stratus_phase[offset + i].rgb, stratus_phase[offset + i + 1u].rgb, f);
}

// The shape A(θ_l, θ_v, φ) of the reflected orders 3+ (their radiance over
// the Lambertian R₃₊/π) under the sun at `sun_zenith_deg`, towards a viewer
// at `view_zenith_deg` and `relative_azimuth_deg` from the sun's azimuth (0:
// the sun behind the viewer): trilinear between the traced nodes stored
// after the phase tables, zenith angles clamped to 0–88°, the azimuth
// folded into 0–180°. Twin of
// nimbus_physics::transport::reflected_exit::reflected_shape (the node
// counts and steps are its ZENITH_NODES, ZENITH_STEP_DEG, AZIMUTH_NODES,
// AZIMUTH_STEP_DEG).
fn stratus_reflected_shape(sun_zenith_deg: f32, view_zenith_deg: f32, relative_azimuth_deg: f32) -> f32 {
    let offset = 2u * stratus.sizes.x + stratus.sizes.y;
    let zenith_nodes = 9u;
    let azimuth_nodes = 7u;
    var azimuth = relative_azimuth_deg - 360.0 * floor(relative_azimuth_deg / 360.0);
    if (azimuth > 180.0) {
        azimuth = 360.0 - azimuth;
    }
    let p = vec3<f32>(
        clamp(sun_zenith_deg / 11.0, 0.0, f32(zenith_nodes - 1u)),
        clamp(view_zenith_deg / 11.0, 0.0, f32(zenith_nodes - 1u)),
        clamp(azimuth / 30.0, 0.0, f32(azimuth_nodes - 1u)),
    );
    let base = min(vec3<u32>(p), vec3<u32>(zenith_nodes - 2u, zenith_nodes - 2u, azimuth_nodes - 2u));
    let f = p - vec3<f32>(base);
    var value = 0.0;
    for (var corner = 0u; corner < 8u; corner += 1u) {
        let d = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let w = mix(1.0 - f, f, vec3<f32>(d));
        let n = base + d;
        let index = (n.x * zenith_nodes + n.y) * azimuth_nodes + n.z;
        value += w.x * w.y * w.z * stratus_phase[offset + index].x;
    }
    return value;
}

// Depths of the interior source's nodes below the lit face, scattering
// optical depth (nimbus_physics::transport::interior_source::DEPTH_NODES),
// and the scattering optical depths of the slabs it was traced in
// (THICKNESS_NODES).
const STRATUS_INTERIOR_DEPTHS = array<f32, 7>(0.1, 0.35, 0.75, 1.25, 2.0, 3.0, 4.5);
const STRATUS_INTERIOR_THICKNESSES = array<f32, 4>(0.5, 1.5, 4.0, 12.0);

// The sun's scattered light S (orders ≥ 1, per unit scattering optical
// depth and unit normal irradiance, sr⁻¹) scattered towards the direction
// of travel at cosine `cos_travel` to the inward normal and
// `relative_azimuth_deg` from the beam's azimuth, at `depth` (scattering
// optical depth) below a face lit at `sun_zenith_deg`, in a slab
// `thickness` thick (scattering optical depth): multilinear between the
// traced nodes stored after the reflected shape, clamped to their ranges,
// the azimuth folded into 0–180°, the thickness linear in its logarithm
// (and to 0 below the first node). Twin of
// nimbus_physics::transport::interior_source::interior_source (4 slab
// thicknesses, 9 sun nodes 11° apart, 7 depths, 11 cosines from −1 to 1,
// 13 azimuths 15° apart).
fn stratus_interior_source(thickness: f32, sun_zenith_deg: f32, depth: f32, cos_travel: f32,
    relative_azimuth_deg: f32) -> f32 {
    return stratus_interior_source_at(
        stratus_interior_source_nodes(sun_zenith_deg, cos_travel, relative_azimuth_deg), depth, thickness);
}

// stratus_interior_source at the depth nodes of every slab thickness
// ([thickness][depth]): along a view ray only the depth and the column's
// thickness change, so a march reads the table once per ray (8 texels
// per node) and interpolates at each step.
fn stratus_interior_source_nodes(sun_zenith_deg: f32, cos_travel: f32, relative_azimuth_deg: f32) -> array<f32, 28> {
    // After the phase tables and the reflected shape's 9 × 9 × 7 values.
    let offset = 2u * stratus.sizes.x + stratus.sizes.y + 567u;
    var azimuth = relative_azimuth_deg - 360.0 * floor(relative_azimuth_deg / 360.0);
    if (azimuth > 180.0) {
        azimuth = 360.0 - azimuth;
    }
    let sun = clamp(sun_zenith_deg / 11.0, 0.0, 8.0);
    let i = min(u32(sun), 7u);
    let fi = sun - f32(i);
    let cosine = clamp((clamp(cos_travel, -1.0, 1.0) + 1.0) / 0.2, 0.0, 10.0);
    let k = min(u32(cosine), 9u);
    let fk = cosine - f32(k);
    let az = clamp(azimuth / 15.0, 0.0, 12.0);
    let l = min(u32(az), 11u);
    let fl = az - f32(l);
    var values: array<f32, 28>;
    for (var t = 0u; t < 4u; t += 1u) {
        for (var j = 0u; j < 7u; j += 1u) {
            var value = 0.0;
            for (var corner = 0u; corner < 8u; corner += 1u) {
                let d = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
                let w = mix(vec3<f32>(1.0 - fi, 1.0 - fk, 1.0 - fl), vec3<f32>(fi, fk, fl), vec3<f32>(d));
                let index = ((((t * 9u + i + d.x) * 7u + j) * 11u) + k + d.y) * 13u + l + d.z;
                value += w.x * w.y * w.z * stratus_phase[offset + index].x;
            }
            values[t * 7u + j] = value;
        }
    }
    return values;
}

// Values of the sun's interior source table (4 × 9 × 7 × 11 × 13), after
// which the sky's is stored.
const STRATUS_INTERIOR_SOURCE_VALUES: u32 = 36036u;

// The sky's scattered light S near a layer's top (every order, per unit
// scattering optical depth, sr⁻¹) travelling at cosine `cos_travel` to the
// inward normal, at the depth nodes of every slab thickness, per channel
// ([channel][thickness][depth], read at a depth and thickness by
// stratus_interior_source_at, whose rule the table shares), for a sky
// whose irradiance on the top from each band of zenith angles is `bands`
// (Lighting.sky_irradiance_bands): the table's bands (per unit irradiance
// from each) weighted by them, linear in the cosine. Twin of
// nimbus_physics::transport::sky_source::sky_source (4 slab thicknesses,
// 4 bands, 7 depths, 11 cosines from −1 to 1).
fn stratus_sky_source_nodes(cos_travel: f32, bands: array<vec4<f32>, 4>) -> array<array<f32, 28>, 3> {
    // After the phase tables, the reflected shape's 9 × 9 × 7 values and
    // the sun's interior source.
    let offset = 2u * stratus.sizes.x + stratus.sizes.y + 567u + STRATUS_INTERIOR_SOURCE_VALUES;
    let cosine = clamp((clamp(cos_travel, -1.0, 1.0) + 1.0) / 0.2, 0.0, 10.0);
    let k = min(u32(cosine), 9u);
    let fk = cosine - f32(k);
    var values: array<array<f32, 28>, 3>;
    for (var t = 0u; t < 4u; t += 1u) {
        for (var j = 0u; j < 7u; j += 1u) {
            var e = vec3<f32>(0.0);
            for (var b = 0u; b < 4u; b += 1u) {
                let index = offset + ((t * 4u + b) * 7u + j) * 11u + k;
                e += mix(stratus_phase[index].x, stratus_phase[index + 1u].x, fk) * bands[b].xyz;
            }
            values[0][t * 7u + j] = e.x;
            values[1][t * 7u + j] = e.y;
            values[2][t * 7u + j] = e.z;
        }
    }
    return values;
}

// The sky's S from one `band` per unit irradiance from it, at `depth` below
// the top of a slab `thickness` thick (scattering optical depths). Twin of
// nimbus_physics::transport::sky_source::sky_source.
fn stratus_sky_source(thickness: f32, band: u32, depth: f32, cos_travel: f32) -> f32 {
    var bands: array<vec4<f32>, 4>;
    bands[band] = vec4<f32>(1.0);
    let nodes = stratus_sky_source_nodes(cos_travel, bands);
    return stratus_interior_source_at(nodes[0], depth, thickness);
}

// Where a source at optical depth `depth` in slab node `t` falls among
// that slab's values (index t * 7 + j): the lower plane j and the upper's
// weight, linear between the planes where that slab was tallied (the
// nodes below its base moved up to just above it), clamped to the first
// and the last.
fn stratus_interior_in_slab(t: u32, depth: f32) -> vec2<f32> {
    let base = STRATUS_INTERIOR_THICKNESSES[t] * (1.0 - 1e-3);
    var planes: array<f32, 7>;
    for (var n = 0u; n < 7u; n += 1u) {
        planes[n] = min(STRATUS_INTERIOR_DEPTHS[n], base);
    }
    if (depth >= planes[6]) {
        return vec2<f32>(5.0, 1.0);
    }
    if (depth <= planes[0]) {
        return vec2<f32>(0.0, 0.0);
    }
    var j = 0u;
    for (var n = 0u; n < 6u; n += 1u) {
        if (planes[n] <= depth) {
            j = n;
        }
    }
    return vec2<f32>(f32(j), (depth - planes[j]) / (planes[j + 1u] - planes[j]));
}

// The four values (indices into a [thickness][depth] array of 28) and
// their weights that give a source at `depth` in a slab `thickness` thick
// (twin of interior_source's across_thickness: linear in the logarithm
// between thickness nodes, each node slab read at the same fraction of
// its thickness; the first's scaled down linearly below it; the last's at
// the same depth above it). Computed once per step and applied to every
// table read along the ray (the sun's, and the sky's three channels).
struct InteriorWeights {
    index: vec4<u32>,
    weight: vec4<f32>,
}

fn stratus_interior_weights(depth: f32, thickness: f32) -> InteriorWeights {
    var t = 3u;
    var ft = 0.0;
    var scale = 1.0;
    var depth_lower = depth;
    var depth_upper = depth;
    if (thickness < STRATUS_INTERIOR_THICKNESSES[3]) {
        let fraction = depth / max(thickness, 1e-6);
        if (thickness <= STRATUS_INTERIOR_THICKNESSES[0]) {
            t = 0u;
            scale = max(thickness, 0.0) / STRATUS_INTERIOR_THICKNESSES[0];
            depth_lower = fraction * STRATUS_INTERIOR_THICKNESSES[0];
        } else {
            t = 0u;
            for (var n = 0u; n < 3u; n += 1u) {
                if (STRATUS_INTERIOR_THICKNESSES[n] <= thickness) {
                    t = n;
                }
            }
            ft = log(thickness / STRATUS_INTERIOR_THICKNESSES[t])
                / log(STRATUS_INTERIOR_THICKNESSES[t + 1u] / STRATUS_INTERIOR_THICKNESSES[t]);
            depth_lower = fraction * STRATUS_INTERIOR_THICKNESSES[t];
            depth_upper = fraction * STRATUS_INTERIOR_THICKNESSES[t + 1u];
        }
    }
    let lower = stratus_interior_in_slab(t, depth_lower);
    let t_upper = min(t + 1u, 3u);
    let upper = stratus_interior_in_slab(t_upper, depth_upper);
    var out: InteriorWeights;
    out.index = vec4<u32>(t * 7u + u32(lower.x), t * 7u + u32(lower.x) + 1u,
        t_upper * 7u + u32(upper.x), t_upper * 7u + u32(upper.x) + 1u);
    out.weight = vec4<f32>((1.0 - lower.y) * (1.0 - ft), lower.y * (1.0 - ft),
        (1.0 - upper.y) * ft, upper.y * ft) * scale;
    return out;
}

// A source from its values at the depth nodes of every slab thickness
// (stratus_interior_source_nodes, stratus_sky_source_nodes) with the
// weights of stratus_interior_weights.
fn stratus_interior_weighted(values: array<f32, 28>, w: InteriorWeights) -> f32 {
    return w.weight.x * values[w.index.x] + w.weight.y * values[w.index.y]
        + w.weight.z * values[w.index.z] + w.weight.w * values[w.index.w];
}

// The source at `depth` in a slab `thickness` thick from the values of
// stratus_interior_source_nodes (or stratus_sky_source_nodes).
fn stratus_interior_source_at(values: array<f32, 28>, depth: f32, thickness: f32) -> f32 {
    return stratus_interior_weighted(values, stratus_interior_weights(depth, thickness));
}

// P_S, P² and P_F at scattering angle theta (rad), sr⁻¹.
fn stratus_peak_removed(theta: f32) -> vec3<f32> {
    return stratus_table(0u, stratus.sizes.x, theta / PI);
}
fn stratus_double(theta: f32) -> vec3<f32> {
    return stratus_table(stratus.sizes.x, stratus.sizes.x, theta / PI);
}
fn stratus_forward_peak(theta: f32) -> vec3<f32> {
    if (theta >= stratus.extinction.w) {
        return vec3<f32>(0.0);
    }
    return stratus_table(2u * stratus.sizes.x, stratus.sizes.y, theta / stratus.extinction.w);
}

// Bilinear sample of a radiosity field at world (x, z), texel centres,
// clamped at the edge (the convention of the radiosity pass).
fn stratus_radiosity_sample(ground: bool, xz: vec2<f32>) -> vec3<f32> {
    let n = i32(stratus.sizes.z);
    let p = (xz - stratus.radiosity.xy) / stratus.radiosity.z - 0.5;
    let p0 = floor(p);
    let f = p - p0;
    let i0 = clamp(vec2<i32>(p0), vec2<i32>(0), vec2<i32>(n - 1));
    let i1 = clamp(vec2<i32>(p0) + 1, vec2<i32>(0), vec2<i32>(n - 1));
    let k00 = u32(i0.y * n + i0.x);
    let k10 = u32(i0.y * n + i1.x);
    let k01 = u32(i1.y * n + i0.x);
    let k11 = u32(i1.y * n + i1.x);
    var a: vec3<f32>;
    var b: vec3<f32>;
    var c: vec3<f32>;
    var d: vec3<f32>;
    if (ground) {
        a = radiosity_ground[k00].rgb;
        b = radiosity_ground[k10].rgb;
        c = radiosity_ground[k01].rgb;
        d = radiosity_ground[k11].rgb;
    } else {
        a = radiosity_cloud[k00].rgb;
        b = radiosity_cloud[k10].rgb;
        c = radiosity_cloud[k01].rgb;
        d = radiosity_cloud[k11].rgb;
    }
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

// Where the ray from `position_m` towards the sun crosses the layer's
// mid-plane. This is the geometrically correct parallax offset,
// (h_mid − y) tan θ_l along the sun's azimuth; Bouthors 2006 (§5.1) writes
// h·sin θ_l, which is short by the factor cos θ_l (a 2 km error for a layer
// 2 km up under a sun 45° high).
fn stratus_sun_crossing(position_m: vec3<f32>) -> vec2<f32> {
    let l = frame.sun_direction;
    let rise = stratus.window.x - position_m.y;
    return position_m.xz + l.xz * (rise / max(l.y, 1e-3));
}

// Fraction of the sun's light that reaches `position_m` through the layer
// as a directional beam (T₀ + T₁ + T₂ = T_C), per channel: the layer's
// shadow. 1 without a layer, above it or with the sun below the horizon.
fn stratus_sun_transmittance(position_m: vec3<f32>) -> vec3<f32> {
    let l = frame.sun_direction;
    if (!stratus_enabled() || l.y <= 0.0 || position_m.y >= stratus.window.x) {
        return vec3<f32>(1.0);
    }
    let h = stratus_thickness_at(stratus_sun_crossing(position_m));
    return slab_directional_transmittance(stratus, h, l.y);
}

// Indirect irradiance on ground of unit normal n at `position_m`: R_G from
// the radiosity (sky through the layer, the layer's diffuse light and the
// ground–cloud inter-reflections, for a horizontal receiver), carried to
// the slope by the clear sky's ratio of tilted to horizontal irradiance.
// `clear` is the clear-sky irradiance on n; returned as is without a layer
// or above it.
fn stratus_ground_irradiance(position_m: vec3<f32>, n: vec3<f32>, clear: vec3<f32>) -> vec3<f32> {
    if (!stratus_enabled() || position_m.y >= stratus.window.x) {
        return clear;
    }
    let up = sh_irradiance(lighting, vec3<f32>(0.0, 1.0, 0.0));
    let tilt = clear / max(up, vec3<f32>(1e-6));
    return stratus_radiosity_sample(true, position_m.xz) * tilt;
}

// The SH of a uniform lower hemisphere of unit exitance (radiance 1/π
// below the horizon, 0 above), in the nine coefficients: only the constant
// and the y terms are non-zero, and the irradiance they give on a plane of
// normal n is exactly (1 − n_y)/2, the lower hemisphere's share.
const STRATUS_GROUND_SH_0: f32 = 0.564190;
const STRATUS_GROUND_SH_Y: f32 = -0.488603;
// Rec. 709 luminance weights.
const STRATUS_LUMA: vec3<f32> = vec3<f32>(0.2126, 0.7152, 0.0722);

// The environment `l`'s light under the layer, as a change of its SH:
// L' = α Y(L) + β G, G the lower hemisphere above and Y(L) the SH's
// luminance. The clear environment's irradiance on an upward-facing plane
// U becomes the layer's R_G (α = R_G / Y(U): the sky's part keeps its
// angular shape and takes the deck's brightness and colour; a ratio per
// channel, R_G/U, would turn the clear sky's white haze red where the
// deck's grey replaces its blue), and its irradiance on a downward-facing
// plane, D, the ground's light, becomes R_C, what the radiosity gives the
// layer's base from the ground (lit by the sun through the gaps and the
// shadows and by R_G): β = R_C − α Y(D). Scaling the whole clear
// environment by R_G/U (what stratus_ground_irradiance does) lit a
// cumulus's base by the clear day's sunlit ground times the deck's
// brightness over the blue sky: 19 W m⁻² from below beside a cloud under
// the default scene's broken deck where the reference has 3–4
// (docs/REALISM.md, "A cumulus under a broken deck"). Identity without a
// layer or above its mid-plane.
struct StratusUnderLight {
    sky_scale: vec3<f32>,
    ground_add: vec3<f32>,
    under: bool,
}

fn stratus_under_light(l: Lighting, position_m: vec3<f32>) -> StratusUnderLight {
    var out: StratusUnderLight;
    out.sky_scale = vec3<f32>(1.0);
    out.ground_add = vec3<f32>(0.0);
    out.under = stratus_enabled() && position_m.y < stratus.window.x;
    if (out.under) {
        let up = sh_irradiance(l, vec3<f32>(0.0, 1.0, 0.0));
        let down = sh_irradiance(l, vec3<f32>(0.0, -1.0, 0.0));
        out.sky_scale = stratus_radiosity_sample(true, position_m.xz) / max(dot(up, STRATUS_LUMA), 1e-6);
        out.ground_add = stratus_radiosity_sample(false, position_m.xz) - out.sky_scale * dot(down, STRATUS_LUMA);
    }
    return out;
}

// `l` with its SH changed to L' = α Y(L) + β G (stratus_under_light).
fn stratus_layered_lighting(l: Lighting, u: StratusUnderLight) -> Lighting {
    var out = l;
    if (!u.under) {
        return out;
    }
    for (var k = 0u; k < 9u; k += 1u) {
        out.sh[k] = vec4<f32>(u.sky_scale * dot(l.sh[k].xyz, STRATUS_LUMA), l.sh[k].w);
    }
    out.sh[0] = out.sh[0] + vec4<f32>(STRATUS_GROUND_SH_0 * u.ground_add, 0.0);
    out.sh[1] = out.sh[1] + vec4<f32>(STRATUS_GROUND_SH_Y * u.ground_add, 0.0);
    return out;
}

// Irradiance on a surface of unit normal n at `position_m` from the
// environment `l`, under the layer the light that is there
// (stratus_under_light).
fn stratus_environment_irradiance(l: Lighting, position_m: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return sh_irradiance(stratus_layered_lighting(l, stratus_under_light(l, position_m)), n);
}

// The angular shape of the deck's diffuse light seen from below, (a, b)
// with the radiance at vertical cosine μ = (a + b μ) R_G/π: the escape
// function u(μ) = (3/7)(1 + 2μ) of a slab's transmitted diffuse light where
// the layer is drawn as faces (stratus.model = "marched"), uniform for the
// paper's slab ("bnl2006") and for the volume ("volume", whose broken deck
// is as bright towards the horizon as overhead; docs/REALISM.md).
fn stratus_deck_light_shape() -> vec2<f32> {
    if (stratus.model.x == 0u || stratus.model.y == 1u) {
        return vec2<f32>(1.0, 0.0);
    }
    return vec2<f32>(3.0 / 7.0, 6.0 / 7.0);
}

// The light the air scatters towards the eye from the diffuse field under
// the layer at `position_m`, by the air's weights for a diffuse field (the
// CPU twin is nimbus_physics::atmosphere::under_layer::diffuse_inscatter):
// the layer's light from above (R_G, the radiosity's irradiance on the
// ground, leaving the deck by the escape function, or uniform with
// stratus.model = "bnl2006" and "volume") and the ground's from below.
fn stratus_air_diffuse_inscatter(parts: AirParts, position_m: vec3<f32>, sun_transmittance: vec3<f32>) -> vec3<f32> {
    let from_above = stratus_radiosity_sample(true, position_m.xz);
    let sun_on_ground = sun_irradiance_at(position_m) * max(frame.sun_direction.y, 0.0) * sun_transmittance;
    let from_below = atmosphere.near_ground_albedo * (from_above + sun_on_ground);
    let shape = stratus_deck_light_shape();
    return (from_above * (shape.x * parts.above + shape.y * parts.above_cosine)
        + from_below * (parts.total - parts.above)) / PI;
}

// The aerial perspective between the camera and `position_m` under the
// layer, lit by the light that is there. The clear air's in-scattered light
// is the sun's single scattering plus the sky's light scattered again
// (Hillaire 2020's Ψ_ms σ_s). Under the layer the sun's part is dimmed by
// the layer's directional transmittance T_C along the path (without it,
// looking towards a sun hidden by the layer would show the aureole of
// sunlit air in front of the cloud; the sun's beams through the layer's
// gaps light the air they cross), and the sky's part is replaced by the
// layer's and the ground's diffuse light (stratus_air_diffuse_inscatter)
// over the share of the path below the layer's mid-plane, evaluated at the
// middle of that share.
fn stratus_aerial_perspective(position_m: vec3<f32>) -> vec4<f32> {
    let ap = aerial_perspective(position_m);
    if (!stratus_enabled()) {
        return ap;
    }
    let camera = frame.camera_position_m;
    let parts = aerial_perspective_parts(position_m);
    let clear_sky_light = max(ap.rgb - parts.sun_single, vec3<f32>(0.0));
    // The share of the path from the camera (t = 0) to the point (t = 1)
    // below the mid-plane, [t0, t1], and its middle.
    let mid_plane = stratus.window.x;
    var below = vec2<f32>(0.0, select(0.0, 1.0, camera.y < mid_plane));
    let rise = position_m.y - camera.y;
    if (abs(rise) > 1e-3) {
        let crossing = clamp((mid_plane - camera.y) / rise, 0.0, 1.0);
        below = select(vec2<f32>(crossing, 1.0), vec2<f32>(0.0, crossing), rise > 0.0);
    }
    let share = below.y - below.x;
    let middle = mix(camera, position_m, select(0.5, 0.5 * (below.x + below.y), share > 0.0));
    // T_C along the path: its two ends and the middle (weights ¼, ½, ¼).
    let middle_transmittance = stratus_sun_transmittance(middle);
    let shade = 0.25 * (stratus_sun_transmittance(camera) + stratus_sun_transmittance(position_m))
        + 0.5 * middle_transmittance;
    var light = parts.sun_single * shade + clear_sky_light;
    if (share > 0.0) {
        let under = stratus_air_diffuse_inscatter(parts, middle, middle_transmittance);
        light = parts.sun_single * shade + mix(clear_sky_light, under, share);
    }
    return vec4<f32>(light, ap.a);
}

// Radiance leaving a world point as seen from the camera, through air
// shadowed by the layer.
fn stratus_apply_aerial_perspective(radiance: vec3<f32>, position_m: vec3<f32>) -> vec3<f32> {
    let ap = stratus_aerial_perspective(position_m);
    return radiance * ap.a + ap.rgb;
}
