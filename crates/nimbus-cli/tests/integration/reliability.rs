//! Hostile inputs (issue 28): files that never end, block, or are far
//! larger than their format allows are refused with one line, before they
//! are read, within a memory bound (the binary runs under `ulimit -v`) and a
//! time bound (a run that blocks is killed and fails the test).

use crate::support::temp_dir;

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Address space the binary may use, KiB: room for the executable, its
/// threads' stacks and the allocator, far below what reading any of these
/// files whole would take (the smallest is 600 MiB).
const ADDRESS_SPACE_KIB: u64 = 512 * 1024;

/// Longest a refusal may take.
const DEADLINE: Duration = Duration::from_secs(60);

/// How a run of the binary is bounded.
struct Bounds {
    /// Address space (`ulimit -v`), KiB.
    address_space_kib: u64,
    /// Past this the run is killed and the test fails (it blocked).
    deadline: Duration,
    /// Environment set for the run.
    envs: &'static [(&'static str, &'static str)],
}

/// The bounds of a refusal of hostile input.
const INPUT_BOUNDS: Bounds = Bounds {
    address_space_kib: ADDRESS_SPACE_KIB,
    deadline: DEADLINE,
    envs: &[],
};

/// Runs `nimbus ARGS` in `dir` within `bounds`; kills it and fails past the
/// deadline. Both pipes are read as the run goes (a full pipe would block
/// it).
fn bounded_run(args: &[&str], dir: &Path, bounds: &Bounds) -> Output {
    let mut child = Command::new("bash")
        .arg("-c")
        .arg(format!(
            "ulimit -v {} && exec \"$0\" \"$@\"",
            bounds.address_space_kib
        ))
        .arg(env!("CARGO_BIN_EXE_nimbus"))
        .args(args)
        .envs(bounds.envs.iter().copied())
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let (stdout, stderr) = (drain(child.stdout.take()), drain(child.stderr.take()));
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("waits") {
            break status;
        }
        if start.elapsed() > bounds.deadline {
            child.kill().ok();
            child.wait().ok();
            panic!(
                "nimbus {args:?} still running after {:?} (blocked?)",
                bounds.deadline
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output {
        status,
        stdout: stdout.join().expect("stdout"),
        stderr: stderr.join().expect("stderr"),
    }
}

/// Reads a child's pipe to the end on a thread of its own.
fn drain<R: std::io::Read + Send + 'static>(pipe: Option<R>) -> std::thread::JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut pipe) = pipe {
            pipe.read_to_end(&mut bytes).ok();
        }
        bytes
    })
}

/// The run failed with exit code 1 and one line containing every `needle`.
fn assert_refused(args: &[&str], dir: &Path, needles: &[&str]) {
    let out = bounded_run(args, dir, &INPUT_BOUNDS);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: {stderr}");
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "{args:?}: no {needle:?} in {stderr}"
        );
    }
}

fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(status.success());
}

/// A sparse file of `len` bytes starting with `head` (no disk used).
fn sparse(path: &Path, head: &[u8], len: u64) {
    let mut file = std::fs::File::create(path).expect("create");
    file.write_all(head).expect("write");
    file.set_len(len).expect("set_len");
}

/// A valid .npy header for a (2, 2, 2, 3) float32 array.
fn npy_header() -> Vec<u8> {
    let dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 2, 3), }";
    let mut header = format!("{dict:<117}\n").into_bytes();
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.append(&mut header);
    out
}

fn wind_scene(dir: &Path, file: &str) {
    std::fs::write(
        dir.join("scene.toml"),
        format!("[wind]\nspeed_m_s = 5.0\n[wind.field]\nfile = \"{file}\"\ncell_m = 10.0\n"),
    )
    .expect("scene");
}

#[test]
fn wind_fields_that_never_end_block_or_are_huge_are_refused_unread() {
    let dir = temp_dir("reliability", "wind");
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.npy")).expect("symlink");
    wind_scene(&dir, "zero.npy");
    assert_refused(
        &["scene", "--check", "scene.toml"],
        &dir,
        &["wind.field.file", "character device"],
    );

    mkfifo(&dir.join("pipe.npy"));
    wind_scene(&dir, "pipe.npy");
    assert_refused(
        &["scene", "--check", "scene.toml"],
        &dir,
        &["wind.field.file", "named pipe"],
    );

    // A legal header, then 3 GiB of (sparse) data: read whole before.
    sparse(&dir.join("big.npy"), &npy_header(), 3 << 30);
    wind_scene(&dir, "big.npy");
    assert_refused(
        &["scene", "--check", "scene.toml"],
        &dir,
        &["wind.field.file", "3 GiB", "at most"],
    );

    // The same header with trailing bytes: the shape does not describe it.
    let mut bytes = npy_header();
    bytes.extend(std::iter::repeat_n(0u8, 2 * 2 * 2 * 3 * 4 + 8));
    std::fs::write(dir.join("trailing.npy"), bytes).expect("write");
    wind_scene(&dir, "trailing.npy");
    assert_refused(
        &["scene", "--check", "scene.toml"],
        &dir,
        &["wind.field.file", "exactly"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn meshes_and_their_buffers_are_bounded() {
    let dir = temp_dir("reliability", "mesh");
    let scene = |mesh: &str| {
        std::fs::write(
            dir.join("scene.toml"),
            format!(
                "[[objects]]\nkind = \"mesh\"\ngltf = \"{mesh}\"\nposition_m = [0.0, 0.0, 0.0]\n"
            ),
        )
        .expect("scene");
    };
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.glb")).expect("symlink");
    scene("zero.glb");
    assert_refused(
        &["scene", "--check", "scene.toml"],
        &dir,
        &["zero.glb", "character device"],
    );
    mkfifo(&dir.join("pipe.gltf"));
    scene("pipe.gltf");
    assert_refused(
        &["scene", "--check", "scene.toml"],
        &dir,
        &["pipe.gltf", "named pipe"],
    );
    // A glTF whose external buffer is 600 MiB (the documented limit is 512).
    let gltf = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"uri": "big%20buffer.bin", "byteLength": 629145600}]}"#;
    std::fs::write(dir.join("big.gltf"), gltf).expect("gltf");
    sparse(&dir.join("big buffer.bin"), &[0; 36], 600 << 20);
    scene("big.gltf");
    assert_refused(
        &["scene", "--check", "scene.toml"],
        &dir,
        &["big buffer.bin", "600 MiB", "512 MiB"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scene_and_roots_files_are_bounded_before_parsing() {
    let dir = temp_dir("reliability", "scene");
    // 600,000 objects (~50 MB): refused by size, not after a 2.5 GB parse.
    let mut text = String::with_capacity(56 << 20);
    for _ in 0..600_000 {
        text.push_str(
            "[[objects]]\nkind = \"box\"\ncenter_m = [0.0, 0.0, 0.0]\nsize_m = [1.0, 1.0, 1.0]\n",
        );
    }
    std::fs::write(dir.join("many.toml"), &text).expect("write");
    assert_refused(
        &["scene", "--check", "many.toml"],
        &dir,
        &["many.toml", "at most 1 MiB"],
    );
    mkfifo(&dir.join("pipe.toml"));
    assert_refused(
        &["scene", "--check", "pipe.toml"],
        &dir,
        &["pipe.toml", "named pipe"],
    );
    // A million roots (~60 MB of JSON).
    let mut roots = String::from("[");
    for i in 0..1_000_000 {
        if i > 0 {
            roots.push(',');
        }
        roots.push_str(r#"{"centre_m":[0,0,0],"radius_m":100}"#);
    }
    roots.push(']');
    std::fs::write(dir.join("roots.json"), roots).expect("write");
    assert_refused(
        &["cumulus", "--roots", "roots.json", "-o", "out.glb"],
        &dir,
        &["--roots", "roots.json", "at most 1 MiB"],
    );
    assert!(!dir.join("out.glb").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// `--json` never carries NaN or infinity (serde_json would write `null`
/// and exit 0): the inputs that produced them are refused with their range,
/// and the limits themselves give finite documents.
#[test]
fn json_documents_hold_only_finite_numbers() {
    let dir = temp_dir("reliability", "json");
    for (args, needles) in [
        (
            &[
                "optics",
                "mie",
                "--radius-um",
                "5",
                "--wavelength-nm",
                "550",
                "--refractive-index=1e-100,0",
                "--json",
            ][..],
            &["--refractive-index", "[0.1, 10]"][..],
        ),
        (
            &[
                "optics",
                "mie",
                "--radius-um",
                "5",
                "--wavelength-nm",
                "550",
                "--refractive-index=1.33,101",
                "--json",
            ][..],
            &["1.33,101", "K in [0, 10]"][..],
        ),
        (
            &["optics", "dsd", "--lognormal-sigma", "1.000001", "--json"][..],
            &["--lognormal-sigma 1.000001", "[1.001, 5]"][..],
        ),
        (
            &[
                "rain",
                "terminal-velocity",
                "--diameter-mm",
                "1e-300",
                "--json",
            ][..],
            &["--diameter-mm", "[0.01, 8]"][..],
        ),
    ] {
        assert_refused(args, &dir, needles);
    }
    for args in [
        &[
            "optics",
            "mie",
            "--radius-um",
            "5",
            "--wavelength-nm",
            "550",
            "--refractive-index=0.1,10",
            "--json",
        ][..],
        &[
            "rain",
            "terminal-velocity",
            "--diameter-mm",
            "0.01,8",
            "--json",
        ][..],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_nimbus"))
            .args(args)
            .output()
            .expect("runs");
        assert!(out.status.success(), "{args:?}");
        let text = String::from_utf8(out.stdout).expect("utf-8");
        let value: serde_json::Value = serde_json::from_str(&text).expect("one JSON document");
        fn nulls(v: &serde_json::Value, path: &str, out: &mut Vec<String>) {
            match v {
                serde_json::Value::Null => out.push(path.to_owned()),
                serde_json::Value::Array(a) => a
                    .iter()
                    .enumerate()
                    .for_each(|(i, x)| nulls(x, &format!("{path}[{i}]"), out)),
                serde_json::Value::Object(o) => o
                    .iter()
                    .for_each(|(k, x)| nulls(x, &format!("{path}.{k}"), out)),
                _ => {}
            }
        }
        let mut found = Vec::new();
        nulls(&value, "", &mut found);
        // Gunn & Kinzer's measurement is absent where they did not tabulate.
        found.retain(|p| !p.ends_with("gunn_kinzer_m_s"));
        assert!(found.is_empty(), "{args:?}: null at {found:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A run killed while writing leaves `.NAME.PID.tmp`; the next run that
/// writes NAME removes it (its process is gone), and leaves alone the
/// temporary file of a run still going.
#[test]
fn the_next_run_removes_what_a_killed_run_left() {
    let dir = temp_dir("reliability", "stale");
    // Beyond Linux's largest pid (2²²): no such process.
    let stale = dir.join(".phase.svg.999999999.tmp");
    let live = dir.join(format!(".phase.svg.{}.tmp", std::process::id()));
    let other = dir.join(".other.svg.999999999.tmp");
    for file in [&stale, &live, &other] {
        std::fs::write(file, b"partial").expect("write");
    }
    let out = bounded_run(
        &[
            "optics",
            "dsd",
            "--wavelength-nm",
            "550",
            "--plot",
            "phase.svg",
        ],
        &dir,
        &INPUT_BOUNDS,
    );
    crate::support::assert_success(&out);
    assert!(dir.join("phase.svg").exists());
    assert!(!stale.exists(), "the killed run's file is still there");
    assert!(live.exists() && other.exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// Address space of the GPU runs below, KiB. The software adapter's
/// device memory is the process's own, so this bound makes it run out of
/// memory for real. Measured (llvmpipe, LLVM 15): a 64×64 frame needs
/// 1.0–1.2 GiB (the device, the shader compiler, the pipelines); with Mesa
/// 22.3 the targets of a 8192×8192 frame could not be allocated under
/// 1.4–2.3 GiB and were under 2.6 GiB; with Mesa 25.0 a frame that does
/// not fit ends the process (a segmentation fault; seen at 4096×2048 under
/// this bound with glibc's default malloc arenas), which nimbus's check of
/// the frame's memory refuses first. Outside that window
/// what fails is llvmpipe's compiler or Rust's allocator (an abort), not a
/// GPU allocation.
const GPU_ADDRESS_SPACE_KIB: u64 = 1792 * 1024;

/// Longest a GPU run under the bound may take (a small frame on the
/// software adapter, its shaders compiled).
const GPU_DEADLINE: Duration = Duration::from_secs(300);

/// The bounds of the GPU runs: [`GPU_ADDRESS_SPACE_KIB`], with the
/// threads that reserve address space (llvmpipe's rasterizer, rayon's pool,
/// glibc's malloc arenas) bounded so that what a run needs does not grow
/// with the machine's cores.
const GPU_BOUNDS: Bounds = Bounds {
    address_space_kib: GPU_ADDRESS_SPACE_KIB,
    deadline: GPU_DEADLINE,
    envs: &[
        ("LP_NUM_THREADS", "2"),
        ("RAYON_NUM_THREADS", "2"),
        ("MALLOC_ARENA_MAX", "2"),
    ],
};

/// Out of GPU memory ends `render`, `animate` and `bench` with one line,
/// no panic and nothing written. Forced for real on the software adapter
/// (required: the bound on the address space exhausts its memory, not a
/// hardware GPU's): under the bound a small frame renders (the control),
/// the largest frame nimbus allows cannot have its targets. nimbus refuses
/// it before allocating (the software adapter's memory is the process's,
/// which it reads): Mesa 25's lavapipe ends the process where it runs out,
/// where Mesa 22's reported it. Device loss cannot be forced from the
/// command line; `nimbus-render/tests/integration/faults.rs` forces it in the library.
#[test]
fn out_of_gpu_memory_ends_render_animate_and_bench_with_one_line_and_nothing_written() {
    let dir = temp_dir("reliability", "gpu-memory");
    let small = [
        "render",
        "--adapter",
        "software",
        "--width",
        "64",
        "--height",
        "64",
        "-o",
        "small.png",
    ];
    // The control: a small frame renders under the bound.
    crate::support::assert_success(&bounded_run(&small, &dir, &GPU_BOUNDS));
    std::fs::remove_file(dir.join("small.png")).expect("the control frame was written");

    let largest = [
        "--adapter",
        "software",
        "--width",
        "8192",
        "--height",
        "8192",
    ];
    let commands: [&[&str]; 3] = [
        &["render", "-o", "big.png"],
        &["animate", "--seconds", "1", "--fps", "1", "-o", "frames"],
        &["bench", "--frames", "1", "--json"],
    ];
    for command in commands {
        let args: Vec<&str> = command.iter().chain(&largest).copied().collect();
        let out = bounded_run(&args, &dir, &GPU_BOUNDS);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        crate::support::assert_fails_with(
            &out,
            &[
                "a 8192×8192 frame needs about",
                "MiB of GPU memory (its targets and the driver's work) and the software adapter has",
                "try a smaller image",
            ],
        );
        assert!(out.stdout.is_empty(), "{args:?}: stdout {:?}", out.stdout);
    }
    // No image, no temporary file; animate's directory holds no frame.
    assert_eq!(crate::support::files_in(&dir), ["frames"]);
    assert!(crate::support::files_in(&dir.join("frames")).is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

/// A roots file of one root blob.
const ONE_ROOT: &str = r#"[{"centre_m": [0, 0, 0], "radius_m": 300, "flattening": 0.3}]"#;

/// One root and no generated level is a valid cloud (a flattened sphere);
/// it was refused as "surface empty" (the seed search started at the
/// blob's centre, where the field's gradient vanishes).
#[test]
fn a_single_root_without_levels_is_a_cloud() {
    let dir = temp_dir("reliability", "one-root");
    std::fs::write(dir.join("one.json"), ONE_ROOT).expect("roots");
    let out = crate::support::nimbus(
        &[
            "cumulus", "--roots", "one.json", "--levels", "0", "--lods", "1", "-o", "one.glb",
            "--json",
        ],
        &dir,
    );
    crate::support::assert_success(&out);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON document");
    assert_eq!(report["watertight"], true, "{report}");
    assert!(report["triangles"].as_u64().unwrap_or(0) > 100, "{report}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `cumulus`'s mesh, hierarchy and preview are replaced as a set: when one
/// cannot be written, the previous run's files stay as they were (the mesh
/// was replaced before the hierarchy failed), and no temporary is left.
#[test]
fn cumulus_outputs_are_replaced_together_or_not_at_all() {
    let dir = temp_dir("reliability", "set");
    std::fs::write(dir.join("one.json"), ONE_ROOT).expect("roots");
    std::fs::write(dir.join("one.glb"), b"the previous mesh").expect("write");
    // A hierarchy path that is a directory: no file can be renamed onto it.
    std::fs::create_dir(dir.join("one.json.d")).expect("mkdir");
    let args = [
        "cumulus",
        "--roots",
        "one.json",
        "--levels",
        "0",
        "--lods",
        "1",
        "-o",
        "one.glb",
        "--hierarchy",
        "one.json.d",
        "--preview",
        "one.png",
    ];
    assert_refused(
        &args,
        &dir,
        &["one.json.d", "directory", "nothing was replaced"],
    );
    assert_eq!(
        std::fs::read(dir.join("one.glb")).expect("read"),
        b"the previous mesh"
    );
    assert_eq!(
        crate::support::files_in(&dir),
        ["one.glb", "one.json", "one.json.d"]
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The scene file's 1 MiB bound bounds every count the TOML parser can
/// meet (at most ~500,000 of anything), so the costliest scenes of that
/// size parse within the address-space bound and refuse in a second: a
/// million-byte array of numbers, 75,000 dotted keys (the parser's worst
/// measured: 128 MB resident), 87,000 `[[objects]]`.
#[test]
fn the_costliest_megabyte_scenes_stay_within_the_memory_bound() {
    let dir = temp_dir("reliability", "megabyte");
    let n = 1024 * 1024 - 64;
    let array = format!("a = [{}]\n", "1,".repeat((n - 10) / 2));
    let dotted: String = (0..n / 14).map(|i| format!("a.b{i}.c=1\n")).collect();
    let objects = "[[objects]]\n".repeat(n / 12);
    for (name, text, needle) in [
        ("array.toml", array, "unknown key"),
        ("dotted.toml", dotted, "unknown key"),
        ("objects.toml", objects, "objects"),
    ] {
        assert!(text.len() <= 1024 * 1024, "{name}: {} bytes", text.len());
        std::fs::write(dir.join(name), text).expect("write");
        assert_refused(&["scene", "--check", name], &dir, &[name, needle]);
    }
    std::fs::remove_dir_all(&dir).ok();
}
