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
/// leave after two or more events) gives T₀ = Y₀ π f (the area per
/// macroscopic surface is the area here: the sphere is smooth), and the transfer's
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
            kernel_radius_m: 25.0,
            seed: 5,
            to_light: None,
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
    // Each point within 15 % (the kernel holds ~10³ photons; the sphere's
    // curvature makes the projected area a few per cent small), their mean
    // within 7 %.
    let mut mean = 0.0;
    for d in fibonacci_sphere(26) {
        mean += transfer.at(d * surface)[0] / expected_t0 / 26.0;
        let t = transfer.at(d * surface);
        assert!(
            (t[0] / expected_t0 - 1.0).abs() < 0.15,
            "T0 {} vs {expected_t0} at {d}",
            t[0]
        );
        let form = SphericalQuadratic::from_sh(&t);
        let cos = form.linear.normalize().dot(d);
        assert!(cos > 0.9, "linear part at {d}: {}", form.linear);
        // Light from outside the point's horizon leaves more than from behind.
        assert!(form.value(d) > 2.0 * form.value(-d).max(0.0));
    }
    assert!((mean - 1.0).abs() < 0.07, "mean T0 ratio {mean}");
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

/// The estimator against the slab: a 4 km × 4 km × 100 m box of σ 0.1 m⁻¹
/// (τ = 10, HG g = 0.8) lit from 30° off the zenith; at its centre, far
/// from the sides, the exitance of orders ≥ 2 through the top and the
/// bottom per unit irradiance is the slab tracer's reflectance and
/// transmittance of those orders times μ₀, within 8 %; and the SH transfer
/// (photons from every direction) evaluated at that direction gives the
/// same within 10 %.
#[test]
fn transfer_matches_the_slab_at_a_wide_box_centre() {
    let (side, height, sigma, g, zenith_deg) = (4000.0, 100.0, 0.1, 0.8, 30.0f64);
    let cell = 10.0;
    let dims = [
        (side / cell) as usize + 2,
        (height / cell) as usize + 2,
        (side / cell) as usize + 2,
    ];
    let origin_m = DVec3::new(-0.5 * side - cell, -cell, -0.5 * side - cell);
    let mut values_per_m = vec![0.0f32; dims[0] * dims[1] * dims[2]];
    for k in 1..dims[2] - 1 {
        for j in 1..dims[1] - 1 {
            for i in 1..dims[0] - 1 {
                values_per_m[(k * dims[1] + j) * dims[0] + i] = sigma as f32;
            }
        }
    }
    let grid = ExtinctionGrid {
        origin_m,
        cell_m: cell,
        dims,
        values_per_m,
        coarsened: false,
    };
    let medium = GridMedium::new(&grid, 1.0);
    let scattering = Scattering {
        single_scattering_albedo: 1.0,
        phase: PhaseModel::HenyeyGreenstein { g },
        max_orders: 100_000,
    };
    // The faces where the grid's σ falls to 0 (half a cell beyond the
    // outer non-zero cell centres' trilinear ramp): y = 0 and y = height,
    // a 600 m square at the centre of each.
    let mut triangles = Vec::new();
    for y in [-0.5 * cell + cell * 0.5, height + cell * 0.5] {
        let n = 30;
        for a in 0..n {
            for b in 0..n {
                let p = |i: usize, j: usize| {
                    DVec3::new(-300.0 + 20.0 * i as f64, y, -300.0 + 20.0 * j as f64)
                };
                triangles.push([p(a, b), p(a + 1, b), p(a + 1, b + 1)]);
                triangles.push([p(a, b), p(a + 1, b + 1), p(a, b + 1)]);
            }
        }
    }
    let (s, c) = zenith_deg.to_radians().sin_cos();
    let to_light = DVec3::new(s, c, 0.0);
    let settings = TransferSettings {
        photons: 1 << 22,
        kernel_radius_m: 40.0,
        seed: 11,
        to_light: Some(to_light),
    };
    let direct = trace_transfer(&medium, &scattering, &triangles, &settings);
    let reference = trace(
        &SlabMedium {
            optical_depth: sigma * height,
            single_scattering_albedo: 1.0,
            phase: PhaseModel::HenyeyGreenstein { g },
        },
        &TraceSettings {
            photons: 200_000,
            seed: 4,
            sun_zenith_deg: zenith_deg,
            ..Default::default()
        },
        &|_| {},
    );
    let reflected =
        c * (reference.reflectance.order2.value + reference.reflectance.order3plus.value);
    let transmitted =
        c * (reference.transmittance.order2.value + reference.transmittance.order3plus.value);
    // The kernel's estimate averaged over 25 points of the central 400 m
    // (one kernel holds ~170 photons: 8 % noise each).
    let mean_at = |y: f64| {
        let mut sum = 0.0;
        for i in 0..5 {
            for k in 0..5 {
                let p = DVec3::new(-200.0 + 100.0 * i as f64, y, -200.0 + 100.0 * k as f64);
                sum += direct.at(p)[0];
            }
        }
        sum / 25.0
    };
    let (top, bottom) = (mean_at(height + 0.5 * cell), mean_at(0.0));
    eprintln!("top {top} vs {reflected}, bottom {bottom} vs {transmitted}");
    assert!(
        (top / reflected - 1.0).abs() < 0.08,
        "top {top} vs {reflected}"
    );
    assert!(
        (bottom / transmitted - 1.0).abs() < 0.08,
        "bottom {bottom} vs {transmitted}"
    );
}

/// Diagnostic (run by hand): the slab's reflected radiance of orders ≥ 2
/// by exit angle and azimuth against the exitance leaving by the escape
/// function, M u(μ)/π, for the default droplets.
#[test]
#[ignore]
fn reflected_radiance_against_the_escape_function() {
    use crate::optics::dsd::{SizeDistribution, bulk_optics};
    use crate::optics::phase::PhaseTable;
    use crate::optics::tables::computation_angles;
    use crate::optics::water::water_refractive_index;
    let dsd = SizeDistribution::ModifiedGamma {
        number_density_per_m3: 300e6,
        gamma: 2.0,
        effective_radius_m: 7e-6,
    };
    let optics = bulk_optics(
        &dsd,
        550.0,
        water_refractive_index(550.0),
        &computation_angles(5.0),
        1e-3,
    );
    let phase = PhaseTable::new(optics.angles_deg.clone(), optics.phase.clone());
    let f = phase.forward_fraction(5.0);
    for (tau, zenith) in [
        (40.0 * (1.0 - f), 35.0),
        (40.0 * (1.0 - f), 60.0),
        (10.0 * (1.0 - f), 35.0),
    ] {
        let settings = TraceSettings {
            photons: 400_000,
            seed: 3,
            sun_zenith_deg: zenith,
            zenith_bins: 9,
            azimuth_bins: 6,
            ..Default::default()
        };
        let r = trace(
            &SlabMedium {
                optical_depth: tau,
                single_scattering_albedo: 1.0,
                phase: PhaseModel::tabulated(&phase.peak_removed(5.0)),
            },
            &settings,
            &|_| {},
        );
        let m = r.reflectance.order2.value + r.reflectance.order3plus.value;
        eprintln!(
            "τ* {tau:.1} sun zenith {zenith}: M/(μ0 E) = {m:.3}; radiance / (M μ0 u(μ)/π) by exit zenith (rows) and azimuth 0–180° (columns, 0 = towards the sun's side)"
        );
        for z in 0..9 {
            let mu = ((z as f64 + 0.5) * 10.0f64).to_radians().cos();
            let u = crate::transport::stratus::escape_function(mu);
            let row: Vec<String> = (0..6)
                .map(|a| {
                    let i = z * 6 + a;
                    let l = r.reflected.radiance[2][i] + r.reflected.radiance[3][i];
                    format!("{:.2}", l / (m * u / PI))
                })
                .collect();
            eprintln!("  {:>4.0}°: {}", (z as f64 + 0.5) * 10.0, row.join(" "));
        }
    }
}
