//! Image metrics between a real-time HDR image and a path-traced reference:
//! HDR-FLIP, luminance RMSE (relative) and PSNR, mean luminance ratio and
//! the colour of the means, over a mask of pixels.
//!
//! HDR-FLIP after Andersson, Nilsson, Shirley & Akenine-Möller, "Visualizing
//! Errors in Rendered High Dynamic Range Images", Eurographics 2021 (short
//! papers), as in NVIDIA's reference implementation (`flip.h`): both images
//! are exposed at N stops between a start exposure (the reference's largest
//! luminance maps to the tone curve's 0.85) and a stop exposure (its median
//! maps there), N = max(2, ⌈stop − start⌉), tone-mapped by the ACES fit
//! (Narkowicz 2015, input scaled by 0.6), and compared by LDR-FLIP
//! (Andersson et al. 2020); the error of a pixel is its largest over the
//! exposures. LDR-FLIP is NVIDIA's own code through the `nv-flip` crate,
//! which takes 8-bit sRGB: the tone-mapped images are quantised to it.
//! Against NVIDIA's float HDR-FLIP (`flip-evaluator` 1.7, test
//! `hdr_flip_matches_nvidias_implementation`) the quantisation adds < 0.001
//! to the mean where the images differ visibly (0.12–0.67), but inflates
//! faint, pixel-scale differences such as Monte-Carlo noise: a ±5 %
//! checkerboard scores 0.016 instead of 0.006.
//!
//! Luminance: Rec. 709 / sRGB primaries, Y = 0.2126 R + 0.7152 G + 0.0722 B.

use nimbus_physics::photometry::srgb_encode;

/// Weights of linear R, G and B in the Rec. 709 luminance.
pub const LUMINANCE_RGB: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Rec. 709 luminance of linear RGB.
pub fn luminance(rgb: [f32; 3]) -> f64 {
    luminance_f64(rgb.map(f64::from))
}

/// [`luminance`] of linear RGB in double precision.
pub fn luminance_f64(rgb: [f64; 3]) -> f64 {
    let [wr, wg, wb] = LUMINANCE_RGB;
    wr * rgb[0] + wg * rgb[1] + wb * rgb[2]
}

/// A linear HDR RGB image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Linear RGB per pixel.
    pub pixels: Vec<[f32; 3]>,
}

/// ACES fit with FLIP's 0.6 input scale: `(a x² + b x + c) / (d x² + e x + f)`.
const ACES: [f64; 6] = [
    0.6 * 0.6 * 2.51,
    0.6 * 0.03,
    0.0,
    0.6 * 0.6 * 2.43,
    0.6 * 0.59,
    0.14,
];

fn tone_map(x: f64) -> f64 {
    let [a, b, c, d, e, f] = ACES;
    ((a * x * x + b * x + c) / (d * x * x + e * x + f)).clamp(0.0, 1.0)
}

/// The exposures, in stops, at which HDR-FLIP compares (from the reference).
pub fn hdr_flip_exposures(reference: &RgbImage) -> Vec<f64> {
    // Input x whose tone-mapped value is 0.85: root of
    // (a − t d) x² + (b − t e) x + (c − t f) = 0.
    let t = 0.85;
    let [a, b, c, d, e, f] = ACES;
    let (qa, qb, qc) = (a - t * d, b - t * e, c - t * f);
    let x_max = ((-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa)).max(0.0);
    let mut luminances: Vec<f64> = reference.pixels.iter().map(|p| luminance(*p)).collect();
    luminances.sort_by(f64::total_cmp);
    let floor = 1e-12;
    let y_max = luminances.last().copied().unwrap_or(1.0).max(floor);
    let y_median = luminances
        .get(luminances.len() / 2)
        .copied()
        .unwrap_or(1.0)
        .max(floor);
    let start = (x_max / y_max).log2();
    let stop = (x_max / y_median).log2();
    let count = ((stop - start).ceil() as usize).max(2);
    let step = (stop - start) / (count - 1) as f64;
    (0..count).map(|i| start + i as f64 * step).collect()
}

/// 8-bit sRGB of an image exposed by `2^stops` and tone-mapped.
fn exposed_srgb8(image: &RgbImage, stops: f64) -> nv_flip::FlipImageRgb8 {
    let scale = stops.exp2();
    let bytes: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| {
            p.map(|c| {
                let mapped = tone_map(f64::from(c.max(0.0)) * scale);
                (srgb_encode(mapped) * 255.0).round().clamp(0.0, 255.0) as u8
            })
        })
        .collect();
    nv_flip::FlipImageRgb8::with_data(image.width, image.height, &bytes)
}

/// The HDR-FLIP error of each pixel, 0 (no visible difference) to 1,
/// viewed at `pixels_per_degree`.
pub fn hdr_flip(reference: &RgbImage, test: &RgbImage, pixels_per_degree: f32) -> Vec<f32> {
    let mut error = vec![0.0f32; reference.pixels.len()];
    for stops in hdr_flip_exposures(reference) {
        let map = nv_flip::flip(
            exposed_srgb8(reference, stops),
            exposed_srgb8(test, stops),
            pixels_per_degree,
        );
        for (e, m) in error.iter_mut().zip(map.to_vec()) {
            *e = e.max(m);
        }
    }
    error
}

/// Default viewing condition: a 0.7 m viewing distance from a 0.68 m wide,
/// 3840-pixel monitor (FLIP's default, 67 pixels per degree).
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// The metrics over the masked pixels.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Metrics {
    /// Pixels compared.
    pub pixels: usize,
    /// Mean HDR-FLIP error, 0 to 1.
    pub hdr_flip_mean: f64,
    /// RMSE of luminance over the reference's mean luminance.
    pub luminance_relative_rmse: f64,
    /// PSNR of luminance, dB: 20 log10(peak reference luminance / RMSE).
    pub luminance_psnr_db: f64,
    /// Mean luminance of the test over the reference's.
    pub mean_luminance_ratio: f64,
    /// Red over blue of the test's mean colour.
    pub red_over_blue_test: f64,
    /// Red over blue of the reference's mean colour.
    pub red_over_blue_reference: f64,
    /// Distance between the CIE 1931 xy chromaticities of the two mean colours.
    pub mean_chromaticity_difference_xy: f64,
}

/// CIE 1931 xy of linear Rec. 709 RGB (IEC 61966-2-1 matrix).
fn chromaticity_xy(rgb: [f64; 3]) -> [f64; 2] {
    let [r, g, b] = rgb;
    let x = 0.4124 * r + 0.3576 * g + 0.1805 * b;
    let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    let z = 0.0193 * r + 0.1192 * g + 0.9505 * b;
    let sum = (x + y + z).max(1e-30);
    [x / sum, y / sum]
}

/// Computes the metrics over the pixels where `mask` is true, given the
/// per-pixel HDR-FLIP map.
pub fn metrics(test: &RgbImage, reference: &RgbImage, flip: &[f32], mask: &[bool]) -> Metrics {
    let mut n = 0usize;
    let (mut flip_sum, mut squared, mut peak) = (0.0, 0.0, 0.0f64);
    let (mut mean_test, mut mean_reference) = ([0.0f64; 3], [0.0f64; 3]);
    for i in 0..mask.len() {
        if !mask[i] {
            continue;
        }
        n += 1;
        flip_sum += f64::from(flip[i]);
        let (lt, lr) = (luminance(test.pixels[i]), luminance(reference.pixels[i]));
        squared += (lt - lr) * (lt - lr);
        peak = peak.max(lr);
        for k in 0..3 {
            mean_test[k] += f64::from(test.pixels[i][k]);
            mean_reference[k] += f64::from(reference.pixels[i][k]);
        }
    }
    let count = n.max(1) as f64;
    let mean_test = mean_test.map(|c| c / count);
    let mean_reference = mean_reference.map(|c| c / count);
    let rmse = (squared / count).sqrt();
    let luminance_reference = luminance(mean_reference.map(|c| c as f32));
    let luminance_test = luminance(mean_test.map(|c| c as f32));
    let [xt, yt] = chromaticity_xy(mean_test);
    let [xr, yr] = chromaticity_xy(mean_reference);
    Metrics {
        pixels: n,
        hdr_flip_mean: flip_sum / count,
        luminance_relative_rmse: rmse / luminance_reference.max(1e-30),
        luminance_psnr_db: 20.0 * (peak.max(1e-30) / rmse.max(1e-30)).log10(),
        mean_luminance_ratio: luminance_test / luminance_reference.max(1e-30),
        red_over_blue_test: mean_test[0] / mean_test[2].max(1e-30),
        red_over_blue_reference: mean_reference[0] / mean_reference[2].max(1e-30),
        mean_chromaticity_difference_xy: ((xt - xr).powi(2) + (yt - yr).powi(2)).sqrt(),
    }
}

/// An image tone-mapped for display in the report (ACES, sRGB), exposed so
/// that the reference's log-average luminance maps to middle grey.
pub fn display_rgb8(image: &RgbImage, stops: f64) -> Vec<u8> {
    exposed_srgb8(image, stops).to_vec()
}

/// The exposure, in stops, that maps an image's log-average luminance to 0.18.
pub fn key_exposure(reference: &RgbImage) -> f64 {
    let n = reference.pixels.len().max(1) as f64;
    let log_mean = reference
        .pixels
        .iter()
        .map(|p| luminance(*p).max(1e-9).log2())
        .sum::<f64>()
        / n;
    0.18f64.log2() - log_mean
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth HDR test image: a sky-like gradient with a bright disc.
    fn gradient(width: u32, height: u32) -> RgbImage {
        let pixels = (0..width * height)
            .map(|i| {
                let (x, y) = ((i % width) as f32, (i / width) as f32);
                let base = 0.05 + 0.5 * y / height as f32 + 0.2 * x / width as f32;
                let dx = x - width as f32 * 0.7;
                let dy = y - height as f32 * 0.3;
                let sun = if dx * dx + dy * dy < 16.0 { 50.0 } else { 0.0 };
                [base * 0.8 + sun, base * 0.9 + sun, base + sun]
            })
            .collect();
        RgbImage {
            width,
            height,
            pixels,
        }
    }

    #[test]
    fn identical_images_have_no_error() {
        let image = gradient(64, 48);
        let flip = hdr_flip(&image, &image, PIXELS_PER_DEGREE);
        assert!(flip.iter().all(|e| *e == 0.0));
        let m = metrics(&image, &image, &flip, &vec![true; flip.len()]);
        assert_eq!(m.hdr_flip_mean, 0.0);
        assert_eq!(m.luminance_relative_rmse, 0.0);
        assert!((m.mean_luminance_ratio - 1.0).abs() < 1e-12);
        assert_eq!(m.mean_chromaticity_difference_xy, 0.0);
    }

    /// HDR-FLIP chooses its exposures from the reference, so scaling both
    /// images by a power of two (a change of units) leaves it unchanged
    /// but for 8-bit rounding (Andersson et al. 2021, sec. 3).
    #[test]
    fn hdr_flip_is_invariant_to_the_units_of_radiance() {
        let reference = gradient(64, 48);
        let mut test = reference.clone();
        for p in &mut test.pixels {
            p[0] *= 1.3;
        }
        let scale = |img: &RgbImage, s: f32| RgbImage {
            pixels: img.pixels.iter().map(|p| p.map(|c| c * s)).collect(),
            ..img.clone()
        };
        let a = hdr_flip(&reference, &test, PIXELS_PER_DEGREE);
        let b = hdr_flip(
            &scale(&reference, 16.0),
            &scale(&test, 16.0),
            PIXELS_PER_DEGREE,
        );
        let mean = |v: &[f32]| v.iter().map(|x| f64::from(*x)).sum::<f64>() / v.len() as f64;
        assert!(mean(&a) > 0.01, "a 30 % red shift is visible: {}", mean(&a));
        assert!(
            (mean(&a) - mean(&b)).abs() < 0.01 * mean(&a),
            "{} vs {}",
            mean(&a),
            mean(&b)
        );
    }

    /// Larger differences give larger errors.
    #[test]
    fn hdr_flip_grows_with_the_difference() {
        let reference = gradient(64, 48);
        let mut previous = 0.0;
        for factor in [1.05f32, 1.3, 2.0, 4.0] {
            let test = RgbImage {
                pixels: reference
                    .pixels
                    .iter()
                    .map(|p| p.map(|c| c * factor))
                    .collect(),
                ..reference.clone()
            };
            let flip = hdr_flip(&reference, &test, PIXELS_PER_DEGREE);
            let mean = flip.iter().map(|x| f64::from(*x)).sum::<f64>() / flip.len() as f64;
            assert!(mean > previous, "×{factor}: {mean} ≤ {previous}");
            previous = mean;
        }
    }

    /// The exposure range: its start puts the brightest pixel at 0.85 on
    /// the tone curve, its stop the median pixel.
    #[test]
    fn exposures_span_the_reference_from_its_peak_to_its_median() {
        let reference = gradient(64, 48);
        let exposures = hdr_flip_exposures(&reference);
        let mut l: Vec<f64> = reference.pixels.iter().map(|p| luminance(*p)).collect();
        l.sort_by(f64::total_cmp);
        let first = exposures[0];
        let last = exposures[exposures.len() - 1];
        assert!((tone_map(l[l.len() - 1] * first.exp2()) - 0.85).abs() < 1e-9);
        assert!((tone_map(l[l.len() / 2] * last.exp2()) - 0.85).abs() < 1e-9);
        assert_eq!(exposures.len(), ((last - first).ceil() as usize).max(2));
    }

    #[test]
    fn metrics_of_a_uniform_scale() {
        let reference = gradient(16, 8);
        let test = RgbImage {
            pixels: reference
                .pixels
                .iter()
                .map(|p| p.map(|c| c * 1.5))
                .collect(),
            ..reference.clone()
        };
        let mask = vec![true; reference.pixels.len()];
        let m = metrics(&test, &reference, &vec![0.0; mask.len()], &mask);
        assert!((m.mean_luminance_ratio - 1.5).abs() < 1e-6);
        assert!(m.mean_chromaticity_difference_xy < 1e-9);
        // RMSE of 0.5 L over the mean L: 0.5·sqrt(mean L²)/mean L ≥ 0.5.
        assert!(m.luminance_relative_rmse >= 0.5 - 1e-9);
        assert!((m.red_over_blue_test - m.red_over_blue_reference).abs() < 1e-6);
    }

    /// Checked against NVIDIA's own implementation (`flip-evaluator` 1.7,
    /// the FLIP authors' package) on pairs of former realism references
    /// (tests/data/flip/; tools/reference/flip_check.py wrote
    /// tests/data/flip_nvidia.json):
    /// the exposures are NVIDIA's, the mean equals NVIDIA's pipeline with
    /// each exposure quantised to 8-bit sRGB (what the `nv-flip` crate
    /// takes), and it differs from NVIDIA's float HDR-FLIP by no more than
    /// that quantisation does.
    #[test]
    fn hdr_flip_matches_nvidias_implementation() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let data: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(root.join("tests/data/flip_nvidia.json"))
                .expect("the stored NVIDIA results"),
        )
        .expect("valid JSON");
        let load = |name: &str| {
            let path = root.join(format!("tests/data/flip/{name}.exr"));
            super::super::read_exr(&path)
                .expect("a stored image of tests/data/flip/")
                .image
        };
        let pairs = data["pairs"].as_array().expect("an array field");
        assert_eq!(pairs.len(), 4);
        for pair in pairs {
            let reference = load(pair["reference"].as_str().expect("a string field"));
            let scale: Vec<f32> = pair["test_scale"]
                .as_array()
                .expect("an array field")
                .iter()
                .map(|v| v.as_f64().expect("a number field") as f32)
                .collect();
            let test = if pair["test"] == "checkerboard" {
                // The reference × (1 ± 0.05) on a checkerboard, as in the script.
                let width = reference.width as usize;
                let pixels = reference
                    .pixels
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let even = (i % width + i / width).is_multiple_of(2);
                        let factor = if even { 1.0 + scale[0] } else { 1.0 - scale[0] };
                        p.map(|c| c * factor)
                    })
                    .collect();
                RgbImage {
                    pixels,
                    ..reference.clone()
                }
            } else {
                let mut image = load(pair["test"].as_str().expect("a string field"));
                for p in &mut image.pixels {
                    for (c, s) in p.iter_mut().zip(&scale) {
                        *c *= *s;
                    }
                }
                image
            };
            let exposures = hdr_flip_exposures(&reference);
            let name = format!("{} vs {}", pair["reference"], pair["test"]);
            assert_eq!(
                exposures.len() as u64,
                pair["exposures"].as_u64().expect("an integer field"),
                "{name}"
            );
            for (ours, key) in [
                (exposures[0], "start_exposure"),
                (exposures[exposures.len() - 1], "stop_exposure"),
            ] {
                let theirs = pair[key].as_f64().expect("a number field");
                assert!(
                    (ours - theirs).abs() < 1e-3,
                    "{name}: {key} {ours} vs NVIDIA's {theirs}"
                );
            }
            let flip = hdr_flip(&reference, &test, PIXELS_PER_DEGREE);
            let ours = flip.iter().map(|e| f64::from(*e)).sum::<f64>() / flip.len() as f64;
            let quantised = pair["hdr_flip_mean_8bit_exposures"]
                .as_f64()
                .expect("a number field");
            let float = pair["hdr_flip_mean"].as_f64().expect("a number field");
            assert!(
                (ours - quantised).abs() < 2e-4,
                "{name}: {ours} vs NVIDIA's 8-bit pipeline {quantised}"
            );
            assert!(
                (ours - float).abs() <= (quantised - float).abs() + 2e-4,
                "{name}: {ours} vs NVIDIA's HDR-FLIP {float}"
            );
        }
    }
}
