//! What the in-cloud view needs of each shape variant, computed on a worker
//! thread and cached on disk beside the shapes: the coarse extinction the
//! march reads ([`nimbus_physics::cumulus::interior::downsample`] of the
//! extinction grid the path-traced references and the transport model's
//! tracer use) and the scattered light inside
//! ([`nimbus_physics::cumulus::interior::trace_interior`]) at the field's
//! smallest and largest scale, as quadratic forms the shader turns with the
//! cloud (like the surface transfer, [`super::transfer`]).

use super::transfer::{pack_form, tracer_scattering, variant_extinction_grid};
use super::variants::{CumulusVariant, VariantError, VariantParams};
use glam::DVec3;
use nimbus_physics::cumulus::interior::{InteriorSettings, downsample, trace_interior};
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
/// Largest side of the coarse extinction texture, cells (≤ 128³ texels of
/// 2 bytes: 4 MiB per variant).
pub const EXTINCTION_CELLS: usize = 128;
const CACHE_MAGIC: &[u8; 8] = b"NIMBUSIC";
const CACHE_VERSION: u32 = 1;
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
        text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        })
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
    /// smallest scale, then at the largest.
    pub light_forms: Vec<[[f32; 4]; 6]>,
}

/// Computes variant `index`'s interior (seconds).
pub fn compute_interior(
    params: &InteriorParams,
    index: u32,
    shape: &CumulusVariant,
    optics: &CloudOpticsTables,
) -> Result<VariantInterior, VariantError> {
    let grid = variant_extinction_grid(
        &params.variants,
        index,
        params.density_per_m,
        params.corona_thickness_m,
    )?;
    let origin = DVec3::from_array(shape.origin_m.map(f64::from));
    let (scattering, truncated) = tracer_scattering(optics);
    let mut forms: Vec<[[f32; 4]; 6]> = Vec::new();
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
            forms = vec![[[0.0; 4]; 6]; interior.coefficients.len()];
        }
        for (out, phi) in forms.iter_mut().zip(&interior.coefficients) {
            let packed = pack_form(&SphericalQuadratic::from_sh(phi));
            out[3 * slot..3 * slot + 3].copy_from_slice(&packed);
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
    let light_forms: Vec<[[f32; 4]; 6]> =
        bytemuck::pod_collect_to_vec(take(light_cells.checked_mul(96)?)?);
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
                || compute_interior(params, index, shape, optics),
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
            light_forms: vec![[[1.0, 2.0, 3.0, 4.0]; 6]; 2],
        };
        let bytes = to_bytes(&interior);
        assert_eq!(from_bytes(&bytes), Some(interior));
        assert_eq!(from_bytes(&bytes[..bytes.len() - 1]), None);
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(from_bytes(&longer), None);
    }
}
