// import shader/fullscreen.wgsl
// Tone mapping: pre-exposed HDR radiance to display values. ACES filmic
// curve as fitted by Stephen Hill (RRT + ODT fit, "BakingLab", 2016), in the
// ACES AP1-like space of his input/output matrices; then, for 8-bit unorm
// outputs, the sRGB transfer function and triangular dithering of ±1 LSB so
// that smooth sky gradients do not band.

struct TonemapParams {
    // 1: write sRGB-encoded values (the target is a plain unorm format).
    encode_srgb: u32,
    // Dither amplitude in output code values (0 disables it).
    dither_lsb: f32,
    // Code values of the output (255 for 8-bit).
    code_values: f32,
    _padding: f32,
}

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<uniform> params: TonemapParams;
// Written by the exposure pass; only `tonemap_scale` is read here.
struct ExposureScale {
    ev100: f32,
    tonemap_scale: f32,
}
@group(0) @binding(2) var<storage, read> exposure: ExposureScale;

fn rrt_and_odt_fit(v: vec3<f32>) -> vec3<f32> {
    let a = v * (v + 0.0245786) - 0.000090537;
    let b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return a / b;
}

fn aces_fitted(color: vec3<f32>) -> vec3<f32> {
    // Matrices given by columns (Hill's are row-major).
    let input = mat3x3<f32>(
        vec3<f32>(0.59719, 0.07600, 0.02840),
        vec3<f32>(0.35458, 0.90834, 0.13383),
        vec3<f32>(0.04823, 0.01566, 0.83777),
    );
    let output = mat3x3<f32>(
        vec3<f32>(1.60475, -0.10208, -0.00327),
        vec3<f32>(-0.53108, 1.10813, -0.07276),
        vec3<f32>(-0.07367, -0.00605, 1.07602),
    );
    return clamp(output * rrt_and_odt_fit(input * color), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb_encode(linear: vec3<f32>) -> vec3<f32> {
    let c = clamp(linear, vec3<f32>(0.0), vec3<f32>(1.0));
    let low = c * 12.92;
    let high = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, c <= vec3<f32>(0.0031308));
}

// Deterministic per-pixel hash in [0, 1) (PCG, Jarzynski & Olano, JCGT 2020).
fn hash_unit(pixel: vec2<u32>, salt: u32) -> f32 {
    var v = pixel.x * 1664525u + pixel.y * 1013904223u + salt * 2654435769u;
    v = v * 747796405u + 2891336453u;
    let word = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
    return f32((word >> 22u) ^ word) * (1.0 / 4294967296.0);
}

@fragment
fn tonemap_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    let pixel = vec2<u32>(in.position.xy);
    let radiance = textureLoad(hdr, pixel, 0).rgb * exposure.tonemap_scale;
    let mapped = aces_fitted(radiance);
    if (params.encode_srgb == 0u) {
        return vec4<f32>(mapped, 1.0);
    }
    var encoded = srgb_encode(mapped);
    // Triangular PDF: the sum of two uniform variables, in (−1, 1) code values.
    let tpdf = vec3<f32>(
        hash_unit(pixel, 1u) + hash_unit(pixel, 2u),
        hash_unit(pixel, 3u) + hash_unit(pixel, 4u),
        hash_unit(pixel, 5u) + hash_unit(pixel, 6u),
    ) - 1.0;
    encoded += tpdf * params.dither_lsb / params.code_values;
    return vec4<f32>(clamp(encoded, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}
