//! The stratus pass's GPU work against its CPU references: the thickness
//! window against nimbus_physics::cloud_layer, the radiosity inputs against
//! the 1-D slab model, and the frame's radiosity result against
//! nimbus_physics::radiosity::iterate run on the inputs the GPU computed.

use nimbus_physics::cloud_layer::CloudLayerField;
use nimbus_physics::radiosity::{PlaneField, RadiosityInputs, iterate};
use nimbus_physics::transport::stratus::{OneDimensionalTable, one_dimensional};
use nimbus_render::headless::{HeadlessRenderer, read_texture};
use nimbus_render::{AdapterPreference, Scene};

fn headless() -> HeadlessRenderer {
    HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

fn scene(iterations: u32) -> Scene {
    Scene::from_toml_str(
        &format!(
            "[camera]\nposition_m = [1200.0, 300.0, -800.0]\npitch_deg = 20.0\n\
             [sun]\nazimuth_deg = 150.0\nelevation_deg = 50.0\n\
             [terrain]\nresolution = 64\n\
             [stratus]\nbase_m = 1600.0\nthickness_m = 300.0\ncoverage = 0.6\n\
             resolution = 128\nextent_m = 20000.0\nradiosity_iterations = {iterations}\n\
             [wind]\nspeed_m_s = 12.0\nfrom_deg = 300.0\n"
        ),
        "stratus-test.toml",
    )
    .expect("scene")
}

fn field_of(scene: &Scene) -> CloudLayerField {
    let s = scene.stratus.as_ref().expect("stratus");
    CloudLayerField {
        max_thickness_m: s.thickness_m,
        coverage: s.coverage,
        feature_size_m: s.feature_size_m,
        octaves: s.detail,
        seed: s.seed,
        wind_velocity_m_s: scene.wind.as_ref().expect("wind").velocity_xz_m_s(),
        evolution_time_s: s.evolution_time_s,
    }
}

fn read_vec4s(h: &HeadlessRenderer, buffer: &wgpu::Buffer, texels: usize) -> Vec<[f32; 4]> {
    h.read_buffer_elements(buffer, texels).expect("read back")
}

/// The thickness window the GPU fills each frame equals the CPU field at
/// the texel centres, at a time when the wind has moved the layer.
#[test]
fn gpu_thickness_window_matches_the_cpu_field() {
    let mut h = headless();
    let scene = scene(3);
    let time_s = 137.5;
    h.render_frame(&scene, 32, 18, time_s).expect("frame");
    let stratus = h.renderer.stratus();
    let uniform = *stratus.uniform();
    let texture = stratus.thickness_texture().expect("texture");
    let raw = read_texture(&h.gpu, texture, 4).expect("read");
    let gpu: &[f32] = bytemuck::cast_slice(&raw);
    let field = field_of(&scene);
    let n = uniform.flags[3] as usize;
    let texel = uniform.window[1] as f64 / n as f64;
    let (mut worst, mut covered) = (0.0f64, 0);
    for j in 0..n {
        for i in 0..n {
            let x = uniform.window[2] as f64 + (i as f64 + 0.5) * texel;
            let z = uniform.window[3] as f64 + (j as f64 + 0.5) * texel;
            let cpu = field.thickness_m(x, z, time_s as f64);
            worst = worst.max((gpu[j * n + i] as f64 - cpu).abs());
            covered += usize::from(cpu > 0.0);
        }
    }
    assert!(worst < 0.05, "largest |GPU − CPU| = {worst} m");
    // The window is neither empty nor full, so the comparison means something.
    assert!(
        covered > n * n / 4 && covered < n * n,
        "{covered} texels covered"
    );
}

/// The radiosity inputs computed on the GPU (ρ_C = R_ms of the texel's
/// mean thickness) follow the CPU 1-D model, and R_G, R_C after the
/// iterations equal the CPU iteration of those same inputs within 1 %.
#[test]
fn gpu_stratus_radiosity_matches_the_cpu_reference() {
    let mut h = headless();
    let time_s = 20.0;
    // With no iteration the inputs survive the frame: ρ_C, S_G^d and level 0
    // of the cloud's pyramid (S_C) are only read.
    let inputs_scene = scene(0);
    h.render_frame(&inputs_scene, 32, 18, time_s)
        .expect("frame");
    let uniform = *h.renderer.stratus().uniform();
    let radiosity = h.renderer.stratus().radiosity().expect("radiosity");
    let size = radiosity.size() as usize;
    let texels = size * size;
    let buffers = radiosity.input_buffers();
    let ground_reflectance = read_vec4s(&h, buffers.ground_reflectance, texels);
    let cloud_reflectance = read_vec4s(&h, buffers.cloud_reflectance, texels);
    let ground_direct = read_vec4s(&h, buffers.ground_extra, texels);
    let cloud_source = read_vec4s(&h, buffers.cloud_emitted, texels);

    // ρ_C against the CPU model.
    let field = field_of(&inputs_scene);
    let sun_zenith_deg = 40.0;
    let table = OneDimensionalTable::bouthors_2006();
    let params = table.at(sun_zenith_deg);
    let texel_m = uniform.radiosity[2] as f64;
    let mut worst_rho: f64 = 0.0;
    for j in 0..size {
        for i in 0..size {
            let x = uniform.radiosity[0] as f64 + (i as f64 + 0.5) * texel_m;
            let z = uniform.radiosity[1] as f64 + (j as f64 + 0.5) * texel_m;
            let q = 0.25 * texel_m;
            let h_mean = [(-q, -q), (q, -q), (-q, q), (q, q)]
                .iter()
                .map(|(dx, dz)| field.thickness_m(x + dx, z + dz, time_s as f64))
                .sum::<f64>()
                / 4.0;
            let r_ms = 1.0 - one_dimensional::t_ms(&params, table.beta, h_mean);
            worst_rho = worst_rho.max((cloud_reflectance[j * size + i][0] as f64 - r_ms).abs());
        }
    }
    assert!(worst_rho < 2e-3, "largest |ρ_C GPU − CPU| = {worst_rho}");

    // The iteration.
    let iterations = 3;
    h.render_frame(&scene(iterations), 32, 18, time_s)
        .expect("frame");
    let radiosity = h.renderer.stratus().radiosity().expect("radiosity");
    let ground_received = read_vec4s(&h, radiosity.input_buffers().ground_received, texels);
    let cloud_received = read_vec4s(&h, radiosity.input_buffers().cloud_received, texels);
    let plane = |v: &[[f32; 4]]| PlaneField {
        size,
        texels: v
            .iter()
            .map(|t| [t[0] as f64, t[1] as f64, t[2] as f64])
            .collect(),
    };
    let cpu = iterate(&RadiosityInputs {
        ground_reflectance: plane(&ground_reflectance),
        cloud_reflectance: plane(&cloud_reflectance),
        cloud_source: plane(&cloud_source),
        ground_direct: plane(&ground_direct),
        ground_sky: PlaneField::uniform(size, [0.0; 3]),
        iterations: iterations as usize,
    });
    let largest = cpu
        .ground_received
        .texels
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(*v));
    assert!(largest > 0.0);
    let mut worst: f64 = 0.0;
    for (gpu, cpu) in [
        (&ground_received, &cpu.ground_received),
        (&cloud_received, &cpu.cloud_received),
    ] {
        for (g, c) in gpu.iter().zip(&cpu.texels) {
            for k in 0..3 {
                worst = worst.max((g[k] as f64 - c[k]).abs() / largest);
            }
        }
    }
    assert!(worst < 0.01, "largest relative difference {worst}");
}
