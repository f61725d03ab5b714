//! The viewer's egui side: the parameter panel (every scene parameter,
//! grouped by feature, as widgets over the scene's TOML document), the
//! per-pass GPU time overlay and the error and status lines.

use super::camera::{CameraMode, ViewerCamera};
use super::editor::{
    CAMERA_POSE_KEYS, CHOICES, GROUPS, OPTIONAL_KEYS, SceneEditor, new_element, optional_section,
};
use std::collections::HashMap;

/// Slider ranges of the parameters a slider suits (others get a drag
/// field): table path, key, range, logarithmic. Validation still has the
/// last word (the ranges of `docs/scene-file.md`).
const SLIDERS: &[(&str, f64, f64, bool)] = &[
    ("sun.azimuth_deg", 0.0, 360.0, false),
    ("sun.elevation_deg", -90.0, 90.0, false),
    ("sun.latitude_deg", -90.0, 90.0, false),
    ("sun.longitude_deg", -180.0, 180.0, false),
    ("camera.fov_deg", 1.0, 150.0, false),
    ("camera.exposure_ev100", -10.0, 30.0, false),
    ("camera.exposure_compensation_ev", -10.0, 10.0, false),
    ("camera.adaptation_time_s", 0.0, 60.0, false),
    ("atmosphere.aerosol_optical_depth", 0.0, 5.0, true),
    ("atmosphere.aerosol_angstrom_exponent", -1.0, 4.0, false),
    (
        "atmosphere.aerosol_single_scattering_albedo",
        0.0,
        1.0,
        false,
    ),
    ("atmosphere.aerosol_asymmetry", -0.99, 0.99, false),
    ("terrain.height_scale_m", 0.0, 10_000.0, false),
    ("terrain.water_level_m", -1000.0, 3000.0, false),
    ("terrain.snow_line_m", -1000.0, 10_000.0, false),
    ("terrain.rock_slope_deg", 0.0, 90.0, false),
    ("terrain.resolution", 16.0, 2048.0, true),
    ("stratus.base_m", 0.0, 15_000.0, false),
    ("stratus.thickness_m", 1.0, 2000.0, true),
    ("stratus.coverage", 0.0, 1.0, false),
    ("stratus.feature_size_m", 100.0, 100_000.0, true),
    ("stratus.detail", 1.0, 8.0, false),
    ("stratus.effective_radius_um", 1.0, 50.0, true),
    ("stratus.droplet_concentration_cm3", 1.0, 5000.0, true),
    ("stratus.resolution", 16.0, 2048.0, true),
    ("stratus.radiosity_iterations", 0.0, 32.0, false),
    ("cumulus.coverage", 0.0, 1.0, false),
    ("cumulus.base_m", 0.0, 10_000.0, false),
    ("cumulus.variants", 1.0, 8.0, false),
    ("cumulus.levels_of_detail", 1.0, 5.0, false),
    ("rain.intensity_mm_h", 0.0, 300.0, true),
    ("rain.box_radius_m", 1.0, 200.0, true),
    ("rain.min_diameter_mm", 0.1, 2.0, false),
    ("rain.max_diameter_mm", 2.1, 8.0, false),
    ("wind.speed_m_s", 0.0, 100.0, false),
    ("wind.from_deg", 0.0, 360.0, false),
    ("keyframes[].stratus_coverage", 0.0, 1.0, false),
    ("keyframes[].sun_elevation_deg", -90.0, 90.0, false),
    ("keyframes[].sun_azimuth_deg", 0.0, 360.0, false),
    ("keyframes[].wind_from_deg", 0.0, 360.0, false),
];

/// What the user asked for through the panel this frame.
#[derive(Debug, Default)]
pub struct PanelActions {
    /// The document changed: validate and apply it.
    pub edited: bool,
    /// Save the scene to [`PanelState::save_path`].
    pub save: bool,
    /// Read the scene file again.
    pub reload: bool,
    /// Take a screenshot.
    pub screenshot: bool,
}

/// The panel's own state between frames.
#[derive(Debug)]
pub struct PanelState {
    /// Where "Save" writes.
    pub save_path: String,
    /// Sections switched off, kept to restore when switched on again.
    stashed_sections: HashMap<String, toml::Value>,
    /// The sun's date settings, kept while the sun is set by angles.
    stashed_sun: Option<toml::Table>,
}

impl PanelState {
    /// A panel that saves to `save_path`.
    pub fn new(save_path: String) -> Self {
        Self {
            save_path,
            stashed_sections: HashMap::new(),
            stashed_sun: None,
        }
    }
}

/// The animation clock shown in the panel.
#[derive(Debug)]
pub struct Clock {
    /// Scene time, s.
    pub time_s: f64,
    /// Whether time runs.
    pub playing: bool,
    /// Whether the scene's keyframes drive the weather (off: the panel's values).
    pub keyframes: bool,
}

/// Smoothed per-pass GPU times for the overlay.
#[derive(Debug, Default)]
pub struct PassTimes {
    /// Exponential moving average per pass, ms; `None` for passes that did not run lately.
    smoothed_ms: Vec<Option<f64>>,
    /// Smoothed wall-clock frame time, s.
    frame_s: f64,
}

impl PassTimes {
    /// Weight of the newest frame in the averages.
    const NEWEST_WEIGHT: f64 = 0.1;

    /// Adds a frame's times (in [`nimbus_render::PASS_NAMES`] order).
    pub fn add(&mut self, times_ms: &[Option<f64>]) {
        self.smoothed_ms.resize(times_ms.len(), None);
        for (smoothed, time) in self.smoothed_ms.iter_mut().zip(times_ms) {
            *smoothed = match (*smoothed, time) {
                (Some(old), Some(new)) => Some(old + Self::NEWEST_WEIGHT * (new - old)),
                (_, new) => *new,
            };
        }
    }

    /// Adds a frame's wall-clock time, s.
    pub fn add_frame(&mut self, frame_s: f64) {
        self.frame_s = if self.frame_s == 0.0 {
            frame_s
        } else {
            self.frame_s + Self::NEWEST_WEIGHT * (frame_s - self.frame_s)
        };
    }

    /// The sum of the passes' smoothed times, ms.
    pub fn total_ms(&self) -> f64 {
        self.smoothed_ms.iter().flatten().sum()
    }
}

/// The overlay of per-pass GPU times (top right).
pub fn timing_overlay(ctx: &egui::Context, times: Option<&PassTimes>, adapter: &str) {
    egui::Area::new(egui::Id::new("nimbus gpu times"))
        .anchor(egui::Align2::RIGHT_TOP, egui::vec2(-8.0, 8.0))
        .interactable(false)
        .show(ctx, |ui| {
            egui::Frame::popup(ui.style())
                .fill(egui::Color32::from_black_alpha(170))
                .show(ui, |ui| {
                    ui.style_mut().override_font_id = Some(egui::FontId::monospace(11.0));
                    ui.label(adapter);
                    let Some(times) = times else {
                        ui.label("GPU times: no timestamp queries on this adapter");
                        return;
                    };
                    if times.frame_s > 0.0 {
                        ui.label(format!(
                            "frame {:7.2} ms ({:.1} fps)",
                            times.frame_s * 1e3,
                            1.0 / times.frame_s
                        ));
                    }
                    for (name, time) in nimbus_render::PASS_NAMES.iter().zip(&times.smoothed_ms) {
                        if let Some(ms) = time {
                            ui.label(format!("{name:<20}{ms:8.3} ms"));
                        }
                    }
                    ui.label(format!("{:<20}{:8.3} ms", "GPU total", times.total_ms()));
                });
        });
}

/// Splits an ISO 8601 date-time into the text before the time of day, the
/// hour of day (with minutes and seconds as fractions) and the zone after it.
pub fn split_time_of_day(text: &str) -> Option<(&str, f64, &str)> {
    let t = text.find('T')?;
    let (date, rest) = text.split_at(t + 1);
    let clock_len = rest
        .find(|c: char| !(c.is_ascii_digit() || c == ':' || c == '.'))
        .unwrap_or(rest.len());
    let (clock, zone) = rest.split_at(clock_len);
    let mut parts = clock.split(':');
    let hours: f64 = parts.next()?.parse().ok()?;
    let minutes: f64 = parts.next()?.parse().ok()?;
    let seconds: f64 = parts.next().map_or(Some(0.0), |s| s.parse().ok())?;
    Some((date, hours + minutes / 60.0 + seconds / 3600.0, zone))
}

/// Writes an hour of day in [0, 24) as `HH:MM:SS` between `date` and `zone`.
pub fn join_time_of_day(date: &str, hours: f64, zone: &str) -> String {
    let total_s = (hours.clamp(0.0, 24.0) * 3600.0).round().min(86_399.0) as u32;
    format!(
        "{date}{:02}:{:02}:{:02}{zone}",
        total_s / 3600,
        total_s / 60 % 60,
        total_s % 60
    )
}

/// The left panel: file actions, the clock, every group of parameters.
pub fn scene_panel(
    ui: &mut egui::Ui,
    editor: &mut SceneEditor,
    state: &mut PanelState,
    camera: &mut ViewerCamera,
    clock: &mut Clock,
) -> PanelActions {
    let mut actions = PanelActions::default();
    ui.heading("nimbus");
    ui.label(
        editor
            .file
            .as_ref()
            .map_or_else(|| "default scene".to_owned(), |f| f.display().to_string()),
    );
    ui.horizontal(|ui| {
        ui.label("Save to");
        ui.text_edit_singleline(&mut state.save_path);
    });
    ui.horizontal(|ui| {
        actions.save = ui.button("Save (Ctrl+S)").clicked();
        if editor.file.is_some() {
            actions.reload = ui.button("Reload file").clicked();
        }
        actions.screenshot = ui.button("Screenshot (F12)").clicked();
    });
    if let Some(error) = &editor.error {
        ui.colored_label(
            egui::Color32::from_rgb(255, 110, 90),
            format!("Not applied: {error}"),
        );
    }
    ui.separator();
    egui::ScrollArea::vertical().show(ui, |ui| {
        for (group, sections) in GROUPS {
            egui::CollapsingHeader::new(group)
                .default_open(matches!(group, "Time and place" | "Camera"))
                .show(ui, |ui| {
                    match group {
                        "Time and place" => actions.edited |= sun_controls(ui, editor, state),
                        "Camera" => camera_controls(ui, camera),
                        "Animation" => clock_controls(ui, editor, clock),
                        _ => {}
                    }
                    for section in sections {
                        actions.edited |= section_controls(ui, editor, state, section);
                    }
                });
        }
        egui::CollapsingHeader::new("Controls").show(ui, |ui| {
            ui.label(
                "Drag: look (fly) or turn about the target (orbit)\n\
                 W A S D: move, Q E: down and up, Shift: ×10\n\
                 Wheel: flying speed, or zoom (orbit)\n\
                 Tab: fly / orbit   Space: play / pause\n\
                 F1: hide the panel   F12: screenshot   Ctrl+S: save",
            );
        });
    });
    actions
}

/// The sun: by angles, or by date, time and place with a time-of-day slider.
fn sun_controls(ui: &mut egui::Ui, editor: &mut SceneEditor, state: &mut PanelState) -> bool {
    let Some(sun) = editor
        .doc
        .get_mut("sun")
        .and_then(toml::Value::as_table_mut)
    else {
        return false;
    };
    let by_date = sun.contains_key("time_utc");
    let mut want_date = by_date;
    ui.horizontal(|ui| {
        ui.radio_value(&mut want_date, false, "By angles");
        ui.radio_value(&mut want_date, true, "By date, time and place");
    });
    let mut changed = false;
    if want_date != by_date {
        changed = true;
        let (azimuth, elevation) = editor.scene.sun.angles_deg();
        if want_date {
            let date = state.stashed_sun.take().unwrap_or_else(|| {
                let mut t = toml::Table::new();
                t.insert("time_utc".into(), "2026-06-21T12:00:00Z".into());
                t.insert("latitude_deg".into(), toml::Value::Float(45.0));
                t.insert("longitude_deg".into(), toml::Value::Float(6.0));
                t
            });
            sun.clear();
            sun.extend(date);
        } else {
            state.stashed_sun = Some(sun.clone());
            sun.clear();
            sun.insert("azimuth_deg".into(), toml::Value::Float(azimuth));
            sun.insert("elevation_deg".into(), toml::Value::Float(elevation));
        }
    }
    if let Some(toml::Value::String(time)) = sun.get_mut("time_utc") {
        if let Some((date, hours, zone)) = split_time_of_day(time) {
            let (date, zone) = (date.to_owned(), zone.to_owned());
            let mut hours = hours;
            let response = ui.add(
                egui::Slider::new(&mut hours, 0.0..=23.999)
                    .text("time of day, h")
                    .fixed_decimals(2),
            );
            if response.changed() {
                *time = join_time_of_day(&date, hours, &zone);
                changed = true;
            }
        }
    } else {
        // Angles left out mean the defaults; show them so that they can be moved.
        let (azimuth, elevation) = editor.scene.sun.angles_deg();
        sun.entry("azimuth_deg")
            .or_insert(toml::Value::Float(azimuth));
        sun.entry("elevation_deg")
            .or_insert(toml::Value::Float(elevation));
    }
    let (azimuth, elevation) = editor.scene.sun.angles_deg();
    ui.label(format!(
        "sun: azimuth {azimuth:.1}°, elevation {elevation:.1}°"
    ));
    changed
}

/// The camera's mode and pose (the mouse and keys own the pose).
fn camera_controls(ui: &mut egui::Ui, camera: &mut ViewerCamera) {
    let mut mode = camera.mode;
    ui.horizontal(|ui| {
        ui.radio_value(&mut mode, CameraMode::Fly, "Fly");
        ui.radio_value(&mut mode, CameraMode::Orbit, "Orbit");
    });
    camera.set_mode(mode);
    if camera.mode == CameraMode::Fly {
        ui.add(
            egui::Slider::new(&mut camera.speed_m_s, 1.0..=10_000.0)
                .logarithmic(true)
                .text("speed, m/s"),
        );
    }
    let [x, y, z] = camera.position_m.to_array();
    ui.label(format!(
        "position ({x:.0}, {y:.0}, {z:.0}) m\nheading {:.1}°, elevation {:.1}°",
        camera.yaw_deg, camera.pitch_deg
    ));
    ui.label("Image size: the window's.");
}

/// Time of the keyframed weather: a slider and play / pause.
fn clock_controls(ui: &mut egui::Ui, editor: &SceneEditor, clock: &mut Clock) {
    let end_s = editor
        .scene
        .keyframes
        .iter()
        .map(|k| k.time_s)
        .fold(0.0_f64, f64::max)
        .max(clock.time_s)
        .max(10.0);
    ui.horizontal(|ui| {
        let label = if clock.playing { "Pause" } else { "Play" };
        if ui.button(label).clicked() {
            clock.playing = !clock.playing;
        }
        ui.add(egui::Slider::new(&mut clock.time_s, 0.0..=end_s).text("time, s"));
    });
    if !editor.scene.keyframes.is_empty() {
        ui.checkbox(&mut clock.keyframes, "Apply the keyframes")
            .on_hover_text("Editing a keyed value (sun, wind, rain intensity, stratus coverage) turns them off");
    }
}

/// One top-level section: a switch when the scene may leave it out, then
/// its parameters.
fn section_controls(
    ui: &mut egui::Ui,
    editor: &mut SceneEditor,
    state: &mut PanelState,
    section: &str,
) -> bool {
    let mut changed = false;
    if let Some(defaults) = optional_section(section) {
        let mut on = editor.doc.contains_key(section);
        if ui.checkbox(&mut on, format!("[{section}]")).changed() {
            changed = true;
            if on {
                let value = state.stashed_sections.remove(section).unwrap_or(defaults);
                editor.doc.insert(section.to_owned(), value);
            } else if let Some(value) = editor.doc.remove(section) {
                state.stashed_sections.insert(section.to_owned(), value);
            }
        }
    }
    let hidden: &[&str] = match section {
        "camera" => &CAMERA_POSE_KEYS,
        // The sun's keys are shown by `sun_controls` above them.
        _ => &[],
    };
    match editor.doc.get_mut(section) {
        Some(toml::Value::Table(table)) => {
            changed |= edit_table(ui, section, table, hidden);
        }
        Some(toml::Value::Array(items)) => {
            changed |= edit_array_of_tables(ui, section, items);
        }
        Some(_) => {}
        None if new_element(section).is_some()
            // An array of tables the scene leaves out (no objects, no keyframes).
            && ui.button(format!("Add {section}")).clicked() =>
        {
            if let Some(element) = new_element(section) {
                editor
                    .doc
                    .insert(section.to_owned(), toml::Value::Array(vec![element]));
                changed = true;
            }
        }
        None => {}
    }
    changed
}

/// The path of `key` in the table at `path`.
fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_owned()
    } else {
        format!("{path}.{key}")
    }
}

/// Widgets for every key of a table; buttons to set or unset optional keys.
fn edit_table(ui: &mut egui::Ui, path: &str, table: &mut toml::Table, hidden: &[&str]) -> bool {
    let mut changed = false;
    let keys: Vec<String> = table.keys().cloned().collect();
    let mut unset = None;
    for key in keys {
        if hidden.contains(&key.as_str()) {
            continue;
        }
        let key_path = join(path, &key);
        let optional = OPTIONAL_KEYS
            .iter()
            .any(|k| k.table == path && k.key == key);
        let Some(value) = table.get_mut(&key) else {
            continue;
        };
        match value {
            toml::Value::Table(inner) => {
                egui::CollapsingHeader::new(&key)
                    .id_salt(&key_path)
                    .show(ui, |ui| {
                        changed |= edit_table(ui, &key_path, inner, &[]);
                        if optional && ui.button(format!("Unset {key}")).clicked() {
                            unset = Some(key.clone());
                        }
                    });
            }
            toml::Value::Array(items)
                if items.iter().any(toml::Value::is_table) || new_element(&key_path).is_some() =>
            {
                egui::CollapsingHeader::new(format!("{key} ({})", items.len()))
                    .id_salt(&key_path)
                    .show(ui, |ui| {
                        changed |= edit_array_of_tables(ui, &key_path, items)
                    });
            }
            _ => {
                ui.horizontal(|ui| {
                    ui.label(&key);
                    changed |= edit_leaf(ui, &key_path, value);
                    if optional && ui.small_button("×").on_hover_text("unset").clicked() {
                        unset = Some(key.clone());
                    }
                });
            }
        }
    }
    if let Some(key) = unset {
        table.remove(&key);
        changed = true;
    }
    let missing: Vec<_> = OPTIONAL_KEYS
        .iter()
        .filter(|k| k.table == path && !table.contains_key(k.key))
        .collect();
    for optional in missing {
        if ui.small_button(format!("Set {}", optional.key)).clicked() {
            table.insert(optional.key.to_owned(), (optional.initial)());
            changed = true;
        }
    }
    changed
}

/// The elements of an array of tables, each removable, and a button to add one.
fn edit_array_of_tables(ui: &mut egui::Ui, path: &str, items: &mut Vec<toml::Value>) -> bool {
    let mut changed = false;
    let element_path = format!("{path}[]");
    let mut remove = None;
    for (index, item) in items.iter_mut().enumerate() {
        ui.push_id(index, |ui| {
            egui::CollapsingHeader::new(format!("{path} {index}")).show(ui, |ui| {
                if let toml::Value::Table(table) = item {
                    changed |= edit_table(ui, &element_path, table, &[]);
                }
                if ui.button("Remove").clicked() {
                    remove = Some(index);
                }
            });
        });
    }
    if let Some(index) = remove {
        items.remove(index);
        changed = true;
    }
    if ui.button("Add").clicked() {
        let mut element = items
            .last()
            .cloned()
            .or_else(|| new_element(path))
            .unwrap_or(toml::Value::Table(toml::Table::new()));
        // Keyframes must come in increasing time.
        if let (Some(toml::Value::Float(time)), Some(last)) = (
            element.get_mut("time_s"),
            items.last().and_then(|l| l.get("time_s")),
        ) {
            *time = last.as_float().unwrap_or(0.0) + 1.0;
        }
        items.push(element);
        changed = true;
    }
    changed
}

/// The widget of one value: slider, drag field, switch, choice or text.
fn edit_leaf(ui: &mut egui::Ui, path: &str, value: &mut toml::Value) -> bool {
    let slider = SLIDERS.iter().find(|(p, ..)| *p == path);
    match value {
        toml::Value::Float(x) => match slider {
            Some(&(_, lo, hi, log)) => ui
                .add(egui::Slider::new(x, lo..=hi).logarithmic(log))
                .changed(),
            None => {
                let speed = drag_speed(*x);
                ui.add(egui::DragValue::new(x).speed(speed)).changed()
            }
        },
        toml::Value::Integer(i) => match slider {
            Some(&(_, lo, hi, log)) => ui
                .add(egui::Slider::new(i, lo as i64..=hi as i64).logarithmic(log))
                .changed(),
            None => {
                let speed = (i.abs() as f64 / 100.0).max(0.2);
                ui.add(egui::DragValue::new(i).speed(speed)).changed()
            }
        },
        toml::Value::Boolean(b) => ui.checkbox(b, "").changed(),
        toml::Value::String(text) => match CHOICES.iter().find(|(p, _)| *p == path) {
            Some((_, choices)) => {
                let mut changed = false;
                egui::ComboBox::from_id_salt(path)
                    .selected_text(text.as_str())
                    .show_ui(ui, |ui| {
                        for choice in *choices {
                            changed |= ui
                                .selectable_value(text, (*choice).to_owned(), *choice)
                                .changed();
                        }
                    });
                changed
            }
            None => ui.text_edit_singleline(text).changed(),
        },
        toml::Value::Array(items) => {
            let mut changed = false;
            for (index, item) in items.iter_mut().enumerate() {
                ui.push_id(index, |ui| changed |= edit_leaf(ui, "", item));
            }
            changed
        }
        toml::Value::Datetime(datetime) => {
            ui.label(datetime.to_string());
            false
        }
        toml::Value::Table(_) => false,
    }
}

/// Drag speed for a number: about a two-hundredth of it per pixel.
fn drag_speed(x: f64) -> f64 {
    (x.abs() * 0.005).max(1e-3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_of_day_round_trips_with_its_date_and_zone() {
        let (date, hours, zone) = split_time_of_day("2026-06-21T14:30:36+02:00").expect("time");
        assert_eq!((date, zone), ("2026-06-21T", "+02:00"));
        assert!((hours - 14.51).abs() < 1e-12);
        assert_eq!(
            join_time_of_day(date, 18.25, zone),
            "2026-06-21T18:15:00+02:00"
        );
        let (_, hours, zone) = split_time_of_day("2026-06-21T05:07Z").expect("no seconds");
        assert_eq!(zone, "Z");
        assert!((hours - (5.0 + 7.0 / 60.0)).abs() < 1e-12);
        assert_eq!(join_time_of_day("d T", 23.9999999, "Z"), "d T23:59:59Z");
        assert!(split_time_of_day("2026-06-21").is_none());
    }

    #[test]
    fn slider_ranges_lie_within_what_validation_allows() {
        // Each slider's ends, written into the default scene with every
        // section on, must validate (so that a slider never leads to an error).
        let mut scene = nimbus_render::Scene::embedded_default();
        scene.rain.get_or_insert_default();
        scene.wind.get_or_insert_default();
        scene.cumulus.get_or_insert_default();
        scene.stratus.get_or_insert_default();
        for &(path, lo, hi, _) in SLIDERS {
            let (table_path, key) = path.rsplit_once('.').expect("dotted");
            for end in [lo, hi] {
                let mut doc = super::super::editor::scene_table(&scene).expect("table");
                // The sun by angles for angle keys, by date and place otherwise.
                let sun: toml::Table = if path.contains("latitude") || path.contains("longitude") {
                    toml::from_str(
                        "time_utc = \"2026-06-21T12:00:00Z\"\nlatitude_deg = 45.0\nlongitude_deg = 6.0",
                    )
                } else {
                    toml::from_str("azimuth_deg = 180.0\nelevation_deg = 30.0")
                }
                .expect("sun");
                doc.insert("sun".into(), toml::Value::Table(sun));
                if path.contains("latitude") || path.contains("longitude") {
                    // The default keyframes key the sun's angles.
                    doc.remove("keyframes");
                }
                if path.starts_with("keyframes") {
                    for keyframe in doc["keyframes"].as_array_mut().expect("keyframes") {
                        if let Some(k) = keyframe.as_table_mut() {
                            k.remove("sun_time_utc");
                        }
                    }
                }
                let target = match table_path.strip_suffix("[]") {
                    Some(array) => doc[array]
                        .as_array_mut()
                        .and_then(|a| a.first_mut())
                        .and_then(toml::Value::as_table_mut)
                        .expect("element"),
                    None => doc[table_path].as_table_mut().expect("section"),
                };
                let value = match target.get(key) {
                    Some(toml::Value::Integer(_)) => toml::Value::Integer(end as i64),
                    _ => toml::Value::Float(end),
                };
                target.insert(key.to_owned(), value);
                let text = toml::to_string(&doc).expect("text");
                if let Err(e) = nimbus_render::Scene::from_toml_str(&text, "slider") {
                    panic!("{path} = {end}: {e}");
                }
            }
        }
    }
}
