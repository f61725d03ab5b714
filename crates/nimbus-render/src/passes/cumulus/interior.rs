//! What the in-cloud view needs of each shape variant, computed on a worker
//! thread and cached on disk beside the shapes: the coarse extinction the
//! march reads ([`nimbus_physics::cumulus::interior::downsample`] of the
//! extinction grid the path-traced references and the transport model's
//! tracer use) and the scattered light inside
//! ([`nimbus_physics::cumulus::interior::trace_interior`]) at the field's
//! smallest and largest scale, as quadratic forms the shader turns with the
//! cloud (like the surface transfer, [`super::transfer`]).
//!
//! Per cloud the camera is in, and per direction of the sun in that cloud's
//! frame: the sun's scattered light resolved in the direction it is sent
//! ([`nimbus_physics::cumulus::interior::trace_sun_cube`]), which the
//! projection over sun directions smooths away ([`SunCubeKey`]).

use super::transfer::{pack_form, tracer_scattering, variant_extinction_grid};
use super::variants::{CumulusVariant, VariantError, VariantParams};
use glam::DVec3;
use nimbus_physics::cumulus::interior::{
    InteriorSettings, downsample, trace_interior, trace_sun_cube,
};
use nimbus_physics::cumulus::transport::{GridMedium, SphericalQuadratic};
use nimbus_physics::cumulus::volume::ExtinctionGrid;
use nimbus_physics::optics::tables::CloudOpticsTables;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Photons per variant and scale of the interior's light: ~2 s per scale
/// for the paper's cloud in release on one core of the 2-core reference
/// machine; each of the ~32³ cells averages thousands of path segments.
pub const INTERIOR_PHOTONS: u64 = 1 << 19;
/// Cells of the interior light along the cloud's longest side (~60 m for
/// a 2 km cloud: under the transport mean free path, ~90 m).
pub const INTERIOR_CELLS: usize = 32;
/// Largest side of the extinction texture, cells (≤ 256³ texels of 2
/// bytes: 32 MiB per variant; the paper's cloud, 199 × 82 × 151 cells, is
/// the references' grid itself, 4.9 MB).
pub const EXTINCTION_CELLS: usize = 256;
const CACHE_MAGIC: &[u8; 8] = b"NIMBUSIC";
const CACHE_VERSION: u32 = 3;
/// Largest interior cache file read, bytes.
const MAX_CACHE_FILE_BYTES: u64 = 256 * 1024 * 1024;

/// What a variant's interior is computed from.
#[derive(Clone, Debug, PartialEq)]
pub struct InteriorParams {
    /// The shapes.
    pub variants: VariantParams,
    /// α_ρ, m⁻¹.
    pub density_per_m: f64,
    /// Corona thickness, m.
    pub corona_thickness_m: f64,
    /// The smallest and the largest scale of the field's clouds.
    pub scales: [f64; 2],
    /// Hash of the droplets' optical tables.
    pub optics_hash: u64,
}

impl InteriorParams {
    fn cache_key(&self, index: u32) -> u64 {
        let text = format!(
            "{CACHE_VERSION} {:?} {} {} {:?} {} {INTERIOR_PHOTONS} {INTERIOR_CELLS} {EXTINCTION_CELLS} {index}",
            self.variants.hierarchy(index),
            self.density_per_m,
            self.corona_thickness_m,
            self.scales,
            self.optics_hash,
        );
        nimbus_physics::io::fnv1a(&text)
    }
}

/// One variant's interior, in its object frame (the field's frame minus
/// the variant's origin, unscaled).
#[derive(Clone, Debug, PartialEq)]
pub struct VariantInterior {
    /// σ_t (before δ-M), m⁻¹, on cells of [`EXTINCTION_CELLS`] at most per
    /// side; its origin in the object frame.
    pub extinction: ExtinctionGrid,
    /// Minimum corner of the light's box, object frame, m.
    pub light_origin_m: [f32; 3],
    /// Size of the light's box, m.
    pub light_extent_m: [f32; 3],
    /// Cells of the light along x, y, z.
    pub light_dims: [u32; 3],
    /// Per cell (x fastest): Φ_k as quadratic forms ([`pack_form`]) at the
    /// smallest scale, then at the largest; then Φ^d_k (the direct
    /// fluence's) at the two scales; then the scattered light's net flux
    /// F_0 … F_3 ([`pack_flux`]) at the two scales.
    pub light_forms: Vec<LightForms>,
}

/// Vectors of a light cell's [`VariantInterior::light_forms`].
pub const LIGHT_FORMS: usize = 18;

/// Parts of the light atlas side by side, each one value per cell: the
/// scattered light, the direct transmittance from the sky, the scattered
/// light's net flux (and, in its fourth channel, the scattered fluence of a
/// unit irradiance from a uniform ground below; WGSL `IN_CLOUD_LIGHT_PARTS`).
pub const LIGHT_PARTS: u32 = 3;

/// One light cell's forms (see [`VariantInterior::light_forms`]).
pub type LightForms = [[f32; 4]; LIGHT_FORMS];

/// F_0 … F_3 (object frame) as three vectors: F_0.xyz F_1.x, F_1.yz
/// F_2.xy, F_2.z F_3.xyz (WGSL `in_cloud_light_fragment` unpacks them).
pub fn pack_flux(flux: &[[f64; 3]; 4]) -> [[f32; 4]; 3] {
    let f: Vec<f32> = flux.iter().flatten().map(|&v| v as f32).collect();
    [
        [f[0], f[1], f[2], f[3]],
        [f[4], f[5], f[6], f[7]],
        [f[8], f[9], f[10], f[11]],
    ]
}

/// Computes variant `index`'s interior (seconds); its extinction grid from
/// `dir`'s cache where it is there.
pub fn compute_interior(
    dir: &Path,
    params: &InteriorParams,
    index: u32,
    shape: &CumulusVariant,
    optics: &CloudOpticsTables,
) -> Result<VariantInterior, VariantError> {
    let grid = variant_extinction_grid(
        dir,
        &params.variants,
        index,
        params.density_per_m,
        params.corona_thickness_m,
    )?;
    let origin = DVec3::from_array(shape.origin_m.map(f64::from));
    let (scattering, truncated) = tracer_scattering(optics);
    let mut forms: Vec<LightForms> = Vec::new();
    let mut light = None;
    for (slot, scale) in params.scales.iter().enumerate() {
        let interior = trace_interior(
            &GridMedium::new(&grid, truncated * scale),
            &scattering,
            &InteriorSettings {
                photons: INTERIOR_PHOTONS,
                cells_longest: INTERIOR_CELLS,
                seed: 0x1c_u64 + u64::from(index),
            },
        );
        if forms.is_empty() {
            forms = vec![[[0.0; 4]; LIGHT_FORMS]; interior.coefficients.len()];
        }
        let cells = interior
            .coefficients
            .iter()
            .zip(&interior.direct)
            .zip(&interior.flux);
        for (out, ((phi, direct), flux)) in forms.iter_mut().zip(cells) {
            let packed = pack_form(&SphericalQuadratic::from_sh(phi));
            out[3 * slot..3 * slot + 3].copy_from_slice(&packed);
            let packed = pack_form(&SphericalQuadratic::from_sh(direct));
            out[6 + 3 * slot..9 + 3 * slot].copy_from_slice(&packed);
            out[12 + 3 * slot..15 + 3 * slot].copy_from_slice(&pack_flux(flux));
        }
        light = Some(interior);
    }
    let light = light.ok_or(VariantError::Transfer {
        index,
        reason: "no scale to compute the interior light for".into(),
    })?;
    let mut extinction = downsample(&grid, EXTINCTION_CELLS);
    extinction.origin_m -= origin;
    Ok(VariantInterior {
        extinction,
        light_origin_m: (light.origin_m - origin).as_vec3().to_array(),
        light_extent_m: light.extent_m.as_vec3().to_array(),
        light_dims: light.dims.map(|n| n as u32),
        light_forms: forms,
    })
}

/// Photons of the sun's cube per cloud and sun direction: ~7 s for the
/// paper's cloud on the 2-core reference machine, on a worker thread.
pub const SUN_CUBE_PHOTONS: u64 = 1 << 21;
/// Cells of the sun's cube along the cloud's longest side (~34 m for a
/// 2.2 km cloud). Finer than the sky's light ([`INTERIOR_CELLS`]): the sun's
/// light varies over its mean free path (~25 m) inside a sunlit face, and
/// 32 cells (~66 m) took 12 % of it from the fog 50 m inside one
/// (docs/REALISM.md, "The sun's light towards the camera").
pub const SUN_CUBE_CELLS: usize = 64;
/// The sun's direction in the cloud's frame is snapped to a grid of this
/// many steps per unit of each component (1/32: under 2°) before a cube is
/// traced for it, so that a turning sun asks for a new one every few
/// degrees and not every frame.
pub const SUN_CUBE_STEPS: f64 = 32.0;
const SUN_CUBE_MAGIC: &[u8; 8] = b"NIMBUSSC";
const SUN_CUBE_VERSION: u32 = 1;

/// What a sun cube is traced for: one variant at one scale, lit from one
/// (snapped) direction in its frame.
#[derive(Clone, Debug, PartialEq)]
pub struct SunCubeKey {
    /// The shapes, droplets and density.
    pub params: InteriorParams,
    /// The variant.
    pub variant: u32,
    /// The cloud's scale, bits of its f32.
    scale_bits: u32,
    /// The direction towards the sun in the variant's frame, snapped
    /// (components × [`SUN_CUBE_STEPS`], rounded).
    sun_steps: [i32; 3],
}

impl SunCubeKey {
    /// The key of `variant` at `scale` lit from `to_sun_object` (towards
    /// the sun, the variant's frame: the world's turned by the cloud's yaw).
    pub fn new(params: InteriorParams, variant: u32, scale: f32, to_sun_object: DVec3) -> Self {
        let d = to_sun_object.normalize_or(DVec3::Y);
        Self {
            params,
            variant,
            scale_bits: scale.to_bits(),
            sun_steps: d.to_array().map(|c| (c * SUN_CUBE_STEPS).round() as i32),
        }
    }

    /// The cloud's scale.
    pub fn scale(&self) -> f32 {
        f32::from_bits(self.scale_bits)
    }

    /// The snapped direction towards the sun the cube is traced for (unit).
    pub fn to_sun(&self) -> DVec3 {
        DVec3::from_array(self.sun_steps.map(f64::from)).normalize_or(DVec3::Y)
    }

    fn cache_key(&self) -> u64 {
        let text = format!(
            "{SUN_CUBE_VERSION} {} {} {:?} {SUN_CUBE_PHOTONS} {SUN_CUBE_CELLS}",
            self.params.cache_key(self.variant),
            self.scale_bits,
            self.sun_steps,
        );
        nimbus_physics::io::fnv1a(&text)
    }
}

/// A variant's sun cube, ready for the GPU, in its object frame (the
/// field's frame minus the variant's origin, unscaled).
#[derive(Clone, Debug, PartialEq)]
pub struct VariantSunCube {
    /// Minimum corner of the cells' box, object frame, m.
    pub origin_m: [f32; 3],
    /// Size of the box, m.
    pub extent_m: [f32; 3],
    /// Cells along x, y, z.
    pub dims: [u32; 3],
    /// The cells (x fastest, then y, then z) twice over: the first holds D
    /// towards +x, +y, +z and the excess of D along the beam over the
    /// cube's reading there, the second D towards −x, −y, −z and the
    /// fluence Φ (per unit normal irradiance of the sun; see
    /// [`nimbus_physics::cumulus::interior::SunCube`]).
    pub texels: Vec<[f32; 4]>,
}

/// Traces the sun cube of `key` (seconds); its extinction grid from
/// `dir`'s cache where it is there.
pub fn compute_sun_cube(
    dir: &Path,
    key: &SunCubeKey,
    shape: &CumulusVariant,
    optics: &CloudOpticsTables,
) -> Result<VariantSunCube, VariantError> {
    let grid = variant_extinction_grid(
        dir,
        &key.params.variants,
        key.variant,
        key.params.density_per_m,
        key.params.corona_thickness_m,
    )?;
    let origin = DVec3::from_array(shape.origin_m.map(f64::from));
    let (scattering, truncated) = tracer_scattering(optics);
    let cube = trace_sun_cube(
        &GridMedium::new(&grid, truncated * f64::from(key.scale())),
        &scattering,
        &InteriorSettings {
            photons: SUN_CUBE_PHOTONS,
            cells_longest: SUN_CUBE_CELLS,
            seed: 0x5c_u64 + u64::from(key.variant),
        },
        key.to_sun(),
    );
    // Cell by cell (the shader interpolates the excess with the cube).
    let cells: Vec<([f64; 6], f64, f64)> = cube
        .cells
        .iter()
        .map(|c| {
            let (six, excess) = cube.cube_and_excess(c);
            (six, excess, c[7])
        })
        .collect();
    let positive = cells
        .iter()
        .map(|(c, excess, _)| [c[0], c[2], c[4], *excess]);
    let negative = cells.iter().map(|(c, _, phi)| [c[1], c[3], c[5], *phi]);
    let texels = positive
        .chain(negative)
        .map(|t| t.map(|v| v as f32))
        .collect();
    Ok(VariantSunCube {
        origin_m: (cube.origin_m - origin).as_vec3().to_array(),
        extent_m: cube.extent_m.as_vec3().to_array(),
        dims: cube.dims.map(|n| n as u32),
        texels,
    })
}

fn sun_cube_to_bytes(v: &VariantSunCube) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(SUN_CUBE_MAGIC);
    out.extend_from_slice(&SUN_CUBE_VERSION.to_le_bytes());
    for x in v.origin_m.iter().chain(&v.extent_m) {
        out.extend_from_slice(&x.to_le_bytes());
    }
    for n in v.dims {
        out.extend_from_slice(&n.to_le_bytes());
    }
    out.extend_from_slice(bytemuck::cast_slice(&v.texels));
    out
}

/// Reads [`sun_cube_to_bytes`]' format: `None` unless it holds a whole cube
/// of this version.
fn sun_cube_from_bytes(bytes: &[u8]) -> Option<VariantSunCube> {
    let head = 8 + 4 + 24 + 12;
    if bytes.len() < head
        || &bytes[..8] != SUN_CUBE_MAGIC
        || bytes[8..12] != SUN_CUBE_VERSION.to_le_bytes()
    {
        return None;
    }
    let word = |i: usize| -> [u8; 4] { bytes[12 + 4 * i..16 + 4 * i].try_into().unwrap_or([0; 4]) };
    let f: [f32; 6] = std::array::from_fn(|i| f32::from_le_bytes(word(i)));
    let dims: [u32; 3] = std::array::from_fn(|i| u32::from_le_bytes(word(6 + i)));
    let cells = dims
        .iter()
        .try_fold(1usize, |a, &n| a.checked_mul(n as usize))?;
    let body = &bytes[head..];
    if cells == 0 || Some(body.len()) != cells.checked_mul(32) {
        return None;
    }
    Some(VariantSunCube {
        origin_m: [f[0], f[1], f[2]],
        extent_m: [f[3], f[4], f[5]],
        dims,
        texels: bytemuck::pod_collect_to_vec(body),
    })
}

/// The sun cube of `key`: from the disk cache in `dir`, else traced and
/// cached (a cache that cannot be written is skipped).
pub fn load_or_compute_sun_cube(
    dir: &Path,
    key: &SunCubeKey,
    shape: &CumulusVariant,
    optics: &CloudOpticsTables,
) -> Result<VariantSunCube, VariantError> {
    super::variants::read_or_compute(
        &dir.join(format!("cumulus-sun-cube-{:016x}.bin", key.cache_key())),
        MAX_CACHE_FILE_BYTES,
        sun_cube_from_bytes,
        || compute_sun_cube(dir, key, shape, optics),
        sun_cube_to_bytes,
    )
}

fn to_bytes(v: &VariantInterior) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(CACHE_MAGIC);
    out.extend_from_slice(&CACHE_VERSION.to_le_bytes());
    let g = &v.extinction;
    for x in g.origin_m.to_array().into_iter().chain([g.cell_m]) {
        out.extend_from_slice(&x.to_le_bytes());
    }
    for n in g.dims {
        out.extend_from_slice(&(n as u32).to_le_bytes());
    }
    for x in v.light_origin_m.iter().chain(&v.light_extent_m) {
        out.extend_from_slice(&x.to_le_bytes());
    }
    for n in v.light_dims {
        out.extend_from_slice(&n.to_le_bytes());
    }
    out.extend_from_slice(bytemuck::cast_slice(&g.values_per_m));
    out.extend_from_slice(bytemuck::cast_slice(&v.light_forms));
    out
}

/// Reads [`to_bytes`]' format: `None` unless it holds a whole interior of
/// this version.
fn from_bytes(bytes: &[u8]) -> Option<VariantInterior> {
    let mut at = 0usize;
    let mut take = |n: usize| -> Option<&[u8]> {
        let s = bytes.get(at..at.checked_add(n)?)?;
        at += n;
        Some(s)
    };
    if take(8)? != CACHE_MAGIC || take(4)? != CACHE_VERSION.to_le_bytes() {
        return None;
    }
    let mut f64s = [0.0f64; 4];
    for x in &mut f64s {
        *x = f64::from_le_bytes(take(8)?.try_into().ok()?);
    }
    let mut dims = [0usize; 3];
    for n in &mut dims {
        *n = u32::from_le_bytes(take(4)?.try_into().ok()?) as usize;
    }
    let mut f32s = [0.0f32; 6];
    for x in &mut f32s {
        *x = f32::from_le_bytes(take(4)?.try_into().ok()?);
    }
    let mut light_dims = [0u32; 3];
    for n in &mut light_dims {
        *n = u32::from_le_bytes(take(4)?.try_into().ok()?);
    }
    let cells = dims.iter().try_fold(1usize, |a, &n| a.checked_mul(n))?;
    let light_cells = light_dims
        .iter()
        .try_fold(1usize, |a, &n| a.checked_mul(n as usize))?;
    let values_per_m: Vec<f32> = bytemuck::pod_collect_to_vec(take(cells.checked_mul(4)?)?);
    let light_forms: Vec<LightForms> = bytemuck::pod_collect_to_vec(take(
        light_cells.checked_mul(std::mem::size_of::<LightForms>())?,
    )?);
    if at != bytes.len() || cells == 0 || light_cells == 0 {
        return None;
    }
    Some(VariantInterior {
        extinction: ExtinctionGrid {
            origin_m: DVec3::new(f64s[0], f64s[1], f64s[2]),
            cell_m: f64s[3],
            dims,
            values_per_m,
            coarsened: true,
        },
        light_origin_m: [f32s[0], f32s[1], f32s[2]],
        light_extent_m: [f32s[3], f32s[4], f32s[5]],
        light_dims,
        light_forms,
    })
}

fn cache_path(dir: &Path, params: &InteriorParams, index: u32) -> PathBuf {
    dir.join(format!(
        "cumulus-interior-{:016x}.bin",
        params.cache_key(index)
    ))
}

/// Every variant's interior: from the disk cache in `dir`, else computed
/// and cached (a cache that cannot be written is skipped).
pub fn load_or_compute(
    dir: &Path,
    params: &InteriorParams,
    shapes: &[Arc<CumulusVariant>],
    optics: &CloudOpticsTables,
) -> Result<Vec<Arc<VariantInterior>>, VariantError> {
    shapes
        .iter()
        .enumerate()
        .map(|(index, shape)| {
            let index = index as u32;
            super::variants::read_or_compute(
                &cache_path(dir, params, index),
                MAX_CACHE_FILE_BYTES,
                from_bytes,
                || compute_interior(dir, params, index, shape, optics),
                to_bytes,
            )
            .map(Arc::new)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cache_format_round_trips_and_rejects_truncation() {
        let interior = VariantInterior {
            extinction: ExtinctionGrid {
                origin_m: DVec3::new(-1.0, 2.0, 3.5),
                cell_m: 4.0,
                dims: [2, 3, 1],
                values_per_m: vec![0.0, 0.1, 0.2, 0.3, 0.4, 0.5],
                coarsened: true,
            },
            light_origin_m: [1.0, 2.0, 3.0],
            light_extent_m: [4.0, 5.0, 6.0],
            light_dims: [2, 1, 1],
            light_forms: vec![[[1.0, 2.0, 3.0, 4.0]; LIGHT_FORMS]; 2],
        };
        let bytes = to_bytes(&interior);
        assert_eq!(from_bytes(&bytes), Some(interior));
        assert_eq!(from_bytes(&bytes[..bytes.len() - 1]), None);
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(from_bytes(&longer), None);
    }

    #[test]
    fn sun_cube_cache_format_round_trips_and_rejects_truncation() {
        let cube = VariantSunCube {
            origin_m: [1.0, -2.0, 3.0],
            extent_m: [4.0, 5.0, 6.5],
            dims: [2, 1, 3],
            texels: (0..12).map(|i| [i as f32, 0.5, 2.0, -1.0]).collect(),
        };
        let bytes = sun_cube_to_bytes(&cube);
        assert_eq!(sun_cube_from_bytes(&bytes), Some(cube));
        assert_eq!(sun_cube_from_bytes(&bytes[..bytes.len() - 1]), None);
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(sun_cube_from_bytes(&longer), None);
        assert_eq!(sun_cube_from_bytes(&bytes[..20]), None);
    }

    /// The sun's direction is snapped to under 2°, so that directions a
    /// fraction of a degree apart share a cube and the cube's sun is within
    /// 1.6° of the true one (√3/64 rad at most).
    #[test]
    fn sun_cube_keys_snap_the_sun_direction() {
        let params = InteriorParams {
            variants: VariantParams::from(&crate::scene::CumulusSettings::default()),
            density_per_m: 0.08,
            corona_thickness_m: 30.0,
            scales: [1.0, 1.0],
            optics_hash: 7,
        };
        let sun = DVec3::new(0.3, 0.6, -0.74).normalize();
        let turned = |deg: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            DVec3::new(c * sun.x - s * sun.z, sun.y, s * sun.x + c * sun.z)
        };
        let key = SunCubeKey::new(params.clone(), 1, 1.2, sun);
        assert!(key.to_sun().angle_between(sun).to_degrees() < 1.6);
        assert_eq!(key.scale(), 1.2);
        let mut same = 0;
        for step in 1..=20 {
            let k = SunCubeKey::new(params.clone(), 1, 1.2, turned(0.01 * f64::from(step)));
            same += usize::from(k == key);
            assert!(
                k.to_sun()
                    .angle_between(turned(0.01 * f64::from(step)))
                    .to_degrees()
                    < 1.6
            );
        }
        assert!(
            same >= 10,
            "{same} of 20 directions within 0.2° share the cube"
        );
        assert_ne!(SunCubeKey::new(params.clone(), 1, 1.2, turned(5.0)), key);
        assert_ne!(SunCubeKey::new(params, 2, 1.2, sun), key);
    }
}
