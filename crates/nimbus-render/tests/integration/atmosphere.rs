//! The GPU atmosphere against its CPU reference (nimbus_physics::atmosphere):
//! each LUT texel, the aerial-perspective froxels and the lighting inputs.
//! Tolerances cover half-float storage (2⁻¹¹ relative), f32 arithmetic and
//! the GPU's bilinear filtering of the LUTs the later passes read.

use glam::{DMat4, DVec3, DVec4};
use nimbus_physics::atmosphere::under_layer::diffuse_weights;
use nimbus_physics::atmosphere::{
    AERIAL_PERSPECTIVE_SIZE, AtmosphereTables, MULTIPLE_SCATTERING_LUT_SIZE, SKY_VIEW_LUT_SIZE,
    TRANSMITTANCE_LUT_SIZE, aerial_perspective_distance_m, unit_of_texel,
};
use nimbus_physics::sh;
use nimbus_render::atmosphere::solar_irradiance_top;
use nimbus_render::frame::Camera;
use nimbus_render::headless::{HeadlessRenderer, read_texture};
use nimbus_render::{AdapterPreference, Scene};

struct Fixture {
    scene: Scene,
    luts: [Vec<[f32; 4]>; 4],
    /// The aerial perspective's parts: sun single scattering and the air's
    /// weights for a diffuse field.
    parts: [Vec<[f32; 4]>; 3],
    lighting: Vec<f32>,
    tables: AtmosphereTables,
}

fn fixture() -> Fixture {
    let mut scene = Scene::default();
    scene.camera.position_m = [0.0, 500.0, 0.0];
    scene.camera.yaw_deg = Some(30.0);
    scene.camera.pitch_deg = Some(5.0);
    scene.sun.azimuth_deg = Some(120.0);
    scene.sun.elevation_deg = Some(20.0);
    scene.terrain.resolution = 32;
    let mut h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    h.render_frame(&scene, 64, 36, 0.0).expect("render");
    let read = |t: &wgpu::Texture| -> Vec<[f32; 4]> {
        let bytes = read_texture(&h.gpu, t, 8).expect("read LUT");
        let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
        halves
            .chunks(4)
            .map(|p| [p[0].to_f32(), p[1].to_f32(), p[2].to_f32(), p[3].to_f32()])
            .collect()
    };
    let [t, m, s, a] = h.renderer.atmosphere().textures();
    let luts = [read(t), read(m), read(s), read(a)];
    let parts = h.renderer.atmosphere().aerial_perspective_parts().map(read);
    let lighting_uniform: nimbus_render::atmosphere::LightingUniform = h
        .read_buffer(h.renderer.atmosphere().lighting_buffer())
        .expect("read lighting");
    let lighting: Vec<f32> = bytemuck::cast_slice(&[lighting_uniform]).to_vec();
    let tables = AtmosphereTables::new(&scene.atmosphere);
    Fixture {
        scene,
        luts,
        parts,
        lighting,
        tables,
    }
}

fn assert_close(what: &str, gpu: [f32; 4], cpu: [f64; 3], relative: f64, absolute: f64) {
    for c in 0..3 {
        let (g, e) = (gpu[c] as f64, cpu[c]);
        assert!(
            (g - e).abs() <= relative * e.abs() + absolute,
            "{what}: channel {c}: GPU {g} vs CPU {e}"
        );
    }
}

#[test]
fn gpu_atmosphere_matches_the_cpu_reference() {
    let f = fixture();
    let p = &f.scene.atmosphere;
    let e0 = solar_irradiance_top().map(f64::from);

    // Transmittance: every 8th texel against the exact integral, within 1 %.
    let [tw, th] = TRANSMITTANCE_LUT_SIZE;
    for j in (0..th).step_by(7) {
        for i in (0..tw).step_by(9) {
            let (r, mu) =
                p.transmittance_r_mu_from_unit(unit_of_texel(i, tw), unit_of_texel(j, th));
            let exact = p
                .optical_depth(r, mu, p.distance_to_top(r, mu), 4000)
                .map(|t| (-t).exp());
            assert_close(
                &format!("transmittance ({i}, {j})"),
                f.luts[0][(j * tw + i) as usize],
                exact,
                0.01,
                1e-3,
            );
        }
    }

    // Multiple scattering: every texel against the CPU table, within 2 %.
    let [mw, mh] = MULTIPLE_SCATTERING_LUT_SIZE;
    for k in 0..mw * mh {
        let cpu = f.tables.multiple_scattering.texels[k as usize];
        assert_close(
            &format!("multiple scattering texel {k}"),
            f.luts[1][k as usize],
            cpu,
            0.02,
            1e-6,
        );
    }

    // Sky view: a grid of texels against the CPU integral, within 2 %.
    let r = p.bottom_radius_m + f.scene.camera.position_m[1];
    let mu_s = f.scene.sun.direction()[1];
    let [sw, sh_] = SKY_VIEW_LUT_SIZE;
    for j in (0..sh_).step_by(11) {
        for i in (0..sw).step_by(13) {
            let (zenith, cos_az) =
                p.sky_view_angles_from_unit(r, unit_of_texel(i, sw), unit_of_texel(j, sh_));
            let cpu = f.tables.sky_view_luminance(r, zenith, cos_az, mu_s);
            let cpu = [0, 1, 2].map(|c| cpu[c] * e0[c]);
            assert_close(
                &format!("sky view ({i}, {j})"),
                f.luts[2][(j * sw + i) as usize],
                cpu,
                0.02,
                1e-4,
            );
        }
    }

    // Aerial perspective: froxels along the view, against the CPU march, within 2 %.
    let [aw, ah, ad] = AERIAL_PERSPECTIVE_SIZE;
    let camera = Camera::from_settings(&f.scene.camera, 64, 36);
    let world_from_clip: DMat4 = camera.clip_from_world().inverse();
    let sun = f.scene.sun.direction();
    for (i, j) in [(0, 0), (16, 16), (31, 5), (7, 30)] {
        let (u, v) = ((i as f64 + 0.5) / aw as f64, (j as f64 + 0.5) / ah as f64);
        let near = world_from_clip * DVec4::new(u * 2.0 - 1.0, 1.0 - v * 2.0, 1.0, 1.0);
        let view: DVec3 = (near.truncate() / near.w - camera.position_m).normalize();
        for k in [0, 5, 15, 31] {
            let w = (k as f64 + 0.5) / ad as f64;
            let path = f.tables.air_path(
                r,
                view.to_array(),
                sun,
                aerial_perspective_distance_m(w),
                16,
            );
            let (l, t) = (path.luminance, path.transmittance);
            let texel = ((k * ah + j) * aw + i) as usize;
            let gpu = f.luts[3][texel];
            let cpu = [0, 1, 2].map(|c| l[c] * e0[c]);
            assert_close(
                &format!("aerial perspective ({i}, {j}, {k})"),
                gpu,
                cpu,
                0.02,
                1e-4,
            );
            // Its parts: the sun's single scattering (a radiance) and the
            // air's weights for a diffuse field (dimensionless), packed as
            // (sun, W.r), (A₀, W.g), (A₁, W.b).
            let weights = diffuse_weights(&path, p.aerosol_asymmetry, view.y);
            let sun_single = [0, 1, 2].map(|c| path.sun_single[c] * e0[c]);
            for (part, (name, cpu)) in [
                ("sun single scattering", sun_single),
                ("weight of light from above", weights.above),
                ("weight by the vertical cosine", weights.above_cosine),
            ]
            .into_iter()
            .enumerate()
            {
                let gpu = f.parts[part][texel];
                assert_close(
                    &format!("aerial perspective's {name} ({i}, {j}, {k})"),
                    gpu,
                    cpu,
                    0.02,
                    1e-6,
                );
                let total = weights.total[part];
                assert!(
                    (f64::from(gpu[3]) - total).abs() <= 0.02 * total + 1e-6,
                    "aerial perspective's total weight ({i}, {j}, {k}), channel {part}: GPU {} vs CPU {total}",
                    gpu[3]
                );
            }
            let mean_t = (t[0] + t[1] + t[2]) / 3.0;
            assert!(
                (gpu[3] as f64 - mean_t).abs() < 2e-3,
                "froxel ({i}, {j}, {k}) transmittance {} vs {mean_t}",
                gpu[3]
            );
        }
    }
}

#[test]
fn gpu_lighting_inputs_match_the_cpu_reference() {
    let f = fixture();
    // The CPU reference is the library's own (what embedders read).
    let cpu = nimbus_render::atmosphere::sky_lighting(&f.scene);
    assert_eq!(cpu.sun_direction, f.scene.sun.direction());
    let (sky_up, sun_e, ground, coefficients) = (
        cpu.sky_irradiance_up,
        cpu.sun_irradiance,
        cpu.ground_radiance,
        cpu.sh,
    );

    let gpu = |k: usize| {
        [
            f.lighting[4 * k],
            f.lighting[4 * k + 1],
            f.lighting[4 * k + 2],
            0.0,
        ]
    };
    assert_close("C_sky", gpu(9), sky_up, 0.03, 1e-3);
    // C_sky by the band the light arrives from (after sh, the four
    // irradiances, the exposure and clouds_sh: vec4 22–25).
    for (band, cpu_band) in cpu.sky_irradiance_bands.iter().enumerate() {
        assert_close(
            &format!("C_sky band {band}"),
            gpu(22 + band),
            *cpu_band,
            0.03,
            1e-3,
        );
    }
    assert_close("C_sun", gpu(10), sun_e, 0.01, 1e-3);
    assert_close("C_ground", gpu(11), ground, 0.03, 1e-3);
    // SH: compare the irradiance they give on a few normals (the quantity the passes use).
    let scale = sh::irradiance(&coefficients, [0.0, 1.0, 0.0])[2];
    let gpu_coefficients: [[f64; 3]; 9] =
        std::array::from_fn(|k| [0, 1, 2].map(|c| f.lighting[4 * k + c] as f64));
    for n in [
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.6, 0.8],
    ] {
        let (g, c) = (
            sh::irradiance(&gpu_coefficients, n),
            sh::irradiance(&coefficients, n),
        );
        for k in 0..3 {
            assert!(
                (g[k] - c[k]).abs() < 0.03 * scale,
                "SH irradiance on {n:?}, channel {k}: GPU {} vs CPU {}",
                g[k],
                c[k]
            );
        }
    }
}

/// The environment the clouds see (`Lighting::clouds_sh`), taken at their
/// mean centre 2 km up, with and without the air below them, against the
/// library's CPU twin ([`nimbus_render::atmosphere::clouds_environment`]):
/// the irradiance the SH give on a few normals, downward ones included
/// (the ground within the terrain's square, the sea and the sun's glint
/// beyond it, at a low sun over a small terrain).
#[test]
fn gpu_clouds_environment_matches_the_cpu_reference() {
    for aerial in [true, false] {
        let mut scene = Scene::from_toml_str(
            r#"
[camera]
position_m = [0.0, 300.0, 5200.0]
look_at_m = [0.0, 1850.0, 0.0]

[sun]
azimuth_deg = 200.0
elevation_deg = 12.0

[terrain]
extent_m = 8000.0
resolution = 32

[cumulus]
[[cumulus.clouds]]
position_m = [2500.0, 1500.0, -1000.0]
"#,
            "clouds-environment.toml",
        )
        .expect("scene");
        scene.camera.aerial_perspective = aerial;
        let mut h = HeadlessRenderer::new(AdapterPreference::Auto)
            .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
        h.render_frame(&scene, 64, 36, 0.0).expect("render");
        let ground = *h.renderer.atmosphere().clouds_ground().expect("prepared");
        // The observer is the cloud's centre: above its base, over it.
        let [x, y, z] = ground.observer_m;
        assert!(
            (1600.0..4000.0).contains(&y)
                && (x - 2500.0).abs() < 500.0
                && (z + 1000.0).abs() < 500.0,
            "observer {:?}",
            ground.observer_m
        );
        assert_eq!(ground.below.through_air, aerial);
        let lighting: nimbus_render::atmosphere::LightingUniform = h
            .read_buffer(h.renderer.atmosphere().lighting_buffer())
            .expect("read lighting");
        let gpu: [[f64; 3]; 9] =
            std::array::from_fn(|k| [0, 1, 2].map(|c| f64::from(lighting.clouds_sh[k][c])));
        let cpu = nimbus_render::atmosphere::clouds_environment(&scene, &ground);
        let scale = sh::irradiance(&cpu, [0.0, 1.0, 0.0])[2];
        for n in [
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, -0.6, 0.8],
            [-0.8, -0.6, 0.0],
        ] {
            let (g, c) = (sh::irradiance(&gpu, n), sh::irradiance(&cpu, n));
            for k in 0..3 {
                assert!(
                    (g[k] - c[k]).abs() < 0.03 * scale.max(c[k]),
                    "aerial {aerial}: SH irradiance on {n:?}, channel {k}: GPU {} vs CPU {}",
                    g[k],
                    c[k]
                );
            }
        }
    }
}

/// `camera.aerial_perspective = false` leaves the air out of everything in
/// front of the sky and nothing else: the aerial-perspective volume holds no
/// in-scattered light and a transmittance of 1, the sky's pixels are the
/// same, and distant terrain loses its haze (bluer and brighter with it at
/// a high sun over green land is the test's scene).
#[test]
fn without_aerial_perspective_only_what_is_in_front_of_the_sky_changes() {
    let mut scene = Scene::default();
    scene.camera.position_m = [0.0, 600.0, 0.0];
    scene.camera.yaw_deg = Some(30.0);
    scene.camera.pitch_deg = Some(-2.0);
    scene.camera.auto_exposure = false;
    scene.sun.azimuth_deg = Some(200.0);
    scene.sun.elevation_deg = Some(50.0);
    scene.terrain.resolution = 64;
    scene.stratus = None;
    scene.cumulus = None;
    scene.rain = None;
    let mut h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let with_air = h.render_hdr(&scene, 64, 36, 0.0).expect("render");
    scene.camera.aerial_perspective = false;
    let without_air = h.render_hdr(&scene, 64, 36, 0.0).expect("render");
    let bytes =
        read_texture(&h.gpu, h.renderer.atmosphere().textures()[3], 8).expect("read volume");
    let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
    for froxel in halves.chunks(4) {
        let [r, g, b, t] = [0, 1, 2, 3].map(|k| froxel[k].to_f32());
        assert!(
            r == 0.0 && g == 0.0 && b == 0.0 && t == 1.0,
            "froxel {r} {g} {b} {t}"
        );
    }
    // The top rows are sky, the bottom rows terrain (the camera looks 2° down, the
    // horizon near row 17).
    let row = |image: &[[f32; 3]], y: usize| image[y * 64..(y + 1) * 64].to_vec();
    for (a, b) in row(&with_air.pixels, 0)
        .iter()
        .zip(row(&without_air.pixels, 0))
    {
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() <= 1e-4 * a[c].abs().max(1.0),
                "sky {a:?} {b:?}"
            );
        }
    }
    // Rows 20–24: terrain 4–14 km away.
    let mean_blue_over_red = |image: &[[f32; 3]]| {
        let ground: Vec<[f32; 3]> = (20..25).flat_map(|y| row(image, y)).collect();
        let (r, b) = ground
            .iter()
            .fold((0.0, 0.0), |(r, b), p| (r + p[0], b + p[2]));
        b / r
    };
    let (hazy, clear) = (
        mean_blue_over_red(&with_air.pixels),
        mean_blue_over_red(&without_air.pixels),
    );
    assert!(
        hazy > 1.05 * clear,
        "terrain blue/red with air {hazy}, without {clear}"
    );
}

/// Under a thick overcast the air is lit by the layer's diffuse light, not
/// by the hidden sun: the haze over flat ground looks the same with the
/// sun ahead of the camera or behind it (before the air under the layer
/// was lit by the layer, the sun ahead showed its aerosol aureole through
/// 900 m of cloud, and the ground 3.7 × brighter).
#[test]
fn under_an_overcast_the_air_shows_no_aureole() {
    let mut h = HeadlessRenderer::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let ground = |h: &mut HeadlessRenderer, sun_azimuth_deg: f64| {
        let text = format!(
            r#"
[camera]
position_m = [0.0, 300.0, 4000.0]
yaw_deg = 0.0
pitch_deg = -3.0
fov_deg = 50.0

[sun]
azimuth_deg = {sun_azimuth_deg}
elevation_deg = 10.0

[stratus]
base_m = 1500.0
thickness_m = 900.0
coverage = 1.0

[terrain]
height_scale_m = 0.0
water_level_m = -100.0
"#
        );
        let scene = Scene::from_toml_str(&text, "overcast.toml").expect("scene");
        let image = h.render_hdr(&scene, 64, 36, 0.0).expect("render");
        // Rows 22–35 are ground from about 700 m to 6 km away.
        let rows = &image.pixels[22 * 64..];
        rows.iter()
            .map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64)
            .sum::<f64>()
            / rows.len() as f64
    };
    let ahead = ground(&mut h, 0.0);
    let behind = ground(&mut h, 180.0);
    assert!(
        (ahead / behind - 1.0).abs() < 0.07,
        "ground and air with the sun ahead {ahead}, behind {behind}"
    );
}
