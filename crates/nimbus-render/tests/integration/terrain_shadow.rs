//! The terrain's shadow in the air (group 3, bindings 7 and 8): the WGSL
//! lookup `terrain_sun_visibility` against the CPU shadow ceiling
//! `nimbus_physics::terrain::sun_shadow_ceiling_m` of the same terrain and
//! sun, through the map the renderer uploaded.

use crate::common;

use nimbus_physics::terrain::{SHADOW_CEILING_TEXELS, sun_shadow_ceiling_m};
use nimbus_render::frame::cloud_lighting::TERRAIN_SHADOW_EDGE_M;
use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::{AdapterPreference, Scene};

/// A test kernel around the lookup: per query point (x, y, z, unused) the
/// ceiling there and the sun's visibility.
const TERRAIN_SHADOW_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> shadow_queries: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> shadow_values: array<f32>;

@compute @workgroup_size(64)
fn terrain_shadow_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&shadow_queries)) {
        return;
    }
    let q = shadow_queries[id.x].xyz;
    shadow_values[2u * id.x] = terrain_shadow_ceiling_at(q.xz);
    shadow_values[2u * id.x + 1u] = terrain_sun_visibility(q);
}
";

fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The CPU twin of the lookup's bilinear interpolation between texel
/// centres, clamped at the edge texels.
fn ceiling_at(ceiling: &[f32], half_m: f64, x: f64, z: f64) -> f64 {
    let n = SHADOW_CEILING_TEXELS;
    let texel = |v: f64| (v + half_m) / (2.0 * half_m) * n as f64 - 0.5;
    let (px, pz) = (texel(x), texel(z));
    let (fx, fz) = (px - px.floor(), pz - pz.floor());
    let index = |p: f64, d: i64| (p.floor() as i64 + d).clamp(0, n as i64 - 1) as usize;
    let at = |i: usize, j: usize| f64::from(ceiling[j * n + i]);
    let (i0, i1, j0, j1) = (index(px, 0), index(px, 1), index(pz, 0), index(pz, 1));
    let lower = at(i0, j0) + (at(i1, j0) - at(i0, j0)) * fx;
    let upper = at(i0, j1) + (at(i1, j1) - at(i0, j1)) * fx;
    lower + (upper - lower) * fz
}

/// Mountains 1400 m high under a sun 8° high: the GPU's ceiling equals the
/// CPU's to single precision, and its visibility is the smooth step across
/// it (dark deep in a ridge's shadow, lit above it and beyond the square).
#[test]
fn gpu_terrain_shadow_matches_the_cpu_ceiling() {
    let scene = Scene::from_toml_str(
        "[camera]\nposition_m = [-6000.0, 300.0, 2000.0]\n\
         [sun]\nazimuth_deg = 250.0\nelevation_deg = 8.0\n\
         [terrain]\nresolution = 128\nheight_scale_m = 1400.0\n",
        "terrain-shadow-test.toml",
    )
    .expect("scene");
    let mut h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    h.render_frame(&scene, 32, 18, 0.0).expect("frame");
    let terrain = h.renderer.terrain().terrain().expect("terrain").clone();
    let half_m = 0.5 * terrain.params.extent_m;
    let cpu = sun_shadow_ceiling_m(&terrain, scene.sun.direction());
    // Points over the square at heights from the ground up, and beyond it.
    let mut queries: Vec<[f32; 4]> = Vec::new();
    for k in 0..400 {
        let u = (k as f64 * 0.618_034) % 1.0;
        let v = (k as f64 * 0.754_878) % 1.0;
        let (x, z) = ((u - 0.5) * 2.0 * half_m, (v - 0.5) * 2.0 * half_m);
        let y = ceiling_at(&cpu, half_m, x, z) + (k % 9) as f64 * 20.0 - 80.0;
        queries.push([x as f32, y as f32, z as f32, 0.0]);
    }
    queries.push([(half_m + 100.0) as f32, 10.0, 0.0, 0.0]);
    let source = {
        let mut files = nimbus_render::shader::DRAWING_LIBRARIES.to_vec();
        files.push(nimbus_render::shader::TERRAIN_SHADOW_LOOKUP);
        nimbus_render::shader::compose(&files) + TERRAIN_SHADOW_KERNEL
    };
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "terrain shadow test",
            source: &source,
            entry: "terrain_shadow_kernel",
            input: bytemuck::cast_slice(&queries),
            input_stride: 16,
            count: queries.len(),
            outputs_per_item: 2,
            extra: &[common::ExtraGroup {
                index: 3,
                layout: h.renderer.frame_resources().cloud_lighting.layout(),
                group: h.renderer.frame_resources().cloud_lighting.bind_group(),
            }],
        },
    );
    let (mut dark, mut lit) = (0, 0);
    for (q, values) in queries.iter().zip(gpu.chunks(2)).take(400) {
        let (x, y, z) = (f64::from(q[0]), f64::from(q[1]), f64::from(q[2]));
        let ceiling = ceiling_at(&cpu, half_m, x, z);
        assert!(
            (f64::from(values[0]) - ceiling).abs() < 1e-3 * ceiling.abs().max(1.0),
            "{q:?}: GPU ceiling {}, CPU {ceiling}",
            values[0]
        );
        let edge = f64::from(TERRAIN_SHADOW_EDGE_M);
        let visibility = smoothstep(-edge, edge, y - ceiling);
        assert!(
            (f64::from(values[1]) - visibility).abs() < 2e-3,
            "{q:?}: GPU visibility {}, CPU {visibility}",
            values[1]
        );
        dark += usize::from(visibility == 0.0 && ceiling > 200.0);
        lit += usize::from(visibility == 1.0);
    }
    // The queries cross the ceiling: some deep in the shadow over ground
    // well below it, some above it.
    assert!(dark > 10 && lit > 100, "{dark} dark, {lit} lit");
    // Beyond the square nothing shades the air.
    assert_eq!(gpu[2 * 400 + 1], 1.0);
}
