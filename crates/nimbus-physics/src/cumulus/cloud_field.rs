//! A field of cumulus: where the clouds of a scene stand, from a coverage,
//! a seed and a few shared shape variants (instanced with a rotation and a
//! scale, as games draw forests).
//!
//! Coverage is the fraction of the ground area under the clouds'
//! footprints (their horizontal discs), the meteorologist's cloud fraction
//! for clouds seen from straight above. The clouds are placed by dart
//! throwing: candidates uniform over the area, rejected when their
//! footprint overlaps an earlier cloud's by more than [`OVERLAP`] of the
//! smaller radius, until the covered area reaches the target or
//! [`MAX_ATTEMPTS_PER_CLOUD`] candidates in a row fail (high coverage then
//! falls short of the target; [`CloudField::coverage`] reports what was
//! reached).

use crate::transport::rng::Rng;
use glam::DVec3;

/// Fraction of the smaller footprint radius by which two clouds may overlap.
pub const OVERLAP: f64 = 0.25;
/// Consecutive rejected candidates after which placement stops.
pub const MAX_ATTEMPTS_PER_CLOUD: u32 = 2000;

/// What to place.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudFieldParams {
    /// Target fraction of the area under footprints, in [0, 1].
    pub coverage: f64,
    /// Height of the cloud bases, m.
    pub base_m: f64,
    /// Random seed of the placement.
    pub seed: u64,
    /// Centre (x, z) of the square area, m.
    pub centre_m: [f64; 2],
    /// Side of the square area, m.
    pub side_m: f64,
    /// Range of instance scales (uniform).
    pub scale_range: [f64; 2],
    /// Most clouds placed.
    pub max_clouds: usize,
}

/// One cloud of the field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudInstance {
    /// Index of the shape variant.
    pub variant: u32,
    /// Centre of the cloud's base (its footprint's centre at the base height), m.
    pub base_centre_m: DVec3,
    /// Rotation about the vertical, rad.
    pub yaw_rad: f64,
    /// Uniform scale of the variant.
    pub scale: f64,
}

/// The placed clouds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CloudField {
    /// The clouds, in placement order.
    pub clouds: Vec<CloudInstance>,
    /// Fraction of the area under their footprints (overlaps counted once
    /// only approximately: the sum of footprints minus pairwise lenses).
    pub coverage: f64,
}

/// Area of the lens where two discs of radii a and b at distance d overlap.
fn lens_area(a: f64, b: f64, d: f64) -> f64 {
    if d >= a + b {
        return 0.0;
    }
    if d <= (a - b).abs() {
        return std::f64::consts::PI * a.min(b).powi(2);
    }
    let alpha = ((d * d + a * a - b * b) / (2.0 * d * a))
        .clamp(-1.0, 1.0)
        .acos();
    let beta = ((d * d + b * b - a * a) / (2.0 * d * b))
        .clamp(-1.0, 1.0)
        .acos();
    a * a * (alpha - alpha.sin() * alpha.cos()) + b * b * (beta - beta.sin() * beta.cos())
}

/// Places clouds whose variants have the given footprint radii (m, at scale 1).
pub fn place_clouds(params: &CloudFieldParams, footprint_radii_m: &[f64]) -> CloudField {
    let mut field = CloudField::default();
    if footprint_radii_m.is_empty() || params.coverage <= 0.0 || params.side_m <= 0.0 {
        return field;
    }
    let area = params.side_m * params.side_m;
    let target = params.coverage.min(1.0) * area;
    let mut rng = Rng::new(params.seed, 0x0c1d_f1e1d);
    let mut covered = 0.0;
    let mut footprints: Vec<(f64, f64, f64)> = Vec::new();
    let mut failures = 0;
    while covered < target && field.clouds.len() < params.max_clouds {
        let variant = (rng.uniform() * footprint_radii_m.len() as f64) as usize;
        let variant = variant.min(footprint_radii_m.len() - 1);
        let [s0, s1] = params.scale_range;
        let scale = s0 + (s1 - s0) * rng.uniform();
        let radius = footprint_radii_m[variant] * scale;
        // Footprints stay inside the area, so the coverage is of the area.
        let free = (params.side_m - 2.0 * radius).max(0.0);
        let x = params.centre_m[0] + (rng.uniform() - 0.5) * free;
        let z = params.centre_m[1] + (rng.uniform() - 0.5) * free;
        let yaw = std::f64::consts::TAU * rng.uniform();
        let clash = footprints.iter().any(|&(fx, fz, fr)| {
            let d = ((fx - x).powi(2) + (fz - z).powi(2)).sqrt();
            d < fr + radius - OVERLAP * fr.min(radius)
        });
        if clash {
            failures += 1;
            if failures >= MAX_ATTEMPTS_PER_CLOUD {
                break;
            }
            continue;
        }
        failures = 0;
        let overlap: f64 = footprints
            .iter()
            .map(|&(fx, fz, fr)| {
                lens_area(fr, radius, ((fx - x).powi(2) + (fz - z).powi(2)).sqrt())
            })
            .sum();
        covered += std::f64::consts::PI * radius * radius - overlap;
        footprints.push((x, z, radius));
        field.clouds.push(CloudInstance {
            variant: variant as u32,
            base_centre_m: DVec3::new(x, params.base_m, z),
            yaw_rad: yaw,
            scale,
        });
    }
    field.coverage = covered / area;
    field
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(coverage: f64) -> CloudFieldParams {
        CloudFieldParams {
            coverage,
            base_m: 1500.0,
            seed: 3,
            centre_m: [0.0, 0.0],
            side_m: 20_000.0,
            scale_range: [0.7, 1.2],
            max_clouds: 1000,
        }
    }

    #[test]
    fn coverage_is_reached_and_measured() {
        for coverage in [0.05, 0.2, 0.4] {
            let field = place_clouds(&params(coverage), &[800.0, 600.0, 700.0]);
            assert!(
                field.coverage >= coverage && field.coverage < coverage + 0.05,
                "{coverage}: {}",
                field.coverage
            );
            // Check the reported coverage by sampling the area.
            let clouds = &field.clouds;
            let radii = [800.0, 600.0, 700.0];
            let mut rng = Rng::new(9, 1);
            let n = 40_000;
            let inside = (0..n)
                .filter(|_| {
                    let x = (rng.uniform() - 0.5) * 20_000.0;
                    let z = (rng.uniform() - 0.5) * 20_000.0;
                    clouds.iter().any(|c| {
                        let r = radii[c.variant as usize] * c.scale;
                        (c.base_centre_m.x - x).powi(2) + (c.base_centre_m.z - z).powi(2) < r * r
                    })
                })
                .count();
            let sampled = inside as f64 / n as f64;
            assert!(
                (sampled - field.coverage).abs() < 0.015,
                "{sampled} vs {}",
                field.coverage
            );
            assert!(clouds.iter().all(|c| c.base_centre_m.y == 1500.0));
        }
    }

    #[test]
    fn placement_is_seeded_and_uses_every_variant() {
        let a = place_clouds(&params(0.3), &[800.0, 600.0, 700.0]);
        let b = place_clouds(&params(0.3), &[800.0, 600.0, 700.0]);
        assert_eq!(a, b);
        for v in 0..3 {
            assert!(a.clouds.iter().any(|c| c.variant == v));
        }
        let other = place_clouds(
            &CloudFieldParams {
                seed: 4,
                ..params(0.3)
            },
            &[800.0, 600.0, 700.0],
        );
        assert_ne!(a.clouds[0], other.clouds[0]);
        assert!(place_clouds(&params(0.0), &[800.0]).clouds.is_empty());
    }

    #[test]
    fn lens_area_limits() {
        assert_eq!(lens_area(1.0, 1.0, 3.0), 0.0);
        assert!((lens_area(1.0, 2.0, 0.5) - std::f64::consts::PI).abs() < 1e-12);
        // Two unit discs one radius apart: 2π/3 − √3/2.
        let expected = 2.0 * std::f64::consts::PI / 3.0 - 3f64.sqrt() / 2.0;
        assert!((lens_area(1.0, 1.0, 1.0) - expected).abs() < 1e-12);
    }
}
