//! The scene's rain settings converted for the GPU: the rain box at the camera, the physics parameters and zones, the occlusion view and the uniforms.

use super::gpu_types::{RainStepUniform, RainUniform, WindPrimitiveUniform};
use super::{RainState, SPLASH_CAPACITY, ZONE_MAP_SIZE};
use crate::frame::Camera;
use crate::scene::{RainBoxKind, RainSettings, Scene};
use glam::{Mat4, Vec3};
use nimbus_physics::rain::drag::terminal_speed_m_s_f32;
use nimbus_physics::rain::drop_optics::DropTransfer;
use nimbus_physics::rain::dsd::mean_sampled_diameter_mm;
use nimbus_physics::rain::rain_box::{RainBox, RainBoxShape, orthonormal_basis};
use nimbus_physics::rain::simulation::{RainParams, STEP_S};
use nimbus_physics::rain::wind::MAX_WIND_PRIMITIVES;
use nimbus_physics::rain::zones::{RainArea, RainZones, smoothstep};

/// The rain box of the scene's settings at the camera.
pub fn rain_box(settings: &RainSettings, camera: &Camera) -> RainBox {
    let forward = camera.forward.as_vec3();
    let right = forward.cross(camera.up.as_vec3()).normalize_or(Vec3::X);
    let up = right.cross(forward);
    let r = settings.box_radius_m as f32;
    let shape = match settings.box_shape {
        RainBoxKind::Sphere => RainBoxShape::Sphere { radius_m: r },
        RainBoxKind::Box => RainBoxShape::Box {
            half_extent_m: Vec3::splat(r),
        },
        RainBoxKind::Frustum => RainBoxShape::Frustum {
            near_m: crate::frame::NEAR_PLANE_M as f32,
            far_m: r,
            tan_half_fov_y: (0.5 * camera.fov_y_rad as f32).tan(),
            aspect: camera.aspect as f32,
        },
    };
    RainBox::at_rest(shape, camera.position_m.as_vec3(), [right, up, forward])
}

/// The physics crate's parameters of the scene's rain.
pub fn rain_params(scene: &Scene, settings: &RainSettings) -> RainParams {
    RainParams {
        intensity_mm_h: settings.intensity_mm_h as f32,
        min_diameter_mm: settings.min_diameter_mm as f32,
        max_diameter_mm: settings.max_diameter_mm as f32,
        max_drops: settings.max_drops.min(u32::MAX as u64) as u32,
        ceiling_m: scene.rain_ceiling_m() as f32,
    }
}

/// Where it rains: the scene's areas and, with `under_clouds`, where the
/// stratus layer is thicker than the threshold and under the cumulus'
/// footprints (given as (x, z, radius) in m), all with soft edges; rain
/// everywhere when the scene names neither.
pub fn rain_zones(
    scene: &Scene,
    settings: &RainSettings,
    time_s: f64,
    cumulus_footprints_m: &[[f32; 3]],
) -> RainZones {
    if settings.areas.is_empty() && !settings.under_clouds {
        return RainZones::everywhere();
    }
    let areas: Vec<RainArea> = settings
        .areas
        .iter()
        .map(|a| RainArea {
            center_m: [a.center_m[0] as f32, a.center_m[1] as f32],
            radius_m: a.radius_m as f32,
            edge_m: a.edge_m as f32,
        })
        .collect();
    let stratus = scene
        .stratus
        .as_ref()
        .filter(|_| settings.under_clouds)
        .map(|s| crate::scene::cloud_layer_field(scene, s));
    let threshold = settings.cloud_threshold_m as f32;
    let cumulus: &[[f32; 3]] = if settings.under_clouds {
        cumulus_footprints_m
    } else {
        &[]
    };
    let side = scene.terrain.extent_m as f32;
    let drift = scene.cloud_drift_m(time_s);
    RainZones::from_fn([0.0, 0.0], side, ZONE_MAP_SIZE, |x, z| {
        let mut factor = areas
            .iter()
            .map(|a| a.factor_at(x, z))
            .fold(0.0f32, f32::max);
        if let Some(field) = &stratus {
            let h = field.thickness_with_drift_m(x as f64, z as f64, drift, time_s) as f32;
            // A soft edge over a third of the threshold (Puig-Centelles et al. 2009).
            factor = factor.max(smoothstep(threshold * 0.67, threshold, h));
        }
        for &[cx, cz, r] in cumulus {
            let d = ((x - cx).powi(2) + (z - cz).powi(2)).sqrt();
            factor = factor.max(1.0 - smoothstep(0.6 * r, r, d));
        }
        factor
    })
}

/// Mean direction of the rain (unit, world): the velocity of a drop of the
/// mean sampled diameter in the mean wind (Blanchard 2023, §4.2.5: the rain
/// shadow map is drawn along it).
pub fn mean_rain_direction(params: &RainParams, wind_mean_m_s: Vec3) -> Vec3 {
    let d = mean_sampled_diameter_mm(
        params.intensity_mm_h.max(0.1) as f64,
        params.min_diameter_mm as f64,
        params.max_diameter_mm as f64,
    ) as f32;
    (wind_mean_m_s - Vec3::Y * terminal_speed_m_s_f32(d)).normalize_or(Vec3::NEG_Y)
}

/// Clip space of the rain shadow map from world: an orthographic view along
/// `direction` of the square of side `2·radius` around `centre`, reaching
/// `reach_above` beyond the box on the upstream side. Depth 0 upstream, 1 downstream.
pub fn occlusion_from_world(
    centre: Vec3,
    direction: Vec3,
    radius_m: f32,
    reach_above_m: f32,
) -> Mat4 {
    let (right, up) = orthonormal_basis(direction);
    let eye = centre - direction * (radius_m + reach_above_m);
    let view = Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        direction.extend(0.0),
        Vec3::ZERO.extend(1.0),
    )
    .transpose()
        * Mat4::from_translation(-eye);
    let depth_range = 2.0 * radius_m + reach_above_m;
    // x, y in [−1, 1] over the square; z in [0, 1] along the rain.
    let projection = Mat4::from_cols_array(&[
        1.0 / radius_m,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0 / radius_m,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0 / depth_range,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
    ]);
    projection * view
}

pub(super) fn step_uniform(
    b: &RainBox,
    time_s: f32,
    index: u32,
    initialise: bool,
) -> RainStepUniform {
    RainStepUniform {
        box_center: b.center_m.extend(time_s).to_array(),
        box_velocity: b.velocity_m_s.extend(STEP_S).to_array(),
        index: [index, initialise as u32, 0, 0],
        _padding: [0; 52],
    }
}

#[allow(clippy::too_many_arguments)]
pub(super) fn rain_uniform(
    settings: &RainSettings,
    params: &RainParams,
    rain_box: &RainBox,
    state: &RainState,
    camera: &Camera,
    occlusion: Mat4,
    drop: &DropTransfer,
    mist_ground: [f32; 4],
) -> RainUniform {
    let [right, up, forward] = rain_box.basis;
    let (shape, near, far, size) = match rain_box.shape {
        RainBoxShape::Sphere { radius_m } => (0.0, 0.0, 0.0, Vec3::new(radius_m, 0.0, 0.0)),
        RainBoxShape::Box { half_extent_m } => (1.0, 0.0, 0.0, half_extent_m),
        RainBoxShape::Frustum {
            near_m,
            far_m,
            tan_half_fov_y,
            aspect,
        } => (2.0, near_m, far_m, Vec3::new(tan_half_fov_y, aspect, 0.0)),
    };
    let wind = &state.wind;
    let mut primitives = [WindPrimitiveUniform::default(); MAX_WIND_PRIMITIVES];
    for (gpu, p) in primitives.iter_mut().zip(&wind.primitives) {
        let [center, axis, drift, gust] = p.to_gpu();
        *gpu = WindPrimitiveUniform {
            center,
            axis,
            drift,
            gust,
        };
    }
    let grid = wind.grid.as_ref();
    let zones = &state.zone_map;
    // The first mist layer ends where the largest drops' streaks shrink below a pixel.
    let pixel_angle = (2.0 * (0.5 * camera.fov_y_rad).tan() / camera.height_px as f64) as f32;
    let longest_streak_m =
        terminal_speed_m_s_f32(params.max_diameter_mm) * settings.exposure_s as f32;
    let layer_end = (longest_streak_m / pixel_angle).max(rain_box.bounding_radius_m());
    RainUniform {
        box_right: right.extend(shape).to_array(),
        box_up: up.extend(near).to_array(),
        box_forward: forward.extend(far).to_array(),
        box_size: size.extend(rain_box.volume_m3()).to_array(),
        box_angular_velocity: rain_box
            .angular_velocity_rad_s
            .extend(rain_box.bounding_radius_m())
            .to_array(),
        wind_mean: wind
            .mean_m_s
            .extend(grid.map_or(1.0, |g| g.cell_m))
            .to_array(),
        drops: [
            params.intensity_mm_h,
            params.min_diameter_mm,
            params.max_diameter_mm,
            params.ceiling_m.min(1e9),
        ],
        zones: [
            zones.origin_m[0],
            zones.origin_m[1],
            zones.texel_m,
            settings.exposure_s as f32,
        ],
        counts: [
            state.dispatched,
            state.drops.capacity,
            wind.primitives.len().min(MAX_WIND_PRIMITIVES) as u32,
            u32::from(grid.is_some()),
        ],
        flags: [zones.size, SPLASH_CAPACITY, 1, settings.splashes as u32],
        occlusion_from_world: occlusion.to_cols_array_2d(),
        camera_velocity: rain_box
            .velocity_m_s
            .extend(settings.min_streak_width_px as f32)
            .to_array(),
        mist: [
            rain_box.bounding_radius_m(),
            layer_end,
            settings.splash_radius_m as f32,
            settings.mist as u32 as f32,
        ],
        mist_ground,
        wind_grid: grid.map_or([0; 4], |g| {
            [g.cells[0], g.cells[1], g.cells[2], u32::from(g.carried)]
        }),
        wind_grid_origin: grid.map_or([0.0; 4], |g| g.origin_m.extend(0.0).to_array()),
        drop_sh_weights: [
            drop.band_weights[0] as f32,
            drop.band_weights[1] as f32,
            drop.band_weights[2] as f32,
            0.0,
        ],
        drop_kernel: std::array::from_fn(|i| {
            std::array::from_fn(|k| drop.kernel_per_sr[4 * i + k] as f32)
        }),
        primitives,
    }
}
