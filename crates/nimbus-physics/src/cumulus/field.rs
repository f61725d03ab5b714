//! The implicit field of a cumulus: a hierarchy of blob levels, each level
//! deforming its blobs against their neighbours, the level below and the
//! cloud's floor (Bouthors & Neyret 2004, §2; Bouthors 2004, §4.2).
//!
//! For a blob i of level l at P_i with radius r_i and flattening e_i, at a
//! point P at distance d_i from P_i and D from the surface S_{l−1}:
//!
//! - g_i = exp(1 − d_i / (r_i − e_i D)), the flattened sphere: along the
//!   normal of S_{l−1} the blob reaches r_i / (1 + e_i), along it r_i.
//! - m_i = Σ_{j≠i} (1 − ε − g_j) min(1, g_j²), the furrows: near a neighbour's
//!   surface (g_j ≈ 1) the term is −ε, so blobs stay apart by a furrow
//!   instead of touching; farther it is a small bulge.
//! - n_i = b min(1, e^{−I D / r_i}) e^{1 − d_i / r_i}, the blending of the
//!   blob into S_{l−1} where it meets it.
//! - o_i = g_i min(0, (y − h₀) / α_h), the flat floor: below h₀ the field is
//!   pushed down with stiffness α_h. nimbus cuts n_i the same way (else the
//!   blending of the last level bulges below the floor), so no surface
//!   reaches below h₀ − α_h (1 − 1/max(g + n)), within 0.82 α_h of h₀.
//! - f_i = g_i + m_i + n_i + o_i and f_l = max(f_{l−1}, max_i f_i); the
//!   surface S_l is {f_l = 1}.
//!
//! **The distance to S_{l−1}** (the paper leaves it open, and writes both
//! e_i d_{l−1} and I d_{l−1} / r_i, which cannot both be in metres). nimbus
//! estimates it in metres from the potential: for one unflattened blob,
//! f = exp(1 − d/r) gives the distance to its surface exactly as −r ln f, so
//! D = −r̄_{l−1} ln f_{l−1}(P) with r̄_{l−1} the mean radius of level l−1,
//! clamped to 0 inside S_{l−1}. It is continuous and differentiable where
//! f_{l−1} is, costs one evaluation of the level below, and makes e_i D
//! scale with r_i as the flattening needs. The paper's g has e_i d_{l−1}
//! inside r_i(1 − ·); with D in metres it becomes r_i − e_i D, the same
//! shape with the distance measured in blob radii.
//!
//! **The roots** have no S_{−1}: their flattening is about their own centre,
//! D = max(0, y − y_i), so a root's top reaches r_i / (1 + e_i) above its
//! centre and its sides r_i.
//!
//! Only blobs near P contribute: each level keeps its blobs in a
//! [`PointGrid`], and a blob is skipped where g falls below about 10⁻² (its
//! furrow term is then below 10⁻⁴).

use super::dual::Dual;
use super::grid::PointGrid;
use glam::DVec3;

/// One blob: an implicit flattened sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blob {
    /// Centre P_i, m (y up).
    pub centre_m: DVec3,
    /// Radius r_i, m.
    pub radius_m: f64,
    /// Flattening e_i, in [0, 1].
    pub flattening: f64,
}

/// The blending parameters shared by the blobs of one level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelBlend {
    /// ε, the furrow offset (the paper's 0.5: blobs stay half a radius apart).
    pub furrow_offset: f64,
    /// b, the amount of blending into the level below (paper: 0 for levels
    /// 0–1, 1 for level 2).
    pub blending: f64,
    /// I, how little of the blob is enlarged to blend (paper: 10).
    pub blend_sharpness: f64,
}

/// The cloud's flat floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Floor {
    /// h₀, the condensation height, m.
    pub height_m: f64,
    /// α_h, the stiffness of the floor, m (paper: 100 m).
    pub stiffness_m: f64,
}

/// Blobs whose g is below about 10⁻² at a point are skipped there: beyond
/// this many radii from their centre (g = e^{1−5.6} ≈ 10⁻²).
const INFLUENCE_RADII: f64 = 5.6;

/// A blob's own f_i can reach 1 only within this many radii of its centre
/// (g + n ≤ (1 + b) e^{1 − d/r} < 1 beyond (1 + ln 2) r for b ≤ 1, plus the
/// neighbours' bulges, each below 0.02).
const OWN_REACH_RADII: f64 = 2.0;

/// Potential below which the distance estimate is capped (−ln 10⁻¹² ≈ 27.6
/// radii: "far").
const FAR_POTENTIAL: f64 = 1e-12;

struct FieldLevel {
    blobs: Vec<Blob>,
    blend: LevelBlend,
    mean_radius_m: f64,
    max_radius_m: f64,
    grid: PointGrid,
}

/// The potential of a level at a point, and the blob that set it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldSample {
    /// f_l and its gradient (the surface's outward normal is −∇f/|∇f|).
    pub potential: Dual,
    /// (level, index) of the blob whose f_i is the maximum, if any.
    pub blob: Option<(usize, usize)>,
}

/// The field of a blob hierarchy.
pub struct BlobField {
    levels: Vec<FieldLevel>,
    floor: Floor,
}

impl BlobField {
    /// A field with no levels yet, over `floor`.
    pub fn new(floor: Floor) -> Self {
        Self {
            levels: Vec::new(),
            floor,
        }
    }

    /// The floor.
    pub fn floor(&self) -> Floor {
        self.floor
    }

    /// Adds a level of blobs on top of the existing ones (a level with no
    /// blob leaves the surface unchanged).
    pub fn push_level(&mut self, blobs: Vec<Blob>, blend: LevelBlend) {
        let mean_radius_m = if blobs.is_empty() {
            1.0
        } else {
            blobs.iter().map(|b| b.radius_m).sum::<f64>() / blobs.len() as f64
        };
        let max_radius_m = blobs.iter().map(|b| b.radius_m).fold(1e-3, f64::max);
        let grid = PointGrid::new(
            INFLUENCE_RADII * max_radius_m,
            blobs.iter().map(|b| b.centre_m),
        );
        self.levels.push(FieldLevel {
            blobs,
            blend,
            mean_radius_m,
            max_radius_m,
            grid,
        });
    }

    /// Number of levels.
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// The blobs of `level`.
    pub fn blobs(&self, level: usize) -> &[Blob] {
        &self.levels[level].blobs
    }

    /// Mean blob radius of `level`, m.
    pub fn mean_radius_m(&self, level: usize) -> f64 {
        self.levels[level].mean_radius_m
    }

    /// f_level at `p` (levels 0..=level all contribute).
    pub fn sample(&self, level: usize, p: DVec3) -> FieldSample {
        let base = if level == 0 {
            None
        } else {
            Some(self.sample(level - 1, p))
        };
        self.sample_on(level, p, base)
    }

    /// f_0 … f_level at `p`, each evaluated once.
    pub fn samples(&self, level: usize, p: DVec3) -> Vec<FieldSample> {
        let mut out: Vec<FieldSample> = Vec::with_capacity(level + 1);
        for l in 0..=level {
            let base = out.last().copied();
            out.push(self.sample_on(l, p, base));
        }
        out
    }

    /// Distance estimate D to S_level from its potential there, m (0
    /// inside): −r̄_level ln f (see the module's documentation).
    pub fn distance_from_potential(&self, level: usize, potential: Dual) -> Dual {
        let r = self.levels[level].mean_radius_m;
        if potential.value >= 1.0 {
            Dual::constant(0.0)
        } else if potential.value <= FAR_POTENTIAL {
            Dual::constant(-r * FAR_POTENTIAL.ln())
        } else {
            potential.ln().scale(-r)
        }
    }

    fn sample_on(&self, level: usize, p: DVec3, base: Option<FieldSample>) -> FieldSample {
        let lv = &self.levels[level];
        let mut best = base.unwrap_or(FieldSample {
            potential: Dual::constant(0.0),
            blob: None,
        });
        if lv.blobs.is_empty() {
            return best;
        }
        // D, the distance to S_{l−1} (for the roots, per blob below).
        let base_distance = base.map(|b| self.distance_from_potential(level - 1, b.potential));
        let blend = lv.blend;

        // g_j for the blobs near p, and the sum of their furrow terms.
        // (index, d_i, g_i, D, the blob's own furrow term).
        let mut near: Vec<(usize, Dual, Dual, Dual, Dual)> = Vec::new();
        let mut furrow_sum = Dual::constant(0.0);
        let reach = INFLUENCE_RADII * lv.max_radius_m;
        lv.grid.for_each_near(p, reach, |id| {
            let blob = &lv.blobs[id as usize];
            let offset = p - blob.centre_m;
            let d = offset.length();
            if d > INFLUENCE_RADII * blob.radius_m {
                return;
            }
            let distance = Dual {
                value: d,
                gradient: if d > 0.0 { offset / d } else { DVec3::ZERO },
            };
            let base_d = match base_distance {
                Some(dist) => dist,
                None => {
                    let above = p.y - blob.centre_m.y;
                    if above > 0.0 {
                        Dual {
                            value: above,
                            gradient: DVec3::Y,
                        }
                    } else {
                        Dual::constant(0.0)
                    }
                }
            };
            // ρ = r − e D, kept above 5 % of r (the blob has no extent
            // there, g ≈ 0, either way).
            let rho = (Dual::constant(blob.radius_m) - base_d.scale(blob.flattening))
                .max(Dual::constant(0.05 * blob.radius_m));
            let g = (Dual::constant(1.0) - distance * rho.recip()).exp();
            let g2 = g * g;
            let furrow =
                (Dual::constant(1.0 - blend.furrow_offset) - g) * g2.min(Dual::constant(1.0));
            furrow_sum = furrow_sum + furrow;
            near.push((id as usize, distance, g, base_d, furrow));
        });
        for &(index, distance, g, base_d, own_furrow) in &near {
            let blob = &lv.blobs[index];
            if distance.value > OWN_REACH_RADII * blob.radius_m * (1.0 + blend.blending) {
                continue;
            }
            let m = furrow_sum - own_furrow;
            let n = if blend.blending != 0.0 {
                (base_d.scale(-blend.blend_sharpness / blob.radius_m) + Dual::constant(1.0)
                    - distance.scale(1.0 / blob.radius_m))
                .exp()
                .scale(blend.blending)
            } else {
                Dual::constant(0.0)
            };
            // o_i = g_i min(0, (y − h₀)/α_h) as the paper writes it, and
            // the same cut on n_i: the paper's o leaves the blending term
            // alone, which lets the blended last level bulge a blob radius
            // below the floor.
            let below = p.y - self.floor.height_m;
            let o = if below < 0.0 {
                (g + n)
                    * Dual {
                        value: below / self.floor.stiffness_m,
                        gradient: DVec3::Y / self.floor.stiffness_m,
                    }
            } else {
                Dual::constant(0.0)
            };
            let f = g + m + n + o;
            if f.value > best.potential.value {
                best = FieldSample {
                    potential: f,
                    blob: Some((level, index)),
                };
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blend(b: f64) -> LevelBlend {
        LevelBlend {
            furrow_offset: 0.5,
            blending: b,
            blend_sharpness: 10.0,
        }
    }

    fn floor() -> Floor {
        Floor {
            height_m: -1e6,
            stiffness_m: 100.0,
        }
    }

    /// One round blob: f = e at its centre, 1 on the sphere of radius r,
    /// exp(1 − d/r) everywhere, symmetric.
    #[test]
    fn single_blob_is_the_pure_exponential_sphere() {
        let mut field = BlobField::new(floor());
        let c = DVec3::new(10.0, 500.0, -20.0);
        field.push_level(
            vec![Blob {
                centre_m: c,
                radius_m: 300.0,
                flattening: 0.0,
            }],
            blend(0.0),
        );
        assert!((field.sample(0, c).potential.value - std::f64::consts::E).abs() < 1e-12);
        for dir in [
            DVec3::X,
            DVec3::Y,
            DVec3::NEG_Z,
            DVec3::new(1.0, 1.0, 1.0).normalize(),
        ] {
            let on = field.sample(0, c + dir * 300.0).potential.value;
            assert!((on - 1.0).abs() < 1e-12, "{on}");
            let half = field.sample(0, c + dir * 150.0).potential.value;
            assert!((half - 0.5f64.exp()).abs() < 1e-12);
        }
    }

    /// A flattened root reaches r/(1 + e) above its centre and r sideways.
    #[test]
    fn root_flattening_shortens_the_top() {
        let mut field = BlobField::new(floor());
        let c = DVec3::new(0.0, 1000.0, 0.0);
        let (r, e) = (300.0, 0.5);
        field.push_level(
            vec![Blob {
                centre_m: c,
                radius_m: r,
                flattening: e,
            }],
            blend(0.0),
        );
        let top = field
            .sample(0, c + DVec3::Y * r / (1.0 + e))
            .potential
            .value;
        let side = field.sample(0, c + DVec3::X * r).potential.value;
        let bottom = field.sample(0, c - DVec3::Y * r).potential.value;
        for v in [top, side, bottom] {
            assert!((v - 1.0).abs() < 1e-9, "{top} {side} {bottom}");
        }
    }

    /// Two blobs closer than the sum of their radii: the furrow term pushes
    /// each surface back (the midpoint is outside though each pure sphere
    /// contains it), the field is symmetric under swapping them, and it is
    /// continuous across the boundary where the maximum switches blob.
    #[test]
    fn furrow_between_two_blobs_symmetry_and_continuity() {
        let mut field = BlobField::new(floor());
        let (a, b) = (DVec3::new(-120.0, 0.0, 0.0), DVec3::new(120.0, 0.0, 0.0));
        let blob = |c| Blob {
            centre_m: c,
            radius_m: 150.0,
            flattening: 0.0,
        };
        field.push_level(vec![blob(a), blob(b)], blend(0.0));
        // Each pure sphere reaches the midpoint (120 < 150) ...
        assert!((1.0 - 120.0f64 / 150.0).exp() > 1.0);
        // ... but the furrow keeps it outside.
        let mid = field.sample(0, DVec3::ZERO).potential.value;
        assert!(mid < 1.0, "{mid}");
        // Mirror symmetry x → −x.
        for p in [DVec3::new(30.0, 40.0, 5.0), DVec3::new(80.0, -60.0, 20.0)] {
            let q = DVec3::new(-p.x, p.y, p.z);
            let (fp, fq) = (field.sample(0, p).potential, field.sample(0, q).potential);
            assert!((fp.value - fq.value).abs() < 1e-12);
            assert!((fp.gradient.x + fq.gradient.x).abs() < 1e-12);
        }
        // Continuity along a line crossing the switching plane x = 0.
        let mut previous = field.sample(0, DVec3::new(-1.0, 50.0, 0.0)).potential.value;
        for i in 1..=200 {
            let x = -1.0 + i as f64 * 0.01;
            let v = field.sample(0, DVec3::new(x, 50.0, 0.0)).potential.value;
            assert!((v - previous).abs() < 1e-3, "jump at x = {x}");
            previous = v;
        }
    }

    /// The analytic gradient equals central differences of the value, on a
    /// two-level field with flattening, blending and the floor all active.
    #[test]
    fn gradient_matches_finite_differences() {
        let mut field = BlobField::new(Floor {
            height_m: 50.0,
            stiffness_m: 100.0,
        });
        field.push_level(
            vec![
                Blob {
                    centre_m: DVec3::new(0.0, 100.0, 0.0),
                    radius_m: 300.0,
                    flattening: 0.4,
                },
                Blob {
                    centre_m: DVec3::new(350.0, 150.0, 80.0),
                    radius_m: 250.0,
                    flattening: 0.8,
                },
            ],
            blend(0.0),
        );
        field.push_level(
            vec![
                Blob {
                    centre_m: DVec3::new(0.0, 330.0, 0.0),
                    radius_m: 100.0,
                    flattening: 0.5,
                },
                Blob {
                    centre_m: DVec3::new(120.0, 300.0, 60.0),
                    radius_m: 90.0,
                    flattening: 0.2,
                },
            ],
            blend(1.0),
        );
        for p in [
            DVec3::new(40.0, 420.0, 10.0),
            DVec3::new(100.0, 380.0, 90.0),
            DVec3::new(300.0, 20.0, 40.0),
        ] {
            let s = field.sample(1, p).potential;
            let h = 1e-4;
            for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
                let numeric = (field.sample(1, p + axis * h).potential.value
                    - field.sample(1, p - axis * h).potential.value)
                    / (2.0 * h);
                let analytic = s.gradient.dot(axis);
                assert!(
                    (numeric - analytic).abs() < 1e-6 * (1.0 + analytic.abs()),
                    "{p}: {numeric} vs {analytic}"
                );
            }
        }
    }

    /// The floor: below h₀ a blob's field is cut by (y − h₀)/α_h, so its
    /// surface ends within α_h (1 − 1/e) of h₀ even for a blob centred on it.
    #[test]
    fn floor_flattens_the_bottom() {
        let floor = Floor {
            height_m: 0.0,
            stiffness_m: 100.0,
        };
        let mut field = BlobField::new(floor);
        field.push_level(
            vec![Blob {
                centre_m: DVec3::ZERO,
                radius_m: 400.0,
                flattening: 0.0,
            }],
            blend(0.0),
        );
        let bound = floor.stiffness_m * (1.0 - (-1.0f64).exp());
        assert!(
            field
                .sample(0, DVec3::new(0.0, -bound - 1.0, 0.0))
                .potential
                .value
                < 1.0
        );
        assert!(field.sample(0, DVec3::new(0.0, -10.0, 0.0)).potential.value > 1.0);
    }
}
