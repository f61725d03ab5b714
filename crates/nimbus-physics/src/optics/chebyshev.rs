//! Polynomials in μ = cos θ held by their values at Chebyshev–Lobatto points.
//!
//! The scattered intensity of one sphere, |S1|² + |S2|², is a polynomial in
//! μ of degree 2N for a series of N orders: π_n(μ) has degree n − 1 and
//! τ_n(μ) = nμπ_n − (n + 1)π_{n−1} degree n (Bohren & Huffman 1983, eq.
//! 4.47), so S1 and S2 have degree N and their squared moduli 2N. Sampled at
//! the M + 1 Chebyshev–Lobatto points μ_j = cos(jπ/M), M ≥ 2N, it is known
//! exactly everywhere: the Chebyshev coefficients follow from a type-I
//! discrete cosine transform (Trefethen, *Approximation Theory and
//! Approximation Practice*, 2013, ch. 3), and Clenshaw's recurrence evaluates
//! the series stably at any μ. Sums over droplet radii stay polynomials, so
//! the DSD integral can accumulate samples on a few grids whose size follows
//! the droplet, and convert to the requested angles once, instead of summing
//! the Mie series at every requested angle for every radius.

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

/// The M + 1 Chebyshev–Lobatto points cos(jπ/M), j = 0..=M (from 1 to −1).
pub fn lobatto_points(m: usize) -> Vec<f64> {
    (0..=m)
        .map(|j| (j as f64 * std::f64::consts::PI / m as f64).cos())
        .collect()
}

/// Chebyshev coefficients c_0..=c_M of the polynomial of degree ≤ M with the
/// given `values` at [`lobatto_points`]`(M)`, such that
/// p(μ) = Σ_k c_k T_k(μ). A type-I DCT through an FFT of length 2M.
pub fn coefficients_from_lobatto(values: &[f64], planner: &mut FftPlanner<f64>) -> Vec<f64> {
    let m = values.len() - 1;
    if m == 0 {
        return values.to_vec();
    }
    // The even extension f_0, …, f_M, f_{M−1}, …, f_1 has the DFT
    // f_0 + (−1)^k f_M + 2 Σ_{j=1}^{M−1} f_j cos(πjk/M), twice the
    // trapezoid-weighted cosine sum.
    let mut buffer: Vec<Complex<f64>> = values
        .iter()
        .chain(values[1..m].iter().rev())
        .map(|&v| Complex::new(v, 0.0))
        .collect();
    planner.plan_fft_forward(2 * m).process(&mut buffer);
    let mut coefficients: Vec<f64> = buffer[..=m].iter().map(|c| c.re / m as f64).collect();
    coefficients[0] *= 0.5;
    coefficients[m] *= 0.5;
    coefficients
}

/// Σ_k c_k T_k(μ) by Clenshaw's recurrence.
pub fn evaluate(coefficients: &[f64], mu: f64) -> f64 {
    let (mut b1, mut b2) = (0.0, 0.0);
    for &c in coefficients.iter().skip(1).rev() {
        (b1, b2) = (2.0 * mu * b1 - b2 + c, b1);
    }
    mu * b1 - b2 + coefficients.first().copied().unwrap_or(0.0)
}

/// ∫_{−1}^{1} T_k(μ) dμ: 2/(1 − k²) for even k, 0 for odd k.
fn integral_of_t(k: usize) -> f64 {
    if k % 2 == 1 {
        0.0
    } else {
        2.0 / (1.0 - (k * k) as f64)
    }
}

/// ∫_{−1}^{1} Σ_k c_k T_k(μ) dμ.
pub fn integral(coefficients: &[f64]) -> f64 {
    coefficients
        .iter()
        .enumerate()
        .map(|(k, c)| c * integral_of_t(k))
        .sum()
}

/// ∫_{−1}^{1} μ Σ_k c_k T_k(μ) dμ, from μ T_k = (T_{k+1} + T_{|k−1|})/2.
pub fn first_moment(coefficients: &[f64]) -> f64 {
    coefficients
        .iter()
        .enumerate()
        .map(|(k, c)| c * 0.5 * (integral_of_t(k + 1) + integral_of_t(k.abs_diff(1))))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_polynomial_is_recovered_exactly_between_the_points() {
        // p(μ) = 3 − 2μ + 5μ⁴ − μ⁷ (degree 7) sampled at M = 9 points.
        let p = |mu: f64| 3.0 - 2.0 * mu + 5.0 * mu.powi(4) - mu.powi(7);
        let values: Vec<f64> = lobatto_points(9).into_iter().map(p).collect();
        let c = coefficients_from_lobatto(&values, &mut FftPlanner::new());
        for mu in [-1.0, -0.73, 0.0, 0.31, 0.999, 1.0] {
            assert!((evaluate(&c, mu) - p(mu)).abs() < 1e-13, "μ {mu}");
        }
        // ∫p = 6 + 2 = 8, ∫μp = −4/3 − 2/9 (odd parts only).
        assert!((integral(&c) - 8.0).abs() < 1e-13, "{}", integral(&c));
        let moment = -4.0 / 3.0 - 2.0 / 9.0;
        assert!(
            (first_moment(&c) - moment).abs() < 1e-13,
            "{}",
            first_moment(&c)
        );
        // T_k coefficients of μ⁷ beyond degree 7 vanish.
        assert!(c[8].abs() < 1e-14 && c[9].abs() < 1e-14, "{c:?}");
    }
}
