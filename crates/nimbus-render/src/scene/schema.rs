//! The scene file format as a JSON Schema, generated from the settings
//! types that a scene file deserialises into ([`Scene`] and the types of its
//! sections, `#[derive(JsonSchema)]` following their serde attributes:
//! unknown keys refused, defaults, renamed enum values). Each key's doc
//! comment, with its unit and range, is its description.
//!
//! The repository ships the result as `schemas/scene.schema.json`, which TOML
//! editors (taplo, Even Better TOML) use to complete, document and check
//! scene files (docs/scene-file.md); `nimbus scene --schema` prints it, and a
//! test fails when the shipped file is stale.
//!
//! The schema is written in JSON Schema draft 7, schemars' default being
//! 2020-12: editors' validators support draft 7 widely and later drafts
//! unevenly (taplo documents draft 4 features; its 0.9 release checks this
//! draft-7 schema, tested by hand with `taplo check`). TOML has no null, so
//! the `null` that schemars allows for `Option` keys is taken out.
//! The documented ranges are stated in the descriptions, not as
//! `minimum`/`maximum` (only integers carry their type's bounds): the
//! scene's validation ([`Scene::from_toml_str`]) enforces them, with
//! one-line errors naming the key, and the rules between keys.

use super::Scene;
use schemars::generate::SchemaSettings;
use serde_json::{Map, Value};

/// Path of the shipped schema, relative to the repository root.
pub const SCHEMA_PATH: &str = "schemas/scene.schema.json";

/// The JSON Schema (draft 7) of a scene file, as a JSON value.
pub fn json_schema() -> Value {
    let generator = SchemaSettings::draft07().for_deserialize().into_generator();
    let mut schema = generator.into_root_schema_for::<Scene>();
    schema.insert("title".into(), "nimbus scene file".into());
    schema.insert(
        "description".into(),
        "A nimbus scene (TOML): the image, camera, sun, atmosphere, terrain, \
         clouds, rain, wind, objects and keyframes of one picture or \
         animation. Every section is optional, and every key but those an \
         element of a list needs; docs/scene-file.md is the reference."
            .into(),
    );
    sorted(for_toml(schema.to_value()))
}

/// [`json_schema`] as the shipped file's text: pretty-printed with keys in
/// alphabetical order, ending with a newline.
pub fn json_schema_text() -> String {
    // A `Value` serialises without error (its map keys are strings).
    let mut text = serde_json::to_string_pretty(&json_schema()).unwrap_or_default();
    text.push('\n');
    text
}

/// Adapts schemars' output to TOML and to editors: takes out the `null`
/// that schemars allows for `Option` values (TOML has none: `"type":
/// ["number", "null"]` becomes `"type": "number"`, a `{"type": "null"}`
/// alternative of `anyOf`/`oneOf` goes, an `anyOf` left with one
/// alternative is replaced by it, `"default": null` and the absent keys of
/// a default table go), bounds 32-bit integers (schemars states only their
/// sign) and turns the doc comments' Rust links (``[`Scene::at_time`]``)
/// into plain code spans.
fn for_toml(value: Value) -> Value {
    match value {
        Value::Array(items) => Value::Array(items.into_iter().map(for_toml).collect()),
        Value::Object(map) => {
            let mut out = Map::new();
            for (key, item) in map {
                let item = match (key.as_str(), item) {
                    ("default", Value::Null) => continue,
                    ("default", default) => without_null_members(default),
                    ("description", Value::String(text)) => {
                        Value::String(text.replace("[`", "`").replace("`]", "`"))
                    }
                    ("type", Value::Array(types)) => {
                        let mut kept: Vec<Value> =
                            types.into_iter().filter(|t| t != "null").collect();
                        if kept.len() == 1 {
                            kept.remove(0)
                        } else {
                            Value::Array(kept)
                        }
                    }
                    ("anyOf" | "oneOf", Value::Array(alternatives)) => Value::Array(
                        alternatives
                            .into_iter()
                            .filter(|a| a.get("type").is_none_or(|t| t != "null"))
                            .map(for_toml)
                            .collect(),
                    ),
                    (_, item) => for_toml(item),
                };
                out.insert(key, item);
            }
            // `anyOf: [X]` (what remains of `Option<X>`) is X itself, merged
            // with the keys beside it (description, default); a reference
            // goes into an `allOf`, as draft 7 ignores the siblings of `$ref`.
            if let Some(Value::Array(alternatives)) = out.get("anyOf")
                && alternatives.len() == 1
                && let Some(Value::Object(only)) = alternatives.first().cloned()
                && only.keys().all(|k| !out.contains_key(k) || k == "anyOf")
            {
                out.remove("anyOf");
                if only.contains_key("$ref") {
                    out.insert("allOf".into(), Value::Array(vec![Value::Object(only)]));
                } else {
                    out.extend(only);
                }
            }
            let bound = match out.get("format").and_then(Value::as_str) {
                Some("uint8") => Some(u64::from(u8::MAX)),
                Some("uint16") => Some(u64::from(u16::MAX)),
                Some("uint32") => Some(u64::from(u32::MAX)),
                _ => None,
            };
            if let Some(bound) = bound {
                out.entry("maximum").or_insert(bound.into());
            }
            Value::Object(out)
        }
        other => other,
    }
}

/// A default value without its `null` members (keys a scene file leaves out).
fn without_null_members(value: Value) -> Value {
    match value {
        Value::Array(items) => Value::Array(items.into_iter().map(without_null_members).collect()),
        Value::Object(map) => Value::Object(
            map.into_iter()
                .filter(|(_, v)| !v.is_null())
                .map(|(k, v)| (k, without_null_members(v)))
                .collect(),
        ),
        other => other,
    }
}

/// `value` with every object's keys in alphabetical order, whatever the
/// order `serde_json` keeps (its `preserve_order` feature keeps insertion
/// order), so that the shipped file's text is the same in every build.
fn sorted(value: Value) -> Value {
    match value {
        Value::Array(items) => Value::Array(items.into_iter().map(sorted).collect()),
        Value::Object(map) => {
            let mut entries: Vec<(String, Value)> = map.into_iter().collect();
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            Value::Object(entries.into_iter().map(|(k, v)| (k, sorted(v))).collect())
        }
        other => other,
    }
}
