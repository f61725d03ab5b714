//! Output files, written atomically: each is written under a temporary
//! name in the same directory and renamed into place, so a failed run never
//! leaves a partial file; files that belong together (a mesh and its
//! hierarchy, a Mitsuba scene and its volumes) are renamed only once all of
//! them are written ([`FileSet`]).

use anyhow::Context;
use nimbus_render::headless::{ImageLayers, Rgba8Image};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Image file formats nimbus writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit sRGB PNG, tone-mapped.
    Png,
    /// OpenEXR, 32-bit float linear radiance (W·sr⁻¹·m⁻² per channel).
    Exr,
}

/// A path's extension, lower-cased (`None` without one, or when it is not
/// UTF-8): what chooses an output's format.
pub fn lowercase_extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

impl ImageFormat {
    /// The format of an output path, from its extension.
    pub fn from_path(path: &Path) -> anyhow::Result<Self> {
        match lowercase_extension(path).as_deref() {
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

/// Stale temporaries found so far, by directory then by the final file name
/// they were written for; each directory is read once per process, so that
/// `animate` writing thousands of frames into one folder does not read it
/// once per frame.
type StaleTemporaries = std::sync::Mutex<HashMap<PathBuf, HashMap<String, Vec<PathBuf>>>>;

/// Removes `.NAME.PID.tmp` files beside `path` whose process no longer
/// runs (or, where that cannot be told, that are more than a day old):
/// what a killed run left. Only NAME's are removed (another program's run
/// may be writing other names); the directory is read at the first call
/// for it. Errors are ignored: this is housekeeping.
pub fn remove_stale_temporaries(path: &Path) {
    static STALE: OnceLock<StaleTemporaries> = OnceLock::new();
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let Ok(mut stale) = STALE.get_or_init(Default::default).lock() else {
        return;
    };
    let by_name = stale
        .entry(dir.to_path_buf())
        .or_insert_with(|| stale_temporaries_in(dir));
    for temporary in by_name.remove(&file_name(path)).unwrap_or_default() {
        let _ = std::fs::remove_file(temporary);
    }
}

/// The stale `.NAME.PID.tmp` files of `dir`, by NAME.
fn stale_temporaries_in(dir: &Path) -> HashMap<String, Vec<PathBuf>> {
    let mut stale: HashMap<String, Vec<PathBuf>> = HashMap::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return stale;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some((name, pid)) = file
            .to_str()
            .and_then(|f| f.strip_prefix('.'))
            .and_then(|f| f.strip_suffix(".tmp"))
            .and_then(|f| f.rsplit_once('.'))
            .and_then(|(name, pid)| Some((name, pid.parse::<u32>().ok()?)))
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
            stale.entry(name.to_owned()).or_default().push(entry.path());
        }
    }
    stale
}

/// Files replaced as a set: each is written under its temporary name, and
/// none is moved into place until [`Self::commit`], after every one has
/// been written. A failure (or a drop without commit) removes the
/// temporaries and leaves every earlier file as it was. The renames
/// themselves follow one another (microseconds): a `kill -9` between two of
/// them leaves some files new and some old, each whole.
#[derive(Debug, Default)]
pub struct FileSet {
    /// (temporary, final) names of the files written so far.
    staged: Vec<(PathBuf, PathBuf)>,
}

impl FileSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes `path`'s content under its temporary name with `write`.
    pub fn write_with(
        &mut self,
        path: &Path,
        write: impl FnOnce(&Path) -> anyhow::Result<()>,
    ) -> anyhow::Result<()> {
        let temporary = temporary_path(path);
        if let Err(error) = write(&temporary) {
            let _ = std::fs::remove_file(&temporary);
            return Err(error);
        }
        self.staged.push((temporary, path.to_path_buf()));
        Ok(())
    }

    /// Writes `bytes` as `path`'s content; `flag` names the option that
    /// gave the path, for the error message.
    pub fn write_bytes(&mut self, path: &Path, flag: &str, bytes: &[u8]) -> anyhow::Result<()> {
        self.write_with(path, |temporary| write_synced(temporary, bytes, flag, path))
    }

    /// Moves every file into place, in the order written. A final name
    /// that a rename cannot replace (a directory) is found before any file
    /// moves.
    pub fn commit(mut self) -> anyhow::Result<()> {
        if let Some((_, path)) = self.staged.iter().find(|(_, path)| path.is_dir()) {
            anyhow::bail!(
                "output {}: is a directory; nothing was replaced",
                path.display()
            );
        }
        let staged = std::mem::take(&mut self.staged);
        let mut files = staged.iter();
        for (temporary, path) in files.by_ref() {
            if let Err(error) = std::fs::rename(temporary, path) {
                for (temporary, _) in files {
                    let _ = std::fs::remove_file(temporary);
                }
                let _ = std::fs::remove_file(temporary);
                return Err(anyhow::anyhow!(
                    "output {}: cannot move the file into place: {error}",
                    path.display()
                ));
            }
        }
        Ok(())
    }
}

impl Drop for FileSet {
    fn drop(&mut self) {
        for (temporary, _) in &self.staged {
            let _ = std::fs::remove_file(temporary);
        }
    }
}

/// Creates `temporary`, writes `bytes` and syncs them to disk (a rename of
/// an unsynced file can leave an empty file after a power loss).
fn write_synced(temporary: &Path, bytes: &[u8], flag: &str, path: &Path) -> anyhow::Result<()> {
    let mut file = std::fs::File::create(temporary)
        .with_context(|| format!("{flag} {}: cannot create file", path.display()))?;
    file.write_all(bytes)
        .and_then(|()| file.sync_all())
        .with_context(|| format!("{flag} {}: write failed", path.display()))
}

/// The PNG bytes of a tone-mapped image.
pub fn encode_png(path: &Path, image: &Rgba8Image) -> anyhow::Result<Vec<u8>> {
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
    Ok(encoded)
}

/// Writes `path` through a temporary file and a rename; removes the
/// temporary file if anything fails.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    // A set of one file: the same temporary, clean-up and rename.
    let mut files = FileSet::new();
    files.write_with(path, write)?;
    files.commit()
}

/// Writes `bytes` to `path` atomically; `flag` names the option that gave
/// the path, for the error message.
pub fn write_bytes_atomically(path: &Path, flag: &str, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomically(path, |temporary| write_synced(temporary, bytes, flag, path))
}

/// Writes a tone-mapped image as PNG.
pub fn write_png(path: &Path, image: &Rgba8Image) -> anyhow::Result<()> {
    write_bytes_atomically(path, "output", &encode_png(path, image)?)
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
