//! `nimbus export SCENE --gltf FILE.glb`: the scene's cumulus field and
//! terrain at `--time-s` as binary glTF, built by
//! [`nimbus_render::export::scene_glb`] and written atomically (with
//! `--mitsuba`, as one set with its files).

use super::super::check_output_dir;
use crate::output::{FileSet, lowercase_extension};
use nimbus_render::Scene;
use std::path::Path;
use std::time::Instant;

/// Checks, before any work, that `path` ends in `.glb` and its directory exists.
pub fn check_output(path: &Path) -> anyhow::Result<()> {
    let extension = lowercase_extension(path);
    anyhow::ensure!(
        extension.as_deref() == Some("glb"),
        "--gltf {}: must end in .glb (binary glTF)",
        path.display()
    );
    check_output_dir(path)?;
    Ok(())
}

/// Writes `scene` (already at `time_s`) at `time_s` to `path`, as one file
/// of the export's set; returns the line that reports it once written.
pub fn write(
    scene: &Scene,
    time_s: f64,
    path: &Path,
    files: &mut FileSet,
) -> anyhow::Result<String> {
    let start = Instant::now();
    let export = nimbus_render::export::scene_glb(scene, time_s)
        .map_err(|e| anyhow::anyhow!("--gltf {}: {e}", path.display()))?;
    files.write_bytes(path, "--gltf", &export.bytes)?;
    let terrain = match export.terrain_vertices {
        Some(n) => format!("terrain of {n} vertices"),
        None => "no terrain (ground.terrain = false)".to_owned(),
    };
    let shapes = export
        .clouds
        .iter()
        .map(|c| c.variant)
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    Ok(format!(
        "nimbus: wrote {} ({} bytes) at {time_s} s: {terrain}, {} cumulus instancing {shapes} shapes, in {:.2} s",
        path.display(),
        export.bytes.len(),
        export.clouds.len(),
        start.elapsed().as_secs_f64()
    ))
}
