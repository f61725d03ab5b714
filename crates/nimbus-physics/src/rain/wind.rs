//! The wind the drops are carried by: W(x, t) = a mean wind + a periodic 3-D
//! velocity grid (generated frozen turbulence carried along by the mean wind,
//! Taylor's hypothesis, or a field read from a file, fixed in the world or
//! carried) + flow primitives after Wejchert & Haumann, "Animation
//! aerodynamics", SIGGRAPH 1991 (uniform flow, source/sink, vortex) and gust
//! fronts crossing the scene.
//!
//! Blanchard (2023, §4.2.1) splits the wind into a global direction W_D and
//! local perturbations W_L(x, t) (a vector field); this is that split, with
//! W_L built from a grid and primitives. Every function here has a WGSL twin
//! in `nimbus-render/src/rain/simulation.wgsl`, evaluated in f32 the same way.
//!
//! Units: positions m, velocities m/s, times s.

use crate::rain::random::uniform;
use glam::Vec3;

/// Most primitives in one wind field (the GPU's fixed-size array).
pub const MAX_WIND_PRIMITIVES: usize = 16;

/// What a primitive does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindPrimitiveKind {
    /// Uniform flow along `axis` at `speed_m_s`, everywhere (`radius_m` 0)
    /// or in a ball of `radius_m` fading to its edge (a jet).
    Uniform = 0,
    /// Radial flow out of `center_m` (a sink for negative `speed_m_s`): the
    /// 3-D point source, speed s·(R/r)² beyond the core radius R and
    /// s·r/R inside it (a solid core keeps it finite).
    Source = 1,
    /// Rotation about the line through `center_m` along `axis`: the Rankine
    /// vortex, tangential speed s·R/ρ beyond the core radius R, s·ρ/R inside.
    Vortex = 2,
    /// Gust fronts travelling along the horizontal `axis` at
    /// `front_speed_m_s`, one every `period_s`: behind each front the wind
    /// rises to `speed_m_s` at `radius_m` and decays, profile
    /// (ξ/R)·e^(1 − ξ/R) of the distance ξ behind the front.
    GustFront = 3,
}

/// One flow primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindPrimitive {
    /// What it does.
    pub kind: WindPrimitiveKind,
    /// Centre at t = 0, m (for gust fronts: the middle of the fronts' run).
    pub center_m: Vec3,
    /// Velocity of the centre, m/s (primitives drift with the weather).
    pub drift_m_s: Vec3,
    /// Unit direction: flow direction, vortex axis or gust direction.
    pub axis: Vec3,
    /// Characteristic speed, m/s (see [`WindPrimitiveKind`]).
    pub speed_m_s: f32,
    /// Characteristic radius, m (see [`WindPrimitiveKind`]).
    pub radius_m: f32,
    /// Gust fronts: time between fronts, s.
    pub period_s: f32,
    /// Gust fronts: speed of the fronts, m/s.
    pub front_speed_m_s: f32,
}

/// Profile of a gust behind its front: (ξ/R)·e^(1 − ξ/R) for ξ > 0, 0 ahead.
fn gust_profile(behind_m: f32, width_m: f32) -> f32 {
    if behind_m <= 0.0 {
        return 0.0;
    }
    let s = behind_m / width_m.max(1e-3);
    s * (1.0 - s).exp()
}

impl WindPrimitive {
    /// The primitive's wind at `p` and time `t_s`, m/s.
    pub fn velocity_m_s(&self, p: Vec3, t_s: f32) -> Vec3 {
        let c = self.center_m + self.drift_m_s * t_s;
        let d = p - c;
        let r_core = self.radius_m.max(1e-3);
        match self.kind {
            WindPrimitiveKind::Uniform => {
                let fade = if self.radius_m > 0.0 {
                    let q = (d.length_squared() / (self.radius_m * self.radius_m)).min(1.0);
                    (1.0 - q) * (1.0 - q)
                } else {
                    1.0
                };
                self.axis * (self.speed_m_s * fade)
            }
            WindPrimitiveKind::Source => {
                let r = d.length();
                if r < 1e-6 {
                    return Vec3::ZERO;
                }
                let speed = if r < r_core {
                    self.speed_m_s * r / r_core
                } else {
                    self.speed_m_s * (r_core / r) * (r_core / r)
                };
                d * (speed / r)
            }
            WindPrimitiveKind::Vortex => {
                let radial = d - self.axis * d.dot(self.axis);
                let rho = radial.length();
                if rho < 1e-6 {
                    return Vec3::ZERO;
                }
                let speed = if rho < r_core {
                    self.speed_m_s * rho / r_core
                } else {
                    self.speed_m_s * r_core / rho
                };
                self.axis.cross(radial) * (speed / rho)
            }
            WindPrimitiveKind::GustFront => {
                let period = self.period_s.max(1e-3);
                let run_m = self.front_speed_m_s * period;
                let phase = t_s / period;
                let front_m = (phase - phase.floor()) * run_m - 0.5 * run_m;
                let behind = front_m - d.dot(self.axis);
                // The current front and the one before it, so the wind is
                // continuous when a new front starts.
                let g = gust_profile(behind, self.radius_m)
                    + gust_profile(behind + run_m, self.radius_m);
                self.axis * (self.speed_m_s * g)
            }
        }
    }

    /// The GPU layout (WGSL `WindPrimitive`): four vec4s.
    pub fn to_gpu(&self) -> [[f32; 4]; 4] {
        [
            [
                self.center_m.x,
                self.center_m.y,
                self.center_m.z,
                self.kind as u32 as f32,
            ],
            [self.axis.x, self.axis.y, self.axis.z, self.speed_m_s],
            [
                self.drift_m_s.x,
                self.drift_m_s.y,
                self.drift_m_s.z,
                self.radius_m,
            ],
            [self.period_s, self.front_speed_m_s, 0.0, 0.0],
        ]
    }
}

/// A periodic grid of wind velocities (the scene's turbulence or a field
/// read from a file), sampled trilinearly with wrap-around.
#[derive(Clone, Debug, PartialEq)]
pub struct WindGrid {
    /// Grid points along x, y and z (the grid repeats with this period).
    pub cells: [u32; 3],
    /// Spacing of the grid points, m.
    pub cell_m: f32,
    /// World position of grid point (0, 0, 0) at time 0, m.
    pub origin_m: Vec3,
    /// Whether the grid moves with the mean wind (frozen turbulence) or
    /// stays in place in the world.
    pub carried: bool,
    /// Velocities, x fastest then y then z, m/s (w unused, for the GPU's vec4 layout).
    pub velocities_m_s: Vec<[f32; 4]>,
}

/// Most grid points of a wind grid read from a file (64 MiB on the GPU).
pub const MAX_WIND_GRID_POINTS: u64 = 1 << 22;

/// Largest `.npy` wind field read, bytes: [`MAX_WIND_GRID_POINTS`] float64
/// vectors and the longest header a version 1–3 file of them needs
/// (64 KiB, far more than NumPy writes).
pub const MAX_WIND_NPY_BYTES: u64 = MAX_WIND_GRID_POINTS * 3 * 8 + 64 * 1024;

/// Why a wind-field file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum WindGridError {
    /// Not a NumPy array file of the supported kind.
    #[error("{0}")]
    Format(String),
    /// A value that is not a finite speed of at most 300 m/s.
    #[error(
        "velocity {value} at grid point (x {x}, y {y}, z {z}) is not a finite speed of at most 300 m/s"
    )]
    Value {
        /// The value.
        value: f64,
        /// Grid point.
        x: usize,
        /// Grid point.
        y: usize,
        /// Grid point.
        z: usize,
    },
}

impl WindGrid {
    /// Reads a wind field from the bytes of a NumPy `.npy` file (format
    /// versions 1–3): little-endian float32 or float64, C order, shape
    /// (nz, ny, nx, 3) — the velocity (x, y, z) in m/s at grid point
    /// (x, y, z), y up — with nx, ny, nz ≥ 2 and at most
    /// [`MAX_WIND_GRID_POINTS`] points. The grid repeats beyond its
    /// n·`cell_m` extent on each axis.
    pub fn from_npy(
        bytes: &[u8],
        cell_m: f32,
        origin_m: Vec3,
        carried: bool,
    ) -> Result<Self, WindGridError> {
        let format = |m: &str| WindGridError::Format(m.to_owned());
        if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
            return Err(format("not a NumPy .npy file (no \\x93NUMPY magic)"));
        }
        let (header_len, start) = match bytes[6] {
            1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
            2 | 3 if bytes.len() >= 12 => (
                u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
                12,
            ),
            v => {
                return Err(WindGridError::Format(format!(
                    "unsupported .npy version {v}"
                )));
            }
        };
        let header = bytes
            .get(start..start + header_len)
            .and_then(|h| std::str::from_utf8(h).ok())
            .ok_or_else(|| format("truncated or unreadable .npy header"))?;
        // The header is a Python dict literal: {'descr': '<f4',
        // 'fortran_order': False, 'shape': (nz, ny, nx, 3), }.
        let value_of = |key: &str| -> Option<&str> {
            let at = header.find(&format!("'{key}'"))? + key.len() + 2;
            let rest = header[at..].trim_start().strip_prefix(':')?.trim_start();
            Some(rest)
        };
        let descr = value_of("descr").ok_or_else(|| format("the header has no 'descr'"))?;
        let width = if descr.starts_with("'<f4'") {
            4
        } else if descr.starts_with("'<f8'") {
            8
        } else {
            return Err(WindGridError::Format(format!(
                "dtype {}: must be little-endian float32 ('<f4') or float64 ('<f8')",
                crate::io::shown_text(
                    descr.split(',').next().unwrap_or(descr).trim(),
                    crate::io::MAX_SHOWN_CHARS
                )
            )));
        };
        if !value_of("fortran_order").is_some_and(|v| v.starts_with("False")) {
            return Err(format("the array must be in C order (fortran_order False)"));
        }
        let shape_text = value_of("shape")
            .and_then(|v| v.strip_prefix('('))
            .and_then(|v| v.split(')').next())
            .ok_or_else(|| format("the header has no 'shape'"))?;
        // The header's text is shown as error lines show file content.
        let shown_shape = crate::io::shown_text(shape_text, crate::io::MAX_SHOWN_CHARS);
        let shape: Vec<usize> = shape_text
            .split(',')
            .map(str::trim)
            .filter(|t| !t.is_empty())
            .map(|t| t.parse::<usize>())
            .collect::<Result<_, _>>()
            .map_err(|_| {
                WindGridError::Format(format!("shape ({shown_shape}) is not a tuple of sizes"))
            })?;
        let [nz, ny, nx, 3] = shape[..] else {
            return Err(WindGridError::Format(format!(
                "shape ({shown_shape}): must be (nz, ny, nx, 3)"
            )));
        };
        let points = (nx as u64) * (ny as u64) * (nz as u64);
        if nx < 2 || ny < 2 || nz < 2 || points > MAX_WIND_GRID_POINTS {
            return Err(WindGridError::Format(format!(
                "shape ({shown_shape}): needs at least 2 points per axis and at most {MAX_WIND_GRID_POINTS} points"
            )));
        }
        let data = &bytes[start + header_len..];
        let count = points as usize * 3;
        // Exactly: trailing bytes mean the header does not describe the file.
        if data.len() != count * width {
            return Err(WindGridError::Format(format!(
                "the data hold {} bytes, the shape needs exactly {}",
                data.len(),
                count * width
            )));
        }
        let value = |i: usize| -> f64 {
            let b = &data[i * width..(i + 1) * width];
            if width == 4 {
                f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64
            } else {
                f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
            }
        };
        let mut velocities_m_s = Vec::with_capacity(points as usize);
        for point in 0..points as usize {
            let mut v = [0.0f32; 4];
            for (c, slot) in v.iter_mut().take(3).enumerate() {
                let x = value(3 * point + c);
                if !(x.is_finite() && x.abs() <= 300.0) {
                    return Err(WindGridError::Value {
                        value: x,
                        x: point % nx,
                        y: point / nx % ny,
                        z: point / (nx * ny),
                    });
                }
                *slot = x as f32;
            }
            velocities_m_s.push(v);
        }
        Ok(Self {
            cells: [nx as u32, ny as u32, nz as u32],
            cell_m,
            origin_m,
            carried,
            velocities_m_s,
        })
    }

    /// The velocities as a NumPy `.npy` file (version 1, float32, shape
    /// (nz, ny, nx, 3)), the format [`Self::from_npy`] reads.
    pub fn to_npy(&self) -> Vec<u8> {
        let [nx, ny, nz] = self.cells;
        let mut header =
            format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({nz}, {ny}, {nx}, 3), }}");
        // Magic (6) + version (2) + length (2) + header + newline, padded
        // with spaces to a multiple of 64 bytes (the format's alignment).
        let unpadded = 10 + header.len() + 1;
        header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
        header.push('\n');
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
        bytes.extend_from_slice(header.as_bytes());
        for v in &self.velocities_m_s {
            for c in &v[..3] {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
        }
        bytes
    }
}

/// Random Fourier modes in a generated turbulence grid.
const TURBULENCE_MODES: u32 = 48;
/// Largest integer wavenumber of a mode (per tile), so that a mode spans at
/// least `cells_per_side / 4` cells and trilinear sampling resolves it.
const TURBULENCE_MAX_WAVENUMBER: i32 = 4;

impl WindGrid {
    /// Divergence-free random turbulence, periodic over a tile of `tile_m`,
    /// with RMS speed `rms_speed_m_s`: a sum of Fourier modes a·cos(k·x + φ)
    /// with a ⊥ k (each mode, hence the sum, has zero divergence) and
    /// amplitudes falling as |k|^(−5/6) per mode, so that energy per unit
    /// wavenumber falls as the Kolmogorov k^(−5/3) for modes spread evenly
    /// over the shells.
    /// The grid is carried by the mean wind (Taylor's frozen turbulence).
    pub fn turbulence(cells_per_side: u32, tile_m: f32, rms_speed_m_s: f32, seed: u32) -> Self {
        let n = cells_per_side.max(2);
        let mut modes = Vec::new();
        let mut draw = 0u32;
        let mut next = || {
            draw += 1;
            uniform(seed, draw, 0x77_17)
        };
        while modes.len() < TURBULENCE_MODES as usize {
            let m = TURBULENCE_MAX_WAVENUMBER;
            let k = [0; 3].map(|_| ((next() * (2 * m + 1) as f32).floor() as i32 - m).clamp(-m, m));
            let kv = Vec3::new(k[0] as f32, k[1] as f32, k[2] as f32);
            if kv.length_squared() < 0.5 {
                continue;
            }
            let khat = kv.normalize();
            let raw = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let a = raw - khat * raw.dot(khat);
            if a.length_squared() < 1e-6 {
                continue;
            }
            let amplitude = kv.length().powf(-5.0 / 6.0);
            let phase = next() * std::f32::consts::TAU;
            modes.push((kv, a.normalize() * amplitude, phase));
        }
        let mut velocities = Vec::with_capacity((n * n * n) as usize);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let q = Vec3::new(x as f32, y as f32, z as f32) / n as f32;
                    let mut v = Vec3::ZERO;
                    for (k, a, phase) in &modes {
                        v += *a * (std::f32::consts::TAU * k.dot(q) + phase).cos();
                    }
                    velocities.push(v);
                }
            }
        }
        let mean_square =
            velocities.iter().map(|v| v.length_squared()).sum::<f32>() / velocities.len() as f32;
        let scale = rms_speed_m_s / mean_square.sqrt().max(1e-12);
        Self {
            cells: [n; 3],
            cell_m: tile_m / n as f32,
            origin_m: Vec3::ZERO,
            carried: true,
            velocities_m_s: velocities
                .into_iter()
                .map(|v| {
                    let v = v * scale;
                    [v.x, v.y, v.z, 0.0]
                })
                .collect(),
        }
    }

    fn at(&self, i: i32, j: i32, k: i32) -> Vec3 {
        let [nx, ny, nz] = self.cells.map(|n| n as i32);
        let index = (i.rem_euclid(nx) + nx * (j.rem_euclid(ny) + ny * k.rem_euclid(nz))) as usize;
        let v = self.velocities_m_s[index];
        Vec3::new(v[0], v[1], v[2])
    }

    /// Trilinear sample at `p` relative to the grid's point (0, 0, 0), m/s
    /// (grid points at integer multiples of the cell size).
    pub fn sample(&self, p: Vec3) -> Vec3 {
        let g = p / self.cell_m;
        let base = g.floor();
        let f = g - base;
        let (i, j, k) = (base.x as i32, base.y as i32, base.z as i32);
        let lerp = |a: Vec3, b: Vec3, t: f32| a + (b - a) * t;
        let x00 = lerp(self.at(i, j, k), self.at(i + 1, j, k), f.x);
        let x10 = lerp(self.at(i, j + 1, k), self.at(i + 1, j + 1, k), f.x);
        let x01 = lerp(self.at(i, j, k + 1), self.at(i + 1, j, k + 1), f.x);
        let x11 = lerp(self.at(i, j + 1, k + 1), self.at(i + 1, j + 1, k + 1), f.x);
        lerp(lerp(x00, x10, f.y), lerp(x01, x11, f.y), f.z)
    }
}

/// The wind field W(x, t).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WindField {
    /// The mean (global) wind, m/s.
    pub mean_m_s: Vec3,
    /// A velocity grid: frozen turbulence or a field from a file.
    pub grid: Option<WindGrid>,
    /// Local primitives, at most [`MAX_WIND_PRIMITIVES`].
    pub primitives: Vec<WindPrimitive>,
}

impl WindField {
    /// A uniform wind.
    pub fn uniform(mean_m_s: Vec3) -> Self {
        Self {
            mean_m_s,
            ..Self::default()
        }
    }

    /// W(p, t), m/s.
    pub fn velocity_m_s(&self, p: Vec3, t_s: f32) -> Vec3 {
        let mut w = self.mean_m_s;
        if let Some(grid) = &self.grid {
            let mut q = p - grid.origin_m;
            if grid.carried {
                q -= self.mean_m_s * t_s;
            }
            w += grid.sample(q);
        }
        for primitive in self.primitives.iter().take(MAX_WIND_PRIMITIVES) {
            w += primitive.velocity_m_s(p, t_s);
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small grid whose velocity says where it is: (x, 10 y, 100 z) at
    /// grid point (x, y, z).
    fn labelled_grid(carried: bool) -> WindGrid {
        let cells = [4u32, 3, 2];
        let mut velocities_m_s = Vec::new();
        for z in 0..cells[2] {
            for y in 0..cells[1] {
                for x in 0..cells[0] {
                    velocities_m_s.push([x as f32, 10.0 * y as f32, 100.0 * z as f32, 0.0]);
                }
            }
        }
        WindGrid {
            cells,
            cell_m: 2.0,
            origin_m: Vec3::new(10.0, -4.0, 6.0),
            carried,
            velocities_m_s,
        }
    }

    #[test]
    fn wind_grids_round_trip_through_npy_files() {
        let grid = labelled_grid(false);
        let bytes = grid.to_npy();
        // The header is padded to a multiple of 64 bytes, as NumPy writes it.
        assert_eq!(
            (10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize) % 64,
            0
        );
        let read = WindGrid::from_npy(&bytes, 2.0, grid.origin_m, false).expect("npy");
        assert_eq!(read, grid);
        // float64 files read too: the same header with '<f8' and 8-byte values.
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).expect("utf8");
        let mut doubles = bytes[..10].to_vec();
        doubles.extend_from_slice(header.replace("<f4", "<f8").as_bytes());
        for v in &grid.velocities_m_s {
            for c in &v[..3] {
                doubles.extend_from_slice(&(*c as f64).to_le_bytes());
            }
        }
        assert_eq!(
            WindGrid::from_npy(&doubles, 2.0, grid.origin_m, false).expect("f8"),
            grid
        );
    }

    #[test]
    fn bad_npy_files_are_refused_with_a_reason() {
        let good = labelled_grid(false).to_npy();
        let header_len = 10 + u16::from_le_bytes([good[8], good[9]]) as usize;
        let with_header = |from: &str, to: &str| {
            let mut b = good.clone();
            let text = std::str::from_utf8(&good[10..header_len])
                .expect("utf8")
                .replace(from, to);
            assert_eq!(text.len(), header_len - 10);
            b[10..header_len].copy_from_slice(text.as_bytes());
            b
        };
        let mut nan = good.clone();
        nan[header_len + 4 * 7..header_len + 4 * 8].copy_from_slice(&f32::NAN.to_le_bytes());
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"PK\x03\x04 not npy".to_vec(), "magic"),
            (with_header("<f4", ">f4"), "dtype"),
            (with_header("<f4", "<i4"), "dtype"),
            (with_header("False", "True "), "C order"),
            (
                with_header("(2, 3, 4, 3)", "(2, 3, 4, 2)"),
                "(nz, ny, nx, 3)",
            ),
            (with_header("(2, 3, 4, 3)", "(1, 3, 4, 3)"), "at least 2"),
            (good[..good.len() - 4].to_vec(), "bytes"),
            (nan, "(x 2, y 0, z 0)"),
        ];
        for (bytes, reason) in cases {
            let error = WindGrid::from_npy(&bytes, 1.0, Vec3::ZERO, false)
                .expect_err(reason)
                .to_string();
            assert!(error.contains(reason), "{error:?} should say {reason:?}");
        }
    }

    #[test]
    fn a_fixed_grid_stays_put_and_a_carried_one_moves_with_the_mean_wind() {
        let mean = Vec3::new(3.0, 0.0, -1.0);
        let fixed = WindField {
            mean_m_s: mean,
            grid: Some(labelled_grid(false)),
            primitives: Vec::new(),
        };
        // Grid point (1, 2, 1) is at origin + 2 m × (1, 2, 1), at every time.
        let p = Vec3::new(12.0, 0.0, 8.0);
        for t in [0.0, 7.5] {
            let w = fixed.velocity_m_s(p, t) - mean;
            assert!((w - Vec3::new(1.0, 20.0, 100.0)).length() < 1e-4, "{w}");
        }
        // Halfway between points (1, 2, 1) and (2, 2, 1); and the grid
        // wraps: x = 4 cells further is the same point.
        let halfway = fixed.velocity_m_s(p + Vec3::X, 0.0) - mean;
        assert!(
            (halfway - Vec3::new(1.5, 20.0, 100.0)).length() < 1e-4,
            "{halfway}"
        );
        let wrapped = fixed.velocity_m_s(p + Vec3::X * 8.0, 0.0) - mean;
        assert!(
            (wrapped - Vec3::new(1.0, 20.0, 100.0)).length() < 1e-4,
            "{wrapped}"
        );
        // Carried: at time t the point that was at p is at p + mean·t.
        let carried = WindField {
            grid: Some(labelled_grid(true)),
            ..fixed
        };
        let w = carried.velocity_m_s(p + mean * 2.0, 2.0) - mean;
        assert!((w - Vec3::new(1.0, 20.0, 100.0)).length() < 1e-4, "{w}");
    }

    fn divergence(f: impl Fn(Vec3) -> Vec3, p: Vec3, h: f32) -> f32 {
        let dx = (f(p + Vec3::X * h) - f(p - Vec3::X * h)).x;
        let dy = (f(p + Vec3::Y * h) - f(p - Vec3::Y * h)).y;
        let dz = (f(p + Vec3::Z * h) - f(p - Vec3::Z * h)).z;
        (dx + dy + dz) / (2.0 * h)
    }

    #[test]
    fn vortex_and_source_are_the_potential_flows_of_wejchert_and_haumann() {
        let vortex = WindPrimitive {
            kind: WindPrimitiveKind::Vortex,
            center_m: Vec3::ZERO,
            drift_m_s: Vec3::ZERO,
            axis: Vec3::Y,
            speed_m_s: 10.0,
            radius_m: 5.0,
            period_s: 0.0,
            front_speed_m_s: 0.0,
        };
        // Tangential, counter-clockwise about +Y, speed s·R/ρ outside the core.
        let v = vortex.velocity_m_s(Vec3::new(20.0, 3.0, 0.0), 0.0);
        assert!((v - Vec3::new(0.0, 0.0, -2.5)).length() < 1e-5, "{v}");
        // Irrotational flow outside the core is divergence-free.
        let div = divergence(
            |p| vortex.velocity_m_s(p, 0.0),
            Vec3::new(12.0, 1.0, 7.0),
            0.01,
        );
        assert!(div.abs() < 1e-3, "{div}");
        let source = WindPrimitive {
            kind: WindPrimitiveKind::Source,
            ..vortex
        };
        // Outside the core the point source's flux through any sphere is
        // constant: divergence-free.
        let div = divergence(
            |p| source.velocity_m_s(p, 0.0),
            Vec3::new(9.0, -4.0, 6.0),
            0.01,
        );
        assert!(div.abs() < 1e-3, "{div}");
        let v = source.velocity_m_s(Vec3::new(0.0, 0.0, 10.0), 0.0);
        assert!((v - Vec3::new(0.0, 0.0, 2.5)).length() < 1e-5, "{v}");
    }

    #[test]
    fn gust_fronts_cross_and_are_continuous_in_time() {
        let gust = WindPrimitive {
            kind: WindPrimitiveKind::GustFront,
            center_m: Vec3::ZERO,
            drift_m_s: Vec3::ZERO,
            axis: Vec3::X,
            speed_m_s: 8.0,
            radius_m: 20.0,
            period_s: 30.0,
            front_speed_m_s: 10.0,
        };
        let p = Vec3::ZERO;
        let mut peak: f32 = 0.0;
        let mut previous = gust.velocity_m_s(p, 0.0);
        for step in 1..=6000 {
            let t = step as f32 * 0.01;
            let v = gust.velocity_m_s(p, t);
            assert!(
                (v - previous).length() < 0.15,
                "jump at {t}: {previous} → {v}"
            );
            peak = peak.max(v.x);
            previous = v;
        }
        assert!((peak - 8.0).abs() < 0.05, "{peak}");
    }

    #[test]
    fn turbulence_is_divergence_free_periodic_and_has_its_rms_speed() {
        let grid = WindGrid::turbulence(32, 64.0, 2.0, 9);
        let rms = (grid
            .velocities_m_s
            .iter()
            .map(|v| v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            .sum::<f32>()
            / grid.velocities_m_s.len() as f32)
            .sqrt();
        assert!((rms - 2.0).abs() < 1e-3, "{rms}");
        let p = Vec3::new(3.3, 17.1, 40.2);
        assert!((grid.sample(p) - grid.sample(p + Vec3::splat(64.0))).length() < 1e-4);
        // The sampled field's divergence, relative to its gradients' scale.
        let mut worst: f32 = 0.0;
        for i in 0..50 {
            let q = Vec3::new(
                i as f32 * 1.37,
                i as f32 * 0.71 + 5.0,
                60.0 - i as f32 * 1.13,
            );
            worst = worst.max(divergence(|x| grid.sample(x), q, 0.5).abs());
        }
        // |∇v| ~ rms·2π·k_max/tile ≈ 0.8 s⁻¹; trilinear interpolation keeps the divergence small.
        assert!(worst < 0.1, "{worst}");
    }
}
