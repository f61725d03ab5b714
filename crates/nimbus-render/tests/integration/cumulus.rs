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

fn peak_source_angle_rad(i: u32) -> f32 {
    return 0.25 * f32(i % 23u) * 0.0174533;
}
fn peak_source_depth(i: u32) -> f32 {
    return 0.37 * f32(i % 31u);
}

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
    // And the peak's last-scattering source H at an angle and depth from
    // the case's index (the volume march's lookup).
    let h = cumulus_forward_peak_source(peak_source_angle_rad(i), peak_source_depth(i));
    results[4u * i + 2u] = vec4<f32>(cumulus_bump_height(t.normal_radius.xyz * 7.3), h);
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

/// The pass's group 1 for a compute kernel: the uniform at binding 0 and
/// the textures from binding 1 on.
fn cumulus_group(
    device: &wgpu::Device,
    uniform: &CumulusUniform,
    textures: &[&wgpu::TextureView],
) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let mut entries = vec![nimbus_render::binding::uniform_layout_entry(
        0,
        wgpu::ShaderStages::COMPUTE,
        std::mem::size_of::<CumulusUniform>() as u64,
    )];
    for binding in 1..=textures.len() as u32 {
        entries.push(nimbus_render::binding::texture_entry(
            binding,
            wgpu::TextureViewDimension::D2,
            false,
            wgpu::ShaderStages::COMPUTE,
        ));
    }
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("cumulus test group"),
        entries: &entries,
    });
    let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("cumulus test uniform"),
        contents: bytemuck::bytes_of(uniform),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let mut resources = vec![buffer.as_entire_binding()];
    resources.extend(
        textures
            .iter()
            .map(|v| wgpu::BindingResource::TextureView(v)),
    );
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("cumulus test group"),
        layout: &layout,
        entries: &resources
            .into_iter()
            .enumerate()
            .map(|(i, resource)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource,
            })
            .collect::<Vec<_>>(),
    });
    (layout, group)
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
        let (uniform_layout, uniform_group) = cumulus_group(device, &uniform, &[&peak_view]);
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
            // H(θ, τ) against ForwardPeakTable::last_scattering_at, the
            // kernel's θ and τ (f32 there) from the case's index.
            let (angle, depth) = (
                f64::from(0.25 * (i % 23) as f32 * 0.017_453_3),
                f64::from(0.37 * (i % 31) as f32),
            );
            let h_cpu = peak_table.last_scattering_at(angle, depth);
            for (gpu_c, cpu_c) in g2[1..].iter().zip(h_cpu) {
                assert!(
                    (f64::from(*gpu_c) - cpu_c).abs() <= 2e-3 * (1.0 + cpu_c),
                    "peak source at θ {angle} τ {depth}: gpu {gpu_c} cpu {cpu_c}"
                );
            }
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

fn luminance(p: &[f32; 3]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

fn mean_luminance(pixels: &[[f32; 3]]) -> f32 {
    pixels.iter().map(luminance).sum::<f32>() / pixels.len() as f32
}

/// The largest difference in luminance between two images' pixels.
fn largest_luminance_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (luminance(p) - luminance(q)).abs())
        .fold(0.0f32, f32::max)
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
    let mean = mean_luminance(&redrawn.pixels);
    let largest_difference =
        |image: &[[f32; 3]]| largest_luminance_difference(image, &redrawn.pixels);
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

/// The volume model's light atlases, kept while the lighting holds, are
/// rendered again when it changes: the front-lit cumulus over flat ground,
/// drawn over a dark ground and then, by the same renderer, over a bright
/// one (more light from below: a new `Lighting`, the same sun), gives the
/// picture a fresh renderer gives over the bright ground; and the ground's
/// light is in that picture (the two grounds differ far more).
#[test]
fn kept_light_atlases_follow_the_lighting() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes/cumulus-front-lit.toml");
    let mut dark = nimbus_render::Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
    dark.camera.auto_exposure = false;
    dark.ground.terrain = false;
    dark.ground.albedo = [0.05; 3];
    if let Some(cumulus) = &mut dark.cumulus {
        cumulus.shading.model = nimbus_physics::cumulus::shading::CumulusShadingModel::Volume;
    }
    let mut bright = dark.clone();
    bright.ground.albedo = [0.9; 3];
    let (width, height) = (64, 36);
    let mut kept = HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter");
    kept.render_hdr(&dark, width, height, 0.0).expect("frame");
    let followed = kept.render_hdr(&bright, width, height, 0.0).expect("frame");
    let mut fresh = HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter");
    let redrawn = fresh
        .render_hdr(&bright, width, height, 0.0)
        .expect("frame");
    let over_dark = fresh.render_hdr(&dark, width, height, 0.0).expect("frame");
    let mean = mean_luminance(&redrawn.pixels);
    let largest_difference =
        |image: &[[f32; 3]]| largest_luminance_difference(image, &redrawn.pixels);
    let largest = largest_difference(&followed.pixels);
    let ground = largest_difference(&over_dark.pixels);
    eprintln!("kept against fresh: largest {largest}; the grounds differ by {ground}; mean {mean}");
    assert!(
        largest <= 1e-3 * mean,
        "largest difference {largest} against a mean luminance of {mean}"
    );
    assert!(
        ground > 0.05 * mean,
        "the ground changes the picture by {ground}"
    );
}

const TRANSPORT_KERNEL: &str = r#"
struct TransportCase {
    low_c_b: vec4<f32>,
    low_diagonal_xy: vec4<f32>,
    low_yz_xz: vec4<f32>,
    high_c_b: vec4<f32>,
    high_diagonal_xy: vec4<f32>,
    high_yz_xz: vec4<f32>,
    // scale, cos yaw, sin yaw, τ.
    instance: vec4<f32>,
    normal: vec4<f32>,
    o: vec4<f32>,
    l: vec4<f32>,
}
@group(0) @binding(1) var<storage, read> cases: array<TransportCase>;
@group(0) @binding(2) var<storage, read_write> results: array<vec4<f32>>;

fn test_environment() -> Lighting {
    var l: Lighting;
    for (var k = 0; k < 9; k += 1) {
        let x = f32(k);
        l.sh[k] = vec4<f32>(1.0 / (1.0 + x), 0.5 - 0.1 * x, 0.2 + 0.05 * x, 0.0);
    }
    return l;
}

@compute @workgroup_size(64)
fn transport_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&cases)) {
        return;
    }
    let c = cases[i];
    var t: CumulusTransferVertex;
    t.low_c_b = c.low_c_b;
    t.low_diagonal_xy = c.low_diagonal_xy;
    t.low_yz_xz = c.low_yz_xz;
    t.high_c_b = c.high_c_b;
    t.high_diagonal_xy = c.high_diagonal_xy;
    t.high_yz_xz = c.high_yz_xz;
    var inst: CumulusInstance;
    inst.offset_scale = vec4<f32>(0.0, 0.0, 0.0, c.instance.x);
    inst.rotation_noise = vec4<f32>(c.instance.y, c.instance.z, 0.0, 0.0);
    let f = cumulus_transfer_at(t, inst);
    let environment = cumulus_transfer_environment(f, test_environment());
    var terms: CumulusTerms;
    terms.smoothed_normal = c.normal.xyz;
    terms.optical_depth = c.instance.w;
    terms.forward_peak = vec3<f32>(0.25, 0.5, 0.75);
    let sun = vec3<f32>(1.0, 0.9, 0.8);
    let radiance = cumulus_transport_radiance(terms, normalize(c.normal.xyz + vec3<f32>(0.0, 0.5, 0.0)), f, c.o.xyz, c.l.xyz, environment, sun,
        vec3<f32>(0.9), vec3<f32>(0.7), vec3<f32>(0.4), vec3<f32>(0.6));
    let mu0 = dot(c.normal.xyz, c.l.xyz);
    let mu = saturate(dot(c.normal.xyz, c.o.xyz));
    results[3u * i] = vec4<f32>(cumulus_transfer_value(f, c.l.xyz), cumulus_single_scattering(mu0, mu, c.instance.w), 0.0, 0.0);
    results[3u * i + 1u] = vec4<f32>(environment, 0.0);
    results[3u * i + 2u] = vec4<f32>(radiance, 0.0);
}
"#;

/// The transport model's WGSL (`cumulus_transfer_at`, `_value`,
/// `_environment`, `cumulus_single_scattering`,
/// `cumulus_transport_radiance`) against its CPU twin
/// (`nimbus_physics::cumulus::transport`): the transfer interpolated in
/// ln(scale) and turned with the cloud, its environment integral, the slab
/// factor and the radiance, on points lit from the front, from behind and
/// grazing.
#[test]
fn gpu_transport_matches_the_cpu_twin() {
    use nimbus_physics::cumulus::transport::{
        SphericalQuadratic, TransportPoint, single_scattering_factor, transport_radiance,
    };
    use nimbus_render::cumulus::{PHASE_TEXELS, PHASE_TEXTURE};
    let h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let device = &h.gpu.device;
    // A smooth phase-like table per channel, sr⁻¹.
    let phase_at = |c: usize, theta: f64| 0.05 + 0.3 * (1.0 + theta.cos()).powi(2 + c as i32) / 4.0;
    let mut phase_rgba = vec![0.0f32; 4 * PHASE_TEXELS];
    for i in 0..PHASE_TEXELS {
        let theta = std::f64::consts::PI * i as f64 / (PHASE_TEXELS - 1) as f64;
        for c in 0..3 {
            phase_rgba[4 * i + c] = phase_at(c, theta) as f32;
        }
    }
    let phase_cpu = |cos_theta: f64| -> [f64; 3] {
        let x =
            cos_theta.clamp(-1.0, 1.0).acos() / std::f64::consts::PI * (PHASE_TEXELS - 1) as f64;
        let j = (x.floor() as usize).min(PHASE_TEXELS - 2);
        let t = x - j as f64;
        std::array::from_fn(|c| {
            let (a, b) = (
                phase_rgba[4 * j + c] as f64,
                phase_rgba[4 * j + 4 + c] as f64,
            );
            a + t * (b - a)
        })
    };
    let texture_of = |desc: &wgpu::TextureDescriptor<'_>, data: &[f32]| {
        device
            .create_texture_with_data(
                &h.gpu.queue,
                desc,
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(data),
            )
            .create_view(&Default::default())
    };
    let peak_view = texture_of(
        &FORWARD_PEAK_TEXTURE,
        &ForwardPeakTable::gaussian([0.02; 3], [0.5; 3]).rgba_texels(),
    );
    let phase_view = texture_of(&PHASE_TEXTURE, &phase_rgba);
    let settings = CumulusSettings::default();
    let mut uniform = CumulusUniform::new(
        &settings,
        &nimbus_physics::atmosphere::AtmosphereParams::default(),
        [0.0, 1.0, 0.0],
    );
    let (scale_low, scale_high, truncation) = (0.5f64, 1.25f64, 0.55f64);
    uniform.transport = [
        scale_low.ln() as f32,
        (1.0 / (scale_high / scale_low).ln()) as f32,
        truncation as f32,
        PHASE_TEXELS as f32,
    ];
    uniform.extension[1] = 1.0;
    // Cases: random forms, scales inside and beyond the range, yaws, views.
    let mut k = 7u32;
    let mut r = || {
        k = k.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        ((k >> 8) & 0xffff) as f64 / 32_767.5 - 1.0
    };
    let mut cases = Vec::new();
    for case in 0..120 {
        let mut form = || SphericalQuadratic {
            constant: 0.5 + 0.3 * r(),
            linear: DVec3::new(r(), r(), r()) * 0.4,
            quadratic: [r(), r(), r(), r(), r(), r()].map(|v| 0.2 * v),
        };
        let (low, high) = (form(), form());
        let scale: f64 = [0.4, 0.5, 0.8, 1.25, 1.6][case % 5];
        let yaw = std::f64::consts::PI * r();
        let normal = unit(r(), r() + 0.2, r());
        let o = match case % 3 {
            0 => (normal + unit(r(), r(), r()) * 0.5).normalize(),
            1 => unit(r(), r(), r()),
            _ => unit(normal.z, 0.05 * r(), -normal.x),
        };
        let l = match case % 4 {
            0 => -o,
            1 => (normal + unit(r(), r(), r()) * 0.3).normalize(),
            _ => unit(r(), r().abs() + 0.1, r()),
        };
        let tau = [0.05, 0.7, 3.0, 40.0][case % 4] * (1.0 + 0.3 * r());
        cases.push((low, high, scale, yaw, normal, o, l, tau));
    }
    let data: Vec<[[f32; 4]; 10]> = cases
        .iter()
        .map(|(low, high, scale, yaw, normal, o, l, tau)| {
            let [a, b, c] = nimbus_render::cumulus::transfer::pack_form(low);
            let [d, e, f] = nimbus_render::cumulus::transfer::pack_form(high);
            [
                a,
                b,
                c,
                d,
                e,
                f,
                [
                    *scale as f32,
                    yaw.cos() as f32,
                    yaw.sin() as f32,
                    *tau as f32,
                ],
                pack(*normal, 0.0),
                pack(*o, 0.0),
                pack(*l, 0.0),
            ]
        })
        .collect();
    let source = {
        let mut files = shader::DRAWING_LIBRARIES.to_vec();
        files.extend([
            nimbus_render::stratus::FIELD,
            nimbus_render::cumulus::SHADING,
            nimbus_render::cumulus::SHADOW_UNIFORM,
            nimbus_render::cumulus::CUMULUS_WGSL,
        ]);
        shader::compose(&files) + TRANSPORT_KERNEL
    };
    let (layout, group) = cumulus_group(device, &uniform, &[&peak_view, &phase_view]);
    let gpu: Vec<[f32; 4]> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "cumulus transport test",
            source: &source,
            entry: "transport_kernel",
            input: bytemuck::cast_slice(&data),
            input_stride: 160,
            count: cases.len(),
            outputs_per_item: 3,
            extra: &[common::ExtraGroup {
                index: 1,
                layout: &layout,
                group: &group,
            }],
        },
    );
    let environment_sh: [[f64; 3]; 9] = std::array::from_fn(|k| {
        let x = k as f64;
        [1.0 / (1.0 + x), 0.5 - 0.1 * x, 0.2 + 0.05 * x]
    });
    let mut lit_from_behind = 0;
    for (i, (low, high, scale, yaw, normal, o, l, tau)) in cases.iter().enumerate() {
        let w = ((scale.ln() - scale_low.ln()) / (scale_high / scale_low).ln()).clamp(0.0, 1.0);
        let mix = |a: f64, b: f64| a + w * (b - a);
        let object = SphericalQuadratic {
            constant: mix(low.constant, high.constant),
            linear: low.linear + w * (high.linear - low.linear),
            quadratic: std::array::from_fn(|k| mix(low.quadratic[k], high.quadratic[k])),
        };
        let world = object.yawed(yaw.cos(), yaw.sin());
        let coefficients = world.to_sh();
        let environment: [f64; 3] =
            std::array::from_fn(|c| (0..9).map(|k| coefficients[k] * environment_sh[k][c]).sum());
        let radiance = transport_radiance(&TransportPoint {
            normal: *normal,
            exit_normal: (*normal + DVec3::new(0.0, 0.5, 0.0)).normalize(),
            to_observer: *o,
            to_sun: *l,
            optical_depth: *tau,
            truncation,
            transfer: world,
            phase: phase_cpu(-o.dot(*l)),
            sun_radiance: [1.0, 0.9, 0.8],
            environment_exitance: environment,
            layer_shadow: [0.9; 3],
            direct: [0.7; 3],
            forward_direct: [0.4; 3],
            forward_peak: std::array::from_fn(|c| [1.0, 0.9, 0.8][c] * 0.6 * [0.25, 0.5, 0.75][c]),
        });
        let mu0 = normal.dot(*l);
        let single = single_scattering_factor(mu0, normal.dot(*o).clamp(0.0, 1.0), *tau);
        lit_from_behind += usize::from(mu0 < 0.0 && single > 0.05);
        let [g0, g1, g2] = [gpu[3 * i], gpu[3 * i + 1], gpu[3 * i + 2]];
        let close = |a: f32, b: f64, tol: f64| (f64::from(a) - b).abs() <= tol * (1.0 + b.abs());
        let context = format!("case {i}: gpu {g0:?} {g1:?} {g2:?}");
        assert!(
            close(g0[0], world.value(*l), 2e-4),
            "T(l) {}, {context}",
            world.value(*l)
        );
        assert!(close(g0[1], single, 2e-3), "S {single}, {context}");
        for c in 0..3 {
            assert!(
                close(g1[c], environment[c], 2e-4),
                "environment {environment:?}, {context}"
            );
            assert!(
                close(g2[c], radiance[c], 3e-3),
                "radiance {radiance:?}, {context}"
            );
        }
    }
    assert!(
        lit_from_behind > 5,
        "{lit_from_behind} cases lit from behind"
    );
}

/// A test kernel around the sun cube's reading: per case four vec4 (the
/// cube's positive values and the excess, the negative values and the
/// beam's optical depth, the direction read and the asymmetry, the beam's
/// travel), the excess's shape and the value read out.
const SUN_CUBE_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> cube_cases: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> cube_values: array<f32>;

@compute @workgroup_size(64)
fn sun_cube_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (4u * id.x >= arrayLength(&cube_cases)) {
        return;
    }
    let a = cube_cases[4u * id.x];
    let b = cube_cases[4u * id.x + 1u];
    let c = cube_cases[4u * id.x + 2u];
    let d = cube_cases[4u * id.x + 3u];
    let shape = sun_cube_excess_shape(c.xyz, d.xyz, b.w, c.w);
    cube_values[2u * id.x] = shape;
    cube_values[2u * id.x + 1u] = sun_cube_toward(a.xyz, b.xyz, a.w, c.xyz, shape);
}
";

/// The in-cloud march's reading of the sun cube towards the camera
/// (`shader/diffusion.wgsl`: the ambient cube and the spread of the excess
/// along the beam) against its CPU twins
/// (`nimbus_physics::cumulus::interior::sun_cube_excess_shape` and
/// `sun_cube_toward`), over directions on and between the axes, beams and
/// depths, within 1e-4.
#[test]
fn gpu_sun_cube_reading_matches_the_cpu_twin() {
    use glam::DVec3;
    use nimbus_physics::cumulus::interior::{sun_cube_excess_shape, sun_cube_toward};
    let h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let cube = [0.7f32, 0.05, 1.3, 0.2, 2.5, 0.4];
    let excess = 0.9f32;
    let single = |v: DVec3| v.normalize().as_vec3().as_dvec3();
    let mut directions: Vec<DVec3> = Vec::new();
    for x in [-1.0, -0.3, 0.0, 0.6, 1.0] {
        for y in [-1.0, -0.5, 0.0, 0.8] {
            for z in [-0.9, 0.0, 0.2, 1.0] {
                let d = DVec3::new(x, y, z);
                if d.length() > 0.0 {
                    directions.push(single(d));
                }
            }
        }
    }
    let beams = [
        single(DVec3::new(0.3, -0.8, 0.52)),
        single(DVec3::new(-0.7, -0.4, 0.1)),
        DVec3::NEG_Y,
    ];
    let mut cases: Vec<(DVec3, DVec3, f32, f32)> = Vec::new();
    for &beam in &beams {
        for &d in directions.iter().chain([beam, -beam].iter()) {
            for (tau, g) in [(0.3f32, 0.74f32), (2.5, 0.74), (8.0, 0.85)] {
                cases.push((d, beam, tau, g));
            }
        }
    }
    let input: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|(d, beam, tau, g)| {
            [
                [cube[0], cube[2], cube[4], excess],
                [cube[1], cube[3], cube[5], *tau],
                [d.x as f32, d.y as f32, d.z as f32, *g],
                [beam.x as f32, beam.y as f32, beam.z as f32, 0.0],
            ]
        })
        .collect();
    let source = shader::compose(&[shader::DIFFUSION]) + SUN_CUBE_KERNEL;
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "sun cube test",
            source: &source,
            entry: "sun_cube_kernel",
            input: bytemuck::cast_slice(&input),
            input_stride: 64,
            count: cases.len(),
            outputs_per_item: 2,
            extra: &[],
        },
    );
    let cpu_cube = cube.map(f64::from);
    let mut spread = 0;
    for ((d, beam, tau, g), out) in cases.iter().zip(gpu.chunks(2)) {
        let shape = sun_cube_excess_shape(*d, *beam, f64::from(*tau), f64::from(*g));
        let value = sun_cube_toward(&cpu_cube, f64::from(excess), *d, shape);
        let context = format!("{d} beam {beam} τ {tau} g {g}: GPU {out:?}, CPU {shape} {value}");
        assert!((f64::from(out[0]) - shape).abs() < 1e-4, "{context}");
        assert!(
            (f64::from(out[1]) - value).abs() < 1e-4 * value.max(1.0),
            "{context}"
        );
        spread += usize::from(shape > 0.01 && shape < 0.99);
    }
    assert!(spread > 20, "{spread} cases between the axes and the beam");
}

/// A test kernel around the forward lobe: one (τ, cos θ, g) in, the lobe out.
const FORWARD_LOBE_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> lobe_cases: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> lobes: array<f32>;

@compute @workgroup_size(64)
fn forward_lobe_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&lobe_cases)) {
        return;
    }
    let c = lobe_cases[id.x];
    lobes[id.x] = forward_orders_lobe(c.x, c.y, c.z);
}
";

/// The in-cloud march's forward lobe of the sun's scattered light
/// (`shader/diffusion.wgsl`) against its CPU twin
/// (`nimbus_physics::cumulus::interior::forward_orders_lobe`) over optical
/// depths, angles and asymmetries, within 1e-4 relative.
#[test]
fn gpu_forward_orders_lobe_matches_the_cpu_twin() {
    use nimbus_physics::cumulus::interior::forward_orders_lobe;
    let h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let mut cases: Vec<[f32; 4]> = Vec::new();
    for tau in [0.0f32, 0.05, 0.7, 2.2, 5.0, 12.0, 40.0] {
        for c in [-1.0f32, -0.4, 0.0, 0.5, 0.9, 0.99, 1.0] {
            for g in [0.0f32, 0.5, 0.74, 0.85] {
                cases.push([tau, c, g, 0.0]);
            }
        }
    }
    let source = shader::compose(&[shader::DIFFUSION]) + FORWARD_LOBE_KERNEL;
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "forward lobe test",
            source: &source,
            entry: "forward_lobe_kernel",
            input: bytemuck::cast_slice(&cases),
            input_stride: 16,
            count: cases.len(),
            outputs_per_item: 1,
            extra: &[],
        },
    );
    for (case, g) in cases.iter().zip(&gpu) {
        let cpu = forward_orders_lobe(f64::from(case[0]), f64::from(case[1]), f64::from(case[2]));
        assert!(
            (f64::from(*g) - cpu).abs() < 1e-4 * cpu.max(1.0),
            "{case:?}: GPU {g}, CPU {cpu}"
        );
    }
}

/// The volume model (`cumulus.shading.model = "volume"`) draws a cloud
/// seen from outside where its mesh is, and writes the depth of its body:
/// the cloud's opaque pixels are the fitted model's (the same shape, the
/// mesh its iso-surface), and at its core the distance layer is the
/// cloud's, not the sky's, within its box.
#[test]
fn the_volume_model_draws_the_cloud_where_its_mesh_is_and_writes_its_depth() {
    use nimbus_physics::cumulus::shading::CumulusShadingModel;
    use nimbus_render::headless::SKY_DISTANCE_M;
    let mut scene = nimbus_render::Scene::from_toml_str(
        r#"
[camera]
aerial_perspective = false
position_m = [0.0, 350.0, 5200.0]
look_at_m = [0.0, 1850.0, 0.0]
fov_deg = 15.0
auto_exposure = false

[sun]
azimuth_deg = 165.0
elevation_deg = 35.0

[cumulus]
[[cumulus.clouds]]
position_m = [0.0, 1500.0, 0.0]
"#,
        "volume.toml",
    )
    .expect("scene");
    let (width, height) = (128, 72);
    let mut h = HeadlessRenderer::new(AdapterPreference::Auto).expect("a wgpu adapter");
    let mesh = h.render_layers(&scene, width, height, 0.0).expect("frame");
    let cumulus = scene.cumulus.as_mut().expect("cumulus");
    cumulus.shading = CumulusShading::of_model(CumulusShadingModel::Volume);
    let volume = h.render_layers(&scene, width, height, 0.0).expect("frame");
    let opaque = |l: &nimbus_render::headless::ImageLayers, i: usize| l.cloud_opacity[i] > 0.5;
    let count = (width * height) as usize;
    let both = (0..count)
        .filter(|&i| opaque(&mesh, i) && opaque(&volume, i))
        .count();
    let either = (0..count)
        .filter(|&i| opaque(&mesh, i) || opaque(&volume, i))
        .count();
    let overlap = both as f64 / either.max(1) as f64;
    // The core: pixels opaque in both and far from the sky in the mesh.
    let core: Vec<usize> = (0..count)
        .filter(|&i| mesh.cloud_opacity[i] > 0.99 && volume.cloud_opacity[i] > 0.99)
        .collect();
    let mut gaps: Vec<f32> = core
        .iter()
        .map(|&i| (volume.distance_m[i] - mesh.distance_m[i]).abs())
        .collect();
    gaps.sort_by(f32::total_cmp);
    let median_gap_m = gaps.get(gaps.len() / 2).copied().unwrap_or(f32::MAX);
    let at_sky = core
        .iter()
        .filter(|&&i| volume.distance_m[i] >= SKY_DISTANCE_M)
        .count();
    eprintln!(
        "cloud pixels {either}, overlap {overlap:.3}, core {} px, median depth gap {median_gap_m:.1} m, \
         core at the sky's distance {at_sky}",
        core.len()
    );
    assert!(either > 400, "the cloud covers {either} pixels");
    assert!(overlap > 0.75, "the opaque pixels overlap by {overlap}");
    assert!(core.len() > 250, "core of {} pixels", core.len());
    assert_eq!(at_sky, 0, "the volume's core writes its depth");
    // A scale-1 cumulus is ~800 m wide; its body's depth is the mesh's to
    // a fraction of that (the march's ½-transmittance point lies tens of
    // metres inside the iso-surface).
    assert!(median_gap_m < 120.0, "median depth gap {median_gap_m} m");
}

/// A test kernel around the sky's direct light: a sky, a view, droplets and
/// a transmittance in, the source per unit σ* out (rgb).
const SKY_DIRECT_KERNEL: &str = r"
struct SkyDirectCase {
    sh: array<vec4<f32>, 9>,
    toward_g: vec4<f32>,
    transmittance: vec4<f32>,
}
@group(0) @binding(1) var<storage, read> sky_cases: array<SkyDirectCase>;
@group(0) @binding(2) var<storage, read_write> sky_sources: array<f32>;

@compute @workgroup_size(64)
fn sky_direct_test_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&sky_cases)) {
        return;
    }
    let c = sky_cases[id.x];
    let kernel = sky_direct_kernel(c.sh, c.toward_g.w, c.toward_g.xyz);
    let s = sky_direct_source(kernel, c.transmittance);
    sky_sources[3u * id.x] = s.x;
    sky_sources[3u * id.x + 1u] = s.y;
    sky_sources[3u * id.x + 2u] = s.z;
}
";

/// The in-cloud march's sky direct light (`sky_direct_kernel` and
/// `sky_direct_source`, `shader/diffusion.wgsl`) against its CPU twin
/// (`nimbus_physics::cumulus::interior::SkyDirectKernel`) over views all
/// round, asymmetries and transmittances from isotropic to a narrow cap,
/// within 1e-4 of the sky's mean radiance.
#[test]
fn gpu_sky_direct_kernel_matches_the_cpu_twin() {
    use nimbus_physics::cumulus::interior::SkyDirectKernel;
    let h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    // A blue sky brighter overhead and towards +x, a dim green ground.
    let sky: [[f64; 3]; 9] = [
        [2.0, 2.6, 3.4],
        [0.8, 1.0, 1.4],
        [0.1, 0.1, 0.05],
        [0.3, 0.25, 0.2],
        [0.05, 0.04, 0.02],
        [-0.03, 0.02, 0.01],
        [0.2, 0.15, 0.1],
        [0.02, -0.01, 0.0],
        [-0.1, -0.05, 0.02],
    ];
    let sh: Vec<[f32; 4]> = sky
        .iter()
        .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 0.0])
        .collect();
    let mut cases: Vec<(DVec3, f32, [f32; 4])> = Vec::new();
    for i in 0..40u32 {
        let d = nimbus_physics::atmosphere::fibonacci_sphere(i, 40);
        let toward = DVec3::from_array(d);
        for (g, t) in [
            (0.0f32, [1.0f32, 0.0, 0.0, 0.0]),
            (0.74, [0.5, 0.0, -0.4, 0.1]),
            (0.85, [0.2, 0.15, 0.05, -0.1]),
            // A half-space open below (inside a base) and a narrow cap.
            (0.74, [0.5, 0.0, -0.75, 0.0]),
            (0.74, [0.1, 0.0, -0.25, 0.05]),
        ] {
            cases.push((toward, g, t));
        }
    }
    let input: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|(toward, g, t)| {
            let mut v = sh.clone();
            v.push([toward.x as f32, toward.y as f32, toward.z as f32, *g]);
            v.push(*t);
            v
        })
        .collect();
    let source = shader::compose(&[shader::DIFFUSION]) + SKY_DIRECT_KERNEL;
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "sky direct test",
            source: &source,
            entry: "sky_direct_test_kernel",
            input: bytemuck::cast_slice(&input),
            input_stride: 176,
            count: cases.len(),
            outputs_per_item: 3,
            extra: &[],
        },
    );
    let mean_radiance = 0.282_095 * sky[0][1];
    for ((toward, g, t), out) in cases.iter().zip(gpu.chunks(3)) {
        let kernel = SkyDirectKernel::new(&sky, f64::from(*g), *toward);
        let gradient = DVec3::new(f64::from(t[1]), f64::from(t[2]), f64::from(t[3]));
        let cpu = kernel.source((f64::from(t[0]), gradient));
        for c in 0..3 {
            assert!(
                (f64::from(out[c]) - cpu[c]).abs() < 1e-4 * mean_radiance,
                "towards {toward} g {g} T {t:?} channel {c}: GPU {out:?}, CPU {cpu:?}"
            );
        }
    }
}
