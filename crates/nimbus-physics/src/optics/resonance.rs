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

use super::mie::{MieCoefficients, series_length};
use num_complex::Complex64;
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
    /// F_a and dF_a/dx.
    f_a: f64,
    slope_a: f64,
    /// F_b and dF_b/dx.
    f_b: f64,
    slope_b: f64,
    /// D_n(mx).
    log_derivative: f64,
    /// χ_n(x).
    chi: f64,
}

impl Matching {
    /// F and F' of one coefficient.
    fn of(&self, coefficient: Coefficient) -> (f64, f64) {
        match coefficient {
            Coefficient::A => (self.f_a, self.slope_a),
            Coefficient::B => (self.f_b, self.slope_b),
        }
    }
}

/// The matching functions for orders 1..=`orders` at size parameter `x`.
#[allow(clippy::needless_range_loop)] // n is the order in every formula.
fn matching_functions(x: f64, m: f64, orders: usize) -> Vec<Matching> {
    let mx = m * x;
    // D_n(mx) by downward recurrence, started as in `MieCoefficients::new`.
    let n_start = orders.max(series_length(x)).max(mx.ceil() as usize)
        + 16
        + (8.0 * mx.cbrt()).ceil() as usize;
    let mut d = vec![0.0; n_start + 1];
    for n in (1..=n_start).rev() {
        let n_over_mx = n as f64 / mx;
        d[n - 1] = n_over_mx - 1.0 / (d[n] + n_over_mx);
    }
    // χ_n upward (stable: χ grows with n beyond x); G_n = χ_{n−1}/χ_n − n/x.
    let (mut chi_prev2, mut chi_prev) = (-x.sin(), x.cos());
    let mut out = Vec::with_capacity(orders);
    for n in 1..=orders {
        let nf = n as f64;
        let chi = (2.0 * nf - 1.0) / x * chi_prev - chi_prev2;
        let g = chi_prev / chi - nf / x;
        let dn = d[n];
        let centrifugal = nf * (nf + 1.0);
        let d_slope = centrifugal / (mx * mx) - 1.0 - dn * dn;
        let g_slope = centrifugal / (x * x) - 1.0 - g * g;
        out.push(Matching {
            f_a: dn - m * g,
            slope_a: m * (d_slope - g_slope),
            f_b: m * dn - g,
            slope_b: m * m * d_slope - g_slope,
            log_derivative: dn,
            chi,
        });
        (chi_prev2, chi_prev) = (chi_prev, chi);
    }
    out
}

/// [`matching_functions`] for the one order `order`, without storage: D_n(mx)
/// by the same downward recurrence stopped at n, χ_n upward.
fn matching_function(x: f64, m: f64, order: usize) -> Matching {
    let mx = m * x;
    let n_start = order.max(series_length(x)).max(mx.ceil() as usize)
        + 16
        + (8.0 * mx.cbrt()).ceil() as usize;
    let mut dn = 0.0;
    for n in (order + 1..=n_start).rev() {
        let n_over_mx = n as f64 / mx;
        dn = n_over_mx - 1.0 / (dn + n_over_mx);
    }
    let (mut chi_prev2, mut chi_prev) = (-x.sin(), x.cos());
    for n in 1..order {
        let chi = (2.0 * n as f64 - 1.0) / x * chi_prev - chi_prev2;
        (chi_prev2, chi_prev) = (chi_prev, chi);
    }
    let nf = order as f64;
    let chi = (2.0 * nf - 1.0) / x * chi_prev - chi_prev2;
    let g = chi_prev / chi - nf / x;
    let centrifugal = nf * (nf + 1.0);
    let d_slope = centrifugal / (mx * mx) - 1.0 - dn * dn;
    let g_slope = centrifugal / (x * x) - 1.0 - g * g;
    Matching {
        f_a: dn - m * g,
        slope_a: m * (d_slope - g_slope),
        f_b: m * dn - g,
        slope_b: m * m * d_slope - g_slope,
        log_derivative: dn,
        chi,
    }
}

/// Γ = 1/t'(x_r) at a zero of F whose slope is `slope`: with the
/// numerator N = αψ_n − ψ_{n−1} of the coefficient (α = D_n/m + n/x for a_n,
/// m D_n + n/x for b_n; ψ_n by upward recurrence as in
/// [`MieCoefficients::new`], so that the width is that of the coefficients
/// the radius integral sums), t = C/N with C = χ_n F_a / m or χ_n F_b, so
/// t' = χ_n F'/(m N) or χ_n F'/N where F = 0.
fn width_at(x: f64, m: f64, order: usize, coefficient: Coefficient, slope: f64) -> f64 {
    let f = matching_function(x, m, order);
    let (mut psi_prev2, mut psi_prev) = (x.cos(), x.sin());
    for n in 1..order {
        let psi = (2.0 * n as f64 - 1.0) / x * psi_prev - psi_prev2;
        (psi_prev2, psi_prev) = (psi_prev, psi);
    }
    let psi = (2.0 * order as f64 - 1.0) / x * psi_prev - psi_prev2;
    let nf = order as f64;
    match coefficient {
        Coefficient::A => {
            let numerator = (f.log_derivative / m + nf / x) * psi - psi_prev;
            m * numerator / (f.chi * slope)
        }
        Coefficient::B => {
            let numerator = (m * f.log_derivative + nf / x) * psi - psi_prev;
            numerator / (f.chi * slope)
        }
    }
}

/// t_n(x) = −Im(1/c_n) of one coefficient, from the full Mie solution.
#[cfg(test)]
fn detuning(x: f64, m: f64, order: usize, coefficient: Coefficient) -> f64 {
    let c = MieCoefficients::new(x, Complex64::new(m, 0.0));
    let value = match coefficient {
        Coefficient::A => c.a.get(order - 1),
        Coefficient::B => c.b.get(order - 1),
    };
    value.map_or(f64::NAN, |v| -(1.0 / v).im)
}

/// The resonances with peaks in [`x_lo`, `x_hi`] of the orders the series
/// keeps there (n ≤ N(x_r), Wiscombe's length), with `min_width` ≤ |Γ| ≤
/// `max_width` (at most ½), for the real refractive index `m` > 1, sorted by
/// size parameter. None for m ≤ 1 (no trapped modes).
pub fn resonances(m: f64, x_lo: f64, x_hi: f64, min_width: f64, max_width: f64) -> Vec<Resonance> {
    if m <= 1.0 || x_hi <= x_lo || x_lo <= 0.0 {
        return Vec::new();
    }
    let max_width = max_width.min(0.5);
    // Orders beyond the series length at x cannot resonate inside the
    // series; a margin covers the bracket's left end.
    let orders_at = |x: f64| series_length(x) + 4;
    let steps = ((x_hi - x_lo) / SCAN_STEP).ceil().max(1.0) as usize;
    let step = (x_hi - x_lo) / steps as f64;
    // Brackets (order, coefficient, left end), scanned in parallel chunks.
    let chunks = steps.div_ceil(SCAN_CHUNK);
    let brackets: Vec<(usize, Coefficient, f64)> = (0..chunks)
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
                        if before.of(coefficient).0 > 0.0 && after.of(coefficient).0 <= 0.0 {
                            found.push((n, coefficient, left));
                        }
                    }
                }
                previous = current;
            }
            found
        })
        .collect();
    let mut found: Vec<Resonance> = brackets
        .into_par_iter()
        .filter_map(|(n, coefficient, left)| refine(m, n, coefficient, left, left + step))
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

/// The zero of F in a bracket where it falls through zero, if it is one
/// (not a pole of G).
fn refine(
    m: f64,
    order: usize,
    coefficient: Coefficient,
    mut lo: f64,
    mut hi: f64,
) -> Option<Resonance> {
    let value = |x: f64| matching_function(x, m, order).of(coefficient);
    // Newton steps kept inside the bracket, bisection when they leave it.
    let mut x = 0.5 * (lo + hi);
    for _ in 0..60 {
        let (f, slope) = value(x);
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
        if (next - x).abs() <= 1e-13 * x.max(1.0) || hi - lo <= 1e-13 * x.max(1.0) {
            x = next;
            break;
        }
        x = next;
    }
    let (f, slope) = value(x);
    // A pole of G (a zero of χ_n) also falls through zero, through infinity.
    if !(f.abs() <= 1e-6 * (1.0 + slope.abs()) && slope < 0.0) {
        return None;
    }
    if order > series_length(x) {
        return None;
    }
    let width = width_at(x, m, order, coefficient, slope);
    width.is_finite().then_some(Resonance {
        order,
        coefficient,
        size_parameter: x,
        width,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn census() {
        let m = 1.3314;
        let k = 2.0 * std::f64::consts::PI / 650e-9;
        let dsd = super::super::dsd::SizeDistribution::BOUTHORS_2006;
        let (r_lo, r_hi) = dsd.radius_range_m(1e-5);
        let t0 = std::time::Instant::now();
        let list = resonances(m, r_lo * k, r_hi * k, 0.0, 1.0);
        eprintln!("{} resonances in {:?}", list.len(), t0.elapsed());
        let mut bins = [(0usize, 0.0f64); 12];
        for r in &list {
            let w = dsd.density(r.size_parameter / k) / k
                * (2.0 * std::f64::consts::PI / (k * k))
                * (2 * r.order + 1) as f64
                * std::f64::consts::PI
                * r.width.abs();
            let bin = ((-r.width.abs().log10()).floor().max(0.0) as usize).min(11);
            bins[bin].0 += 1;
            bins[bin].1 += w;
        }
        for r in list.iter().filter(|r| r.order % 40 == 0) {
            eprintln!("n {} x {:.3} Γ {:.3e} (x-n)/n^1/3 {:.2}", r.order, r.size_parameter, r.width, (r.size_parameter - r.order as f64)/ (r.order as f64).cbrt());
        }
        // σ_sca ≈ 0.036 /m
        for (i, b) in bins.iter().enumerate() {
            eprintln!("Γ ~ 1e-{i}: {} resonances, area/σ {:.3e}", b.0, b.1 / 0.036);
        }
    }
}
