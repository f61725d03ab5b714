//! Figures drawn with `plotters`: line and area charts over a linear x axis
//! and a linear or logarithmic y axis, written as PNG (a bitmap whose text is
//! drawn with the DejaVu Sans font embedded in the binary, through
//! `ab_glyph`, so no system font is needed) or SVG (vector, text kept as
//! text), chosen by the output path's extension. Used for the phase-function
//! plots of `nimbus optics dsd --plot` (like Bouthors et al. 2006, fig. 4)
//! and the per-order radiance plots of `nimbus slab plot` (figs 6 and 9).
//!
//! Everything is drawn in plot coordinates: the data value on linear axes,
//! log₁₀ of it on logarithmic ones. Lines are clipped to the plot area here,
//! because plotters draws whatever it is given, margins included.

use crate::output::write_bytes_atomically;
use anyhow::Context;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::{
    BitMapBackend, ChartBuilder, Color, DrawingArea, DrawingAreaErrorKind, DrawingBackend,
    EmptyElement, IntoDrawingArea, PathElement, Polygon, RGBColor, Rectangle, SVGBackend,
    SeriesLabelPosition, ShapeStyle, Text, WHITE,
};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, IntoTextStyle, TextStyle};
use std::ops::Range;
use std::path::Path;

/// The font family every text of a figure uses. The embedded font is
/// registered under the generic CSS name so that SVG viewers, which draw
/// the text with their own fonts, pick a sans-serif face too.
const FONT_FAMILY: &str = "sans-serif";

/// DejaVu Sans 2.37 (Bitstream Vera licence, see `assets/fonts/`): it has
/// the Greek letters, superscripts and signs the labels use.
static DEJAVU_SANS: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

/// Registers the embedded font with plotters, once per process. Bitmap
/// text needs it to draw glyphs and SVG text to measure the labels.
fn register_embedded_font() -> anyhow::Result<()> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let registered = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok()
    });
    anyhow::ensure!(
        registered,
        "embedded font assets/fonts/DejaVuSans.ttf: not a valid TrueType font"
    );
    Ok(())
}

/// An RGB colour.
pub type Rgb = [u8; 3];

/// The file formats of figures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FigureFormat {
    /// An 8-bit RGB PNG.
    Png,
    /// An SVG document.
    Svg,
}

impl FigureFormat {
    /// The format of an output path, from its extension; `flag` names the
    /// option that gave the path, for the error message.
    pub fn from_path(path: &Path, flag: &str) -> anyhow::Result<Self> {
        match crate::output::lowercase_extension(path).as_deref() {
            Some("png") => Ok(Self::Png),
            Some("svg") => Ok(Self::Svg),
            other => anyhow::bail!(
                "{flag} {}: extension {} is not supported for figures; use .png or .svg",
                path.display(),
                other.map_or("(none)".to_owned(), |e| format!(".{e}"))
            ),
        }
    }
}

/// Axis scales.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    Linear,
    /// Logarithmic, base 10.
    Log,
}

/// One axis: range, scale, grid lines and title.
#[derive(Clone, Debug)]
pub struct Axis {
    /// The range in plot coordinates (log₁₀ of the data on log axes).
    range: Range<f64>,
    scale: Scale,
    /// Labelled grid lines, plot coordinates.
    ticks: Vec<f64>,
    /// Unlabelled light grid lines, plot coordinates.
    minor_ticks: Vec<f64>,
    title: String,
}

impl Axis {
    /// A linear axis from `lo` to `hi` with labelled grid lines at `ticks`.
    pub fn linear(lo: f64, hi: f64, ticks: Vec<f64>, title: impl Into<String>) -> Self {
        Self {
            range: lo..hi,
            scale: Scale::Linear,
            ticks,
            minor_ticks: Vec::new(),
            title: title.into(),
        }
    }

    /// A logarithmic axis over whole decades, 10^`lo_decade` to
    /// 10^`hi_decade`, labelled at every decade, with light lines at 2–9 ×
    /// 10ⁿ when there are few enough decades for them to stay apart.
    pub fn log_decades(lo_decade: i32, hi_decade: i32, title: impl Into<String>) -> Self {
        let hi_decade = hi_decade.max(lo_decade + 1);
        let minor_ticks = if hi_decade - lo_decade <= 8 {
            (lo_decade..hi_decade)
                .flat_map(|d| (2..=9).map(move |k| d as f64 + (k as f64).log10()))
                .collect()
        } else {
            Vec::new()
        };
        Self {
            range: lo_decade as f64..hi_decade as f64,
            scale: Scale::Log,
            ticks: (lo_decade..=hi_decade).map(f64::from).collect(),
            minor_ticks,
            title: title.into(),
        }
    }

    /// A data value in plot coordinates; `None` where it cannot be shown
    /// (not finite, or not positive on a log axis).
    fn to_plot(&self, v: f64) -> Option<f64> {
        match self.scale {
            Scale::Linear => v.is_finite().then_some(v),
            Scale::Log => (v.is_finite() && v > 0.0).then(|| v.log10()),
        }
    }

    /// A data value in plot coordinates, held inside the axis range: values
    /// that cannot be shown go to the bottom (for the edges of areas).
    fn to_plot_clamped(&self, v: f64) -> f64 {
        self.to_plot(v)
            .unwrap_or(self.range.start)
            .clamp(self.range.start, self.range.end)
    }

    /// The label of a grid line at plot coordinate `v`.
    fn label(&self, v: f64) -> String {
        match self.scale {
            Scale::Log => power_of_ten(v.round() as i32),
            Scale::Linear => {
                let step = self
                    .ticks
                    .windows(2)
                    .map(|w| (w[1] - w[0]).abs())
                    .fold(f64::MAX, f64::min);
                linear_label(v, step)
            }
        }
    }
}

/// An axis as plotters sees it: a linear map of plot coordinates with our
/// grid lines as its key points (plotters' own choice of ticks knows nothing
/// of whole decades in log₁₀ coordinates).
struct GridCoord {
    linear: RangedCoordf64,
    ticks: Vec<f64>,
    minor_ticks: Vec<f64>,
}

impl GridCoord {
    fn new(axis: &Axis) -> Self {
        Self {
            linear: axis.range.clone().into(),
            ticks: axis.ticks.clone(),
            minor_ticks: axis.minor_ticks.clone(),
        }
    }
}

impl Ranged for GridCoord {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.linear.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor_ticks.clone()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.linear.range()
    }
}

/// `10ⁿ` with the exponent in superscript digits.
fn power_of_ten(exponent: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut label = String::from("10");
    if exponent < 0 {
        label.push('⁻');
    }
    for c in exponent.unsigned_abs().to_string().chars() {
        label.push(c.to_digit(10).map_or(c, |d| DIGITS[d as usize]));
    }
    label
}

/// A grid-line value with as many decimals as the grid step needs (at
/// most 6) and a true minus sign.
fn linear_label(v: f64, step: f64) -> String {
    let decimals = (0..=6)
        .find(|d| {
            let scaled = step * 10f64.powi(*d);
            (scaled - scaled.round()).abs() <= 1e-6 * scaled.max(1.0)
        })
        .unwrap_or(6) as usize;
    let text = format!("{:.*}", decimals, v);
    // "-0" and "-0.00" from values a rounding error below zero.
    if text.trim_start_matches(['-', '0', '.']).is_empty() {
        return format!("{:.*}", decimals, 0.0);
    }
    text.replace('-', "−")
}

/// Line styles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stroke {
    /// Continuous.
    Solid,
    /// Dashed.
    Dashed,
}

/// A curve through data points; points that cannot be shown break it.
#[derive(Clone, Debug)]
pub struct Line {
    /// Legend text, if the curve is in the legend.
    pub label: Option<String>,
    /// Colour.
    pub color: Rgb,
    /// Solid or dashed.
    pub stroke: Stroke,
    /// Data points, in order along the curve.
    pub points: Vec<(f64, f64)>,
}

/// The area between two curves sampled at the same ascending x values.
#[derive(Clone, Debug)]
pub struct Area {
    /// Legend text, if the area is in the legend.
    pub label: Option<String>,
    /// Fill colour.
    pub color: Rgb,
    /// Ascending x values.
    pub xs: Vec<f64>,
    /// The lower edge at each x.
    pub lower: Vec<f64>,
    /// The upper edge at each x.
    pub upper: Vec<f64>,
}

/// A dashed vertical line at one x, labelled at the top of the plot area.
#[derive(Clone, Debug)]
pub struct Marker {
    /// Where, in data units.
    pub x: f64,
    /// The label.
    pub label: String,
    /// Colour of the line and label.
    pub color: Rgb,
}

/// Where the legend box goes in the plot area.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LegendPosition {
    /// Top, centred.
    UpperMiddle,
    /// Top right corner.
    UpperRight,
}

/// A chart: axes, areas (drawn first, in order), lines, markers, legend.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Size in pixels (PNG) or user units (SVG).
    pub size: (u32, u32),
    /// A title above the plot area.
    pub caption: Option<String>,
    /// The horizontal axis.
    pub x: Axis,
    /// The vertical axis.
    pub y: Axis,
    /// Filled areas.
    pub areas: Vec<Area>,
    /// Curves.
    pub lines: Vec<Line>,
    /// Vertical markers.
    pub markers: Vec<Marker>,
    /// Where the legend goes.
    pub legend: LegendPosition,
}

const TICK_LABEL_PX: u32 = 15;
const AXIS_TITLE_PX: u32 = 17;
const CAPTION_PX: u32 = 19;
/// Grid lines at labelled values, and the light ones between.
const GRID: RGBColor = RGBColor(205, 205, 205);
const LIGHT_GRID: RGBColor = RGBColor(236, 236, 236);
const INK: RGBColor = RGBColor(0, 0, 0);

fn rgb(c: Rgb) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

impl Figure {
    /// Draws the figure in the format of `path`'s extension and writes it
    /// atomically; `flag` names the option that gave the path, for error
    /// messages.
    pub fn write(&self, path: &Path, flag: &str) -> anyhow::Result<()> {
        let format = FigureFormat::from_path(path, flag)?;
        let bytes = self
            .render(format)
            .with_context(|| format!("{flag} {}: drawing the figure failed", path.display()))?;
        write_bytes_atomically(path, flag, &bytes)
    }

    /// The encoded file: PNG bytes or SVG text.
    pub fn render(&self, format: FigureFormat) -> anyhow::Result<Vec<u8>> {
        register_embedded_font()?;
        let (w, h) = self.size;
        anyhow::ensure!(
            (64..=8192).contains(&w) && (64..=8192).contains(&h),
            "figure size {w}×{h}: each side must be in [64, 8192] pixels"
        );
        match format {
            FigureFormat::Svg => {
                let mut svg = String::new();
                {
                    let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                    self.draw(&root).map_err(|e| anyhow::anyhow!("{e}"))?;
                    root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
                }
                Ok(svg.into_bytes())
            }
            FigureFormat::Png => {
                let mut pixels = vec![0u8; w as usize * h as usize * 3];
                {
                    let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
                    self.draw(&root).map_err(|e| anyhow::anyhow!("{e}"))?;
                    root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
                }
                use image::ImageEncoder;
                let mut encoded = Vec::new();
                image::codecs::png::PngEncoder::new(&mut encoded)
                    .write_image(&pixels, w, h, image::ExtendedColorType::Rgb8)
                    .context("PNG encoding failed")?;
                Ok(encoded)
            }
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        root.fill(&WHITE)?;
        let font = |px: u32| (FONT_FAMILY, px).into_text_style(root);
        let mut builder = ChartBuilder::on(root);
        builder
            .margin(14)
            .margin_right(24)
            .x_label_area_size(58)
            .y_label_area_size(86);
        if let Some(caption) = &self.caption {
            builder.caption(caption, font(CAPTION_PX));
        }
        let mut chart =
            builder.build_cartesian_2d(GridCoord::new(&self.x), GridCoord::new(&self.y))?;
        let x_label = |v: &f64| self.x.label(*v);
        let y_label = |v: &f64| self.y.label(*v);
        chart
            .configure_mesh()
            .x_desc(self.x.title.as_str())
            .y_desc(self.y.title.as_str())
            .x_label_formatter(&x_label)
            .y_label_formatter(&y_label)
            .label_style(font(TICK_LABEL_PX))
            .axis_desc_style(font(AXIS_TITLE_PX))
            .bold_line_style(GRID)
            .light_line_style(LIGHT_GRID)
            .axis_style(INK)
            .draw()?;

        let (x_range, y_range) = (self.x.range.clone(), self.y.range.clone());
        let mut labelled = false;
        for area in &self.areas {
            let edge = |values: &[f64], k: usize| {
                (
                    area.xs[k].clamp(x_range.start, x_range.end),
                    self.y.to_plot_clamped(values[k]),
                )
            };
            let n = area.xs.len().min(area.lower.len()).min(area.upper.len());
            let outline: Vec<(f64, f64)> = (0..n)
                .map(|k| edge(&area.upper, k))
                .chain((0..n).rev().map(|k| edge(&area.lower, k)))
                .collect();
            let color = rgb(area.color);
            let series =
                chart.draw_series((n >= 2).then(|| Polygon::new(outline, color.filled())))?;
            if let Some(label) = &area.label {
                labelled = true;
                series.label(label).legend(move |(x, y)| {
                    Rectangle::new([(x, y - 6), (x + 22, y + 6)], color.filled())
                });
            }
        }
        for line in &self.lines {
            let points: Vec<Option<(f64, f64)>> = line
                .points
                .iter()
                .map(|&(x, y)| Some((self.x.to_plot(x)?, self.y.to_plot(y)?)))
                .collect();
            let runs = clip_polyline(&points, &x_range, &y_range);
            let style = ShapeStyle::from(rgb(line.color)).stroke_width(2);
            let series = match line.stroke {
                Stroke::Solid => {
                    chart.draw_series(runs.into_iter().map(|run| PathElement::new(run, style)))?
                }
                Stroke::Dashed => chart.draw_series(
                    runs.into_iter()
                        .map(|run| DashedPathElement::new(run, 7, 5, style)),
                )?,
            };
            if let Some(label) = &line.label {
                labelled = true;
                match line.stroke {
                    Stroke::Solid => series
                        .label(label)
                        .legend(move |(x, y)| PathElement::new([(x, y), (x + 22, y)], style)),
                    Stroke::Dashed => series.label(label).legend(move |(x, y)| {
                        DashedPathElement::new([(x, y), (x + 22, y)], 7, 5, style)
                    }),
                };
            }
        }
        for marker in &self.markers {
            let Some(x) = self
                .x
                .to_plot(marker.x)
                .filter(|x| x_range.contains(x) || *x == x_range.end)
            else {
                continue;
            };
            let color = rgb(marker.color);
            chart.draw_series(std::iter::once(DashedPathElement::new(
                [(x, y_range.start), (x, y_range.end)],
                6,
                4,
                ShapeStyle::from(color).stroke_width(1),
            )))?;
            // The label beside the line, not across it, on the side with
            // room, over a light box that keeps it legible across the grid.
            let style: TextStyle = font(TICK_LABEL_PX).color(&color);
            let (w, h) = root.estimate_text_size(&marker.label, &style)?;
            let (w, h) = (w as i32, h as i32);
            let right_side = (x - x_range.start) < 0.8 * (x_range.end - x_range.start);
            let left = if right_side { 5 } else { -5 - w };
            chart.draw_series(std::iter::once(
                EmptyElement::at((x, y_range.end))
                    + Rectangle::new(
                        [(left - 2, 4), (left + w + 2, 8 + h)],
                        WHITE.mix(0.85).filled(),
                    )
                    + Text::new(
                        marker.label.clone(),
                        (left, 6),
                        style.pos(Pos::new(HPos::Left, VPos::Top)),
                    ),
            ))?;
        }
        if labelled {
            chart
                .configure_series_labels()
                .position(match self.legend {
                    LegendPosition::UpperMiddle => SeriesLabelPosition::UpperMiddle,
                    LegendPosition::UpperRight => SeriesLabelPosition::UpperRight,
                })
                .margin(8)
                .legend_area_size(34)
                .label_font(font(TICK_LABEL_PX))
                .background_style(WHITE.mix(0.9))
                .border_style(GRID)
                .draw()?;
        }
        Ok(())
    }
}

/// Splits a polyline in plot coordinates (`None` where a point cannot be
/// shown) into runs inside the box `x` × `y`, each segment clipped to the
/// box (Liang & Barsky 1984), so that a curve leaving the box ends at its
/// edge instead of running into the margins.
fn clip_polyline(
    points: &[Option<(f64, f64)>],
    x: &Range<f64>,
    y: &Range<f64>,
) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    let mut flush = |run: &mut Vec<(f64, f64)>| {
        if run.len() >= 2 {
            runs.push(std::mem::take(run));
        }
        run.clear();
    };
    for pair in points.windows(2) {
        let clipped = match (pair[0], pair[1]) {
            (Some(p), Some(q)) => clip_segment(p, q, x, y),
            _ => None,
        };
        match clipped {
            Some((a, b)) => {
                if run.last() != Some(&a) {
                    flush(&mut run);
                    run.push(a);
                }
                run.push(b);
            }
            None => flush(&mut run),
        }
    }
    flush(&mut run);
    runs
}

/// The part of segment `p`–`q` inside the box, or `None`; an end that is
/// inside is returned unchanged, so that consecutive segments still join.
fn clip_segment(
    p: (f64, f64),
    q: (f64, f64),
    x: &Range<f64>,
    y: &Range<f64>,
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (q.0 - p.0, q.1 - p.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    // Each edge as (−direction, distance from p to the edge): inside
    // where t · direction ≤ distance.
    for (dir, dist) in [
        (-dx, p.0 - x.start),
        (dx, x.end - p.0),
        (-dy, p.1 - y.start),
        (dy, y.end - p.1),
    ] {
        if dir == 0.0 {
            if dist < 0.0 {
                return None;
            }
        } else {
            let t = dist / dir;
            if dir < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| (p.0 + t * dx, p.1 + t * dy);
    let a = if t0 == 0.0 { p } else { at(t0) };
    let b = if t1 == 1.0 { q } else { at(t1) };
    Some((a, b))
}

/// Colours for `count` curves from red to blue (long to short wavelengths).
fn spectrum_color(k: usize, count: usize) -> Rgb {
    let t = k as f64 / (count.max(2) - 1) as f64;
    [
        (220.0 * (1.0 - t)) as u8,
        (140.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
        (220.0 * t) as u8,
    ]
}

/// Writes phase functions (label, angles in degrees, values in sr⁻¹) as
/// curves on a log scale against the scattering angle over 0–180°, the
/// axis spanning whole decades; `flag` names the option that gave `path`.
pub fn write_phase_plot(
    path: &Path,
    flag: &str,
    curves: &[(String, Vec<f64>, Vec<f64>)],
) -> anyhow::Result<()> {
    let positive = curves
        .iter()
        .flat_map(|(_, _, v)| v.iter().copied())
        .filter(|v| *v > 0.0 && v.is_finite());
    let (lo, hi) = positive.fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
    anyhow::ensure!(
        lo <= hi,
        "{flag} {}: nothing to plot (no positive phase-function value)",
        path.display()
    );
    let figure = Figure {
        size: (960, 540),
        caption: None,
        x: Axis::linear(
            0.0,
            180.0,
            (0..=6).map(|k| 30.0 * k as f64).collect(),
            "scattering angle θ (°)",
        ),
        y: Axis::log_decades(
            lo.log10().floor() as i32,
            hi.log10().ceil() as i32,
            "phase function p(θ) (sr⁻¹), ∫p dΩ = 1",
        ),
        areas: Vec::new(),
        lines: curves
            .iter()
            .enumerate()
            .map(|(k, (label, angles, values))| Line {
                label: Some(label.clone()),
                color: spectrum_color(k, curves.len()),
                stroke: Stroke::Solid,
                points: angles.iter().copied().zip(values.iter().copied()).collect(),
            })
            .collect(),
        markers: Vec::new(),
        // The forward peak fills the top left; the curves are low on the right.
        legend: LegendPosition::UpperRight,
    };
    figure.write(path, flag)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_follow_the_extension_and_others_are_refused() {
        assert_eq!(
            FigureFormat::from_path(Path::new("a/fig.PNG"), "--out").expect("png"),
            FigureFormat::Png
        );
        assert_eq!(
            FigureFormat::from_path(Path::new("fig.svg"), "--out").expect("svg"),
            FigureFormat::Svg
        );
        let error = FigureFormat::from_path(Path::new("fig.pdf"), "--plot")
            .expect_err("pdf")
            .to_string();
        assert_eq!(
            error,
            "--plot fig.pdf: extension .pdf is not supported for figures; use .png or .svg"
        );
        let error = FigureFormat::from_path(Path::new("fig"), "--plot")
            .expect_err("none")
            .to_string();
        assert!(error.contains("(none)"), "{error}");
    }

    #[test]
    fn tick_labels_use_superscripts_and_true_minus_signs() {
        assert_eq!(power_of_ten(-12), "10⁻¹²");
        assert_eq!(power_of_ten(0), "10⁰");
        assert_eq!(power_of_ten(3), "10³");
        assert_eq!(linear_label(-45.0, 15.0), "−45");
        assert_eq!(linear_label(0.48, 0.24), "0.48");
        assert_eq!(linear_label(1.6, 1.6), "1.6");
        assert_eq!(linear_label(-1e-17, 0.5), "0.0");
        let axis = Axis::log_decades(-2, 4, "p");
        assert_eq!(axis.ticks.len(), 7);
        assert_eq!(axis.minor_ticks.len(), 6 * 8);
        assert_eq!(axis.label(-2.0), "10⁻²");
        assert_eq!(axis.to_plot(0.0), None);
        assert_eq!(axis.to_plot_clamped(0.0), -2.0);
        assert_eq!(axis.to_plot_clamped(1e9), 4.0);
    }

    #[test]
    fn lines_are_clipped_to_the_box_and_broken_where_points_are_missing() {
        let (x, y) = (0.0..10.0, 0.0..1.0);
        // Inside, then up through the top edge at x = 2.5, back in at 3.5.
        let points = [
            Some((0.0, 0.5)),
            Some((2.0, 0.9)),
            Some((3.0, 1.9)),
            Some((4.0, 0.9)),
            None,
            Some((5.0, 0.5)),
            Some((6.0, 0.5)),
            Some((7.0, -3.0)),
            Some((8.0, -3.0)),
        ];
        let runs = clip_polyline(&points, &x, &y);
        assert_eq!(runs.len(), 3, "{runs:?}");
        assert_eq!(runs[0][..2], [(0.0, 0.5), (2.0, 0.9)]);
        let (ex, ey) = runs[0][2];
        assert!(
            (ex - 2.1).abs() < 1e-12 && (ey - 1.0).abs() < 1e-12,
            "{ex} {ey}"
        );
        let (sx, sy) = runs[1][0];
        assert!(
            (sx - 3.9).abs() < 1e-12 && (sy - 1.0).abs() < 1e-12,
            "{sx} {sy}"
        );
        assert_eq!(runs[1][1], (4.0, 0.9));
        // After the gap: from 5 down to where it leaves the bottom.
        assert_eq!(runs[2][0], (5.0, 0.5));
        let (bx, by) = runs[2][2];
        assert!(
            (bx - (6.0 + 0.5 / 3.5)).abs() < 1e-12 && by == 0.0,
            "{bx} {by}"
        );
        // Entirely outside: nothing.
        assert!(clip_polyline(&[Some((0.0, 2.0)), Some((9.0, 3.0))], &x, &y).is_empty());
    }

    /// The embedded font has a glyph for every symbol the labels use: each
    /// renders differently from a character it lacks (drawn as .notdef).
    #[test]
    fn embedded_font_has_the_symbols_of_the_labels() {
        register_embedded_font().expect("font");
        let draw = |text: &str| -> Vec<u8> {
            let mut pixels = vec![255u8; 48 * 48 * 3];
            {
                let root = BitMapBackend::with_buffer(&mut pixels, (48, 48)).into_drawing_area();
                root.draw(&Text::new(
                    text,
                    (8, 8),
                    (FONT_FAMILY, 32).into_text_style(&root),
                ))
                .expect("draw");
                root.present().expect("present");
            }
            pixels
        };
        let notdef = draw("\u{E000}");
        for symbol in "θµτλΩ∫°−’–⁻⁰¹²³⁴⁵⁶⁷⁸⁹".chars() {
            let glyph = draw(&symbol.to_string());
            assert!(glyph.iter().any(|v| *v < 128), "{symbol} draws nothing");
            // Not assert_ne!, which would print both bitmaps.
            assert!(glyph != notdef, "{symbol} is missing from the font");
        }
    }

    #[test]
    fn svg_keeps_the_labels_as_text_and_png_draws_them() {
        let figure = Figure {
            size: (400, 300),
            caption: Some("τ = 3.68".into()),
            x: Axis::linear(0.0, 180.0, vec![0.0, 90.0, 180.0], "θ (°)"),
            y: Axis::log_decades(-1, 2, "p(θ) (sr⁻¹)"),
            areas: vec![Area {
                label: Some("area".into()),
                color: [200, 200, 250],
                xs: vec![0.0, 180.0],
                lower: vec![0.0, 0.0],
                upper: vec![10.0, 1.0],
            }],
            lines: vec![Line {
                label: Some("550 nm".into()),
                color: [0, 0, 0],
                stroke: Stroke::Dashed,
                points: vec![(0.0, 50.0), (90.0, 0.5), (180.0, 1e-3)],
            }],
            markers: vec![Marker {
                x: 140.0,
                label: "fogbow".into(),
                color: [120, 0, 120],
            }],
            legend: LegendPosition::UpperRight,
        };
        let svg = String::from_utf8(figure.render(FigureFormat::Svg).expect("svg")).expect("utf-8");
        for text in ["τ = 3.68", "θ (°)", "sr⁻¹", "10⁻¹", "550 nm", "fogbow"] {
            assert!(svg.contains(text), "SVG lacks {text}");
        }
        let png = figure.render(FigureFormat::Png).expect("png");
        let image = image::load_from_memory(&png).expect("decodes").to_rgb8();
        assert_eq!(image.dimensions(), (400, 300));
        // The caption's band above the plot area holds dark text pixels.
        let dark = (0..300)
            .flat_map(|x| (0..20).map(move |y| (x, y)))
            .filter(|&(x, y)| image.get_pixel(x, y).0.iter().all(|c| *c < 100))
            .count();
        assert!(dark > 20, "{dark} dark pixels in the caption band");
    }
}
