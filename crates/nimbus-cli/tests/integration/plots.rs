//! Integration tests of the figures of `nimbus optics dsd --plot` and
//! `nimbus slab plot`: PNG or SVG by extension, labels with their real
//! symbols (drawn with the embedded font in PNGs, kept as text in SVGs),
//! other extensions refused in one line before any work, nothing left behind.

use crate::support::*;
use std::path::Path;
use std::process::Output;

/// A quick `nimbus optics dsd` writing its plot to `plot`.
fn phase_plot(dir: &Path, plot: &str) -> Output {
    nimbus(
        &[
            "optics",
            "dsd",
            "--wavelength-nm",
            "650,450",
            "--angle-step-deg",
            "5",
            "--tolerance",
            "0.01",
            "--plot",
            plot,
        ],
        dir,
    )
}

/// A quick `nimbus slab plot` writing `out`.
fn slab_plot(dir: &Path, out: &str) -> Output {
    nimbus(
        &[
            "slab",
            "plot",
            "--thickness-m",
            "100",
            "--sun-zenith-deg",
            "70",
            "--photons",
            "4096",
            "--step-deg",
            "5",
            "--out",
            out,
        ],
        dir,
    )
}

/// Pixels darker than mid-grey (text and lines on the white background).
fn dark_pixels(
    image: &image::RgbImage,
    xs: std::ops::Range<u32>,
    ys: std::ops::Range<u32>,
) -> usize {
    xs.flat_map(|x| ys.clone().map(move |y| (x, y)))
        .filter(|&(x, y)| image.get_pixel(x, y).0.iter().all(|c| *c < 100))
        .count()
}

#[test]
fn phase_plot_svg_labels_carry_greek_letters_and_units() {
    let dir = temp_dir("plots", "phase-svg");
    assert_success(&phase_plot(&dir, "phase.svg"));
    let svg = std::fs::read_to_string(dir.join("phase.svg")).expect("svg");
    assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(80)]);
    for text in [
        "scattering angle θ (°)",
        "sr⁻¹",
        "650 nm",
        "450 nm",
        "10⁰",
        "10⁻¹",
    ] {
        assert!(svg.contains(text), "the SVG lacks `{text}`");
    }
    // Two curves: one polyline each at least (runs between clipped parts).
    assert!(svg.matches("<polyline").count() >= 2);
}

#[test]
fn phase_plot_png_draws_its_axis_titles() {
    let dir = temp_dir("plots", "phase-png");
    assert_success(&phase_plot(&dir, "phase.png"));
    let image = image::open(dir.join("phase.png"))
        .expect("decodes")
        .to_rgb8();
    let (w, h) = image.dimensions();
    assert_eq!((w, h), (960, 540));
    // The x-axis title's band (under the tick labels) and the strip of the
    // rotated y-axis title: only text is drawn there.
    let x_title = dark_pixels(&image, 0..w, h - 40..h - 8);
    let y_title = dark_pixels(&image, 0..30, 0..h);
    assert!(x_title > 150, "{x_title} dark pixels in the x title band");
    assert!(y_title > 150, "{y_title} dark pixels in the y title strip");
    // Nothing but white in the outer margin corners.
    assert_eq!(dark_pixels(&image, 0..30, h - 30..h), 0);
}

#[test]
fn slab_plot_svg_caption_names_tau_and_lambda() {
    let dir = temp_dir("plots", "slab-svg");
    let out = slab_plot(&dir, "fig.svg");
    assert_success(&out);
    let svg = std::fs::read_to_string(dir.join("fig.svg")).expect("svg");
    for text in [
        "H = 100 m, sun zenith angle 70°, λ = 550 nm, τ = ",
        "reflected radiance per unit incident flux (sr⁻¹)",
        "A glory",
        "B fogbow (",
        "Monte-Carlo, modified Mie: orders 1–2",
        "−90",
    ] {
        assert!(svg.contains(text), "the SVG lacks `{text}`");
    }
    // Filled areas for the analytic orders 1, 2 and 3+.
    assert_eq!(svg.matches("<polygon").count(), 3);
}

#[test]
fn figures_refuse_other_extensions_in_one_line_and_write_nothing() {
    let dir = temp_dir("plots", "extensions");
    assert_fails_with(
        &phase_plot(&dir, "phase.pdf"),
        &["--plot phase.pdf", ".pdf", ".png or .svg"],
    );
    assert_fails_with(
        &slab_plot(&dir, "fig.jpg"),
        &["--out fig.jpg", ".jpg", ".png or .svg"],
    );
    assert_fails_with(&slab_plot(&dir, "fig"), &["--out fig", "(none)"]);
    let left: Vec<_> = std::fs::read_dir(&dir).expect("dir").collect();
    assert!(left.is_empty(), "{left:?}");
}
