//! Spectral integration of scattering quantities to Rec.709 RGB.
//!
//! The CIE 1931 2° colour-matching functions are evaluated with the
//! multi-lobe Gaussian fit of Wyman, Sloan & Shirley, "Simple Analytic
//! Approximations to the CIE XYZ Color Matching Functions", JCGT 2(2), 2013
//! (their eq. 2; within about 1 % of the tabulated functions' peaks), and
//! converted to linear Rec.709 with the sRGB matrix (IEC 61966-2-1). A
//! quantity f(λ) seen under an equal-energy illuminant maps to the channel
//! values C = M ∫ f(λ) x̄ȳz̄(λ) dλ / M ∫ x̄ȳz̄(λ) dλ (per channel), so a
//! wavelength-independent f gives C = f in every channel.

use crate::photometry::rec709_from_xyz;

fn lobe(lambda: f64, mean: f64, sigma_below: f64, sigma_above: f64) -> f64 {
    let sigma = if lambda < mean {
        sigma_below
    } else {
        sigma_above
    };
    let t = (lambda - mean) / sigma;
    (-0.5 * t * t).exp()
}

/// CIE 1931 x̄, ȳ, z̄ at a wavelength in nm (Wyman et al. 2013, eq. 2).
pub fn cie_1931_cmf(lambda_nm: f64) -> [f64; 3] {
    let l = lambda_nm;
    [
        1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7)
            - 0.065 * lobe(l, 501.1, 20.4, 26.2),
        0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
        1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8),
    ]
}

/// Wavelengths (nm) and trapezoid weights of the spectral quadrature, 380–780 nm.
pub fn spectral_grid(step_nm: f64) -> Vec<(f64, f64)> {
    let count = ((780.0 - 380.0) / step_nm).round() as usize;
    (0..=count)
        .map(|i| {
            let w = if i == 0 || i == count { 0.5 } else { 1.0 } * step_nm;
            (380.0 + i as f64 * step_nm, w)
        })
        .collect()
}

/// Per-wavelength values `values[i]` (one per grid wavelength, each a slice
/// of samples) to RGB: each sample position k maps to an [R, G, B].
pub fn to_rgb(grid: &[(f64, f64)], values: &[Vec<f64>]) -> Vec<[f64; 3]> {
    let samples = values.first().map_or(0, Vec::len);
    let mut white = [0.0; 3];
    for (lambda, w) in grid {
        let cmf = cie_1931_cmf(*lambda);
        for c in 0..3 {
            white[c] += w * cmf[c];
        }
    }
    let white_rgb = rec709_from_xyz(white);
    (0..samples)
        .map(|k| {
            let mut xyz = [0.0; 3];
            for ((lambda, w), v) in grid.iter().zip(values) {
                let cmf = cie_1931_cmf(*lambda);
                for c in 0..3 {
                    xyz[c] += w * cmf[c] * v[k];
                }
            }
            let rgb = rec709_from_xyz(xyz);
            [0, 1, 2].map(|c| rgb[c] / white_rgb[c])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cmf_fit_has_the_known_peaks() {
        // CIE 1931: ȳ peaks at 555 nm with value 1.0; x̄ ≈ 1.06 at 600 nm; z̄ ≈ 1.78 at 445 nm.
        let y555 = cie_1931_cmf(555.0)[1];
        assert!((y555 - 1.0).abs() < 0.02, "{y555}");
        assert!((cie_1931_cmf(600.0)[0] - 1.062).abs() < 0.03);
        assert!((cie_1931_cmf(445.0)[2] - 1.78).abs() < 0.05);
    }

    #[test]
    fn a_flat_spectrum_maps_to_itself_in_every_channel() {
        let grid = spectral_grid(10.0);
        let values: Vec<Vec<f64>> = grid.iter().map(|_| vec![0.25, 2.0]).collect();
        for (k, expected) in [0.25, 2.0].iter().enumerate() {
            let rgb = to_rgb(&grid, &values)[k];
            assert!(rgb.iter().all(|c| (c - expected).abs() < 1e-12), "{rgb:?}");
        }
        // A spectrum rising to the red is redder than it is blue.
        let ramp: Vec<Vec<f64>> = grid
            .iter()
            .map(|(l, _)| vec![(l - 380.0) / 400.0])
            .collect();
        let rgb = to_rgb(&grid, &ramp)[0];
        assert!(rgb[0] > rgb[1] && rgb[1] > rgb[2], "{rgb:?}");
    }
}
