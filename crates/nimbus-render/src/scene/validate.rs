//! Scene errors and range validation.
//!
//! Every error is one line naming the file, the key (its dotted path), the
//! offending value and what is allowed, e.g.
//! `scene.toml: camera.fov_deg = 190: must be a finite number in [0.01, 179]`.

use super::Scene;
use nimbus_physics::io::shown_text as shown;
use std::fmt::Display;

/// What errors of a scene made in code name in place of a file ([`Scene::check`]).
pub const IN_CODE: &str = "scene";

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read (or was refused unread: not a regular
    /// file, too large, not UTF-8).
    #[error("{file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// Why, e.g. "cannot read: No such file or directory (os error 2)"
        /// or "is a named pipe (FIFO), not a regular file".
        message: String,
    },
    /// The text is not valid TOML.
    #[error("{file}: line {line}: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// 1-based line of the error.
        line: usize,
        /// The parser's message.
        message: String,
    },
    /// A key is unknown, or its value has the wrong type.
    #[error("{file}: {key}: {message} (line {line})")]
    Key {
        /// The file.
        file: String,
        /// Dotted path of the key.
        key: String,
        /// What is wrong, with the allowed keys or type.
        message: String,
        /// 1-based line of the key.
        line: usize,
    },
    /// A value is out of range or inconsistent with another.
    #[error("{file}: {key} = {value}: {allowed}")]
    Invalid {
        /// The file.
        file: String,
        /// Dotted path of the key.
        key: String,
        /// The value as given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
}

fn line_of(text: &str, span: Option<std::ops::Range<usize>>) -> usize {
    let offset = span.map_or(0, |s| s.start.min(text.len()));
    text.as_bytes()[..offset]
        .iter()
        .filter(|b| **b == b'\n')
        .count()
        + 1
}

fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Most characters of a value shown in an error line.
const MAX_SHOWN_CHARS: usize = nimbus_physics::io::MAX_SHOWN_CHARS;

/// Most characters of a parser's message in an error line.
const MAX_MESSAGE_CHARS: usize = 240;

/// `message` with each `quoted` value in it shortened (see [`shown`]).
fn shorten_quoted(message: &str) -> String {
    message
        .split('`')
        .enumerate()
        .map(|(i, part)| {
            if i % 2 == 1 {
                shown_value(part)
            } else {
                part.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("`")
}

/// A value as an error line shows it (see [`shown`]).
pub(super) fn shown_value(text: &str) -> String {
    shown(text, MAX_SHOWN_CHARS)
}

/// A number as an error line shows it: as written for everyday magnitudes,
/// in exponent form for very large or small ones (`1e308`, not 309 digits).
pub(super) fn shown_number(value: f64) -> String {
    let magnitude = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-4..1e15).contains(&magnitude) {
        value.to_string()
    } else {
        format!("{value:e}")
    }
}

/// A parser's message in words a scene's author knows: no Rust type names.
fn without_rust_types(message: &str) -> String {
    let mut out = message.replace(" as i128", "").replace(" as u128", "");
    for (rust, words) in [
        ("expected f64", "expected a number"),
        ("expected f32", "expected a number"),
        ("expected u8", "expected an integer in [0, 255]"),
        ("expected u16", "expected an integer in [0, 65535]"),
        ("expected u32", "expected an integer in [0, 4294967295]"),
        ("expected u64", "expected a non-negative integer"),
        ("expected usize", "expected a non-negative integer"),
        ("expected i32", "expected an integer"),
        ("expected i64", "expected an integer"),
        ("expected a boolean", "expected true or false"),
        ("expected bool", "expected true or false"),
        ("expected a sequence", "expected an array"),
        ("expected a map", "expected a table"),
    ] {
        out = out.replace(rust, words);
    }
    // `struct CameraSettings`, `enum Projection`: the type's name.
    for kind in ["struct ", "enum "] {
        while let Some(at) = out.find(kind) {
            let name_end = out[at + kind.len()..]
                .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .map_or(out.len(), |n| at + kind.len() + n);
            let words = if kind == "struct " {
                "a table"
            } else {
                "one of the allowed names"
            };
            out.replace_range(at..name_end, words);
        }
    }
    out
}

/// The text a number literal at `span` of `text` is replaced by to learn
/// the key's allowed range from the validator: the largest value of the
/// expected type, with the literal's sign. `None` when the message is not
/// about a number out of its type's range.
fn range_probe(message: &str, literal: &str) -> Option<String> {
    let negative = literal.trim_start().starts_with('-');
    if message.contains("overflowed") || message.contains("expected f64") {
        return Some(if negative { "-1.0e308" } else { "1.0e308" }.to_owned());
    }
    if !(message.contains("integer") || message.contains("floating point")) {
        return None;
    }
    for (rust, largest) in [
        ("expected u8", "255"),
        ("expected u16", "65535"),
        ("expected u32", "4294967295"),
        ("expected u64", "18446744073709551615"),
        ("expected usize", "18446744073709551615"),
    ] {
        if message.contains(rust) {
            return Some(largest.to_owned());
        }
    }
    None
}

impl SceneError {
    pub(super) fn syntax(file: &str, text: &str, error: &toml::de::Error) -> Self {
        Self::Syntax {
            file: file.to_owned(),
            line: line_of(text, error.span()),
            message: one_line(error.message()),
        }
    }

    pub(super) fn from_path_error(
        file: &str,
        text: &str,
        error: serde_path_to_error::Error<toml::de::Error>,
    ) -> Self {
        let key = error.path().to_string();
        let inner = error.inner();
        let raw = one_line(inner.message());
        let mut message = without_rust_types(&raw)
            .replace("unknown field", "unknown key")
            .replace(", expected one of", "; allowed keys:")
            .replace(", expected", "; expected");
        let span = inner
            .span()
            .filter(|s| s.end <= text.len() && s.start <= s.end);
        let literal = span
            .clone()
            .and_then(|s| text.get(s))
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('[') && !l.starts_with('{'));
        if let Some(literal) = literal {
            // The value, when the parser's message leaves it out (an
            // overflowed number), shortened and escaped.
            let bare = literal.trim_matches(|c| c == '"' || c == '\'');
            if !raw.contains(bare) {
                message = format!("{}: {message}", shown_value(literal));
            }
            // The allowed range, from the validator: the same file with the
            // literal replaced by its type's largest value fails the range
            // check of this key, whose message says what is allowed.
            if let (Some(probe), Some(span)) = (range_probe(&raw, literal), span) {
                let mut probed = text.to_owned();
                probed.replace_range(span, &probe);
                if let Err(Self::Invalid {
                    key: probed_key,
                    allowed,
                    ..
                }) = super::Scene::from_toml_str(&probed, file)
                    && probed_key == key
                {
                    message = format!("{message}; {allowed}");
                }
            }
        }
        let key = if key == "." {
            "(top level)".to_owned()
        } else {
            key
        };
        Self::Key {
            file: file.to_owned(),
            key,
            message: shown(&shorten_quoted(&message), MAX_MESSAGE_CHARS),
            line: line_of(text, inner.span()),
        }
    }
}

/// Collects range checks against one file, stopping at the first failure.
pub(super) struct Checker<'a> {
    pub(super) file: &'a str,
    /// Read the files the scene refers to (glTF meshes, wind fields) to
    /// check them; off for [`Scene::check`], which must not touch the disk.
    pub(super) read_files: bool,
}

impl Checker<'_> {
    pub(super) fn invalid(
        &self,
        key: &str,
        value: impl Display,
        allowed: impl Into<String>,
    ) -> SceneError {
        SceneError::Invalid {
            file: self.file.to_owned(),
            key: key.to_owned(),
            value: shown_value(&value.to_string()),
            // Messages may quote the file (a date-time, a mesh's error):
            // escaped so the error stays one line.
            allowed: shown(&allowed.into(), usize::MAX),
        }
    }

    /// `lo <= value <= hi`, and finite.
    pub(super) fn closed(&self, key: &str, value: f64, lo: f64, hi: f64) -> Result<(), SceneError> {
        if value.is_finite() && value >= lo && value <= hi {
            Ok(())
        } else {
            Err(self.invalid(
                key,
                shown_number(value),
                format!("must be a finite number in [{lo}, {hi}]"),
            ))
        }
    }

    pub(super) fn integer(
        &self,
        key: &str,
        value: u64,
        lo: u64,
        hi: u64,
    ) -> Result<(), SceneError> {
        if (lo..=hi).contains(&value) {
            Ok(())
        } else {
            Err(self.invalid(key, value, format!("must be an integer in [{lo}, {hi}]")))
        }
    }

    pub(super) fn vector(
        &self,
        key: &str,
        value: &[f64],
        lo: f64,
        hi: f64,
    ) -> Result<(), SceneError> {
        if value.iter().all(|v| v.is_finite() && *v >= lo && *v <= hi) {
            Ok(())
        } else {
            // Debug writes extreme magnitudes in exponent form (1e300).
            Err(self.invalid(
                key,
                format!("{value:?}"),
                format!("each component must be a finite number in [{lo}, {hi}]"),
            ))
        }
    }
}

/// Narrowest vertical field of view, degrees.
pub const MIN_FOV_DEG: f64 = 0.01;

/// World coordinates are bounded so that f32 positions on the GPU keep
/// sub-metre precision.
pub(super) const MAX_COORDINATE_M: f64 = 1.0e6;

impl Scene {
    fn validate_sun(&self, c: &Checker<'_>) -> Result<(), SceneError> {
        let sun = &self.sun;
        if let Some(azimuth) = sun.azimuth_deg {
            c.closed("sun.azimuth_deg", azimuth, 0.0, 360.0)?;
        }
        if let Some(elevation) = sun.elevation_deg {
            c.closed("sun.elevation_deg", elevation, -90.0, 90.0)?;
        }
        if let Some(latitude) = sun.latitude_deg {
            c.closed("sun.latitude_deg", latitude, -90.0, 90.0)?;
        }
        if let Some(longitude) = sun.longitude_deg {
            c.closed("sun.longitude_deg", longitude, -180.0, 180.0)?;
        }
        let by_angles = sun.azimuth_deg.is_some() || sun.elevation_deg.is_some();
        let by_place =
            sun.time_utc.is_some() || sun.latitude_deg.is_some() || sun.longitude_deg.is_some();
        if by_angles && by_place {
            let key = if sun.time_utc.is_some() {
                "sun.time_utc"
            } else {
                "sun.latitude_deg"
            };
            let value = sun
                .time_utc
                .clone()
                .map(|t| format!("{t:?}"))
                .unwrap_or_else(|| format!("{:?}", sun.latitude_deg.or(sun.longitude_deg)));
            return Err(c.invalid(key, value, "must not be combined with azimuth_deg/elevation_deg: give the sun either by angles or by time and place"));
        }
        if by_place {
            match &sun.time_utc {
                None => return Err(c.invalid("sun.time_utc", "(missing)", "must be given with latitude_deg and longitude_deg, e.g. \"2026-06-21T12:00:00Z\"")),
                Some(time) => {
                    if let Err(message) = nimbus_physics::sky::UtcDateTime::parse(time) {
                        return Err(c.invalid("sun.time_utc", format!("{time:?}"), format!("must be an ISO 8601 date-time: {message}")));
                    }
                }
            }
            if sun.latitude_deg.is_none() || sun.longitude_deg.is_none() {
                let key = if sun.latitude_deg.is_none() {
                    "sun.latitude_deg"
                } else {
                    "sun.longitude_deg"
                };
                return Err(c.invalid(
                    key,
                    "(missing)",
                    "must be given with sun.time_utc (degrees north / east)",
                ));
            }
        } else if sun.azimuth_deg.is_some() != sun.elevation_deg.is_some() {
            let key = if sun.azimuth_deg.is_none() {
                "sun.azimuth_deg"
            } else {
                "sun.elevation_deg"
            };
            return Err(c.invalid(
                key,
                "(missing)",
                "must be given together with the other sun angle",
            ));
        }
        Ok(())
    }

    /// Checks a scene made in code (no file): the range and consistency
    /// checks of [`Self::validate`], each error's line naming [`IN_CODE`]
    /// where a file's errors name the file, e.g.
    /// `scene: camera.fov_deg = 190: must be a finite number in [0.01, 179]`. It reads no
    /// file (the files a scene refers to are read, and their errors
    /// reported, by the passes that load them), so the renderer's `prepare`
    /// runs it on every scene it is given.
    pub fn check(&self) -> Result<(), SceneError> {
        self.validate_with(&Checker {
            file: IN_CODE,
            read_files: false,
        })
    }

    /// Checks every value against its documented range; `file` names the
    /// scene in the errors.
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        self.validate_with(&Checker {
            file,
            read_files: true,
        })
    }

    fn validate_with(&self, c: &Checker<'_>) -> Result<(), SceneError> {
        let side = super::MAX_IMAGE_SIDE_PX as u64;
        c.integer("image.width", self.image.width as u64, 1, side)?;
        c.integer("image.height", self.image.height as u64, 1, side)?;
        let pixels = self.image.width as u64 * self.image.height as u64;
        if pixels > super::MAX_IMAGE_PIXELS {
            return Err(c.invalid(
                "image",
                format!("{}×{}", self.image.width, self.image.height),
                format!(
                    "width × height must be at most {} pixels",
                    super::MAX_IMAGE_PIXELS
                ),
            ));
        }

        let cam = &self.camera;
        c.vector(
            "camera.position_m",
            &cam.position_m,
            -MAX_COORDINATE_M,
            MAX_COORDINATE_M,
        )?;
        if let Some(target) = &cam.look_at_m {
            c.vector(
                "camera.look_at_m",
                target,
                -MAX_COORDINATE_M,
                MAX_COORDINATE_M,
            )?;
            if cam.yaw_deg.is_some() || cam.pitch_deg.is_some() {
                return Err(c.invalid(
                    "camera.look_at_m",
                    format!("{target:?}"),
                    "give either look_at_m or yaw_deg/pitch_deg, not both",
                ));
            }
            if let Some(why) = super::animation::degenerate_look_at(cam.position_m, *target) {
                return Err(c.invalid("camera.look_at_m", format!("{target:?}"), why));
            }
        }
        if let Some(yaw) = cam.yaw_deg {
            c.closed("camera.yaw_deg", yaw, -360.0, 360.0)?;
        }
        if let Some(pitch) = cam.pitch_deg {
            c.closed("camera.pitch_deg", pitch, -89.0, 89.0)?;
        }
        // 0.01° (a 14 m lens on full frame) keeps the projection's f32
        // terms finite; an open (0, 179) range let 1e-200 through.
        c.closed("camera.fov_deg", cam.fov_deg, MIN_FOV_DEG, 179.0)?;
        c.closed("camera.exposure_ev100", cam.exposure_ev100, -10.0, 30.0)?;
        c.closed(
            "camera.exposure_compensation_ev",
            cam.exposure_compensation_ev,
            -10.0,
            10.0,
        )?;
        c.closed("camera.adaptation_time_s", cam.adaptation_time_s, 0.0, 60.0)?;

        self.validate_sun(c)?;
        self.validate_keyframes(c)?;
        let a = &self.atmosphere;
        c.closed(
            "atmosphere.bottom_radius_m",
            a.bottom_radius_m,
            1.0e5,
            1.0e8,
        )?;
        if !(a.top_radius_m.is_finite()
            && a.top_radius_m > a.bottom_radius_m
            && a.top_radius_m <= 2.0 * a.bottom_radius_m)
        {
            return Err(c.invalid(
                "atmosphere.top_radius_m",
                a.top_radius_m,
                format!(
                    "must be a finite number in ({}, {}] (above bottom_radius_m, at most twice it)",
                    a.bottom_radius_m,
                    2.0 * a.bottom_radius_m
                ),
            ));
        }
        c.vector(
            "atmosphere.rayleigh_scattering_per_m",
            &a.rayleigh_scattering_per_m,
            0.0,
            1.0e-3,
        )?;
        c.closed(
            "atmosphere.rayleigh_scale_height_m",
            a.rayleigh_scale_height_m,
            100.0,
            100_000.0,
        )?;
        c.closed(
            "atmosphere.aerosol_optical_depth",
            a.aerosol_optical_depth,
            0.0,
            5.0,
        )?;
        c.closed(
            "atmosphere.aerosol_angstrom_exponent",
            a.aerosol_angstrom_exponent,
            -1.0,
            4.0,
        )?;
        c.closed(
            "atmosphere.aerosol_single_scattering_albedo",
            a.aerosol_single_scattering_albedo,
            0.0,
            1.0,
        )?;
        c.closed(
            "atmosphere.aerosol_scale_height_m",
            a.aerosol_scale_height_m,
            10.0,
            100_000.0,
        )?;
        c.closed(
            "atmosphere.aerosol_asymmetry",
            a.aerosol_asymmetry,
            -0.99,
            0.99,
        )?;
        c.vector(
            "atmosphere.ozone_absorption_per_m",
            &a.ozone_absorption_per_m,
            0.0,
            1.0e-3,
        )?;
        c.closed(
            "atmosphere.ozone_peak_altitude_m",
            a.ozone_peak_altitude_m,
            0.0,
            1.0e6,
        )?;
        c.closed(
            "atmosphere.ozone_half_width_m",
            a.ozone_half_width_m,
            1.0,
            1.0e6,
        )?;
        c.vector("atmosphere.ground_albedo", &a.ground_albedo, 0.0, 1.0)?;

        let t = &self.terrain;
        c.closed("terrain.extent_m", t.extent_m, 100.0, MAX_COORDINATE_M)?;
        c.closed("terrain.height_scale_m", t.height_scale_m, 0.0, 10_000.0)?;
        c.closed(
            "terrain.feature_wavelength_m",
            t.feature_wavelength_m,
            10.0,
            MAX_COORDINATE_M,
        )?;
        c.integer(
            "terrain.resolution",
            t.resolution as u64,
            16,
            super::MAX_TERRAIN_RESOLUTION as u64,
        )?;
        c.closed(
            "terrain.water_level_m",
            t.water_level_m,
            -10_000.0,
            10_000.0,
        )?;
        c.closed("terrain.sand_band_m", t.sand_band_m, 0.0, 1_000.0)?;
        c.closed("terrain.snow_line_m", t.snow_line_m, -10_000.0, 100_000.0)?;
        c.closed("terrain.rock_slope_deg", t.rock_slope_deg, 0.0, 90.0)?;
        for (name, rgb) in t.albedo.named() {
            let rgb = rgb.map(f64::from);
            c.vector(&format!("terrain.albedo.{name}"), &rgb, 0.0, 1.0)?;
        }

        let g = &self.ground;
        c.vector("ground.albedo", &g.albedo, 0.0, 1.0)?;
        c.closed("ground.height_m", g.height_m, -10_000.0, 10_000.0)?;
        if let Some(map) = &g.albedo_map {
            let map = map.map();
            let texels = u64::from(map.width) * u64::from(map.height);
            if map.width == 0 || map.height == 0 || map.width > 4096 || map.height > 4096 {
                return Err(c.invalid(
                    "ground.albedo_map",
                    format!("{} × {} texels", map.width, map.height),
                    "1 to 4096 texels on each side",
                ));
            }
            if map.texels.len() as u64 != texels {
                return Err(c.invalid(
                    "ground.albedo_map",
                    format!("{} texels", map.texels.len()),
                    format!("width × height = {texels}"),
                ));
            }
            if let Some((i, t)) = map
                .texels
                .iter()
                .enumerate()
                .find(|(_, t)| !t.iter().all(|a| (0.0..=1.0).contains(a)))
            {
                return Err(c.invalid(
                    &format!("ground.albedo_map texel {i}"),
                    format!("{t:?}"),
                    "each channel in [0, 1]",
                ));
            }
        }

        if let Some(cu) = &self.cumulus {
            c.closed("cumulus.coverage", cu.coverage, 0.0, 1.0)?;
            c.closed("cumulus.base_m", cu.base_m, 0.0, 10_000.0)?;
            if let Some(area) = cu.area_m {
                c.closed("cumulus.area_m", area, 1_000.0, MAX_COORDINATE_M)?;
            }
            c.vector("cumulus.scale_range", &cu.scale_range, 0.1, 5.0)?;
            if cu.scale_range[0] > cu.scale_range[1] {
                return Err(c.invalid(
                    "cumulus.scale_range",
                    format!("{:?}", cu.scale_range),
                    "[smallest, largest] with smallest ≤ largest",
                ));
            }
            c.integer("cumulus.variants", cu.variants as u64, 1, 8)?;
            c.integer("cumulus.levels_of_detail", cu.levels_of_detail as u64, 1, 5)?;
            c.integer(
                "cumulus.clouds",
                cu.clouds.len() as u64,
                0,
                super::MAX_CLOUDS as u64,
            )?;
            for (i, cloud) in cu.clouds.iter().enumerate() {
                let key = |name: &str| format!("cumulus.clouds[{i}].{name}");
                c.vector(
                    &key("position_m"),
                    &cloud.position_m,
                    -MAX_COORDINATE_M,
                    MAX_COORDINATE_M,
                )?;
                c.closed(&key("yaw_deg"), cloud.yaw_deg, -360.0, 360.0)?;
                c.closed(&key("scale"), cloud.scale, 0.1, 5.0)?;
                c.integer(
                    &key("variant"),
                    cloud.variant as u64,
                    0,
                    cu.variants.saturating_sub(1) as u64,
                )?;
            }
            let s = &cu.shading;
            for (name, value, lo, hi) in [
                ("ambient", s.ambient, 0.0, 10.0),
                ("lambert", s.lambert, 0.0, 10.0),
                ("light_traps", s.light_traps, 0.0, 10.0),
                ("transmission", s.transmission, 0.0, 10.0),
                ("diffusion", s.diffusion, 0.0, 10.0),
                ("forward_peak", s.forward_peak, 0.0, 10.0),
                ("transmission_gain", s.transmission_gain, 0.0, 100.0),
                ("bump", s.bump, 0.0, 1.0),
                ("normal_smoothing", s.normal_smoothing, 0.0, 100.0),
                ("trap_width", s.trap_width, 0.0, 100.0),
                ("trap_height", s.trap_height, 0.0, 1.0),
                ("corona_thickness_m", s.corona_thickness_m, 0.1, 1_000.0),
            ] {
                c.closed(&format!("cumulus.shading.{name}"), value, lo, hi)?;
            }
            // Positive, with usable lower limits (issue 28: an open range
            // admits 1e-300, which overflows the shader's powers and divisions).
            for (name, value, lo, hi) in [
                ("forward_width", s.forward_width, 1e-3, 100.0),
                ("density_per_m", s.density_per_m, 1e-6, 10.0),
                ("trap_sharpness", s.trap_sharpness, 1e-3, 100.0),
            ] {
                c.closed(&format!("cumulus.shading.{name}"), value, lo, hi)?;
            }
            c.integer("cumulus.shading.bump_octaves", s.bump_octaves as u64, 0, 6)?;
        }
        if let Some(st) = &self.stratus {
            c.closed("stratus.base_m", st.base_m, 0.0, 15_000.0)?;
            c.closed("stratus.thickness_m", st.thickness_m, 1.0, 2_000.0)?;
            c.closed("stratus.coverage", st.coverage, 0.0, 1.0)?;
            c.closed(
                "stratus.feature_size_m",
                st.feature_size_m,
                100.0,
                100_000.0,
            )?;
            c.integer("stratus.detail", st.detail as u64, 1, 8)?;
            c.closed("stratus.evolution_time_s", st.evolution_time_s, 10.0, 1e6)?;
            c.closed(
                "stratus.effective_radius_um",
                st.effective_radius_um,
                1.0,
                50.0,
            )?;
            c.closed(
                "stratus.droplet_concentration_cm3",
                st.droplet_concentration_cm3,
                1.0,
                5_000.0,
            )?;
            c.closed("stratus.extent_m", st.extent_m, 1_000.0, 400_000.0)?;
            c.integer("stratus.resolution", st.resolution as u64, 16, 2048)?;
            c.integer(
                "stratus.radiosity_iterations",
                st.radiosity_iterations as u64,
                0,
                32,
            )?;
        }
        if let Some(wind) = &self.wind {
            c.closed("wind.speed_m_s", wind.speed_m_s, 0.0, 100.0)?;
            c.closed("wind.from_deg", wind.from_deg, 0.0, 360.0)?;
        }
        self.validate_objects(c)?;
        self.validate_rain(c)?;
        Ok(())
    }
}

impl Scene {
    /// Rejects arrays whose length differs from what their key holds: a
    /// fixed-size array (a position, a colour) is read from the first
    /// values of a longer TOML array and the rest silently dropped. Each
    /// array of the file is compared with the same key of the scene as read,
    /// written back (fixed arrays come back at their own length; lists at
    /// the length given).
    pub(super) fn check_array_lengths(&self, text: &str, file: &str) -> Result<(), SceneError> {
        let (Ok(given), Ok(toml::Value::Table(read))) = (
            toml::from_str::<toml::Table>(text),
            toml::Value::try_from(self),
        ) else {
            return Ok(());
        };
        match first_length_mismatch(&given, &read, "") {
            None => Ok(()),
            Some((key, found, expected)) => {
                let last = key.rsplit(['.', ']']).next().unwrap_or(&key).to_owned();
                let line = text
                    .lines()
                    .position(|l| {
                        let l = l.trim_start();
                        l.strip_prefix(last.as_str())
                            .is_some_and(|rest| rest.trim_start().starts_with('='))
                    })
                    .map_or(1, |i| i + 1);
                Err(SceneError::Key {
                    file: file.to_owned(),
                    key,
                    message: format!("{found} values; expected {expected}"),
                    line,
                })
            }
        }
    }
}

/// The first key (dotted, arrays of tables indexed) whose array in `given`
/// has another length than in `read`: (key, length given, length read).
fn first_length_mismatch(
    given: &toml::Table,
    read: &toml::Table,
    prefix: &str,
) -> Option<(String, usize, usize)> {
    for (name, value) in given {
        let Some(read_value) = read.get(name) else {
            continue;
        };
        let key = if prefix.is_empty() {
            name.clone()
        } else {
            format!("{prefix}.{name}")
        };
        let found = match (value, read_value) {
            (toml::Value::Table(g), toml::Value::Table(r)) => first_length_mismatch(g, r, &key),
            (toml::Value::Array(g), toml::Value::Array(r)) if g.len() != r.len() => {
                Some((key, g.len(), r.len()))
            }
            (toml::Value::Array(g), toml::Value::Array(r)) => {
                g.iter()
                    .zip(r)
                    .enumerate()
                    .find_map(|(i, pair)| match pair {
                        (toml::Value::Table(g), toml::Value::Table(r)) => {
                            first_length_mismatch(g, r, &format!("{key}[{i}]"))
                        }
                        _ => None,
                    })
            }
            _ => None,
        };
        if found.is_some() {
            return found;
        }
    }
    None
}
