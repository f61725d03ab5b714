//! Composition of WGSL sources. A WGSL file names the files it needs in
//! header lines `// import shader/common.wgsl` (paths relative to the
//! crate's `src/`); [`compose`] resolves them depth-first, each file once,
//! dependencies before the files that need them, and concatenates the
//! result. Imports resolve against the shared [`LIBRARY`] (the WGSL used by
//! more than one pass, in this directory) and the files a pass hands in.
//! Plain concatenation keeps naga's error positions mappable to files
//! through the `// ---- file:` markers.
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
    // Bounded like every file nimbus reads: a shader is tens of kilobytes.
    dir.and_then(|dir| nimbus_physics::io::read_text_bounded(&dir.join(file.name), 4 << 20).ok())
        .map_or(Cow::Borrowed(file.source), Cow::Owned)
}

/// Composes `files` (a pass's own WGSL, in order) with everything they
/// import, into one shader module source.
pub fn compose(files: &[WgslFile]) -> String {
    compose_from(files, source_dir().as_deref())
}

/// Starts a line naming a file the file it is in needs.
pub const IMPORT_PREFIX: &str = "// import ";

/// The files a file's text imports, in the order it names them.
pub fn imports(text: &str) -> impl Iterator<Item = &str> {
    text.lines()
        .filter_map(|line| line.strip_prefix(IMPORT_PREFIX))
        .map(str::trim)
}

/// [`compose`] with the files read from `dir` (`None`: embedded).
pub fn compose_from(files: &[WgslFile], dir: Option<&Path>) -> String {
    compose_resolving(files, &[], dir)
}

/// [`compose`] where imports also resolve against `library`: a pass's own
/// files that several of its shaders share. Only the files `files` import
/// (directly or not) are included.
pub fn compose_with_library(files: &[WgslFile], library: &[WgslFile]) -> String {
    compose_resolving(files, library, source_dir().as_deref())
}

fn compose_resolving(files: &[WgslFile], library: &[WgslFile], dir: Option<&Path>) -> String {
    let known: Vec<WgslFile> = LIBRARY
        .iter()
        .chain(library)
        .chain(files)
        .copied()
        .collect();
    let mut done: Vec<&'static str> = Vec::new();
    let mut out = String::new();
    for file in files {
        visit(file, &known, dir, &mut done, &mut out);
    }
    out
}

/// Appends `file` to `out` after its imports (depth first), unless done.
fn visit(
    file: &WgslFile,
    known: &[WgslFile],
    dir: Option<&Path>,
    done: &mut Vec<&'static str>,
    out: &mut String,
) {
    if done.contains(&file.name) {
        return;
    }
    // Marked before its imports are visited, so that a cycle ends.
    done.push(file.name);
    let text = file_text(file, dir);
    for name in imports(&text) {
        match known.iter().find(|k| k.name == name) {
            Some(import) => visit(import, known, dir, done, out),
            // Left to the compiler, which names the missing declarations;
            // the embedded files' imports are checked by a test.
            None => {
                out.push_str(&format!("// ---- unresolved import: {name}\n"));
            }
        }
    }
    out.push_str(FILE_MARKER);
    out.push_str(file.name);
    out.push('\n');
    out.push_str(&text);
    out.push('\n');
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

/// Shared declarations: constants, the frame uniform and its binding.
pub const COMMON: WgslFile = WgslFile {
    name: "shader/common.wgsl",
    source: include_str!("common.wgsl"),
};
/// A full-screen triangle vertex shader.
pub const FULLSCREEN: WgslFile = WgslFile {
    name: "shader/fullscreen.wgsl",
    source: include_str!("fullscreen.wgsl"),
};
/// Lambertian surfaces lit by the sun and the environment, `lambert_radiance`;
/// shared by the terrain and the static objects.
pub const LIT_SURFACE: WgslFile = WgslFile {
    name: "shader/lit_surface.wgsl",
    source: include_str!("lit_surface.wgsl"),
};
/// GGX roughness α of the sun's glint on open water (`WATER_GGX_ALPHA` in
/// water.wgsl; exporters give the sea the same lobe).
pub const WATER_GGX_ALPHA: f64 = 0.06;

/// Shading of open water.
pub const WATER: WgslFile = WgslFile {
    name: "shader/water.wgsl",
    source: include_str!("water.wgsl"),
};

/// Open water under the clouds: water.wgsl's hooks for the terrain's water
/// and the open sea beyond it (the sky and the stratus layer reflected, the
/// radiosity's diffuse light).
pub const OPEN_WATER: WgslFile = WgslFile {
    name: "shader/open_water.wgsl",
    source: include_str!("open_water.wgsl"),
};

/// The atmosphere's parameters and its functions (optical depths,
/// scattering): the LUT passes and every lookup build on it.
pub const ATMOSPHERE: WgslFile = WgslFile {
    name: "shader/atmosphere.wgsl",
    source: include_str!("atmosphere.wgsl"),
};
/// The lighting inputs' layout (sun, ambient) written by the atmosphere's
/// lighting pass and read by exposure and every lit pass.
pub const LIGHTING_TYPES: WgslFile = WgslFile {
    name: "shader/lighting_types.wgsl",
    source: include_str!("lighting_types.wgsl"),
};
/// The atmosphere's lookups (group 2): transmittance, sky view, aerial
/// perspective, lighting.
pub const ATMOSPHERE_LOOKUP: WgslFile = WgslFile {
    name: "shader/atmosphere_lookup.wgsl",
    source: include_str!("atmosphere_lookup.wgsl"),
};
/// The stratiform layer's uniform and pure functions: its thickness field
/// and the 1-D slab model (twin of `nimbus_physics::cloud_layer`).
pub const CLOUD_LAYER_FIELD: WgslFile = WgslFile {
    name: "shader/cloud_layer_field.wgsl",
    source: include_str!("cloud_layer_field.wgsl"),
};
/// The cloud lighting group (group 3): the layer's thickness window,
/// optical tables and radiosity, its shadow and indirect light.
pub const CLOUD_LAYER_LOOKUP: WgslFile = WgslFile {
    name: "shader/cloud_layer_lookup.wgsl",
    source: include_str!("cloud_layer_lookup.wgsl"),
};
/// The cloud shadow map's transform and parameters.
pub const CLOUD_SHADOW_UNIFORM: WgslFile = WgslFile {
    name: "shader/cloud_shadow_uniform.wgsl",
    source: include_str!("cloud_shadow_uniform.wgsl"),
};
/// The cumulus shadow on whatever the sun lights.
pub const CLOUD_SHADOW_LOOKUP: WgslFile = WgslFile {
    name: "shader/cloud_shadow_lookup.wgsl",
    source: include_str!("cloud_shadow_lookup.wgsl"),
};

/// The terrain's shadow in the air (clouds and rain behind its ridges).
pub const TERRAIN_SHADOW_LOOKUP: WgslFile = WgslFile {
    name: "shader/terrain_shadow_lookup.wgsl",
    source: include_str!("terrain_shadow_lookup.wgsl"),
};

/// Hemisphere moments of phase functions (diffuse light scattered by the
/// rain's mist and by the air under a cloud layer); self-contained.
pub const HEMISPHERE_MOMENTS: WgslFile = WgslFile {
    name: "shader/hemisphere_moments.wgsl",
    source: include_str!("hemisphere_moments.wgsl"),
};

/// Eddington's radiance of a fluence and its gradient (the in-cloud
/// marches of the cumulus and of the stratus layer).
pub const DIFFUSION: WgslFile = WgslFile {
    name: "shader/diffusion.wgsl",
    source: include_str!("diffusion.wgsl"),
};

/// nimbus's lighting for the caller's own pipelines: the stable functions
/// `nimbus_sun_visibility`, `nimbus_sun_direction`, `nimbus_sun_irradiance`,
/// `nimbus_lambert_radiance`, `nimbus_pre_exposure` ([`lighting_include`]).
pub const NIMBUS_LIGHTING: WgslFile = WgslFile {
    name: "shader/nimbus_lighting.wgsl",
    source: include_str!("nimbus_lighting.wgsl"),
};

/// The WGSL a caller's pipeline starts with to light its surfaces as
/// nimbus lights its own (the sun through the atmosphere and the clouds'
/// shadows, the sky's or the cloud layer's ambient light): the functions of
/// `shader/nimbus_lighting.wgsl` and everything they need, composed. The
/// pipeline's layout: nimbus's groups 0, 2 and 3 and the caller's group 1
/// (`FrameLayouts::pipeline_layout` of `Renderer::frame_resources`); bound
/// with `FrameBindings::set_on`. See docs/embedding.md.
pub fn lighting_include() -> String {
    compose(&[NIMBUS_LIGHTING])
}

/// Every shared WGSL file: what imports resolve against.
pub const LIBRARY: [WgslFile; 15] = [
    COMMON,
    FULLSCREEN,
    LIT_SURFACE,
    WATER,
    OPEN_WATER,
    ATMOSPHERE,
    LIGHTING_TYPES,
    ATMOSPHERE_LOOKUP,
    CLOUD_LAYER_FIELD,
    CLOUD_LAYER_LOOKUP,
    CLOUD_SHADOW_UNIFORM,
    CLOUD_SHADOW_LOOKUP,
    TERRAIN_SHADOW_LOOKUP,
    HEMISPHERE_MOMENTS,
    DIFFUSION,
];

/// The files every drawing pass that reads the atmosphere needs, in order
/// (for kernels composed by hand, e.g. tests).
pub const DRAWING_LIBRARIES: [WgslFile; 4] =
    [COMMON, ATMOSPHERE, LIGHTING_TYPES, ATMOSPHERE_LOOKUP];

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

    /// Every shared file is found under its name in the checkout with the
    /// embedded text (so that hot reload edits what is rendered), and
    /// every import of one names another.
    #[test]
    fn library_files_resolve_in_the_checkout_and_import_each_other() {
        let dir = Path::new(CHECKOUT_SOURCE_DIR);
        for file in LIBRARY {
            let on_disk = std::fs::read_to_string(dir.join(file.name))
                .unwrap_or_else(|e| panic!("{}: {e}", file.name));
            assert_eq!(on_disk, file.source, "{}", file.name);
            for name in imports(file.source) {
                assert!(
                    LIBRARY.iter().any(|f| f.name == name),
                    "{} imports {name}, which is not in the library",
                    file.name
                );
            }
        }
    }

    /// The exporters' sea and the shader's share one glint roughness.
    #[test]
    fn water_glint_roughness_matches_the_shader() {
        let line = WATER
            .source
            .lines()
            .find_map(|l| l.strip_prefix("const WATER_GGX_ALPHA: f32 = "))
            .expect("water.wgsl declares WATER_GGX_ALPHA");
        let alpha: f64 = line.trim_end_matches(';').parse().expect("a number");
        assert_eq!(alpha as f32, WATER_GGX_ALPHA as f32);
    }

    const A: WgslFile = WgslFile {
        name: "a.wgsl",
        source: "// import shader/common.wgsl\n// import b.wgsl\nfn a() {}",
    };
    const B: WgslFile = WgslFile {
        name: "b.wgsl",
        source: "// import shader/common.wgsl\n// import a.wgsl\nfn b() {}",
    };

    /// Imports come before the file, each file once, and a cycle ends.
    #[test]
    fn imports_resolve_depth_first_without_duplicates() {
        let composed = compose_from(&[A, B], None);
        let order: Vec<&str> = composed
            .lines()
            .filter_map(|l| l.strip_prefix(FILE_MARKER))
            .collect();
        assert_eq!(order, [COMMON.name, B.name, A.name]);
        let lookup = compose_from(&[CLOUD_SHADOW_LOOKUP], None);
        let order: Vec<&str> = lookup
            .lines()
            .filter_map(|l| l.strip_prefix(FILE_MARKER))
            .collect();
        assert_eq!(
            order,
            [
                COMMON.name,
                CLOUD_SHADOW_UNIFORM.name,
                CLOUD_SHADOW_LOOKUP.name
            ]
        );
        let missing = WgslFile {
            name: "m.wgsl",
            source: "// import nowhere.wgsl\n",
        };
        assert!(compose_from(&[missing], None).contains("unresolved import: nowhere.wgsl"));
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
        std::fs::create_dir_all(dir.join("shader")).expect("temp dir");
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
