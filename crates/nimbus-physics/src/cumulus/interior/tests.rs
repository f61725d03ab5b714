use super::*;
use crate::transport::phase_model::PhaseModel;

/// A uniform sphere of radius R about the origin.
struct Sphere {
    extinction_per_m: f64,
    radius_m: f64,
}

impl Medium for Sphere {
    fn extinction_per_m(&self, p_m: DVec3) -> f64 {
        if p_m.length() <= self.radius_m {
            self.extinction_per_m
        } else {
            0.0
        }
    }
    fn majorant_per_m(&self) -> f64 {
        self.extinction_per_m
    }
    fn bounds_m(&self) -> (DVec3, DVec3) {
        (DVec3::splat(-self.radius_m), DVec3::splat(self.radius_m))
    }
    fn exit_step_m(&self) -> f64 {
        1.0
    }
}

/// Conservative scattering by a Henyey–Greenstein phase function of
/// asymmetry `g` (0.85: a cumulus' droplets, peak kept).
fn conservative_hg(g: f64) -> Scattering {
    Scattering {
        single_scattering_albedo: 1.0,
        phase: PhaseModel::HenyeyGreenstein { g },
        max_orders: 100_000,
    }
}

/// ∫ e^{−σ ℓ(x, s)} ds over the sphere of directions, ℓ the chord from x
/// to the sphere's surface along s: the direct (unscattered) fluence of a
/// uniform isotropic illumination of unit radiance.
fn direct_fluence(sphere: &Sphere, x: DVec3) -> f64 {
    let (n_theta, n_phi) = (200, 100);
    let mut sum = 0.0;
    for i in 0..n_theta {
        let mu = -1.0 + 2.0 * (i as f64 + 0.5) / n_theta as f64;
        let s = (1.0 - mu * mu).sqrt();
        for j in 0..n_phi {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n_phi as f64;
            let d = DVec3::new(s * phi.cos(), s * phi.sin(), mu);
            let b = x.dot(d);
            let c = x.length_squared() - sphere.radius_m * sphere.radius_m;
            let l = -b + (b * b - c).max(0.0).sqrt();
            sum += (-sphere.extinction_per_m * l).exp();
        }
    }
    sum * 4.0 * PI / (n_theta * n_phi) as f64
}

/// Conservation: in a non-absorbing medium lit by a uniform isotropic
/// radiance L₀ the radiance is L₀ everywhere (Chandrasekhar 1950, §1), so
/// the total fluence is 4π L₀: the scattered fluence ∫ Φ(x, s) ds =
/// √(4π) Φ₀ (Y₀ = 1/√(4π)) must equal 4π − the direct fluence, at every
/// cell of a uniform sphere (τ = 2 to its centre, HG g = 0.85 as a
/// cumulus' droplets). Cells wholly inside the sphere: each within 15 %
/// (the estimate's noise over 2¹⁸ photons is ~5 % per cell), their mean
/// within 1.5 %; trilinear reading at a cell's centre gives the cell. The
/// tallied direct fluence Φ^d₀ is the analytic direct fluence (each cell
/// within 30 %: fewer photons cross a cell unscattered, ~10 % noise; the
/// mean within 5 %), and the two tallies add to 4π (each cell within 15 %).
/// There is no net flux: the scattered light's F₀ flows out (every cell
/// more than 40 m from the centre) as much as the direct light flows in
/// (their radial sum over those cells within 10 % of the direct's; per
/// cell the flux, a difference, is as noisy as the flux itself).
#[test]
fn scattered_plus_direct_fluence_is_four_pi_inside_a_conservative_sphere() {
    let sphere = Sphere {
        extinction_per_m: 0.02,
        radius_m: 100.0,
    };
    let scattering = conservative_hg(0.85);
    let interior = trace_interior(
        &sphere,
        &scattering,
        &InteriorSettings {
            photons: 1 << 18,
            cells_longest: 8,
            seed: 5,
        },
    );
    assert_eq!(interior.dims, [8, 8, 8]);
    let y0 = 0.5 / PI.sqrt();
    let mut checked = 0;
    let mut ratio_sum = 0.0;
    let mut direct_sum = 0.0;
    let (mut outward, mut flux_cells, mut flux_residual, mut flux_scale) = (0, 0, 0.0, 0.0);
    for k in 0..8 {
        for j in 0..8 {
            for i in 0..8 {
                let centre = interior.origin_m
                    + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * interior.cell_m();
                // Cells wholly inside the sphere.
                if centre.length() + 0.87 * 25.0 > 100.0 {
                    continue;
                }
                let phi = interior.cell([i, j, k]);
                let scattered = phi[0] / y0;
                let direct = direct_fluence(&sphere, centre);
                let expected = 4.0 * PI - direct;
                assert!(
                    (scattered / expected - 1.0).abs() < 0.15,
                    "cell {i} {j} {k} at {centre}: {scattered} vs {expected}"
                );
                // The tallied direct fluence is the analytic one, and the
                // two tallies together the equilibrium's 4π.
                let tallied_direct = interior.direct_cell([i, j, k])[0] / y0;
                assert!(
                    (tallied_direct / direct - 1.0).abs() < 0.3,
                    "cell {i} {j} {k}: direct {tallied_direct} vs {direct}"
                );
                let total = scattered + tallied_direct;
                assert!(
                    (total / (4.0 * PI) - 1.0).abs() < 0.15,
                    "cell {i} {j} {k}: total {total}"
                );
                direct_sum += tallied_direct / direct;
                // No net flux at equilibrium: the scattered light's flows
                // out as much as the direct light's flows in, −∫ T s ds =
                // −(4π/3) b.
                let scattered_flux = DVec3::from_array(interior.flux_cell([i, j, k])[0]) / y0;
                let (_, b) = direct_transmittance(&interior.direct_cell([i, j, k]));
                let direct_flux = -4.0 * PI / 3.0 * b;
                if centre.length() > 40.0 {
                    outward += usize::from(scattered_flux.dot(centre) > 0.0);
                    flux_cells += 1;
                    let radial = centre.normalize();
                    flux_residual += (scattered_flux + direct_flux).dot(radial);
                    flux_scale += direct_flux.dot(radial);
                }
                ratio_sum += scattered / expected;
                assert_eq!(interior.at(centre), phi);
                checked += 1;
            }
        }
    }
    assert!(checked >= 8, "{checked}");
    let mean = ratio_sum / f64::from(checked);
    assert!(
        (mean - 1.0).abs() < 0.015,
        "mean ratio {mean} over {checked} cells"
    );
    let direct_mean = direct_sum / f64::from(checked);
    eprintln!("direct: mean ratio {direct_mean} over {checked} cells");
    assert!(
        (direct_mean - 1.0).abs() < 0.05,
        "mean direct ratio {direct_mean} over {checked} cells"
    );
    eprintln!(
        "flux: residual {flux_residual} of {flux_scale} over {flux_cells} cells, {outward} outward"
    );
    assert!(
        flux_cells >= 8 && outward == flux_cells,
        "{outward} of {flux_cells} outward"
    );
    assert!(
        flux_residual.abs() < 0.1 * flux_scale.abs(),
        "net flux {flux_residual} against the direct's {flux_scale}"
    );
}

/// The sun's scattered fluence is higher on the lit side: the linear band
/// of Φ points to the light. In a cell near the +x face, light from +x
/// (Σ Φ_k Y_k(+x)) gives more than light from −x.
#[test]
fn the_scattered_fluence_is_higher_on_the_side_of_the_light() {
    let sphere = Sphere {
        extinction_per_m: 0.05,
        radius_m: 100.0,
    };
    let scattering = conservative_hg(0.85);
    let interior = trace_interior(
        &sphere,
        &scattering,
        &InteriorSettings {
            photons: 1 << 16,
            cells_longest: 8,
            seed: 9,
        },
    );
    let phi = interior.at(DVec3::new(60.0, 0.0, 0.0));
    let value = |s: [f64; 3]| -> f64 { sh::basis(s).iter().zip(&phi).map(|(y, p)| y * p).sum() };
    let (lit, unlit) = (value([1.0, 0.0, 0.0]), value([-1.0, 0.0, 0.0]));
    assert!(lit > 1.3 * unlit, "{lit} vs {unlit}");
}

/// The march against the closed form of a uniform fog: L = S (1 − e^{−σ ℓ}),
/// T = e^{−σ ℓ}, S the source over σ.
#[test]
fn march_of_a_uniform_fog_is_the_closed_form() {
    let ray = FogRay {
        sun_irradiance: [2.0, 3.0, 4.0],
        phase: [0.1, 0.2, 0.3],
        span_m: [10.0, 60.0],
        steps: 7,
        cos_view_sun: 0.3,
        asymmetry: 0.74,
    };
    let light = FogLight {
        extinction_per_m: 0.04,
        environment_fluence: [1.0, 2.0, 3.0],
        sun_fluence: 0.5,
        sun_transmittance: 0.25,
        sun_toward_camera: None,
        environment_flux_toward_camera: 0.0,
        sky_direct: [0.01, 0.02, 0.03],
    };
    let (l, t) = march_fog(&ray, |_| light);
    let opacity = 1.0 - (-0.04f64 * 50.0).exp();
    assert!((t - (1.0 - opacity)).abs() < 1e-12);
    // Φ_sun = 0.5 ≤ 1 − T_sun: all of it in the forward lobe.
    let lobe = forward_orders_lobe(4f64.ln(), 0.3, 0.74);
    for (c, l) in l.iter().enumerate() {
        let s = ray.phase[c] * ray.sun_irradiance[c] * 0.25
            + (ray.sun_irradiance[c] * 0.5 * lobe + light.environment_fluence[c]) / (4.0 * PI);
        let s = s + light.sky_direct[c];
        assert!((l - s * opacity).abs() < 1e-12 * s, "{c}");
    }
}

/// The forward lobe is a distribution (its mean over the sphere is 1), is
/// HG(g²) where the beam has barely been scattered, tends to isotropic
/// deep in, and grows towards the beam's travel with τ's fall.
#[test]
fn forward_orders_lobe_is_normalised_and_spreads_with_depth() {
    let hg4pi = |g: f64, c: f64| 4.0 * PI * PhaseModel::HenyeyGreenstein { g }.value(c);
    for g in [0.3, 0.74, 0.85] {
        for tau in [0.01, 0.5, 2.0, 6.0, 20.0] {
            // ∫ lobe dω/(4π) = ½ ∫ lobe d(cos θ), Simpson over cos θ.
            let n = 20_000;
            let h = 2.0 / f64::from(n);
            let mut mean = 0.0;
            for i in 0..=n {
                let c = -1.0 + f64::from(i) * h;
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                mean += w * forward_orders_lobe(tau, c, g);
            }
            mean *= h / 3.0 / 2.0;
            assert!((mean - 1.0).abs() < 1e-3, "g {g} τ {tau}: mean {mean}");
        }
        let shallow = forward_orders_lobe(1e-6, 0.9, g);
        assert!(
            (shallow / hg4pi(g * g, 0.9) - 1.0).abs() < 1e-3,
            "{shallow}"
        );
        assert!((forward_orders_lobe(200.0, 0.9, g) - 1.0).abs() < 1e-9);
        let along = |tau| forward_orders_lobe(tau, 1.0, g);
        assert!(along(0.5) > along(2.0) && along(2.0) > along(6.0) && along(6.0) > 1.0);
    }
}

/// The sun's scattered light beyond what left the beam (Φ_sun > 1 − T_sun)
/// stays isotropic: looking towards and away from the sun differ by the
/// forward part only.
#[test]
fn march_keeps_the_sun_light_beyond_the_beams_loss_isotropic() {
    let (tau, phi) = (1.5f64, 2.0f64);
    let t_sun = (-tau).exp();
    let light = FogLight {
        extinction_per_m: 0.05,
        environment_fluence: [0.0; 3],
        sun_fluence: phi,
        sun_transmittance: t_sun,
        sun_toward_camera: None,
        environment_flux_toward_camera: 0.0,
        sky_direct: [0.0; 3],
    };
    let fog = |cos_view_sun: f64| {
        let ray = FogRay {
            sun_irradiance: [1.0; 3],
            phase: [0.0; 3],
            span_m: [0.0, 1e4],
            steps: 4,
            cos_view_sun,
            asymmetry: 0.74,
        };
        march_fog(&ray, |_| light).0[0]
    };
    let forward = 1.0 - t_sun;
    for c in [-1.0, 0.0, 0.7, 1.0] {
        let expected = (phi - forward + forward * forward_orders_lobe(tau, c, 0.74)) / (4.0 * PI);
        assert!((fog(c) - expected).abs() < 1e-9 * expected, "{c}");
    }
    assert!(fog(1.0) > 3.0 * fog(-1.0));
}

/// With the sun's own cube ready, the march sends the sun's scattered light
/// towards the camera by it, whatever Φ_sun and the forward lobe say.
#[test]
fn march_takes_the_sun_light_towards_the_camera_from_the_cube() {
    let ray = FogRay {
        sun_irradiance: [2.0, 3.0, 4.0],
        phase: [0.0; 3],
        span_m: [0.0, 50.0],
        steps: 5,
        cos_view_sun: -0.8,
        asymmetry: 0.74,
    };
    let light = FogLight {
        extinction_per_m: 0.03,
        environment_fluence: [0.5, 0.25, 0.125],
        sun_fluence: 0.9,
        sun_transmittance: 0.1,
        sun_toward_camera: Some(0.3),
        environment_flux_toward_camera: 0.0,
        sky_direct: [0.0; 3],
    };
    let (l, _) = march_fog(&ray, |_| light);
    let opacity = 1.0 - (-0.03f64 * 50.0).exp();
    for (c, l) in l.iter().enumerate() {
        let s = (ray.sun_irradiance[c] * 0.3 + light.environment_fluence[c]) / (4.0 * PI);
        assert!((l - s * opacity).abs() < 1e-12 * s, "{c}");
    }
}

/// The ambient cube is exact along its axes and for a value the same in
/// every direction, blends between the axes with weights that sum to 1,
/// and never goes below its smallest value.
#[test]
fn ambient_cube_is_exact_on_its_axes_and_a_convex_blend_between() {
    let values = [3.0, 0.5, 2.0, 1.0, 0.25, 4.0];
    for (a, axis) in CUBE_AXES.iter().enumerate() {
        assert_eq!(ambient_cube(&values, DVec3::from_array(*axis)), values[a]);
    }
    assert!((ambient_cube(&[1.5; 6], DVec3::new(0.36, -0.48, 0.8)) - 1.5).abs() < 1e-12);
    let mut rng = Rng::new(3, 0);
    for _ in 0..1000 {
        let d = super::super::transport::uniform_direction(&mut rng);
        let v = ambient_cube(&values, d);
        assert!((0.25..=4.0).contains(&v), "{d}: {v}");
    }
}

/// The sun's cube in a uniform sphere (τ = 30 across, HG g = 0.85: 4.5
/// transport mean free paths) lit from +z: the light flows down the beam
/// (D towards −z above D towards +z everywhere the sun's light has
/// diffused), the sphere's symmetry about the beam holds (±x and ±y alike,
/// summed over the cells), and the mean of the six directions is the
/// fluence where the light has diffused, within 1.5 transport mean free
/// paths of the centre (the six axes integrate every harmonic of order ≤ 3
/// exactly, and D = 4π ∫ p L is normalised like Φ = ∫ L; near the faces
/// the light's sharper lobes break that): each within noise.
#[test]
fn sun_cube_of_a_sphere_flows_down_the_beam_and_averages_to_the_fluence() {
    let sphere = Sphere {
        extinction_per_m: 0.15,
        radius_m: 100.0,
    };
    let scattering = conservative_hg(0.85);
    let cube = trace_sun_cube(
        &sphere,
        &scattering,
        &InteriorSettings {
            photons: 1 << 18,
            cells_longest: 6,
            seed: 9,
        },
        DVec3::Z,
    );
    assert_eq!(cube.dims, [6, 6, 6]);
    let mut checked = 0;
    let mut sides = [0.0; 2];
    for k in 1..5 {
        for j in 1..5 {
            for i in 1..5 {
                let p =
                    cube.origin_m + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * 100.0 / 3.0;
                if p.length() > 60.0 {
                    continue;
                }
                let v = cube.at(p);
                let mean = v[..6].iter().sum::<f64>() / 6.0;
                if p.length() < 35.0 {
                    assert!(
                        (mean / v[7] - 1.0).abs() < 0.06,
                        "{p}: mean {mean}, Φ {}",
                        v[7]
                    );
                }
                assert!(v[5] > 1.2 * v[4], "{p}: down {} up {}", v[5], v[4]);
                // D along the beam (here −z) is the cube's −z, traced twice.
                assert!((v[6] / v[5] - 1.0).abs() < 1e-9, "{p}: {} {}", v[6], v[5]);
                sides[0] += v[0] + v[1];
                sides[1] += v[2] + v[3];
                checked += 1;
            }
        }
    }
    assert!(checked >= 8, "{checked}");
    assert!((sides[0] / sides[1] - 1.0).abs() < 0.05, "{sides:?}");
}

/// The cube read with the beam's excess: the cube on the axes, the cube
/// plus the whole excess along the beam, the excess fading away from it,
/// and no excess to spread when the beam runs along an axis.
#[test]
fn sun_cube_toward_is_exact_on_the_axes_and_along_the_beam() {
    let cube = [0.4, 0.2, 0.9, 0.3, 1.1, 0.5];
    let beam = DVec3::new(0.3, -0.8, 0.52).normalize();
    let (tau, g) = (2.5, 0.74);
    for (a, axis) in CUBE_AXES.iter().enumerate() {
        let d = DVec3::from_array(*axis);
        let shape = sun_cube_excess_shape(d, beam, tau, g);
        assert!(shape.abs() < 1e-12, "{d}: {shape}");
        assert!((sun_cube_toward(&cube, 0.7, d, shape) - cube[a]).abs() < 1e-12);
    }
    let along = sun_cube_excess_shape(beam, beam, tau, g);
    assert!((along - 1.0).abs() < 1e-12);
    let expected = ambient_cube(&cube, beam) + 0.7;
    assert!((sun_cube_toward(&cube, 0.7, beam, along) - expected).abs() < 1e-12);
    let rotate = |deg: f64| {
        let (t, _) = super::super::transport::tangents(beam);
        let (s, c) = deg.to_radians().sin_cos();
        (beam * c + t * s).normalize()
    };
    assert!(
        sun_cube_excess_shape(rotate(10.0), beam, tau, g)
            > sun_cube_excess_shape(rotate(40.0), beam, tau, g)
    );
    assert!(sun_cube_excess_shape(rotate(10.0), beam, tau, g) > 0.5);
    assert_eq!(
        sun_cube_excess_shape(rotate(30.0), DVec3::NEG_Y, tau, g),
        0.0
    );
    for deg in [0.0, 5.0, 20.0, 60.0, 90.0, 150.0, 180.0] {
        let shape = sun_cube_excess_shape(rotate(deg), beam, tau, g);
        assert!((0.0..=1.0).contains(&shape), "{deg}°: {shape}");
    }
    assert_eq!(sun_cube_toward(&cube, -10.0, beam, 1.0), 0.0);
}

/// Block averages keep the mean extinction and the box.
#[test]
fn downsampling_keeps_the_box_and_the_mean() {
    let dims = [10, 6, 9];
    let values_per_m: Vec<f32> = (0..540).map(|i| (i % 7) as f32 * 0.01).collect();
    let grid = ExtinctionGrid {
        origin_m: DVec3::new(-5.0, 0.0, 3.0),
        cell_m: 2.0,
        dims,
        values_per_m,
        coarsened: false,
    };
    let coarse = downsample(&grid, 5);
    assert_eq!(coarse.dims, [5, 3, 5]);
    assert_eq!(coarse.cell_m, 4.0);
    assert_eq!(coarse.origin_m, grid.origin_m);
    // The padded cells (beyond the fine grid) count as 0.
    let sum = |g: &ExtinctionGrid| -> f64 {
        g.values_per_m.iter().map(|&v| f64::from(v)).sum::<f64>() * g.cell_m.powi(3)
    };
    assert!((sum(&coarse) - sum(&grid)).abs() < 1e-4 * sum(&grid));
    assert_eq!(downsample(&grid, 10), grid);
}

/// The 38-point rule integrates every monomial of degree ≤ 9 exactly: the
/// mean of x^a y^b z^c over the sphere is (a−1)!!(b−1)!!(c−1)!!/(a+b+c+1)!!
/// for even a, b, c, else 0.
#[test]
fn lebedev_38_is_exact_to_degree_9() {
    let double_factorial = |n: i32| -> f64 { (1..=n).rev().step_by(2).map(f64::from).product() };
    let points = lebedev_38();
    assert!((points.iter().map(|p| p.1).sum::<f64>() - 1.0).abs() < 1e-14);
    for a in 0..=9i32 {
        for b in 0..=(9 - a) {
            for c in 0..=(9 - a - b) {
                let rule: f64 = points
                    .iter()
                    .map(|(d, w)| w * d.x.powi(a) * d.y.powi(b) * d.z.powi(c))
                    .sum();
                let exact = if a % 2 == 0 && b % 2 == 0 && c % 2 == 0 {
                    double_factorial(a - 1) * double_factorial(b - 1) * double_factorial(c - 1)
                        / double_factorial(a + b + c + 1)
                } else {
                    0.0
                };
                assert!(
                    (rule - exact).abs() < 1e-14,
                    "x^{a} y^{b} z^{c}: {rule} vs {exact}"
                );
            }
        }
    }
}

/// The sky's direct light towards the camera, from the kernel, is the
/// integral ∫ L(s) T(s) HG(g, −s·o) ds over a fine grid of directions with
/// the whole Henyey–Greenstein phase function and T the cap of its mean
/// and first moment ([`transmittance_cap`]), for skies with a
/// gradient and a bright side, views all round and asymmetries up to 0.85.
/// Relative to the sky's mean radiance times t̄: for caps of half-angle
/// 70° or more (|b|/t̄ ≤ 2) within 2 % for g ≤ 0.5 and 8 % for the
/// droplets' g* = 0.74 (7.6 % found; the linear form's error against the
/// same integrals reaches 30 %): the phase function's orders ≥ 4 and the
/// cap's ≥ 4 dropped. Narrower caps (deep inside, where t̄ is small) and
/// HG(0.85) are not held by orders ≤ 3: there the summed error is less
/// than 0.7 of the linear form t̄ + b·s's. The kernel's orders ≤ 1 are
/// that linear form's integral (2·10⁻⁴).
#[test]
fn sky_direct_kernel_is_the_integral_with_the_whole_phase_function() {
    let grid: Vec<[f64; 3]> = (0..400_000)
        .map(|i| crate::atmosphere::fibonacci_sphere(i, 400_000))
        .collect();
    let sky_radiance = |s: [f64; 3]| -> [f64; 3] {
        let [x, y, z] = s;
        // Brighter towards +x+y, bluer overhead, a dim ground below.
        let up = y.max(0.0);
        [
            0.3 + 0.4 * up + 0.3 * (x + y).max(0.0) * 0.7 + 0.05 * z,
            0.4 + 0.6 * up + 0.2 * (x + y).max(0.0) * 0.7,
            0.6 + 0.9 * up + 0.1 * x * x,
        ]
    };
    let sky = crate::sh::project(&grid, sky_radiance);
    // ∫ L T HG over the grid, T given per direction.
    let integral = |toward: DVec3, g: f64, t: &dyn Fn(DVec3) -> f64| -> [f64; 3] {
        let phase = PhaseModel::HenyeyGreenstein { g };
        let mut out = [0.0; 3];
        for s in &grid {
            let d = DVec3::from_array(*s);
            let l = crate::sh::radiance(&sky, *s);
            let w = 4.0 * PI / grid.len() as f64 * phase.value(-d.dot(toward)) * t(d);
            for c in 0..3 {
                out[c] += w * l[c];
            }
        }
        out
    };
    let mut rng = Rng::new(11, 0);
    let (mut narrow_kernel, mut narrow_linear) = (0.0, 0.0);
    let (mut sharp_kernel, mut sharp_linear) = (0.0, 0.0);
    for case in 0..48 {
        let g = [0.0, 0.5, 0.74, 0.85][case % 4];
        let toward = uniform_direction(&mut rng);
        let mean = 0.2 + 0.6 * rng.uniform();
        // |b|/t̄ from 0 to 2.9: isotropic to a narrow cone.
        let ratio = 2.9 * (case / 4) as f64 / 11.0;
        let gradient = uniform_direction(&mut rng) * mean * ratio;
        let kernel = SkyDirectKernel::new(&sky, g, toward);
        let fast = kernel.source((mean, gradient));
        let cap = transmittance_cap(mean, gradient);
        let exact = integral(toward, g, &|d| cap.map_or(mean, |cap| cap.at(d)));
        let linear = integral(toward, g, &|d| mean + gradient.dot(d));
        let tolerance = [0.02, 0.02, 0.08, f64::INFINITY][case % 4];
        for c in 0..3 {
            let scale = sky[0][c] * 0.282_095 * mean;
            if g > 0.8 {
                // HG(0.85) is beyond orders ≤ 3 (its peak 36× its mean):
                // held to no worse than the linear form.
                sharp_kernel += (fast[c] - exact[c]).abs() / scale;
                sharp_linear += (linear[c].max(0.0) - exact[c]).abs() / scale;
            } else if ratio <= 2.0 {
                assert!(
                    (fast[c] - exact[c]).abs() < tolerance * scale,
                    "case {case} g {g} r {ratio} channel {c}: kernel {} vs {}",
                    fast[c],
                    exact[c]
                );
            } else {
                narrow_kernel += (fast[c] - exact[c]).abs() / scale;
                narrow_linear += (linear[c] - exact[c]).abs() / scale;
            }
            // The kernel's orders ≤ 1 are the linear form's integral (where
            // the source is not held at zero).
            if fast[c] <= 0.0 {
                continue;
            }
            let orders_2_3 = cap.map_or(0.0, |cap| {
                let y2 = crate::sh::basis(cap.axis.to_array());
                let y3 = order_3_basis(cap.axis);
                let [_, _, l2, l3] = cap.orders();
                cap.amplitude
                    * (l2
                        * (0..5)
                            .map(|k| kernel.order_2[k][c] * y2[4 + k])
                            .sum::<f64>()
                        + l3 * (0..7).map(|k| kernel.order_3[k][c] * y3[k]).sum::<f64>())
            });
            let linear_kernel = mean * kernel.mean[c]
                + (0..3)
                    .map(|a| gradient[a] * kernel.moment[a][c])
                    .sum::<f64>();
            assert!(
                (fast[c] - orders_2_3 - linear_kernel).abs() < 2e-4 * sky[0][c] * 0.282_095,
                "case {case} channel {c}"
            );
        }
    }
    assert!(
        narrow_kernel < 0.7 * narrow_linear,
        "narrow caps: kernel {narrow_kernel}, linear {narrow_linear}"
    );
    assert!(
        sharp_kernel < 0.7 * sharp_linear,
        "g 0.85: kernel {sharp_kernel}, linear {sharp_linear}"
    );
    // Looking up from just inside a flat base: T is 1 from below and 0
    // above (t̄ = ½, b = −¾ ŷ). The linear form is ½ at the horizon,
    // positive to 42° above it and negative overhead, where the droplets
    // would send the sky's light on to the camera (0.49 of the scale below
    // from the step's integral); the cap is the step itself, and its
    // orders ≤ 3 come within 0.08. The droplets send little of the light
    // from below back down.
    let down = DVec3::NEG_Y;
    let below = (0.5, DVec3::new(0.0, -0.75, 0.0));
    let step = integral(down, 0.74, &|d| if d.y < 0.0 { 1.0 } else { 0.0 })[1];
    let looking_up = SkyDirectKernel::new(&sky, 0.74, down).source(below)[1];
    let linear_up = integral(down, 0.74, &|d| below.0 + below.1.dot(d))[1];
    let looking_down = SkyDirectKernel::new(&sky, 0.74, DVec3::Y).source(below)[1];
    // Relative to the sky's mean radiance times t̄.
    let scale = sky[0][1] * 0.282_095 * below.0;
    assert!(
        (looking_up - step).abs() < 0.1 * scale && (linear_up - step).abs() > 0.3 * scale,
        "step {step}, cap {looking_up}, linear {linear_up}, scale {scale}"
    );
    assert!(
        looking_down > 3.0 * looking_up,
        "{looking_down} vs {looking_up}"
    );
}

/// The cap has the mean and the first moment it was made from, its
/// orders 2 and 3 are the projection's (Funk–Hecke's λ_l against a fine
/// grid), and a half-space open below (inside a flat base) is itself.
#[test]
fn transmittance_cap_keeps_the_mean_and_moment() {
    let grid: Vec<[f64; 3]> = (0..100_000)
        .map(|i| crate::atmosphere::fibonacci_sphere(i, 100_000))
        .collect();
    let mut rng = Rng::new(3, 0);
    for case in 0..12 {
        let mean = 0.1 + 0.8 * rng.uniform();
        let ratio = 2.9 * (case + 1) as f64 / 12.0;
        let gradient = uniform_direction(&mut rng) * mean * ratio;
        let cap = transmittance_cap(mean, gradient).expect("a direction");
        let (mut t, mut b, mut p2, mut p3) = (0.0, DVec3::ZERO, 0.0, 0.0);
        for s in &grid {
            let d = DVec3::from_array(*s);
            let v = cap.at(d) / grid.len() as f64;
            let mu = d.dot(cap.axis);
            t += v;
            b += 3.0 * v * d;
            p2 += 4.0 * PI * v * 0.5 * (3.0 * mu * mu - 1.0);
            p3 += 4.0 * PI * v * 0.5 * (5.0 * mu * mu * mu - 3.0 * mu);
        }
        assert!(
            (t - mean).abs() < 2e-3 * mean,
            "case {case}: mean {t} vs {mean}"
        );
        assert!(
            (b - gradient).length() < 5e-3 * mean,
            "case {case}: moment {b} vs {gradient}"
        );
        let [_, _, l2, l3] = cap.orders();
        assert!(
            (p2 - cap.amplitude * l2).abs() < 1e-2 * mean,
            "case {case}: {p2}"
        );
        assert!(
            (p3 - cap.amplitude * l3).abs() < 1e-2 * mean,
            "case {case}: {p3}"
        );
    }
    let base = transmittance_cap(0.5, DVec3::new(0.0, -0.75, 0.0)).expect("a direction");
    assert!(base.cos_half_angle.abs() < 1e-12 && (base.amplitude - 1.0).abs() < 1e-12);
    assert_eq!(
        (
            base.at(DVec3::NEG_Y),
            base.at(DVec3::new(0.0, 0.01, 1.0).normalize())
        ),
        (1.0, 0.0)
    );
    assert!(transmittance_cap(0.5, DVec3::ZERO).is_none());
}

/// The transmittance's order-1 part comes back from its projection.
#[test]
fn direct_transmittance_reads_the_order_1_projection() {
    let grid: Vec<[f64; 3]> = (0..20_000)
        .map(|i| crate::atmosphere::fibonacci_sphere(i, 20_000))
        .collect();
    let t = |s: [f64; 3]| 0.6 + 0.2 * s[0] - 0.3 * s[1] + 0.1 * s[2] + 0.2 * s[2] * s[2];
    let projected = crate::sh::project(&grid, |s| [t(s); 3]);
    let direct: [f64; 9] = std::array::from_fn(|k| projected[k][0]);
    let (mean, gradient) = direct_transmittance(&direct);
    assert!((mean - (0.6 + 0.2 / 3.0)).abs() < 1e-4, "{mean}");
    let expected = DVec3::new(0.2, -0.3, 0.1);
    assert!((gradient - expected).length() < 1e-4, "{gradient}");
}
