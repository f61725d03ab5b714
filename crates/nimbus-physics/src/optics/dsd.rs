//! Droplet size distributions (DSDs) and the bulk optical properties of a
//! cloud of droplets.
//!
//! Modified gamma DSD (Bouthors, Neyret & Lefebvre 2006, §3, eq. 1; after
//! Deirmendjian): n(r) = N₀ / (Γ(γ) r_n) (r/r_n)^{γ−1} e^{−r/r_n}, with
//! effective radius r_e = ⟨r³⟩/⟨r²⟩ = (γ + 2) r_n; the paper uses
//! N₀ = 300 cm⁻³, γ = 2, r_e = 7 µm. Log-normal DSD:
//! n(r) = N₀ / (√(2π) ln σ_g r) exp(−ln²(r/r_g) / (2 ln² σ_g)), with
//! r_e = r_g exp(2.5 ln² σ_g). n(r) is per m³ per m of radius.
//!
//! Bulk properties integrate the single-sphere Mie quantities over n(r)
//! (Bohren & Huffman §3.4): σ_ext = ∫ Q_ext π r² n dr (m⁻¹), likewise σ_sca,
//! and the phase function p(θ) = ∫ (|S1|² + |S2|²)/(2k²) n dr / σ_sca
//! (sr⁻¹, unit integral over the sphere).
//!
//! Convergence criterion of the radius integral: the trapezoid rule in size
//! parameter over the radii that carry all but a tenth of the tolerance of
//! the cross-section moment ∫ r² n dr on each side, starting at a spacing of
//! ½ and halving (each level adds the midpoints of the last) until σ_ext,
//! σ_sca and g change by less than the tolerance (relative; g absolute) and
//! the phase function changes by less than the tolerance in the L1 norm over
//! the sphere, ∫ |Δp| dΩ (the fraction of scattered energy that moves
//! between angles). σ_sca and g come from the summed intensity itself
//! (σ_sca = 2π ∫ dσ/dΩ dμ and its first moment, exact on the polynomial
//! below), so that they always agree with the phase function.
//!
//! The DSD weight is small and smooth at both ends of the range, so for the
//! smooth part of the integrand — diffraction, fogbow, glory — the
//! trapezoid rule converges faster than any power of the spacing
//! (Euler–Maclaurin). The Mie resonances are not smooth: a water droplet of
//! x ≈ 100 has hundreds of them, with half-widths Γ from 0.3 down to 10⁻⁸ in
//! x (see [`resonance`]), and the trapezoid rule's error on a Lorentzian
//! narrower than the spacing h is of the order of its whole area, whatever
//! the nodes' offset: summed over the resonances narrower than h, an error
//! that falls only as h (it set the spacing, 1/128, and the cost of the
//! paper's case before). So the resonances narrower than
//! `RESONANCE_MAX_WIDTH` are integrated analytically. On a resonance the
//! coefficient is c = λ/(1 − is) with s = (x − x_r)/Γ (λ < 1 with
//! absorption), and the intensity is I⁰ + L/(1 + s²) + D s/(1 + s²) exactly
//! (see [`accumulate_resonance`]), with L and D smooth in x: frozen at the
//! peak, their exact integrals (πΓL and 0) replace their trapezoid sums over
//! the nodes, which have closed forms (`lattice_sums`). The rest of the
//! integrand is smooth and left to the trapezoid rule. The smallest
//! resonances, which together hold less than a thousandth of the tolerance,
//! are left to the grid. Checked against the plain trapezoid rule at 1/8192
//! (tests) and, for the paper's DSD, against the previous plain integration
//! converged to 10⁻⁵ (docs/PERFORMANCE.md).
//!
//! Each droplet's intensity is summed at the Chebyshev–Lobatto points of its
//! size class, where it is an exact polynomial in cos θ (see [`chebyshev`]),
//! so the cost per radius node does not grow with the number of requested
//! angles; the sums are converted to those angles once per level.

use super::angular::{
    IntensityScratch, MirroredAngles, accumulate_intensity, accumulate_resonance,
};
use super::chebyshev;
use super::mie::MieCoefficients;
use super::resonance;
use super::special::ln_gamma;
use num_complex::Complex64;
use rayon::prelude::*;

/// A droplet size distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SizeDistribution {
    /// Modified gamma (Bouthors 2006, eq. 1).
    ModifiedGamma {
        /// Number density N₀, m⁻³.
        number_density_per_m3: f64,
        /// Shape parameter γ > 0.
        gamma: f64,
        /// Effective radius r_e, m.
        effective_radius_m: f64,
    },
    /// Log-normal.
    LogNormal {
        /// Number density N₀, m⁻³.
        number_density_per_m3: f64,
        /// Median radius r_g, m.
        median_radius_m: f64,
        /// Geometric standard deviation σ_g > 1.
        geometric_std: f64,
    },
}

impl SizeDistribution {
    /// The distribution of Bouthors et al. (2006): N₀ = 300 cm⁻³, γ = 2, r_e = 7 µm.
    pub const BOUTHORS_2006: Self = Self::ModifiedGamma {
        number_density_per_m3: 300.0e6,
        gamma: 2.0,
        effective_radius_m: 7.0e-6,
    };

    /// Number density N₀, m⁻³.
    pub fn number_density_per_m3(&self) -> f64 {
        match *self {
            Self::ModifiedGamma {
                number_density_per_m3,
                ..
            }
            | Self::LogNormal {
                number_density_per_m3,
                ..
            } => number_density_per_m3,
        }
    }

    /// n(r), m⁻⁴.
    pub fn density(&self, r_m: f64) -> f64 {
        if r_m <= 0.0 {
            return 0.0;
        }
        match *self {
            Self::ModifiedGamma {
                number_density_per_m3,
                gamma,
                effective_radius_m,
            } => {
                let rn = effective_radius_m / (gamma + 2.0);
                let u = r_m / rn;
                number_density_per_m3 / rn * ((gamma - 1.0) * u.ln() - u - ln_gamma(gamma)).exp()
            }
            Self::LogNormal {
                number_density_per_m3,
                median_radius_m,
                geometric_std,
            } => {
                let s = geometric_std.ln();
                let z = (r_m / median_radius_m).ln() / s;
                number_density_per_m3 / ((2.0 * std::f64::consts::PI).sqrt() * s * r_m)
                    * (-0.5 * z * z).exp()
            }
        }
    }

    /// Effective radius ⟨r³⟩/⟨r²⟩, m.
    pub fn effective_radius_m(&self) -> f64 {
        match *self {
            Self::ModifiedGamma {
                effective_radius_m, ..
            } => effective_radius_m,
            Self::LogNormal {
                median_radius_m,
                geometric_std,
                ..
            } => median_radius_m * (2.5 * geometric_std.ln().powi(2)).exp(),
        }
    }

    /// ∫ r^`power` n(r) dr over all radii (midpoint rule, 20 000 panels
    /// over the range holding all but 10⁻⁹ of the cross section), m^(power−3).
    fn moment(&self, power: i32) -> f64 {
        let (r_lo, r_hi) = self.radius_range_m(1e-9);
        let n = 20_000;
        let h = (r_hi - r_lo) / n as f64;
        (0..n)
            .map(|i| {
                let r = r_lo + (i as f64 + 0.5) * h;
                r.powi(power) * self.density(r)
            })
            .sum::<f64>()
            * h
    }

    /// Liquid water content, kg/m³ (ρ_water = 1000 kg/m³).
    pub fn liquid_water_content_kg_m3(&self) -> f64 {
        1000.0 * 4.0 / 3.0 * std::f64::consts::PI * self.moment(3)
    }

    /// Extinction coefficient in the geometric-optics limit (Q_ext = 2),
    /// 2π ∫ r² n dr, m⁻¹.
    pub fn geometric_extinction_per_m(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.moment(2)
    }

    /// Radii (m) outside which the cross-section moment ∫ r² n dr holds less
    /// than `tail` of its total on each side.
    pub fn radius_range_m(&self, tail: f64) -> (f64, f64) {
        // Tabulate the moment on a wide logarithmic grid around r_e.
        let r_e = self.effective_radius_m();
        let (lo, hi) = (r_e * 1e-4, r_e * 60.0);
        let n = 4000;
        let ratio = (hi / lo).ln() / n as f64;
        let radii: Vec<f64> = (0..=n).map(|i| lo * (ratio * i as f64).exp()).collect();
        let mut cumulative = vec![0.0; n + 1];
        for i in 1..=n {
            let (a, b) = (radii[i - 1], radii[i]);
            let w = |r: f64| r * r * self.density(r);
            cumulative[i] = cumulative[i - 1] + 0.5 * (w(a) + w(b)) * (b - a);
        }
        let total = cumulative[n];
        let first = cumulative
            .iter()
            .position(|c| *c > tail * total)
            .unwrap_or(0);
        let last = cumulative
            .iter()
            .position(|c| *c >= (1.0 - tail) * total)
            .unwrap_or(n);
        (radii[first.saturating_sub(1)], radii[(last + 1).min(n)])
    }
}

/// Bulk optical properties of a droplet population at one wavelength.
#[derive(Clone, Debug)]
pub struct BulkOptics {
    /// Vacuum wavelength, nm.
    pub wavelength_nm: f64,
    /// Extinction coefficient κ, m⁻¹.
    pub extinction_per_m: f64,
    /// Scattering coefficient, m⁻¹.
    pub scattering_per_m: f64,
    /// Asymmetry parameter g.
    pub g: f64,
    /// Scattering angles, degrees.
    pub angles_deg: Vec<f64>,
    /// Phase function at those angles, sr⁻¹, unit integral over the sphere.
    pub phase: Vec<f64>,
    /// Radius nodes of the converged integral.
    pub radius_intervals: usize,
    /// The convergence measure at the last refinement (see the module
    /// documentation): at most the tolerance unless the node limit was hit.
    pub last_change: f64,
    /// The phase function on a fine grid (0.05° steps) from 0° to
    /// [`FORWARD_TABLE_END_DEG`], computed with the requested angles so that
    /// forward-peak fractions do not depend on how coarse those are.
    pub forward_table: super::phase::PhaseTable,
}

/// End of the fine forward table, degrees.
pub const FORWARD_TABLE_END_DEG: f64 = 15.0;
const FORWARD_TABLE_STEP_DEG: f64 = 0.05;

impl BulkOptics {
    /// Single-scattering albedo σ_sca / σ_ext.
    pub fn single_scattering_albedo(&self) -> f64 {
        self.scattering_per_m / self.extinction_per_m
    }

    /// Photon mean free path 1/κ, m.
    pub fn mean_free_path_m(&self) -> f64 {
        1.0 / self.extinction_per_m
    }

    /// Fraction of scattered light within θ_f of the forward direction
    /// (θ_f ≤ [`FORWARD_TABLE_END_DEG`]), from the fine forward table; the
    /// phase function is normalised by σ_sca, so the whole sphere holds 1.
    pub fn forward_fraction(&self, theta_f_deg: f64) -> f64 {
        self.forward_table
            .integral_between(0.0, theta_f_deg.min(FORWARD_TABLE_END_DEG))
    }
}

/// Running sums of the radius integral.
#[derive(Clone)]
struct Sums {
    extinction: f64,
    /// Per size class, the weighted sum of |S1|² + |S2|² / (2k²) at its
    /// Lobatto points (empty until a droplet of that class is added).
    intensity_samples: Vec<Vec<f64>>,
}

impl Sums {
    fn zero(classes: usize) -> Self {
        Self {
            extinction: 0.0,
            intensity_samples: vec![Vec::new(); classes],
        }
    }

    fn add(mut self, other: &Self) -> Self {
        self.extinction += other.extinction;
        for (mine, theirs) in self
            .intensity_samples
            .iter_mut()
            .zip(&other.intensity_samples)
        {
            if mine.is_empty() {
                mine.clone_from(theirs);
            } else if !theirs.is_empty() {
                for (a, b) in mine.iter_mut().zip(theirs) {
                    *a += b;
                }
            }
        }
        self
    }

    /// The samples of class `class`, allocated on first use.
    fn samples_mut(&mut self, class: usize, points: usize) -> &mut Vec<f64> {
        let samples = &mut self.intensity_samples[class];
        if samples.is_empty() {
            samples.resize(points, 0.0);
        }
        samples
    }

    /// Chebyshev coefficients of Σ over the nodes of weight · (|S1|² + |S2|²)
    /// as a polynomial in μ.
    fn differential(&self) -> Vec<f64> {
        let mut planner = rustfft::FftPlanner::new();
        let mut total: Vec<f64> = Vec::new();
        for samples in self.intensity_samples.iter().filter(|s| !s.is_empty()) {
            let coefficients = chebyshev::coefficients_from_lobatto(samples, &mut planner);
            if total.len() < coefficients.len() {
                total.resize(coefficients.len(), 0.0);
            }
            for (t, c) in total.iter_mut().zip(&coefficients) {
                *t += c;
            }
        }
        total
    }

    /// [`Self::differential`] at the cosines `mu`.
    #[cfg(test)]
    fn differential_at(&self, mu: &[f64]) -> Vec<f64> {
        let total = self.differential();
        mu.iter()
            .map(|&mu| chebyshev::evaluate(&total, mu))
            .collect()
    }
}

/// The Lobatto grids of the size classes. The intensity of a droplet whose
/// series has N orders is a polynomial of degree 2N in μ (see
/// [`chebyshev`]); class q holds the droplets with 2N ≤ M_q = 32q − 2, so its
/// M_q + 1 points are exactly 16q distinct |μ| (whole blocks of the angular
/// kernel) and no droplet is sampled on more than 32 points beyond what it
/// needs.
struct LobattoGrids {
    angles: Vec<MirroredAngles>,
}

impl LobattoGrids {
    fn new(max_series_length: usize) -> Self {
        let classes = Self::class_of(max_series_length) + 1;
        let angles = (0..classes)
            .map(|q| MirroredAngles::new(&chebyshev::lobatto_points(Self::points_minus_one(q))))
            .collect();
        Self { angles }
    }

    /// M_q.
    fn points_minus_one(class: usize) -> usize {
        32 * (class + 1) - 2
    }

    /// The smallest class q with M_q ≥ 2N.
    fn class_of(series_length: usize) -> usize {
        (2 * series_length + 2).div_ceil(32).max(1) - 1
    }

    fn len(&self) -> usize {
        self.angles.len()
    }
}

/// Adds the integrand at the size parameters `nodes` (each with its
/// trapezoid weight, 1 or ½ at the ends) to a sum over radius; the caller
/// multiplies by the node spacing.
fn integrate(
    dsd: &SizeDistribution,
    k: f64,
    m: Complex64,
    grids: &LobattoGrids,
    nodes: &[(f64, f64)],
) -> Sums {
    nodes
        .par_iter()
        .fold(
            || (Sums::zero(grids.len()), IntensityScratch::default()),
            |(mut sums, mut scratch), &(x, node_weight)| {
                let r = x / k;
                // dr = dx / k.
                let w = node_weight / k * dsd.density(r);
                if w <= 0.0 || x <= 0.0 {
                    return (sums, scratch);
                }
                let c = MieCoefficients::new(x, m);
                let area = std::f64::consts::PI * r * r;
                sums.extinction += w * c.efficiencies().q_ext * area;
                let class = LobattoGrids::class_of(c.a.len());
                let angles = &grids.angles[class];
                let samples = sums.samples_mut(class, angles.len());
                accumulate_intensity(&c.a, &c.b, angles, w / (2.0 * k * k), &mut scratch, samples);
                (sums, scratch)
            },
        )
        .map(|(sums, _)| sums)
        .reduce(|| Sums::zero(grids.len()), |a, b| a.add(&b))
}

/// What the trapezoid rule of each refinement level misses on the
/// resonances narrower than [`RESONANCE_MAX_WIDTH`] (see the module
/// documentation), in the units of the node sums: for level j (spacing
/// `first_spacing` / 2^j, nodes at `x_lo` + i · spacing) the exact integral
/// of each resonance's Lorentzian and dispersive parts less their lattice
/// sums over the nodes, divided by the spacing.
#[allow(clippy::too_many_arguments)]
fn resonance_corrections(
    dsd: &SizeDistribution,
    k: f64,
    m: Complex64,
    grids: &LobattoGrids,
    x_lo: f64,
    x_hi: f64,
    first_spacing: f64,
    levels: usize,
    tolerance: f64,
) -> Vec<Sums> {
    let found = resonances_to_correct(dsd, k, m.re, x_lo, x_hi, tolerance);
    let empty = || vec![Sums::zero(grids.len()); levels];
    found
        .par_iter()
        .fold(
            || (empty(), IntensityScratch::default(), Vec::new(), Vec::new()),
            |(mut levels, mut scratch, mut lorentzian, mut dispersive), r| {
                let n = r.order;
                let density = dsd.density(r.size_parameter / k) / k;
                let c = MieCoefficients::new(r.size_parameter, m);
                if density <= 0.0 || n > c.a.len() {
                    return (levels, scratch, lorentzian, dispersive);
                }
                let value = match r.coefficient {
                    resonance::Coefficient::A => c.a[n - 1],
                    resonance::Coefficient::B => c.b[n - 1],
                };
                // With absorption 1/c = 1 + ε − i t: the peak is lowered to
                // λ = 1/(1 + ε) and widened by 1 + ε; t(x_r) = t₀ moves it.
                let inverse = 1.0 / value - 1.0;
                let (epsilon, t0) = (inverse.re, -inverse.im);
                if !(epsilon > -0.5 && epsilon.is_finite() && t0.is_finite()) {
                    return (levels, scratch, lorentzian, dispersive);
                }
                let damping = 1.0 / (1.0 + epsilon);
                let centre = r.size_parameter - t0 * r.width;
                let width = r.width / damping;
                let class = LobattoGrids::class_of(c.a.len());
                let angles = &grids.angles[class];
                lorentzian.clear();
                lorentzian.resize(angles.len(), 0.0);
                dispersive.clear();
                dispersive.resize(angles.len(), 0.0);
                accumulate_resonance(
                    &c.a,
                    &c.b,
                    n,
                    r.coefficient,
                    damping,
                    angles,
                    density / (2.0 * k * k),
                    &mut scratch,
                    &mut lorentzian,
                    &mut dispersive,
                );
                // Re c = λ/(1 + s²): the extinction's Lorentzian
                // (Q_ext = (2/x²) Σ (2n + 1) Re(a_n + b_n), πr² · 2/x² = 2π/k²).
                let extinction =
                    damping * density * 2.0 * std::f64::consts::PI * (2 * n + 1) as f64 / (k * k);
                for (level, sums) in levels.iter_mut().enumerate() {
                    let spacing = first_spacing / (1u64 << level) as f64;
                    let (lattice_l, lattice_d) =
                        lattice_sums((x_lo - centre) / spacing, width / spacing);
                    let b = width.abs() / spacing;
                    let missed_l = std::f64::consts::PI * b - lattice_l;
                    let missed_d = -lattice_d;
                    sums.extinction += missed_l * extinction;
                    let samples = sums.samples_mut(class, angles.len());
                    for ((s, l), d) in samples.iter_mut().zip(&lorentzian).zip(&dispersive) {
                        *s += missed_l * l + missed_d * d;
                    }
                }
                (levels, scratch, lorentzian, dispersive)
            },
        )
        .map(|(levels, ..)| levels)
        .reduce(empty, |a, b| {
            a.into_iter().zip(&b).map(|(a, b)| a.add(b)).collect()
        })
}

/// The resonances whose trapezoid error [`resonance_corrections`] removes:
/// those up to [`RESONANCE_MAX_WIDTH`], less the smallest ones, as many as
/// together hold a thousandth of the tolerance of the cross section (the
/// areas of their Lorentzians in σ_sca, against the geometric-optics σ; the
/// grid's error on each is of the order of its area). The scan's estimates
/// choose, so that only the kept ones are refined; the estimates' areas are
/// doubled to cover their error.
fn resonances_to_correct(
    dsd: &SizeDistribution,
    k: f64,
    m: f64,
    x_lo: f64,
    x_hi: f64,
    tolerance: f64,
) -> Vec<resonance::Resonance> {
    let area = |r: &resonance::Resonance| {
        std::f64::consts::PI * r.width.abs() * dsd.density(r.size_parameter / k) / k
            * 2.0
            * std::f64::consts::PI
            * (2 * r.order + 1) as f64
            / (k * k)
    };
    let mut candidates: Vec<(f64, resonance::Bracket)> = resonance::brackets(m, x_lo, x_hi)
        .into_iter()
        .filter_map(|b| {
            let estimate = b.estimate();
            (estimate.width.abs() <= 2.0 * RESONANCE_MAX_WIDTH).then(|| (2.0 * area(&estimate), b))
        })
        .collect();
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
    let budget = 1e-3 * tolerance * dsd.geometric_extinction_per_m();
    let mut skipped = 0.0;
    let first_kept = candidates
        .iter()
        .position(|(area, _)| {
            skipped += area;
            skipped > budget
        })
        .unwrap_or(candidates.len());
    candidates[first_kept..]
        .par_iter()
        .filter_map(|(_, b)| b.refine(m))
        .filter(|r| r.width.abs() <= RESONANCE_MAX_WIDTH)
        .collect()
}

/// Σ_i 1/(1 + t_i²) and Σ_i t_i/(1 + t_i²) over all integers i, for
/// t_i = (i + `offset`)/`width` (width in node spacings, signed): the
/// trapezoid rule of a Lorentzian and of its dispersive partner, in closed
/// form from π cot(π(a + ib)) = Σ 1/(i + a + ib):
///
///   Σ 1/(1 + t²) = πb sinh 2πb / (cosh 2πb − cos 2πa),
///   Σ t/(1 + t²) = ±πb sin 2πa / (cosh 2πb − cos 2πa),
///
/// with b = |width|, a the offset's fractional part, written with
/// q = e^{−2πb} so that neither overflows nor cancels.
fn lattice_sums(offset: f64, width: f64) -> (f64, f64) {
    use std::f64::consts::PI;
    let a = offset - offset.floor();
    let b = width.abs();
    let q = (-2.0 * PI * b).exp();
    let one_minus_q = -(-2.0 * PI * b).exp_m1();
    let sin_pa = (PI * a).sin();
    // cosh 2πb − cos 2πa = ((1 − q)² + 4q sin² πa) / (2q).
    let denominator = one_minus_q * one_minus_q + 4.0 * q * sin_pa * sin_pa;
    let lorentzian = PI * b * one_minus_q * (1.0 + q) / denominator;
    let dispersive = width.signum() * PI * b * 2.0 * q * (2.0 * PI * a).sin() / denominator;
    (lorentzian, dispersive)
}

/// Resonances up to this half-width (in size parameter) are integrated
/// analytically; broader ones are left to the trapezoid rule, whose error on
/// a Lorentzian of half-width Γ falls as 2 e^{−2πΓ/h}.
const RESONANCE_MAX_WIDTH: f64 = 0.25;

/// Solid-angle weights of the angles (trapezoid rule in θ, 2π sin θ dθ), for
/// the L1 norm of the convergence test.
fn solid_angle_weights(angles_deg: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..angles_deg.len()).collect();
    order.sort_by(|a, b| angles_deg[*a].total_cmp(&angles_deg[*b]));
    let mut weights = vec![0.0; angles_deg.len()];
    for pair in order.windows(2) {
        let (a, b) = (
            angles_deg[pair[0]].to_radians(),
            angles_deg[pair[1]].to_radians(),
        );
        let half = 0.5 * (b - a) * 2.0 * std::f64::consts::PI;
        weights[pair[0]] += half * a.sin();
        weights[pair[1]] += half * b.sin();
    }
    weights
}

/// Integrates the Mie quantities over the DSD at one wavelength (nm, in
/// vacuum; the droplets in air) for refractive index `m`, at the scattering
/// angles `angles_deg`, to relative tolerance `tolerance` (see the module
/// documentation for the criterion).
pub fn bulk_optics(
    dsd: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    angles_deg: &[f64],
    tolerance: f64,
) -> BulkOptics {
    bulk_optics_observed(dsd, wavelength_nm, m, angles_deg, tolerance, &mut |_| {})
}

/// [`bulk_optics`], reporting the number of radius nodes of each refinement
/// level to `on_level` as it starts (for progress display).
pub fn bulk_optics_observed(
    dsd: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    angles_deg: &[f64],
    tolerance: f64,
    on_level: &mut dyn FnMut(usize),
) -> BulkOptics {
    let k = 2.0 * std::f64::consts::PI / (wavelength_nm * 1e-9);
    // The requested angles, then the fine forward grid.
    let forward_count = (FORWARD_TABLE_END_DEG / FORWARD_TABLE_STEP_DEG).round() as usize + 1;
    let forward_angles: Vec<f64> = (0..forward_count)
        .map(|i| i as f64 * FORWARD_TABLE_STEP_DEG)
        .collect();
    let all_angles: Vec<f64> = angles_deg.iter().chain(&forward_angles).copied().collect();
    let mu: Vec<f64> = all_angles.iter().map(|a| a.to_radians().cos()).collect();
    let solid_angle = solid_angle_weights(angles_deg);
    // Droplets outside the range carry at most a tenth of the tolerance of
    // the cross-section moment on each side, so leaving them out moves σ and
    // the normalised phase function (L1) by at most 0.4 × tolerance.
    let (r_lo, r_hi) = dsd.radius_range_m((0.1 * tolerance).clamp(1e-12, 1e-3));
    let (x_lo, x_hi) = (r_lo * k, r_hi * k);
    let grids = LobattoGrids::new(super::mie::series_length(x_hi));
    // Nested trapezoid rule in size parameter, starting at a spacing of ½:
    // each level adds the midpoints of the last, so no node is computed twice.
    let mut intervals = (((x_hi - x_lo) / INITIAL_SPACING).ceil() as usize).max(4);
    let mut spacing = (x_hi - x_lo) / intervals as f64;
    let first: Vec<(f64, f64)> = (0..=intervals)
        .map(|i| {
            let end = i == 0 || i == intervals;
            (x_lo + spacing * i as f64, if end { 0.5 } else { 1.0 })
        })
        .collect();
    on_level(first.len());
    let mut raw = integrate(dsd, k, m, &grids, &first);
    let levels = (MAX_INTERVALS / intervals).max(1).ilog2() as usize + 1;
    let corrections =
        resonance_corrections(dsd, k, m, &grids, x_lo, x_hi, spacing, levels, tolerance);
    // Bulk values and the phase function at all angles (requested, then
    // forward table) of refinement level `level`.
    let finish = |raw: &Sums, spacing: f64, level: usize| {
        let total = raw.clone().add(&corrections[level.min(levels - 1)]);
        let differential = total.differential();
        // σ_sca = ∫ dσ/dΩ dΩ = 2π ∫ p(μ) dμ, and g its first moment.
        let scattering = 2.0 * std::f64::consts::PI * chebyshev::integral(&differential);
        let g = 2.0 * std::f64::consts::PI * chebyshev::first_moment(&differential) / scattering;
        let phase: Vec<f64> = mu
            .iter()
            .map(|&mu| chebyshev::evaluate(&differential, mu) / scattering)
            .collect();
        (total.extinction * spacing, scattering * spacing, g, phase)
    };
    let mut level = 0;
    let mut previous = finish(&raw, spacing, level);
    loop {
        let midpoints: Vec<(f64, f64)> = (0..intervals)
            .map(|i| (x_lo + spacing * (i as f64 + 0.5), 1.0))
            .collect();
        intervals *= 2;
        spacing *= 0.5;
        on_level(intervals + 1);
        raw = raw.add(&integrate(dsd, k, m, &grids, &midpoints));
        level += 1;
        let current = finish(&raw, spacing, level);
        let relative = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
        let moved: f64 = current.3[..angles_deg.len()]
            .iter()
            .zip(&previous.3)
            .zip(&solid_angle)
            .map(|((a, b), w)| (a - b).abs() * w)
            .sum();
        let total: f64 = current.3[..angles_deg.len()]
            .iter()
            .zip(&solid_angle)
            .map(|(a, w)| a * w)
            .sum();
        let change = relative(current.0, previous.0)
            .max(relative(current.1, previous.1))
            .max((current.2 - previous.2).abs())
            .max(moved / total.max(1e-300));
        if change <= tolerance || intervals >= MAX_INTERVALS {
            let (extinction_per_m, scattering_per_m, g, mut phase) = current;
            let forward_values = phase.split_off(angles_deg.len());
            return BulkOptics {
                forward_table: super::phase::PhaseTable::new(forward_angles, forward_values),
                wavelength_nm,
                extinction_per_m,
                scattering_per_m,
                g,
                angles_deg: angles_deg.to_vec(),
                phase,
                radius_intervals: intervals + 1,
                last_change: change,
            };
        }
        previous = current;
    }
}

/// First spacing of the trapezoid rule, in size parameter.
const INITIAL_SPACING: f64 = 0.5;

/// Most intervals of the trapezoid rule: past about 10⁶ nodes the result is
/// returned with its `last_change` above the tolerance.
const MAX_INTERVALS: usize = 1 << 20;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::water::water_refractive_index;

    #[test]
    fn lobatto_sums_equal_the_direct_series_at_any_angle() {
        // The size-class sums, converted to arbitrary angles, equal the
        // weighted sum of |S1|² + |S2|² from the plain recurrence (Bohren &
        // Huffman eq. 4.74) at every angle, forward peak and glory included.
        let dsd = SizeDistribution::BOUTHORS_2006;
        let m = water_refractive_index(550.0);
        let k = 2.0 * std::f64::consts::PI / 550.0e-9;
        let nodes: Vec<(f64, f64)> = [0.3, 4.7, 61.2, 180.9, 402.5]
            .iter()
            .map(|&x| (x, 1.0))
            .collect();
        let grids = LobattoGrids::new(crate::optics::mie::series_length(402.5));
        let sums = integrate(&dsd, k, m, &grids, &nodes);
        let angles_deg = [0.0, 0.05, 0.7, 3.3, 17.0, 90.0, 139.5, 179.2, 180.0];
        let mu: Vec<f64> = angles_deg
            .iter()
            .map(|a: &f64| a.to_radians().cos())
            .collect();
        let lobatto = sums.differential_at(&mu);
        let mut direct = vec![0.0; mu.len()];
        for &(x, _) in &nodes {
            let w = dsd.density(x / k) / k / (2.0 * k * k);
            let c = MieCoefficients::new(x, m);
            for (d, (s1, s2)) in direct.iter_mut().zip(c.amplitudes(&mu)) {
                *d += w * (s1.norm_sqr() + s2.norm_sqr());
            }
        }
        for (i, (a, b)) in lobatto.iter().zip(&direct).enumerate() {
            assert!((a / b - 1.0).abs() < 1e-9, "{}°: {a} vs {b}", angles_deg[i]);
        }
    }

    /// With the resonances integrated analytically, a coarse grid agrees
    /// with the plain trapezoid rule on a grid twenty and more times finer
    /// (spacing 1/8192 in x: its error from the resonances narrower than
    /// that, of the order of their area, is below 10⁻⁶ here).
    #[test]
    fn resonance_corrections_match_a_fine_plain_integral() {
        let dsd = SizeDistribution::LogNormal {
            number_density_per_m3: 1.0e8,
            median_radius_m: 2.0e-6,
            geometric_std: 1.3,
        };
        let wavelength_nm = 550.0;
        let m = water_refractive_index(wavelength_nm);
        let k = 2.0 * std::f64::consts::PI / (wavelength_nm * 1e-9);
        let angles: Vec<f64> = (0..=720).map(|i| i as f64 * 0.25).collect();
        let tolerance = 1e-5;
        let optics = bulk_optics(&dsd, wavelength_nm, m, &angles, tolerance);
        // The plain rule over the same radii.
        let (r_lo, r_hi) = dsd.radius_range_m(0.1 * tolerance);
        let (x_lo, x_hi) = (r_lo * k, r_hi * k);
        let intervals = ((x_hi - x_lo) * 8192.0).ceil() as usize;
        let spacing = (x_hi - x_lo) / intervals as f64;
        let nodes: Vec<(f64, f64)> = (0..=intervals)
            .map(|i| {
                let end = i == 0 || i == intervals;
                (x_lo + spacing * i as f64, if end { 0.5 } else { 1.0 })
            })
            .collect();
        let grids = LobattoGrids::new(crate::optics::mie::series_length(x_hi));
        let sums = integrate(&dsd, k, m, &grids, &nodes);
        let differential = sums.differential();
        let scattering = 2.0 * std::f64::consts::PI * chebyshev::integral(&differential);
        let extinction = sums.extinction * spacing;
        let g = 2.0 * std::f64::consts::PI * chebyshev::first_moment(&differential) / scattering;
        assert!(
            (optics.extinction_per_m / extinction - 1.0).abs() < 2e-6,
            "σ_ext {} vs {extinction}",
            optics.extinction_per_m
        );
        assert!(
            (optics.scattering_per_m / (scattering * spacing) - 1.0).abs() < 2e-6,
            "σ_sca {} vs {}",
            optics.scattering_per_m,
            scattering * spacing
        );
        assert!((optics.g - g).abs() < 2e-6, "g {} vs {g}", optics.g);
        let weights = solid_angle_weights(&angles);
        let moved: f64 = angles
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let reference =
                    chebyshev::evaluate(&differential, a.to_radians().cos()) / scattering;
                (optics.phase[i] - reference).abs() * weights[i]
            })
            .sum();
        assert!(
            moved < 2e-5,
            "L1 {moved}, {} radius nodes",
            optics.radius_intervals
        );
        assert!(
            optics.radius_intervals < intervals / 100,
            "{}",
            optics.radius_intervals
        );
    }

    /// The closed forms of the lattice sums equal the sums themselves, for
    /// resonances far narrower than the spacing, comparable and far wider,
    /// with a node on the peak, near it and halfway.
    #[test]
    fn lattice_sums_match_direct_summation() {
        for width in [1e-9, -3e-4, 0.07, -0.5, 2.0, 9.0] {
            for offset in [0.0, 1e-7, 0.13, 0.5, -2.71] {
                let (l, d) = lattice_sums(offset, width);
                // Pairs ±i together so that the slow 1/i tails cancel; the
                // Lorentzian's tail beyond ±N adds 2Γ²/N.
                let terms = 2_000_000i64;
                let (mut l_direct, mut d_direct) = (2.0 * width * width / terms as f64, 0.0);
                for i in 0..terms {
                    for j in if i == 0 { vec![0] } else { vec![i, -i] } {
                        let t = (j as f64 + offset) / width;
                        l_direct += 1.0 / (1.0 + t * t);
                        d_direct += t / (1.0 + t * t);
                    }
                }
                let scale = 1.0 + l_direct.abs();
                assert!(
                    (l - l_direct).abs() < 1e-6 * scale,
                    "Γ {width} a {offset}: {l} vs {l_direct}"
                );
                assert!(
                    (d - d_direct).abs() < 1e-6 * scale,
                    "Γ {width} a {offset}: {d} vs {d_direct}"
                );
            }
        }
    }

    #[test]
    fn distributions_are_normalised_with_the_stated_effective_radius() {
        let dists = [
            SizeDistribution::BOUTHORS_2006,
            SizeDistribution::LogNormal {
                number_density_per_m3: 1.0e8,
                median_radius_m: 5.0e-6,
                geometric_std: 1.4,
            },
        ];
        for dsd in dists {
            let (lo, hi) = (1e-9, 200e-6);
            let n = 200_000;
            let h = (hi - lo) / n as f64;
            let (mut m0, mut m2, mut m3) = (0.0, 0.0, 0.0);
            for i in 0..n {
                let r = lo + (i as f64 + 0.5) * h;
                let v = dsd.density(r) * h;
                m0 += v;
                m2 += v * r * r;
                m3 += v * r * r * r;
            }
            assert!(
                (m0 / dsd.number_density_per_m3() - 1.0).abs() < 1e-4,
                "{dsd:?}: N {m0}"
            );
            assert!(
                (m3 / m2 / dsd.effective_radius_m() - 1.0).abs() < 1e-4,
                "{dsd:?}: r_e {}",
                m3 / m2
            );
        }
    }

    #[test]
    fn bouthors_cloud_has_the_expected_liquid_water_and_extinction() {
        // LWC = (4/3)π ρ N₀ r_n³ Γ(γ+3)/Γ(γ) = 0.16 g/m³ for N₀ = 300 cm⁻³,
        // γ = 2, r_e = 7 µm. Geometric optics (Q_ext = 2) gives
        // κ = 3 LWC / (2 ρ r_e) = 0.035 m⁻¹; Mie's Q_ext exceeds 2 by the edge
        // term ≈ 2 x^{−2/3} (van de Hulst 1957, §17.3), a few percent here.
        // (Bouthors 2006, §3, takes σ = π r_e² per droplet, κ = N₀ π r_e²
        // = 0.046 m⁻¹, "20 m" mean free path: a rougher estimate.)
        let dsd = SizeDistribution::BOUTHORS_2006;
        let lwc = dsd.liquid_water_content_kg_m3();
        let rn: f64 = 7.0e-6 / 4.0;
        let expected =
            1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 300.0e6 * rn.powi(3) * 24.0 / 1.0;
        assert!((lwc / expected - 1.0).abs() < 1e-3, "{lwc} vs {expected}");
        let angles: Vec<f64> = (0..=36).map(|i| i as f64 * 5.0).collect();
        let optics = bulk_optics(&dsd, 550.0, water_refractive_index(550.0), &angles, 1e-3);
        let geometric = 3.0 * lwc / (2.0 * 1000.0 * 7.0e-6);
        let ratio = optics.extinction_per_m / geometric;
        assert!(
            (1.02..1.10).contains(&ratio),
            "{} vs {geometric}",
            optics.extinction_per_m
        );
        assert!(optics.single_scattering_albedo() > 0.99999);
        // g ≈ 0.85 for cloud droplets in the visible (Hansen & Travis 1974, fig. 12).
        assert!((0.84..0.87).contains(&optics.g), "g {}", optics.g);
    }
}
