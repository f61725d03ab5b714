//! The cumulus shader's terms on the GPU (`cumulus/shading.wgsl`) against
//! their CPU reference (`nimbus_physics::cumulus::shading`) on points that
//! cover front-lit, back-lit and grazing views, every lower level, the bump
//! and both light-trap models.

use crate::common;

use glam::DVec3;
use nimbus_physics::cumulus::forward_peak::ForwardPeakTable;
use nimbus_physics::cumulus::shading::{
    CumulusShading, LightTrapModel, PointLight, ShadingTerms, SurfacePoint, bump_height, shade,
};
use nimbus_render::AdapterPreference;
use nimbus_render::cumulus::{BUMP_LACUNARITY, CumulusUniform, FORWARD_PEAK_TEXTURE};
use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::scene::CumulusSettings;
use nimbus_render::shader;
use wgpu::util::DeviceExt;

const KERNEL: &str = r#"
struct TestPoint {
    normal_radius: vec4<f32>,
    n1_d1: vec4<f32>,
    n2_d2: vec4<f32>,
    n3_d3: vec4<f32>,
    radii_h: vec4<f32>,
    gradient: vec4<f32>,
    o: vec4<f32>,
    l: vec4<f32>,
    up: vec4<f32>,
}
@group(0) @binding(1) var<storage, read> points: array<TestPoint>;
@group(0) @binding(2) var<storage, read_write> results: array<vec4<f32>>;

@compute @workgroup_size(64)
fn terms_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&points)) {
        return;
    }
    let t = points[i];
    var p: CumulusPoint;
    p.normal = t.normal_radius.xyz;
    p.blob_radius_m = t.normal_radius.w;
    p.base_normals = array<vec3<f32>, 3>(t.n1_d1.xyz, t.n2_d2.xyz, t.n3_d3.xyz);
    p.base_distances = vec3<f32>(t.n1_d1.w, t.n2_d2.w, t.n3_d3.w);
    p.base_radii_m = t.radii_h.xyz;
    p.bump_height = t.radii_h.w;
    p.bump_gradient = t.gradient.xyz;
    p.blob_up = t.up.xyz;
    let terms = cumulus_shade_terms(p, t.o.xyz, t.l.xyz);
    results[4u * i] = vec4<f32>(terms.lambert, terms.light_traps, terms.forward, terms.optical_depth);
    results[4u * i + 1u] = vec4<f32>(terms.smoothed_normal, cumulus_opacity(terms));
    // The bump noise at the point's normal taken as noise coordinates.
    results[4u * i + 2u] = vec4<f32>(cumulus_bump_height(t.normal_radius.xyz * 7.3), 0.0, 0.0, 0.0);
    results[4u * i + 3u] = vec4<f32>(terms.forward_peak, terms.diffusion);
}
"#;

fn unit(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z).normalize()
}

fn points() -> Vec<(SurfacePoint, DVec3, DVec3)> {
    let mut out = Vec::new();
    let mut k = 0u32;
    let mut r = || {
        // A small deterministic sequence in [−1, 1].
        k = k.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        ((k >> 8) & 0xffff) as f64 / 32_767.5 - 1.0
    };
    for case in 0..240 {
        let normal = unit(r(), r() + 0.3, r());
        let n1 = (normal + DVec3::new(r(), r(), r()) * 0.4).normalize();
        let n2 = (n1 + DVec3::new(r(), r(), r()) * 0.3).normalize();
        let absent = case % 3 == 0;
        let o = match case % 4 {
            0 => normal,
            1 => unit(r(), r(), r()),
            2 => (normal + unit(r(), r(), r()) * 1.2).normalize(),
            _ => unit(normal.z, 0.05 * r(), -normal.x),
        };
        let l = match case % 5 {
            0 => -o,
            1 => (-o + DVec3::new(r(), r(), r()) * 0.1).normalize(),
            _ => unit(r(), r().abs() + 0.1, r()),
        };
        let point = SurfacePoint {
            normal,
            base_normals: if absent {
                vec![n1, n2, normal]
            } else {
                vec![n1, n2, n2]
            },
            base_distances: vec![
                0.6 * (r() + 1.0),
                0.5 * (r() + 1.0),
                if absent { 1.0e3 } else { 0.7 },
            ],
            base_radii_m: vec![
                125.0 * (1.0 + 0.2 * r()),
                400.0,
                if absent { 0.0 } else { 900.0 },
            ],
            blob_radius_m: 45.0 * (1.0 + 0.3 * r()),
            blob_up: (normal + DVec3::new(r(), r(), r()) * 0.5).normalize(),
            bump_height: 0.5 * (r() + 1.0),
            bump_gradient: DVec3::new(r(), r(), r()) * 2.0,
        };
        out.push((point, o, l));
    }
    out
}

fn pack(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

#[test]
fn gpu_terms_match_the_cpu_reference() {
    let h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let device = &h.gpu.device;
    let cases = points();
    // A Gaussian peak (σ 1°, 1.5°, 0.8° per channel) holding half the
    // scattering: the shader's lookup does not depend on how it was made.
    let peak_table = ForwardPeakTable::gaussian([1f64, 1.5, 0.8].map(f64::to_radians), [0.5; 3]);
    let peak_texture = device.create_texture_with_data(
        &h.gpu.queue,
        &FORWARD_PEAK_TEXTURE,
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&peak_table.rgba_texels()),
    );
    let peak_view = peak_texture.create_view(&Default::default());
    for model in [LightTrapModel::Furrows, LightTrapModel::Arctan] {
        let mut settings = CumulusSettings::default();
        settings.shading = CumulusShading {
            trap_model: model,
            diffusion: 0.4,
            forward_peak: 1.0,
            ..CumulusShading::default()
        };
        let uniform = CumulusUniform::new(
            &settings,
            &nimbus_physics::atmosphere::AtmosphereParams::default(),
            [0.0, 1.0, 0.0],
        );
        let data: Vec<[[f32; 4]; 9]> = cases
            .iter()
            .map(|(p, o, l)| {
                [
                    pack(p.normal, p.blob_radius_m),
                    pack(p.base_normals[0], p.base_distances[0]),
                    pack(p.base_normals[1], p.base_distances[1]),
                    pack(p.base_normals[2], p.base_distances[2]),
                    [
                        p.base_radii_m[0] as f32,
                        p.base_radii_m[1] as f32,
                        p.base_radii_m[2] as f32,
                        p.bump_height as f32,
                    ],
                    pack(p.bump_gradient, 0.0),
                    pack(*o, 0.0),
                    pack(*l, 0.0),
                    pack(p.blob_up, 0.0),
                ]
            })
            .collect();
        let source = {
            let mut files = shader::DRAWING_LIBRARIES.to_vec();
            files.extend([
                nimbus_render::stratus::FIELD,
                nimbus_render::cumulus::SHADING,
            ]);
            shader::compose(&files) + KERNEL
        };
        let uniform_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("terms uniform"),
            entries: &[
                nimbus_render::binding::uniform_layout_entry(
                    0,
                    wgpu::ShaderStages::COMPUTE,
                    std::mem::size_of::<CumulusUniform>() as u64,
                ),
                nimbus_render::binding::texture_entry(
                    1,
                    wgpu::TextureViewDimension::D2,
                    false,
                    wgpu::ShaderStages::COMPUTE,
                ),
            ],
        });
        let uniform_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("terms uniform"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let uniform_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("terms uniform"),
            layout: &uniform_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&peak_view),
                },
            ],
        });
        // Nine vec4 per point in, four vec4 out.
        let gpu: Vec<[f32; 4]> = common::run_kernel(
            &h,
            &common::Kernel {
                label: "cumulus terms test",
                source: &source,
                entry: "terms_kernel",
                input: bytemuck::cast_slice(&data),
                input_stride: 144,
                count: cases.len(),
                outputs_per_item: 4,
                extra: &[common::ExtraGroup {
                    index: 1,
                    layout: &uniform_layout,
                    group: &uniform_group,
                }],
            },
        );
        let light = PointLight {
            to_observer: DVec3::Z,
            to_sun: DVec3::Y,
            sun_radiance: [1.0; 3],
            ambient_radiance: [0.0; 3],
            shadow: 1.0,
            forward_shadow: 1.0,
            forward_peak: Some(&peak_table),
        };
        let (mut glowing, mut partly_transparent, mut lit_by_the_peak) = (0, 0, 0);
        for (i, (point, o, l)) in cases.iter().enumerate() {
            let cpu = shade(
                point,
                &PointLight {
                    to_observer: *o,
                    to_sun: *l,
                    ..light
                },
                &settings.shading,
                ShadingTerms::default(),
            );
            let [g0, g1, g2, g3] = [gpu[4 * i], gpu[4 * i + 1], gpu[4 * i + 2], gpu[4 * i + 3]];
            let close = |a: f32, b: f64, tol: f64| (a as f64 - b).abs() <= tol * (1.0 + b.abs());
            let context = format!("{model:?} case {i}: gpu {g0:?} {g1:?}, cpu {cpu:?}");
            assert!(close(g0[0], cpu.lambert, 1e-4), "lambert, {context}");
            assert!(
                close(g0[1], cpu.light_traps, 1e-4),
                "light traps, {context}"
            );
            // The lobe is cos θ^(α_g/ρ): below ρ = 0.05 its exponent (> 20)
            // magnifies τ's f32 error; compare it above.
            if cpu.optical_depth > 0.05 {
                assert!(close(g0[2], cpu.forward, 2e-3), "forward, {context}");
            }
            // The chord integral cancels terms of order R² in f32: a few
            // millimetres of chord, 2·10⁻³ in τ at worst.
            let tau_error = (g0[3] as f64 - cpu.optical_depth).abs();
            assert!(tau_error <= 2e-3 + 1e-4 * cpu.optical_depth, "τ, {context}");
            assert!(
                (g1[3] as f64 - cpu.opacity).abs() <= 2e-3,
                "opacity, {context}"
            );
            for (gpu_c, cpu_c) in g1[..3].iter().zip(cpu.smoothed_normal.to_array()) {
                assert!(close(*gpu_c, cpu_c, 1e-4), "N′, {context}");
            }
            let h_cpu = bump_height(
                point.normal * 7.3,
                f64::from(BUMP_LACUNARITY),
                settings.shading.bump_octaves,
            );
            assert!(close(g2[0], h_cpu, 1e-4), "bump {} vs {h_cpu}", g2[0]);
            assert!(close(g3[3], cpu.diffusion, 1e-4), "diffusion, {context}");
            // P = π F(θ, τ): where τ is well inside the table (its f32 error
            // moves the lookup little), to the table's own f32 precision.
            for (gpu_c, cpu_c) in g3[..3].iter().zip(cpu.forward_peak) {
                let tolerance = 2e-3 * (1.0 + cpu_c) + cpu_c * (cpu.optical_depth * 1e-3).min(0.05);
                assert!(
                    (f64::from(*gpu_c) - cpu_c).abs() <= tolerance,
                    "forward peak, {context}"
                );
            }
            lit_by_the_peak += usize::from(cpu.forward_peak[1] > 0.1);
            glowing += usize::from(cpu.forward > 0.5);
            partly_transparent += usize::from(cpu.opacity > 0.05 && cpu.opacity < 0.95);
        }
        // The cases reach the corona's regimes, not only the opaque body.
        assert!(
            glowing > 10 && partly_transparent > 10 && lit_by_the_peak > 5,
            "{glowing} glowing, {partly_transparent} partly transparent, {lit_by_the_peak} lit by the peak"
        );
    }
}

/// The cloud shadow map kept while the wind carries the field (drawn once,
/// then translated with the drift) gives the picture a renderer that draws
/// it for that frame gives: the default scene without rain or keyframes,
/// five seconds of an 8 m/s wind later, against a fresh renderer.
#[test]
fn a_kept_shadow_map_shades_as_a_redrawn_one() {
    let mut scene = nimbus_render::Scene::embedded_default();
    scene.rain = None;
    scene.keyframes.clear();
    scene.terrain.resolution = 64;
    scene.camera.auto_exposure = false;
    let (width, height) = (64, 36);
    let mut kept = HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter");
    kept.render_hdr(&scene, width, height, 0.0).expect("frame");
    assert!(
        kept.renderer.cumulus().shadow_redrawn(),
        "the first frame draws the map"
    );
    let carried = kept.render_hdr(&scene, width, height, 5.0).expect("frame");
    assert!(
        !kept.renderer.cumulus().shadow_redrawn(),
        "the drifted field keeps its map"
    );
    let mut fresh = HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter");
    let redrawn = fresh.render_hdr(&scene, width, height, 5.0).expect("frame");
    assert!(fresh.renderer.cumulus().shadow_redrawn());
    let luminance = |p: &[f32; 3]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let mean = redrawn.pixels.iter().map(luminance).sum::<f32>() / redrawn.pixels.len() as f32;
    let largest_difference = |image: &[[f32; 3]]| {
        image
            .iter()
            .zip(&redrawn.pixels)
            .map(|(a, b)| (luminance(a) - luminance(b)).abs())
            .fold(0.0f32, f32::max)
    };
    let largest = largest_difference(&carried.pixels);
    eprintln!("kept against redrawn: largest luminance difference {largest}, mean {mean}");
    assert!(
        largest <= 1e-3 * mean,
        "largest difference {largest} against a mean luminance of {mean}"
    );
    // The shadows are in the picture: without them it differs far more.
    let mut unshadowed = scene.clone();
    if let Some(cumulus) = &mut unshadowed.cumulus {
        cumulus.terms.shadow = false;
    }
    let bare = fresh
        .render_hdr(&unshadowed, width, height, 5.0)
        .expect("frame");
    let shadowing = largest_difference(&bare.pixels);
    assert!(
        shadowing > 0.05 * mean,
        "the clouds' shadows change the picture by at most {shadowing}"
    );
}
