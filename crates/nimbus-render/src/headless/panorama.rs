//! Panoramas: six perspective cube faces resampled to one equirectangular
//! (latitude–longitude) image, the layout of HDRI environment maps; and the
//! CPU tone mapping such an image needs, since its faces are drawn as six
//! frames that the GPU's exposure meters separately.
//!
//! Rasterised passes (terrain, cumulus meshes, rain streaks) cannot project
//! onto a sphere directly, so a panorama is drawn as a cube map and
//! resampled, as offline renderers' panoramic cameras do for rasterisers
//! (e.g. Blender EEVEE's light probes). Each face is drawn a little wider
//! than 90° ([`OVERSCAN_PX`] on each side) so that bilinear filtering never
//! reads past its edge and the seams between faces do not show.

use crate::frame::{CubeFace, equirectangular_direction};
use glam::DVec3;

/// Pixels drawn beyond each edge of a cube face.
pub const OVERSCAN_PX: u32 = 2;

/// Smallest cube face drawn, pixels.
const MIN_FACE_PX: u32 = 8;

/// The size of the cube faces for an equirectangular image of this size:
/// the faces' pixels at their centres are as fine as the panorama's at the
/// equator (a face spans a quarter of the longitudes and half the latitudes).
pub fn face_size_px(width: u32, height: u32) -> u32 {
    width.div_ceil(4).max(height.div_ceil(2)).max(MIN_FACE_PX)
}

/// Side of a face's image including the overscan, pixels.
pub fn face_side_px(face_px: u32) -> u32 {
    face_px + 2 * OVERSCAN_PX
}

/// Where a direction falls in a face's image: the face and the continuous
/// pixel coordinates (x right, y down, pixel centres at half-integers minus
/// one half, i.e. pixel `i` covers `[i, i + 1)` and its centre is `i + ½`
/// — returned here as `position − ½` so that `floor` gives the left sample).
fn face_coordinates(direction: DVec3, face_px: u32) -> (usize, f64, f64) {
    let (face, right, up) = CubeFace::project(direction);
    let index = CubeFace::ALL
        .iter()
        .position(|f| *f == face)
        .unwrap_or_default();
    let half = f64::from(face_px) * 0.5;
    let centre = f64::from(face_side_px(face_px)) * 0.5;
    (index, centre + right * half - 0.5, centre - up * half - 0.5)
}

/// The cube-face plane coordinates `(right, up)` at unit distance of the
/// centre of pixel (`x`, `y`) of a face image (overscan included).
pub fn face_plane_coordinates(x: u32, y: u32, face_px: u32) -> (f64, f64) {
    let half = f64::from(face_px) * 0.5;
    let centre = f64::from(face_side_px(face_px)) * 0.5;
    (
        (f64::from(x) + 0.5 - centre) / half,
        (centre - (f64::from(y) + 0.5)) / half,
    )
}

/// How to read between pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// Bilinear interpolation (radiance, opacity).
    Bilinear,
    /// The nearest pixel (distances: interpolating across an object's edge
    /// would invent surfaces between it and what is behind).
    Nearest,
}

/// Resamples six face images (in [`CubeFace::ALL`] order, each
/// [`face_side_px`]² pixels, rows top to bottom) to an equirectangular image
/// of `width` × `height` pixels.
pub fn resample<const C: usize>(
    faces: &[Vec<[f32; C]>; 6],
    face_px: u32,
    width: u32,
    height: u32,
    filter: Filter,
) -> Vec<[f32; C]> {
    let side = face_side_px(face_px) as usize;
    let mut out = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height {
        for x in 0..width {
            let u = (f64::from(x) + 0.5) / f64::from(width);
            let v = (f64::from(y) + 0.5) / f64::from(height);
            let (face, px, py) = face_coordinates(equirectangular_direction(u, v), face_px);
            let image = &faces[face];
            let value = match filter {
                Filter::Nearest => {
                    let ix = (px + 0.5).floor().clamp(0.0, (side - 1) as f64) as usize;
                    let iy = (py + 0.5).floor().clamp(0.0, (side - 1) as f64) as usize;
                    image[iy * side + ix]
                }
                Filter::Bilinear => {
                    let x0 = px.floor().clamp(0.0, (side - 2) as f64);
                    let y0 = py.floor().clamp(0.0, (side - 2) as f64);
                    let (fx, fy) = ((px - x0).clamp(0.0, 1.0), (py - y0).clamp(0.0, 1.0));
                    let (x0, y0) = (x0 as usize, y0 as usize);
                    let at = |ix: usize, iy: usize| image[iy * side + ix];
                    let (a, b, c, d) = (
                        at(x0, y0),
                        at(x0 + 1, y0),
                        at(x0, y0 + 1),
                        at(x0 + 1, y0 + 1),
                    );
                    std::array::from_fn(|k| {
                        let top = f64::from(a[k]) * (1.0 - fx) + f64::from(b[k]) * fx;
                        let bottom = f64::from(c[k]) * (1.0 - fx) + f64::from(d[k]) * fx;
                        (top * (1.0 - fy) + bottom * fy) as f32
                    })
                }
            };
            out.push(value);
        }
    }
    out
}

/// The log-average luminance of an equirectangular image, cd/m², each pixel
/// weighted by the solid angle it covers (cos latitude) — the exposure
/// pass's meter (ISO 2720 reflected light), over the whole sphere.
pub fn log_average_luminance_cd_m2(radiance: &[[f32; 3]], width: u32, height: u32) -> f64 {
    let (mut sum, mut weight) = (0.0, 0.0);
    for (i, p) in radiance.iter().enumerate() {
        let y = (i / width.max(1) as usize) as f64;
        let latitude = std::f64::consts::PI * (0.5 - (y + 0.5) / f64::from(height.max(1)));
        let w = latitude.cos();
        let luminance = nimbus_physics::photometry::luminance_cd_m2(p.map(f64::from));
        // The exposure pass's floor (exposure.wgsl).
        sum += w * luminance.max(1e-4).log2();
        weight += w;
    }
    if weight > 0.0 {
        (sum / weight).exp2()
    } else {
        1e-4
    }
}

/// CPU twin of `tonemap.wgsl`'s ACES fit (Hill 2016, BakingLab): exposed
/// linear Rec.709 to display-linear values in [0, 1].
pub fn aces_fitted(color: [f32; 3]) -> [f32; 3] {
    // Hill's matrices, row-major here.
    const INPUT: [[f32; 3]; 3] = [
        [0.59719, 0.35458, 0.04823],
        [0.07600, 0.90834, 0.01566],
        [0.02840, 0.13383, 0.83777],
    ];
    const OUTPUT: [[f32; 3]; 3] = [
        [1.60475, -0.53108, -0.07367],
        [-0.10208, 1.10813, -0.00605],
        [-0.00327, -0.07276, 1.07602],
    ];
    let multiply = |m: &[[f32; 3]; 3], v: [f32; 3]| -> [f32; 3] {
        std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
    };
    let v = multiply(&INPUT, color);
    let fitted = v.map(|v| {
        let a = v * (v + 0.0245786) - 0.000090537;
        let b = v * (0.983729 * v + 0.432_951) + 0.238081;
        a / b
    });
    multiply(&OUTPUT, fitted).map(|c| c.clamp(0.0, 1.0))
}

/// Tone-maps linear radiance (W·sr⁻¹·m⁻²) times `exposure_scale` to sRGB
/// RGBA8 as the tone-mapping pass does, without its dither.
pub fn tonemap_rgba8(radiance: &[[f32; 3]], exposure_scale: f64) -> Vec<u8> {
    let mut out = Vec::with_capacity(radiance.len() * 4);
    for p in radiance {
        let mapped = aces_fitted(p.map(|c| (f64::from(c) * exposure_scale) as f32));
        for c in mapped {
            let encoded = nimbus_physics::photometry::srgb_encode(f64::from(c));
            out.push((encoded * 255.0).round().clamp(0.0, 255.0) as u8);
        }
        out.push(255);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Faces filled with their direction's world-space vector: the
    /// panorama must hold each pixel's own direction, to the accuracy of
    /// bilinear interpolation of a smooth function.
    #[test]
    fn resampled_faces_give_each_pixel_its_direction() {
        let face_px = 32;
        let side = face_side_px(face_px);
        let faces: [Vec<[f32; 3]>; 6] = std::array::from_fn(|f| {
            let (forward, up) = CubeFace::ALL[f].forward_up();
            let right = forward.cross(up);
            let mut image = Vec::new();
            for y in 0..side {
                for x in 0..side {
                    let (s, t) = face_plane_coordinates(x, y, face_px);
                    let d = (forward + right * s + up * t).normalize();
                    image.push(d.as_vec3().to_array());
                }
            }
            image
        });
        let (width, height) = (128, 64);
        for filter in [Filter::Bilinear, Filter::Nearest] {
            let panorama = resample(&faces, face_px, width, height, filter);
            let mut worst: f64 = 0.0;
            for y in 0..height {
                for x in 0..width {
                    let u = (f64::from(x) + 0.5) / f64::from(width);
                    let v = (f64::from(y) + 0.5) / f64::from(height);
                    let expected = equirectangular_direction(u, v);
                    let got = DVec3::from_array(panorama[(y * width + x) as usize].map(f64::from));
                    worst = worst.max((got - expected).length());
                }
            }
            // Nearest: half a pixel's diagonal, √2/2 · 2/face_px in units of
            // the face plane (an angle at most that); far less when interpolated.
            let bound = match filter {
                Filter::Bilinear => 2e-3,
                Filter::Nearest => 1.5 / f64::from(face_px),
            };
            assert!(worst < bound, "{filter:?}: worst error {worst}");
        }
    }

    /// No seam at longitude ±180°: the first and last columns look at
    /// directions on either side of south and hold nearly equal values.
    #[test]
    fn the_panorama_wraps_around_without_a_seam() {
        let face_px = 16;
        let side = face_side_px(face_px) as usize;
        // A smooth function of direction: x + 2y + 3z, evaluated per face pixel.
        let faces: [Vec<[f32; 1]>; 6] = std::array::from_fn(|f| {
            let (forward, up) = CubeFace::ALL[f].forward_up();
            let right = forward.cross(up);
            (0..side * side)
                .map(|i| {
                    let (s, t) =
                        face_plane_coordinates((i % side) as u32, (i / side) as u32, face_px);
                    let d = (forward + right * s + up * t).normalize();
                    [(d.x + 2.0 * d.y + 3.0 * d.z) as f32]
                })
                .collect()
        });
        let (width, height) = (64, 32);
        let panorama = resample(&faces, face_px, width, height, Filter::Bilinear);
        for y in 0..height as usize {
            let first = panorama[y * width as usize][0];
            let last = panorama[y * width as usize + width as usize - 1][0];
            // Neighbours one column apart differ by at most the function's
            // change over one pixel (≤ |∇|·2π/width).
            let step = (1.0 + 4.0 + 9.0f32).sqrt() * std::f32::consts::TAU / width as f32;
            assert!((first - last).abs() <= step, "row {y}: {first} vs {last}");
        }
    }

    #[test]
    fn aces_twin_maps_black_to_black_and_saturates() {
        assert!(aces_fitted([0.0; 3]).iter().all(|c| c.abs() < 1e-3));
        assert!(aces_fitted([100.0; 3]).iter().all(|c| *c > 0.99));
        let mid = aces_fitted([0.18; 3]);
        assert!(mid[1] > 0.1 && mid[1] < 0.4, "{mid:?}");
    }

    #[test]
    fn the_meter_weights_by_solid_angle() {
        // Bright poles, dark equator: the equator dominates the average.
        let (w, h) = (8, 4);
        let radiance: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let y = i / w;
                if y == 0 || y == h - 1 {
                    [10.0; 3]
                } else {
                    [0.01; 3]
                }
            })
            .collect();
        let average = log_average_luminance_cd_m2(&radiance, w, h);
        let dark = nimbus_physics::photometry::luminance_cd_m2([0.01; 3]);
        let bright = nimbus_physics::photometry::luminance_cd_m2([10.0; 3]);
        let unweighted = (0.5 * dark.log2() + 0.5 * bright.log2()).exp2();
        assert!(
            average < unweighted && average > dark,
            "{average} {unweighted}"
        );
    }
}
