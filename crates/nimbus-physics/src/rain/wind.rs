//! The wind the drops are carried by: W(x, t) = a mean wind + frozen
//! turbulence from a periodic 3-D velocity grid carried along by the mean
//! wind (Taylor's hypothesis) + flow primitives after Wejchert & Haumann,
//! "Animation aerodynamics", SIGGRAPH 1991 (uniform flow, source/sink,
//! vortex) and gust fronts crossing the scene.
//!
//! Blanchard (2023, §4.2.1) splits the wind into a global direction W_D and
//! local perturbations W_L(x, t) (a vector field); this is that split, with
//! W_L built from a grid and primitives. Every function here has a WGSL twin
//! in `nimbus-render/src/rain/wind.wgsl`, evaluated in f32 the same way.
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

/// A periodic grid of wind velocities (the scene's turbulence), sampled
/// trilinearly with wrap-around.
#[derive(Clone, Debug, PartialEq)]
pub struct TurbulenceGrid {
    /// Cells per side (the grid is cubic and periodic).
    pub cells_per_side: u32,
    /// Cell size, m.
    pub cell_m: f32,
    /// Velocities, x fastest then y then z, m/s (w unused, for the GPU's vec4 layout).
    pub velocities_m_s: Vec<[f32; 4]>,
}

/// Random Fourier modes in a generated turbulence grid.
const TURBULENCE_MODES: u32 = 48;
/// Largest integer wavenumber of a mode (per tile), so that a mode spans at
/// least `cells_per_side / 4` cells and trilinear sampling resolves it.
const TURBULENCE_MAX_WAVENUMBER: i32 = 4;

impl TurbulenceGrid {
    /// Divergence-free random turbulence, periodic over a tile of `tile_m`,
    /// with RMS speed `rms_speed_m_s`: a sum of Fourier modes a·cos(k·x + φ)
    /// with a ⊥ k (each mode, hence the sum, has zero divergence) and
    /// amplitudes falling as |k|^(−5/6) per mode, so that energy per unit
    /// wavenumber falls as the Kolmogorov k^(−5/3) for modes spread evenly
    /// over the shells.
    pub fn generate(cells_per_side: u32, tile_m: f32, rms_speed_m_s: f32, seed: u32) -> Self {
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
            cells_per_side: n,
            cell_m: tile_m / n as f32,
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
        let n = self.cells_per_side as i32;
        let index = (i.rem_euclid(n) + n * (j.rem_euclid(n) + n * k.rem_euclid(n))) as usize;
        let v = self.velocities_m_s[index];
        Vec3::new(v[0], v[1], v[2])
    }

    /// Trilinear sample at `p`, m/s (grid points at integer multiples of the cell size).
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
    /// Frozen turbulence, carried by the mean wind.
    pub turbulence: Option<TurbulenceGrid>,
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
        if let Some(grid) = &self.turbulence {
            w += grid.sample(p - self.mean_m_s * t_s);
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
        let grid = TurbulenceGrid::generate(32, 64.0, 2.0, 9);
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
