//! Phase-function plots: log-scale p(θ) against the scattering angle, like
//! Bouthors et al. 2006, fig. 4, drawn into a PNG without a plotting library.
//! The frame spans 0–180° (grid every 30°) and whole decades of p (grid
//! every decade); each curve has its own colour, red to blue in the order
//! given (long to short wavelengths).

use crate::output::write_atomically;
use anyhow::Context;

const WIDTH: u32 = 960;
const HEIGHT: u32 = 540;
const MARGIN: u32 = 40;

fn put(img: &mut image::RgbImage, x: i64, y: i64, color: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, image::Rgb(color));
    }
}

fn line(img: &mut image::RgbImage, (x0, y0): (f64, f64), (x1, y1): (f64, f64), color: [u8; 3]) {
    let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
    for s in 0..=steps {
        let t = s as f64 / steps as f64;
        let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
        put(img, x.round() as i64, y.round() as i64, color);
        put(img, x.round() as i64, y.round() as i64 + 1, color);
    }
}

/// Writes curves (label, angles in degrees, values in sr⁻¹) to a PNG.
pub fn write_phase_plot(
    path: &std::path::Path,
    curves: &[(String, Vec<f64>, Vec<f64>)],
) -> anyhow::Result<()> {
    let positive = curves
        .iter()
        .flat_map(|(_, _, v)| v.iter().copied())
        .filter(|v| *v > 0.0 && v.is_finite());
    let (lo, hi) = positive.fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
    anyhow::ensure!(lo <= hi, "--plot {}: nothing to plot", path.display());
    let (decade_lo, decade_hi) = (lo.log10().floor(), hi.log10().ceil());
    let mut img = image::RgbImage::from_pixel(WIDTH, HEIGHT, image::Rgb([255, 255, 255]));
    let (x0, x1) = (MARGIN as f64, (WIDTH - MARGIN) as f64);
    let (y0, y1) = ((HEIGHT - MARGIN) as f64, MARGIN as f64);
    let to_px = |angle: f64, value: f64| {
        let x = x0 + angle / 180.0 * (x1 - x0);
        let y = y0 + (value.max(lo).log10() - decade_lo) / (decade_hi - decade_lo) * (y1 - y0);
        (x, y)
    };
    let grid = [215, 215, 215];
    for a in (0..=180).step_by(30) {
        line(
            &mut img,
            to_px(a as f64, 10f64.powf(decade_lo)),
            to_px(a as f64, 10f64.powf(decade_hi)),
            grid,
        );
    }
    for d in decade_lo as i32..=decade_hi as i32 {
        line(
            &mut img,
            to_px(0.0, 10f64.powi(d)),
            to_px(180.0, 10f64.powi(d)),
            grid,
        );
    }
    line(&mut img, (x0, y0), (x1, y0), [0, 0, 0]);
    line(&mut img, (x0, y0), (x0, y1), [0, 0, 0]);
    let count = curves.len().max(2) - 1;
    for (k, (_, angles, values)) in curves.iter().enumerate() {
        let t = k as f64 / count as f64;
        let color = [
            (220.0 * (1.0 - t)) as u8,
            (140.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
            (220.0 * t) as u8,
        ];
        for i in 1..angles.len() {
            if values[i - 1] > 0.0 && values[i] > 0.0 {
                line(
                    &mut img,
                    to_px(angles[i - 1], values[i - 1]),
                    to_px(angles[i], values[i]),
                    color,
                );
            }
        }
    }
    let mut encoded = Vec::new();
    image::codecs::png::PngEncoder::new(&mut encoded)
        .write_image(img.as_raw(), WIDTH, HEIGHT, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("--plot {}: PNG encoding failed", path.display()))?;
    write_atomically(path, |temporary| {
        std::fs::write(temporary, &encoded)
            .with_context(|| format!("--plot {}: write failed", path.display()))
    })
}

use image::ImageEncoder;
