//! Static scene objects (`[[objects]]`): boxes and glTF meshes standing in
//! the scene, drawn lit like the terrain by the objects pass and used as
//! occluders (e.g. of rain).
//!
//! One TOML table per object, its shape chosen by `kind`:
//!
//! ```toml
//! [[objects]]
//! kind = "box"
//! center_m = [0.0, 1.5, 0.0]
//! size_m = [6.0, 0.2, 4.0]
//! yaw_deg = 30.0
//! albedo = [0.4, 0.3, 0.2]
//!
//! [[objects]]
//! kind = "mesh"
//! gltf = "assets/shed.gltf"
//! position_m = [10.0, 0.0, -4.0]
//! scale = 1.0
//! ```
//!
//! The keys of both kinds live in one flat struct rather than a serde enum
//! tagged by `kind`: an internally tagged enum is deserialised through a
//! buffer that loses the key paths and line numbers of errors, and every
//! scene error names its key and line. [`SceneObject::shape`] gives the typed
//! view once the scene is validated.

use super::Scene;
use super::SceneError;
use super::validate::{Checker, MAX_COORDINATE_M};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Most objects a scene may hold.
pub const MAX_OBJECTS: usize = 1024;

/// Most triangles all objects together may have (boxes count 12 each): the
/// baked vertex buffer then stays below about 220 MB even when every
/// triangle has vertices of its own, within every device's default 256 MiB
/// buffer limit.
pub const MAX_OBJECT_TRIANGLES: u64 = 2_000_000;

/// Triangles of one box (two per face).
pub const BOX_TRIANGLES: u64 = 12;

/// Albedo of an object that gives none.
pub const DEFAULT_OBJECT_ALBEDO: [f64; 3] = [0.5, 0.5, 0.5];

/// The shape of an object (`kind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum ObjectKind {
    /// A rectangular box (`center_m`, `size_m`).
    Box,
    /// A triangle mesh read from a glTF 2.0 file (`gltf`, `position_m`, `scale`).
    Mesh,
}

/// One static object (`[[objects]]`). Which keys apply depends on `kind`;
/// validation rejects a key of the other kind and a missing one of its own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct SceneObject {
    /// `"box"` or `"mesh"`.
    pub kind: ObjectKind,
    /// Box: centre, world m (x east, y up, z south).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub center_m: Option<[f64; 3]>,
    /// Box: side lengths along the box's own x, y, z before the yaw, m, each in (0, 10000].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size_m: Option<[f64; 3]>,
    /// Mesh: path of a `.gltf` or `.glb` file, relative to the scene file's
    /// directory (to the current directory for scenes parsed from text).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf: Option<String>,
    /// Mesh: world position of the mesh's origin, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_m: Option<[f64; 3]>,
    /// Mesh: uniform scale of the mesh (glTF units are metres), in [0.001, 1000]; 1 when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// Rotation about +Y, degrees, in [−360, 360]; right-handed: positive
    /// turns +X (east) towards −Z (north), anticlockwise seen from above.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Linear Rec.709 albedo, each channel in [0, 1]. Meshes use it where a
    /// primitive has no material or a textured base colour (textures are
    /// not read).
    #[serde(default = "default_albedo")]
    pub albedo: [f64; 3],
}

fn default_albedo() -> [f64; 3] {
    DEFAULT_OBJECT_ALBEDO
}

/// The typed view of a validated [`SceneObject`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ObjectShape<'a> {
    /// A box.
    Box {
        /// Centre, world m.
        center_m: [f64; 3],
        /// Side lengths, m.
        size_m: [f64; 3],
    },
    /// A glTF mesh.
    Mesh {
        /// The path as written in the scene (see [`Scene::resolve_path`]).
        gltf: &'a str,
        /// World position of the mesh's origin, m.
        position_m: [f64; 3],
        /// Uniform scale.
        scale: f64,
    },
}

impl SceneObject {
    /// A box object.
    pub fn new_box(center_m: [f64; 3], size_m: [f64; 3], yaw_deg: f64, albedo: [f64; 3]) -> Self {
        Self {
            kind: ObjectKind::Box,
            center_m: Some(center_m),
            size_m: Some(size_m),
            gltf: None,
            position_m: None,
            scale: None,
            yaw_deg,
            albedo,
        }
    }

    /// A mesh object of scale 1 and the default albedo.
    pub fn new_mesh(gltf: impl Into<String>, position_m: [f64; 3], yaw_deg: f64) -> Self {
        Self {
            kind: ObjectKind::Mesh,
            center_m: None,
            size_m: None,
            gltf: Some(gltf.into()),
            position_m: Some(position_m),
            scale: None,
            yaw_deg,
            albedo: DEFAULT_OBJECT_ALBEDO,
        }
    }

    /// The object's shape, or `None` when a key its kind needs is missing
    /// (never for an object of a validated scene).
    pub fn shape(&self) -> Option<ObjectShape<'_>> {
        match self.kind {
            ObjectKind::Box => Some(ObjectShape::Box {
                center_m: self.center_m?,
                size_m: self.size_m?,
            }),
            ObjectKind::Mesh => Some(ObjectShape::Mesh {
                gltf: self.gltf.as_deref()?,
                position_m: self.position_m?,
                scale: self.scale.unwrap_or(1.0),
            }),
        }
    }
}

impl Scene {
    /// Where a path written in the scene refers to: as is when absolute,
    /// else relative to [`Scene::base_dir`] (the current directory when none).
    pub fn resolve_path(&self, path: &str) -> PathBuf {
        let path = std::path::Path::new(path);
        match &self.base_dir {
            Some(dir) if path.is_relative() => dir.join(path),
            _ => path.to_path_buf(),
        }
    }

    /// Checks `[[objects]]`: ranges, the keys of each kind, the count and
    /// triangle limits, and that every glTF file reads (so that a bad file
    /// fails the scene's loading, not the render).
    pub(super) fn validate_objects(&self, c: &Checker<'_>) -> Result<(), SceneError> {
        c.integer("objects", self.objects.len() as u64, 0, MAX_OBJECTS as u64)?;
        let mut triangles = 0u64;
        for (i, object) in self.objects.iter().enumerate() {
            let key = |name: &str| format!("objects[{i}].{name}");
            let (own, other): (&[&str], &[&str]) = match object.kind {
                ObjectKind::Box => (&["center_m", "size_m"], &["gltf", "position_m", "scale"]),
                ObjectKind::Mesh => (&["gltf", "position_m"], &["center_m", "size_m"]),
            };
            let kind = match object.kind {
                ObjectKind::Box => "box",
                ObjectKind::Mesh => "mesh",
            };
            for name in other {
                if let Some(value) = object.key_value(name) {
                    return Err(c.invalid(
                        &key(name),
                        value,
                        format!(
                            "is not a key of kind = \"{kind}\" (its keys: {}, yaw_deg, albedo{})",
                            own.join(", "),
                            if kind == "mesh" { ", scale" } else { "" }
                        ),
                    ));
                }
            }
            for name in own {
                if object.key_value(name).is_none() {
                    return Err(c.invalid(
                        &key(name),
                        "(missing)",
                        format!("must be given for kind = \"{kind}\""),
                    ));
                }
            }
            c.closed(&key("yaw_deg"), object.yaw_deg, -360.0, 360.0)?;
            c.vector(&key("albedo"), &object.albedo, 0.0, 1.0)?;
            match object.shape() {
                Some(ObjectShape::Box { center_m, size_m }) => {
                    c.vector(
                        &key("center_m"),
                        &center_m,
                        -MAX_COORDINATE_M,
                        MAX_COORDINATE_M,
                    )?;
                    if !size_m
                        .iter()
                        .all(|s| s.is_finite() && *s > 0.0 && *s <= 10_000.0)
                    {
                        return Err(c.invalid(
                            &key("size_m"),
                            format!("{size_m:?}"),
                            "each side must be a finite number in (0, 10000]",
                        ));
                    }
                    triangles += BOX_TRIANGLES;
                }
                Some(ObjectShape::Mesh {
                    gltf,
                    position_m,
                    scale,
                }) => {
                    c.vector(
                        &key("position_m"),
                        &position_m,
                        -MAX_COORDINATE_M,
                        MAX_COORDINATE_M,
                    )?;
                    c.closed(&key("scale"), scale, 0.001, 1_000.0)?;
                    let lower = gltf.to_ascii_lowercase();
                    if !(lower.ends_with(".gltf") || lower.ends_with(".glb")) {
                        return Err(c.invalid(
                            &key("gltf"),
                            format!("{gltf:?}"),
                            "must be the path of a .gltf or .glb file",
                        ));
                    }
                    if !c.read_files {
                        continue;
                    }
                    let budget = MAX_OBJECT_TRIANGLES.saturating_sub(triangles);
                    let mesh =
                        super::gltf::load_gltf(&self.resolve_path(gltf), budget).map_err(|e| {
                            c.invalid(
                                &key("gltf"),
                                format!("{gltf:?}"),
                                format!("must be a readable glTF 2.0 file: {e}"),
                            )
                        })?;
                    triangles += mesh.triangle_count();
                }
                // Unreachable: the keys were checked above.
                None => return Err(c.invalid(&key("kind"), kind, "is missing keys")),
            }
        }
        if triangles > MAX_OBJECT_TRIANGLES {
            return Err(c.invalid(
                "objects",
                format!("{triangles} triangles"),
                format!("all objects together may have at most {MAX_OBJECT_TRIANGLES} triangles"),
            ));
        }
        Ok(())
    }
}

impl SceneObject {
    /// The value of an optional key, for messages; `None` when absent.
    fn key_value(&self, name: &str) -> Option<String> {
        match name {
            "center_m" => self.center_m.map(|v| format!("{v:?}")),
            "size_m" => self.size_m.map(|v| format!("{v:?}")),
            "gltf" => self.gltf.as_ref().map(|v| format!("{v:?}")),
            "position_m" => self.position_m.map(|v| format!("{v:?}")),
            "scale" => self.scale.map(|v| v.to_string()),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn scenes_dir() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
    }

    /// The one-line error of a scene with these `[[objects]]`, parsed as if
    /// from `scenes/scene.toml`.
    fn error_of(objects: &str) -> String {
        let err = Scene::from_toml_str_in(objects, "scene.toml", Some(&scenes_dir()))
            .expect_err("scene should be rejected");
        let message = err.to_string();
        assert!(!message.contains('\n'), "error spans lines: {message}");
        assert!(message.starts_with("scene.toml: "), "{message}");
        message
    }

    const BOX: &str =
        "[[objects]]\nkind = \"box\"\ncenter_m = [0.0, 1.0, 0.0]\nsize_m = [1.0, 2.0, 3.0]\n";
    const MESH: &str =
        "[[objects]]\nkind = \"mesh\"\ngltf = \"assets/shed.gltf\"\nposition_m = [5.0, 0.0, 0.0]\n";

    #[test]
    fn the_shed_scene_loads_with_paths_relative_to_its_file() {
        let scene = Scene::from_file(&scenes_dir().join("objects-shed.toml"))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(scene.objects.len() >= 6);
        let mesh = scene
            .objects
            .iter()
            .find(|o| o.kind == ObjectKind::Mesh)
            .expect("a mesh");
        let Some(ObjectShape::Mesh { gltf, .. }) = mesh.shape() else {
            panic!("not a mesh")
        };
        assert_eq!(
            scene.resolve_path(gltf),
            scenes_dir().join("assets/shed.gltf")
        );
        // The base directory is not a key: it does not appear when written out.
        let text = toml::to_string(&scene).expect("serialise");
        assert!(
            text.contains("[[objects]]") && !text.contains("base_dir"),
            "{text}"
        );
    }

    #[test]
    fn good_objects_parse_with_their_defaults() {
        let scene = Scene::from_toml_str_in(&format!("{BOX}{MESH}"), "s.toml", Some(&scenes_dir()))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            scene.objects[0],
            SceneObject::new_box([0.0, 1.0, 0.0], [1.0, 2.0, 3.0], 0.0, DEFAULT_OBJECT_ALBEDO)
        );
        assert_eq!(
            scene.objects[1],
            SceneObject::new_mesh("assets/shed.gltf", [5.0, 0.0, 0.0], 0.0)
        );
        assert_eq!(
            scene.objects[1].shape(),
            Some(ObjectShape::Mesh {
                gltf: "assets/shed.gltf",
                position_m: [5.0, 0.0, 0.0],
                scale: 1.0
            })
        );
    }

    #[test]
    fn each_bad_object_key_is_reported_with_its_value_and_what_is_allowed() {
        let cases = [
            (
                BOX.replace("[1.0, 2.0, 3.0]", "[1.0, 0.0, 3.0]"),
                "scene.toml: objects[0].size_m = [1.0, 0.0, 3.0]: each side must be a finite number in (0, 10000]",
            ),
            (
                BOX.replace("[0.0, 1.0, 0.0]", "[0.0, nan, 0.0]"),
                "scene.toml: objects[0].center_m = [0.0, NaN, 0.0]: each component must be a finite number in [-1000000, 1000000]",
            ),
            (
                format!("{BOX}yaw_deg = 400.0\n"),
                "scene.toml: objects[0].yaw_deg = 400: must be a finite number in [-360, 360]",
            ),
            (
                format!("{BOX}albedo = [0.5, 1.5, 0.5]\n"),
                "scene.toml: objects[0].albedo = [0.5, 1.5, 0.5]: each component must be a finite number in [0, 1]",
            ),
            (
                BOX.replace("size_m = [1.0, 2.0, 3.0]\n", ""),
                "scene.toml: objects[0].size_m = (missing): must be given for kind = \"box\"",
            ),
            (
                format!("{BOX}gltf = \"assets/shed.gltf\"\n"),
                "scene.toml: objects[0].gltf = \"assets/shed.gltf\": is not a key of kind = \"box\" (its keys: center_m, size_m, yaw_deg, albedo)",
            ),
            (
                format!("{MESH}center_m = [0.0, 0.0, 0.0]\n"),
                "scene.toml: objects[0].center_m = [0.0, 0.0, 0.0]: is not a key of kind = \"mesh\" (its keys: gltf, position_m, yaw_deg, albedo, scale)",
            ),
            (
                MESH.replace("position_m = [5.0, 0.0, 0.0]\n", ""),
                "scene.toml: objects[0].position_m = (missing): must be given for kind = \"mesh\"",
            ),
            (
                format!("{MESH}scale = 0.0\n"),
                "scene.toml: objects[0].scale = 0: must be a finite number in [0.001, 1000]",
            ),
            (
                MESH.replace("assets/shed.gltf", "assets/shed.obj"),
                "scene.toml: objects[0].gltf = \"assets/shed.obj\": must be the path of a .gltf or .glb file",
            ),
        ];
        for (text, expected) in cases {
            assert_eq!(error_of(&text), expected, "{text}");
        }
        // Keys and kinds unknown to serde name the key, the allowed ones and the line.
        let m = error_of(&format!("{BOX}colour = [1.0, 0.0, 0.0]\n"));
        assert!(
            m.contains("objects[0].colour")
                && m.contains("unknown key")
                && m.contains("albedo")
                && m.contains("(line 5)"),
            "{m}"
        );
        let m = error_of(&BOX.replace("\"box\"", "\"sphere\""));
        assert!(
            m.contains("objects[0].kind") && m.contains("box") && m.contains("mesh"),
            "{m}"
        );
        // The second object is named by its index.
        let m = error_of(&format!(
            "{BOX}{}",
            BOX.replace("[1.0, 2.0, 3.0]", "[1.0, 2.0, -3.0]")
        ));
        assert!(m.starts_with("scene.toml: objects[1].size_m = "), "{m}");
    }

    #[test]
    fn a_missing_gltf_file_names_the_scene_file_the_key_the_path_and_the_reason() {
        let m = error_of(&format!(
            "{BOX}{}",
            MESH.replace("shed.gltf", "absent.gltf")
        ));
        let path = scenes_dir().join("assets/absent.gltf");
        assert!(
            m.starts_with("scene.toml: objects[1].gltf = \"assets/absent.gltf\": must be a readable glTF 2.0 file: cannot read ")
                && m.contains(&path.display().to_string())
                && m.contains("No such file"),
            "{m}"
        );
        // Read through a file: the scene's own path is named.
        let dir = std::env::temp_dir().join(format!("nimbus-scene-objects-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let file = dir.join("bad.toml");
        std::fs::write(&file, MESH.replace("assets/shed.gltf", "nothing.glb")).expect("write");
        let m = Scene::from_file(&file)
            .expect_err("missing glb")
            .to_string();
        assert!(
            m.starts_with(&format!(
                "{}: objects[0].gltf = \"nothing.glb\"",
                file.display()
            )) && m.contains(&dir.join("nothing.glb").display().to_string()),
            "{m}"
        );
    }

    #[test]
    fn scenes_from_text_resolve_paths_against_the_current_directory() {
        let scene = Scene::from_toml_str("", "s.toml").expect("empty scene");
        assert_eq!(scene.base_dir, None);
        assert_eq!(scene.resolve_path("a/b.glb"), Path::new("a/b.glb"));
        assert_eq!(scene.resolve_path("/a/b.glb"), Path::new("/a/b.glb"));
        // The crate's directory is the tests' current directory: the path is
        // not found there, and the message says where it looked.
        let m = Scene::from_toml_str(MESH, "s.toml")
            .expect_err("not here")
            .to_string();
        assert!(m.contains("cannot read assets/shed.gltf"), "{m}");
    }

    #[test]
    fn the_object_count_is_limited() {
        let many = BOX.repeat(MAX_OBJECTS + 1);
        assert_eq!(
            error_of(&many),
            format!(
                "scene.toml: objects = {}: must be an integer in [0, {MAX_OBJECTS}]",
                MAX_OBJECTS + 1
            )
        );
    }

    #[test]
    fn the_triangle_limit_counts_every_object() {
        // A file claiming 2 million triangles (its buffer need not exist: the
        // count is checked before the buffers are read), after one box.
        let dir =
            std::env::temp_dir().join(format!("nimbus-scene-triangles-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let count = 3 * MAX_OBJECT_TRIANGLES;
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "buffers":[{{"byteLength":{},"uri":"absent.bin"}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":{}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,0,1]}},
            {{"bufferView":1,"componentType":5125,"count":{count},"type":"SCALAR"}}]}}"#,
            36 + 4 * count,
            4 * count
        );
        std::fs::write(dir.join("big.gltf"), json).expect("write");
        let text = format!(
            "{BOX}{}",
            MESH.replace(
                "assets/shed.gltf",
                &dir.join("big.gltf").display().to_string()
            )
        );
        let m = error_of(&text);
        assert!(
            m.contains("objects[1].gltf")
                && m.contains(&format!(
                    "has {MAX_OBJECT_TRIANGLES} triangles; the objects may have at most {} more",
                    MAX_OBJECT_TRIANGLES - BOX_TRIANGLES
                )),
            "{m}"
        );
    }
}
