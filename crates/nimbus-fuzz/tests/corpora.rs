//! Replays the fuzz targets' stored inputs on stable Rust (CI has no
//! nightly): the minimised corpora (`fuzz/corpus/TARGET/`), the seeds
//! (`fuzz/seeds/TARGET/`) and the inputs of every crash once found
//! (`fuzz/regressions/TARGET/`), each through the same body the fuzzer ran.
//!
//! `NIMBUS_WRITE_FUZZ_SEEDS=1 cargo test -p nimbus-fuzz --test corpora`
//! rewrites `fuzz/seeds/` from `nimbus_fuzz::seeds`.

use nimbus_fuzz::{Target, run, seeds};
use std::path::{Path, PathBuf};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

/// The files of one folder, sorted (none when it does not exist).
fn inputs(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

/// Runs every input; the names of those whose run panicked.
fn failures(target: Target, files: &[PathBuf]) -> Vec<String> {
    files
        .iter()
        .filter_map(|file| {
            let data = std::fs::read(file).expect("read a stored input");
            std::panic::catch_unwind(|| run(target, &data))
                .is_err()
                .then(|| file.display().to_string())
        })
        .collect()
}

#[test]
fn every_stored_fuzz_input_runs_clean() {
    if std::env::var_os("NIMBUS_WRITE_FUZZ_SEEDS").is_some() {
        for target in Target::ALL {
            let dir = fuzz_dir().join("seeds").join(target.name());
            std::fs::create_dir_all(&dir).expect("seed folder");
            for (i, seed) in seeds(target).iter().enumerate() {
                std::fs::write(dir.join(format!("seed-{i}")), seed).expect("write a seed");
            }
        }
    }
    let mut replayed = 0;
    let mut failed = Vec::new();
    for target in Target::ALL {
        let mut files = Vec::new();
        for folder in ["seeds", "corpus", "regressions"] {
            files.extend(inputs(&fuzz_dir().join(folder).join(target.name())));
        }
        // Every target has its seeds stored, so the replay can never be empty.
        assert!(!files.is_empty(), "no stored inputs for {}", target.name());
        replayed += files.len();
        failed.extend(failures(target, &files));
    }
    assert!(
        failed.is_empty(),
        "inputs that break a reader's promise: {failed:?}"
    );
    eprintln!("replayed {replayed} stored fuzz inputs");
}

/// The seeds are valid documents: each reaches its reader's success path
/// (a seed the reader refused would start the fuzzer from an error).
#[test]
fn seeds_are_accepted_by_their_readers() {
    use nimbus_render::scene::Scene;
    for seed in seeds(Target::SceneToml) {
        let text = std::str::from_utf8(&seed).expect("UTF-8");
        Scene::from_toml_str(text, "seed.toml").expect("the scene seed is valid");
    }
    for seed in seeds(Target::Gltf) {
        let mesh = nimbus_render::scene::gltf::gltf_from_bytes(
            &seed,
            Path::new("seed.glb"),
            nimbus_render::scene::MAX_OBJECT_TRIANGLES,
        )
        .expect("the glTF seed is valid");
        assert_eq!(mesh.triangle_count(), 1);
    }
    for seed in seeds(Target::Npy) {
        nimbus_physics::rain::wind::WindGrid::from_npy(&seed, 10.0, glam::Vec3::ZERO, false)
            .expect("the .npy seed is valid");
    }
    for seed in seeds(Target::RootsJson) {
        let text = std::str::from_utf8(&seed).expect("UTF-8");
        nimbus_physics::cumulus::hierarchy::roots_from_json(text).expect("the roots seed");
    }
    for seed in seeds(Target::OpticsCache) {
        nimbus_physics::optics::tables::CloudOpticsTables::from_cache_bytes(
            &seed,
            &nimbus_fuzz::fuzz_optics_params(),
        )
        .expect("the optics cache seed is valid");
    }
    for seed in seeds(Target::CumulusCache) {
        assert!(nimbus_render::passes::cumulus::variants::from_bytes(&seed).is_some());
    }
    for seed in seeds(Target::FitTable) {
        let text = std::str::from_utf8(&seed).expect("UTF-8");
        nimbus_physics::transport::stratus::OneDimensionalTable::from_toml(text, "seed.toml")
            .expect("the fit table seed is valid");
    }
}

/// The structure-aware generator reaches the scene's keys: most of what it
/// builds parses as TOML and many of its scenes are valid.
#[test]
fn structured_scenes_use_the_schema_keys() {
    let (mut valid, mut built) = (0, 0);
    for i in 0..400u32 {
        let bytes: Vec<u8> = (0..512u32)
            .map(|j| (j.wrapping_mul(2_654_435_761).wrapping_add(i * 97) >> 13) as u8)
            .collect();
        let Ok(text) = nimbus_fuzz::structured_scene(&mut arbitrary::Unstructured::new(&bytes))
        else {
            continue;
        };
        built += 1;
        if nimbus_render::scene::Scene::from_toml_str(&text, "s.toml").is_ok() {
            valid += 1;
        }
    }
    assert!(built > 300, "{built} of 400 built");
    assert!(valid > 0, "no valid scene among {built}");
}

/// A broken promise is a finding: the check itself fails on a reader that
/// would give a two-line error.
#[test]
#[should_panic(expected = "an error of several lines")]
fn a_multi_line_error_is_a_finding() {
    nimbus_fuzz::check_error_line::<(), _>(Err("first\nsecond"));
}
