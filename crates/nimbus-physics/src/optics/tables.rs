//! GPU-ready optical tables of a cloud: the peak-removed phase function P_S,
//! the forward peak P_F and the double-scattering phase function P² per RGB
//! channel, with the extinction and forward fractions, produced by
//! [`CloudOpticsTables::compute`] and cached on disk by
//! [`CloudOpticsTables::load_or_compute`] so that start-up stays fast.
//!
//! Layout, for 1-D textures with linear filtering: every table samples its
//! angle range uniformly, texel i at θ = θ_min + i (θ_max − θ_min)/(n − 1);
//! values are per steradian, f32, interleaved RGB. The three channels are the
//! representative wavelengths 680, 550 and 440 nm (nimbus's RGB convention).

use super::dsd::{SizeDistribution, bulk_optics};
use super::phase::PhaseTable;
use super::water::water_refractive_index;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Largest cloud-optics cache file read, bytes.
const MAX_CACHE_BYTES: u64 = 64 * 1024 * 1024;

/// Wavelengths (nm) of the R, G, B channels.
pub const CHANNEL_WAVELENGTHS_NM: [f64; 3] = [680.0, 550.0, 440.0];

/// What the tables are computed from.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudOpticsParams {
    /// The droplet size distribution.
    pub dsd: SizeDistribution,
    /// Half-angle of the forward peak, degrees (Bouthors 2006: 5°).
    pub forward_peak_deg: f64,
    /// Texels of the P_S and P² tables over 0–180°.
    pub texels: usize,
    /// Texels of the P_F table over 0–θ_f.
    pub peak_texels: usize,
    /// Relative tolerance of the radius integration.
    pub tolerance: f64,
}

impl CloudOpticsParams {
    /// The paper's cloud with tables of 1024 texels.
    pub fn bouthors_2006() -> Self {
        Self {
            dsd: SizeDistribution::BOUTHORS_2006,
            forward_peak_deg: 5.0,
            texels: 1024,
            peak_texels: 256,
            tolerance: 1e-3,
        }
    }

    /// A stable text key of every parameter (and the table format version).
    fn key(&self) -> String {
        format!(
            "nimbus-cloud-optics-v4 {:?} {} {} {} {}",
            self.dsd, self.forward_peak_deg, self.texels, self.peak_texels, self.tolerance
        )
    }

    /// FNV-1a hash of the key: stable across builds and platforms.
    pub fn cache_hash(&self) -> u64 {
        crate::io::fnv1a(&self.key())
    }
}

/// The tables, ready for upload.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudOpticsTables {
    /// The parameters.
    pub params: CloudOpticsParams,
    /// Extinction coefficient κ per channel, m⁻¹.
    pub extinction_per_m: [f32; 3],
    /// Forward-peak fraction P_f per channel.
    pub forward_fraction: [f32; 3],
    /// Asymmetry parameter g per channel.
    pub asymmetry: [f32; 3],
    /// P_S over 0–180°, interleaved RGB, sr⁻¹.
    pub peak_removed: Vec<f32>,
    /// P_F over 0–θ_f, interleaved RGB, sr⁻¹.
    pub forward_peak: Vec<f32>,
    /// P² (of P_S) over 0–180°, interleaved RGB, sr⁻¹.
    pub double_scattering: Vec<f32>,
}

fn resample(table: &PhaseTable, from_deg: f64, to_deg: f64, count: usize) -> Vec<f64> {
    (0..count)
        .map(|i| table.at(from_deg + (to_deg - from_deg) * i as f64 / (count - 1) as f64))
        .collect()
}

/// Angles for the bulk computation of a phase function whose forward peak
/// reaches `forward_peak_deg`: 0.05° steps to twice that (at most 30°),
/// 0.25° beyond.
pub fn computation_angles(forward_peak_deg: f64) -> Vec<f64> {
    let fine_end = (2.0 * forward_peak_deg).min(30.0);
    let mut angles: Vec<f64> = (0..)
        .map(|i| i as f64 * 0.05)
        .take_while(|a| *a < fine_end)
        .collect();
    angles.extend(
        (0..)
            .map(|i| fine_end + i as f64 * 0.25)
            .take_while(|a| *a <= 180.0),
    );
    if *angles.last().unwrap_or(&0.0) < 180.0 {
        angles.push(180.0);
    }
    angles
}

impl CloudOpticsTables {
    /// Computes the tables (seconds of CPU time; see `load_or_compute`).
    pub fn compute(params: &CloudOpticsParams) -> Self {
        let angles = computation_angles(params.forward_peak_deg);
        let (mut extinction, mut forward, mut asymmetry) = ([0.0f32; 3], [0.0f32; 3], [0.0f32; 3]);
        let (n, np) = (params.texels, params.peak_texels);
        let (mut ps, mut pf, mut p2) = (
            vec![0.0f32; 3 * n],
            vec![0.0f32; 3 * np],
            vec![0.0f32; 3 * n],
        );
        for (c, wavelength) in CHANNEL_WAVELENGTHS_NM.iter().enumerate() {
            let optics = bulk_optics(
                &params.dsd,
                *wavelength,
                water_refractive_index(*wavelength),
                &angles,
                params.tolerance,
            );
            let table = PhaseTable::new(optics.angles_deg.clone(), optics.phase.clone());
            extinction[c] = optics.extinction_per_m as f32;
            forward[c] = optics.forward_fraction(params.forward_peak_deg) as f32;
            asymmetry[c] = optics.g as f32;
            let peak_removed = table.peak_removed(params.forward_peak_deg);
            let double = peak_removed.self_convolution(n.min(361), 120);
            for (i, v) in resample(&peak_removed, 0.0, 180.0, n).iter().enumerate() {
                ps[3 * i + c] = *v as f32;
            }
            for (i, v) in resample(
                &table.forward_peak(params.forward_peak_deg),
                0.0,
                params.forward_peak_deg * 0.999_999,
                np,
            )
            .iter()
            .enumerate()
            {
                pf[3 * i + c] = *v as f32;
            }
            for (i, v) in resample(&double, 0.0, 180.0, n).iter().enumerate() {
                p2[3 * i + c] = *v as f32;
            }
        }
        Self {
            params: params.clone(),
            extinction_per_m: extinction,
            forward_fraction: forward,
            asymmetry,
            peak_removed: ps,
            forward_peak: pf,
            double_scattering: p2,
        }
    }

    /// The cache file of a parameter set in `dir`.
    pub fn cache_path(dir: &Path, params: &CloudOpticsParams) -> PathBuf {
        dir.join(format!("cloud-optics-{:016x}.bin", params.cache_hash()))
    }

    /// Loads the tables from `dir` when a cache file for these parameters
    /// exists and is intact, otherwise computes and stores them (atomically).
    pub fn load_or_compute(dir: &Path, params: &CloudOpticsParams) -> std::io::Result<Self> {
        let path = Self::cache_path(dir, params);
        if let Ok(tables) = Self::read(&path, params) {
            return Ok(tables);
        }
        let tables = Self::compute(params);
        std::fs::create_dir_all(dir)?;
        // A name unique to this process and call: threads of one process
        // (parallel tests) may compute the same tables at once.
        static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let temporary = path.with_extension(format!("{}-{call}.tmp", std::process::id()));
        {
            let mut file = std::fs::File::create(&temporary)?;
            file.write_all(&tables.to_cache_bytes())?;
            file.sync_all()?;
        }
        std::fs::rename(&temporary, &path)?;
        Ok(tables)
    }

    /// The cache file's bytes: magic, the parameters' hash, then each table
    /// as its length and little-endian f32 values.
    pub fn to_cache_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(b"NIMBUSCO");
        out.extend_from_slice(&self.params.cache_hash().to_le_bytes());
        let mut put = |values: &[f32]| {
            out.extend_from_slice(&(values.len() as u64).to_le_bytes());
            for v in values {
                out.extend_from_slice(&v.to_le_bytes());
            }
        };
        put(&self.extinction_per_m);
        put(&self.forward_fraction);
        put(&self.asymmetry);
        put(&self.peak_removed);
        put(&self.forward_peak);
        put(&self.double_scattering);
        out
    }

    fn read(path: &Path, params: &CloudOpticsParams) -> std::io::Result<Self> {
        // A cache of the largest tables is a few hundred kilobytes; anything
        // far larger (or not a regular file) is not ours and is recomputed.
        let bytes = crate::io::read_bounded(path, MAX_CACHE_BYTES)
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()))?;
        Self::from_cache_bytes(&bytes, params)
    }

    /// Reads the bytes of a cache file written for `params`; an error when
    /// they are not a whole, intact cache of exactly these parameters (the
    /// caller then recomputes). Counts in the file are checked against the
    /// parameters' table sizes before anything is allocated.
    pub fn from_cache_bytes(bytes: &[u8], params: &CloudOpticsParams) -> std::io::Result<Self> {
        let bad = || {
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "corrupt cloud-optics cache",
            )
        };
        if bytes.len() < 16
            || &bytes[..8] != b"NIMBUSCO"
            || bytes[8..16] != params.cache_hash().to_le_bytes()
        {
            return Err(bad());
        }
        let mut at = 16;
        let mut take = |expected: usize| -> std::io::Result<Vec<f32>> {
            let len_bytes: [u8; 8] = bytes
                .get(at..at + 8)
                .ok_or_else(bad)?
                .try_into()
                .map_err(|_| bad())?;
            let len = u64::from_le_bytes(len_bytes) as usize;
            if len != expected {
                return Err(bad());
            }
            at += 8;
            let data = bytes.get(at..at + 4 * len).ok_or_else(bad)?;
            at += 4 * len;
            Ok(data
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect())
        };
        let three = |v: Vec<f32>| [v[0], v[1], v[2]];
        let extinction_per_m = three(take(3)?);
        let forward_fraction = three(take(3)?);
        let asymmetry = three(take(3)?);
        let peak_removed = take(3 * params.texels)?;
        let forward_peak = take(3 * params.peak_texels)?;
        let double_scattering = take(3 * params.texels)?;
        if at != bytes.len() {
            return Err(bad());
        }
        Ok(Self {
            params: params.clone(),
            extinction_per_m,
            forward_fraction,
            asymmetry,
            peak_removed,
            forward_peak,
            double_scattering,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_normalised_physical_and_cached() {
        let params = CloudOpticsParams {
            texels: 181,
            peak_texels: 33,
            tolerance: 3e-3,
            ..CloudOpticsParams::bouthors_2006()
        };
        let dir = std::env::temp_dir().join(format!("nimbus-optics-cache-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let tables = CloudOpticsTables::load_or_compute(&dir, &params).expect("compute");
        // Bouthors 2006, §4.1: "P_f = 51 % for θ_f = 5°" for typical clouds.
        for c in 0..3 {
            let pf = tables.forward_fraction[c];
            assert!((0.40..0.60).contains(&pf), "channel {c}: P_f = {pf}");
            assert!((0.83..0.88).contains(&tables.asymmetry[c]));
        }
        // P_S and P² integrate to one over the sphere (trapezoid on the texels).
        for (name, table) in [
            ("P_S", &tables.peak_removed),
            ("P²", &tables.double_scattering),
        ] {
            for c in 0..3 {
                let values: Vec<f64> = (0..181).map(|i| table[3 * i + c] as f64).collect();
                let integral =
                    PhaseTable::new((0..181).map(|i| i as f64).collect(), values).integral();
                assert!(
                    (integral - 1.0).abs() < 0.03,
                    "{name} channel {c}: ∫ = {integral}"
                );
            }
        }
        // The cache file now exists and reproduces the tables exactly.
        assert!(CloudOpticsTables::cache_path(&dir, &params).exists());
        let again = CloudOpticsTables::load_or_compute(&dir, &params).expect("load");
        assert_eq!(again, tables);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
