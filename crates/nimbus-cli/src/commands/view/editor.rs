//! The scene being edited in the viewer: the panel edits a TOML document of
//! every parameter; each change is parsed and validated like a scene file,
//! and only a valid document replaces the scene that is drawn (the error is
//! shown otherwise). Saving writes the document with the camera's pose.

use super::camera::ViewerCamera;
use nimbus_render::Scene;
use nimbus_render::scene::SceneError;
use std::path::{Path, PathBuf};

/// The top-level sections the panel shows, grouped by feature, in order.
/// `image` is left out: the window sets the image size.
pub const GROUPS: [(&str, &[&str]); 9] = [
    ("Time and place", &["sun"]),
    ("Camera", &["camera"]),
    ("Sky", &["atmosphere"]),
    ("Terrain", &["terrain", "ground", "objects"]),
    ("Stratus", &["stratus"]),
    ("Cumulus", &["cumulus"]),
    ("Rain", &["rain"]),
    ("Wind", &["wind"]),
    ("Animation", &["keyframes"]),
];

/// Camera keys the mouse and keyboard own; the panel shows them read-only.
pub const CAMERA_POSE_KEYS: [&str; 4] = ["position_m", "look_at_m", "yaw_deg", "pitch_deg"];

/// A parameter that is absent unless set: where it lives (a table path,
/// `[]` for the elements of an array of tables) and the value it starts at.
pub struct OptionalKey {
    /// Dotted path of the table, e.g. `rain` or `keyframes[]`.
    pub table: &'static str,
    /// The key.
    pub key: &'static str,
    /// Its value when added.
    pub initial: fn() -> toml::Value,
}

/// Every parameter that serialises to nothing when unset (an `Option` in
/// the scene types), except the camera's pose and the sun's position (the
/// panel has its own controls for those).
pub const OPTIONAL_KEYS: &[OptionalKey] = &[
    OptionalKey {
        table: "cumulus",
        key: "area_m",
        initial: || toml::Value::Float(20_000.0),
    },
    OptionalKey {
        table: "rain",
        key: "ceiling_m",
        initial: || toml::Value::Float(1500.0),
    },
    OptionalKey {
        table: "wind",
        key: "turbulence",
        initial: || {
            toml::Value::try_from(nimbus_render::scene::TurbulenceSettings::default())
                .unwrap_or(toml::Value::Table(toml::Table::new()))
        },
    },
    OptionalKey {
        table: "wind",
        key: "field",
        initial: || {
            toml::Value::try_from(nimbus_render::scene::WindFieldSettings::new(
                "wind.npy", 2.0,
            ))
            .unwrap_or(toml::Value::Table(toml::Table::new()))
        },
    },
    OptionalKey {
        table: "keyframes[]",
        key: "sun_time_utc",
        initial: || toml::Value::String("2026-06-21T12:00:00Z".to_owned()),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "sun_azimuth_deg",
        initial: || toml::Value::Float(180.0),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "sun_elevation_deg",
        initial: || toml::Value::Float(30.0),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "wind_speed_m_s",
        initial: || toml::Value::Float(5.0),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "wind_from_deg",
        initial: || toml::Value::Float(270.0),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "rain_intensity_mm_h",
        initial: || toml::Value::Float(5.0),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "stratus_coverage",
        initial: || toml::Value::Float(0.7),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "camera_position_m",
        initial: || toml::Value::try_from([0.0, 100.0, 0.0]).unwrap_or(toml::Value::Float(0.0)),
    },
    OptionalKey {
        table: "keyframes[]",
        key: "camera_look_at_m",
        initial: || {
            toml::Value::try_from([0.0, 1000.0, -5000.0]).unwrap_or(toml::Value::Float(0.0))
        },
    },
    OptionalKey {
        table: "objects[]",
        key: "center_m",
        initial: || toml::Value::try_from([0.0, 10.0, 0.0]).unwrap_or(toml::Value::Float(0.0)),
    },
    OptionalKey {
        table: "objects[]",
        key: "size_m",
        initial: || toml::Value::try_from([10.0, 20.0, 10.0]).unwrap_or(toml::Value::Float(0.0)),
    },
    OptionalKey {
        table: "objects[]",
        key: "gltf",
        initial: || toml::Value::String("model.glb".to_owned()),
    },
    OptionalKey {
        table: "objects[]",
        key: "position_m",
        initial: || toml::Value::try_from([0.0, 0.0, 0.0]).unwrap_or(toml::Value::Float(0.0)),
    },
    OptionalKey {
        table: "objects[]",
        key: "scale",
        initial: || toml::Value::Float(1.0),
    },
];

/// The allowed values of the parameters that take one of a few words.
pub const CHOICES: [(&str, &[&str]); 5] = [
    ("camera.projection", &["perspective", "equirectangular"]),
    ("cumulus.shading.trap_model", &["furrows", "arctan"]),
    ("rain.box_shape", &["sphere", "box", "frustum"]),
    (
        "wind.primitives[].kind",
        &["uniform", "source", "vortex", "gust_front"],
    ),
    ("objects[].kind", &["box", "mesh"]),
];

/// A new element of an array of tables (`objects`, `keyframes`, …), from
/// the smallest valid table of its type with every default spelled out.
pub fn new_element(array: &str) -> Option<toml::Value> {
    use nimbus_render::scene::{
        Keyframe, PlacedCloud, RainAreaSettings, SceneObject, WindPrimitiveSettings,
    };
    fn spelled_out<T: serde::Serialize + serde::de::DeserializeOwned>(
        text: &str,
    ) -> Option<toml::Value> {
        let value: T = toml::from_str(text).ok()?;
        toml::Value::try_from(value).ok()
    }
    match array {
        "objects" => spelled_out::<SceneObject>(
            "kind = \"box\"\ncenter_m = [0.0, 10.0, 0.0]\nsize_m = [10.0, 20.0, 10.0]",
        ),
        "keyframes" => spelled_out::<Keyframe>("time_s = 0.0"),
        "wind.primitives" => {
            spelled_out::<WindPrimitiveSettings>("kind = \"vortex\"\nspeed_m_s = 10.0")
        }
        "rain.areas" => spelled_out::<RainAreaSettings>("center_m = [0.0, 0.0]\nradius_m = 2000.0"),
        "cumulus.clouds" => spelled_out::<PlacedCloud>("position_m = [0.0, 1500.0, 0.0]"),
        _ => None,
    }
}

/// A section (`cumulus`, …) that the scene may leave out, with its defaults.
pub fn optional_section(name: &str) -> Option<toml::Value> {
    use nimbus_render::scene::{CumulusSettings, RainSettings, StratusSettings, WindSettings};
    match name {
        "cumulus" => toml::Value::try_from(CumulusSettings::default()).ok(),
        "stratus" => toml::Value::try_from(StratusSettings::default()).ok(),
        "rain" => toml::Value::try_from(RainSettings::default()).ok(),
        "wind" => toml::Value::try_from(WindSettings::default()).ok(),
        _ => None,
    }
}

/// Whether `after` differs from `before` in a value that `before`'s
/// keyframes drive (the sun, the wind's speed and direction, the rain's
/// intensity, the stratus coverage): an edit that the keyframes would
/// override at once.
pub fn keyed_value_changed(before: &Scene, after: &Scene) -> bool {
    let keyed = |f: fn(&nimbus_render::scene::Keyframe) -> bool| before.keyframes.iter().any(f);
    let sun = keyed(|k| {
        k.sun_time_utc.is_some() || k.sun_azimuth_deg.is_some() || k.sun_elevation_deg.is_some()
    }) && before.sun != after.sun;
    let wind_of = |s: &Scene| s.wind.as_ref().map(|w| (w.speed_m_s, w.from_deg));
    let wind = keyed(|k| k.wind_speed_m_s.is_some() || k.wind_from_deg.is_some())
        && wind_of(before) != wind_of(after);
    let rain = keyed(|k| k.rain_intensity_mm_h.is_some())
        && before.rain.as_ref().map(|r| r.intensity_mm_h)
            != after.rain.as_ref().map(|r| r.intensity_mm_h);
    let stratus = keyed(|k| k.stratus_coverage.is_some())
        && before.stratus.as_ref().map(|s| s.coverage)
            != after.stratus.as_ref().map(|s| s.coverage);
    sun || wind || rain || stratus
}

/// The scene of the viewer: the edited document and the last valid scene.
#[derive(Debug)]
pub struct SceneEditor {
    /// Every parameter, as the panel edits it.
    pub doc: toml::Table,
    /// The last document that validated.
    pub scene: Scene,
    /// Why the current document is not the scene drawn, if it is not.
    pub error: Option<String>,
    /// The scene file, when one was opened; saving writes it.
    pub file: Option<PathBuf>,
    /// Counts the scenes applied, so that the renderer knows when to prepare anew.
    pub generation: u64,
}

/// Name of the scene in error messages.
fn display_name(file: Option<&Path>) -> String {
    file.map_or_else(|| "<default scene>".to_owned(), |f| f.display().to_string())
}

/// The scene as a TOML table, every parameter spelled out.
pub fn scene_table(scene: &Scene) -> Result<toml::Table, String> {
    match toml::Value::try_from(scene) {
        Ok(toml::Value::Table(table)) => Ok(table),
        Ok(_) => Err("the scene did not serialise to a table".to_owned()),
        Err(e) => Err(format!("cannot serialise the scene: {e}")),
    }
}

impl SceneEditor {
    /// Starts editing a scene read from `file` (or the embedded default).
    pub fn new(scene: Scene, file: Option<PathBuf>) -> Result<Self, String> {
        Ok(Self {
            doc: scene_table(&scene)?,
            scene,
            error: None,
            file,
            generation: 0,
        })
    }

    /// Parses and validates the document; a valid one becomes the scene.
    /// Returns whether the scene changed.
    pub fn apply(&mut self) -> bool {
        let text = toml::to_string(&self.doc).unwrap_or_default();
        let name = display_name(self.file.as_deref());
        let base_dir = self.scene.base_dir.clone();
        match Scene::from_toml_str_in(&text, &name, base_dir.as_deref()) {
            Ok(scene) => {
                self.error = None;
                if scene != self.scene {
                    self.scene = scene;
                    self.generation += 1;
                    return true;
                }
                false
            }
            Err(e) => {
                self.error = Some(e.to_string());
                false
            }
        }
    }

    /// Reads the scene file again (after it changed on disk). A file that
    /// does not parse or validate leaves the scene as it was and sets the error.
    pub fn reload(&mut self) -> bool {
        let Some(file) = self.file.clone() else {
            return false;
        };
        match Scene::from_file(&file).map_err(|e: SceneError| e.to_string()) {
            Ok(scene) => match scene_table(&scene) {
                Ok(doc) => {
                    self.doc = doc;
                    self.error = None;
                    self.scene = scene;
                    self.generation += 1;
                    true
                }
                Err(e) => {
                    self.error = Some(e);
                    false
                }
            },
            Err(e) => {
                self.error = Some(e);
                false
            }
        }
    }

    /// The scene with the camera's pose: what is saved.
    pub fn posed_scene(&self, camera: &ViewerCamera) -> Scene {
        let mut scene = self.scene.clone();
        camera.write_to(&mut scene.camera);
        scene
    }

    /// The scene drawn at `time_s`: posed by the camera, with the keyframed
    /// weather at that time when `keyframes` is on (else the values of the
    /// panel, the clouds still carried by the wind).
    pub fn scene_at(&self, camera: &ViewerCamera, time_s: f64, keyframes: bool) -> Scene {
        let mut scene = self.posed_scene(camera);
        if !keyframes {
            scene.keyframes.clear();
        }
        // The mouse and keyboard fly the viewer's camera: a keyed flight
        // (what `animate` renders) would take it from them every frame.
        for key in &mut scene.keyframes {
            key.camera_position_m = None;
            key.camera_look_at_m = None;
        }
        scene.at_time(time_s)
    }

    /// The scene file's text for the drawn scene with the camera's pose.
    pub fn to_toml(&self, camera: &ViewerCamera) -> Result<String, String> {
        let table = scene_table(&self.posed_scene(camera))?;
        toml::to_string_pretty(&table).map_err(|e| format!("cannot write TOML: {e}"))
    }

    /// Writes the scene with the camera's pose to `path`, atomically (a
    /// temporary file renamed over it), and checks that it reads back.
    pub fn save(&self, path: &Path, camera: &ViewerCamera) -> Result<(), String> {
        let text = self.to_toml(camera)?;
        let name = path.display().to_string();
        Scene::from_toml_str(&text, &name)
            .map_err(|e| format!("{name}: the saved scene would not read back: {e}"))?;
        let tmp = path.with_extension("toml.tmp");
        std::fs::write(&tmp, &text)
            .and_then(|()| std::fs::rename(&tmp, path))
            .map_err(|e| {
                std::fs::remove_file(&tmp).ok();
                format!("{name}: cannot write: {e}")
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn default_editor() -> SceneEditor {
        SceneEditor::new(Scene::embedded_default(), None).expect("editor")
    }

    #[test]
    fn a_valid_edit_applies_and_an_invalid_one_keeps_the_last_good_scene() {
        let mut editor = default_editor();
        let sun = editor.doc["sun"].as_table_mut().expect("sun");
        sun.insert("latitude_deg".into(), toml::Value::Float(10.0));
        sun.remove("time_utc");
        sun.remove("longitude_deg");
        sun.remove("latitude_deg");
        sun.insert("azimuth_deg".into(), toml::Value::Float(90.0));
        sun.insert("elevation_deg".into(), toml::Value::Float(12.0));
        assert!(editor.apply(), "{:?}", editor.error);
        assert_eq!(editor.scene.sun.angles_deg(), (90.0, 12.0));
        assert_eq!(editor.generation, 1);

        let stratus = editor.doc["stratus"].as_table_mut().expect("stratus");
        stratus.insert("coverage".into(), toml::Value::Float(1.5));
        assert!(!editor.apply());
        let error = editor.error.clone().expect("error");
        assert!(error.contains("stratus.coverage"), "{error}");
        assert_eq!(editor.scene.sun.angles_deg(), (90.0, 12.0));
        assert_eq!(editor.generation, 1);
    }

    #[test]
    fn the_scene_file_reloads_when_valid_and_is_kept_when_not() {
        let dir = std::env::temp_dir().join(format!("nimbus-editor-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let file = dir.join("scene.toml");
        std::fs::write(&file, "[sun]\nazimuth_deg = 100.0\nelevation_deg = 20.0\n").expect("write");
        let scene = Scene::from_file(&file).expect("scene");
        let mut editor = SceneEditor::new(scene, Some(file.clone())).expect("editor");
        let camera = ViewerCamera::from_settings(&editor.scene.camera);

        std::fs::write(&file, "[sun]\nazimuth_deg = 400.0\n").expect("write");
        assert!(!editor.reload());
        let error = editor.error.clone().expect("error");
        assert!(
            error.contains("sun.azimuth_deg") && error.contains("scene.toml"),
            "{error}"
        );
        assert_eq!(editor.scene.sun.angles_deg(), (100.0, 20.0));

        std::fs::write(&file, "[sun]\nazimuth_deg = 120.0\nelevation_deg = 5.0\n").expect("write");
        assert!(editor.reload());
        assert_eq!(editor.error, None);
        assert_eq!(editor.doc["sun"]["azimuth_deg"].as_float(), Some(120.0));

        // Saving writes the scene with the camera's pose, and it reads back the same.
        let saved = dir.join("saved.toml");
        editor.save(&saved, &camera).expect("save");
        let back = Scene::from_file(&saved).expect("saved scene reads back");
        assert_eq!(back.sun, editor.scene.sun);
        assert_eq!(back.camera, editor.posed_scene(&camera).camera);
        assert!(!dir.join("saved.toml.tmp").exists());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn edits_of_keyed_values_are_recognised() {
        // The default scene keys the sun's elevation, the wind and the rain.
        let before = Scene::embedded_default();
        assert!(!before.keyframes.is_empty());
        let mut after = before.clone();
        after.terrain.height_scale_m += 100.0;
        assert!(!keyed_value_changed(&before, &after));
        after.sun.elevation_deg = Some(5.0);
        after.sun.azimuth_deg = Some(100.0);
        assert!(keyed_value_changed(&before, &after));
        let mut after = before.clone();
        after.stratus.as_mut().expect("stratus").coverage = 0.1;
        assert!(
            !keyed_value_changed(&before, &after),
            "coverage is not keyed"
        );
        after.rain.as_mut().expect("rain").intensity_mm_h = 50.0;
        assert!(keyed_value_changed(&before, &after));
        // Without keyframes nothing is keyed.
        let mut unkeyed = before.clone();
        unkeyed.keyframes.clear();
        assert!(!keyed_value_changed(&unkeyed, &after));

        // Keyframes off: the panel's value is drawn whatever the time.
        let editor = SceneEditor::new(after.clone(), None).expect("editor");
        let camera = ViewerCamera::from_settings(&after.camera);
        let late = editor.scene_at(&camera, 9.0, false);
        assert_eq!(late.rain.expect("rain").intensity_mm_h, 50.0);
        let keyed = editor.scene_at(&camera, 9.0, true);
        assert_ne!(keyed.rain.expect("rain").intensity_mm_h, 50.0);
    }

    #[test]
    fn every_top_level_section_is_in_exactly_one_group() {
        let mut scene = Scene::embedded_default();
        scene.cumulus.get_or_insert_default();
        scene.stratus.get_or_insert_default();
        scene.rain.get_or_insert_default();
        scene.wind.get_or_insert_default();
        let table = scene_table(&scene).expect("table");
        for key in table.keys().filter(|k| k.as_str() != "image") {
            let count = GROUPS
                .iter()
                .filter(|(_, sections)| sections.contains(&key.as_str()))
                .count();
            assert_eq!(count, 1, "section {key}");
        }
        for name in ["cumulus", "stratus", "rain", "wind"] {
            assert!(optional_section(name).is_some(), "{name}");
        }
    }

    /// Every key the scene reference documents can be reached in the panel:
    /// it is in the serialised default scene with every section on, an
    /// optional key, the camera's pose or the sun's position.
    #[test]
    fn the_panel_reaches_every_documented_key() {
        let mut scene = Scene::embedded_default();
        scene.cumulus.get_or_insert_default();
        scene.stratus.get_or_insert_default();
        scene.rain.get_or_insert_default();
        scene.wind.get_or_insert_default();
        let table = scene_table(&scene).expect("table");
        let mut reachable = std::collections::BTreeSet::new();
        fn walk(prefix: &str, value: &toml::Value, out: &mut std::collections::BTreeSet<String>) {
            match value {
                toml::Value::Table(t) => {
                    for (k, v) in t {
                        let path = if prefix.is_empty() {
                            k.clone()
                        } else {
                            format!("{prefix}.{k}")
                        };
                        out.insert(path.clone());
                        walk(&path, v, out);
                    }
                }
                toml::Value::Array(items) => {
                    for item in items {
                        walk(&format!("{prefix}[]"), item, out);
                    }
                }
                _ => {}
            }
        }
        walk("", &toml::Value::Table(table), &mut reachable);
        for key in OPTIONAL_KEYS {
            let path = format!("{}.{}", key.table, key.key);
            reachable.insert(path.clone());
            walk(&path, &(key.initial)(), &mut reachable);
        }
        for key in CAMERA_POSE_KEYS {
            reachable.insert(format!("camera.{key}"));
        }
        for key in [
            "azimuth_deg",
            "elevation_deg",
            "time_utc",
            "latitude_deg",
            "longitude_deg",
        ] {
            reachable.insert(format!("sun.{key}"));
        }
        // The elements the panel adds to arrays of tables.
        for array in [
            "objects",
            "keyframes",
            "wind.primitives",
            "rain.areas",
            "cumulus.clouds",
        ] {
            let element = new_element(array).unwrap_or_else(|| panic!("{array}"));
            walk(&format!("{array}[]"), &element, &mut reachable);
        }
        // Read, not embedded: the published crate holds no file from outside it.
        let doc_path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/scene-file.md");
        let doc = std::fs::read_to_string(doc_path).expect("docs/scene-file.md");
        let doc = doc.as_str();
        let mut missing = Vec::new();
        for documented in doc.split('`').skip(1).step_by(2).filter(|s| {
            s.contains('.')
                && s.chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || "._[]".contains(c))
                && !s.ends_with(".toml")
                && !s.ends_with(".glb")
                && !s.ends_with(".gltf")
                && !s.ends_with(".npy")
        }) {
            // `[table]`, `[[array]]` and `.key` (a key of the table named before it).
            let key = documented.replace("[]", "");
            let key = key.trim_matches(|c| c == '[' || c == ']');
            let reached = reachable.iter().any(|r| {
                let r = r.replace("[]", "");
                match key.strip_prefix('.') {
                    Some(tail) => r.ends_with(&format!(".{tail}")),
                    None => r == key,
                }
            });
            if !reached {
                missing.push(documented.to_owned());
            }
        }
        assert!(
            missing.is_empty(),
            "not reachable in the panel: {missing:?}"
        );
    }
}
