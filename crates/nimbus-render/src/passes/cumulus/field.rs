//! The cloud field per frame: placing, drifting with the wind, culling against the frustum, choosing the level of detail, and the shadow map's transform.

use super::gpu_types::{BUMP_LACUNARITY, CumulusInstance};
use super::variants::CumulusVariant;
use super::{FieldCloud, LOD_CELL_PX};
use glam::{DVec3, Mat4, Vec3, Vec4};
use nimbus_physics::cumulus::cloud_field::CloudInstance;

/// Shadow clip space from world space: orthographic along the light
/// (towards −`to_sun`) over the given bounding spheres; x, y in [−1, 1]
/// (square texels), z in [0, 1] from the nearest to the farthest sphere.
/// Returns the matrix and the depth range, m.
pub fn shadow_clip_from_world(to_sun: DVec3, spheres: &[(DVec3, f64)]) -> (Mat4, f64) {
    let forward = -to_sun.normalize();
    let right = if forward.y.abs() < 0.999 {
        forward.cross(DVec3::Y).normalize()
    } else {
        DVec3::X
    };
    let up = right.cross(forward);
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for &(c, r) in spheres {
        let p = DVec3::new(c.dot(right), c.dot(up), c.dot(forward));
        lo = lo.min(p - DVec3::splat(r));
        hi = hi.max(p + DVec3::splat(r));
    }
    let half = 0.5 * (hi.x - lo.x).max(hi.y - lo.y).max(1.0);
    let (cx, cy) = (0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
    let depth = (hi.z - lo.z).max(1.0);
    let rows = [
        [right.x / half, right.y / half, right.z / half, -cx / half],
        [up.x / half, up.y / half, up.z / half, -cy / half],
        [
            forward.x / depth,
            forward.y / depth,
            forward.z / depth,
            -lo.z / depth,
        ],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let m = glam::DMat4::from_cols_array_2d(&rows).transpose();
    (m.as_mat4(), depth)
}

/// Level of detail of a cloud at `distance_m` whose finest cell is `cell_m`
/// (scaled), for a pixel angle `pixel_angle_rad`: the coarsest whose cell
/// projects to at most [`LOD_CELL_PX`] pixels.
pub fn level_of_detail(cell_m: f64, distance_m: f64, pixel_angle_rad: f64, levels: usize) -> usize {
    let ratio = LOD_CELL_PX * distance_m.max(1.0) * pixel_angle_rad / cell_m.max(1e-6);
    if ratio < 2.0 {
        return 0;
    }
    (ratio.log2().floor() as usize).min(levels.saturating_sub(1))
}

/// Whether a sphere is (partly) inside the frustum of a reverse-Z,
/// infinite-far clip transform.
pub fn sphere_in_frustum(clip_from_world: &Mat4, centre: Vec3, radius: f32) -> bool {
    let rows = [
        clip_from_world.row(0),
        clip_from_world.row(1),
        clip_from_world.row(2),
        clip_from_world.row(3),
    ];
    let planes: [Vec4; 5] = [
        rows[3] + rows[0],
        rows[3] - rows[0],
        rows[3] + rows[1],
        rows[3] - rows[1],
        rows[3] - rows[2],
    ];
    planes.iter().all(|p| {
        let n = p.truncate();
        n.dot(centre) + p.w >= -radius * n.length()
    })
}

/// The per-frame data of the `index`th cloud, an instance of `shape`.
pub(super) fn field_cloud(
    index: usize,
    cloud: &CloudInstance,
    shape: &CumulusVariant,
) -> FieldCloud {
    let (c, s) = (cloud.yaw_rad.cos(), cloud.yaw_rad.sin());
    let b = DVec3::from_array(shape.bounds_centre_m.map(f64::from)) * cloud.scale;
    let r = shape.base_radii_m;
    FieldCloud {
        variant: cloud.variant as usize,
        centre_m: cloud.base_centre_m + DVec3::new(c * b.x + s * b.z, b.y, -s * b.x + c * b.z),
        radius_m: f64::from(shape.bounds_radius_m) * cloud.scale,
        finest_cell_m: f64::from(shape.lods[0].cell_m) * cloud.scale,
        instance: CumulusInstance {
            offset_scale: [
                cloud.base_centre_m.x as f32,
                cloud.base_centre_m.y as f32,
                cloud.base_centre_m.z as f32,
                cloud.scale as f32,
            ],
            rotation_noise: [c as f32, s as f32, (index as f32 * 37.31) % 512.0, 0.0],
            radii_wavelength: [
                r[0],
                r[1],
                r[2],
                2.0 * shape.last_radius_m / BUMP_LACUNARITY,
            ],
        },
    }
}

/// `cloud` moved by the wind's drift (x, z), m; with `wrap_side_m`, its base
/// kept inside the square of that side around `area_centre_m`.
pub(super) fn drifted_cloud(
    cloud: &FieldCloud,
    drift_m: [f64; 2],
    area_centre_m: [f64; 2],
    wrap_side_m: Option<f64>,
) -> FieldCloud {
    let base = cloud.instance.offset_scale;
    let mut target = [
        f64::from(base[0]) + drift_m[0],
        f64::from(base[2]) + drift_m[1],
    ];
    if let Some(side) = wrap_side_m {
        for (t, c) in target.iter_mut().zip(area_centre_m) {
            *t = c - 0.5 * side + (*t - (c - 0.5 * side)).rem_euclid(side);
        }
    }
    let shift = DVec3::new(
        target[0] - f64::from(base[0]),
        0.0,
        target[1] - f64::from(base[2]),
    );
    let mut moved = cloud.clone();
    moved.centre_m += shift;
    moved.instance.offset_scale[0] = target[0] as f32;
    moved.instance.offset_scale[2] = target[1] as f32;
    moved
}
