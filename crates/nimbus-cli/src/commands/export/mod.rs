//! `nimbus export SCENE --mitsuba DIR`: the scene as nimbus draws it, for
//! the Mitsuba 3 path tracer (tools/reference/render.py renders it): the
//! ground truth that `nimbus compare` measures the real-time image against.
//!
//! `nimbus export SCENE --gltf FILE.glb` (alone or with `--mitsuba`): the
//! scene's cumulus field where the renderer places it at `--time-s` and its
//! terrain, as binary glTF for Blender (`nimbus_render::export::scene_glb`,
//! no GPU needed).
//!
//! What the Mitsuba scene holds (see `docs/REALISM.md` for what is left out):
//! - the camera (position, orientation, vertical field of view, size);
//! - the sun: a directional emitter with nimbus's solar irradiance times
//!   the atmosphere's transmittance at the clouds' altitude, per channel;
//! - the sky: nimbus's own clear-sky panorama at the camera (the
//!   equirectangular projection, clouds and rain removed, the sun's disc
//!   replaced by its surroundings) as an environment map;
//! - the terrain as a triangle mesh with its albedo texture (Lambertian),
//!   the sea as a plane of water (a diffuse body under a smooth dielectric
//!   coat of n = 1.333: nimbus's Fresnel-weighted sky reflection and body);
//! - each placed cumulus as a grid of droplet extinction (the shader's
//!   core α_ρ and corona, `nimbus_physics::cumulus::volume`); clouds whose
//!   boxes overlap as one grid holding the sum of their extinctions
//!   (Mitsuba follows one medium at a time: `overlap`);
//! - the stratus layer as a grid of its thickness field at that time, with
//!   the extinction of its droplet size distribution;
//! - the droplets' phase function (Mie, integrated over the layer's size
//!   distribution at 550 nm) as a tabulated phase function, and their
//!   single-scattering albedo; the forward diffraction peak truncated by the
//!   δ-M method at `--phase-truncation-deg` (default 5°; 0 keeps it);
//! - with `--light sun` or `--light sky`, that emitter alone and every
//!   surface black, to split the light by where it comes from;
//! - the rain's mist (drops' extinction, Henyey–Greenstein 0.85) where
//!   nimbus's map of rain factors puts it: inside the rain areas with their
//!   soft edges and under the clouds with `rain.under_clouds` (a grid), or
//!   everywhere below the rain's ceiling when the scene rains everywhere.

mod air;
mod gltf;
mod mitsuba;
mod overlap;

use crate::output::FileSet;
use anyhow::Context;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `nimbus export`: `--mitsuba`, `--gltf` or both.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("format").args(["mitsuba", "gltf"]).required(true).multiple(true)))]
pub struct ExportArgs {
    #[command(flatten)]
    frame: super::FrameArgs,
    /// Write a Mitsuba 3 scene (scene.xml and its assets) into this
    /// directory (created if missing; its parent must exist).
    #[arg(long, value_name = "DIR")]
    mitsuba: Option<PathBuf>,
    /// Write the cumulus field (each cloud a node instancing its shape's
    /// mesh, where the wind has carried it at --time-s) and the terrain as
    /// binary glTF: metres, y up, world space, for Blender. No GPU needed.
    #[arg(long, value_name = "FILE.glb")]
    gltf: Option<PathBuf>,
    /// Animation time, s (as `render --time-s`).
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    time_s: f64,
    /// With --mitsuba: truncate the droplets' forward diffraction peak
    /// inside this scattering angle by the δ-M method (Wiscombe 1977), in
    /// degrees, 0 to 30; 0 keeps the full phase function. The truncation
    /// cuts the path tracer's variance many times; it biases the light
    /// seen within about this angle of the sun's direction.
    #[arg(long, default_value_t = 5.0, value_name = "DEG")]
    phase_truncation_deg: f64,
    /// With --mitsuba: export the air below the clouds as a medium, nimbus's
    /// molecules and aerosols, so that the reference has the aerial
    /// perspective nimbus draws; one grey medium per channel, chosen by the
    /// scene's `$air` parameter (r, g or b; tools/reference/air.sh renders
    /// the three and combines them).
    #[arg(long)]
    air: bool,
    /// With --mitsuba and --phase-truncation-deg 0: the droplets' phase
    /// function at each channel's wavelength (680, 550, 440 nm), chosen by
    /// the scene's `$phase` parameter (r, g or b; render the three and take
    /// channel c of render c, tools/reference/channels.py), not green's in
    /// every channel: the diffraction peak's width goes with the
    /// wavelength, which colours a lining seen a few degrees from the sun.
    #[arg(long, requires = "mitsuba")]
    phase_per_channel: bool,
    /// With --mitsuba: one light source alone, the terrain, sea and ground
    /// black: with the full export's render, the light split by where it
    /// comes from (the full render minus the sun's and the sky's is the
    /// light the surfaces reflect; docs/REALISM.md).
    #[arg(long, value_enum, requires = "mitsuba", value_name = "SOURCE")]
    light: Option<mitsuba::LightSource>,
}

/// Runs the subcommand.
pub fn run(args: &ExportArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.time_s.is_finite() && (0.0..=1.0e7).contains(&args.time_s),
        "--time-s {}: must be a number in [0, 10000000]",
        args.time_s
    );
    anyhow::ensure!(
        args.phase_truncation_deg.is_finite()
            && (0.0..=mitsuba::MAX_PHASE_TRUNCATION_DEG).contains(&args.phase_truncation_deg),
        "--phase-truncation-deg {}: must be a number of degrees in [0, {}] (0: the full phase function)",
        args.phase_truncation_deg,
        mitsuba::MAX_PHASE_TRUNCATION_DEG
    );
    anyhow::ensure!(
        !args.phase_per_channel || args.phase_truncation_deg == 0.0,
        "--phase-per-channel: needs --phase-truncation-deg 0, not {} (the truncated fraction, and with it the extinction's scale, would differ per channel)",
        args.phase_truncation_deg
    );
    if let Some(path) = &args.gltf {
        gltf::check_output(path)?;
    }
    let (scene, width, height) = args.frame.scene_and_size()?;
    let scene = scene.at_time(args.time_s);
    // Every file of the export is replaced together, once all are written.
    let mut files = FileSet::new();
    let Some(mitsuba_dir) = args.mitsuba.as_deref() else {
        // --gltf alone (clap asks for one of the two): no GPU.
        if let Some(path) = args.gltf.as_deref() {
            let wrote = gltf::write(&scene, args.time_s, path, &mut files)?;
            files.commit()?;
            eprintln!("{wrote}");
        }
        return Ok(());
    };
    anyhow::ensure!(
        scene.camera.projection == nimbus_render::scene::Projection::Perspective,
        "camera.projection = equirectangular: export needs a perspective camera"
    );
    let parent = mitsuba_dir
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    anyhow::ensure!(
        parent.is_dir(),
        "--mitsuba {}: the parent directory {} does not exist",
        mitsuba_dir.display(),
        parent.display()
    );
    let wrote_gltf = match &args.gltf {
        Some(path) => Some(gltf::write(&scene, args.time_s, path, &mut files)?),
        None => None,
    };
    std::fs::create_dir_all(mitsuba_dir).with_context(|| {
        format!(
            "--mitsuba {}: cannot create the directory",
            mitsuba_dir.display()
        )
    })?;
    let mut headless = nimbus_render::headless::HeadlessRenderer::new(args.frame.adapter())?;
    eprintln!(
        "nimbus: exporting {width}×{height} to {} on {}",
        mitsuba_dir.display(),
        headless.gpu.adapter_summary()
    );
    // Optics tables, the sky panorama and the cloud volumes: no known total.
    let progress = crate::progress::Progress::spinner("export");
    let summary = mitsuba::export(
        &mut headless,
        &scene,
        width,
        height,
        mitsuba::Options {
            time_s: args.time_s,
            phase_truncation_deg: args.phase_truncation_deg,
            air: args.air,
            phase_per_channel: args.phase_per_channel,
            light: args.light,
        },
        mitsuba_dir,
        &mut files,
    )?;
    files.commit()?;
    progress.finish();
    if let Some(line) = wrote_gltf {
        eprintln!("{line}");
    }
    for line in &summary.approximations {
        eprintln!("nimbus: export: {line}");
    }
    eprintln!(
        "nimbus: wrote {} ({} cumulus, stratus {})",
        mitsuba_dir.join("scene.xml").display(),
        summary.cumulus_count,
        if summary.stratus { "yes" } else { "no" }
    );
    Ok(())
}
