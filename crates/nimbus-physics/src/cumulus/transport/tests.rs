use super::*;
use crate::transport::monte_carlo::{SlabMedium, TraceSettings, trace};

/// A slab 0 < y < H, laterally unbounded.
struct Slab {
    extinction_per_m: f64,
    thickness_m: f64,
}

impl Medium for Slab {
    fn extinction_per_m(&self, p_m: DVec3) -> f64 {
        if (0.0..=self.thickness_m).contains(&p_m.y) {
            self.extinction_per_m
        } else {
            0.0
        }
    }
    fn majorant_per_m(&self) -> f64 {
        self.extinction_per_m
    }
    fn bounds_m(&self) -> (DVec3, DVec3) {
        (
            DVec3::new(-1e9, 0.0, -1e9),
            DVec3::new(1e9, self.thickness_m, 1e9),
        )
    }
    fn exit_step_m(&self) -> f64 {
        1.0
    }
}

/// The random walk against nimbus's independent slab tracer
/// (`transport::monte_carlo`, its own geometry and bookkeeping): the
/// fractions of a 30° beam leaving a τ = 8 slab (HG g = 0.8) through the top
/// and the bottom after one and after two or more scattering events agree
/// within four standard errors.
#[test]
fn random_walk_matches_the_slab_tracer() {
    let (tau, g, zenith_deg) = (8.0, 0.8, 30.0f64);
    let scattering = Scattering {
        single_scattering_albedo: 1.0,
        phase: PhaseModel::HenyeyGreenstein { g },
        max_orders: 100_000,
    };
    let slab = Slab {
        extinction_per_m: 0.1,
        thickness_m: tau / 0.1,
    };
    let (s, c) = zenith_deg.to_radians().sin_cos();
    let direction = DVec3::new(s, -c, 0.0);
    let photons = 100_000u64;
    // [top, bottom] × [order 1, orders 2+].
    let mut counts = [[0u64; 2]; 2];
    let mut rng = Rng::new(3, 0);
    for _ in 0..photons {
        let start = DVec3::new(0.0, slab.thickness_m + 1.0, 0.0);
        let escape = random_walk(&slab, &scattering, start, direction, &mut rng)
            .expect("no photon is dropped in a τ = 8 slab");
        if escape.order == 0 {
            continue;
        }
        let side = usize::from(escape.direction.y < 0.0);
        counts[side][usize::from(escape.order >= 2)] += 1;
    }
    let reference = trace(
        &SlabMedium {
            optical_depth: tau,
            single_scattering_albedo: 1.0,
            phase: PhaseModel::HenyeyGreenstein { g },
        },
        &TraceSettings {
            photons,
            seed: 9,
            sun_zenith_deg: zenith_deg,
            ..Default::default()
        },
        &|_| {},
    );
    let n = photons as f64;
    for (side, by_order) in [(0, &reference.reflectance), (1, &reference.transmittance)] {
        let expected = [
            by_order.order1,
            crate::transport::monte_carlo::Estimate {
                value: by_order.order2.value + by_order.order3plus.value,
                std_error: by_order
                    .order2
                    .std_error
                    .hypot(by_order.order3plus.std_error),
            },
        ];
        for k in 0..2 {
            let ours = counts[side][k] as f64 / n;
            let own_error = (ours * (1.0 - ours) / n).sqrt();
            let bound = 4.0 * expected[k].std_error.hypot(own_error) + 1e-4;
            assert!(
                (ours - expected[k].value).abs() < bound,
                "side {side} class {k}: {ours} vs {:?}",
                expected[k]
            );
        }
    }
}

fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// The quadratic form is the SH expansion it was made from, turns like the
/// cloud, and its product integral is the sphere's quadrature.
#[test]
fn quadratic_form_is_the_sh_expansion() {
    let a = [0.7, -0.2, 0.4, 0.3, 0.15, -0.25, 0.35, 0.05, -0.3];
    let b = [1.1, 0.3, -0.1, 0.2, -0.4, 0.1, -0.2, 0.3, 0.25];
    let (fa, fb) = (
        SphericalQuadratic::from_sh(&a),
        SphericalQuadratic::from_sh(&b),
    );
    let directions = fibonacci_sphere(40_000);
    let series = |c: &[f64; 9], s: DVec3| -> f64 {
        sh::basis(s.to_array())
            .iter()
            .zip(c)
            .map(|(y, c)| y * c)
            .sum()
    };
    let mut quadrature = 0.0;
    for &s in &directions {
        assert!((fa.value(s) - series(&a, s)).abs() < 1e-9);
        quadrature += series(&a, s) * series(&b, s);
    }
    quadrature *= 4.0 * PI / directions.len() as f64;
    assert!(
        (fa.product_integral(&fb) - quadrature).abs() < 1e-3,
        "{quadrature}"
    );
    // Orthonormal basis: the product integral is the coefficients' dot product.
    let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
    assert!((fa.product_integral(&fb) - dot).abs() < 1e-4);
    for (x, y) in fa.to_sh().iter().zip(&a) {
        assert!((x - y).abs() < 1e-5, "{:?} vs {a:?}", fa.to_sh());
    }
    let (c, s) = (0.6f64.cos(), 0.6f64.sin());
    let turned = fa.yawed(c, s);
    for &d in directions.iter().step_by(97) {
        let r = DVec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
        assert!((turned.value(r) - fa.value(d)).abs() < 1e-9);
    }
}

/// A uniform sphere (radius 100 m, σ 0.1 m⁻¹, HG g = 0.8) on an
/// [`ExtinctionGrid`]: by symmetry T₀ is the same all over its surface,
/// ∫ T₀ dA = Y₀ 4π · πR² f (f the fraction of the photons hitting it that
/// leave after two or more events) gives T₀ = Y₀ π f, and the transfer's
/// linear part points outwards (more light leaves the side facing the
/// light). Every photon is accounted for.
#[test]
fn sphere_transfer_is_symmetric_and_conserves_energy() {
    let radius = 100.0;
    let cell = 5.0;
    let n = 48usize;
    let origin_m = DVec3::splat(-0.5 * n as f64 * cell);
    let mut values_per_m = vec![0.0f32; n * n * n];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = origin_m + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * cell;
                if p.length() < radius {
                    values_per_m[(k * n + j) * n + i] = 0.1;
                }
            }
        }
    }
    let grid = ExtinctionGrid {
        origin_m,
        cell_m: cell,
        dims: [n; 3],
        values_per_m,
        coarsened: false,
    };
    let medium = GridMedium::new(&grid, 1.0);
    let scattering = Scattering {
        single_scattering_albedo: 1.0,
        phase: PhaseModel::HenyeyGreenstein { g: 0.8 },
        max_orders: 100_000,
    };
    // The surface: a latitude–longitude sphere where the voxels end.
    let surface = radius;
    let point = |t: usize, p: usize| {
        let theta = PI * t as f64 / 32.0;
        let phi = std::f64::consts::TAU * p as f64 / 64.0;
        DVec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        ) * surface
    };
    let mut triangles = Vec::new();
    for t in 0..32 {
        for p in 0..64 {
            let (a, b, c, d) = (
                point(t, p),
                point(t + 1, p),
                point(t + 1, p + 1),
                point(t, p + 1),
            );
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    let transfer = trace_transfer(
        &medium,
        &scattering,
        &triangles,
        &TransferSettings {
            photons: 300_000,
            kernel_cell_m: 25.0,
            seed: 5,
        },
    );
    let accounted: f64 = transfer.escaped_by_order.iter().sum::<f64>() + transfer.dropped;
    assert!((accounted - 1.0).abs() < 1e-12, "{accounted}");
    // Photons that scattered (a negligible few cross τ ≥ 1 of the rim unscattered).
    let hit = 1.0 - transfer.escaped_by_order[0];
    let f = transfer.escaped_by_order[2] / hit;
    // The disk is the box's, not the sphere's: the fraction hitting is πR²/A_disk.
    let expected_hit = PI * radius * radius / transfer.disk_area_m2;
    assert!(
        (hit / expected_hit - 1.0).abs() < 0.05,
        "{hit} vs {expected_hit}"
    );
    let expected_t0 = 0.282_095 * PI * f;
    for d in fibonacci_sphere(26) {
        let t = transfer.at(d * surface);
        assert!(
            (t[0] / expected_t0 - 1.0).abs() < 0.12,
            "T0 {} vs {expected_t0} at {d}",
            t[0]
        );
        let form = SphericalQuadratic::from_sh(&t);
        let cos = form.linear.normalize().dot(d);
        assert!(cos > 0.9, "linear part at {d}: {}", form.linear);
        // Light from outside the point's horizon leaves more than from behind.
        assert!(form.value(d) > 2.0 * form.value(-d).max(0.0));
    }
}

/// S against a numerical integral of single scattering along the view
/// through a slab: lit side, from behind, and the silhouette's limit.
#[test]
fn single_scattering_factor_is_the_slab_integral() {
    for (mu0, mu, tau) in [
        (0.8, 0.5, 3.0),
        (0.3, 0.9, 0.5),
        (-0.6, 0.4, 2.0),
        (-0.5, 0.5, 1.0),
        (-0.2, 0.7, 8.0),
    ] {
        let tau_n = tau * mu;
        // ∫_0^{τ_n} e^{−t/μ} e^{−(τ_n or 0 … )} dt/μ by the midpoint rule.
        let steps = 200_000;
        let h = tau_n / steps as f64;
        let mut sum = 0.0;
        for i in 0..steps {
            let t = (i as f64 + 0.5) * h;
            let to_sun = if mu0 > 0.0 {
                t / mu0
            } else {
                (tau_n - t) / -mu0
            };
            sum += (-t / mu).exp() * (-to_sun).exp() * h / mu;
        }
        let s = single_scattering_factor(mu0, mu, tau);
        assert!(
            (s - sum).abs() < 1e-6 * (1.0 + sum),
            "{mu0} {mu} {tau}: {s} vs {sum}"
        );
    }
    let edge = single_scattering_factor(-0.5, 1e-6, 2.0);
    assert!((edge - (1.0 - (-2.0f64).exp())).abs() < 1e-2, "{edge}");
}
