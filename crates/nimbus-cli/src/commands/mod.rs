//! One module per subcommand.

pub mod bench;
pub mod render;
pub mod scene;

use anyhow::Context;
use nimbus_render::{AdapterPreference, Scene};
use std::path::{Path, PathBuf};

/// Image-size limit of the flags (the device's limit is checked as well).
pub const MAX_SIDE_PX: u32 = nimbus_render::scene::MAX_IMAGE_SIDE_PX;

/// Loads the scene file, or the embedded default scene when none is given,
/// and warns on standard error about sections that are not rendered yet.
pub fn load_scene(path: Option<&Path>) -> anyhow::Result<Scene> {
    let scene = match path {
        Some(path) => Scene::from_file(path)?,
        None => Scene::embedded_default(),
    };
    for name in scene.reserved_sections_present() {
        eprintln!("nimbus: warning: [{name}] is validated but not rendered by this version");
    }
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

/// Parses `--adapter`.
pub fn parse_adapter(text: &str) -> Result<AdapterPreference, String> {
    text.parse()
}

/// Image size from flags, falling back to the scene's.
pub fn image_size(scene: &Scene, width: Option<u32>, height: Option<u32>) -> (u32, u32) {
    (
        width.unwrap_or(scene.image.width),
        height.unwrap_or(scene.image.height),
    )
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
    Ok(dir)
}
