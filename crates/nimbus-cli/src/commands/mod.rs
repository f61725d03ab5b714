//! One module per subcommand.

pub mod animate;
pub mod bench;
pub mod compare;
pub mod completions;
pub mod cumulus;
pub mod export;
pub mod optics;
pub mod rain;
pub mod render;
pub mod scene;
pub mod slab;
pub mod sun;
pub mod view;

use anyhow::Context;
use nimbus_render::{AdapterPreference, Scene};
use std::path::{Path, PathBuf};

/// Image-size limit of the flags (the device's limit is checked as well).
pub const MAX_SIDE_PX: u32 = nimbus_render::scene::MAX_IMAGE_SIDE_PX;

/// Loads the scene file, or the embedded default scene when none is given,
/// and warns on standard error about a camera under the ground.
pub fn load_scene(path: Option<&Path>) -> anyhow::Result<Scene> {
    let scene = match path {
        Some(path) => Scene::from_file(path)?,
        None => Scene::embedded_default(),
    };
    let [x, y, z] = scene.camera.position_m;
    let ground = nimbus_physics::terrain::ground_height_m(&scene.terrain, x, z)
        .max(scene.terrain.water_level_m);
    if y < ground {
        eprintln!(
            "nimbus: warning: camera.position_m is {:.0} m below the terrain surface there ({ground:.0} m)",
            ground - y
        );
    }
    Ok(scene)
}

/// The `--adapter` flag's values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Adapter {
    /// A hardware GPU if there is one, otherwise a software adapter.
    Auto,
    /// Only a hardware GPU.
    Hardware,
    /// Only a software (CPU) adapter such as lavapipe.
    Software,
}

impl From<Adapter> for AdapterPreference {
    fn from(adapter: Adapter) -> Self {
        match adapter {
            Adapter::Auto => Self::Auto,
            Adapter::Hardware => Self::Hardware,
            Adapter::Software => Self::Software,
        }
    }
}

/// The scene, image size and adapter flags shared by the rendering commands.
#[derive(Debug, clap::Args)]
pub struct FrameArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    scene: Option<PathBuf>,
    /// Image width in pixels (overrides the scene's image.width).
    #[arg(long, value_name = "PX", value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE_PX as i64))]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene's image.height).
    #[arg(long, value_name = "PX", value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE_PX as i64))]
    height: Option<u32>,
    /// GPU adapter.
    #[arg(long, value_enum, default_value_t = Adapter::Auto)]
    adapter: Adapter,
}

impl FrameArgs {
    /// Loads the scene and resolves the image size (flags override the scene).
    pub fn scene_and_size(&self) -> anyhow::Result<(Scene, u32, u32)> {
        let scene = load_scene(self.scene.as_deref())?;
        let width = self.width.unwrap_or(scene.image.width);
        let height = self.height.unwrap_or(scene.image.height);
        Ok((scene, width, height))
    }

    /// The scene's name in reports: the file's name without its extension,
    /// `default` for the embedded scene.
    pub fn scene_name(&self) -> String {
        match &self.scene {
            Some(path) => path
                .file_stem()
                .unwrap_or(path.as_os_str())
                .to_string_lossy()
                .into_owned(),
            None => "default".to_owned(),
        }
    }

    /// The adapter asked for.
    pub fn adapter(&self) -> AdapterPreference {
        self.adapter.into()
    }
}

/// Checks that an output path's directory exists before any work is done.
pub fn check_output_dir(path: &Path) -> anyhow::Result<PathBuf> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let meta = std::fs::metadata(&dir).with_context(|| {
        format!(
            "output {}: directory {} does not exist",
            path.display(),
            dir.display()
        )
    })?;
    anyhow::ensure!(
        meta.is_dir(),
        "output {}: {} is not a directory",
        path.display(),
        dir.display()
    );
    // Writable now, before the work (a read-only directory was found only
    // after a whole render): a probe file created and removed.
    let probe = dir.join(format!(".nimbus-write-probe.{}.tmp", std::process::id()));
    std::fs::File::create(&probe).map_err(|e| {
        anyhow::anyhow!(
            "output {}: cannot write in directory {}: {e}",
            path.display(),
            dir.display()
        )
    })?;
    let _ = std::fs::remove_file(&probe);
    Ok(dir)
}
