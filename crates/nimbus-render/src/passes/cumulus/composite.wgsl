// import shader/fullscreen.wgsl
// Composites the cumulus fringes' weighted blended transparency over the HDR
// target (McGuire & Bavoil 2013, eq. 6): C = Σ w α C / Σ w α, coverage
// 1 − Π(1 − α), blended as premultiplied colour. Needs fullscreen.wgsl.

@group(0) @binding(0) var fringe_accumulation: texture_2d<f32>;
@group(0) @binding(1) var fringe_revealage: texture_2d<f32>;

@fragment
fn cumulus_composite_fragment(in: FullscreenOutput) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(in.position.xy);
    let revealage = textureLoad(fringe_revealage, texel, 0).r;
    if (revealage >= 1.0) {
        discard;
    }
    let accumulation = textureLoad(fringe_accumulation, texel, 0);
    let colour = accumulation.rgb / max(accumulation.a, 1e-5);
    let coverage = 1.0 - revealage;
    return vec4<f32>(colour * coverage, coverage);
}
