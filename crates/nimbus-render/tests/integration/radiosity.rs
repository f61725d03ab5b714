//! The GPU radiosity pass against its CPU reference
//! (nimbus_physics::radiosity::iterate) on the reference's analytic cases
//! (uniform planes, a square cloud) and on random fields. The issue asks
//! for 1 %; both do the same operations in the same order, so the
//! difference is f32 rounding.

use nimbus_physics::radiosity::{PlaneField, RadiosityInputs, iterate};
use nimbus_render::radiosity::{RadiosityFields, RadiosityPass};
use nimbus_render::{AdapterPreference, GpuContext};

/// A repeatable pseudo-random field in [lo, hi).
fn random_field(size: usize, seed: u64, lo: f64, hi: f64) -> PlaneField {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        lo + (hi - lo) * (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let texels = (0..size * size).map(|_| [next(), next(), next()]).collect();
    PlaneField { size, texels }
}

/// Largest |GPU − CPU| over R_G and R_C, relative to the largest CPU value.
fn compare(gpu: &GpuContext, inputs: &RadiosityInputs) -> f64 {
    let pass =
        RadiosityPass::new(&gpu.device, inputs.ground_reflectance.size as u32).expect("pass");
    let (ground, cloud) = pass
        .run_and_read(
            gpu,
            &RadiosityFields::from_reference(inputs),
            inputs.iterations as u32,
        )
        .expect("run");
    let cpu = iterate(inputs);
    let mut worst: f64 = 0.0;
    for (gpu_field, cpu_field) in [
        (&ground, &cpu.ground_received),
        (&cloud, &cpu.cloud_received),
    ] {
        let scale = cpu_field
            .texels
            .iter()
            .flat_map(|t| t.iter().copied())
            .fold(1e-12, f64::max);
        for (g, c) in gpu_field.iter().zip(&cpu_field.texels) {
            for k in 0..3 {
                worst = worst.max((g[k] as f64 - c[k]).abs() / scale);
            }
        }
    }
    worst
}

#[test]
fn gpu_radiosity_matches_the_cpu_reference() {
    let gpu = GpuContext::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let uniform = |n: usize, v: f64| PlaneField::uniform(n, [v; 3]);
    let planes = RadiosityInputs {
        ground_reflectance: uniform(16, 0.8),
        cloud_reflectance: uniform(16, 0.7),
        cloud_source: uniform(16, 0.3),
        ground_direct: uniform(16, 1.0),
        ground_sky: uniform(16, 0.2),
        iterations: 3,
    };
    let inside = |c: usize, r: usize| (28..36).contains(&c) && (28..36).contains(&r);
    let square = RadiosityInputs {
        ground_reflectance: uniform(64, 1.0),
        cloud_reflectance: PlaneField::from_fn(64, |c, r| {
            [if inside(c, r) { 1.0 } else { 0.0 }; 3]
        }),
        cloud_source: uniform(64, 0.0),
        ground_direct: uniform(64, 1.0),
        ground_sky: uniform(64, 0.0),
        iterations: 1,
    };
    // Snow-like: high reflectances, eight iterations.
    let random = RadiosityInputs {
        ground_reflectance: random_field(32, 1, 0.5, 0.9),
        cloud_reflectance: random_field(32, 2, 0.3, 0.9),
        cloud_source: random_field(32, 3, 0.0, 0.5),
        ground_direct: random_field(32, 4, 0.0, 1.0),
        ground_sky: random_field(32, 5, 0.1, 0.3),
        iterations: 8,
    };
    for (name, inputs) in [
        ("uniform planes", &planes),
        ("square cloud", &square),
        ("random", &random),
    ] {
        let worst = compare(&gpu, inputs);
        println!("{name}: largest |GPU − CPU| / max = {worst:.2e}");
        assert!(worst < 1e-4, "{name}: {worst:.2e} (the issue allows 1e-2)");
    }
}

#[test]
fn bad_sizes_are_refused() {
    let gpu = GpuContext::new(AdapterPreference::Auto)
        .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    for size in [0, 4, 12, 100] {
        let error = RadiosityPass::new(&gpu.device, size).expect_err("refused");
        assert!(
            error.to_string().contains(&format!("size {size}")),
            "{error}"
        );
    }
}
