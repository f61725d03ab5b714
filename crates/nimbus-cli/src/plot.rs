//! Charts drawn into PNGs without a plotting library: a framed plot area
//! with linear or logarithmic axes, grid lines with tick labels, polylines
//! (solid or dashed), areas filled between two curves, and text in an 8×8
//! bitmap font (`font8x8`, ASCII), for the phase-function plots of
//! `nimbus optics dsd --plot` (like Bouthors et al. 2006, fig. 4) and the
//! per-order radiance plots of `nimbus slab plot` (like figs 6 and 9).

use crate::output::write_bytes_atomically;
use anyhow::Context;
use image::ImageEncoder;

/// An RGB colour.
pub type Color = [u8; 3];

/// Grid lines.
pub const GRID: Color = [220, 220, 220];
/// Frame and text.
pub const INK: Color = [0, 0, 0];

/// One axis: its range and scale.
#[derive(Clone, Copy, Debug)]
pub struct Axis {
    /// Lower end of the range.
    pub lo: f64,
    /// Upper end of the range.
    pub hi: f64,
    /// Logarithmic scale (the range must then be positive).
    pub log: bool,
}

impl Axis {
    /// A linear axis.
    pub fn linear(lo: f64, hi: f64) -> Self {
        Self { lo, hi, log: false }
    }

    /// A logarithmic axis.
    pub fn log(lo: f64, hi: f64) -> Self {
        Self { lo, hi, log: true }
    }

    /// Position of a value along the axis, 0 at `lo` and 1 at `hi`.
    fn fraction(&self, v: f64) -> f64 {
        if self.log {
            (v.max(self.lo * 1e-3).ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }
}

/// Line styles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stroke {
    /// Continuous, two pixels wide.
    Solid,
    /// Dashes of 8 pixels.
    Dashed,
}

/// A chart being drawn.
pub struct Chart {
    img: image::RgbImage,
    /// Plot area in pixels: left, top, right, bottom.
    frame: (f64, f64, f64, f64),
    x: Axis,
    y: Axis,
}

const LEFT_MARGIN: f64 = 76.0;
const RIGHT_MARGIN: f64 = 20.0;
const TOP_MARGIN: f64 = 36.0;
const BOTTOM_MARGIN: f64 = 48.0;

impl Chart {
    /// A white chart of `width` × `height` pixels with the given axes.
    pub fn new(width: u32, height: u32, x: Axis, y: Axis) -> Self {
        Self {
            img: image::RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255])),
            frame: (
                LEFT_MARGIN,
                TOP_MARGIN,
                width as f64 - RIGHT_MARGIN,
                height as f64 - BOTTOM_MARGIN,
            ),
            x,
            y,
        }
    }

    /// Pixel position of a data point.
    pub fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        let (l, t, r, b) = self.frame;
        (
            l + self.x.fraction(x) * (r - l),
            b + self.y.fraction(y) * (t - b),
        )
    }

    fn put(&mut self, x: i64, y: i64, color: Color) {
        let (l, t, r, b) = self.frame;
        let inside = (x as f64) >= l - 1.0
            && (x as f64) <= r + 1.0
            && (y as f64) >= t - 1.0
            && (y as f64) <= b + 1.0;
        if inside {
            self.put_anywhere(x, y, color);
        }
    }

    fn put_anywhere(&mut self, x: i64, y: i64, color: Color) {
        if x >= 0 && y >= 0 && (x as u32) < self.img.width() && (y as u32) < self.img.height() {
            self.img.put_pixel(x as u32, y as u32, image::Rgb(color));
        }
    }

    /// A pixel-space segment, clipped to the plot area; `phase` counts drawn
    /// pixels so that dashes run on across segments.
    fn segment(
        &mut self,
        (x0, y0): (f64, f64),
        (x1, y1): (f64, f64),
        color: Color,
        stroke: Stroke,
        phase: &mut usize,
    ) {
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for s in 0..=steps {
            *phase += 1;
            if stroke == Stroke::Dashed && (*phase / 8) % 2 == 1 {
                continue;
            }
            let t = s as f64 / steps as f64;
            let (x, y) = (
                (x0 + t * (x1 - x0)).round() as i64,
                (y0 + t * (y1 - y0)).round() as i64,
            );
            self.put(x, y, color);
            self.put(x, y + 1, color);
        }
    }

    /// Grid lines at the given data values, the frame, and tick labels
    /// written with `x_label` and `y_label`.
    pub fn grid(
        &mut self,
        x_ticks: &[f64],
        y_ticks: &[f64],
        x_label: impl Fn(f64) -> String,
        y_label: impl Fn(f64) -> String,
    ) {
        let (l, t, r, b) = self.frame;
        let mut phase = 0;
        for &x in x_ticks {
            let (px, _) = self.to_px(x, self.y.lo);
            self.segment((px, t), (px, b), GRID, Stroke::Solid, &mut phase);
            let label = x_label(x);
            let w = text_width(&label);
            self.text(px - w / 2.0, b + 8.0, &label, INK);
        }
        for &y in y_ticks {
            let (_, py) = self.to_px(self.x.lo, y);
            self.segment((l, py), (r, py), GRID, Stroke::Solid, &mut phase);
            let label = y_label(y);
            let w = text_width(&label);
            self.text(l - 6.0 - w, py - 4.0, &label, INK);
        }
        for (p, q) in [
            ((l, b), (r, b)),
            ((l, b), (l, t)),
            ((l, t), (r, t)),
            ((r, t), (r, b)),
        ] {
            self.segment(p, q, INK, Stroke::Solid, &mut phase);
        }
    }

    /// Axis titles: under the x axis and above the y axis.
    pub fn axis_titles(&mut self, x_title: &str, y_title: &str) {
        let (l, t, r, b) = self.frame;
        let w = text_width(x_title);
        self.text((l + r - w) / 2.0, b + 26.0, x_title, INK);
        self.text(8.0, t - 22.0, y_title, INK);
    }

    /// A title at the top right.
    pub fn title(&mut self, title: &str) {
        let (_, t, r, _) = self.frame;
        let w = text_width(title);
        self.text(r - w, t - 22.0, title, INK);
    }

    /// A polyline through data points; points that are not finite break it.
    pub fn polyline(&mut self, xs: &[f64], ys: &[f64], color: Color, stroke: Stroke) {
        let mut phase = 0;
        for i in 1..xs.len().min(ys.len()) {
            let ok = |k: usize| xs[k].is_finite() && ys[k].is_finite();
            if ok(i - 1) && ok(i) {
                let p = self.to_px(xs[i - 1], ys[i - 1]);
                let q = self.to_px(xs[i], ys[i]);
                self.segment(p, q, color, stroke, &mut phase);
            }
        }
    }

    /// Fills the area between two curves sampled at ascending `xs`, column
    /// by column, interpolating linearly between samples.
    pub fn fill_between(&mut self, xs: &[f64], lower: &[f64], upper: &[f64], color: Color) {
        if xs.len() < 2 {
            return;
        }
        let (l, _, r, _) = self.frame;
        for px in l.ceil() as i64..=r.floor() as i64 {
            let f = (px as f64 - l) / (r - l);
            let x = self.x.lo + f * (self.x.hi - self.x.lo);
            if x < xs[0] || x > xs[xs.len() - 1] {
                continue;
            }
            let i = xs.partition_point(|v| *v <= x).clamp(1, xs.len() - 1);
            let s = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
            let lerp = |v: &[f64]| v[i - 1] + s * (v[i] - v[i - 1]);
            let (_, y0) = self.to_px(x, lerp(lower));
            let (_, y1) = self.to_px(x, lerp(upper));
            let (top, bottom) = (y0.min(y1).round() as i64, y0.max(y1).round() as i64);
            for py in top..=bottom {
                self.put(px, py, color);
            }
        }
    }

    /// A vertical marker line at data `x` with a label above the plot area.
    pub fn marker(&mut self, x: f64, label: &str, color: Color) {
        let (_, t, _, b) = self.frame;
        let (px, _) = self.to_px(x, self.y.lo);
        let mut phase = 0;
        self.segment((px, t), (px, b), color, Stroke::Dashed, &mut phase);
        let w = text_width(label);
        self.text(px - w / 2.0, t + 4.0, label, color);
    }

    /// A legend box in the top-left corner of the plot area: one line per
    /// entry, with a swatch (a filled square for areas, a line otherwise).
    pub fn legend(&mut self, entries: &[(String, Color, Option<Stroke>)]) {
        let (l, t, _, _) = self.frame;
        let width = entries
            .iter()
            .map(|(s, _, _)| text_width(s))
            .fold(0.0, f64::max)
            + 40.0;
        let height = 14.0 * entries.len() as f64 + 8.0;
        let (x0, y0) = (l + 10.0, t + 20.0);
        for py in y0 as i64..(y0 + height) as i64 {
            for px in x0 as i64..(x0 + width) as i64 {
                self.put(px, py, [255, 255, 255]);
            }
        }
        for (k, (label, color, stroke)) in entries.iter().enumerate() {
            let y = y0 + 6.0 + 14.0 * k as f64;
            match stroke {
                None => {
                    for py in y as i64..y as i64 + 8 {
                        for px in (x0 + 6.0) as i64..(x0 + 26.0) as i64 {
                            self.put(px, py, *color);
                        }
                    }
                }
                Some(stroke) => {
                    let mut phase = 0;
                    self.segment(
                        (x0 + 6.0, y + 3.0),
                        (x0 + 28.0, y + 3.0),
                        *color,
                        *stroke,
                        &mut phase,
                    );
                }
            }
            self.text(x0 + 34.0, y, label, INK);
        }
    }

    /// Text with its top-left corner at a pixel position.
    pub fn text(&mut self, x: f64, y: f64, text: &str, color: Color) {
        for (k, c) in text.chars().enumerate() {
            let glyph = font8x8::legacy::BASIC_LEGACY
                .get(c as usize)
                .copied()
                .unwrap_or([0; 8]);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        self.put_anywhere(
                            (x + 8.0 * k as f64) as i64 + col,
                            y as i64 + row as i64,
                            color,
                        );
                    }
                }
            }
        }
    }

    /// Encodes the chart and writes it atomically; `flag` names the option
    /// that gave the path, for error messages.
    pub fn write_png(self, path: &std::path::Path, flag: &str) -> anyhow::Result<()> {
        let (w, h) = self.img.dimensions();
        let mut encoded = Vec::new();
        image::codecs::png::PngEncoder::new(&mut encoded)
            .write_image(self.img.as_raw(), w, h, image::ExtendedColorType::Rgb8)
            .with_context(|| format!("{flag} {}: PNG encoding failed", path.display()))?;
        write_bytes_atomically(path, flag, &encoded)
    }
}

/// Width in pixels of a text line.
pub fn text_width(text: &str) -> f64 {
    8.0 * text.chars().count() as f64
}

/// Colours for `count` curves from red to blue (long to short wavelengths).
fn spectrum_color(k: usize, count: usize) -> Color {
    let t = k as f64 / (count.max(2) - 1) as f64;
    [
        (220.0 * (1.0 - t)) as u8,
        (140.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
        (220.0 * t) as u8,
    ]
}

/// Writes phase functions (label, angles in degrees, values in sr⁻¹) as
/// log-scale curves against the scattering angle over 0–180°, the frame
/// spanning whole decades.
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
    let (decade_lo, decade_hi) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let mut chart = Chart::new(
        960,
        540,
        Axis::linear(0.0, 180.0),
        Axis::log(
            10f64.powi(decade_lo),
            10f64.powi(decade_hi.max(decade_lo + 1)),
        ),
    );
    let x_ticks: Vec<f64> = (0..=6).map(|k| 30.0 * k as f64).collect();
    let y_ticks: Vec<f64> = (decade_lo..=decade_hi).map(|d| 10f64.powi(d)).collect();
    chart.grid(
        &x_ticks,
        &y_ticks,
        |x| format!("{x:.0}"),
        |y| format!("1e{}", y.log10().round()),
    );
    chart.axis_titles(
        "scattering angle (deg)",
        "phase function (1/sr, normalised to 1 over the sphere)",
    );
    let mut legend = Vec::new();
    for (k, (label, angles, values)) in curves.iter().enumerate() {
        let color = spectrum_color(k, curves.len());
        let masked: Vec<f64> = values
            .iter()
            .map(|v| if *v > 0.0 { *v } else { f64::NAN })
            .collect();
        chart.polyline(angles, &masked, color, Stroke::Solid);
        legend.push((label.clone(), color, Some(Stroke::Solid)));
    }
    chart.legend(&legend);
    chart.write_png(path, "--plot")
}
