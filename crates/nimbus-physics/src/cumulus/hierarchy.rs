//! The blob hierarchy of a cumulus (Bouthors & Neyret 2004, §3 and §5):
//! root blobs given or generated, then each further level sampled by
//! particles on the surface of the level below, its radius a third of the
//! parent level's, ±30 %, its flattening random in [0.1, 1].

use super::field::{Blob, BlobField, Floor, LevelBlend};
use super::sampler::{SamplerSettings, SamplingReport, sample_surface};
use crate::transport::rng::Rng;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A root blob as the user gives it (JSON or scene file).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RootBlob {
    /// Centre (x east, y up, z south), m.
    pub centre_m: [f64; 3],
    /// Radius, m.
    pub radius_m: f64,
    /// Flattening e in [0, 1] (the top reaches r / (1 + e) above the centre).
    #[serde(default = "default_root_flattening")]
    pub flattening: f64,
}

fn default_root_flattening() -> f64 {
    0.3
}

/// Most root blobs a hierarchy takes (given in a roots file or a scene).
pub const MAX_ROOT_BLOBS: usize = 1000;

/// A roots file that cannot be read: where in the document, and why.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
#[error(
    "{path}: {message} (each root is {{\"centre_m\": [x, y, z], \"radius_m\": r, \"flattening\": e}})"
)]
pub struct RootsJsonError {
    /// The place in the document (`[3].radius_m`, or `.` for the whole).
    pub path: String,
    /// What is wrong there.
    pub message: String,
}

/// Reads root blobs from JSON: a list of roots, or an object whose `roots`
/// key holds the list (the hierarchy file `nimbus cumulus` writes; its other
/// keys are skipped).
///
/// The document is parsed as it streams: a list longer than
/// [`MAX_ROOT_BLOBS`] is refused at its 1001st element, and skipped keys
/// are walked without being kept, so no document makes the reader hold more
/// than a thousand roots whatever its size or counts.
pub fn roots_from_json(text: &str) -> Result<Vec<RootBlob>, RootsJsonError> {
    let mut deserializer = serde_json::Deserializer::from_str(text);
    // Paths and messages quote the document's keys: shown as error lines
    // show file text (escaped, shortened), so the error stays one line.
    let shown = |text: String, max_chars| crate::io::shown_text(&text, max_chars);
    let roots =
        serde_path_to_error::deserialize::<_, RootsDocument>(&mut deserializer).map_err(|e| {
            RootsJsonError {
                path: shown(e.path().to_string(), crate::io::MAX_SHOWN_CHARS),
                message: shown(e.inner().to_string(), 4 * crate::io::MAX_SHOWN_CHARS),
            }
        })?;
    deserializer.end().map_err(|e| RootsJsonError {
        path: ".".to_owned(),
        message: e.to_string(),
    })?;
    Ok(roots.0)
}

/// The roots of a roots document, at most [`MAX_ROOT_BLOBS`] of them.
struct RootsDocument(Vec<RootBlob>);

/// The list itself, refused past [`MAX_ROOT_BLOBS`] while it is parsed.
struct BoundedRoots(Vec<RootBlob>);

impl<'de> Deserialize<'de> for BoundedRoots {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = BoundedRoots;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "a list of at most {MAX_ROOT_BLOBS} roots")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Self::Value, A::Error> {
                let mut roots = Vec::new();
                while let Some(root) = seq.next_element::<RootBlob>()? {
                    if roots.len() == MAX_ROOT_BLOBS {
                        return Err(serde::de::Error::custom(format!(
                            "more than {MAX_ROOT_BLOBS} roots (a hierarchy takes 1 to {MAX_ROOT_BLOBS})"
                        )));
                    }
                    roots.push(root);
                }
                Ok(BoundedRoots(roots))
            }
        }
        deserializer.deserialize_seq(Visitor)
    }
}

impl<'de> Deserialize<'de> for RootsDocument {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = RootsDocument;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "a list of roots, or an object with a \"roots\" list")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                seq: A,
            ) -> Result<Self::Value, A::Error> {
                let list =
                    BoundedRoots::deserialize(serde::de::value::SeqAccessDeserializer::new(seq))?;
                Ok(RootsDocument(list.0))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<Self::Value, A::Error> {
                let mut roots = None;
                while let Some(key) = map.next_key::<std::borrow::Cow<'de, str>>()? {
                    if key == "roots" {
                        if roots.is_some() {
                            return Err(serde::de::Error::duplicate_field("roots"));
                        }
                        roots = Some(map.next_value::<BoundedRoots>()?.0);
                    } else {
                        map.next_value::<serde::de::IgnoredAny>()?;
                    }
                }
                roots
                    .map(RootsDocument)
                    .ok_or_else(|| serde::de::Error::missing_field("roots"))
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

/// Where the roots come from.
#[derive(Clone, Debug, PartialEq)]
pub enum Roots {
    /// Given blobs.
    Given(Vec<RootBlob>),
    /// `count` blobs at random over a horizontal disc sized to hold them.
    Random {
        /// Number of root blobs.
        count: u32,
    },
}

/// Parameters of the hierarchy; the defaults are the paper's (§5).
#[derive(Clone, Debug, PartialEq)]
pub struct CumulusParams {
    /// The roots.
    pub roots: Roots,
    /// Levels generated on top of the roots (the paper: 2).
    pub generated_levels: u32,
    /// Radius of a level over its parent level's (1/3).
    pub radius_ratio: f64,
    /// Random spread of radii and desired energies (±0.3).
    pub radius_variation: f64,
    /// Range of the random flattening of generated blobs ([0.1, 1]).
    pub flattening_range: [f64; 2],
    /// Range of random root radii, m ([200, 450]).
    pub root_radius_range_m: [f64; 2],
    /// ε, the furrow offset (0.5).
    pub furrow_offset: f64,
    /// b per level, the last value repeated for deeper levels ([0, 0, 1]).
    pub blending: Vec<f64>,
    /// I (10).
    pub blend_sharpness: f64,
    /// h₀, m; `None`: the centre height of the lowest root.
    pub floor_height_m: Option<f64>,
    /// α_h, m (100).
    pub floor_stiffness_m: f64,
    /// Random seed.
    pub seed: u64,
}

impl Default for CumulusParams {
    fn default() -> Self {
        Self {
            roots: Roots::Given(paper_roots()),
            generated_levels: 2,
            radius_ratio: 1.0 / 3.0,
            radius_variation: 0.3,
            flattening_range: [0.1, 1.0],
            root_radius_range_m: [200.0, 450.0],
            furrow_offset: 0.5,
            blending: vec![0.0, 0.0, 1.0],
            blend_sharpness: 10.0,
            floor_height_m: None,
            floor_stiffness_m: 100.0,
            seed: 1,
        }
    }
}

/// Six hand-placed roots of 200–450 m in the spirit of the paper's figure 2:
/// a tall central tower, a shoulder on each side and lower blobs around the
/// base, all sitting on the floor at 100 m.
pub fn paper_roots() -> Vec<RootBlob> {
    let root = |x: f64, y: f64, z: f64, r: f64, e: f64| RootBlob {
        centre_m: [x, y, z],
        radius_m: r,
        flattening: e,
    };
    vec![
        root(0.0, 420.0, 0.0, 450.0, 0.2),
        root(-520.0, 260.0, 80.0, 380.0, 0.4),
        root(500.0, 230.0, -60.0, 360.0, 0.5),
        root(-120.0, 150.0, 430.0, 300.0, 0.6),
        root(180.0, 100.0, -420.0, 260.0, 0.7),
        root(-850.0, 120.0, -250.0, 200.0, 0.8),
    ]
}

/// Errors in the parameters.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum CumulusError {
    /// A value out of its range.
    #[error("{key} = {value}: {allowed}")]
    OutOfRange {
        /// The parameter.
        key: String,
        /// Its value.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
}

/// One level of the result.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelSummary {
    /// Blob count.
    pub count: usize,
    /// Mean radius, m.
    pub mean_radius_m: f64,
    /// The sampler's report (`None` for the roots).
    pub sampling: Option<SamplingReport>,
}

/// The built hierarchy: its field (levels 0..=L) and what each level holds.
pub struct Cumulus {
    /// The field of all levels.
    pub field: BlobField,
    /// Per level.
    pub levels: Vec<LevelSummary>,
}

/// Progress of [`build`]: level being sampled, iteration, particle count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildProgress {
    /// Level being built (1-based among the generated ones).
    pub level: u32,
    /// Sampler iteration.
    pub iteration: u32,
    /// Current particle count.
    pub particles: usize,
}

impl CumulusParams {
    /// Checks every value; the message names the parameter.
    pub fn validate(&self) -> Result<(), CumulusError> {
        let bad = |key: &str, value: String, allowed| {
            Err(CumulusError::OutOfRange {
                key: key.to_string(),
                value,
                allowed,
            })
        };
        match &self.roots {
            Roots::Given(roots) => {
                if roots.is_empty() || roots.len() > MAX_ROOT_BLOBS {
                    return bad("roots", roots.len().to_string(), "1 to 1000 root blobs");
                }
                for (i, r) in roots.iter().enumerate() {
                    if !(r.radius_m.is_finite() && r.radius_m >= 10.0 && r.radius_m <= 5000.0) {
                        return bad(
                            &format!("roots[{i}].radius_m"),
                            r.radius_m.to_string(),
                            "10 to 5000 m",
                        );
                    }
                    if !(0.0..=1.0).contains(&r.flattening) {
                        return bad(
                            &format!("roots[{i}].flattening"),
                            r.flattening.to_string(),
                            "0 to 1",
                        );
                    }
                    if r.centre_m.iter().any(|c| !c.is_finite() || c.abs() > 1e6) {
                        return bad(
                            &format!("roots[{i}].centre_m"),
                            format!("{:?}", r.centre_m),
                            "finite, within 1000 km",
                        );
                    }
                }
            }
            Roots::Random { count } => {
                if !(1..=200).contains(count) {
                    return bad("root_count", count.to_string(), "1 to 200");
                }
            }
        }
        if self.generated_levels > 3 {
            return bad(
                "levels",
                self.generated_levels.to_string(),
                "0 to 3 generated levels",
            );
        }
        if !(self.radius_ratio > 0.05 && self.radius_ratio < 0.8) {
            return bad("radius_ratio", self.radius_ratio.to_string(), "0.05 to 0.8");
        }
        if !(0.0..0.9).contains(&self.radius_variation) {
            return bad(
                "radius_variation",
                self.radius_variation.to_string(),
                "0 to 0.9",
            );
        }
        if !(self.floor_stiffness_m > 0.0 && self.floor_stiffness_m.is_finite()) {
            return bad(
                "floor_stiffness_m",
                self.floor_stiffness_m.to_string(),
                "a positive length",
            );
        }
        Ok(())
    }

    fn blending_at(&self, level: usize) -> f64 {
        self.blending
            .get(level)
            .or(self.blending.last())
            .copied()
            .unwrap_or(0.0)
    }

    fn blend(&self, level: usize) -> LevelBlend {
        LevelBlend {
            furrow_offset: self.furrow_offset,
            blending: self.blending_at(level),
            blend_sharpness: self.blend_sharpness,
        }
    }

    /// The root blobs (drawn from the seed when random).
    pub fn root_blobs(&self, rng: &mut Rng) -> Vec<Blob> {
        match &self.roots {
            Roots::Given(roots) => roots
                .iter()
                .map(|r| Blob {
                    centre_m: DVec3::from_array(r.centre_m),
                    radius_m: r.radius_m,
                    flattening: r.flattening,
                })
                .collect(),
            Roots::Random { count } => {
                // A disc holding the blobs side by side with some overlap,
                // centres at up to half a radius above the floor.
                let [r_min, r_max] = self.root_radius_range_m;
                let mean = 0.5 * (r_min + r_max);
                let disc = mean * (*count as f64).sqrt();
                (0..*count)
                    .map(|_| {
                        let radius = r_min + (r_max - r_min) * rng.uniform();
                        let a = std::f64::consts::TAU * rng.uniform();
                        let d = disc * rng.uniform().sqrt();
                        Blob {
                            centre_m: DVec3::new(
                                d * a.cos(),
                                0.5 * radius * rng.uniform(),
                                d * a.sin(),
                            ),
                            radius_m: radius,
                            flattening: 0.1 + 0.6 * rng.uniform(),
                        }
                    })
                    .collect()
            }
        }
    }
}

/// Builds the hierarchy.
pub fn build(
    params: &CumulusParams,
    mut progress: impl FnMut(BuildProgress),
) -> Result<Cumulus, CumulusError> {
    params.validate()?;
    let mut rng = Rng::new(params.seed, 0xc0ffee);
    let roots = params.root_blobs(&mut rng);
    let floor_height = params.floor_height_m.unwrap_or_else(|| {
        roots
            .iter()
            .map(|b| b.centre_m.y)
            .fold(f64::INFINITY, f64::min)
    });
    let mut field = BlobField::new(Floor {
        height_m: floor_height,
        stiffness_m: params.floor_stiffness_m,
    });
    let mean =
        |blobs: &[Blob]| blobs.iter().map(|b| b.radius_m).sum::<f64>() / blobs.len().max(1) as f64;
    let mut levels = vec![LevelSummary {
        count: roots.len(),
        mean_radius_m: mean(&roots),
        sampling: None,
    }];
    field.push_level(roots, params.blend(0));
    let settings = SamplerSettings {
        variation: params.radius_variation,
        ..SamplerSettings::default()
    };
    for level in 1..=params.generated_levels as usize {
        let parent = level - 1;
        let parent_blobs = field.blobs(parent).to_vec();
        let target = params.radius_ratio * field.mean_radius_m(parent);
        // Seeds: about as many per parent blob as its sphere holds
        // particles of the target size, at random around it (the sampler
        // projects them on the surface, kills the crowded, splits into the
        // empty).
        let mut seeds = Vec::new();
        for b in &parent_blobs {
            let k = ((b.radius_m / target).powi(2) * 1.5)
                .ceil()
                .clamp(4.0, 400.0) as usize;
            for _ in 0..k {
                let z = 2.0 * rng.uniform() - 1.0;
                let a = std::f64::consts::TAU * rng.uniform();
                let s = (1.0 - z * z).sqrt();
                seeds.push(b.centre_m + DVec3::new(s * a.cos(), z, s * a.sin()) * b.radius_m);
            }
        }
        let potential = |p: DVec3| field.sample(parent, p).potential;
        let (particles, report) = sample_surface(
            &potential,
            &seeds,
            target,
            &settings,
            &mut rng,
            |iteration, count| {
                progress(BuildProgress {
                    level: level as u32,
                    iteration,
                    particles: count,
                })
            },
        );
        let [e_min, e_max] = params.flattening_range;
        let blobs: Vec<Blob> = particles
            .iter()
            .map(|p| Blob {
                centre_m: p.position_m,
                radius_m: p.radius_m,
                flattening: e_min + (e_max - e_min) * rng.uniform(),
            })
            .collect();
        levels.push(LevelSummary {
            count: blobs.len(),
            mean_radius_m: mean(&blobs),
            sampling: Some(report),
        });
        field.push_level(blobs, params.blend(level));
    }
    Ok(Cumulus { field, levels })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_files_are_lists_or_hierarchies_and_bounded_while_parsed() {
        let one = r#"{"centre_m": [1, 2, 3], "radius_m": 300}"#;
        let expected = vec![RootBlob {
            centre_m: [1.0, 2.0, 3.0],
            radius_m: 300.0,
            flattening: 0.3,
        }];
        assert_eq!(roots_from_json(&format!("[{one}]")), Ok(expected.clone()));
        // The hierarchy file: other keys skipped, whatever they hold.
        let hierarchy =
            format!(r#"{{"levels": [[{{"x": [1, {{}}]}}]], "roots": [{one}], "n": 1}}"#);
        assert_eq!(roots_from_json(&hierarchy), Ok(expected));
        // 1000 roots are read; the 1001st is refused where it stands.
        let list = |n: usize| format!("[{}]", vec![one; n].join(","));
        assert_eq!(
            roots_from_json(&list(MAX_ROOT_BLOBS)).map(|r| r.len()),
            Ok(1000)
        );
        let error = roots_from_json(&list(MAX_ROOT_BLOBS + 5)).expect_err("too many");
        assert_eq!(error.path, ".");
        assert!(error.message.contains("more than 1000 roots"), "{error}");
        for (text, path, needle) in [
            (
                r#"[{"centre": [0, 0, 0], "radius_m": 3}]"#,
                "[0].centre",
                "centre_m",
            ),
            (r#"{"roots": [], "roots": []}"#, ".", "duplicate"),
            (r#"{"levels": []}"#, ".", "roots"),
            ("[] []", ".", "trailing"),
            ("7", ".", "a list of roots"),
        ] {
            let error = roots_from_json(text).expect_err(text);
            assert_eq!(error.path, path, "{text}: {error}");
            assert!(error.to_string().contains(needle), "{text}: {error}");
        }
    }

    fn small() -> CumulusParams {
        CumulusParams {
            roots: Roots::Given(vec![
                RootBlob {
                    centre_m: [0.0, 200.0, 0.0],
                    radius_m: 300.0,
                    flattening: 0.3,
                },
                RootBlob {
                    centre_m: [380.0, 150.0, 0.0],
                    radius_m: 250.0,
                    flattening: 0.5,
                },
            ]),
            generated_levels: 1,
            ..CumulusParams::default()
        }
    }

    /// Each generated level's mean radius is about a third of its parent's,
    /// its particles sit on the parent surface, and the sampler converged.
    #[test]
    fn levels_shrink_by_a_third() {
        let cumulus = build(&small(), |_| {}).expect("build");
        assert_eq!(cumulus.levels.len(), 2);
        let ratio = cumulus.levels[1].mean_radius_m / cumulus.levels[0].mean_radius_m;
        assert!((ratio - 1.0 / 3.0).abs() < 0.07, "radius ratio {ratio}");
        assert!(cumulus.levels[1].sampling.expect("report").converged);
        assert!(cumulus.levels[1].count > 30, "{:?}", cumulus.levels[1]);
        for b in cumulus.field.blobs(1) {
            let f = cumulus.field.sample(0, b.centre_m).potential.value;
            assert!((f - 1.0).abs() < 1e-2, "blob centre off S_0: f = {f}");
        }
    }

    /// The same seed gives the same hierarchy; another seed another one.
    #[test]
    fn deterministic_by_seed() {
        let a = build(&small(), |_| {}).expect("a");
        let b = build(&small(), |_| {}).expect("b");
        assert_eq!(a.field.blobs(1), b.field.blobs(1));
        let c = build(&CumulusParams { seed: 2, ..small() }, |_| {}).expect("c");
        assert_ne!(a.field.blobs(1), c.field.blobs(1));
    }

    /// Out-of-range values are refused with the parameter's name.
    #[test]
    fn bad_parameters_are_named() {
        let mut p = small();
        if let Roots::Given(r) = &mut p.roots {
            r[1].flattening = 1.5;
        }
        let e = build(&p, |_| {}).err().expect("error");
        assert!(
            e.to_string().starts_with("roots[1].flattening = 1.5"),
            "{e}"
        );
    }
}
