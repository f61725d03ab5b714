// import shader/cloud_shadow_uniform.wgsl
// The cumulus shadow on whatever is lit by the sun (terrain, the stratus
// layer, the clouds themselves). Layer 0 of the map is the depth of the
// nearest cloud core seen from the sun, layer 1 the farthest; a point
// behind the nearest core by Δ (at most the cores' thickness) receives the
// two-stream diffuse transmittance 1/(1 + ¾(1 − g) α_ρ Δ)
// (nimbus_physics::cumulus::shading::two_stream_transmittance), averaged
// over (2k + 1)² texels (percentage-closer filtering: soft edges). Needs
// shader/cloud_shadow_uniform.wgsl.

@group(3) @binding(1) var cloud_shadow_map: texture_depth_2d_array;

fn cloud_shadow_texel(texel: vec2<i32>, depth: f32) -> f32 {
    let front = textureLoad(cloud_shadow_map, texel, 0, 0);
    if (front >= 1.0) {
        return 1.0;
    }
    let back = textureLoad(cloud_shadow_map, texel, 1, 0);
    let crossed_m = clamp(depth - front, 0.0, max(back - front, 0.0)) * cloud_shadow.params.x;
    return 1.0 / (1.0 + 0.75 * (1.0 - cloud_shadow.params.z) * cloud_shadow.params.y * crossed_m);
}

// Fraction of the sun's light reaching `position_m` through the clouds.
fn cloud_shadow_transmittance(position_m: vec3<f32>) -> f32 {
    if (cloud_shadow.flags.x == 0u) {
        return 1.0;
    }
    let clip = cloud_shadow.clip_from_world * vec4<f32>(position_m, 1.0);
    let uv = vec2<f32>(clip.x * 0.5 + 0.5, 0.5 - clip.y * 0.5);
    if (any(uv <= vec2<f32>(0.0)) || any(uv >= vec2<f32>(1.0))) {
        return 1.0;
    }
    let size = cloud_shadow.params.w;
    let centre = vec2<i32>(uv * size);
    let k = i32(cloud_shadow.flags.y);
    let last = i32(size) - 1;
    var sum = 0.0;
    for (var dy = -k; dy <= k; dy += 1) {
        for (var dx = -k; dx <= k; dx += 1) {
            let texel = clamp(centre + vec2<i32>(dx, dy), vec2<i32>(0), vec2<i32>(last));
            sum += cloud_shadow_texel(texel, clip.z);
        }
    }
    let side = f32(2 * k + 1);
    return sum / (side * side);
}
