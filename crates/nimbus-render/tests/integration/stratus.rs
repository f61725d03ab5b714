//! The stratus pass's GPU work against its CPU references: the thickness
//! window against nimbus_physics::cloud_layer, the radiosity inputs against
//! the 1-D slab model, and the frame's radiosity result against
//! nimbus_physics::radiosity::iterate run on the inputs the GPU computed.

use crate::common;

use nimbus_physics::cloud_layer::CloudLayerField;
use nimbus_physics::radiosity::{PlaneField, RadiosityInputs, iterate};
use nimbus_physics::transport::stratus::{OneDimensionalTable, one_dimensional};
use nimbus_render::headless::{HeadlessRenderer, read_texture};
use nimbus_render::stratus::StratusUniform;
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

/// A test kernel's source: the drawing libraries and the stratus ones (the
/// layer's lookups in WGSL) followed by `kernel`.
fn lookup_kernel_source(kernel: &str) -> String {
    let mut files = nimbus_render::shader::DRAWING_LIBRARIES.to_vec();
    files.extend(nimbus_render::stratus::DRAWING_LIBRARIES);
    nimbus_render::shader::compose(&files) + kernel
}

/// The frame's cloud-lighting group (the layer's uniform and tables) as a
/// test kernel's group 3, where the stratus libraries read it.
fn cloud_lighting_group(h: &HeadlessRenderer) -> common::ExtraGroup<'_> {
    common::ExtraGroup {
        index: 3,
        layout: h.renderer.frame_resources().cloud_lighting.layout(),
        group: h.renderer.frame_resources().cloud_lighting.bind_group(),
    }
}

fn read_vec4s(h: &HeadlessRenderer, buffer: &wgpu::Buffer, texels: usize) -> Vec<[f32; 4]> {
    h.read_buffer_elements(buffer, texels).expect("read back")
}

/// The layer's uniform and its thickness window (m, row-major) as the last
/// frame left them.
fn thickness_window(h: &HeadlessRenderer) -> (StratusUniform, Vec<f32>) {
    let stratus = h.renderer.stratus();
    let texture = stratus.thickness_texture().expect("texture");
    let raw = read_texture(&h.gpu, texture, 4).expect("read");
    (*stratus.uniform(), bytemuck::cast_slice(&raw).to_vec())
}

/// The thickness window the GPU fills each frame equals the CPU field at
/// the texel centres, at a time when the wind has moved the layer.
#[test]
fn gpu_thickness_window_matches_the_cpu_field() {
    let mut h = headless();
    let scene = scene(3);
    let time_s = 137.5;
    h.render_frame(&scene, 32, 18, time_s).expect("frame");
    let (uniform, gpu) = thickness_window(&h);
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

/// The radiosity inputs computed on the GPU (ρ_C the mean of R_ms over the
/// texel's 4 × 4 columns) follow the CPU 1-D model, and R_G, R_C after the
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
            // The columns at the centres of a 4 × 4 split of the texel
            // (compute.wgsl's RADIOSITY_TEXEL_SAMPLES).
            let r_ms = (0..16)
                .map(|k| {
                    let dx = ((k % 4) as f64 + 0.5) / 4.0 - 0.5;
                    let dz = ((k / 4) as f64 + 0.5) / 4.0 - 0.5;
                    let h = field.thickness_m(x + dx * texel_m, z + dz * texel_m, time_s as f64);
                    1.0 - one_dimensional::t_ms(&params, table.beta, h)
                })
                .sum::<f64>()
                / 16.0;
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

/// A test kernel around `stratus_view_path_m` and the other marches: per
/// ray (xyz: start, w: thickness offset; xyz: direction, w: range) the view
/// path, the cloud along the ray, the first entry and the surface's normal
/// at the start.
const VIEW_PATH_KERNEL: &str = r"
struct ViewPathRay {
    start: vec4<f32>,
    direction: vec4<f32>,
}
@group(0) @binding(1) var<storage, read> view_path_rays: array<ViewPathRay>;
@group(0) @binding(2) var<storage, read_write> view_path_lengths: array<f32>;

@compute @workgroup_size(64)
fn view_path_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&view_path_rays)) {
        return;
    }
    let ray = view_path_rays[id.x];
    view_path_lengths[6u * id.x] = stratus_view_path_m(ray.start.xyz, ray.direction.xyz, ray.start.w, ray.direction.w);
    view_path_lengths[6u * id.x + 1u] = stratus_cloud_along_ray_m(ray.start.xyz, ray.direction.xyz, ray.start.w, ray.direction.w);
    view_path_lengths[6u * id.x + 2u] = stratus_view_entry_m(ray.start.xyz, ray.direction.xyz, ray.start.w, ray.direction.w);
    let normal = stratus_surface_normal(ray.start.xyz);
    view_path_lengths[6u * id.x + 3u] = normal.x;
    view_path_lengths[6u * id.x + 4u] = normal.y;
    view_path_lengths[6u * id.x + 5u] = normal.z;
}
";

/// The layer shader's marches against their CPU twins marching the same
/// window: the view path (`stratus_view_path_m`,
/// `cloud_layer::path_inside_layer_m`) for rays entering the tops, the
/// bases and the cells' sides, and the cloud along the sun's ray
/// (`stratus_cloud_along_ray_m`, `cloud_layer::cloud_along_ray_m`) for rays
/// leaving the tops towards a low sun, the first entry of a level
/// camera's rays (`stratus_view_entry_m`, `cloud_layer::first_entry_m`,
/// with the cells thickened and thinned by an offset), and the surface's
/// normal at the rays' starts (`stratus_surface_normal`,
/// `cloud_layer::surface_normal`).
#[test]
fn gpu_layer_marches_match_the_cpu_marches() {
    use nimbus_physics::cloud_layer::{
        cloud_along_ray_m, first_entry_m, path_inside_layer_m, surface_normal,
    };

    let mut h = headless();
    let scene = scene(0);
    let time_s = 42.0;
    h.render_frame(&scene, 32, 18, time_s).expect("frame");
    let (uniform, window) = thickness_window(&h);
    let n = uniform.flags[3] as usize;
    let side_m = uniform.window[1] as f64;
    let corner = [uniform.window[2] as f64, uniform.window[3] as f64];
    let mid_m = uniform.window[0] as f64;
    let field = field_of(&scene);
    // stratus_thickness_at on the CPU: bilinear between texel centres
    // inside the window, the field beyond.
    let thickness = |x: f64, z: f64| {
        let p = [
            (x - corner[0]) / side_m * n as f64 - 0.5,
            (z - corner[1]) / side_m * n as f64 - 0.5,
        ];
        if p.iter().any(|&c| c < 0.0 || c > (n - 1) as f64) {
            return field.thickness_m(x, z, time_s as f64);
        }
        let (i, j) = (p[0].floor() as usize, p[1].floor() as usize);
        let (fx, fz) = (p[0] - i as f64, p[1] - j as f64);
        let (i1, j1) = ((i + 1).min(n - 1), (j + 1).min(n - 1));
        let at = |i: usize, j: usize| window[j * n + i] as f64;
        let top = at(i, j) * (1.0 - fx) + at(i1, j) * fx;
        let bottom = at(i, j1) * (1.0 - fx) + at(i1, j1) * fx;
        top * (1.0 - fz) + bottom * fz
    };

    // Rays from covered texels of the window's inner half: down from the
    // top, up from the base at several slants, and horizontally from the
    // mid-plane at the edge of a cell (where the slab model sees nothing).
    let mut rays: Vec<[[f32; 4]; 2]> = Vec::new();
    let step = n / 24;
    for j in (n / 4..3 * n / 4).step_by(step) {
        for i in (n / 4..3 * n / 4).step_by(step) {
            let x = corner[0] + (i as f64 + 0.5) * side_m / n as f64;
            let z = corner[1] + (j as f64 + 0.5) * side_m / n as f64;
            let hc = thickness(x, z);
            if hc <= 1.0 {
                // A side entry: horizontal, towards +x.
                rays.push([
                    [x as f32, mid_m as f32, z as f32, 0.0],
                    [1.0, 0.0, 0.0, 4000.0],
                ]);
                continue;
            }
            for (k, mu) in [0.95f64, 0.5, 0.15].iter().enumerate() {
                let sin = (1.0 - mu * mu).sqrt();
                let azimuth = 0.7 + k as f64 * 2.1;
                let (dx, dz) = (sin * azimuth.cos(), sin * azimuth.sin());
                let range = (scene.stratus.as_ref().expect("stratus").thickness_m + 5.0) / mu;
                let offset = 3.0 * k as f32 - 3.0;
                rays.push([
                    [x as f32, (mid_m + 0.5 * hc) as f32, z as f32, offset],
                    [dx as f32, -*mu as f32, dz as f32, range as f32],
                ]);
                rays.push([
                    [x as f32, (mid_m - 0.5 * hc) as f32, z as f32, 0.0],
                    [dz as f32, *mu as f32, dx as f32, range as f32],
                ]);
            }
            // Towards a sun 5° high from the top, over the distance in
            // which it climbs out of the layer's height range.
            let mu = 5f64.to_radians().sin();
            let cos = (1.0 - mu * mu).sqrt();
            let thickest = scene.stratus.as_ref().expect("stratus").thickness_m;
            rays.push([
                [x as f32, (mid_m + 0.5 * hc) as f32, z as f32, 0.0],
                [
                    cos as f32,
                    mu as f32,
                    0.0,
                    (0.5 * (thickest - hc) / mu) as f32,
                ],
            ]);
        }
    }
    assert!(rays.len() > 300, "{} rays", rays.len());

    let source = lookup_kernel_source(VIEW_PATH_KERNEL);
    // One ray (two vec4) in, six f32 out: the view path, the cloud along
    // the ray, the first entry, the surface's normal.
    let marches_on_gpu = |rays: &[[[f32; 4]; 2]]| -> Vec<f32> {
        common::run_kernel(
            &h,
            &common::Kernel {
                label: "layer marches test",
                source: &source,
                entry: "view_path_kernel",
                input: bytemuck::cast_slice(rays),
                input_stride: 32,
                count: rays.len(),
                outputs_per_item: 6,
                extra: &[cloud_lighting_group(&h)],
            },
        )
    };
    let gpu = marches_on_gpu(&rays);

    let (mut worst, mut worst_along, mut side_entries_through_cloud, mut shaded_by_others) =
        (0.0f64, 0.0f64, 0, 0);
    let (mut worst_normal, mut leaning_faces) = (0.0f64, 0);
    for (ray, gpu_lengths) in rays.iter().zip(gpu.chunks(6)) {
        let [start, direction] = *ray;
        let start_m = [start[0] as f64, start[1] as f64, start[2] as f64];
        let direction_unit = [
            direction[0] as f64,
            direction[1] as f64,
            direction[2] as f64,
        ];
        let (offset_m, range_m) = (start[3] as f64, direction[3] as f64);
        let cpu_length =
            path_inside_layer_m(thickness, offset_m, mid_m, start_m, direction_unit, range_m);
        let cpu_along =
            cloud_along_ray_m(thickness, offset_m, mid_m, start_m, direction_unit, range_m);
        // f32 against f64: a bisection may fall on the other side of a
        // crossing only within the last refinement of a step.
        let tolerance = 0.5 + 2e-3 * cpu_length;
        worst = worst.max((gpu_lengths[0] as f64 - cpu_length).abs() - tolerance);
        // No bisection in the sum: only rounding of the step ends.
        worst_along =
            worst_along.max((gpu_lengths[1] as f64 - cpu_along).abs() - (0.5 + 2e-3 * cpu_along));
        if direction[1] == 0.0 && cpu_length > 100.0 {
            side_entries_through_cloud += 1;
        }
        if direction[1] > 0.0 && direction[1] < 0.1 && cpu_along > 50.0 {
            shaded_by_others += 1;
        }
        // The surface's normal at the start, over one texel of the window.
        let cpu_normal = surface_normal(thickness, mid_m, start_m, 0.5 * side_m / n as f64);
        for k in 0..3 {
            worst_normal = worst_normal.max((gpu_lengths[3 + k] as f64 - cpu_normal[k]).abs());
        }
        if cpu_normal[1].abs() < 0.95 {
            leaning_faces += 1;
        }
    }
    assert!(
        worst_normal < 1e-3,
        "surface normal: GPU and CPU differ by {worst_normal} in a component"
    );
    assert!(leaning_faces > 5, "{leaning_faces} faces lean by over 18°");
    assert!(
        worst <= 0.0,
        "view path: GPU − CPU exceeds the tolerance by {worst} m"
    );

    // A camera level with the layer, 20 m above the mid-plane at the
    // window's centre, looking all round at slants within ±6°: where each
    // ray first enters a cell, the cells thinned, kept or thickened by 10 m.
    let centre = [corner[0] + 0.5 * side_m, mid_m, corner[1] + 0.5 * side_m];
    let level_rays: Vec<[[f32; 4]; 2]> = (0..360)
        .map(|k| {
            let azimuth = (k as f64).to_radians();
            let slant = (6.0 * ((k % 13) as f64 / 6.0 - 1.0)).to_radians();
            [
                [
                    centre[0] as f32,
                    (centre[1] + 20.0) as f32,
                    centre[2] as f32,
                    (10.0 * ((k % 3) as f64 - 1.0)) as f32,
                ],
                [
                    (slant.cos() * azimuth.cos()) as f32,
                    slant.sin() as f32,
                    (slant.cos() * azimuth.sin()) as f32,
                    (0.5 * side_m) as f32,
                ],
            ]
        })
        .collect();
    let gpu = marches_on_gpu(&level_rays);
    let (mut entries, mut misses, mut disagreements) = (0, 0, 0);
    for (ray, gpu_lengths) in level_rays.iter().zip(gpu.chunks(6)) {
        let [start, direction] = *ray;
        let cpu = first_entry_m(
            thickness,
            start[3] as f64,
            mid_m,
            [start[0] as f64, start[1] as f64, start[2] as f64],
            [
                direction[0] as f64,
                direction[1] as f64,
                direction[2] as f64,
            ],
            direction[3] as f64,
        );
        let gpu_entry = gpu_lengths[2] as f64;
        match cpu {
            Some(s) if (gpu_entry - s).abs() <= 0.5 + 1e-3 * s => entries += 1,
            None if gpu_entry < 0.0 => misses += 1,
            // f32 against f64 can flip a sample lying on the surface.
            _ => disagreements += 1,
        }
    }
    assert!(
        disagreements <= 3 && entries > 100,
        "level entries: {entries} agree, {misses} miss on both, {disagreements} disagree"
    );
    assert!(
        worst_along <= 0.0,
        "cloud along the sun ray: GPU − CPU exceeds the tolerance by {worst_along} m"
    );
    // Some tops are shaded by other cells under the low sun.
    assert!(
        shaded_by_others > 5,
        "{shaded_by_others} tops shaded by other cells"
    );
    // Some horizontal rays from cell edges cross real cloud.
    assert!(
        side_entries_through_cloud > 5,
        "{side_entries_through_cloud} side entries"
    );
}

/// A test kernel around `stratus_reflected_shape`: one shape per query
/// (sun zenith, view zenith, relative azimuth, degrees; w unused).
const REFLECTED_SHAPE_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> shape_queries: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> shape_values: array<f32>;

@compute @workgroup_size(64)
fn reflected_shape_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&shape_queries)) {
        return;
    }
    let q = shape_queries[id.x];
    shape_values[id.x] = stratus_reflected_shape(q.x, q.y, q.z);
}
";

/// The layer shader's shape of the reflected orders 3+ (the table uploaded
/// after the phase tables, interpolated in WGSL) against its CPU twin
/// `nimbus_physics::transport::reflected_exit::reflected_shape`, at nodes,
/// between them, beyond the clamped zenith range and at azimuths to fold.
#[test]
fn gpu_reflected_shape_matches_the_cpu_table() {
    use nimbus_physics::transport::reflected_exit::reflected_shape;

    let mut h = headless();
    h.render_frame(&scene(0), 32, 18, 0.0).expect("frame");
    let mut queries: Vec<[f32; 4]> = Vec::new();
    for sun in [0.0f32, 5.5, 30.0, 44.0, 61.3, 77.0, 85.0, 89.5] {
        for view in [0.0f32, 11.0, 37.2, 66.0, 80.0, 88.0, 95.0] {
            for azimuth in [-30.0f32, 0.0, 15.0, 90.0, 171.0, 180.0, 250.0] {
                queries.push([sun, view, azimuth, 0.0]);
            }
        }
    }
    let source = lookup_kernel_source(REFLECTED_SHAPE_KERNEL);
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "reflected shape test",
            source: &source,
            entry: "reflected_shape_kernel",
            input: bytemuck::cast_slice(&queries),
            input_stride: 16,
            count: queries.len(),
            outputs_per_item: 1,
            extra: &[cloud_lighting_group(&h)],
        },
    );
    let mut worst = 0.0f64;
    for (q, g) in queries.iter().zip(&gpu) {
        let cpu = reflected_shape(f64::from(q[0]), f64::from(q[1]), f64::from(q[2]));
        let difference = (f64::from(*g) - cpu).abs();
        assert!(
            difference < 1e-4 * cpu.max(1.0),
            "{q:?}: GPU {g}, CPU {cpu}"
        );
        worst = worst.max(difference);
    }
    assert!(worst < 1e-4, "largest difference {worst}");
}

/// A test kernel around `stratus_interior_source`: one value per query
/// (sun zenith °, depth, cosine of travel, relative azimuth °; slab
/// thickness).
const INTERIOR_SOURCE_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> source_queries: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> source_values: array<f32>;

@compute @workgroup_size(64)
fn interior_source_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (2u * id.x + 1u >= arrayLength(&source_queries)) {
        return;
    }
    let q = source_queries[2u * id.x];
    let thickness = source_queries[2u * id.x + 1u].x;
    source_values[id.x] = stratus_interior_source(thickness, q.x, q.y, q.z, q.w);
}
";

/// The in-layer march's traced source near a lit face (the table uploaded
/// after the reflected shape, interpolated in WGSL) against its CPU twin
/// `nimbus_physics::transport::interior_source::interior_source`, at
/// nodes, between them, beyond the clamped ranges and at azimuths to fold.
#[test]
fn gpu_interior_source_matches_the_cpu_table() {
    use nimbus_physics::transport::interior_source::interior_source;

    let mut h = headless();
    h.render_frame(&scene(0), 32, 18, 0.0).expect("frame");
    let mut queries: Vec<[[f32; 4]; 2]> = Vec::new();
    for thickness in [0.2f32, 0.5, 0.9, 1.5, 2.6, 12.0, 30.0] {
        for sun in [0.0f32, 22.0, 47.3, 89.5] {
            for depth in [0.0f32, 0.1, 0.42, 1.25, 2.7, 4.5, 9.0] {
                for cosine in [-1.0f32, -0.45, 0.2, 0.73, 1.0] {
                    for azimuth in [-20.0f32, 7.5, 90.0, 300.0] {
                        queries.push([[sun, depth, cosine, azimuth], [thickness, 0.0, 0.0, 0.0]]);
                    }
                }
            }
        }
    }
    let source = lookup_kernel_source(INTERIOR_SOURCE_KERNEL);
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "interior source test",
            source: &source,
            entry: "interior_source_kernel",
            input: bytemuck::cast_slice(&queries),
            input_stride: 32,
            count: queries.len(),
            outputs_per_item: 1,
            extra: &[cloud_lighting_group(&h)],
        },
    );
    for ([q, t], g) in queries.iter().zip(&gpu) {
        let cpu = interior_source(
            f64::from(t[0]),
            f64::from(q[0]),
            f64::from(q[1]),
            f64::from(q[2]),
            f64::from(q[3]),
        );
        assert!(
            (f64::from(*g) - cpu).abs() < 1e-4 * cpu.max(0.1),
            "{q:?} in a slab {t:?} thick: GPU {g}, CPU {cpu}"
        );
    }
}

/// A test kernel around `stratus_sky_source`: one value per query (slab
/// thickness, band, depth, cosine of travel).
const SKY_SOURCE_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> sky_queries: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> sky_values: array<f32>;

@compute @workgroup_size(64)
fn sky_source_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&sky_queries)) {
        return;
    }
    let q = sky_queries[id.x];
    sky_values[id.x] = stratus_sky_source(q.x, u32(q.y), q.z, q.w);
}
";

/// The in-layer march's traced sky light near a layer's top (the table
/// uploaded after the sun's interior source, weighted by bands in WGSL)
/// against its CPU twin `nimbus_physics::transport::sky_source::sky_source`,
/// at nodes, between them and beyond the clamped ranges, for every band.
#[test]
fn gpu_sky_source_matches_the_cpu_table() {
    use nimbus_physics::transport::sky_source::{BANDS, sky_source};

    let mut h = headless();
    h.render_frame(&scene(0), 32, 18, 0.0).expect("frame");
    let mut queries: Vec<[f32; 4]> = Vec::new();
    for thickness in [0.2f32, 0.5, 0.9, 1.5, 2.6, 12.0, 30.0] {
        for band in 0..BANDS {
            for depth in [0.0f32, 0.1, 0.42, 1.25, 2.7, 4.5, 9.0] {
                for cosine in [-1.0f32, -0.45, 0.2, 0.73, 1.0] {
                    queries.push([thickness, band as f32, depth, cosine]);
                }
            }
        }
    }
    let source = lookup_kernel_source(SKY_SOURCE_KERNEL);
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "sky source test",
            source: &source,
            entry: "sky_source_kernel",
            input: bytemuck::cast_slice(&queries),
            input_stride: 16,
            count: queries.len(),
            outputs_per_item: 1,
            extra: &[cloud_lighting_group(&h)],
        },
    );
    for (q, g) in queries.iter().zip(&gpu) {
        let cpu = sky_source(
            f64::from(q[0]),
            q[1] as usize,
            f64::from(q[2]),
            f64::from(q[3]),
        );
        assert!(
            (f64::from(*g) - cpu).abs() < 1e-4 * cpu.max(0.1),
            "{q:?}: GPU {g}, CPU {cpu}"
        );
    }
}

const DIFFUSION_KERNEL: &str = r"
@group(0) @binding(1) var<storage, read> diffusion_in: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> diffusion_out: array<f32>;

@compute @workgroup_size(64)
fn diffusion_kernel(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (2u * i + 1u >= arrayLength(&diffusion_in)) {
        return;
    }
    let a = diffusion_in[2u * i];
    let b = diffusion_in[2u * i + 1u];
    let diffuse = in_layer_diffuse(a.x, a.y, vec3<f32>(b.x), vec3<f32>(b.y));
    let diffuse_net_flux = in_layer_diffuse_net_flux(a.y, vec3<f32>(b.x), vec3<f32>(b.y));
    diffusion_out[4u * i] = in_layer_collimated(a.x, a.y, a.z, a.w);
    diffusion_out[4u * i + 1u] = in_layer_collimated_net_flux(a.x, a.y, a.z, a.w);
    diffusion_out[4u * i + 2u] = eddington_source(diffuse, diffuse_net_flux, b.z, b.w).x;
    diffusion_out[4u * i + 3u] = escape_over_eddington(a.z);
}
";

/// The in-layer march's light (in_layer.wgsl) against its CPU twin
/// (`nimbus_physics::transport::diffusion`): the diffuse fluence of a
/// conservative slab lit by a beam and its net flux (the δ-Eddington beam
/// and the similarity one), the P1 source of one lit by diffuse fluxes and
/// the escape function's ratio to P1's exit, over depths, thicknesses, sun
/// cosines, view cosines and asymmetries, within 1e-4 relative (f32 against
/// f64).
#[test]
fn in_layer_diffusion_matches_the_cpu_twin() {
    use nimbus_physics::transport::diffusion::{
        collimated_fluence, collimated_net_flux, diffuse_fluence, diffuse_net_flux,
        eddington_source, escape_over_eddington,
    };
    let h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let mut items: Vec<[[f32; 4]; 2]> = Vec::new();
    for total in [0.05f32, 0.8, 3.0, 12.0, 40.0] {
        for f in [0.0f32, 0.1, 0.5, 0.9, 1.0] {
            for mu0 in [0.05f32, 0.3, 0.7, 1.0] {
                let view_mu = 2.0 * f - 1.0;
                for rate in [1.0f32, 1.85] {
                    let asymmetry = if rate > 1.0 { 0.75 } else { 1.0 };
                    items.push([
                        [f * total, total, mu0, rate],
                        [1.7, 0.4, view_mu, asymmetry],
                    ]);
                }
            }
        }
    }
    let source = nimbus_render::stratus::in_layer_shader_source() + DIFFUSION_KERNEL;
    let gpu: Vec<f32> = common::run_kernel(
        &h,
        &common::Kernel {
            label: "in-layer diffusion test",
            source: &source,
            entry: "diffusion_kernel",
            input: bytemuck::cast_slice(&items),
            input_stride: 32,
            count: items.len(),
            outputs_per_item: 4,
            extra: &[],
        },
    );
    for (item, out) in items.iter().zip(gpu.chunks(4)) {
        let [a, b] = item;
        let (t, total, mu0, rate) = (
            f64::from(a[0]),
            f64::from(a[1]),
            f64::from(a[2]),
            f64::from(a[3]),
        );
        let (top, base, view_mu, asymmetry) = (
            f64::from(b[0]),
            f64::from(b[1]),
            f64::from(b[2]),
            f64::from(b[3]),
        );
        let beam = collimated_fluence(t, total, mu0, rate);
        let beam_flux = collimated_net_flux(t, total, mu0, rate);
        let diffuse = eddington_source(
            diffuse_fluence(t, total, top, base),
            diffuse_net_flux(total, top, base),
            view_mu,
            asymmetry,
        );
        let exit = escape_over_eddington(mu0);
        for (gpu, cpu) in [
            (out[0], beam),
            (out[1], beam_flux),
            (out[2], diffuse),
            (out[3], exit),
        ] {
            assert!(
                (f64::from(gpu) - cpu).abs() <= 1e-4 * cpu.abs().max(1.0),
                "t {t}, T {total}, μ₀ {mu0}, ρ {rate}: GPU {gpu} vs CPU {cpu}"
            );
        }
    }
}
