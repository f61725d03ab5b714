//! Morphology-dependent resonances of the Mie coefficients.
//!
//! For a real refractive index m > 1 each coefficient can be written
//! a_n = 1 / (1 − i t_n(x)) with t_n real (Bohren & Huffman 1983, eq. 4.88
//! with ξ_n = ψ_n − iχ_n: a_n = N/(N − iC), t = C/N, both real), and
//! likewise b_n. Where t_n crosses zero the coefficient reaches 1: a
//! resonance, |a_n|² = 1/(1 + t²) a Lorentzian in x of half-width
//! Γ = 1/|t'(x_r)|. Below x ≈ n the centrifugal barrier traps the wave and
//! Γ falls exponentially with n − x (Chýlek 1976; Johnson, JOSA A 10, 1993),
//! so a water droplet has thousands of resonances far narrower than any
//! affordable radius grid.
//!
//! They are located as the zeros of smooth functions: t_n = 0 where C = 0,
//! i.e. where the logarithmic derivatives of the inside and outside fields
//! match,
//!
//!   F_a(x) = D_n(mx) − m G_n(x) = 0,   F_b(x) = m D_n(mx) − G_n(x) = 0,
//!
//! with D_n = ψ_n'/ψ_n (argument mx) and G_n = χ_n'/χ_n (argument x). F has
//! poles where ψ_n(mx) = 0 (F rises through them) and crosses zero falling
//! between them: from the Riccati equations D' = n(n+1)/z² − 1 − D² and
//! G' = n(n+1)/x² − 1 − G², at a zero F_a' = −(m − 1/m)(n(n+1)/x² + D²) and
//! F_b' = 1 − m², both negative for m > 1. So a falling sign change on a
//! grid much finer than the pole spacing (π/m in x) brackets each zero once,
//! however narrow the resonance.

use super::mie::series_length;
use rayon::prelude::*;

/// Which coefficient resonates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coefficient {
    /// a_n (transverse magnetic modes).
    A,
    /// b_n (transverse electric modes).
    B,
}

/// One resonance of the Mie coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resonance {
    /// Order n (1-based).
    pub order: usize,
    /// Which coefficient.
    pub coefficient: Coefficient,
    /// Size parameter of the peak, x_r.
    pub size_parameter: f64,
    /// Signed width Γ = 1/t'(x_r): near the peak t ≈ (x − x_r)/Γ.
    pub width: f64,
}

/// The matching functions of one order at one size parameter.
#[derive(Clone, Copy, Debug, Default)]
struct Matching {
    /// F_a, dF_a/dx and m N_a / (χ_n F_a'), the width where F_a = 0.
    f_a: f64,
    slope_a: f64,
    width_a: f64,
    /// F_b, dF_b/dx and N_b / (χ_n F_b').
    f_b: f64,
    slope_b: f64,
    width_b: f64,
    /// χ_n(x).
    chi: f64,
}

impl Matching {
    /// F, F' and the width function of one coefficient.
    fn of(&self, coefficient: Coefficient) -> (f64, f64, f64) {
        match coefficient {
            Coefficient::A => (self.f_a, self.slope_a, self.width_a),
            Coefficient::B => (self.f_b, self.slope_b, self.width_b),
        }
    }

    /// The functions of order n from D_n(mx) and the Riccati–Bessel
    /// functions at x. The width: with the numerator N = αψ_n − ψ_{n−1} of
    /// the coefficient (α = D_n/m + n/x for a_n, m D_n + n/x for b_n) and
    /// C = αχ_n − χ_{n−1} = χ_n F_a/m or χ_n F_b, t = C/N, so where F = 0,
    /// t' = χ_n F'/(m N) or χ_n F'/N.
    #[allow(clippy::too_many_arguments)]
    fn new(
        x: f64,
        m: f64,
        n: usize,
        dn: f64,
        psi: f64,
        psi_prev: f64,
        chi: f64,
        chi_prev: f64,
    ) -> Self {
        let nf = n as f64;
        let mx = m * x;
        let g = chi_prev / chi - nf / x;
        let centrifugal = nf * (nf + 1.0);
        let d_slope = centrifugal / (mx * mx) - 1.0 - dn * dn;
        let g_slope = centrifugal / (x * x) - 1.0 - g * g;
        let slope_a = m * (d_slope - g_slope);
        let slope_b = m * m * d_slope - g_slope;
        let numerator_a = (dn / m + nf / x) * psi - psi_prev;
        let numerator_b = (m * dn + nf / x) * psi - psi_prev;
        Self {
            f_a: dn - m * g,
            slope_a,
            width_a: m * numerator_a / (chi * slope_a),
            f_b: m * dn - g,
            slope_b,
            width_b: numerator_b / (chi * slope_b),
            chi,
        }
    }
}

/// Start of the downward recurrence of D_n(mx), as in `MieCoefficients::new`.
fn recurrence_start(x: f64, m: f64, orders: usize) -> usize {
    let mx = m * x;
    orders.max(series_length(x)).max(mx.ceil() as usize) + 16 + (8.0 * mx.cbrt()).ceil() as usize
}

/// The matching functions for orders 1..=`orders` at size parameter `x`:
/// D_n(mx) by downward recurrence, ψ_n and χ_n upward (as in
/// [`MieCoefficients::new`], so that widths are those of the coefficients
/// the radius integral sums; χ grows with n beyond x, which keeps its
/// recurrence stable).
#[allow(clippy::needless_range_loop)] // n is the order in every formula.
fn matching_functions(x: f64, m: f64, orders: usize) -> Vec<Matching> {
    let mx = m * x;
    let n_start = recurrence_start(x, m, orders);
    let mut d = vec![0.0; n_start + 1];
    for n in (1..=n_start).rev() {
        let n_over_mx = n as f64 / mx;
        d[n - 1] = n_over_mx - 1.0 / (d[n] + n_over_mx);
    }
    let (mut psi_prev2, mut psi_prev) = (x.cos(), x.sin());
    let (mut chi_prev2, mut chi_prev) = (-x.sin(), x.cos());
    let mut out = Vec::with_capacity(orders);
    for n in 1..=orders {
        let factor = (2.0 * n as f64 - 1.0) / x;
        let psi = factor * psi_prev - psi_prev2;
        let chi = factor * chi_prev - chi_prev2;
        out.push(Matching::new(x, m, n, d[n], psi, psi_prev, chi, chi_prev));
        (psi_prev2, psi_prev) = (psi_prev, psi);
        (chi_prev2, chi_prev) = (chi_prev, chi);
    }
    out
}

/// [`matching_functions`] for the one order `order`, without storage.
fn matching_function(x: f64, m: f64, order: usize) -> Matching {
    let mx = m * x;
    let mut dn = 0.0;
    for n in (order + 1..=recurrence_start(x, m, order)).rev() {
        let n_over_mx = n as f64 / mx;
        dn = n_over_mx - 1.0 / (dn + n_over_mx);
    }
    let (mut psi_prev2, mut psi_prev) = (x.cos(), x.sin());
    let (mut chi_prev2, mut chi_prev) = (-x.sin(), x.cos());
    for n in 1..order {
        let factor = (2.0 * n as f64 - 1.0) / x;
        (psi_prev2, psi_prev) = (psi_prev, factor * psi_prev - psi_prev2);
        (chi_prev2, chi_prev) = (chi_prev, factor * chi_prev - chi_prev2);
    }
    let factor = (2.0 * order as f64 - 1.0) / x;
    let psi = factor * psi_prev - psi_prev2;
    let chi = factor * chi_prev - chi_prev2;
    Matching::new(x, m, order, dn, psi, psi_prev, chi, chi_prev)
}

/// An interval of size parameter holding one resonance (a falling zero of
/// F), found by the scan of [`brackets`].
#[derive(Clone, Copy, Debug)]
pub struct Bracket {
    order: usize,
    coefficient: Coefficient,
    /// Ends: (x, F, width function).
    lo: (f64, f64, f64),
    hi: (f64, f64, f64),
}

impl Bracket {
    /// The resonance as the scan sees it, without refinement: the secant's
    /// zero and the width interpolated there (geometrically: across a
    /// trapped mode's bracket it changes by a factor of about e^{1/8}).
    pub fn estimate(&self) -> Resonance {
        let (x0, f0, w0) = self.lo;
        let (x1, f1, w1) = self.hi;
        let u = (f0 / (f0 - f1)).clamp(0.0, 1.0);
        let width = if w0 * w1 > 0.0 {
            w0.signum() * (w0.abs().ln() * (1.0 - u) + w1.abs().ln() * u).exp()
        } else {
            w0 * (1.0 - u) + w1 * u
        };
        Resonance {
            order: self.order,
            coefficient: self.coefficient,
            size_parameter: x0 + (x1 - x0) * u,
            width,
        }
    }

    /// The resonance located to rounding by Newton steps kept inside the
    /// bracket (bisection when they leave it), from the secant's zero; None
    /// when the bracket holds a pole of G instead (a zero of χ_n falls
    /// through infinity) or the order lies beyond the series at the zero.
    pub fn refine(&self, m: f64) -> Option<Resonance> {
        let (order, coefficient) = (self.order, self.coefficient);
        let value = |x: f64| matching_function(x, m, order).of(coefficient);
        let (mut lo, mut hi) = (self.lo.0, self.hi.0);
        let mut x = self.estimate().size_parameter;
        if !(x > lo && x < hi) {
            x = 0.5 * (lo + hi);
        }
        for _ in 0..60 {
            let (f, slope, _) = value(x);
            if f > 0.0 {
                lo = x;
            } else {
                hi = x;
            }
            let newton = x - f / slope;
            let next = if slope < 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            let converged = (next - x).abs() <= 1e-12 * x.max(1.0) || hi - lo <= 1e-12 * x.max(1.0);
            x = next;
            if converged {
                break;
            }
        }
        let (f, slope, width) = value(x);
        let is_zero = f.abs() <= 1e-6 * (1.0 + slope.abs()) && slope < 0.0;
        (is_zero && order <= series_length(x) && width.is_finite()).then_some(Resonance {
            order,
            coefficient,
            size_parameter: x,
            width,
        })
    }
}

/// Brackets of the resonances in [`x_lo`, `x_hi`] of the orders the series
/// keeps there (n ≤ N(x), Wiscombe's length) below the top of the
/// centrifugal barrier, for the real refractive index `m`; none for m ≤ 1
/// (no trapped modes).
pub fn brackets(m: f64, x_lo: f64, x_hi: f64) -> Vec<Bracket> {
    if m <= 1.0 || x_hi <= x_lo || x_lo <= 0.0 {
        return Vec::new();
    }
    // Orders beyond the series length at x cannot resonate inside the
    // series; a margin covers the bracket's left end.
    let orders_at = |x: f64| series_length(x) + 4;
    let steps = ((x_hi - x_lo) / SCAN_STEP).ceil().max(1.0) as usize;
    let step = (x_hi - x_lo) / steps as f64;
    // Scanned in parallel chunks.
    (0..steps.div_ceil(SCAN_CHUNK))
        .into_par_iter()
        .flat_map_iter(|chunk| {
            let first = chunk * SCAN_CHUNK;
            let last = (first + SCAN_CHUNK).min(steps);
            let at = |i: usize| x_lo + step * i as f64;
            let mut found = Vec::new();
            let mut previous = matching_functions(at(first), m, orders_at(at(first)));
            for i in first + 1..=last {
                let (left, right) = (at(i - 1), at(i));
                let current = matching_functions(right, m, orders_at(right));
                for n in 1..=previous.len().min(series_length(right)) {
                    let (before, after) = (previous[n - 1], current[n - 1]);
                    // Above the centrifugal barrier (x beyond ν + 2ν^⅓,
                    // ν = n + ½) nothing is trapped and the widths are of
                    // order one (Johnson 1993); there too the poles of G_n
                    // (zeros of χ_n) fall through zero like the zeros of F.
                    let nu = n as f64 + 0.5;
                    if left > nu + 2.0 * nu.cbrt() || before.chi * after.chi <= 0.0 {
                        continue;
                    }
                    for coefficient in [Coefficient::A, Coefficient::B] {
                        let (f_left, _, w_left) = before.of(coefficient);
                        let (f_right, _, w_right) = after.of(coefficient);
                        if f_left > 0.0 && f_right <= 0.0 {
                            found.push(Bracket {
                                order: n,
                                coefficient,
                                lo: (left, f_left, w_left),
                                hi: (right, f_right, w_right),
                            });
                        }
                    }
                }
                previous = current;
            }
            found
        })
        .collect()
}

/// The resonances of [`brackets`] with `min_width` ≤ |Γ| ≤ `max_width`,
/// refined, sorted by size parameter.
pub fn resonances(m: f64, x_lo: f64, x_hi: f64, min_width: f64, max_width: f64) -> Vec<Resonance> {
    let mut found: Vec<Resonance> = brackets(m, x_lo, x_hi)
        .into_par_iter()
        .filter_map(|b| b.refine(m))
        .filter(|r| (min_width..=max_width).contains(&r.width.abs()))
        .collect();
    found.sort_by(|a, b| a.size_parameter.total_cmp(&b.size_parameter));
    found
}

/// Scan spacing in size parameter: an eighth keeps each zero of F apart from
/// the poles next to it (π/m apart, and the zero of the lowest mode about
/// 0.5–0.9 below the first pole, Lam, Leung & Young 1992).
const SCAN_STEP: f64 = 0.125;

/// Scan steps per parallel task.
const SCAN_CHUNK: usize = 64;

#[cfg(test)]
mod tests {
    use super::super::mie::MieCoefficients;
    use super::*;
    use num_complex::Complex64;

    const WATER: f64 = 1.3314;

    /// The coefficient at a located resonance reaches 1, and half of it in
    /// |c|² one width away, on the Mie code's own coefficients.
    #[test]
    fn located_resonances_are_peaks_of_the_stated_width() {
        let list = resonances(WATER, 20.0, 80.0, 1e-9, 0.5);
        assert!(list.len() > 100, "{}", list.len());
        for r in &list {
            let value = |x: f64| {
                let c = MieCoefficients::new(x, Complex64::new(WATER, 0.0));
                match r.coefficient {
                    Coefficient::A => c.a[r.order - 1],
                    Coefficient::B => c.b[r.order - 1],
                }
            };
            let peak = value(r.size_parameter).norm_sqr();
            // The peak is located to 10⁻¹² x, a few thousandths of the
            // narrowest widths here.
            assert!((peak - 1.0).abs() < 1e-5, "{r:?}: |c|² {peak}");
            // |c|² = 1/(1 + t²) with t ≈ (x − x_r)/Γ: ½ at x_r ± Γ, to the
            // curvature of t over a width (t varies on a scale of order one;
            // near the barrier's top the resonances are broad and t is not
            // linear over a width).
            if r.width.abs() > 0.05 {
                continue;
            }
            for side in [-1.0, 1.0] {
                let half = value(r.size_parameter + side * r.width.abs()).norm_sqr();
                let tolerance = 0.002 + r.width.abs();
                assert!(
                    (half - 0.5).abs() < tolerance,
                    "{r:?}: |c|² {half} at {side}Γ"
                );
            }
        }
    }

    /// Lowest-mode positions against the asymptotic series of Lam, Leung &
    /// Young (JOSA B 9, 1585, 1992, eq. 11): with ν = n + ½, α₁ = 2.33811
    /// the first zero of Ai(−z), P = m for b_n (TE) and 1/m for a_n (TM),
    ///   m x = ν + 2^{−1/3} α₁ ν^{1/3} − P/√(m² − 1)
    ///         + (3/10) 2^{−2/3} α₁² ν^{−1/3}
    ///         − 2^{−1/3} P (m² − 2P²/3)/(m² − 1)^{3/2} α₁ ν^{−2/3} + O(ν^{−1}).
    #[test]
    fn lowest_modes_follow_the_asymptotic_series() {
        let m = WATER;
        let alpha = 2.338_107_410_459_767;
        // Orders whose lowest mode the truncated series keeps (n ≤ N(x_r)).
        for n in [45usize, 60, 80, 100] {
            let nu = n as f64 + 0.5;
            for (coefficient, p) in [(Coefficient::B, m), (Coefficient::A, 1.0 / m)] {
                let mx = nu + 2f64.powf(-1.0 / 3.0) * alpha * nu.cbrt() - p / (m * m - 1.0).sqrt()
                    + 0.3 * 2f64.powf(-2.0 / 3.0) * alpha * alpha / nu.cbrt()
                    - 2f64.powf(-1.0 / 3.0) * p * (m * m - 2.0 * p * p / 3.0)
                        / (m * m - 1.0).powf(1.5)
                        * alpha
                        / nu.powf(2.0 / 3.0);
                let expected = mx / m;
                let lowest = resonances(m, expected - 1.5, expected + 1.5, 0.0, 0.5)
                    .into_iter()
                    .filter(|r| r.order == n && r.coefficient == coefficient)
                    .min_by(|a, b| a.size_parameter.total_cmp(&b.size_parameter))
                    .expect("a resonance near the predicted position");
                // The series' next term is O(ν^{−1}) in m x.
                assert!(
                    m * (lowest.size_parameter - expected).abs() < 5.0 / nu,
                    "n {n} {coefficient:?}: {} vs {expected}",
                    lowest.size_parameter
                );
            }
        }
    }

    /// The scan's estimates, which choose the resonances worth refining,
    /// are close to the refined values.
    #[test]
    fn estimates_are_close_to_refined_resonances() {
        let mut count = 0;
        for bracket in brackets(WATER, 10.0, 120.0) {
            let Some(refined) = bracket.refine(WATER) else {
                continue;
            };
            let estimate = bracket.estimate();
            assert!((estimate.size_parameter - refined.size_parameter).abs() < SCAN_STEP);
            if refined.width.abs() < 0.1 {
                count += 1;
                let ratio = estimate.width / refined.width;
                assert!(
                    (0.67..1.5).contains(&ratio),
                    "{refined:?}: estimate {estimate:?}"
                );
            }
        }
        assert!(count > 500, "{count}");
    }

    /// A scan twice as fine finds the same resonances: none hides between
    /// the scan points next to a pole.
    #[test]
    fn a_finer_scan_finds_no_more() {
        let list = resonances(WATER, 5.0, 60.0, 0.0, 0.5);
        let mut fine = Vec::new();
        // Two scans offset by half a step together sample every 1/16.
        for offset in [0.0, SCAN_STEP / 2.0] {
            fine.extend(resonances(WATER, 5.0 + offset, 60.0 + offset, 0.0, 0.5));
        }
        fine.retain(|r| r.size_parameter <= 60.0);
        fine.sort_by(|a, b| a.size_parameter.total_cmp(&b.size_parameter));
        fine.dedup_by(|a, b| {
            a.order == b.order
                && a.coefficient == b.coefficient
                && (a.size_parameter - b.size_parameter).abs() < 1e-9
        });
        assert_eq!(list.len(), fine.len());
    }

    #[test]
    fn no_resonances_without_a_denser_sphere() {
        assert!(resonances(0.75, 1.0, 50.0, 0.0, 0.5).is_empty());
        assert!(resonances(1.0, 1.0, 50.0, 0.0, 0.5).is_empty());
    }
}
