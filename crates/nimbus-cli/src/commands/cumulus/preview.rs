//! `--preview`: the mesh drawn with plain Lambert lighting by a small
//! z-buffered rasteriser (Gouraud-interpolated normals), seen from the
//! south, a little below the cloud's middle, framed on its bounding box.

use glam::{Mat4, Vec3, Vec4Swizzles};
use nimbus_physics::cumulus::surface::CumulusMesh;
use nimbus_render::headless::Rgba8Image;

/// Direction towards the light (sun high in the south-east).
const LIGHT: Vec3 = Vec3::new(0.45, 0.8, 0.4);
/// Share of diffuse ambient light.
const AMBIENT: f32 = 0.25;

/// Renders `mesh` at `width` × `height`.
pub fn render(mesh: &CumulusMesh, width: u32, height: u32) -> Rgba8Image {
    let (w, h) = (width as usize, height as usize);
    let mut pixels = vec![0u8; w * h * 4];
    // A pale sky gradient behind.
    for y in 0..h {
        let t = y as f32 / h.max(1) as f32;
        let sky = [0.35 + 0.35 * t, 0.55 + 0.25 * t, 0.85 + 0.1 * t];
        for x in 0..w {
            let i = (y * w + x) * 4;
            pixels[i..i + 3].copy_from_slice(&sky.map(|c| (c * 255.0) as u8));
            pixels[i + 3] = 255;
        }
    }
    if mesh.positions.is_empty() {
        return Rgba8Image {
            width,
            height,
            pixels,
        };
    }
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in &mesh.positions {
        lo = lo.min(Vec3::from(*p));
        hi = hi.max(Vec3::from(*p));
    }
    let centre = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    let fov = 40f32.to_radians();
    let aspect = width as f32 / height as f32;
    // Far enough for the box's front face to fit with a margin, whichever
    // of width and height binds.
    let tan_v = (0.5 * fov).tan();
    let fit = (half.x / (tan_v * aspect)).max(half.y / tan_v);
    let distance = 1.15 * fit + half.z;
    // From the south (+z), slightly below the middle.
    let eye = centre + Vec3::new(0.0, -0.15, 1.0).normalize() * distance;
    let view = Mat4::look_at_rh(eye, centre, Vec3::Y);
    let projection = Mat4::perspective_rh(fov, aspect, 0.05 * distance, 3.0 * distance);
    let clip_from_world = projection * view;
    let light = LIGHT.normalize();

    let screen: Vec<Option<Vec3>> = mesh
        .positions
        .iter()
        .map(|p| {
            let c = clip_from_world * Vec3::from(*p).extend(1.0);
            (c.w > 0.0).then(|| {
                let ndc = c.xyz() / c.w;
                Vec3::new(
                    (ndc.x * 0.5 + 0.5) * w as f32,
                    (0.5 - ndc.y * 0.5) * h as f32,
                    ndc.z,
                )
            })
        })
        .collect();
    let shade: Vec<f32> = mesh
        .normals
        .iter()
        .map(|n| AMBIENT + (1.0 - AMBIENT) * Vec3::from(*n).dot(light).max(0.0))
        .collect();
    let mut depth = vec![f32::INFINITY; w * h];
    for t in mesh.indices.chunks(3) {
        let (Some(a), Some(b), Some(c)) = (
            screen[t[0] as usize],
            screen[t[1] as usize],
            screen[t[2] as usize],
        ) else {
            continue;
        };
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if area.abs() < 1e-12 {
            continue;
        }
        let min_x = a.x.min(b.x).min(c.x).floor().max(0.0) as usize;
        let max_x = (a.x.max(b.x).max(c.x).ceil() as usize).min(w.saturating_sub(1));
        let min_y = a.y.min(b.y).min(c.y).floor().max(0.0) as usize;
        let max_y = (a.y.max(b.y).max(c.y).ceil() as usize).min(h.saturating_sub(1));
        let s = [
            shade[t[0] as usize],
            shade[t[1] as usize],
            shade[t[2] as usize],
        ];
        for y in min_y..=max_y {
            for x in min_x..=max_x {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
                let w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * a.z + w1 * b.z + w2 * c.z;
                let k = y * w + x;
                if z >= depth[k] {
                    continue;
                }
                depth[k] = z;
                let v = (w0 * s[0] + w1 * s[1] + w2 * s[2]).clamp(0.0, 1.0);
                // A slightly warm white, in sRGB.
                let rgb = [v, v * 0.98, v * 0.95].map(|c| (c.powf(1.0 / 2.2) * 255.0) as u8);
                pixels[k * 4..k * 4 + 3].copy_from_slice(&rgb);
            }
        }
    }
    Rgba8Image {
        width,
        height,
        pixels,
    }
}
