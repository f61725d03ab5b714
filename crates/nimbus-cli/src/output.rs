//! Image output, written atomically: the file is written under a temporary
//! name in the same directory and renamed into place, so a failed run never
//! leaves a partial image.

use anyhow::Context;
use nimbus_render::headless::{ImageLayers, Rgba8Image};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Image file formats nimbus writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit sRGB PNG, tone-mapped.
    Png,
    /// OpenEXR, 32-bit float linear radiance (W·sr⁻¹·m⁻² per channel).
    Exr,
}

impl ImageFormat {
    /// The format of an output path, from its extension.
    pub fn from_path(path: &Path) -> anyhow::Result<Self> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => Ok(Self::Png),
            Some("exr") => Ok(Self::Exr),
            other => anyhow::bail!(
                "output {}: extension {} is not supported; use .png or .exr",
                path.display(),
                other.map_or("(none)".to_owned(), |e| format!(".{e}"))
            ),
        }
    }
}

/// The temporary name `path` is written under: `.NAME.PID.tmp` beside it.
/// Stale ones, left by a run that was killed (`kill -9`, power loss), are
/// removed first (see [`remove_stale_temporaries`]).
pub fn temporary_path(path: &Path) -> PathBuf {
    remove_stale_temporaries(path);
    path.with_file_name(format!(".{}.{}.tmp", file_name(path), std::process::id()))
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Whether the process `pid` still runs. Linux answers through /proc;
/// elsewhere every other process is taken as running, and only files a
/// day old count as stale.
fn process_runs(pid: u32) -> bool {
    let proc = Path::new("/proc");
    if proc.join("self").exists() {
        proc.join(pid.to_string()).exists()
    } else {
        true
    }
}

/// Removes `.NAME.PID.tmp` files beside `path` whose process no longer
/// runs (or, where that cannot be told, that are more than a day old):
/// what a killed run left. Errors are ignored: this is housekeeping.
pub fn remove_stale_temporaries(path: &Path) {
    let name = file_name(path);
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(pid) = file
            .to_str()
            .and_then(|f| f.strip_prefix(&prefix))
            .and_then(|f| f.strip_suffix(".tmp"))
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        let day_old = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age.as_secs() > 86_400);
        if pid != std::process::id() && (!process_runs(pid) || day_old) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Writes `path` through a temporary file and a rename; removes the
/// temporary file if anything fails.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let temporary = temporary_path(path);
    let result = write(&temporary).and_then(|()| {
        std::fs::rename(&temporary, path).with_context(|| {
            format!(
                "output {}: cannot move the image into place",
                path.display()
            )
        })
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    result
}

/// Writes `bytes` to `path` atomically; `flag` names the option that gave
/// the path, for the error message.
pub fn write_bytes_atomically(path: &Path, flag: &str, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomically(path, |temporary| {
        std::fs::write(temporary, bytes)
            .with_context(|| format!("{flag} {}: write failed", path.display()))
    })
}

/// Writes a tone-mapped image as PNG.
pub fn write_png(path: &Path, image: &Rgba8Image) -> anyhow::Result<()> {
    use image::ImageEncoder;
    let mut encoded = Vec::new();
    image::codecs::png::PngEncoder::new(&mut encoded)
        .write_image(
            &image.pixels,
            image.width,
            image.height,
            image::ExtendedColorType::Rgba8,
        )
        .with_context(|| format!("output {}: PNG encoding failed", path.display()))?;
    write_atomically(path, |temporary| {
        let mut file = std::fs::File::create(temporary)
            .with_context(|| format!("output {}: cannot create file", path.display()))?;
        file.write_all(&encoded)
            .with_context(|| format!("output {}: write failed", path.display()))?;
        file.sync_all()
            .with_context(|| format!("output {}: write failed", path.display()))?;
        Ok(())
    })
}

/// Writes an image and its layers as one OpenEXR file (ZIP-compressed,
/// 32-bit float): channels `R`, `G`, `B` (linear radiance), `Z` (distance
/// along the view ray, m), `cloud.A` (the clouds' opacity) and `sky.R`,
/// `sky.G`, `sky.B` (radiance without clouds and rain) — the layer.channel
/// names that Blender, Nuke and OpenEXR's tools read as layers.
pub fn write_exr_layers(path: &Path, image: &ImageLayers) -> anyhow::Result<()> {
    use exr::prelude::*;
    let plane = |values: Vec<f32>| FlatSamples::F32(values);
    let channel = |pixels: &[[f32; 3]], k: usize| plane(pixels.iter().map(|p| p[k]).collect());
    let mut channels = vec![
        AnyChannel::new("R", channel(&image.radiance, 0)),
        AnyChannel::new("G", channel(&image.radiance, 1)),
        AnyChannel::new("B", channel(&image.radiance, 2)),
    ];
    let pixels = image.width as usize * image.height as usize;
    if image.distance_m.len() == pixels {
        channels.push(AnyChannel::new("Z", plane(image.distance_m.clone())));
    }
    if image.cloud_opacity.len() == pixels {
        channels.push(AnyChannel::new(
            "cloud.A",
            plane(image.cloud_opacity.clone()),
        ));
    }
    if image.sky_radiance.len() == pixels {
        for (k, name) in ["sky.R", "sky.G", "sky.B"].into_iter().enumerate() {
            channels.push(AnyChannel::new(name, channel(&image.sky_radiance, k)));
        }
    }
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    write_atomically(path, |temporary| {
        Image::from_layer(layer)
            .write()
            .to_file(temporary)
            .with_context(|| format!("output {}: EXR write failed", path.display()))
    })
}
