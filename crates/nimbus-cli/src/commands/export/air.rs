//! The air below the clouds as a Mitsuba 3 medium (`nimbus export --mitsuba
//! --air`): the same molecules and aerosols as nimbus's atmosphere
//! (`nimbus_physics::atmosphere`, Hillaire 2020's profiles), so that a
//! reference carries the aerial perspective that nimbus draws.
//!
//! Mitsuba's media are grey in what a path tracer needs per channel here:
//! `blendphase` mixes its two phase functions by one scalar weight, where
//! the aerosols' share of the scattering differs by channel (at sea level
//! with nimbus's default atmosphere, 75 % in blue and 91 % in red).
//! So the export writes the medium once per channel (`$air` = r, g or b in
//! the scene, grey volumes of that channel's coefficients), each channel is
//! path-traced on its own (the light's RGB channels do not mix), and the
//! reference takes channel c from render c (tools/reference/air.sh).

use crate::output::FileSet;
use glam::{DMat4, DVec3};
use nimbus_physics::atmosphere::{AtmosphereParams, cornette_shanks_phase};
use std::fmt::Write as _;
use std::path::Path;

/// Cells of the vertical profile between the box's floor and ceiling.
pub const AIR_PROFILE_CELLS: usize = 128;
/// Side of the air's box around the camera, m: past the terrain of every
/// scene's default extent (24 km) from anywhere on it.
pub const AIR_SIDE_M: f64 = 60_000.0;
/// The air's ceiling without a cloud box, m.
pub const AIR_CLEAR_CEILING_M: f64 = 12_000.0;
/// Samples of the aerosols' phase function, uniform in cos θ.
const AEROSOL_PHASE_SAMPLES: usize = 2049;
/// The channels' names in the volumes' file names and `$air`.
pub const AIR_CHANNELS: [&str; 3] = ["r", "g", "b"];

/// The air's coefficients at altitude `h_m` for channel `c`: extinction
/// (m⁻¹), single-scattering albedo, and the aerosols' share of the
/// scattering (`blendphase`'s weight of its second phase function).
pub fn air_at(params: &AtmosphereParams, h_m: f64, c: usize) -> (f64, f64, f64) {
    let d = params.densities(h_m);
    let rayleigh = params.rayleigh_scattering_per_m[c] * d.rayleigh;
    let aerosol_scattering = params.aerosol_scattering_per_m()[c] * d.aerosol;
    let extinction = params.extinction_per_m(h_m)[c];
    let scattering = rayleigh + aerosol_scattering;
    (
        extinction,
        (scattering / extinction.max(1e-30)).clamp(0.0, 1.0),
        aerosol_scattering / scattering.max(1e-30),
    )
}

/// A Mitsuba `.vol` grid of 2 × n × 2 cells holding `profile` along y (the
/// same in x and z), over the unit cube (the medium's transform places it).
fn profile_vol(profile: &[f32]) -> Vec<u8> {
    let n = profile.len();
    let mut out = Vec::with_capacity(48 + 16 * n);
    out.extend_from_slice(b"VOL");
    out.push(3);
    out.extend_from_slice(&1i32.to_le_bytes());
    for d in [2, n, 2] {
        out.extend_from_slice(&i32::try_from(d).unwrap_or(i32::MAX).to_le_bytes());
    }
    out.extend_from_slice(&1i32.to_le_bytes());
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    // x fastest, then y, then z.
    for _z in 0..2 {
        for v in profile {
            for _x in 0..2 {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out
}

/// What [`write_air`] declared.
pub struct AirBox {
    /// Mitsuba's [−1, 1]³ cube to the world: the box of air.
    pub world_from_cube: DMat4,
    /// A line for the export's APPROXIMATIONS.md.
    pub approximation: String,
}

/// Where the air's box lies: from `floor_m` to `ceiling_m`, [`AIR_SIDE_M`]
/// square around `centre_m`.
#[derive(Clone, Copy, Debug)]
pub struct AirExtent {
    /// The box's horizontal centre (its y is not used), m.
    pub centre_m: DVec3,
    /// Its floor, m.
    pub floor_m: f64,
    /// Its ceiling, m.
    pub ceiling_m: f64,
}

/// Writes the air's volumes (three per channel) into `dir` and declares
/// the medium `air` in `media` and its box in `xml`.
pub fn write_air(
    params: &AtmosphereParams,
    extent: &AirExtent,
    dir: &Path,
    files: &mut FileSet,
    media: &mut String,
    xml: &mut String,
) -> anyhow::Result<AirBox> {
    let AirExtent {
        centre_m,
        floor_m,
        ceiling_m,
    } = *extent;
    let n = AIR_PROFILE_CELLS;
    let height = |j: usize| floor_m + (j as f64 + 0.5) / n as f64 * (ceiling_m - floor_m);
    for (c, name) in AIR_CHANNELS.iter().enumerate() {
        let cells: Vec<(f64, f64, f64)> = (0..n).map(|j| air_at(params, height(j), c)).collect();
        for (what, pick) in [("sigma_t", 0usize), ("albedo", 1), ("aerosol_share", 2)] {
            let profile: Vec<f32> = cells.iter().map(|v| [v.0, v.1, v.2][pick] as f32).collect();
            files.write_bytes(
                &dir.join(format!("air_{what}_{name}.vol")),
                "--mitsuba",
                &profile_vol(&profile),
            )?;
        }
    }
    let half = 0.5 * AIR_SIDE_M;
    let lo = DVec3::new(centre_m.x - half, floor_m, centre_m.z - half);
    let hi = DVec3::new(centre_m.x + half, ceiling_m, centre_m.z + half);
    let world_from_grid = DMat4::from_translation(lo) * DMat4::from_scale(hi - lo);
    let world_from_cube =
        DMat4::from_translation(0.5 * (lo + hi)) * DMat4::from_scale(0.5 * (hi - lo));
    let grid = super::mitsuba::matrix(&world_from_grid);
    // Mitsuba's `tabphase`: cos θ from −1 (back scattering) to +1.
    let aerosol_phase: Vec<String> = (0..AEROSOL_PHASE_SAMPLES)
        .map(|i| {
            let mu = -1.0 + 2.0 * i as f64 / (AEROSOL_PHASE_SAMPLES - 1) as f64;
            format!(
                "{:.6e}",
                cornette_shanks_phase(mu, params.aerosol_asymmetry)
            )
        })
        .collect();
    let volume = |name: &str, what: &str| {
        format!(
            r#"<volume type="gridvolume" name="{name}">
            <string name="filename" value="air_{what}_$air.vol"/>
            <transform name="to_world"><matrix value="{grid}"/></transform>
        </volume>"#
        )
    };
    let _ = write!(
        media,
        r#"    <medium type="heterogeneous" id="air">
        <phase type="blendphase">
            {weight}
            <phase type="rayleigh" name="phase_0"/>
            <phase type="tabphase" name="phase_1">
                <string name="values" value="{values}"/>
            </phase>
        </phase>
        {sigma_t}
        {albedo}
    </medium>
"#,
        weight = volume("weight", "aerosol_share"),
        values = aerosol_phase.join(", "),
        sigma_t = volume("sigma_t", "sigma_t"),
        albedo = volume("albedo", "albedo"),
    );
    super::mitsuba::cube_shape(xml, "air", &world_from_cube);
    Ok(AirBox {
        world_from_cube,
        approximation: format!(
            "air: nimbus's molecules and aerosols (Rayleigh, Cornette–Shanks g = {}, ozone) as a heterogeneous medium from {floor_m:.0} m to {ceiling_m:.0} m (the floor of the lowest cloud box), {:.0} km square around the camera, its density along y in {n} cells; one grey medium per channel (`$air` = r, g, b: render each and take its channel, tools/reference/air.sh); no air inside or above the cloud boxes, and the sky's environment map (nimbus's clear sky at the camera) already holds the air of rays that leave the box",
            params.aerosol_asymmetry,
            AIR_SIDE_M / 1000.0
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exported coefficients are nimbus's: near the ground the blue
    /// channel's aerosols are a smaller share of the scattering than the
    /// red's (75 % and 91 %), and the share falls with height (their scale
    /// height is shorter); the albedo is below 1 by the aerosols'
    /// absorption; the grid holds the profile along y.
    #[test]
    fn the_air_is_nimbus_atmosphere() {
        let p = AtmosphereParams::default();
        let (red_t, red_albedo, red_share) = air_at(&p, 0.0, 0);
        let (blue_t, _, blue_share) = air_at(&p, 0.0, 2);
        assert!((red_t - p.extinction_per_m(0.0)[0]).abs() < 1e-15);
        assert!(blue_t > 2.0 * red_t, "{blue_t} {red_t}");
        assert!(
            (0.85..0.95).contains(&red_share) && (0.70..0.80).contains(&blue_share),
            "{red_share} {blue_share}"
        );
        assert!(red_albedo > 0.8 && red_albedo <= 1.0, "{red_albedo}");
        let (high_t, _, high_share) = air_at(&p, 3000.0, 0);
        assert!(high_t < red_t && high_share < red_share);
        let vol = profile_vol(&[1.0, 2.0, 3.0]);
        assert_eq!(vol.len(), 48 + 4 * 12);
        let value =
            |k: usize| f32::from_le_bytes(vol[48 + 4 * k..52 + 4 * k].try_into().expect("4 bytes"));
        // x fastest: cells (0, 1, 0) and (1, 1, 0) hold the second value.
        assert_eq!((value(2), value(3), value(6 + 2)), (2.0, 2.0, 2.0));
    }
}
