//! Gauss–Legendre quadrature on [−1, 1]: nodes are the roots of P_n, found
//! by Newton's method from Tricomi's initial guesses; weights
//! 2 / ((1 − x²) P'_n(x)²) (Abramowitz & Stegun 25.4.29). Exact for
//! polynomials up to degree 2n − 1.

/// Nodes (descending from near 1 to near −1) and weights of the n-point rule.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    let nf = n as f64;
    for i in 0..n.div_ceil(2) {
        // Tricomi's approximation of the i-th root.
        let theta = std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5);
        let mut x = (1.0 - (nf - 1.0) / (8.0 * nf * nf * nf)) * theta.cos();
        let mut derivative = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_{n−1}(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let kf = k as f64;
                (p0, p1) = (p1, ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf);
            }
            let pn = if n == 0 { 1.0 } else { p1 };
            let pn1 = if n == 1 { 1.0 } else { p0 };
            derivative = nf * (x * pn - pn1) / (x * x - 1.0);
            let dx = pn / derivative;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = x;
        nodes[n - 1 - i] = -x;
        let w = 2.0 / ((1.0 - x * x) * derivative * derivative);
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre(7);
        assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-14);
        // ∫ x¹² dx over [−1, 1] = 2/13, degree 12 ≤ 2·7 − 1.
        let integral: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(12)).sum();
        assert!((integral - 2.0 / 13.0).abs() < 1e-14);
    }

    #[test]
    fn large_rules_are_accurate() {
        let (x, w) = gauss_legendre(3000);
        let integral: f64 = x.iter().zip(&w).map(|(x, w)| w * (5.0 * x).exp()).sum();
        let exact = ((5.0f64).exp() - (-5.0f64).exp()) / 5.0;
        assert!((integral / exact - 1.0).abs() < 1e-12);
    }
}
