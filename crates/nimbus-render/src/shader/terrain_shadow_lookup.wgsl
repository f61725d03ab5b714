// The terrain's shadow in the air: whether a point above the relief sees
// the sun over its ridges (clouds and rain behind a mountain at a low sun).
// The ceiling map holds, over the terrain's square, the height above which
// each vertical line sees the centre of the sun's disk
// (nimbus_physics::terrain::sun_shadow_ceiling_m, computed when the
// terrain or the sun changes; frame/cloud_lighting.rs, bindings 7 and 8).
// Needs common.wgsl.

struct TerrainShadow {
    // Half the side of the terrain's square, m; 1 with a relief, 0
    // without; the half-width of the shadow's edge in height, m; unused.
    square: vec4<f32>,
}

@group(3) @binding(7) var terrain_shadow_ceiling: texture_2d<f32>;
@group(3) @binding(8) var<uniform> terrain_shadow: TerrainShadow;

// The ceiling's height at world (x, z), m: bilinear between texel centres,
// clamped at the square's edge texels. Twin of the CPU map's texel layout
// (centres at −½ side + (i + ½) side / n).
fn terrain_shadow_ceiling_at(xz: vec2<f32>) -> f32 {
    let n = i32(textureDimensions(terrain_shadow_ceiling).x);
    let half = terrain_shadow.square.x;
    return load_bilinear_r(terrain_shadow_ceiling, (xz + half) / (2.0 * half) * f32(n) - 0.5, n);
}

// Fraction of the sun's disk that `position_m` sees over the relief, in
// [0, 1]: 1 beyond the terrain's square (the open sea shades nothing) or
// without a relief; a smooth step over the edge's half-width across the
// ceiling.
fn terrain_sun_visibility(position_m: vec3<f32>) -> f32 {
    let half = terrain_shadow.square.x;
    if (terrain_shadow.square.y == 0.0 || any(abs(position_m.xz) > vec2<f32>(half))) {
        return 1.0;
    }
    let edge = terrain_shadow.square.z;
    return smoothstep(-edge, edge, position_m.y - terrain_shadow_ceiling_at(position_m.xz));
}
