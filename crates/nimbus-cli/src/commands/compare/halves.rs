//! Errors that the reference's own noise does not inflate: a real-time
//! image R against a path-traced reference given as two independent halves
//! A and B (each the mean of half the samples; the reference is S = (A + B)/2).
//!
//! Per pixel (or per k×k block, after taking the block means of R, A and
//! B), with luminances r, a, b and s = (a + b)/2, h = (a − b)/2:
//!
//! - (r − a)(r − b) = (r − s)² − h² is an unbiased estimate of (r − μ)², μ
//!   the noise-free reference: E\[(r − a)(r − b)\] = (r − μ)² when A and B
//!   are independent with mean μ (the cross term vanishes). Its mean over
//!   the pixels, m, is the unbiased mean squared error; √max(m, 0) over the
//!   reference's mean luminance is the relative RMSE reported (the raw m,
//!   which noise can make negative, is reported too). The naive RMSE,
//!   mean (r − s)², exceeds it by the reference's noise variance mean h².
//! - The reference's noise: E\[h²\] is the variance of s, so √(mean h²) over
//!   the mean luminance is the reference's own relative RMSE.
//! - Standard errors, over the reference's noise (R is deterministic, the
//!   pixels' noise independent): with s = μ + e, h independent of e (equal
//!   variances of the halves; Gaussian), Var\[(r − s)² − h²\] =
//!   4 (r − μ)² σ² + 4 σ⁴, of which 4 h² (r − s)² is an unbiased estimate
//!   (E\[h² (r − s)²\] = σ² ((r − μ)² + σ²)). So SE(m) = √(Σ 4 h² (r − s)²) / n.
//!   The relative RMSE's standard error is half the spread of √ over m ± SE(m)
//!   (well defined at m ≈ 0, where the delta method is not).
//! - Mean luminance ratio L̄_R / L̄_S and red/blue of the means: the
//!   reference's means have variance Σ h² / n² (each channel; covariances
//!   Σ h_x h_y / n²), propagated to first order (delta method).
//!
//! The construction is the "two independent estimates" trick of
//! Monte-Carlo error analysis: e.g. Rousselle, Knaus & Zwicker, "Adaptive
//! Sampling and Reconstruction using Greedy Error Minimization", SIGGRAPH
//! Asia 2011, sec. 4 (the product of two independent buffers' errors as an
//! unbiased squared-error estimate).

use super::metrics::{LUMINANCE_RGB, RgbImage, luminance_f64};

/// Default side of the blocks, pixels.
pub const DEFAULT_BLOCK_PX: u32 = 4;

/// Largest block side accepted, pixels.
pub const MAX_BLOCK_PX: u32 = 256;

/// One scale of the comparison (pixels or blocks).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ScaleMetrics {
    /// Samples compared: masked pixels, or blocks at least half masked.
    pub count: usize,
    /// √max(m, 0) / L̄_S: the relative RMSE of luminance that the reference's
    /// noise does not inflate.
    pub luminance_relative_rmse_unbiased: f64,
    /// Its standard error (half the spread of √ over m ± SE(m), over L̄_S).
    pub luminance_relative_rmse_unbiased_se: f64,
    /// m / L̄_S²: the raw unbiased relative mean squared error (may be
    /// negative where the error is below the reference's noise).
    pub luminance_relative_mse_unbiased_raw: f64,
    /// Its standard error.
    pub luminance_relative_mse_unbiased_se: f64,
    /// √(mean (r − s)²) / L̄_S: the naive relative RMSE against the mean of
    /// the halves (inflated by the reference's noise).
    pub luminance_relative_rmse_naive: f64,
    /// √(mean h²) / L̄_S: the reference's own relative RMSE at this scale.
    pub reference_noise_relative_rmse: f64,
}

/// The metrics of a comparison against two halves.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct HalvesMetrics {
    /// Side of the blocks, pixels.
    pub block_px: u32,
    /// Mean luminance of the reference (the mean of the halves) over the mask.
    pub reference_mean_luminance: f64,
    /// Per pixel.
    pub pixels: ScaleMetrics,
    /// Over blocks of `block_px` × `block_px` pixels (those at least half
    /// in the mask; means over their masked pixels).
    pub blocks: ScaleMetrics,
    /// Mean luminance of the test over the reference's.
    pub mean_luminance_ratio: f64,
    /// Its standard error from the reference's noise.
    pub mean_luminance_ratio_se: f64,
    /// Red over blue of the reference's mean colour.
    pub red_over_blue_reference: f64,
    /// Its standard error.
    pub red_over_blue_reference_se: f64,
    /// Red over blue of the test's mean colour over the reference's.
    pub red_over_blue_ratio: f64,
    /// Its standard error.
    pub red_over_blue_ratio_se: f64,
}

/// One sample (pixel or block mean): test, half A, half B, linear RGB.
type Sample = [[f64; 3]; 3];

fn rgb(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

/// The statistics of one scale over its samples, relative to `mean`.
fn scale_metrics(samples: &[Sample], mean: f64) -> ScaleMetrics {
    let n = samples.len().max(1) as f64;
    let (mut m, mut var_m, mut naive, mut noise) = (0.0, 0.0, 0.0, 0.0);
    for [t, a, b] in samples {
        let (r, a, b) = (luminance_f64(*t), luminance_f64(*a), luminance_f64(*b));
        let (s, h) = (0.5 * (a + b), 0.5 * (a - b));
        m += (r - a) * (r - b);
        var_m += 4.0 * h * h * (r - s) * (r - s);
        naive += (r - s) * (r - s);
        noise += h * h;
    }
    let (m, se_m) = (m / n, var_m.sqrt() / n);
    let mean = mean.max(1e-30);
    let root = |x: f64| x.max(0.0).sqrt();
    ScaleMetrics {
        count: samples.len(),
        luminance_relative_rmse_unbiased: root(m) / mean,
        luminance_relative_rmse_unbiased_se: 0.5 * (root(m + se_m) - root(m - se_m)) / mean,
        luminance_relative_mse_unbiased_raw: m / (mean * mean),
        luminance_relative_mse_unbiased_se: se_m / (mean * mean),
        luminance_relative_rmse_naive: (naive / n).sqrt() / mean,
        reference_noise_relative_rmse: (noise / n).sqrt() / mean,
    }
}

/// Block means of the masked pixels: blocks of `block` × `block` pixels
/// (the last row and column of blocks may be smaller) with at least half
/// of their pixels in the mask.
fn block_samples(
    test: &RgbImage,
    a: &RgbImage,
    b: &RgbImage,
    mask: &[bool],
    block: u32,
) -> Vec<Sample> {
    let (w, h, k) = (test.width as usize, test.height as usize, block as usize);
    let mut out = Vec::new();
    for by in (0..h).step_by(k) {
        for bx in (0..w).step_by(k) {
            let (mut sum, mut inside, mut total) = ([[0.0f64; 3]; 3], 0usize, 0usize);
            for y in by..(by + k).min(h) {
                for x in bx..(bx + k).min(w) {
                    total += 1;
                    let i = y * w + x;
                    if !mask[i] {
                        continue;
                    }
                    inside += 1;
                    for (s, img) in sum.iter_mut().zip([test, a, b]) {
                        for (c, v) in s.iter_mut().zip(rgb(img.pixels[i])) {
                            *c += v;
                        }
                    }
                }
            }
            if inside > 0 && 2 * inside >= total {
                out.push(sum.map(|s| s.map(|c| c / inside as f64)));
            }
        }
    }
    out
}

/// Compares `test` with the reference given as its halves `a` and `b` (all
/// the same size) over the pixels where `mask` is true, per pixel and over
/// `block` × `block` blocks (`block` ≥ 1). None when no pixel is masked.
pub fn halves_metrics(
    test: &RgbImage,
    a: &RgbImage,
    b: &RgbImage,
    mask: &[bool],
    block: u32,
) -> Option<HalvesMetrics> {
    let pixels: Vec<Sample> = (0..mask.len())
        .filter(|i| mask[*i])
        .map(|i| [rgb(test.pixels[i]), rgb(a.pixels[i]), rgb(b.pixels[i])])
        .collect();
    if pixels.is_empty() {
        return None;
    }
    let n = pixels.len() as f64;
    // Channel means of the test and of the reference S, and the sums of the
    // halves' half-differences' products (covariances of S's means × n²).
    let (mut mean_t, mut mean_s) = ([0.0f64; 3], [0.0f64; 3]);
    let mut cov = [[0.0f64; 3]; 3];
    for [t, a, b] in &pixels {
        let h: [f64; 3] = std::array::from_fn(|c| 0.5 * (a[c] - b[c]));
        for c in 0..3 {
            mean_t[c] += t[c] / n;
            mean_s[c] += 0.5 * (a[c] + b[c]) / n;
            for d in 0..3 {
                cov[c][d] += h[c] * h[d];
            }
        }
    }
    let cov = cov.map(|row| row.map(|v| v / (n * n)));
    let (lt, ls) = (luminance_f64(mean_t), luminance_f64(mean_s).max(1e-30));
    let var_ls: f64 = (0..3)
        .map(|c| {
            (0..3)
                .map(|d| LUMINANCE_RGB[c] * LUMINANCE_RGB[d] * cov[c][d])
                .sum::<f64>()
        })
        .sum();
    let ratio = lt / ls;
    // ρ = R̄/B̄: Var ρ ≈ (Var R̄ − 2ρ Cov(R̄, B̄) + ρ² Var B̄) / B̄².
    let blue_s = mean_s[2].max(1e-30);
    let rb_s = mean_s[0] / blue_s;
    let var_rb_s = ((cov[0][0] - 2.0 * rb_s * cov[0][2] + rb_s * rb_s * cov[2][2])
        / (blue_s * blue_s))
        .max(0.0);
    let rb_t = mean_t[0] / mean_t[2].max(1e-30);
    let rb_ratio = rb_t / rb_s.max(1e-30);
    let blocks = block_samples(test, a, b, mask, block.max(1));
    Some(HalvesMetrics {
        block_px: block.max(1),
        reference_mean_luminance: ls,
        pixels: scale_metrics(&pixels, ls),
        blocks: scale_metrics(&blocks, ls),
        mean_luminance_ratio: ratio,
        mean_luminance_ratio_se: ratio * var_ls.max(0.0).sqrt() / ls,
        red_over_blue_reference: rb_s,
        red_over_blue_reference_se: var_rb_s.sqrt(),
        red_over_blue_ratio: rb_ratio,
        red_over_blue_ratio_se: rb_ratio * var_rb_s.sqrt() / rb_s.max(1e-30),
    })
}

/// The mean of the two halves, pixel by pixel (the reference itself).
pub fn mean_of_halves(a: &RgbImage, b: &RgbImage) -> RgbImage {
    RgbImage {
        width: a.width,
        height: a.height,
        pixels: a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| std::array::from_fn(|c| 0.5 * (p[c] + q[c])))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::compare::metrics::luminance;

    /// A deterministic generator of standard normal deviates (SplitMix64 and
    /// Box–Muller), so that the tests are reproducible.
    struct Normal(u64);

    impl Normal {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn next(&mut self) -> f64 {
            let (u, v) = (self.uniform().max(1e-300), self.uniform());
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
        }
    }

    /// A smooth image of a cloud-like luminance around 1.
    fn image(width: u32, height: u32) -> RgbImage {
        RgbImage {
            width,
            height,
            pixels: (0..width * height)
                .map(|i| {
                    let (x, y) = ((i % width) as f32, (i / width) as f32);
                    let l = 0.6 + 0.8 * (x / width as f32) * (1.0 - y / height as f32);
                    [l * 1.05, l, l * 0.9]
                })
                .collect(),
        }
    }

    /// `image` times (1 + `sigma` N(0, 1)) per pixel and channel (the
    /// channels' noise fully correlated, as a path tracer's mostly is).
    fn noisy(image: &RgbImage, sigma: f64, rng: &mut Normal) -> RgbImage {
        RgbImage {
            pixels: image
                .pixels
                .iter()
                .map(|p| {
                    let k = (1.0 + sigma * rng.next()).max(0.0) as f32;
                    p.map(|c| c * k)
                })
                .collect(),
            ..image.clone()
        }
    }

    /// The acceptance test of the unbiased error: an image compared with
    /// two halves that are the image plus independent noise has an unbiased
    /// error of 0 within its standard error, at both scales, while the
    /// naive squared error is the noise's, many standard errors above 0; and the
    /// reported noise is the noise put in.
    #[test]
    fn an_image_against_its_own_noisy_halves_has_no_unbiased_error() {
        let truth = image(160, 90);
        let mask = vec![true; truth.pixels.len()];
        let mut rng = Normal(7);
        for sigma in [0.05, 0.3] {
            let a = noisy(&truth, sigma, &mut rng);
            let b = noisy(&truth, sigma, &mut rng);
            let m = halves_metrics(&truth, &a, &b, &mask, 4).expect("masked pixels");
            for (scale, s) in [("pixels", &m.pixels), ("blocks", &m.blocks)] {
                assert!(
                    s.luminance_relative_mse_unbiased_raw.abs()
                        < 3.0 * s.luminance_relative_mse_unbiased_se,
                    "σ {sigma}, {scale}: unbiased MSE {} ± {}",
                    s.luminance_relative_mse_unbiased_raw,
                    s.luminance_relative_mse_unbiased_se
                );
                // The naive squared error is many of those standard errors above 0.
                assert!(
                    s.luminance_relative_rmse_naive.powi(2)
                        > 5.0 * s.luminance_relative_mse_unbiased_se,
                    "σ {sigma}, {scale}: naive RMSE {} vs the MSE's SE {}",
                    s.luminance_relative_rmse_naive,
                    s.luminance_relative_mse_unbiased_se
                );
                // The naive RMSE is the noise of S (σ/√2 of the image, per
                // pixel; 1/k of it per k×k block).
                let expected =
                    sigma / std::f64::consts::SQRT_2 * if scale == "pixels" { 1.0 } else { 0.25 };
                let l = m.reference_mean_luminance;
                let relative_to = |v: f64| v / expected;
                let rms_l = (truth
                    .pixels
                    .iter()
                    .map(|p| luminance(*p).powi(2))
                    .sum::<f64>()
                    / truth.pixels.len() as f64)
                    .sqrt();
                let ratio = relative_to(s.reference_noise_relative_rmse * l / rms_l);
                assert!(
                    (ratio - 1.0).abs() < 0.1,
                    "σ {sigma}, {scale}: noise {ratio}"
                );
            }
            assert!(
                (m.mean_luminance_ratio - 1.0).abs() < 3.0 * m.mean_luminance_ratio_se,
                "σ {sigma}: {} ± {}",
                m.mean_luminance_ratio,
                m.mean_luminance_ratio_se
            );
            assert!(
                (m.red_over_blue_ratio - 1.0).abs() < 3.0 * m.red_over_blue_ratio_se + 1e-9,
                "σ {sigma}: {} ± {}",
                m.red_over_blue_ratio,
                m.red_over_blue_ratio_se
            );
        }
    }

    /// A real difference is measured as it is, whatever the noise: the test
    /// 20 % brighter than the truth gives an unbiased relative RMSE of
    /// 0.2 · rms(L)/mean(L) within its standard error, at σ = 0 and σ = 0.3,
    /// where the naive RMSE is far above it.
    #[test]
    fn a_real_difference_is_measured_without_the_noise() {
        let truth = image(160, 90);
        let test = RgbImage {
            pixels: truth.pixels.iter().map(|p| p.map(|c| c * 1.2)).collect(),
            ..truth.clone()
        };
        let mask = vec![true; truth.pixels.len()];
        let l: Vec<f64> = truth.pixels.iter().map(|p| luminance(*p)).collect();
        let n = l.len() as f64;
        let expected =
            0.2 * (l.iter().map(|v| v * v).sum::<f64>() / n).sqrt() / (l.iter().sum::<f64>() / n);
        let mut rng = Normal(11);
        for sigma in [0.0, 0.3] {
            let a = noisy(&truth, sigma, &mut rng);
            let b = noisy(&truth, sigma, &mut rng);
            let m = halves_metrics(&test, &a, &b, &mask, 4).expect("masked pixels");
            for s in [&m.pixels, &m.blocks] {
                let e = s.luminance_relative_rmse_unbiased;
                assert!(
                    (e - expected).abs() <= 3.0 * s.luminance_relative_rmse_unbiased_se + 0.003,
                    "σ {sigma}: {e} ± {} vs {expected}",
                    s.luminance_relative_rmse_unbiased_se
                );
            }
            assert!(
                (m.mean_luminance_ratio - 1.2).abs() <= 3.0 * m.mean_luminance_ratio_se + 1e-6,
                "σ {sigma}: {} ± {}",
                m.mean_luminance_ratio,
                m.mean_luminance_ratio_se
            );
            if sigma > 0.0 {
                assert!(m.pixels.luminance_relative_rmse_naive > 1.3 * expected);
                assert!(m.mean_luminance_ratio_se > 0.0);
            } else {
                assert_eq!(m.mean_luminance_ratio_se, 0.0);
            }
        }
    }

    /// The standard errors are what they claim: over 200 independent draws
    /// of the halves, the spread of the unbiased MSE and of the luminance
    /// ratio matches the mean reported standard error within 15 %.
    #[test]
    fn the_standard_errors_match_the_spread_over_draws() {
        let truth = image(64, 36);
        let test = RgbImage {
            pixels: truth
                .pixels
                .iter()
                .enumerate()
                .map(|(i, p)| p.map(|c| c * if i % 3 == 0 { 1.3 } else { 0.9 }))
                .collect(),
            ..truth.clone()
        };
        let mask = vec![true; truth.pixels.len()];
        let mut rng = Normal(3);
        let (mut mse, mut mse_se, mut ratio, mut ratio_se) = (vec![], 0.0, vec![], 0.0);
        let draws = 200;
        for _ in 0..draws {
            let a = noisy(&truth, 0.2, &mut rng);
            let b = noisy(&truth, 0.2, &mut rng);
            let m = halves_metrics(&test, &a, &b, &mask, 4).expect("masked pixels");
            mse.push(
                m.pixels.luminance_relative_mse_unbiased_raw * m.reference_mean_luminance.powi(2),
            );
            mse_se += m.pixels.luminance_relative_mse_unbiased_se
                * m.reference_mean_luminance.powi(2)
                / draws as f64;
            ratio.push(m.mean_luminance_ratio);
            ratio_se += m.mean_luminance_ratio_se / draws as f64;
        }
        let spread = |v: &[f64]| {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
        };
        for (name, s, se) in [
            ("MSE", spread(&mse), mse_se),
            ("ratio", spread(&ratio), ratio_se),
        ] {
            assert!((s / se - 1.0).abs() < 0.15, "{name}: spread {s} vs SE {se}");
        }
    }

    /// Blocks follow the mask: only blocks at least half masked count.
    #[test]
    fn blocks_at_least_half_masked_count() {
        let truth = image(8, 8);
        // The left half masked: columns 0–3 (two blocks of 4 per column of blocks).
        let mask: Vec<bool> = (0..64).map(|i| i % 8 < 4).collect();
        let m = halves_metrics(&truth, &truth, &truth, &mask, 4).expect("masked");
        assert_eq!(m.pixels.count, 32);
        assert_eq!(m.blocks.count, 2);
        assert_eq!(m.blocks.luminance_relative_rmse_unbiased, 0.0);
        assert!(halves_metrics(&truth, &truth, &truth, &[false; 64], 4).is_none());
    }
}
