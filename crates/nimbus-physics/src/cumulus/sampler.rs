//! Particles spread evenly over an implicit surface {f = 1}: the repulsion
//! and fission/death scheme of Witkin & Heckbert (1994, "Using particles
//! to sample and control implicit surfaces") as used for isosurfaces by
//! Crossno & Angel (1997), with the change of Bouthors & Neyret (2004, §3):
//! every particle has its own desired radius and its own desired energy
//! (both randomised), and its repulsion radius moves towards the desired
//! energy only while its energy is too low, towards its desired radius
//! otherwise. The particles become the next level's blobs, their repulsion
//! radius the blob radius.
//!
//! Energy of particle i: E_i = Σ_j α exp(−|p_i − p_j|² / 2σ_i²). Its motion
//! (WH94, eq. 8 without the surface-velocity term) is
//! ṗ_i = σ_i² Σ_j r_ij (E^i_ij / σ_i² + E^j_ij / σ_j²), projected on the
//! tangent plane; the particle is then put back on the surface by Newton
//! steps along the gradient. A particle whose neighbours sit at twice its
//! radius in a hexagonal pattern has E = 6 α e^{−2} ≈ 0.81 α, which is the
//! nominal desired energy (WH94's 0.8 α).
//!
//! Equilibrium: no particle born or dead in the last
//! [`SamplerSettings::quiet_iterations`] iterations and a mean step below
//! [`SamplerSettings::rest_step`] of the desired radius; or the iteration
//! limit, which the report says. While no particle is born or dies the time
//! step decays by 5 % per iteration (particles on the surface's creases
//! would otherwise zig-zag across them for ever).

use super::dual::Dual;
use super::grid::PointGrid;
use crate::transport::rng::Rng;
use glam::DVec3;
use rayon::prelude::*;

/// The sampler's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplerSettings {
    /// α, the energy amplitude (WH94: 6).
    pub energy_amplitude: f64,
    /// Time step of the motion (a particle in a crowd moves about
    /// 7·dt·σ per iteration; capped at a third of σ).
    pub time_step: f64,
    /// Largest number of iterations.
    pub max_iterations: u32,
    /// Iterations without birth or death that equilibrium needs.
    pub quiet_iterations: u32,
    /// Mean step, in desired radii, under which the particles are at rest.
    pub rest_step: f64,
    /// Relative spread of the desired radii and energies (±).
    pub variation: f64,
}

impl Default for SamplerSettings {
    fn default() -> Self {
        Self {
            energy_amplitude: 6.0,
            time_step: 0.03,
            max_iterations: 400,
            quiet_iterations: 15,
            rest_step: 0.01,
            variation: 0.3,
        }
    }
}

/// A particle on the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Particle {
    /// Position, m.
    pub position_m: DVec3,
    /// Repulsion radius σ, m.
    pub radius_m: f64,
    /// Desired radius σ̂, m.
    pub desired_radius_m: f64,
    /// Desired energy Ê.
    pub desired_energy: f64,
}

/// How the sampling went.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingReport {
    /// Iterations run.
    pub iterations: u32,
    /// Whether the equilibrium criterion was met (else the limit stopped it).
    pub converged: bool,
    /// Particles born by fission.
    pub births: u32,
    /// Particles removed (crowding, or lost off the surface).
    pub deaths: u32,
}

/// Newton steps along the gradient to the surface f = 1 from `p`, to 10⁻³
/// of `scale_m` (the size of the features, e.g. the blob radius), no step
/// longer than `scale_m`; `None` if the gradient vanishes or the point does
/// not converge.
pub fn project_to_surface(
    potential: &(impl Fn(DVec3) -> Dual + ?Sized),
    p: DVec3,
    scale_m: f64,
) -> Option<DVec3> {
    let tolerance = 1e-3 * scale_m;
    let mut q = p;
    for _ in 0..16 {
        let f = potential(q);
        let g2 = f.gradient.length_squared();
        if g2 < 1e-30 {
            return None;
        }
        let step = (f.gradient * ((f.value - 1.0) / g2)).clamp_length_max(scale_m);
        q -= step;
        if step.length() < tolerance {
            return Some(q);
        }
    }
    None
}

struct Forces {
    energy: f64,
    energy_by_radius: f64,
    velocity: DVec3,
}

/// Spreads particles over {f = 1} from `seeds` (points near the surface).
/// `desired_radius` draws a particle's desired radius; `potential` is the
/// field. Returns the particles at equilibrium and the report.
pub fn sample_surface(
    potential: &(dyn Fn(DVec3) -> Dual + Sync),
    seeds: &[DVec3],
    mean_radius_m: f64,
    settings: &SamplerSettings,
    rng: &mut Rng,
    mut progress: impl FnMut(u32, usize),
) -> (Vec<Particle>, SamplingReport) {
    let alpha = settings.energy_amplitude;
    let nominal_energy = 6.0 * alpha * (-2.0f64).exp();
    let draw = |rng: &mut Rng| {
        let v = settings.variation;
        let radius = mean_radius_m * (1.0 + v * (2.0 * rng.uniform() - 1.0));
        let energy = nominal_energy * (1.0 + v * (2.0 * rng.uniform() - 1.0));
        (radius, energy)
    };
    let mut particles: Vec<Particle> = Vec::new();
    for &s in seeds {
        if let Some(p) = project_to_surface(potential, s, mean_radius_m) {
            let (radius, energy) = draw(rng);
            particles.push(Particle {
                position_m: p,
                radius_m: radius,
                desired_radius_m: radius,
                desired_energy: energy,
            });
        }
    }
    let mut report = SamplingReport {
        iterations: 0,
        converged: false,
        births: 0,
        deaths: 0,
    };
    let mut quiet = 0;
    // Once no particle is born or dies, the motion is damped: particles on
    // the creases of the surface (furrows, the floor's edge) would otherwise
    // zig-zag across them forever.
    let mut time_step = settings.time_step;
    while report.iterations < settings.max_iterations && !particles.is_empty() {
        report.iterations += 1;
        let max_radius = particles.iter().map(|p| p.radius_m).fold(0.0, f64::max);
        let reach = 3.0 * max_radius;
        let grid = PointGrid::new(reach, particles.iter().map(|p| p.position_m));
        let forces: Vec<Forces> = particles
            .par_iter()
            .enumerate()
            .map(|(i, pi)| {
                let mut f = Forces {
                    energy: 0.0,
                    energy_by_radius: 0.0,
                    velocity: DVec3::ZERO,
                };
                let si2 = pi.radius_m * pi.radius_m;
                grid.for_each_near(pi.position_m, reach, |j| {
                    let j = j as usize;
                    if j == i {
                        return;
                    }
                    let pj = &particles[j];
                    let r = pi.position_m - pj.position_m;
                    let r2 = r.length_squared();
                    if r2 > reach * reach {
                        return;
                    }
                    let sj2 = pj.radius_m * pj.radius_m;
                    let ei = alpha * (-r2 / (2.0 * si2)).exp();
                    let ej = alpha * (-r2 / (2.0 * sj2)).exp();
                    f.energy += ei;
                    f.energy_by_radius += r2 / (si2 * pi.radius_m) * ei;
                    f.velocity += r * (ei + ej * si2 / sj2);
                });
                f
            })
            .collect();

        // Motion on the tangent plane, then back onto the surface.
        let moved: Vec<Option<(DVec3, f64)>> = particles
            .par_iter()
            .zip(&forces)
            .map(|(p, f)| {
                let field = potential(p.position_m);
                let n = field.gradient.normalize_or_zero();
                let tangent = f.velocity - n * f.velocity.dot(n);
                let step = (tangent * time_step).clamp_length_max(p.radius_m / 3.0);
                let q = project_to_surface(potential, p.position_m + step, p.desired_radius_m)?;
                Some((q, (q - p.position_m).length() / p.desired_radius_m))
            })
            .collect();

        let mut next: Vec<Particle> = Vec::with_capacity(particles.len() + 16);
        let mut changed = false;
        let mut step_sum = 0.0;
        for ((p, f), m) in particles.iter().zip(&forces).zip(moved) {
            let Some((position, step)) = m else {
                report.deaths += 1;
                changed = true;
                continue;
            };
            step_sum += step;
            let mut p = Particle {
                position_m: position,
                ..*p
            };
            // Radius: towards the desired energy while the energy is too
            // low (WH94's feedback, ρ = 15, β = 10/σ̂), else towards the
            // desired radius (Bouthors & Neyret 2004).
            if f.energy < p.desired_energy {
                let beta = 10.0 / p.desired_radius_m;
                let rate = -15.0 * (f.energy - p.desired_energy) / (f.energy_by_radius + beta);
                let change = (rate * settings.time_step).clamp(-0.1 * p.radius_m, 0.1 * p.radius_m);
                p.radius_m += change;
            } else {
                p.radius_m += 0.2 * (p.desired_radius_m - p.radius_m);
            }
            // Death in a crowd (one in four per iteration, so that a crowd
            // thins out instead of vanishing).
            if f.energy > 2.2 * p.desired_energy && rng.uniform() < 0.25 {
                report.deaths += 1;
                changed = true;
                continue;
            }
            // Fission when grown too large, or alone at full size.
            let lonely =
                f.energy < 0.2 * p.desired_energy && p.radius_m >= 0.9 * p.desired_radius_m;
            if p.radius_m > 1.5 * p.desired_radius_m || lonely {
                let n = potential(p.position_m).gradient.normalize_or_zero();
                let any = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
                let t1 = n.cross(any).normalize_or_zero();
                let t2 = n.cross(t1);
                let angle = std::f64::consts::TAU * rng.uniform();
                let t = t1 * angle.cos() + t2 * angle.sin();
                let child_radius = p.radius_m / std::f64::consts::SQRT_2;
                for sign in [-1.0, 1.0] {
                    let Some(q) = project_to_surface(
                        potential,
                        p.position_m + t * (0.5 * p.radius_m * sign),
                        p.desired_radius_m,
                    ) else {
                        continue;
                    };
                    let (desired_radius, desired_energy) = if sign < 0.0 {
                        (p.desired_radius_m, p.desired_energy)
                    } else {
                        draw(rng)
                    };
                    next.push(Particle {
                        position_m: q,
                        radius_m: child_radius,
                        desired_radius_m: desired_radius,
                        desired_energy,
                    });
                }
                report.births += 1;
                changed = true;
                continue;
            }
            next.push(p);
        }
        let mean_step = step_sum / particles.len().max(1) as f64;
        particles = next;
        progress(report.iterations, particles.len());
        quiet = if changed { 0 } else { quiet + 1 };
        time_step = if quiet > 0 {
            time_step * 0.95
        } else {
            settings.time_step
        };
        if quiet >= settings.quiet_iterations && mean_step < settings.rest_step {
            report.converged = true;
            break;
        }
    }
    (particles, report)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of radius R as the surface f = exp(1 − |p|/R) = 1.
    fn sphere(radius: f64) -> impl Fn(DVec3) -> Dual + Sync {
        move |p: DVec3| {
            let d = p.length();
            let g = (1.0 - d / radius).exp();
            Dual {
                value: g,
                gradient: -p / d * (g / radius),
            }
        }
    }

    /// On a sphere the particles reach equilibrium, cover it without holes
    /// (every point of the sphere is within 2.5 desired radii of a
    /// particle), keep their radii near the target, and their spacing
    /// (distance to the nearest neighbour) is about twice their radius.
    #[test]
    fn sphere_sampling_reaches_an_even_equilibrium() {
        let radius = 300.0;
        let target = 40.0;
        let f = sphere(radius);
        let mut rng = Rng::new(7, 1);
        let seeds: Vec<DVec3> = (0..10)
            .map(|i| {
                let t = i as f64;
                DVec3::new(t.sin(), (2.0 * t).cos(), 0.3 * t - 1.0) * radius
            })
            .collect();
        let (particles, report) = sample_surface(
            &f,
            &seeds,
            target,
            &SamplerSettings::default(),
            &mut rng,
            |_, _| {},
        );
        assert!(report.converged, "{report:?}");
        // Everything on the surface.
        for p in &particles {
            assert!(
                (p.position_m.length() - radius).abs() < 0.1,
                "{}",
                p.position_m.length()
            );
        }
        // Count near the area over the hexagonal cell of spacing 2σ̂.
        let expected =
            4.0 * std::f64::consts::PI * radius * radius / (2.0 * 3f64.sqrt() * target * target);
        let n = particles.len() as f64;
        assert!(
            n > 0.6 * expected && n < 1.6 * expected,
            "{n} particles, hexagonal packing gives {expected:.0}"
        );
        // Mean radius near the target.
        let mean_radius = particles.iter().map(|p| p.radius_m).sum::<f64>() / n;
        assert!(
            (mean_radius / target - 1.0).abs() < 0.3,
            "mean radius {mean_radius}"
        );
        // Spacing: nearest-neighbour distance over the two radii.
        let mut ratios: Vec<f64> = particles
            .iter()
            .map(|a| {
                let nearest = particles
                    .iter()
                    .filter(|b| !std::ptr::eq(*b, a))
                    .map(|b| a.position_m.distance(b.position_m))
                    .fold(f64::INFINITY, f64::min);
                nearest / (a.radius_m + target)
            })
            .collect();
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        assert!(
            median > 0.6 && median < 1.4,
            "median spacing ratio {median}"
        );
        // No holes: a fine set of directions all have a particle nearby.
        for i in 0..2000 {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 2000.0;
            let phi = i as f64 * 2.399_963;
            let s = (1.0 - z * z).sqrt();
            let q = DVec3::new(s * phi.cos(), z, s * phi.sin()) * radius;
            let nearest = particles
                .iter()
                .map(|p| p.position_m.distance(q))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 2.5 * target, "hole of {nearest} m at {q}");
        }
    }
}
