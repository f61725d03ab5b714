//! Composition of WGSL sources: each pass's shader is its own file preceded
//! by the shared libraries it needs. The layer is deliberately thin: plain
//! concatenation in a fixed order, so that naga's error positions map back to
//! files through the `// ---- file:` markers.
//!
//! The sources are embedded in the library. For shader development (the
//! viewer's hot reload) [`set_source_dir`] makes [`compose`] read them from a
//! directory instead, the crate's `src/` in a checkout
//! ([`CHECKOUT_SOURCE_DIR`]); renderers created afterwards use the files on disk.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::RwLock;

/// A named WGSL source file.
#[derive(Clone, Copy, Debug)]
pub struct WgslFile {
    /// File name, for diagnostics.
    pub name: &'static str,
    /// Its text.
    pub source: &'static str,
}

/// The directory the WGSL files are named relative to in this crate's
/// checkout (its `src/`), fixed at build time; it may not exist where the
/// program runs.
pub const CHECKOUT_SOURCE_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/src");

/// Where [`compose`] reads the WGSL files from; `None`: the embedded text.
/// Process-wide, because every pass composes its shaders when it is created.
static SOURCE_DIR: RwLock<Option<PathBuf>> = RwLock::new(None);

/// Makes [`compose`] read each file from `dir` joined with its name (for
/// shader development); `None` restores the embedded sources.
pub fn set_source_dir(dir: Option<PathBuf>) {
    // A poisoned lock still holds a valid `Option<PathBuf>`.
    let mut guard = SOURCE_DIR.write().unwrap_or_else(|e| e.into_inner());
    *guard = dir;
}

/// The directory set by [`set_source_dir`].
pub fn source_dir() -> Option<PathBuf> {
    SOURCE_DIR.read().unwrap_or_else(|e| e.into_inner()).clone()
}

/// The text of `file`, from `dir` when given and readable, else embedded.
/// An unreadable file (being saved, deleted) falls back to the embedded
/// text rather than failing: the compiler reports real mistakes.
fn file_text(file: &WgslFile, dir: Option<&Path>) -> Cow<'static, str> {
    dir.and_then(|dir| std::fs::read_to_string(dir.join(file.name)).ok())
        .map_or(Cow::Borrowed(file.source), Cow::Owned)
}

/// Concatenates the given files into one shader module source.
pub fn compose(files: &[WgslFile]) -> String {
    compose_from(files, source_dir().as_deref())
}

/// [`compose`] with the files read from `dir` (`None`: embedded).
pub fn compose_from(files: &[WgslFile], dir: Option<&Path>) -> String {
    let mut out = String::new();
    for file in files {
        out.push_str(FILE_MARKER);
        out.push_str(file.name);
        out.push('\n');
        out.push_str(&file_text(file, dir));
        out.push('\n');
    }
    out
}

/// Starts each file in a composed source, followed by its name.
pub const FILE_MARKER: &str = "// ---- file: ";

/// The file and the line in it (both counted from 1) of line `line` of a
/// composed source; `None` for a marker line or a line past the end.
pub fn locate(composed: &str, line: usize) -> Option<(&str, usize)> {
    let mut file = None;
    for (index, text) in composed.lines().enumerate().take(line) {
        if let Some(name) = text.strip_prefix(FILE_MARKER) {
            file = Some((name, index + 1));
        }
    }
    let (name, marker_line) = file?;
    (line > marker_line && line <= composed.lines().count()).then(|| (name, line - marker_line))
}

/// Rewrites the `wgsl:LINE:COLUMN` positions of a compiler message about
/// the composed `source` as `FILE:LINE:COLUMN` of the file they fall in.
pub fn map_positions(message: &str, composed: &str) -> String {
    const TAG: &str = "wgsl:";
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(at) = rest.find(TAG) {
        out.push_str(&rest[..at]);
        let after = &rest[at + TAG.len()..];
        let digits = after
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(after.len());
        match after[..digits]
            .parse()
            .ok()
            .and_then(|line| locate(composed, line))
        {
            Some((file, line)) => {
                out.push_str(&format!("{file}:{line}"));
                rest = &after[digits..];
            }
            None => {
                out.push_str(TAG);
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// [`map_positions`] for a message naming one of [`all_modules`] by its
/// label (`label = 'sky'`, as wgpu's validation errors do).
pub fn map_error_positions(message: &str) -> String {
    all_modules()
        .into_iter()
        .find(|(name, _)| message.contains(&format!("label = '{name}'")))
        .map_or_else(
            || message.to_owned(),
            |(_, source)| map_positions(message, &source),
        )
}

/// Shared declarations: constants, the frame uniform and its binding.
pub const COMMON: WgslFile = WgslFile {
    name: "shaders/common.wgsl",
    source: include_str!("shaders/common.wgsl"),
};
/// A full-screen triangle vertex shader.
pub const FULLSCREEN: WgslFile = WgslFile {
    name: "shaders/fullscreen.wgsl",
    source: include_str!("shaders/fullscreen.wgsl"),
};
/// Lambertian surfaces lit by the sun and the environment, `lambert_radiance`
/// (needs `COMMON`, the atmosphere lookups and the stratus lookup); shared by
/// the terrain and the static objects.
pub const LAMBERT: WgslFile = WgslFile {
    name: "shaders/lambert.wgsl",
    source: include_str!("shaders/lambert.wgsl"),
};
/// Shading of open water (needs `COMMON` and the atmosphere lookups).
pub const WATER: WgslFile = WgslFile {
    name: "shaders/water.wgsl",
    source: include_str!("shaders/water.wgsl"),
};

/// Every composed shader module of the renderer, by name: what the naga
/// validation test checks.
pub fn all_modules() -> Vec<(&'static str, String)> {
    let mut modules = crate::atmosphere::shader_sources();
    modules.extend([
        ("sky", crate::sky::shader_source()),
        ("terrain", crate::terrain::shader_source()),
        ("objects", crate::objects::shader_source()),
        ("rain simulation", crate::rain::simulation_shader_source()),
        ("rain visibility", crate::rain::visibility_shader_source()),
        ("rain streaks", crate::rain::streaks_shader_source()),
        ("rain mist", crate::rain::mist_shader_source()),
        ("rain shadow map", crate::rain::occluders_shader_source()),
        ("exposure", crate::exposure::shader_source()),
        ("tonemap", crate::tonemap::shader_source()),
        ("radiosity", crate::radiosity::shader_source()),
        ("stratus layer", crate::stratus::layer_shader_source()),
        ("stratus compute", crate::stratus::compute_shader_source()),
        ("cumulus", crate::cumulus::draw_shader_source()),
        ("cumulus shadow", crate::cumulus::shadow_shader_source()),
        (
            "cumulus composite",
            crate::cumulus::composite_shader_source(),
        ),
    ]);
    modules
}

/// The shared files every drawing pass that reads the atmosphere needs, in order.
pub const DRAWING_LIBRARIES: [WgslFile; 4] = [
    COMMON,
    crate::atmosphere::ATMOSPHERE,
    crate::atmosphere::LIGHTING_TYPES,
    crate::atmosphere::LOOKUP,
];

/// Creates a shader module from composed source.
pub fn create_module(device: &wgpu::Device, label: &str, source: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every file of every module is found under its name in the checkout
    /// with the embedded text, so that hot reload edits what is rendered.
    #[test]
    fn file_names_resolve_to_the_embedded_files_in_the_checkout() {
        let dir = Path::new(CHECKOUT_SOURCE_DIR);
        let mut checked = 0;
        for (module, source) in all_modules() {
            for (index, part) in source.split(FILE_MARKER).enumerate().skip(1) {
                let (name, embedded) = part.split_once('\n').expect("marker line");
                let on_disk = std::fs::read_to_string(dir.join(name))
                    .unwrap_or_else(|e| panic!("module {module}, file #{index} {name}: {e}"));
                assert_eq!(
                    embedded.strip_suffix('\n'),
                    Some(on_disk.as_str()),
                    "module {module}: {name}"
                );
                checked += 1;
            }
        }
        assert!(checked > 40, "only {checked} files checked");
    }

    #[test]
    fn compiler_positions_map_to_files_and_their_lines() {
        let composed = compose_from(&[COMMON, FULLSCREEN], None);
        assert_eq!(locate(&composed, 1), None);
        assert_eq!(locate(&composed, 2), Some((COMMON.name, 1)));
        let marker = format!("{FILE_MARKER}{}", FULLSCREEN.name);
        let fullscreen_first = composed.lines().position(|l| l == marker).expect("marker") + 2;
        assert_eq!(
            locate(&composed, fullscreen_first),
            Some((FULLSCREEN.name, 1))
        );
        let message = format!("error\n  ┌─ wgsl:{}:7\n", fullscreen_first + 1);
        assert_eq!(
            map_positions(&message, &composed),
            format!("error\n  ┌─ {}:2:7\n", FULLSCREEN.name)
        );
        assert_eq!(map_positions("wgsl:x wgsl:", &composed), "wgsl:x wgsl:");
    }

    /// Reading from a directory replaces the text of the files found there
    /// and keeps the embedded text of the others.
    #[test]
    fn compose_from_a_directory_reads_its_files() {
        let dir = std::env::temp_dir().join(format!("nimbus-shader-dir-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("shaders")).expect("temp dir");
        std::fs::write(dir.join(COMMON.name), "// edited\n").expect("write");
        let composed = compose_from(&[COMMON, FULLSCREEN], Some(&dir));
        assert!(composed.contains("// edited\n"));
        assert!(composed.contains(FULLSCREEN.source));
        assert!(!composed.contains(COMMON.source));
        assert_eq!(
            compose_from(&[COMMON], None),
            format!("{FILE_MARKER}{}\n{}\n", COMMON.name, COMMON.source)
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
