//! `nimbus cumulus`: generate a cumulus shape (blob hierarchy by particle
//! sampling), mesh it as one closed surface with the shader's attributes
//! and export it as binary glTF, with the hierarchy as JSON.

mod preview;

use super::check_output_dir;
use crate::output::{FileSet, encode_png, lowercase_extension};
use crate::progress::Progress;
use clap::Args;
use nimbus_physics::cumulus::gltf::to_glb;
use nimbus_physics::cumulus::hierarchy::{
    BuildProgress, Cumulus, CumulusParams, RootBlob, Roots, build, roots_from_json,
};
use nimbus_physics::cumulus::mesh::check_closed_manifold;
use nimbus_physics::cumulus::surface::{CumulusMesh, cumulus_lods};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `nimbus cumulus`.
#[derive(Debug, Args)]
pub struct CumulusArgs {
    /// Root blobs from a JSON file: an array of {"centre_m": [x, y, z],
    /// "radius_m": r, "flattening": e} (or an object with that array as
    /// "roots"). Without it and without --root-count: the six roots of the
    /// paper's example.
    #[arg(long, value_name = "FILE.json", conflicts_with = "root_count")]
    roots: Option<PathBuf>,
    /// Generate this many root blobs at random on a horizontal area (1–200).
    #[arg(long, value_name = "N")]
    root_count: Option<u32>,
    /// Random seed (roots, radii, flattening, sampling).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Levels generated on top of the roots (0–3).
    #[arg(long, default_value_t = 2)]
    levels: u32,
    /// Levels of detail written to the .glb (1–4), each with cells twice as large.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=4))]
    lods: u32,
    /// Output mesh (.glb).
    #[arg(short, long, value_name = "FILE.glb")]
    output: PathBuf,
    /// Where to write the blob hierarchy as JSON (default: next to the
    /// mesh, FILE.hierarchy.json).
    #[arg(long, value_name = "FILE.json")]
    hierarchy: Option<PathBuf>,
    /// Also render the mesh with plain Lambert lighting into a PNG.
    #[arg(long, value_name = "FILE.png")]
    preview: Option<PathBuf>,
    /// Print one JSON report on standard output.
    #[arg(long)]
    json: bool,
}

/// Largest `--roots` file read, bytes.
const MAX_ROOTS_FILE_BYTES: u64 = 1024 * 1024;

fn read_roots(path: &Path) -> anyhow::Result<Vec<RootBlob>> {
    // 1000 roots (the most a hierarchy takes) are ~100 kB of JSON; the
    // bound keeps the file small, and the reader refuses the 1001st root
    // as it parses.
    let text = nimbus_physics::io::read_text_bounded(path, MAX_ROOTS_FILE_BYTES)
        .map_err(|e| anyhow::anyhow!("--roots {}: {e}", path.display()))?;
    roots_from_json(&text).map_err(|e| anyhow::anyhow!("--roots {}: {e}", path.display()))
}

/// One level in the report.
#[derive(Serialize)]
struct LevelReport {
    level: usize,
    particles: usize,
    mean_radius_m: f64,
    sampler_iterations: Option<u32>,
    sampler_converged: Option<bool>,
}

/// One level of detail in the report.
#[derive(Serialize)]
struct LodReport {
    cell_m: f64,
    vertices: usize,
    triangles: usize,
    watertight: bool,
    euler_characteristic: i64,
}

/// The `--json` report.
#[derive(Serialize)]
struct Report {
    output: String,
    hierarchy: String,
    levels: Vec<LevelReport>,
    vertices: usize,
    triangles: usize,
    lods: Vec<LodReport>,
    bounding_box_m: [[f32; 3]; 2],
    lowest_point_m: f32,
    floor_height_m: f64,
    watertight: bool,
    seconds: f64,
}

/// The hierarchy file.
#[derive(Serialize)]
struct HierarchyFile {
    floor_height_m: f64,
    floor_stiffness_m: f64,
    levels: Vec<HierarchyLevel>,
}

#[derive(Serialize)]
struct HierarchyLevel {
    level: usize,
    blobs: Vec<RootBlob>,
}

fn hierarchy_json(cumulus: &Cumulus) -> HierarchyFile {
    let floor = cumulus.field.floor();
    HierarchyFile {
        floor_height_m: floor.height_m,
        floor_stiffness_m: floor.stiffness_m,
        levels: (0..cumulus.field.level_count())
            .map(|l| HierarchyLevel {
                level: l,
                blobs: cumulus
                    .field
                    .blobs(l)
                    .iter()
                    .map(|b| RootBlob {
                        centre_m: b.centre_m.to_array(),
                        radius_m: b.radius_m,
                        flattening: b.flattening,
                    })
                    .collect(),
            })
            .collect(),
    }
}

fn bounds(mesh: &CumulusMesh) -> [[f32; 3]; 2] {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    [lo, hi]
}

/// Runs `nimbus cumulus`.
pub fn run(args: &CumulusArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    anyhow::ensure!(
        lowercase_extension(&args.output).as_deref() == Some("glb"),
        "--output {}: must end in .glb (binary glTF)",
        args.output.display()
    );
    check_output_dir(&args.output)?;
    let hierarchy_path = args
        .hierarchy
        .clone()
        .unwrap_or_else(|| args.output.with_extension("hierarchy.json"));
    check_output_dir(&hierarchy_path)?;
    if let Some(p) = &args.preview {
        anyhow::ensure!(
            lowercase_extension(p).as_deref() == Some("png"),
            "--preview {}: must end in .png",
            p.display()
        );
        check_output_dir(p)?;
    }
    let roots = match (&args.roots, args.root_count) {
        (Some(path), _) => Roots::Given(read_roots(path)?),
        (None, Some(count)) => Roots::Random { count },
        (None, None) => CumulusParams::default().roots,
    };
    let params = CumulusParams {
        roots,
        generated_levels: args.levels,
        seed: args.seed,
        ..CumulusParams::default()
    };
    params.validate().map_err(|e| match &args.roots {
        Some(path) => anyhow::anyhow!("--roots {}: {e}", path.display()),
        None => anyhow::anyhow!("{}", flag_name(&e.to_string())),
    })?;

    // Steps: each generated level's sampling, then each level of detail's meshing.
    let progress = Progress::new("cumulus: steps", u64::from(args.levels + args.lods));
    let cumulus = build(&params, |p: BuildProgress| {
        progress.update(u64::from(p.level.saturating_sub(1)));
        progress.set_message(format!(
            "level {}/{}: iteration {}, {} particles",
            p.level, args.levels, p.iteration, p.particles
        ));
    })?;
    let lods = cumulus_lods(&cumulus, args.lods, |lod| {
        progress.update(u64::from(args.levels + lod));
        progress.set_message(format!("meshing level of detail {lod}"));
    });
    progress.finish();

    let lod_reports: Vec<LodReport> = lods
        .iter()
        .map(|m| {
            let t = check_closed_manifold(&m.triangle_mesh());
            LodReport {
                cell_m: m.cell_m,
                vertices: m.positions.len(),
                triangles: m.triangle_count(),
                watertight: t.is_watertight(),
                euler_characteristic: t.euler_characteristic,
            }
        })
        .collect();
    let finest = &lods[0];
    anyhow::ensure!(
        !finest.positions.is_empty(),
        "the cloud's surface is empty: no blob reaches f = 1"
    );

    let glb =
        to_glb(&lods).map_err(|e| anyhow::anyhow!("--output {}: {e}", args.output.display()))?;
    // The mesh, its hierarchy and the preview describe one cloud: replaced
    // together, so a failure leaves the previous run's three files.
    let mut files = FileSet::new();
    files.write_bytes(&args.output, "--output", &glb)?;
    let hierarchy = serde_json::to_vec_pretty(&hierarchy_json(&cumulus))?;
    files.write_bytes(&hierarchy_path, "--hierarchy", &hierarchy)?;
    if let Some(path) = &args.preview {
        let png = encode_png(path, &preview::render(finest, 960, 640))?;
        files.write_bytes(path, "--preview", &png)?;
    }
    files.commit()?;

    let bounding_box_m = bounds(finest);
    let report = Report {
        output: args.output.display().to_string(),
        hierarchy: hierarchy_path.display().to_string(),
        levels: cumulus
            .levels
            .iter()
            .enumerate()
            .map(|(level, l)| LevelReport {
                level,
                particles: l.count,
                mean_radius_m: l.mean_radius_m,
                sampler_iterations: l.sampling.map(|s| s.iterations),
                sampler_converged: l.sampling.map(|s| s.converged),
            })
            .collect(),
        vertices: finest.positions.len(),
        triangles: finest.triangle_count(),
        watertight: lod_reports.iter().all(|l| l.watertight),
        lods: lod_reports,
        lowest_point_m: bounding_box_m[0][1],
        bounding_box_m,
        floor_height_m: cumulus.field.floor().height_m,
        seconds: start.elapsed().as_secs_f64(),
    };
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        // The report on standard output, the files written on standard error.
        for l in &report.levels {
            outln!(
                "level {}: {} blobs, mean radius {:.1} m{}",
                l.level,
                l.particles,
                l.mean_radius_m,
                match l.sampler_converged {
                    Some(true) => format!(
                        " (equilibrium after {} iterations)",
                        l.sampler_iterations.unwrap_or(0)
                    ),
                    Some(false) => " (iteration limit reached before equilibrium)".to_string(),
                    None => String::new(),
                }
            );
        }
        outln!(
            "mesh: {} vertices, {} triangles, {}, lowest point {:.0} m (floor {:.0} m), {} levels of detail",
            report.vertices,
            report.triangles,
            if report.watertight {
                "watertight"
            } else {
                "NOT watertight"
            },
            report.lowest_point_m,
            report.floor_height_m,
            report.lods.len()
        );
        eprintln!(
            "nimbus: wrote {} and {} in {:.2} s",
            report.output, report.hierarchy, report.seconds
        );
    }
    Ok(())
}

/// Names the parameter as the flag that sets it, where there is one.
fn flag_name(message: &str) -> String {
    message
        .replacen("root_count =", "--root-count", 1)
        .replacen("levels =", "--levels", 1)
}
