//! The bodies of nimbus's fuzz targets.
//!
//! `fuzz/` (a cargo-fuzz crate, built with nightly by `cargo fuzz`) calls
//! [`run`] from one `fuzz_target!` per [`Target`]; the stable test
//! `tests/corpora.rs` replays every stored input (`fuzz/corpus/TARGET/`,
//! the minimised corpora, and `fuzz/regressions/TARGET/`, the inputs of
//! crashes once found) through the same function, so CI checks them without
//! nightly. docs/RELIABILITY.md records the runs.
//!
//! Each body feeds bytes to one of the readers of files that users (or other
//! programs) write, and checks what a reader promises beyond "no panic":
//! an error is one line, bounded in length; what is accepted is whole (indices
//! in range, values finite, counts within their limits, caches that
//! round-trip to the same bytes).

use arbitrary::Unstructured;
use std::path::Path;
use std::sync::OnceLock;

/// Longest error line a reader may give, bytes: values in messages are
/// shortened to 64 characters, so a longer line means a value echoed whole.
pub const MAX_ERROR_LINE_BYTES: usize = 1024;

/// A directory that does not exist: files named relative to a fuzzed
/// document (glTF buffers) resolve into it and are not found.
const MISSING_DIR: &str = "/nonexistent-nimbus-fuzz";

/// The fuzz targets, one per reader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// A scene file's text, parsed and validated (`Scene::from_toml_str`).
    SceneToml,
    /// A scene built key by key from the scene schema's keys (structure-aware:
    /// the bytes choose keys, values and lengths), then parsed and validated.
    SceneStructured,
    /// A `.gltf` or `.glb` object mesh (`scene::gltf::gltf_from_bytes`).
    Gltf,
    /// A `.npy` wind field (`WindGrid::from_npy`).
    Npy,
    /// A `cumulus --roots` file or hierarchy JSON (`roots_from_json`).
    RootsJson,
    /// The cloud-optics table cache (`CloudOpticsTables::from_cache_bytes`).
    OpticsCache,
    /// The cumulus shape cache (`passes::cumulus::variants::from_bytes`).
    CumulusCache,
    /// The stratus 1-D model's fitted table (`OneDimensionalTable::from_toml`).
    FitTable,
}

impl Target {
    /// Every target.
    pub const ALL: [Target; 8] = [
        Target::SceneToml,
        Target::SceneStructured,
        Target::Gltf,
        Target::Npy,
        Target::RootsJson,
        Target::OpticsCache,
        Target::CumulusCache,
        Target::FitTable,
    ];

    /// The target's name: its `fuzz/fuzz_targets/NAME.rs` and corpus folders.
    pub fn name(self) -> &'static str {
        match self {
            Target::SceneToml => "scene_toml",
            Target::SceneStructured => "scene_structured",
            Target::Gltf => "gltf",
            Target::Npy => "npy",
            Target::RootsJson => "roots_json",
            Target::OpticsCache => "optics_cache",
            Target::CumulusCache => "cumulus_cache",
            Target::FitTable => "fit_table",
        }
    }
}

/// Runs one input through a target's reader; panics (the fuzzer's finding)
/// when the reader breaks a promise.
pub fn run(target: Target, data: &[u8]) {
    match target {
        Target::SceneToml => {
            if let Ok(text) = std::str::from_utf8(data) {
                scene_text(text);
            }
        }
        Target::SceneStructured => {
            if let Ok(text) = structured_scene(&mut Unstructured::new(data)) {
                scene_text(&text);
            }
        }
        Target::Gltf => gltf(data),
        Target::Npy => npy(data),
        Target::RootsJson => {
            if let Ok(text) = std::str::from_utf8(data) {
                roots_json(text);
            }
        }
        Target::OpticsCache => optics_cache(data),
        Target::CumulusCache => cumulus_cache(data),
        Target::FitTable => {
            if let Ok(text) = std::str::from_utf8(data) {
                check_error_line(
                    nimbus_physics::transport::stratus::OneDimensionalTable::from_toml(
                        text,
                        "fuzz.toml",
                    )
                    .map(|_| ()),
                );
            }
        }
    }
}

/// Checks a reader's error: one line of at most [`MAX_ERROR_LINE_BYTES`]
/// (panics otherwise); the accepted value when there is no error.
pub fn check_error_line<T, E: std::fmt::Display>(result: Result<T, E>) -> Option<T> {
    match result {
        Ok(value) => Some(value),
        Err(error) => {
            let line = error.to_string();
            assert!(!line.contains('\n'), "an error of several lines: {line:?}");
            assert!(
                line.len() <= MAX_ERROR_LINE_BYTES,
                "an error line of {} bytes: {:?}…",
                line.len(),
                line.chars().take(200).collect::<String>()
            );
            None
        }
    }
}

fn scene_text(text: &str) {
    let Some(scene) = check_error_line(nimbus_render::scene::Scene::from_toml_str(
        text,
        "fuzz.toml",
    )) else {
        return;
    };
    // What is accepted stays within the documented counts.
    assert!(scene.objects.len() <= nimbus_render::scene::MAX_OBJECTS);
    let fov = scene.camera.fov_deg;
    assert!(
        (nimbus_render::scene::MIN_FOV_DEG..=179.0).contains(&fov),
        "fov_deg {fov} accepted"
    );
}

fn gltf(data: &[u8]) {
    let path = Path::new(MISSING_DIR).join("mesh.glb");
    let Some(mesh) = check_error_line(nimbus_render::scene::gltf::gltf_from_bytes(
        data,
        &path,
        nimbus_render::scene::MAX_OBJECT_TRIANGLES,
    )) else {
        return;
    };
    let vertices = mesh.positions.len();
    assert_eq!(mesh.normals.len(), vertices);
    assert_eq!(mesh.base_colour.len(), vertices);
    assert_eq!(mesh.indices.len() % 3, 0);
    assert!(mesh.indices.iter().all(|&i| (i as usize) < vertices));
    assert!(mesh.triangle_count() <= nimbus_render::scene::MAX_OBJECT_TRIANGLES);
}

fn npy(data: &[u8]) {
    use glam::Vec3;
    let Some(grid) = check_error_line(nimbus_physics::rain::wind::WindGrid::from_npy(
        data,
        10.0,
        Vec3::ZERO,
        false,
    )) else {
        return;
    };
    let points: u64 = grid.cells.iter().map(|&n| u64::from(n)).product();
    assert!(points <= nimbus_physics::rain::wind::MAX_WIND_GRID_POINTS);
    assert_eq!(grid.velocities_m_s.len() as u64, points);
    for p in [Vec3::ZERO, Vec3::new(13.7, -4.2, 1e4), Vec3::splat(-1e6)] {
        let v = grid.sample(p);
        assert!(
            v.is_finite() && v.length() <= 300.0 * 3f32.sqrt() * 1.0001,
            "{v}"
        );
    }
}

fn roots_json(text: &str) {
    use nimbus_physics::cumulus::hierarchy::{MAX_ROOT_BLOBS, roots_from_json};
    if let Some(roots) = check_error_line(roots_from_json(text)) {
        assert!(roots.len() <= MAX_ROOT_BLOBS);
    }
}

/// Small tables: the reader's checks are the same whatever the sizes.
pub fn fuzz_optics_params() -> nimbus_physics::optics::tables::CloudOpticsParams {
    nimbus_physics::optics::tables::CloudOpticsParams {
        texels: 4,
        peak_texels: 2,
        ..nimbus_physics::optics::tables::CloudOpticsParams::bouthors_2006()
    }
}

fn optics_cache(data: &[u8]) {
    use nimbus_physics::optics::tables::CloudOpticsTables;
    let params = fuzz_optics_params();
    // The parameters' hash is written in: the fuzzer would not find it.
    let mut bytes = data.to_vec();
    if let Some(hash) = bytes.get_mut(8..16) {
        hash.copy_from_slice(&params.cache_hash().to_le_bytes());
    }
    if let Ok(tables) = CloudOpticsTables::from_cache_bytes(&bytes, &params) {
        assert_eq!(
            tables.to_cache_bytes(),
            bytes,
            "the cache does not round-trip"
        );
    }
}

fn cumulus_cache(data: &[u8]) {
    use nimbus_render::passes::cumulus::variants::{from_bytes, to_bytes};
    if let Some(variant) = from_bytes(data) {
        assert_eq!(to_bytes(&variant), data, "the cache does not round-trip");
    }
}

/// One key of the scene format, from its JSON Schema.
#[derive(Clone, Debug)]
struct SchemaKey {
    /// Table names down to the key; `None` is a list of tables (`[[objects]]`).
    path: Vec<Option<String>>,
    /// The key's name.
    key: String,
    /// What it holds.
    kind: KeyKind,
}

#[derive(Clone, Debug)]
enum KeyKind {
    Number,
    Integer,
    Boolean,
    /// A string, with its allowed values when the schema lists them.
    String(Vec<String>),
    /// A list of values of the inner kind.
    List(Box<KeyKind>),
}

/// Every key of the scene schema (`scene::json_schema`), collected once.
fn schema_keys() -> &'static [SchemaKey] {
    static KEYS: OnceLock<Vec<SchemaKey>> = OnceLock::new();
    KEYS.get_or_init(|| {
        let schema = nimbus_render::scene::json_schema();
        let mut keys = Vec::new();
        collect_keys(&schema, &schema, &mut Vec::new(), &mut keys, 0);
        keys
    })
}

/// The schema node a `$ref`, a one-element `allOf` or an `anyOf` stands for.
fn resolved<'a>(
    root: &'a serde_json::Value,
    node: &'a serde_json::Value,
) -> Vec<&'a serde_json::Value> {
    if let Some(reference) = node.get("$ref").and_then(|r| r.as_str()) {
        let name = reference.trim_start_matches("#/definitions/");
        return root
            .get("definitions")
            .and_then(|d| d.get(name))
            .map(|n| resolved(root, n))
            .unwrap_or_default();
    }
    for combinator in ["allOf", "anyOf", "oneOf"] {
        if let Some(list) = node.get(combinator).and_then(|l| l.as_array()) {
            return list.iter().flat_map(|n| resolved(root, n)).collect();
        }
    }
    vec![node]
}

fn kind_of(root: &serde_json::Value, node: &serde_json::Value) -> Option<KeyKind> {
    let node = *resolved(root, node).first()?;
    if let Some(values) = node.get("enum").and_then(|e| e.as_array()) {
        return Some(KeyKind::String(
            values
                .iter()
                .filter_map(|v| v.as_str().map(str::to_owned))
                .collect(),
        ));
    }
    match node.get("type").and_then(|t| t.as_str())? {
        "number" => Some(KeyKind::Number),
        "integer" => Some(KeyKind::Integer),
        "boolean" => Some(KeyKind::Boolean),
        "string" => Some(KeyKind::String(Vec::new())),
        "array" => Some(KeyKind::List(Box::new(kind_of(root, node.get("items")?)?))),
        _ => None,
    }
}

fn collect_keys(
    root: &serde_json::Value,
    node: &serde_json::Value,
    path: &mut Vec<Option<String>>,
    keys: &mut Vec<SchemaKey>,
    depth: usize,
) {
    if depth > 6 {
        return;
    }
    for node in resolved(root, node) {
        let Some(properties) = node.get("properties").and_then(|p| p.as_object()) else {
            continue;
        };
        for (name, property) in properties {
            let target = *resolved(root, property).first().unwrap_or(&property);
            let is_table = target.get("properties").is_some();
            let items = target.get("items").map(|i| resolved(root, i));
            let is_list_of_tables = items
                .as_ref()
                .and_then(|i| i.first())
                .is_some_and(|i| i.get("properties").is_some());
            if is_table {
                path.push(Some(name.clone()));
                collect_keys(root, property, path, keys, depth + 1);
                path.pop();
            } else if is_list_of_tables {
                path.push(Some(name.clone()));
                path.push(None);
                if let Some(items) = target.get("items") {
                    collect_keys(root, items, path, keys, depth + 1);
                }
                path.pop();
                path.pop();
            } else if let Some(kind) = kind_of(root, property) {
                keys.push(SchemaKey {
                    path: path.clone(),
                    key: name.clone(),
                    kind,
                });
            }
        }
    }
}

/// Numbers at the edges of what the validator must handle.
const EDGE_NUMBERS: [f64; 18] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    2.0,
    179.0,
    360.0,
    1e7,
    1e-300,
    -1e-300,
    1e300,
    f64::MAX,
    f64::MIN,
    f64::MIN_POSITIVE,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
];

/// Strings that name files or that must be escaped in error lines.
const EDGE_STRINGS: [&str; 8] = [
    "",
    "mesh.glb",
    "wind.npy",
    "/dev/zero",
    "/",
    "\u{202e}evil\u{7}",
    "a\nb",
    "2024-06-21T12:00:00Z",
];

fn value_of(
    u: &mut Unstructured<'_>,
    kind: &KeyKind,
    depth: usize,
) -> arbitrary::Result<toml::Value> {
    use toml::Value;
    // Now and then a value of the wrong type.
    if u.ratio(1, 16)? {
        return Ok(match u.int_in_range(0..=3)? {
            0 => Value::String(u.arbitrary()?),
            1 => Value::Boolean(u.arbitrary()?),
            2 => Value::Integer(u.arbitrary()?),
            _ => Value::Table(toml::Table::new()),
        });
    }
    Ok(match kind {
        KeyKind::Number => Value::Float(if u.ratio(1, 2)? {
            *u.choose(&EDGE_NUMBERS)?
        } else if u.ratio(1, 2)? {
            f64::from(u.int_in_range(-2000..=20000)?) / 4.0
        } else {
            u.arbitrary()?
        }),
        KeyKind::Integer => Value::Integer(if u.ratio(2, 3)? {
            *u.choose(&[
                0,
                1,
                -1,
                2,
                3,
                7,
                64,
                1024,
                1025,
                4096,
                i64::from(u32::MAX),
                i64::MAX,
                i64::MIN,
            ])?
        } else {
            u.arbitrary()?
        }),
        KeyKind::Boolean => Value::Boolean(u.arbitrary()?),
        KeyKind::String(allowed) => Value::String(if !allowed.is_empty() && u.ratio(3, 4)? {
            u.choose(allowed)?.clone()
        } else if u.ratio(1, 2)? {
            (*u.choose(&EDGE_STRINGS)?).to_owned()
        } else {
            u.arbitrary()?
        }),
        KeyKind::List(inner) => {
            let length = if u.ratio(3, 4)? {
                u.int_in_range(0..=5)?
            } else {
                u.int_in_range(0..=40)?
            };
            let mut list = Vec::with_capacity(length);
            for _ in 0..length {
                if depth > 3 {
                    break;
                }
                list.push(value_of(u, inner, depth + 1)?);
            }
            Value::Array(list)
        }
    })
}

/// A scene's text built from the schema's keys: the bytes choose how many
/// keys, which, their values (edge values most of the time), and which
/// element of a list of tables each goes into.
pub fn structured_scene(u: &mut Unstructured<'_>) -> arbitrary::Result<String> {
    let keys = schema_keys();
    let mut scene = toml::Table::new();
    let count = u.int_in_range(0..=32)?;
    for _ in 0..count {
        let key = u.choose(keys)?;
        let value = value_of(u, &key.kind, 0)?;
        if let Some(table) = table_at(&mut scene, &key.path, u)? {
            table.insert(key.key.clone(), value);
        }
    }
    toml::to_string(&scene).map_err(|_| arbitrary::Error::IncorrectFormat)
}

/// The table a key of `path` goes into, made where missing; in a list of
/// tables the bytes choose the element (or a new one). `None` where a value
/// of another type already holds the name.
fn table_at<'a>(
    table: &'a mut toml::Table,
    path: &[Option<String>],
    u: &mut Unstructured<'_>,
) -> arbitrary::Result<Option<&'a mut toml::Table>> {
    let Some((Some(name), rest)) = path.split_first() else {
        return Ok(Some(table));
    };
    let entry = table.entry(name.clone());
    if let Some((None, rest)) = rest.split_first() {
        let toml::Value::Array(list) = entry.or_insert_with(|| toml::Value::Array(Vec::new()))
        else {
            return Ok(None);
        };
        let index = u.int_in_range(0..=list.len().min(3))?;
        if index == list.len() {
            list.push(toml::Value::Table(toml::Table::new()));
        }
        let Some(toml::Value::Table(element)) = list.get_mut(index) else {
            return Ok(None);
        };
        return table_at(element, rest, u);
    }
    let toml::Value::Table(inner) = entry.or_insert_with(|| toml::Value::Table(toml::Table::new()))
    else {
        return Ok(None);
    };
    table_at(inner, rest, u)
}

/// Seed inputs of a target: valid documents of each format (the example
/// scenes, small meshes, grids, roots and caches), from which the fuzzer
/// starts mutating.
pub fn seeds(target: Target) -> Vec<Vec<u8>> {
    match target {
        Target::SceneToml => vec![
            nimbus_render::scene::DEFAULT_SCENE_TOML.as_bytes().to_vec(),
            b"[camera]\nfov_deg = 30.0\nposition_m = [0.0, 500.0, 0.0]\n".to_vec(),
            b"[[objects]]\nkind = \"box\"\ncenter_m = [0.0, 1.0, 0.0]\nsize_m = [2.0, 2.0, 2.0]\n"
                .to_vec(),
        ],
        // Any bytes make a scene; a few lengths give the fuzzer a start.
        Target::SceneStructured => vec![vec![0; 8], vec![0x5a; 256], (0..=255).collect()],
        Target::Gltf => vec![seed_glb()],
        Target::Npy => {
            vec![nimbus_physics::rain::wind::WindGrid::turbulence(2, 20.0, 1.0, 7).to_npy()]
        }
        Target::RootsJson => vec![
            br#"[{"centre_m": [0, 0, 0], "radius_m": 300, "flattening": 0.3}]"#.to_vec(),
            br#"{"roots": [{"centre_m": [1, 2, 3], "radius_m": 50}], "levels": [1, 2]}"#.to_vec(),
        ],
        Target::OpticsCache => {
            let params = fuzz_optics_params();
            let mut bytes = b"NIMBUSCO".to_vec();
            bytes.extend_from_slice(&params.cache_hash().to_le_bytes());
            for count in [
                3,
                3,
                3,
                3 * params.texels,
                3 * params.peak_texels,
                3 * params.texels,
            ] {
                bytes.extend_from_slice(&(count as u64).to_le_bytes());
                for i in 0..count {
                    bytes.extend_from_slice(&(i as f32 * 0.25).to_le_bytes());
                }
            }
            vec![bytes]
        }
        Target::CumulusCache => {
            use nimbus_render::passes::cumulus::variants::{
                CumulusVariant, CumulusVertex, VariantLod, to_bytes,
            };
            let vertex = |x: f32| CumulusVertex {
                position_radius: [x, 0.0, 0.0, 100.0],
                ..CumulusVertex::default()
            };
            vec![to_bytes(&CumulusVariant {
                lods: vec![VariantLod {
                    cell_m: 10.0,
                    vertices: vec![vertex(0.0), vertex(1.0), vertex(2.0)],
                    indices: vec![0, 1, 2],
                }],
                base_radii_m: [100.0, 30.0, 0.0],
                last_radius_m: 10.0,
                bounds_centre_m: [0.0; 3],
                bounds_radius_m: 500.0,
                footprint_radius_m: 400.0,
                origin_m: [0.0; 3],
            })]
        }
        Target::FitTable => vec![
            nimbus_physics::transport::stratus::OneDimensionalTable::bouthors_2006()
                .to_toml(&[])
                .into_bytes(),
        ],
    }
}

/// A one-triangle `.glb` written by nimbus's own glTF builder.
fn seed_glb() -> Vec<u8> {
    use nimbus_physics::glb::{GlbBuilder, MeshData, NodeTransform};
    let mut builder = GlbBuilder::new();
    let Ok(mesh) = builder.add_mesh(&MeshData {
        name: "seed".to_owned(),
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].into(),
        normals: Some(vec![[0.0, 0.0, 1.0]; 3].into()),
        indices: vec![0, 1, 2].into(),
        ..MeshData::default()
    }) else {
        return Vec::new();
    };
    let node = builder.add_node("seed", Some(mesh), NodeTransform::default(), &[]);
    if builder.add_scene("seed", &[node]).is_err() {
        return Vec::new();
    }
    builder.finish().unwrap_or_default()
}
