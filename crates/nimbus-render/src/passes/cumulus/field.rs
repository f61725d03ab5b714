//! The cloud field per frame: placing, drifting with the wind, culling against the frustum, choosing the level of detail, and the shadow map's transform.

use super::gpu_types::{BUMP_LACUNARITY, CloudPlacement, CumulusInstance};
use super::variants::{self, CumulusVariant, VariantParams};
use super::{CumulusError, FieldCloud, LOD_CELL_PX};
use crate::scene::{CumulusSettings, MAX_CLOUDS, Scene};
use glam::{DVec3, Mat4, Vec3, Vec4};
use nimbus_physics::cumulus::cloud_field::{CloudFieldParams, CloudInstance, place_clouds};
use std::sync::Arc;

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

/// The square a generated field covers: its centre (x, z) and side, m
/// (`cumulus.area_m`, else the terrain's extent, around the world origin).
pub(super) fn field_area(scene: &Scene, settings: &CumulusSettings) -> ([f64; 2], f64) {
    (
        [0.0, 0.0],
        settings.area_m.unwrap_or(scene.terrain.extent_m),
    )
}

/// The field's clouds before the wind moves them, instances of `shapes`:
/// placed from the coverage over the square of `area_side_m` around
/// `area_centre_m`, or the clouds listed in the settings (their variant
/// clamped to the shapes there are).
pub(super) fn place_field(
    settings: &CumulusSettings,
    area_centre_m: [f64; 2],
    area_side_m: f64,
    shapes: &[&CumulusVariant],
) -> Vec<FieldCloud> {
    let Some(last_variant) = shapes.len().checked_sub(1) else {
        return Vec::new();
    };
    let clouds = if settings.clouds.is_empty() {
        let footprints: Vec<f64> = shapes
            .iter()
            .map(|v| f64::from(v.footprint_radius_m))
            .collect();
        place_clouds(
            &CloudFieldParams {
                coverage: settings.coverage,
                base_m: settings.base_m,
                seed: settings.seed,
                centre_m: area_centre_m,
                side_m: area_side_m,
                scale_range: settings.scale_range,
                max_clouds: MAX_CLOUDS,
            },
            &footprints,
        )
        .clouds
    } else {
        settings
            .clouds
            .iter()
            .map(|c| CloudInstance {
                variant: c.variant.min(last_variant as u32),
                base_centre_m: DVec3::from_array(c.position_m),
                yaw_rad: c.yaw_deg.to_radians(),
                scale: c.scale,
            })
            .collect()
    };
    clouds
        .iter()
        .enumerate()
        .map(|(index, cloud)| {
            let shape = shapes[(cloud.variant as usize).min(last_variant)];
            field_cloud(index, cloud, shape)
        })
        .collect()
}

/// The field's clouds carried by the wind's drift `drift_m` (x, z), m; a
/// generated field (no clouds listed by hand) wraps around its square so
/// that it never empties.
pub(super) fn drift_field<'a>(
    settings: &CumulusSettings,
    placed: &'a [FieldCloud],
    area_centre_m: [f64; 2],
    area_side_m: f64,
    drift_m: [f64; 2],
) -> impl Iterator<Item = FieldCloud> + 'a {
    let wrap = settings.clouds.is_empty().then_some(area_side_m);
    placed
        .iter()
        .map(move |cloud| drifted_cloud(cloud, drift_m, area_centre_m, wrap))
}

impl FieldCloud {
    /// Where the cloud is, as [`CloudPlacement`] (from the instance the
    /// shader reads, so exactly what is drawn).
    pub(super) fn placement(&self) -> CloudPlacement {
        let [x, y, z, scale] = self.instance.offset_scale;
        let [cos_yaw, sin_yaw, ..] = self.instance.rotation_noise;
        CloudPlacement {
            variant: self.variant,
            base_centre_m: DVec3::new(f64::from(x), f64::from(y), f64::from(z)),
            yaw_rad: f64::from(sin_yaw).atan2(f64::from(cos_yaw)),
            scale: f64::from(scale),
        }
    }
}

/// A scene's cumulus field at one time, as the renderer draws it.
#[derive(Clone, Debug)]
pub struct CumulusField {
    /// The shape variants, in the order [`CloudPlacement::variant`] indexes.
    pub shapes: Vec<Arc<CumulusVariant>>,
    /// Every cloud of the field (not only those in a camera's view).
    pub clouds: Vec<CloudPlacement>,
}

/// The cumulus field of `scene` (as [`Scene::at_time`] gives it at `time_s`)
/// at `time_s`, placed and carried by the wind exactly as the cumulus pass
/// places the clouds it draws, without a GPU; `None` without `[cumulus]`.
/// The shapes are loaded from the disk cache of
/// [`crate::core::cache::cache_dir`] or generated (seconds each) and cached.
pub fn cumulus_field_at(scene: &Scene, time_s: f64) -> Result<Option<CumulusField>, CumulusError> {
    let Some(settings) = &scene.cumulus else {
        return Ok(None);
    };
    let shapes = variants::load_or_generate(
        &crate::core::cache::cache_dir(),
        &VariantParams::from(settings),
    )?;
    let (centre, side) = field_area(scene, settings);
    let shape_refs: Vec<&CumulusVariant> = shapes.iter().map(|s| &**s).collect();
    let placed = place_field(settings, centre, side, &shape_refs);
    let clouds = drift_field(settings, &placed, centre, side, scene.cloud_drift_m(time_s))
        .map(|cloud| cloud.placement())
        .collect();
    Ok(Some(CumulusField { shapes, clouds }))
}
