//! Seeded, deterministic 2D gradient noise and fractal sums of it.
//!
//! Gradient noise after Perlin ("Improving Noise", SIGGRAPH 2002) with the
//! quintic fade 6t⁵ − 15t⁴ + 10t³, but with lattice gradients drawn from an
//! integer hash of (cell, seed) instead of a permutation table, so that any
//! seed gives an independent field and no table must be stored. Fractal
//! Brownian motion and ridged multifractal sums follow Musgrave (in Ebert et
//! al., *Texturing and Modeling*, 3rd ed., ch. 16). Inputs are dimensionless
//! lattice coordinates; outputs are dimensionless.

/// A 32-bit integer hash (the "lowbias32" finaliser by C. Wellons), good
/// enough that neighbouring lattice cells get unrelated gradients.
fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

fn hash_cell(ix: i32, iy: i32, seed: u32) -> u32 {
    hash_u32((ix as u32) ^ hash_u32((iy as u32) ^ hash_u32(seed.wrapping_add(0x9e37_79b9))))
}

/// Unit gradient of a lattice cell: one of 16 evenly spaced directions.
fn gradient(ix: i32, iy: i32, seed: u32) -> (f64, f64) {
    let angle = (hash_cell(ix, iy, seed) >> 28) as f64 * (std::f64::consts::TAU / 16.0);
    (angle.cos(), angle.sin())
}

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Gradient noise at (x, y), in about [−1, 1], zero at every lattice point.
pub fn gradient_noise(x: f64, y: f64, seed: u32) -> f64 {
    let x0 = x.floor();
    let y0 = y.floor();
    let (ix, iy) = (x0 as i32, y0 as i32);
    let (fx, fy) = (x - x0, y - y0);
    let dot = |cx: i32, cy: i32, dx: f64, dy: f64| {
        let (gx, gy) = gradient(ix + cx, iy + cy, seed);
        gx * dx + gy * dy
    };
    let n00 = dot(0, 0, fx, fy);
    let n10 = dot(1, 0, fx - 1.0, fy);
    let n01 = dot(0, 1, fx, fy - 1.0);
    let n11 = dot(1, 1, fx - 1.0, fy - 1.0);
    let (u, v) = (fade(fx), fade(fy));
    let nx0 = n00 + u * (n10 - n00);
    let nx1 = n01 + u * (n11 - n01);
    // The maximum of 2D gradient noise with unit gradients is √2/2; scale to about [−1, 1].
    (nx0 + v * (nx1 - nx0)) * std::f64::consts::SQRT_2
}

/// Parameters of a fractal sum of noise octaves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fractal {
    /// Number of octaves summed.
    pub octaves: u32,
    /// Frequency ratio between successive octaves (≈ 2).
    pub lacunarity: f64,
    /// Amplitude ratio between successive octaves (≈ 0.5).
    pub gain: f64,
}

impl Default for Fractal {
    fn default() -> Self {
        Self {
            octaves: 8,
            lacunarity: 2.0,
            gain: 0.5,
        }
    }
}

/// Rotation applied between octaves so that lattice artefacts do not align.
const OCTAVE_ROTATION: (f64, f64) = (0.8, 0.6);

fn rotate(x: f64, y: f64) -> (f64, f64) {
    let (c, s) = OCTAVE_ROTATION;
    (c * x - s * y, s * x + c * y)
}

/// Fractal Brownian motion normalised to about [−1, 1].
pub fn fbm(x: f64, y: f64, seed: u32, fractal: Fractal) -> f64 {
    let (mut px, mut py) = (x, y);
    let (mut sum, mut amplitude, mut norm) = (0.0, 1.0, 0.0);
    for octave in 0..fractal.octaves {
        sum += amplitude * gradient_noise(px, py, seed.wrapping_add(octave * 7919));
        norm += amplitude;
        amplitude *= fractal.gain;
        (px, py) = rotate(px * fractal.lacunarity, py * fractal.lacunarity);
    }
    if norm > 0.0 { sum / norm } else { 0.0 }
}

/// Ridged multifractal (Musgrave): sharp crests where the noise crosses zero,
/// each octave weighted by the previous one so that valleys stay smooth.
/// Returns a value in [0, 1].
pub fn ridged(x: f64, y: f64, seed: u32, fractal: Fractal) -> f64 {
    let (mut px, mut py) = (x, y);
    let (mut sum, mut amplitude, mut norm, mut weight) = (0.0, 1.0, 0.0, 1.0);
    for octave in 0..fractal.octaves {
        let n = 1.0 - gradient_noise(px, py, seed.wrapping_add(octave * 104_729)).abs();
        let signal = n * n * weight;
        weight = (signal * 2.0).clamp(0.0, 1.0);
        sum += amplitude * signal;
        norm += amplitude;
        amplitude *= fractal.gain;
        (px, py) = rotate(px * fractal.lacunarity, py * fractal.lacunarity);
    }
    if norm > 0.0 { sum / norm } else { 0.0 }
}

/// Hash of a 3-D lattice cell and a seed.
fn hash_cell_3d(ix: i32, iy: i32, iz: i32, seed: u32) -> u32 {
    hash_u32(
        (ix as u32)
            ^ hash_u32(
                (iy as u32) ^ hash_u32((iz as u32) ^ hash_u32(seed.wrapping_add(0x9e37_79b9))),
            ),
    )
}

/// The twelve gradients of Perlin's improved noise: the midpoints of a
/// cube's edges (Perlin 2002, §3), which avoid the clumping of random
/// unit vectors.
const EDGE_GRADIENTS: [(f64, f64, f64); 12] = [
    (1.0, 1.0, 0.0),
    (-1.0, 1.0, 0.0),
    (1.0, -1.0, 0.0),
    (-1.0, -1.0, 0.0),
    (1.0, 0.0, 1.0),
    (-1.0, 0.0, 1.0),
    (1.0, 0.0, -1.0),
    (-1.0, 0.0, -1.0),
    (0.0, 1.0, 1.0),
    (0.0, -1.0, 1.0),
    (0.0, 1.0, -1.0),
    (0.0, -1.0, -1.0),
];

/// 3-D gradient noise at (x, y, z) (Perlin 2002), in about [−1, 1], zero at
/// every lattice point. The WGSL twin is `gradient_noise_3d` in
/// `nimbus-render`'s `stratus/layer.wgsl`; both use only integer hashing and
/// the same arithmetic so that they agree to float rounding.
pub fn gradient_noise_3d(x: f64, y: f64, z: f64, seed: u32) -> f64 {
    let (x0, y0, z0) = (x.floor(), y.floor(), z.floor());
    let (ix, iy, iz) = (x0 as i32, y0 as i32, z0 as i32);
    let (fx, fy, fz) = (x - x0, y - y0, z - z0);
    let corner = |cx: i32, cy: i32, cz: i32| {
        let (gx, gy, gz) =
            EDGE_GRADIENTS[(hash_cell_3d(ix + cx, iy + cy, iz + cz, seed) % 12) as usize];
        gx * (fx - cx as f64) + gy * (fy - cy as f64) + gz * (fz - cz as f64)
    };
    let (u, v, w) = (fade(fx), fade(fy), fade(fz));
    let lerp = |a: f64, b: f64, t: f64| a + t * (b - a);
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), u);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), u);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), u);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), u);
    lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
}

/// Fractal sum of 3-D gradient noise normalised to about [−1, 1]. The
/// octaves are rotated in the (x, y) plane like [`fbm`]'s, and the third
/// coordinate is scaled with the others, so finer octaves also change
/// faster along it (time, for the cloud layer: small cells evolve faster).
pub fn fbm_3d(x: f64, y: f64, z: f64, seed: u32, fractal: Fractal) -> f64 {
    let (mut px, mut py, mut pz) = (x, y, z);
    let (mut sum, mut amplitude, mut norm) = (0.0, 1.0, 0.0);
    for octave in 0..fractal.octaves {
        sum += amplitude * gradient_noise_3d(px, py, pz, seed.wrapping_add(octave * 7919));
        norm += amplitude;
        amplitude *= fractal.gain;
        (px, py) = rotate(px * fractal.lacunarity, py * fractal.lacunarity);
        pz *= fractal.lacunarity;
    }
    if norm > 0.0 { sum / norm } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_vanishes_on_the_lattice_and_is_bounded() {
        for i in -5..5 {
            for j in -5..5 {
                assert_eq!(gradient_noise(i as f64, j as f64, 3), 0.0);
            }
        }
        let mut max = 0.0f64;
        for k in 0..20_000 {
            let (x, y) = (k as f64 * 0.0137, (k as f64 * 0.731).sin() * 40.0);
            max = max.max(gradient_noise(x, y, 11).abs());
        }
        assert!(max <= 1.0 + 1e-9 && max > 0.5, "max |noise| = {max}");
    }

    #[test]
    fn noise_is_deterministic_and_seed_dependent() {
        let a = fbm(1.234, 5.678, 42, Fractal::default());
        assert_eq!(a, fbm(1.234, 5.678, 42, Fractal::default()));
        assert_ne!(a, fbm(1.234, 5.678, 43, Fractal::default()));
    }

    #[test]
    fn fbm_has_near_zero_mean_and_ridged_stays_in_unit_interval() {
        let mut mean = 0.0;
        let n = 40_000;
        for k in 0..n {
            let (x, y) = ((k % 200) as f64 * 0.37, (k / 200) as f64 * 0.37);
            mean += fbm(x, y, 7, Fractal::default());
            let r = ridged(x, y, 7, Fractal::default());
            assert!((0.0..=1.0).contains(&r));
        }
        mean /= n as f64;
        assert!(mean.abs() < 0.05, "mean {mean}");
    }

    #[test]
    fn noise_3d_vanishes_on_the_lattice_is_bounded_and_continuous() {
        for i in -3..3 {
            for j in -3..3 {
                assert_eq!(gradient_noise_3d(i as f64, j as f64, 2.0, 5), 0.0);
            }
        }
        let mut max = 0.0f64;
        for k in 0..20_000 {
            let t = k as f64 * 0.0137;
            let (x, y, z) = (t, (t * 0.731).sin() * 40.0, (t * 0.37).cos() * 9.0);
            let n = gradient_noise_3d(x, y, z, 11);
            max = max.max(n.abs());
            // Lipschitz: the gradient of improved noise is bounded (≤ about 3).
            let d = gradient_noise_3d(x + 1e-4, y, z, 11) - n;
            assert!(d.abs() < 5e-4, "jump {d} at {x} {y} {z}");
        }
        assert!(max <= 1.1 && max > 0.5, "max |noise| = {max}");
    }
}
