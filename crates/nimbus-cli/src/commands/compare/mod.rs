//! `nimbus compare`: how far a real-time image is from a path-traced
//! reference of the same scene (see `docs/REALISM.md`). With the reference
//! given as two independent halves (`--halves A.exr B.exr`), also the error
//! that the reference's noise does not inflate and the standard errors of
//! the means ([`halves`]).

pub mod halves;
pub mod metrics;

use anyhow::Context;
use clap::{Args, ValueEnum};
use metrics::{Metrics, PIXELS_PER_DEGREE, RgbImage};
use std::path::{Path, PathBuf};

/// Opacity above which a pixel counts as cloud for `--mask cloud`.
pub const CLOUD_MASK_THRESHOLD: f32 = 0.05;

/// Which pixels the metrics cover.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Mask {
    /// Pixels whose clouds' opacity (the real-time image's `cloud.A` layer)
    /// is at least 0.05.
    Cloud,
    /// Every pixel.
    All,
}

/// Arguments of `nimbus compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The real-time image: an EXR written by `nimbus render -o x.exr` (its
    /// `cloud.A` layer gives the cloud mask).
    realtime: PathBuf,
    /// The reference: an EXR of linear radiance of the same size (e.g.
    /// path-traced by tools/reference/render.py). Leave it out with --halves.
    #[arg(required_unless_present = "halves", conflicts_with = "halves")]
    reference: Option<PathBuf>,
    /// The reference as two independent halves of its samples (written by
    /// tools/reference/render.py --halves): the reference is their mean, and
    /// the report adds the unbiased error, the reference's noise and the
    /// standard errors of the means.
    #[arg(long, num_args = 2, value_names = ["A.exr", "B.exr"])]
    halves: Option<Vec<PathBuf>>,
    /// Side of the blocks for the block metrics of --halves, pixels (1 to 256).
    #[arg(long, default_value_t = halves::DEFAULT_BLOCK_PX, value_name = "K")]
    block: u32,
    /// Pixels compared.
    #[arg(long, value_enum, default_value_t = Mask::Cloud)]
    mask: Mask,
    /// Take the cloud mask (`cloud.A`) from this EXR instead of REALTIME
    /// (e.g. to compare two halves of a reference over the real-time mask).
    #[arg(long, value_name = "FILE.exr")]
    mask_from: Option<PathBuf>,
    /// Print one JSON document on standard output.
    #[arg(long)]
    json: bool,
    /// Write real-time | reference | HDR-FLIP error map side by side (PNG).
    #[arg(long, value_name = "FILE.png")]
    out: Option<PathBuf>,
}

/// Runs the subcommand.
pub fn run(args: &CompareArgs) -> anyhow::Result<()> {
    let mut realtime = read_exr(&args.realtime)?;
    if let Some(path) = &args.mask_from {
        let source = read_exr(path)?;
        ensure_same_size(
            &source.image,
            path,
            &realtime.image,
            &args.realtime,
            "--mask-from ",
        )?;
        realtime.cloud_opacity = Some(source.cloud_opacity.with_context(|| {
            format!(
                "--mask-from {}: the EXR has no cloud.A layer",
                path.display()
            )
        })?);
    }
    anyhow::ensure!(
        (1..=halves::MAX_BLOCK_PX).contains(&args.block),
        "--block {}: must be a whole number of pixels in [1, {}]",
        args.block,
        halves::MAX_BLOCK_PX
    );
    // The reference, or its two halves and their mean.
    let (reference, halves_images, reference_name) = match (&args.reference, &args.halves) {
        (Some(path), _) => {
            let image = read_exr(path)?.image;
            ensure_same_size(&image, path, &realtime.image, &args.realtime, "")?;
            (image, None, path.display().to_string())
        }
        (None, Some(paths)) if paths.len() == 2 => {
            let mut images = Vec::new();
            for path in paths {
                let image = read_exr(path)?.image;
                ensure_same_size(&image, path, &realtime.image, &args.realtime, "--halves ")?;
                images.push(image);
            }
            let (a, b) = (images.remove(0), images.remove(0));
            let name = format!("{} + {}", paths[0].display(), paths[1].display());
            (halves::mean_of_halves(&a, &b), Some((a, b)), name)
        }
        _ => anyhow::bail!("give the reference as REFERENCE or as --halves A.exr B.exr"),
    };
    if let Some(out) = &args.out {
        super::check_output_dir(out)?;
    }
    let report = compare(&realtime, &reference, args.mask)
        .with_context(|| format!("{} vs {reference_name}", args.realtime.display()))?;
    let unbiased = halves_images
        .as_ref()
        .and_then(|(a, b)| halves::halves_metrics(&realtime.image, a, b, &report.mask, args.block));
    if let Some(out) = &args.out {
        write_report(out, &realtime.image, &reference, &report.flip)?;
    }
    if args.json {
        let document = Document {
            metrics: &report.metrics,
            halves: unbiased.as_ref(),
        };
        outln!("{}", serde_json::to_string_pretty(&document)?);
    } else {
        let m = &report.metrics;
        outln!("pixels compared          {}", m.pixels);
        outln!("HDR-FLIP (mean)          {:.4}", m.hdr_flip_mean);
        outln!("luminance RMSE / mean    {:.4}", m.luminance_relative_rmse);
        outln!("luminance PSNR           {:.2} dB", m.luminance_psnr_db);
        outln!("mean luminance ratio     {:.4}", m.mean_luminance_ratio);
        outln!(
            "red/blue of the means    {:.4} (reference {:.4})",
            m.red_over_blue_test,
            m.red_over_blue_reference
        );
        outln!(
            "chromaticity Δxy         {:.4}",
            m.mean_chromaticity_difference_xy
        );
        if let Some(h) = &unbiased {
            for (scale, s) in [
                ("per pixel".to_string(), &h.pixels),
                (format!("{0}×{0} blocks", h.block_px), &h.blocks),
            ] {
                outln!(
                    "{scale} ({}): unbiased luminance RMSE / mean {:.4} ± {:.4} (raw MSE {:.4} ± {:.4}), naive {:.4}, reference noise {:.4}",
                    s.count,
                    s.luminance_relative_rmse_unbiased,
                    s.luminance_relative_rmse_unbiased_se,
                    s.luminance_relative_mse_unbiased_raw,
                    s.luminance_relative_mse_unbiased_se,
                    s.luminance_relative_rmse_naive,
                    s.reference_noise_relative_rmse
                );
            }
            outln!(
                "mean luminance ratio     {:.4} ± {:.4}",
                h.mean_luminance_ratio,
                h.mean_luminance_ratio_se
            );
            outln!(
                "red/blue ratio           {:.4} ± {:.4} (reference {:.4} ± {:.4})",
                h.red_over_blue_ratio,
                h.red_over_blue_ratio_se,
                h.red_over_blue_reference,
                h.red_over_blue_reference_se
            );
        }
    }
    if let Some(out) = &args.out {
        eprintln!("nimbus: wrote {}", out.display());
    }
    Ok(())
}

/// Fails, naming both files, unless `image` (from `path`, named after
/// `flag`) has the size of `other` (from `other_path`).
fn ensure_same_size(
    image: &RgbImage,
    path: &Path,
    other: &RgbImage,
    other_path: &Path,
    flag: &str,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        (image.width, image.height) == (other.width, other.height),
        "{flag}{}: {}×{} pixels, but {} is {}×{}",
        path.display(),
        image.width,
        image.height,
        other_path.display(),
        other.width,
        other.height
    );
    Ok(())
}

/// An EXR read for comparison: its radiance and, when present, its clouds' opacity.
pub struct ExrImage {
    /// Linear RGB.
    pub image: RgbImage,
    /// The `cloud.A` layer, if the file has one.
    pub cloud_opacity: Option<Vec<f32>>,
}

/// The metrics and the HDR-FLIP map of a comparison.
pub struct Report {
    /// Metrics over the mask.
    pub metrics: Metrics,
    /// HDR-FLIP error per pixel.
    pub flip: Vec<f32>,
    /// The pixels compared.
    pub mask: Vec<bool>,
}

/// The JSON document: the metrics against the reference and, with
/// `--halves`, the unbiased ones under `halves`.
#[derive(serde::Serialize)]
struct Document<'a> {
    #[serde(flatten)]
    metrics: &'a Metrics,
    #[serde(skip_serializing_if = "Option::is_none")]
    halves: Option<&'a halves::HalvesMetrics>,
}

/// Compares a real-time image with a reference over a mask.
pub fn compare(realtime: &ExrImage, reference: &RgbImage, mask: Mask) -> anyhow::Result<Report> {
    let mask: Vec<bool> = match mask {
        Mask::All => vec![true; reference.pixels.len()],
        Mask::Cloud => {
            let opacity = realtime.cloud_opacity.as_ref().context(
                "--mask cloud needs the real-time EXR's cloud.A layer (written by `nimbus render -o x.exr`); use --mask all",
            )?;
            opacity.iter().map(|a| *a >= CLOUD_MASK_THRESHOLD).collect()
        }
    };
    anyhow::ensure!(
        mask.iter().any(|m| *m),
        "no pixel is cloud (cloud.A ≥ {CLOUD_MASK_THRESHOLD}); use --mask all"
    );
    let flip = metrics::hdr_flip(reference, &realtime.image, PIXELS_PER_DEGREE);
    Ok(Report {
        metrics: metrics::metrics(&realtime.image, reference, &flip, &mask),
        flip,
        mask,
    })
}

/// Largest EXR read by `compare`, bytes.
const MAX_EXR_BYTES: u64 = 1 << 30;

/// Most pixels of a layer of an EXR read by `compare` (a 8192 × 8192 image).
const MAX_EXR_PIXELS: u64 = 1 << 26;

/// Reads the RGB channels (and `cloud.A`) of an EXR's first layer; rejects
/// non-finite or negative radiance.
pub fn read_exr(path: &Path) -> anyhow::Result<ExrImage> {
    use exr::prelude::*;
    let bytes = nimbus_physics::io::read_bounded(path, MAX_EXR_BYTES)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let not_exr = |e: exr::error::Error| {
        anyhow::anyhow!("{}: not a readable OpenEXR file: {e}", path.display())
    };
    // The headers first: a file of a few bytes may declare a vast image.
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(&bytes), false)
        .map_err(not_exr)?;
    for header in &meta.headers {
        let (w, h) = (header.layer_size.width(), header.layer_size.height());
        anyhow::ensure!(
            (w as u64) * (h as u64) <= MAX_EXR_PIXELS,
            "{}: a layer of {w}×{h} pixels; at most {MAX_EXR_PIXELS} pixels are read",
            path.display()
        );
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(not_exr)?;
    let layer = image
        .layer_data
        .first()
        .with_context(|| format!("{}: the EXR has no layer", path.display()))?;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channel = |name: &str| -> Option<Vec<f32>> {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .map(|c| c.sample_data.values_as_f32().collect())
    };
    let rgb: Vec<Vec<f32>> = ["R", "G", "B"]
        .iter()
        .map(|name| {
            channel(name).with_context(|| {
                format!(
                    "{}: the EXR has no channel {name} (R, G, B needed)",
                    path.display()
                )
            })
        })
        .collect::<anyhow::Result<_>>()?;
    let pixels: Vec<[f32; 3]> = (0..width * height)
        .map(|i| [rgb[0][i], rgb[1][i], rgb[2][i]])
        .collect();
    if let Some(i) = pixels
        .iter()
        .position(|p| p.iter().any(|c| !c.is_finite() || *c < 0.0))
    {
        anyhow::bail!(
            "{}: pixel ({}, {}) = {:?}: radiance must be finite and non-negative",
            path.display(),
            i % width,
            i / width,
            pixels[i]
        );
    }
    Ok(ExrImage {
        image: RgbImage {
            width: width as u32,
            height: height as u32,
            pixels,
        },
        cloud_opacity: channel("cloud.A"),
    })
}

/// Writes real-time | reference | error map (magma) side by side.
fn write_report(
    path: &Path,
    test: &RgbImage,
    reference: &RgbImage,
    flip: &[f32],
) -> anyhow::Result<()> {
    let (w, h) = (test.width as usize, test.height as usize);
    let stops = metrics::key_exposure(reference);
    let left = metrics::display_rgb8(test, stops);
    let middle = metrics::display_rgb8(reference, stops);
    let error = nv_flip::FlipImageFloat::with_data(test.width, test.height, flip)
        .apply_color_lut(&nv_flip::magma_lut())
        .to_vec();
    let gap = 4;
    let width = 3 * w + 2 * gap;
    let mut pixels = vec![255u8; width * h * 4];
    for (panel, source) in [&left, &middle, &error].into_iter().enumerate() {
        for y in 0..h {
            for x in 0..w {
                let s = (y * w + x) * 3;
                let d = (y * width + panel * (w + gap) + x) * 4;
                pixels[d..d + 3].copy_from_slice(&source[s..s + 3]);
                pixels[d + 3] = 255;
            }
        }
    }
    crate::output::write_png(
        path,
        &nimbus_render::headless::Rgba8Image {
            width: width as u32,
            height: h as u32,
            pixels,
        },
    )
}
