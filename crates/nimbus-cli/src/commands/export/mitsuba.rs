//! The Mitsuba 3 scene: XML and assets (see the parent module for what is
//! exported). Formats: Mitsuba 3's `gridvolume` `.vol` (written by
//! `nimbus_physics::cumulus::volume::ExtinctionGrid::to_mitsuba_vol`), PLY
//! meshes, OpenEXR and PNG images; the XML follows Mitsuba 3's scene format
//! (version 3.0.0).

use super::overlap;
use crate::output::FileSet;
use anyhow::Context;
use glam::{DMat4, DVec3};
use nimbus_physics::cumulus::volume::{ExtinctionGrid, VolumeParams, extinction_grid};
use nimbus_physics::optics::dsd::{SizeDistribution, bulk_optics};
use nimbus_physics::optics::tables::CHANNEL_WAVELENGTHS_NM;
use nimbus_physics::optics::water::water_refractive_index;
use nimbus_render::frame::{Camera, equirectangular_direction};
use nimbus_render::headless::HeadlessRenderer;
use nimbus_render::scene::{Projection, Scene, StratusSettings};
use std::fmt::Write as _;
use std::path::Path;

/// Samples of the tabulated phase function, uniform in cos θ over [−1, 1].
pub const PHASE_SAMPLES: usize = 16_001;

/// Wavelength of the phase function and extinction of the volumes, nm
/// (Mitsuba's grid volumes and tabulated phase functions are not spectral).
pub const PHASE_WAVELENGTH_NM: f64 = 550.0;

/// Size of the sky's environment map, pixels.
const SKY_WIDTH_PX: u32 = 512;

/// Largest terrain mesh exported, vertices per side.
const MAX_TERRAIN_VERTICES_PER_SIDE: usize = 513;

/// Half-size of the sea plane, m.
const SEA_HALF_SIZE_M: f64 = 200_000.0;

/// Index of refraction of water for the sea's coat.
const WATER_IOR: f64 = 1.333;

/// Cells of the stratus grid along each horizontal side, at most.
const STRATUS_HORIZONTAL_CELLS: usize = 1024;

/// Cells of the stratus grid across its thickest cells.
const STRATUS_VERTICAL_CELLS: usize = 16;

/// Smallest drop in the exported mist, mm (Marshall–Palmer's N(D) is
/// finite at 0; drops below 0.1 mm hold a negligible cross-section).
const MIST_MIN_DIAMETER_MM: f64 = 0.1;

/// Side of the exported mist box, m.
const MIST_SIDE_M: f64 = 40_000.0;

/// Henyey–Greenstein asymmetry of nimbus's mist (passes/rain/mist.wgsl, MIST_PHASE_G).
const MIST_PHASE_G: f64 = 0.85;

/// What the export wrote.
pub struct Summary {
    /// Cumulus clouds written.
    pub cumulus_count: usize,
    /// Whether a stratus layer was written.
    pub stratus: bool,
    /// What the export leaves out or approximates, one line each.
    pub approximations: Vec<String>,
}

/// Droplet optics for Mitsuba: the phase function at 550 nm sampled
/// uniformly in cos θ, the extinction at 550 nm and the albedo per channel,
/// after the δ-M truncation of the forward peak (when asked for).
struct DropletOptics {
    phase_values: Vec<f64>,
    extinction_per_m: f64,
    albedo_rgb: [f64; 3],
    truncation: Truncation,
}

/// The δ-M truncation of the droplets' forward diffraction peak
/// (Wiscombe 1977, "The Delta-M Method: Rapid Yet Accurate Radiative Flux
/// Calculations for Strongly Asymmetric Phase Functions", J. Atmos. Sci.
/// 34, 1408–1422; Potter 1970, J. Atmos. Sci. 27, 943): inside the
/// truncation angle θ_t the phase function p is replaced by its value
/// p(θ_t); the fraction f of the scattered light removed that way is
/// treated as not scattered at all (it continues in the forward
/// direction), so the medium's extinction becomes σ_t (1 − ω f), its
/// albedo ω (1 − f) / (1 − ω f), and the flattened phase function is
/// renormalised by 1 / (1 − f). Radiance transport is unchanged to the
/// extent that light scattered by less than θ_t may be counted as unscattered;
/// Monte-Carlo variance falls by the peak's huge next-event weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truncation {
    /// Truncation angle θ_t, degrees (0: the full phase function).
    pub angle_deg: f64,
    /// Fraction f of the phase function removed, 0 to 1.
    pub fraction: f64,
    /// Scale of the extinction, 1 − ω f (ω at 550 nm).
    pub extinction_scale: f64,
}

/// Clearance between the boxes of two media stacked one on the other, m.
/// Mitsuba tracks one medium at a time by the boundaries a ray crosses, and
/// it starts each new ray a small distance past the surface it left (some
/// 10⁻⁴ of the coordinates' magnitude: metres, tens of kilometres from the
/// origin). Where the top of one box was the floor of the next, a ray that
/// crossed both at once kept only the first crossing: leaving the lower box
/// it entered no medium, and went through the layer above as through empty
/// space (the air's first reference lit the ground by an unclouded sky).
pub const BOX_GAP_M: f64 = 25.0;

/// Largest `--phase-truncation-deg`, degrees: beyond it the flattened peak
/// changes the light seen around the sun's direction over most of a view.
pub const MAX_PHASE_TRUNCATION_DEG: f64 = 30.0;

/// Flattens `values` (a phase function sampled uniformly in μ = cos θ over
/// [−1, 1], linear between samples, as Mitsuba's `tabphase` reads it) inside
/// `angle_deg` to the value at `angle_deg`, and returns the fraction f of
/// the integral removed (0 for an angle of 0). The values are left
/// unnormalised: `tabphase` normalises them itself, which is the δ-M
/// method's 1 / (1 − f).
pub fn truncate_forward_peak(values: &mut [f64], angle_deg: f64) -> f64 {
    let n = values.len();
    if angle_deg <= 0.0 || n < 2 {
        return 0.0;
    }
    let step = 2.0 / (n - 1) as f64;
    // Integral over μ of the piecewise-linear table (trapezoids): 2π times
    // it is the integral over the sphere.
    let integral = |v: &[f64]| {
        v.windows(2)
            .map(|w| 0.5 * (w[0] + w[1]) * step)
            .sum::<f64>()
    };
    let full = integral(values);
    let mu_t = angle_deg.to_radians().cos();
    // The table's value at μ_t, interpolated.
    let x = (mu_t + 1.0) / step;
    let i = (x.floor() as usize).min(n - 2);
    let t = x - i as f64;
    let at_cut = values[i] * (1.0 - t) + values[i + 1] * t;
    for (k, v) in values.iter_mut().enumerate() {
        let mu = -1.0 + k as f64 * step;
        if mu > mu_t {
            *v = at_cut;
        }
    }
    if full > 0.0 {
        (1.0 - integral(values) / full).max(0.0)
    } else {
        0.0
    }
}

/// The droplets' size distribution of `settings`.
fn droplet_sizes(settings: &StratusSettings) -> SizeDistribution {
    SizeDistribution::ModifiedGamma {
        number_density_per_m3: settings.droplet_concentration_cm3 * 1e6,
        gamma: 2.0,
        effective_radius_m: settings.effective_radius_um * 1e-6,
    }
}

/// The droplets' phase function at `wavelength_nm` as Mitsuba's `tabphase`
/// takes it: [`PHASE_SAMPLES`] values over cos θ from −1 (back scattering)
/// to +1 (forward), θ the scattering angle (it normalises them itself);
/// and their extinction there, m⁻¹.
fn droplet_phase(settings: &StratusSettings, wavelength_nm: f64) -> (Vec<f64>, f64) {
    let angles = nimbus_physics::optics::tables::computation_angles(5.0);
    let optics = bulk_optics(
        &droplet_sizes(settings),
        wavelength_nm,
        water_refractive_index(wavelength_nm),
        &angles,
        1e-3,
    );
    let table = nimbus_physics::optics::phase::PhaseTable::new(
        optics.angles_deg.clone(),
        optics.phase.clone(),
    );
    let values = (0..PHASE_SAMPLES)
        .map(|i| {
            let mu = -1.0 + 2.0 * i as f64 / (PHASE_SAMPLES - 1) as f64;
            table.at(mu.clamp(-1.0, 1.0).acos().to_degrees())
        })
        .collect();
    (values, optics.extinction_per_m)
}

fn droplet_optics(settings: &StratusSettings, truncation_deg: f64) -> DropletOptics {
    let dsd = droplet_sizes(settings);
    let mut albedo_rgb = [1.0; 3];
    for (c, wavelength) in CHANNEL_WAVELENGTHS_NM.iter().enumerate() {
        let optics = bulk_optics(
            &dsd,
            *wavelength,
            water_refractive_index(*wavelength),
            &[0.0, 180.0],
            1e-3,
        );
        albedo_rgb[c] = optics.single_scattering_albedo();
    }
    let (mut phase_values, extinction_per_m) = droplet_phase(settings, PHASE_WAVELENGTH_NM);
    let fraction = truncate_forward_peak(&mut phase_values, truncation_deg);
    // One extinction grid serves all channels (Mitsuba's `scale` is a
    // scalar): its scale takes ω at 550 nm (the green channel), and each
    // channel's albedo keeps its scattering coefficient exact,
    // σ_s' = σ_t ω (1 − f); the absorption is then off by σ_t f (ω_c − ω_g),
    // < 1e-5 σ_t for cloud droplets.
    let omega = albedo_rgb[1];
    let extinction_scale = 1.0 - omega * fraction;
    let albedo_rgb = albedo_rgb.map(|w| (w * (1.0 - fraction) / extinction_scale).clamp(0.0, 1.0));
    DropletOptics {
        phase_values,
        extinction_per_m,
        albedo_rgb,
        truncation: Truncation {
            angle_deg: truncation_deg,
            fraction,
            extinction_scale,
        },
    }
}

fn vector(v: DVec3) -> String {
    format!("{:.6}, {:.6}, {:.6}", v.x, v.y, v.z)
}

pub(super) fn matrix(m: &DMat4) -> String {
    // Mitsuba reads the 16 values row by row.
    let rows = m.transpose().to_cols_array();
    rows.iter()
        .map(|v| format!("{v:.9}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// What fills a medium's box besides its grid of extinction.
struct MediumMaterial {
    /// The phase function's XML element: a `<ref>` to one declared once,
    /// or the element itself.
    phase_xml: String,
    /// Single-scattering albedo per channel.
    albedo_rgb: [f64; 3],
    /// Mitsuba's `scale` of the grid's extinction.
    extinction_scale: f64,
}

/// A heterogeneous medium inside a box: the unit cube of the grid mapped to
/// the world by `world_from_grid`. Returns the box's transform (Mitsuba's
/// [−1, 1]³ cube to the world).
fn medium_shape(
    xml: &mut String,
    media: &mut String,
    id: &str,
    volume_file: &str,
    world_from_grid: &DMat4,
    material: &MediumMaterial,
) -> DMat4 {
    // Mitsuba's `cube` spans [−1, 1]³; the grid volume [0, 1]³.
    let world_from_cube = *world_from_grid
        * DMat4::from_translation(DVec3::splat(0.5))
        * DMat4::from_scale(DVec3::splat(0.5));
    let [r, g, b] = material.albedo_rgb;
    let _ = write!(
        media,
        r#"    <medium type="heterogeneous" id="{id}">
        {phase}
        <volume type="gridvolume" name="sigma_t">
            <string name="filename" value="{volume_file}"/>
            <transform name="to_world"><matrix value="{grid}"/></transform>
        </volume>
        <rgb name="albedo" value="{r:.7}, {g:.7}, {b:.7}"/>
        <float name="scale" value="{scale:.9}"/>
    </medium>
"#,
        phase = material.phase_xml,
        grid = matrix(world_from_grid),
        scale = material.extinction_scale,
    );
    cube_shape(xml, id, &world_from_cube);
    world_from_cube
}

/// A box bounding a medium (no surface of its own).
pub(super) fn cube_shape(xml: &mut String, medium_id: &str, world_from_cube: &DMat4) {
    let _ = write!(
        xml,
        r#"    <shape type="cube">
        <transform name="to_world"><matrix value="{cube}"/></transform>
        <bsdf type="null"/>
        <ref name="interior" id="{medium_id}"/>
    </shape>
"#,
        cube = matrix(world_from_cube),
    );
}

/// Whether a point lies inside the box `world_from_cube` maps [−1, 1]³ to.
fn inside_cube(world_from_cube: &DMat4, point: DVec3) -> bool {
    let local = world_from_cube.inverse().transform_point3(point);
    local.abs().max_element() < 1.0
}

/// The grid's box in its own frame: translate to its minimum corner, scale to its size.
fn box_from_unit(grid: &ExtinctionGrid) -> DMat4 {
    DMat4::from_translation(grid.origin_m) * DMat4::from_scale(grid.max_corner_m() - grid.origin_m)
}

/// What to export beside the scene: the frame's time and the droplets'
/// phase truncation.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Animation time, s.
    pub time_s: f64,
    /// δ-M truncation angle of the droplets' forward peak, degrees (0: none).
    pub phase_truncation_deg: f64,
    /// Whether to export the air below the clouds as a medium
    /// ([`super::air`]).
    pub air: bool,
    /// Whether to declare the droplets' phase function at each channel's
    /// wavelength ([`CHANNEL_WAVELENGTHS_NM`]), chosen by the scene's
    /// `$phase` parameter (r, g or b), instead of once at
    /// [`PHASE_WAVELENGTH_NM`]: the diffraction peak's width goes with the
    /// wavelength, which colours a lining seen a few degrees from the sun.
    /// Only with the full phase function (`phase_truncation_deg` 0).
    pub phase_per_channel: bool,
    /// One light source alone, every surface black (`--light`): with the
    /// full render, a split of the light by where it comes from.
    pub light: Option<LightSource>,
}

/// One of the exported scene's two emitters ([`Options::light`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LightSource {
    /// The sun's directional emitter alone.
    Sun,
    /// The sky's environment map alone.
    Sky,
}

/// Writes the scene.
pub fn export(
    headless: &mut HeadlessRenderer,
    scene: &Scene,
    width: u32,
    height: u32,
    options: Options,
    dir: &Path,
    files: &mut FileSet,
) -> anyhow::Result<Summary> {
    let Options {
        time_s,
        phase_truncation_deg,
        air,
        phase_per_channel,
        light,
    } = options;
    // The caller checks the arguments (`--phase-per-channel` needs the full
    // phase function: green's table below is the shared, untruncated one).
    debug_assert!(!phase_per_channel || phase_truncation_deg == 0.0);
    anyhow::ensure!(
        !air || !scene.rain.as_ref().is_some_and(|r| r.mist),
        "--air: the scene's rain mist would share the air's box (Mitsuba tracks one medium at a time); set rain.mist = false"
    );
    let mut approximations = vec![
        if air {
            "the air below the clouds is a medium (below); the sky is an environment map at infinity, seen from the camera".to_string()
        } else {
            "no atmosphere between the camera and the clouds or terrain (nimbus's aerial perspective is left out); the sky is an environment map at infinity, seen from the camera".to_string()
        },
        if phase_per_channel {
            format!("volumes: extinction at {PHASE_WAVELENGTH_NM} nm for every channel (droplet extinction varies < 2 % over the visible), albedo per channel; the phase function at each channel's wavelength ({:.0}, {:.0}, {:.0} nm), one per render (`$phase` = r, g, b: render each and take its channel, tools/reference/channels.py), tabulated at {PHASE_SAMPLES} values uniform in cos θ (the diffraction peak is averaged over the first ~0.9°)", CHANNEL_WAVELENGTHS_NM[0], CHANNEL_WAVELENGTHS_NM[1], CHANNEL_WAVELENGTHS_NM[2])
        } else {
            format!("volumes: extinction and phase function at {PHASE_WAVELENGTH_NM} nm for every channel (droplet extinction varies < 2 % over the visible; the diffraction peak's width, which goes with the wavelength, is green's in every channel: `--phase-per-channel` keeps each channel's), albedo per channel; phase function tabulated at {PHASE_SAMPLES} values uniform in cos θ (the diffraction peak is averaged over the first ~0.9°)")
        },
        "the sun is a directional emitter (no disc seen by the camera); the water has no waves: a rough dielectric coat over its diffuse body, with nimbus's GGX glint lobe (whose shadowing darkens the sky's reflection at grazing views, where nimbus reflects it as a rippled mirror)".to_string(),
        if scene.ground.terrain {
            "the environment map's lower half is the terrain and sea as seen from the camera (for rays that leave the exported terrain)".to_string()
        } else {
            "the ground is not drawn (ground.terrain = false): a flat diffuse plane of the ground's albedo at its height lights the clouds from below, as in nimbus; the environment map's lower half is what nimbus's panorama shows below the horizon (for rays that leave the plane)".to_string()
        },
    ];
    if !scene.ground.terrain && scene.ground.albedo_map.is_some() {
        approximations
            .push("the flat ground's albedo map is exported as its mean albedo".to_string());
    }
    if let Some(light) = light {
        approximations.push(format!(
            "--light {}: the {} alone, the terrain, sea and ground black (reflecting nothing): the full export's render minus the sun's and the sky's is the light the surfaces reflect",
            match light {
                LightSource::Sun => "sun",
                LightSource::Sky => "sky",
            },
            match light {
                LightSource::Sun => "sun's directional emitter",
                LightSource::Sky => "sky's environment map",
            }
        ));
    }
    let black_surfaces = light.is_some();
    // 1. Render once so that the cumulus pass places this frame's clouds.
    headless.render_frame(scene, 16, 16, time_s as f32)?;
    let placed = headless.renderer.cumulus().placed_clouds();
    let variant_params = headless.renderer.cumulus().variant_params().cloned();

    // 2. The sky: nimbus's clear-sky panorama at the camera, sun disc removed.
    let mut clear = scene.clear_sky();
    clear.camera.projection = Projection::Equirectangular;
    let sky_height = SKY_WIDTH_PX / 2;
    let mut sky = headless.render_hdr(&clear, SKY_WIDTH_PX, sky_height, time_s as f32)?;
    let to_sun = DVec3::from_array(scene.sun.direction());
    remove_sun_disc(&mut sky.pixels, SKY_WIDTH_PX, sky_height, to_sun);
    let sky_file = dir.join("sky.exr");
    files.write_with(&sky_file, |temporary| {
        exr::prelude::write_rgb_file(
            temporary,
            SKY_WIDTH_PX as usize,
            sky_height as usize,
            |x, y| {
                let [r, g, b] = sky.pixels[y * SKY_WIDTH_PX as usize + x];
                (r, g, b)
            },
        )
        .with_context(|| format!("{}: EXR write failed", sky_file.display()))
    })?;

    // 3. The sun at the clouds' altitude.
    let cloud_altitude_m = if let Some(s) = &scene.stratus {
        s.base_m + 0.5 * s.thickness_m
    } else if let Some(c) = &scene.cumulus {
        c.base_m + 500.0
    } else {
        scene.camera.position_m[1]
    };
    let top = nimbus_render::atmosphere::solar_irradiance_top();
    let atmosphere = &scene.atmosphere;
    let t = atmosphere.transmittance_to_top(
        atmosphere.bottom_radius_m + cloud_altitude_m.max(0.0),
        to_sun.y,
    );
    let sun_irradiance: [f64; 3] = std::array::from_fn(|c| f64::from(top[c]) * t[c]);

    // 4. Camera.
    let camera = Camera::from_settings(&scene.camera, width, height);
    let mut xml = String::new();
    let _ = write!(
        xml,
        r#"<?xml version="1.0" encoding="utf-8"?>
<!-- Written by `nimbus export` at time {time_s} s: see docs/REALISM.md. -->
<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="seed" value="0"/>
    <default name="max_depth" value="-1"/>{air_channel}{phase_channel}
    <integrator type="volpath">
        <integer name="max_depth" value="$max_depth"/>
        <integer name="rr_depth" value="100000"/>
    </integrator>
    <sensor type="perspective">
        <string name="fov_axis" value="y"/>
        <float name="fov" value="{fov:.6}"/>
        <float name="near_clip" value="0.5"/>
        <float name="far_clip" value="10000000"/>
        <transform name="to_world">
            <lookat origin="{origin}" target="{target}" up="{up}"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
            <integer name="seed" value="$seed"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/>
            <integer name="height" value="{height}"/>
            <rfilter type="box"/>
            <string name="pixel_format" value="rgb"/>
        </film>
    </sensor>
{sun_emitter}{sky_emitter}"#,
        air_channel = if air {
            "\n    <default name=\"air\" value=\"g\"/>"
        } else {
            ""
        },
        phase_channel = if phase_per_channel {
            "\n    <default name=\"phase\" value=\"g\"/>"
        } else {
            ""
        },
        fov = scene.camera.fov_deg,
        origin = vector(camera.position_m),
        target = vector(camera.position_m + camera.forward * 1000.0),
        up = vector(camera.up),
        sun_emitter = if light == Some(LightSource::Sky) {
            String::new()
        } else {
            format!(
                r#"    <emitter type="directional">
        <vector name="direction" value="{}"/>
        <rgb name="irradiance" value="{:.6}, {:.6}, {:.6}"/>
    </emitter>
"#,
                vector(-to_sun),
                sun_irradiance[0],
                sun_irradiance[1],
                sun_irradiance[2]
            )
        },
        sky_emitter = if light == Some(LightSource::Sun) {
            ""
        } else {
            r#"    <!-- nimbus's panoramas put north (−Z) at the centre; Mitsuba's envmap puts −Z at u = 0. -->
    <emitter type="envmap">
        <string name="filename" value="sky.exr"/>
        <transform name="to_world"><rotate y="1" angle="180"/></transform>
    </emitter>
"#
        },
    );

    // 5. Terrain and sea, or the flat ground of a world nimbus does not draw.
    if scene.ground.terrain {
        write_terrain(scene, dir, &mut xml, files, black_surfaces)?;
    } else {
        xml.push_str(&flat_ground_xml(&scene.ground, black_surfaces));
    }

    // 6. Droplets' optics (the stratus layer's size distribution; the
    // cumulus shader has none of its own, so the same droplets).
    let droplet_settings = scene.stratus.clone().unwrap_or_default();
    let optics = droplet_optics(&droplet_settings, phase_truncation_deg);
    // Every cumulus and the stratus: the phase function declared once below
    // (once per channel, chosen by `$phase`, with --phase-per-channel).
    let droplets = MediumMaterial {
        phase_xml: if phase_per_channel {
            r#"<ref id="droplets_$phase"/>"#.to_string()
        } else {
            r#"<ref id="droplets"/>"#.to_string()
        },
        albedo_rgb: optics.albedo_rgb,
        extinction_scale: optics.truncation.extinction_scale,
    };
    let truncation = optics.truncation;
    approximations.push(if truncation.angle_deg > 0.0 {
        format!(
            "droplets (every cumulus and stratus medium): forward diffraction peak truncated by δ-M (Wiscombe 1977) at {:.2}°: the phase function is flat at its {:.2}° value inside it, the removed fraction f = {:.4} goes to the unscattered beam (extinction × (1 − ω f) = {:.5}, albedo ω (1 − f) / (1 − ω f)); `--phase-truncation-deg 0` keeps the full peak",
            truncation.angle_deg, truncation.angle_deg, truncation.fraction, truncation.extinction_scale
        )
    } else {
        "droplets (every cumulus and stratus medium): full phase function, forward peak not truncated (f = 0)".to_string()
    });
    let phase_values = |values: &[f64]| -> String {
        values
            .iter()
            .map(|v| format!("{v:.6e}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    // Media (and their phase function) are declared before the sensor,
    // which may start its rays in one of them.
    let mut media = String::new();
    let mut camera_medium: Option<String> = None;
    if phase_per_channel {
        for (name, wavelength_nm) in ["r", "g", "b"].iter().zip(CHANNEL_WAVELENGTHS_NM) {
            // Green's is the shared one (the same wavelength, untruncated).
            let values = if wavelength_nm == PHASE_WAVELENGTH_NM {
                phase_values(&optics.phase_values)
            } else {
                phase_values(&droplet_phase(&droplet_settings, wavelength_nm).0)
            };
            let _ = write!(
                media,
                "    <phase type=\"tabphase\" id=\"droplets_{name}\">\n        <string name=\"values\" value=\"{values}\"/>\n    </phase>\n"
            );
        }
    } else {
        let _ = write!(
            media,
            "    <phase type=\"tabphase\" id=\"droplets\">\n        <string name=\"values\" value=\"{}\"/>\n    </phase>\n",
            phase_values(&optics.phase_values)
        );
    }

    // 7. Cumulus.
    let mut cumulus_count = 0;
    let mut cumulus_bottom_m = f64::INFINITY;
    // The cumulus media's boxes (world from the unit cube).
    let mut cumulus_boxes: Vec<DMat4> = Vec::new();
    if let (Some(settings), Some(params)) = (&scene.cumulus, &variant_params) {
        // Each variant's grid and origin, built (and its .vol written) once.
        let mut variants: Vec<Option<(ExtinctionGrid, DVec3)>> =
            (0..params.count).map(|_| None).collect();
        // Each placed cloud: its variant and the world transform of its
        // grid's unit cube.
        let mut clouds: Vec<(usize, DMat4)> = Vec::with_capacity(placed.len());
        for cloud in &placed {
            let slot = variants
                .get_mut(cloud.variant)
                .context("a placed cloud refers to a variant that does not exist")?;
            if slot.is_none() {
                let cumulus = nimbus_physics::cumulus::hierarchy::build(
                    &params.hierarchy(cloud.variant as u32),
                    |_| {},
                )
                .map_err(|e| anyhow::anyhow!("cumulus variant {}: {e}", cloud.variant))?;
                let volume = VolumeParams::from_shading(&settings.shading);
                let grid = extinction_grid(&cumulus.field, &volume)
                    .map_err(|e| anyhow::anyhow!("cumulus variant {}: {e}", cloud.variant))?;
                let origin = variant_origin_m(&grid);
                let file = format!("cumulus_{}.vol", cloud.variant);
                files.write_bytes(&dir.join(&file), "--mitsuba", &grid.to_mitsuba_vol())?;
                *slot = Some((grid, origin));
            }
            let Some((grid, origin_m)) = slot.as_ref() else {
                continue;
            };
            // The shape scales; α_ρ and the corona do not (the shader's are
            // world metres): resample the grid's box, keep its values.
            let world_from_field = DMat4::from_translation(cloud.base_centre_m)
                * DMat4::from_rotation_y(cloud.yaw_rad)
                * DMat4::from_scale(DVec3::splat(cloud.scale))
                * DMat4::from_translation(-*origin_m);
            clouds.push((cloud.variant, world_from_field * box_from_unit(grid)));
        }
        // Clouds whose boxes overlap are one medium (Mitsuba follows one
        // at a time: see `overlap`).
        let boxes: Vec<DMat4> = clouds
            .iter()
            .map(|(_, world_from_grid)| *world_from_grid)
            .collect();
        let (mut merged_groups, mut merged_clouds) = (0, 0);
        for group in overlap::overlap_groups(&boxes) {
            let first = group[0];
            let (id, world_from_grid, file) = if let [index] = group[..] {
                let (variant, world_from_grid) = clouds[index];
                (
                    format!("cumulus_{index}"),
                    world_from_grid,
                    format!("cumulus_{variant}.vol"),
                )
            } else {
                let members: Vec<overlap::PlacedGrid> = group
                    .iter()
                    .filter_map(|&index| {
                        let (variant, world_from_unit) = clouds[index];
                        variants[variant]
                            .as_ref()
                            .map(|(grid, _)| overlap::PlacedGrid {
                                grid,
                                world_from_unit,
                            })
                    })
                    .collect();
                let (grid, world_from_grid) =
                    overlap::merged_grid(&members, overlap::MAX_MERGED_CELLS);
                let file = format!("cumulus_merged_{first}.vol");
                files.write_bytes(&dir.join(&file), "--mitsuba", &grid.to_mitsuba_vol())?;
                merged_groups += 1;
                merged_clouds += group.len();
                if grid.coarsened {
                    approximations.push(format!(
                        "cumulus group {first} ({} clouds whose boxes overlap) resampled on cells of {:.1} m to keep within {} cells",
                        group.len(),
                        grid.cell_m,
                        overlap::MAX_MERGED_CELLS
                    ));
                }
                (format!("cumulus_merged_{first}"), world_from_grid, file)
            };
            let world_from_cube = medium_shape(
                &mut xml,
                &mut media,
                &id,
                &file,
                &world_from_grid,
                &droplets,
            );
            if inside_cube(&world_from_cube, camera.position_m) {
                camera_medium = Some(id);
            }
            cumulus_boxes.push(world_from_grid);
            // The box turns about the vertical only (a merged box does not
            // turn): its floor is the unit cube's.
            cumulus_bottom_m = cumulus_bottom_m.min(
                world_from_cube
                    .transform_point3(DVec3::new(0.0, -1.0, 0.0))
                    .y,
            );
        }
        cumulus_count = clouds.len();
        if placed.iter().any(|c| (c.scale - 1.0).abs() > 1e-6) {
            approximations.push("cumulus scaled by their instance scale keep the variant's corona thickness scaled too (the shader keeps it in world metres)".into());
        }
        if merged_groups > 0 {
            let noun = if merged_groups == 1 {
                "medium"
            } else {
                "media"
            };
            approximations.push(format!("cumulus whose boxes overlap are merged ({merged_clouds} clouds in {merged_groups} {noun}): each group is one grid in the world's axes on its finest member's cells, holding the sum of the members' extinctions resampled trilinearly (Mitsuba follows one medium at a time)"));
        }
    }

    // 8. Stratus.
    let mut stratus_bottom_m = f64::INFINITY;
    let stratus = if let Some(settings) = &scene.stratus {
        let (grid, box_m) = stratus_grid(
            scene,
            settings,
            time_s,
            camera.position_m,
            optics.extinction_per_m,
        );
        stratus_bottom_m = grid.origin_m.y;
        let crossing = cumulus_boxes
            .iter()
            .filter(|cumulus| overlap::boxes_overlap(cumulus, &box_m))
            .count();
        if crossing > 0 {
            approximations.push(format!("{crossing} cumulus media's boxes overlap the stratus grid's and are not merged with it (Mitsuba follows one medium at a time: a ray leaving one inside the other loses the other)"));
        }
        files.write_bytes(
            &dir.join("stratus.vol"),
            "--mitsuba",
            &grid.to_mitsuba_vol(),
        )?;
        let world_from_cube = medium_shape(
            &mut xml,
            &mut media,
            "stratus",
            "stratus.vol",
            &box_m,
            &droplets,
        );
        if inside_cube(&world_from_cube, camera.position_m) {
            camera_medium = Some("stratus".into());
        }
        approximations.push(format!(
            "stratus: a grid of {:.0} m cells ({}×{}×{}) around the camera; beyond it, no layer",
            grid.cell_m, grid.dims[0], grid.dims[1], grid.dims[2]
        ));
        true
    } else {
        false
    };
    // 9. Rain mist.
    if let Some(rain) = scene.rain.as_ref().filter(|r| r.mist) {
        let extinction = nimbus_physics::rain::dsd::extinction_per_m(
            rain.intensity_mm_h,
            MIST_MIN_DIAMETER_MM,
            rain.max_diameter_mm,
        );
        // Up to the rain's ceiling, and never into the stratus grid's box
        // nor a cumulus box: Mitsuba tracks one medium at a time, and a ray
        // leaving one of two overlapping boxes would lose the other (their
        // lowest cells are empty). The default scene's camera, inside the
        // mist, saw no base of the cumulus right above it: its rays entered
        // a cumulus box 9 m below the mist's ceiling and left the cumulus
        // medium where they crossed that ceiling.
        let ceiling_m = scene
            .rain_ceiling_m()
            .min(stratus_bottom_m - BOX_GAP_M)
            .min(cumulus_bottom_m - BOX_GAP_M);
        let floor_m = scene.terrain.water_level_m.min(0.0) - scene.terrain.height_scale_m;
        let half = 0.5 * MIST_SIDE_M;
        let lo = DVec3::new(
            camera.position_m.x - half,
            floor_m,
            camera.position_m.z - half,
        );
        let hi = DVec3::new(
            camera.position_m.x + half,
            ceiling_m,
            camera.position_m.z + half,
        );
        // Where it rains: nimbus's own map of rain factors (the areas with
        // their soft edges, under the clouds where `under_clouds` puts it),
        // the one its mist multiplies its extinction by (passes/rain/zones.wgsl).
        let footprints = headless.renderer.cumulus().footprints_m();
        let zones = nimbus_render::passes::rain::rain_zones(scene, rain, time_s, &footprints);
        let everywhere = zones.size <= 1;
        if hi.y > lo.y && extinction > 0.0 && everywhere {
            let centre = 0.5 * (lo + hi);
            let box_m = DMat4::from_translation(centre) * DMat4::from_scale(0.5 * (hi - lo));
            let _ = write!(
                media,
                r#"    <medium type="homogeneous" id="mist">
        <phase type="hg"><float name="g" value="{MIST_PHASE_G}"/></phase>
        <rgb name="sigma_t" value="{extinction:.7e}"/>
        <rgb name="albedo" value="1.0"/>
    </medium>
"#
            );
            cube_shape(&mut xml, "mist", &box_m);
            if inside_cube(&box_m, camera.position_m) {
                camera_medium = Some("mist".into());
            }
            approximations.push(format!(
                "rain: streaks and splashes are not exported; the mist is a homogeneous medium (σ_t = {extinction:.2e} m⁻¹ from all drops of {MIST_MIN_DIAMETER_MM}–{} mm, albedo 1, Henyey–Greenstein g = {MIST_PHASE_G}, as nimbus's mist) from below the terrain to {ceiling_m:.0} m (the rain's ceiling, or the floor of the lowest cloud box below it), {:.0} km square around the camera (the scene rains everywhere)",
                rain.max_diameter_mm,
                MIST_SIDE_M / 1000.0
            ));
        } else if hi.y > lo.y && extinction > 0.0 {
            let (grid, box_m) = mist_grid(&zones, lo.y, hi.y, extinction);
            files.write_bytes(&dir.join("mist.vol"), "--mitsuba", &grid.to_mitsuba_vol())?;
            let world_from_cube = medium_shape(
                &mut xml,
                &mut media,
                "mist",
                "mist.vol",
                &box_m,
                &MediumMaterial {
                    phase_xml: format!(
                        r#"<phase type="hg"><float name="g" value="{MIST_PHASE_G}"/></phase>"#
                    ),
                    albedo_rgb: [1.0; 3],
                    extinction_scale: 1.0,
                },
            );
            if inside_cube(&world_from_cube, camera.position_m) {
                camera_medium = Some("mist".into());
            }
            approximations.push(format!(
                "rain: streaks and splashes are not exported; the mist (σ_t = {extinction:.2e} m⁻¹ where it rains fully, from all drops of {MIST_MIN_DIAMETER_MM}–{} mm, albedo 1, Henyey–Greenstein g = {MIST_PHASE_G}, as nimbus's mist) follows nimbus's map of where it rains ({}×{} texels of {:.0} m: the rain areas with their soft edges{}), from below the terrain to {ceiling_m:.0} m (the rain's ceiling, or the floor of the lowest cloud box below it); outside the map's {:.0} km square, no mist (nimbus clamps the map's edge); nimbus's mist ends 30 km from the camera and varies its density with noise near the rain box, the export's does not",
                rain.max_diameter_mm,
                zones.size,
                zones.size,
                zones.texel_m,
                if rain.under_clouds { " and under the clouds" } else { "" },
                zones.size as f32 * zones.texel_m / 1000.0,
            ));
        }
    } else if scene.rain.is_some() {
        approximations
            .push("rain: not exported (no streaks or splashes; the scene's mist is off)".into());
    }
    // 10. The air, below every cloud box.
    if air {
        let floor_m = scene.terrain.water_level_m.min(0.0) - scene.terrain.height_scale_m;
        let ceiling_m = (stratus_bottom_m.min(cumulus_bottom_m) - BOX_GAP_M)
            .min(super::air::AIR_CLEAR_CEILING_M);
        let air_box = super::air::write_air(
            &scene.atmosphere,
            &super::air::AirExtent {
                centre_m: camera.position_m,
                floor_m,
                ceiling_m,
            },
            dir,
            files,
            &mut media,
            &mut xml,
        )?;
        if camera_medium.is_none() && inside_cube(&air_box.world_from_cube, camera.position_m) {
            camera_medium = Some("air".into());
        }
        approximations.push(air_box.approximation);
    }
    if let Some(id) = &camera_medium {
        // The camera is inside a medium: its rays start in it.
        xml = xml.replacen(
            "        <film type=\"hdrfilm\">",
            &format!("        <ref name=\"medium\" id=\"{id}\"/>\n        <film type=\"hdrfilm\">"),
            1,
        );
        approximations.push(format!("the camera is inside the {id} medium's box"));
    }
    let sensor = xml.find("    <sensor").unwrap_or(xml.len());
    xml.insert_str(sensor, &media);
    xml.push_str("</scene>\n");
    files.write_bytes(&dir.join("scene.xml"), "--mitsuba", xml.as_bytes())?;
    let notes: String = approximations.iter().map(|l| format!("- {l}\n")).collect();
    files.write_bytes(
        &dir.join("APPROXIMATIONS.md"),
        "--mitsuba",
        notes.as_bytes(),
    )?;
    Ok(Summary {
        cumulus_count,
        stratus,
        approximations,
    })
}

/// The rain's mist as a grid: nimbus's map of rain factors (`zones`, texel
/// centres at (i + ½)·texel, bilinear between them, as Mitsuba's grid
/// volumes sample their cells) times the extinction where it rains fully,
/// two identical cells high from `floor_m` to `ceiling_m`. Returns the grid
/// and the world transform of its unit cube.
fn mist_grid(
    zones: &nimbus_physics::rain::zones::RainZones,
    floor_m: f64,
    ceiling_m: f64,
    extinction_per_m: f64,
) -> (ExtinctionGrid, DMat4) {
    let n = zones.size as usize;
    let texel_m = f64::from(zones.texel_m);
    let origin = DVec3::new(
        f64::from(zones.origin_m[0]),
        floor_m,
        f64::from(zones.origin_m[1]),
    );
    let mut values = vec![0.0f32; n * 2 * n];
    for k in 0..n {
        for j in 0..2 {
            for i in 0..n {
                values[(k * 2 + j) * n + i] =
                    (extinction_per_m * f64::from(zones.factors[k * n + i])) as f32;
            }
        }
    }
    let box_m = DMat4::from_translation(origin)
        * DMat4::from_scale(DVec3::new(
            n as f64 * texel_m,
            ceiling_m - floor_m,
            n as f64 * texel_m,
        ));
    (
        ExtinctionGrid {
            origin_m: origin,
            cell_m: texel_m,
            dims: [n, 2, n],
            values_per_m: values,
            coarsened: false,
        },
        box_m,
    )
}

/// The variant's origin in the field's frame (the renderer puts it under
/// the centre of the finest mesh's footprint, at its base): the centre of
/// the grid's non-zero cells in x and z and their lowest level in y. The
/// mesh and the grid bound the same surface S_L, to a cell.
fn variant_origin_m(grid: &ExtinctionGrid) -> DVec3 {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let [nx, ny, nz] = grid.dims;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if grid.values_per_m[(k * ny + j) * nx + i] > 0.0 {
                    let p = grid.origin_m + DVec3::new(i as f64, j as f64, k as f64) * grid.cell_m;
                    lo = lo.min(p);
                    hi = hi.max(p + DVec3::splat(grid.cell_m));
                }
            }
        }
    }
    DVec3::new(0.5 * (lo.x + hi.x), lo.y, 0.5 * (lo.z + hi.z))
}

/// The stratus layer's extinction on a grid around the camera: the cells
/// with |y − y_mid| < h(x, z)/2 (the renderer's slab of thickness h about
/// the mid-plane), h at the frame's time and drift. The grid covers the
/// renderer's window (`stratus.extent_m` around the camera) and its
/// extinction fades out over the window's outer fifth as the renderer's
/// opacity does (`stratus_window_fade` in cloud_layer_lookup.wgsl), so that
/// both images end the layer at the same distance: a grid of the terrain's
/// extent ended it 12 km out where the renderer draws it to 20 km, and the
/// references showed sea where nimbus showed the far layer.
fn stratus_grid(
    scene: &Scene,
    settings: &StratusSettings,
    time_s: f64,
    camera_m: DVec3,
    extinction_per_m: f64,
) -> (ExtinctionGrid, DMat4) {
    let field = nimbus_render::stratus::cloud_layer_field(scene, settings);
    let drift = scene.cloud_drift_m(time_s);
    let side_m = settings.extent_m;
    let cell_m = (side_m / STRATUS_HORIZONTAL_CELLS as f64).max(10.0);
    let n = (side_m / cell_m).ceil() as usize;
    let dy = (settings.thickness_m / STRATUS_VERTICAL_CELLS as f64).max(1.0);
    let ny = (settings.thickness_m / dy).ceil() as usize + 2;
    let mid = settings.base_m + 0.5 * settings.thickness_m;
    let origin = DVec3::new(
        camera_m.x - 0.5 * side_m,
        mid - 0.5 * ny as f64 * dy,
        camera_m.z - 0.5 * side_m,
    );
    let mut values = vec![0.0f32; n * ny * n];
    for k in 0..n {
        for i in 0..n {
            let x = origin.x + (i as f64 + 0.5) * cell_m;
            let z = origin.z + (k as f64 + 0.5) * cell_m;
            let h = field.thickness_with_drift_m(x, z, drift, time_s);
            let r = (x - camera_m.x).hypot(z - camera_m.z) / (0.5 * side_m);
            let fade = 1.0 - smoothstep(0.8, 1.0, r);
            if fade <= 0.0 {
                continue;
            }
            for j in 0..ny {
                let y = origin.y + (j as f64 + 0.5) * dy;
                if (y - mid).abs() < 0.5 * h {
                    values[(k * ny + j) * n + i] = (extinction_per_m * fade) as f32;
                }
            }
        }
    }
    // Flat cells: Mitsuba maps the grid to its box whatever its cells'
    // shape, so the box below carries the vertical cell `dy`.
    let box_m = DMat4::from_translation(origin)
        * DMat4::from_scale(DVec3::new(
            n as f64 * cell_m,
            ny as f64 * dy,
            n as f64 * cell_m,
        ));
    (
        ExtinctionGrid {
            origin_m: origin,
            cell_m,
            dims: [n, ny, n],
            values_per_m: values,
            coarsened: false,
        },
        box_m,
    )
}

/// WGSL's smoothstep: 0 below `edge0`, 1 above `edge1`, cubic between.
fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Mitsuba's `rectangle` (the unit square in z = 0, facing +z) turned to
/// face up, [`SEA_HALF_SIZE_M`] across its half, at height `height_m`: the
/// sea, or the flat ground.
fn level_plane(height_m: f64) -> DMat4 {
    DMat4::from_translation(DVec3::new(0.0, height_m, 0.0))
        * DMat4::from_rotation_x(-std::f64::consts::FRAC_PI_2)
        * DMat4::from_scale(DVec3::splat(SEA_HALF_SIZE_M))
}

/// The flat ground of `ground.terrain = false`: a diffuse plane at its
/// height, of its albedo (the mean of its albedo map when it has one),
/// [`SEA_HALF_SIZE_M`] across like the sea. nimbus draws nothing there but
/// lights the clouds from below with it (the stratus layer's radiosity,
/// the cumulus's ground light), so the reference must have it too. Black
/// with `black` ([`Options::light`]).
fn flat_ground_xml(ground: &nimbus_render::scene::GroundSettings, black: bool) -> String {
    let albedo = if black {
        [0.0; 3]
    } else {
        ground
            .albedo_map
            .as_ref()
            .map_or(ground.albedo, |map| map.map().mean())
    };
    let plane = level_plane(ground.height_m);
    format!(
        r#"    <shape type="rectangle">
        <transform name="to_world"><matrix value="{plane}"/></transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="{a0:.5}, {a1:.5}, {a2:.5}"/>
        </bsdf>
    </shape>
"#,
        plane = matrix(&plane),
        a0 = albedo[0],
        a1 = albedo[1],
        a2 = albedo[2],
    )
}

/// A surface that reflects nothing ([`Options::light`]).
const BLACK_BSDF: &str = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf>"#;

/// Terrain mesh (PLY) with its albedo (PNG) and the sea plane; both black,
/// and no albedo written, with `black` ([`Options::light`]).
fn write_terrain(
    scene: &Scene,
    dir: &Path,
    xml: &mut String,
    files: &mut FileSet,
    black: bool,
) -> anyhow::Result<()> {
    let terrain = nimbus_physics::terrain::generate(&scene.terrain);
    let n = terrain.vertices_per_side();
    let stride = n.div_ceil(MAX_TERRAIN_VERTICES_PER_SIDE).max(1);
    let indices: Vec<usize> = (0..n)
        .step_by(stride)
        .chain((!(n - 1).is_multiple_of(stride)).then_some(n - 1))
        .collect();
    let m = indices.len();
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m * m,
        2 * (m - 1) * (m - 1)
    )
    .into_bytes();
    for (b, &j) in indices.iter().enumerate() {
        for (a, &i) in indices.iter().enumerate() {
            let (x, z) = terrain.vertex_xz_m(i, j);
            let y = terrain.ground_height_m[j * n + i];
            for v in [
                x as f32,
                y,
                z as f32,
                a as f32 / (m - 1) as f32,
                b as f32 / (m - 1) as f32,
            ] {
                ply.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    for b in 0..m - 1 {
        for a in 0..m - 1 {
            let v = |a: usize, b: usize| (b * m + a) as i32;
            // Counter-clockwise seen from above (+y): normals up.
            for tri in [
                [v(a, b), v(a, b + 1), v(a + 1, b)],
                [v(a + 1, b), v(a, b + 1), v(a + 1, b + 1)],
            ] {
                ply.push(3);
                for i in tri {
                    ply.extend_from_slice(&i.to_le_bytes());
                }
            }
        }
    }
    files.write_bytes(&dir.join("terrain.ply"), "--mitsuba", &ply)?;
    let sea = matrix(&level_plane(scene.terrain.water_level_m));
    let (terrain_bsdf, sea_bsdf) = if black {
        (BLACK_BSDF.to_string(), BLACK_BSDF.to_string())
    } else {
        // The albedo, sRGB-encoded (Mitsuba decodes 8-bit textures as
        // sRGB); row b is v = b/(m − 1).
        let texels = terrain.albedo_rgba8();
        let mut rgb = Vec::with_capacity(m * m * 3);
        for &j in &indices {
            for &i in &indices {
                rgb.extend_from_slice(&texels[j * n + i][..3]);
            }
        }
        let mut png = Vec::new();
        image::ImageEncoder::write_image(
            image::codecs::png::PngEncoder::new(&mut png),
            &rgb,
            m as u32,
            m as u32,
            image::ExtendedColorType::Rgb8,
        )
        .context("terrain albedo: PNG encoding failed")?;
        files.write_bytes(&dir.join("terrain_albedo.png"), "--mitsuba", &png)?;
        let water = scene.terrain.albedo.water;
        (
            r#"<bsdf type="diffuse">
            <texture type="bitmap" name="reflectance">
                <string name="filename" value="terrain_albedo.png"/>
            </texture>
        </bsdf>"#
                .to_string(),
            format!(
                r#"<bsdf type="roughplastic">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="{alpha}"/>
            <rgb name="diffuse_reflectance" value="{w0:.5}, {w1:.5}, {w2:.5}"/>
            <float name="int_ior" value="{WATER_IOR}"/>
            <float name="ext_ior" value="1.0"/>
        </bsdf>"#,
                alpha = nimbus_render::shader::WATER_GGX_ALPHA,
                w0 = water[0],
                w1 = water[1],
                w2 = water[2],
            ),
        )
    };
    let _ = write!(
        xml,
        r#"    <shape type="ply">
        <string name="filename" value="terrain.ply"/>
        <boolean name="face_normals" value="false"/>
        {terrain_bsdf}
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><matrix value="{sea}"/></transform>
        {sea_bsdf}
    </shape>
"#
    );
    Ok(())
}

/// Replaces the pixels of the sun's disc (and its filtered edge, 1.5°)
/// by the mean of a ring around it: the sun is exported as a directional
/// emitter and must not be counted twice.
fn remove_sun_disc(pixels: &mut [[f32; 3]], width: u32, height: u32, to_sun: DVec3) {
    let inner = 1.5f64.to_radians().cos();
    let outer = 2.5f64.to_radians().cos();
    let direction = |i: usize| {
        let u = ((i % width as usize) as f64 + 0.5) / f64::from(width);
        let v = ((i / width as usize) as f64 + 0.5) / f64::from(height);
        equirectangular_direction(u, v)
    };
    let (mut sum, mut count) = ([0.0f64; 3], 0usize);
    for (i, p) in pixels.iter().enumerate() {
        let c = direction(i).dot(to_sun);
        if c < inner && c >= outer {
            for k in 0..3 {
                sum[k] += f64::from(p[k]);
            }
            count += 1;
        }
    }
    let ring = if count > 0 {
        sum.map(|s| (s / count as f64) as f32)
    } else {
        [0.0; 3]
    };
    for (i, p) in pixels.iter_mut().enumerate() {
        if direction(i).dot(to_sun) >= inner {
            *p = ring;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Henyey–Greenstein, per steradian.
    fn hg(g: f64, mu: f64) -> f64 {
        (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5))
    }

    fn hg_table(g: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| hg(g, -1.0 + 2.0 * i as f64 / (n - 1) as f64))
            .collect()
    }

    /// The removed fraction of a Henyey–Greenstein phase function flattened
    /// inside θ_t, against its closed form: the probability of scattering
    /// within θ_t, (1 − g²)/(2g) [1/(1 − g) − (1 + g² − 2g μ_t)^(−1/2)]
    /// (the HG cumulative distribution), less the flat part 2π p(μ_t)(1 − μ_t).
    #[test]
    fn the_removed_fraction_of_henyey_greenstein_matches_its_closed_form() {
        for (g, angle_deg) in [(0.9, 5.0), (0.85, 10.0), (0.5, 20.0)] {
            let mut values = hg_table(g, 200_001);
            let f = truncate_forward_peak(&mut values, angle_deg);
            let mu_t = f64::to_radians(angle_deg).cos();
            let inside = (1.0 - g * g) / (2.0 * g)
                * (1.0 / (1.0 - g) - 1.0 / (1.0 + g * g - 2.0 * g * mu_t).sqrt());
            let expected = inside - 2.0 * std::f64::consts::PI * hg(g, mu_t) * (1.0 - mu_t);
            assert!(
                (f - expected).abs() < 1e-4,
                "g {g}, {angle_deg}°: f {f} vs {expected}"
            );
            // Flat inside the angle, untouched outside.
            let n = values.len();
            assert!((values[n - 1] - hg(g, mu_t)).abs() < 1e-3 * hg(g, mu_t));
            assert_eq!(values[0], hg(g, -1.0));
        }
    }

    /// `--phase-per-channel`: the green channel's phase function is the one
    /// exported for every channel without it, and the diffraction peak
    /// narrows as the wavelength falls (its width goes as λ / r): blue's
    /// phase function is higher than red's in the exact forward direction
    /// and lower a few degrees off it.
    #[test]
    fn the_phase_function_per_channel_keeps_each_wavelengths_peak() {
        let settings = StratusSettings::default();
        let shared = droplet_optics(&settings, 0.0);
        let [red, green, blue] =
            CHANNEL_WAVELENGTHS_NM.map(|wavelength| droplet_phase(&settings, wavelength).0);
        // (The size integrals are summed in parallel: equal to rounding.)
        let largest_difference = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs() / x.abs().max(y.abs()).max(1e-30))
                .fold(0.0, f64::max)
        };
        assert!(largest_difference(&green, &shared.phase_values) < 1e-9);
        assert!(largest_difference(&red, &green) > 0.01);
        assert!(largest_difference(&blue, &green) > 0.01);
        // The samples are uniform in cos θ from −1 to 1: θ = 0 is the last.
        let at_deg = |values: &[f64], angle_deg: f64| {
            let mu = angle_deg.to_radians().cos();
            values[((mu + 1.0) / 2.0 * (PHASE_SAMPLES - 1) as f64).round() as usize]
        };
        assert!(at_deg(&blue, 0.0) > 1.2 * at_deg(&red, 0.0));
        assert!(at_deg(&red, 4.0) > 1.2 * at_deg(&blue, 4.0));
    }

    /// The mist's grid is nimbus's map of where it rains: a rain area's
    /// texels carry the full extinction at its centre, none outside its
    /// radius, the soft edge between, on both vertical cells; the grid's
    /// box spans the map's square from the floor to the ceiling.
    #[test]
    fn the_mist_grid_follows_the_rain_areas() {
        use nimbus_physics::rain::zones::{RainArea, RainZones};
        let area = RainArea {
            center_m: [1000.0, -500.0],
            radius_m: 1500.0,
            edge_m: 700.0,
        };
        let zones = RainZones::from_fn([0.0, 0.0], 8000.0, 64, |x, z| area.factor_at(x, z));
        let (grid, box_m) = mist_grid(&zones, -100.0, 900.0, 2e-3);
        assert_eq!(grid.dims, [64, 2, 64]);
        let texel = 8000.0 / 64.0;
        let value = |x: f64, z: f64, j: usize| {
            let i = ((x + 4000.0) / texel) as usize;
            let k = ((z + 4000.0) / texel) as usize;
            grid.values_per_m[(k * 2 + j) * 64 + i]
        };
        for j in 0..2 {
            assert!((value(1000.0, -500.0, j) - 2e-3).abs() < 1e-9);
            assert_eq!(value(-3000.0, 3000.0, j), 0.0);
            let edge = value(1000.0 + 1200.0, -500.0, j);
            assert!(edge > 0.0 && edge < 2e-3, "{edge}");
        }
        let lo = box_m.transform_point3(DVec3::ZERO);
        let hi = box_m.transform_point3(DVec3::ONE);
        assert!((lo - DVec3::new(-4000.0, -100.0, -4000.0)).length() < 1e-6);
        assert!((hi - DVec3::new(4000.0, 900.0, 4000.0)).length() < 1e-6);
    }

    /// The stratus grid is nimbus's window: a square of `stratus.extent_m`
    /// around the camera, each cell's extinction the layer's where the cell
    /// lies within the slab, faded over the window's outer fifth as the
    /// renderer fades the layer's opacity, and none beyond its radius.
    #[test]
    fn the_stratus_grid_covers_the_renderers_window() {
        let scene = Scene::from_toml_str(
            "[camera]\nposition_m = [500.0, 3000.0, -700.0]\n\
             [stratus]\nbase_m = 1500.0\nthickness_m = 300.0\ncoverage = 0.9\nextent_m = 10000.0\n",
            "grid.toml",
        )
        .expect("scene");
        let settings = scene.stratus.as_ref().expect("[stratus]");
        let camera = DVec3::new(500.0, 3000.0, -700.0);
        let (grid, box_m) = stratus_grid(&scene, settings, 0.0, camera, 0.05);
        let [nx, ny, nz] = grid.dims;
        let lo = box_m.transform_point3(DVec3::ZERO);
        let hi = box_m.transform_point3(DVec3::ONE);
        assert!((hi.x - lo.x - 10_000.0).abs() < 1e-6 && (hi.z - lo.z - 10_000.0).abs() < 1e-6);
        assert!((0.5 * (lo.x + hi.x) - camera.x).abs() < 1e-6);
        assert!((0.5 * (lo.z + hi.z) - camera.z).abs() < 1e-6);
        let (mut inner, mut faded) = (0, 0);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let value = f64::from(grid.values_per_m[(k * ny + j) * nx + i]);
                    if value == 0.0 {
                        continue;
                    }
                    let x = grid.origin_m.x + (i as f64 + 0.5) * grid.cell_m;
                    let z = grid.origin_m.z + (k as f64 + 0.5) * grid.cell_m;
                    let r = (x - camera.x).hypot(z - camera.z) / 5000.0;
                    let expected = 0.05 * (1.0 - smoothstep(0.8, 1.0, r));
                    assert!(
                        (value - expected).abs() < 1e-6,
                        "r {r}: {value} vs {expected}"
                    );
                    if r < 0.8 {
                        inner += 1;
                    } else {
                        faded += 1;
                    }
                }
            }
        }
        assert!(inner > 0 && faded > 0, "inner {inner}, faded {faded}");
    }

    /// A scene whose ground nimbus does not draw exports that ground as a
    /// flat diffuse plane of its albedo at its height, facing up, and no
    /// terrain (the references of such scenes had the procedural terrain).
    #[test]
    fn the_flat_ground_is_a_diffuse_plane_of_its_albedo_at_its_height() {
        let scene = Scene::from_toml_str(
            "[ground]\nterrain = false\nalbedo = [0.1, 0.2, 0.3]\nheight_m = 250.0\n",
            "flat.toml",
        )
        .expect("scene");
        let xml = flat_ground_xml(&scene.ground, false);
        assert!(!xml.contains("terrain"), "{xml}");
        assert!(
            xml.contains(r#"<rgb name="reflectance" value="0.10000, 0.20000, 0.30000"/>"#),
            "{xml}"
        );
        // Black with one light alone (--light).
        let black = flat_ground_xml(&scene.ground, true);
        assert!(
            black.contains(r#"<rgb name="reflectance" value="0.00000, 0.00000, 0.00000"/>"#),
            "{black}"
        );
        // The rectangle's z axis (its normal) turned to +y, its centre at
        // the height.
        let plane = level_plane(250.0);
        let normal = plane.transform_vector3(DVec3::Z).normalize();
        assert!((normal - DVec3::Y).length() < 1e-12, "{normal}");
        let centre = plane.transform_point3(DVec3::ZERO);
        assert!(
            (centre - DVec3::new(0.0, 250.0, 0.0)).length() < 1e-9,
            "{centre}"
        );
        assert!(xml.contains(&matrix(&plane)), "{xml}");
    }

    /// An angle of 0 keeps the phase function as it is.
    #[test]
    fn no_truncation_at_zero_degrees() {
        let mut values = hg_table(0.9, 1001);
        let before = values.clone();
        assert_eq!(truncate_forward_peak(&mut values, 0.0), 0.0);
        assert_eq!(values, before);
    }
}
