//! nimbus in Bevy's render world.
//!
//! - `RenderStartup` (again after a device loss): a [`nimbus_render::Renderer`]
//!   on Bevy's `wgpu::Device` and queue, in `OutputMode::LinearHdr` for
//!   Bevy's `Rgba16Float` HDR main texture.
//! - `ExtractSchedule`: the weather at this frame's time, the nimbus
//!   camera's render entity, the rain occluders when they changed.
//! - `Render`, in `RenderSystems::Prepare`: `Renderer::prepare_view` with
//!   the camera's view (Bevy's `ExtractedView`: its pose and its infinite
//!   reverse-Z perspective; Bevy's depth convention) and pre-exposure
//!   (683 lm·W⁻¹ × the camera's `Exposure`, Bevy's HDR values being
//!   pre-exposed cd·m⁻²).
//! - The camera's `Core3d` schedule: `nimbus_lighting`
//!   (`Renderer::encode_lighting`: atmosphere lookups, stratus field,
//!   cumulus shadow map, rain simulation) after `Core3dSystems::Prepass`
//!   and before `Core3dSystems::MainPass`; `nimbus_composite`
//!   (`Renderer::encode`: sky, cumulus, stratus, rain, mist and air by
//!   Bevy's depth into the main texture) after `main_opaque_pass_3d` and
//!   before `main_transparent_pass_3d` (Bevy's transparent meshes are
//!   drawn over the weather, as with Bevy's own atmosphere).

use crate::cloud_shadows::{
    self, BakeRequest, CloudShadowBaker, ExtractSunQuery, NimbusAmbientProbe,
    NimbusCloudShadowTexture, NimbusCloudShadows,
};
use crate::occluders::NimbusOccluders;
use crate::{NimbusCamera, NimbusFrame, NimbusPlugin};
use bevy::app::App;
use bevy::camera::Camera;
use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::ecs::prelude::*;
use bevy::log::{error, warn};
use bevy::math::{Mat4, Vec3};
use bevy::pbr::decal::clustered::clustered_decals_are_usable;
use bevy::platform::collections::HashSet;
use bevy::render::camera::ExtractedCamera;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::TextureFormat;
use bevy::render::renderer::{RenderAdapter, RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::sync_world::RenderEntity;
use bevy::render::texture::GpuImage;
use bevy::render::view::{ExtractedView, Msaa, ViewDepthTexture, ViewTarget};
use bevy::render::{Extract, ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems};
use bevy::transform::components::GlobalTransform;
use nimbus_physics::photometry::MAX_LUMINOUS_EFFICACY_LM_PER_W;
use nimbus_render::{
    DepthConvention, FrameTargets, PASS_NAMES, Precompute, Projection, Renderer,
    RendererDescriptor, Scene, TargetLoad, View,
};
use std::sync::{Arc, Mutex, MutexGuard};

/// nimbus's per-pass GPU times of the last frame read, ms, by pass name
/// (with [`NimbusPlugin::timestamps`] on a device with timestamp queries):
/// a resource of both worlds, sharing one list.
#[derive(Resource, Clone, Debug, Default)]
pub struct NimbusPassTimes(Arc<Mutex<Vec<(&'static str, f64)>>>);

impl NimbusPassTimes {
    /// The last times read: (pass name, ms) for each pass the frame ran.
    pub fn latest(&self) -> Vec<(&'static str, f64)> {
        self.0.lock().map(|t| t.clone()).unwrap_or_default()
    }

    fn set(&self, times: Vec<(&'static str, f64)>) {
        if let Ok(mut t) = self.0.lock() {
            *t = times;
        }
    }
}

/// The plugin's settings in the render world.
#[derive(Resource, Clone, Copy)]
struct NimbusConfig {
    precompute: Precompute,
    timestamps: bool,
}

/// nimbus's renderer on Bevy's device.
#[derive(Resource)]
pub struct NimbusRenderer(Mutex<Renderer>);

impl NimbusRenderer {
    /// The renderer (e.g. for its frame resources, pending work or pass times).
    pub fn lock(&self) -> MutexGuard<'_, Renderer> {
        // A panic while it was held leaves a renderer that still works.
        self.0
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

/// What the main world gave this frame.
#[derive(Resource, Default)]
pub(crate) struct Extracted {
    scene: Option<Scene>,
    time_s: f64,
    /// The render entity of the nimbus camera, if one can be drawn.
    camera: Option<Entity>,
    /// The occluders' generation last handed over.
    occluder_generation: u64,
    /// New occluders for the renderer.
    occluders: Option<(Vec<[f32; 3]>, Vec<u32>)>,
    /// The cloud shadows to bake for Bevy's meshes this frame.
    cloud_shadows: Option<BakeRequest>,
}

/// The view the renderer was prepared for this frame.
#[derive(Resource, Default)]
pub(crate) struct Prepared {
    view: Option<Entity>,
    /// The cloud shadow bake is ready to record (its uniform written).
    bake: bool,
}

/// The cloud shadow bake's pipeline (made with the renderer's layouts on
/// first use) and whether Bevy can draw light textures on this device.
#[derive(Resource, Default)]
pub(crate) struct CloudShadowBake {
    baker: Option<CloudShadowBaker>,
    /// Bevy's clustered decals (light textures) are usable on this device.
    supported: bool,
}

/// Messages already logged (each unsupported setup is said once, until it changes).
#[derive(Resource, Default)]
struct Said(HashSet<String>);

impl Said {
    fn error(&mut self, message: String) {
        if self.0.insert(message.clone()) {
            error!("nimbus: {message}");
        }
    }
    fn warn(&mut self, message: String) {
        if self.0.insert(message.clone()) {
            warn!("nimbus: {message}");
        }
    }
}

pub(crate) fn build(app: &mut App, _plugin: &NimbusPlugin) {
    app.init_resource::<NimbusPassTimes>()
        .init_resource::<NimbusAmbientProbe>();
}

pub(crate) fn finish(app: &mut App, plugin: &NimbusPlugin) {
    let times = app.world().resource::<NimbusPassTimes>().clone();
    let probe = app.world().resource::<NimbusAmbientProbe>().clone();
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        warn!("nimbus: no render app (RenderPlugin missing): NimbusPlugin draws nothing");
        return;
    };
    render_app
        .insert_resource(NimbusConfig {
            precompute: plugin.precompute,
            timestamps: plugin.timestamps,
        })
        .insert_resource(times)
        .insert_resource(probe)
        .init_resource::<Extracted>()
        .init_resource::<Prepared>()
        .init_resource::<Said>()
        .init_resource::<CloudShadowBake>()
        .add_systems(RenderStartup, create_renderer)
        .add_systems(ExtractSchedule, extract)
        .add_systems(Render, prepare.in_set(RenderSystems::Prepare))
        .add_systems(Render, map_ambient_probe.in_set(RenderSystems::Cleanup))
        .add_systems(
            Core3d,
            (
                nimbus_lighting
                    .after(Core3dSystems::Prepass)
                    .before(Core3dSystems::MainPass),
                nimbus_composite
                    .after(main_opaque_pass_3d)
                    .before(main_transparent_pass_3d),
            ),
        );
}

/// Creates the renderer on Bevy's device.
fn create_renderer(
    mut commands: Commands,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    adapter: Res<RenderAdapter>,
    config: Res<NimbusConfig>,
) {
    let descriptor = RendererDescriptor::linear_hdr(TextureFormat::Rgba16Float)
        .with_precompute(config.precompute)
        .with_timestamps(config.timestamps);
    let queue: &wgpu::Queue = &queue;
    match Renderer::try_new(device.wgpu_device(), queue, &descriptor) {
        Ok(renderer) => commands.insert_resource(NimbusRenderer(Mutex::new(renderer))),
        Err(e) => error!("nimbus: cannot create the renderer on Bevy's device: {e}"),
    }
    // A new device (first start or after a loss): a new bake pipeline.
    commands.insert_resource(CloudShadowBake {
        baker: None,
        supported: clustered_decals_are_usable(&device, &adapter),
    });
}

/// The main world's nimbus cameras.
type CameraQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        RenderEntity,
        &'static Camera,
        Option<&'static Msaa>,
        &'static GlobalTransform,
    ),
    With<NimbusCamera>,
>;

/// Copies the weather, picks the camera, hands over new occluders and
/// the cloud shadows' light texture.
#[allow(clippy::too_many_arguments)]
fn extract(
    frame: Extract<Res<NimbusFrame>>,
    occluders: Extract<Res<NimbusOccluders>>,
    cameras: Extract<CameraQuery>,
    shadow_settings: Extract<Option<Res<NimbusCloudShadows>>>,
    shadow_texture: Extract<Option<Res<NimbusCloudShadowTexture>>>,
    suns: Extract<ExtractSunQuery>,
    mut extracted: ResMut<Extracted>,
    mut said: ResMut<Said>,
) {
    let mut active: Vec<_> = cameras.iter().filter(|(_, _, c, ..)| c.is_active).collect();
    active.sort_by_key(|(entity, _, camera, ..)| (camera.order, *entity));
    let camera_m = active
        .first()
        .map_or(Vec3::ZERO, |(.., transform)| transform.translation());
    extracted.cloud_shadows = match (&*shadow_settings, &*shadow_texture) {
        (Some(settings), Some(texture)) => {
            cloud_shadows::bake_request(settings, texture, &suns, camera_m)
        }
        _ => None,
    };
    if frame.is_changed() || extracted.scene.is_none() {
        extracted.scene.clone_from(&frame.scene);
    }
    extracted.time_s = frame.time_s;
    if occluders.generation != extracted.occluder_generation {
        extracted.occluder_generation = occluders.generation;
        extracted.occluders = Some((occluders.positions_m.clone(), occluders.indices.clone()));
    }
    extracted.camera = None;
    let Some(&(entity, render_entity, _, msaa, _)) = active.first() else {
        return;
    };
    if active.len() > 1 {
        let others: Vec<String> = active[1..].iter().map(|(e, ..)| e.to_string()).collect();
        said.warn(format!(
            "{} cameras have NimbusCamera: only {entity} (the lowest order) gets the weather, not {} \
             (one nimbus camera per app is supported)",
            active.len(),
            others.join(", ")
        ));
    }
    if let Some(msaa) = msaa
        && *msaa != Msaa::Off
    {
        said.error(format!(
            "camera {entity}: MSAA {} samples is not supported (nimbus composites by a \
             single-sample depth): set Msaa::Off; nimbus draws nothing until then",
            msaa.samples()
        ));
        return;
    }
    extracted.camera = Some(render_entity);
}

/// nimbus's view of Bevy's: Bevy's pose, its infinite reverse-Z perspective.
/// Errors: a projection other than Bevy's perspective (orthographic, off
/// centre, finite far plane).
pub fn nimbus_view(world_from_view: Mat4, clip_from_view: Mat4) -> Result<View, String> {
    let m = clip_from_view;
    if m.w_axis.w != 0.0 || m.z_axis.w != -1.0 {
        return Err(
            "the camera's projection is not a perspective (orthographic cameras are not supported)"
                .to_owned(),
        );
    }
    if m.z_axis.z != 0.0 || m.w_axis.z <= 0.0 {
        return Err("the camera's perspective is not Bevy's infinite reverse-Z one".to_owned());
    }
    if m.z_axis.x.abs() > 1e-6 || m.z_axis.y.abs() > 1e-6 {
        return Err("off-centre projections (sub-camera views) are not supported".to_owned());
    }
    let f = f64::from(m.y_axis.y);
    let view = View {
        world_from_view: glam::DMat4::from_cols_array(
            &world_from_view.to_cols_array().map(f64::from),
        ),
        projection: Projection::Perspective {
            fov_y_rad: 2.0 * (1.0 / f).atan(),
            aspect: f / f64::from(m.x_axis.x),
            near_m: f64::from(m.w_axis.z),
            far_m: None,
        },
        depth: DepthConvention::Reverse,
    };
    view.check().map_err(|e| e.to_string())?;
    Ok(view)
}

/// Prepares the renderer for the nimbus camera's view.
#[allow(clippy::too_many_arguments)]
fn prepare(
    renderer: Option<Res<NimbusRenderer>>,
    mut extracted: ResMut<Extracted>,
    views: Query<(&ExtractedView, &ExtractedCamera)>,
    mut prepared: ResMut<Prepared>,
    mut said: ResMut<Said>,
    config: Res<NimbusConfig>,
    times: Res<NimbusPassTimes>,
    (device, queue, mut bake, probe): (
        Res<RenderDevice>,
        Res<RenderQueue>,
        ResMut<CloudShadowBake>,
        Res<NimbusAmbientProbe>,
    ),
) {
    if let Some(baker) = &bake.baker {
        baker.read_probe(device.wgpu_device(), &probe);
    }
    prepared.view = None;
    prepared.bake = false;
    let Some(renderer) = renderer else {
        return;
    };
    let mut renderer = renderer.lock();
    if config.timestamps
        && let Some(last) = renderer.read_pass_times_ms()
    {
        times.set(
            PASS_NAMES
                .iter()
                .zip(last)
                .filter_map(|(name, t)| Some((*name, t?)))
                .collect(),
        );
    }
    if let Some((positions_m, indices)) = extracted.occluders.take()
        && let Err(e) = renderer.set_occluders(&positions_m, &indices)
    {
        said.error(format!("rain occluders from Bevy's meshes: {e}"));
    }
    let (Some(entity), Some(scene)) = (extracted.camera, &extracted.scene) else {
        return;
    };
    let Ok((view, camera)) = views.get(entity) else {
        return;
    };
    if !camera.hdr {
        said.error(format!(
            "camera {entity}: not HDR (nimbus writes linear radiance into Bevy's Rgba16Float \
             main texture): keep the Hdr component NimbusCamera requires"
        ));
        return;
    }
    if view.target_format != TextureFormat::Rgba16Float {
        said.error(format!(
            "camera {entity}: main texture {:?}, not Rgba16Float",
            view.target_format
        ));
        return;
    }
    let Some(size) = camera.physical_target_size else {
        return;
    };
    if camera
        .physical_viewport_size
        .is_some_and(|viewport| viewport != size)
    {
        said.error(format!(
            "camera {entity}: a viewport smaller than its target is not supported; nimbus draws nothing"
        ));
        return;
    }
    let nimbus = match nimbus_view(view.world_from_view.to_matrix(), view.clip_from_view) {
        Ok(v) => v,
        Err(e) => {
            said.error(format!("camera {entity}: {e}; nimbus draws nothing"));
            return;
        }
    };
    renderer.set_pre_exposure((MAX_LUMINOUS_EFFICACY_LM_PER_W as f32) * camera.exposure);
    match renderer.prepare_view(scene, &nimbus, size.x, size.y, extracted.time_s as f32) {
        Ok(()) => prepared.view = Some(entity),
        Err(e) => {
            said.error(format!("weather: {e}"));
            return;
        }
    }
    if let Some(request) = &extracted.cloud_shadows {
        if !bake.supported {
            said.warn(
                "no cloud shadows on Bevy's meshes: Bevy's light textures (clustered decals) \
                 need binding arrays, which this device lacks"
                    .to_owned(),
            );
            return;
        }
        let baker = bake.baker.get_or_insert_with(|| {
            CloudShadowBaker::new(device.wgpu_device(), renderer.frame_resources())
        });
        let queue: &wgpu::Queue = &queue;
        baker.write(queue, request);
        prepared.bake = true;
    }
}

/// Maps the ambient probe's copy once this frame has been submitted.
fn map_ambient_probe(bake: Res<CloudShadowBake>) {
    if let Some(baker) = &bake.baker {
        baker.map_probe();
    }
}

/// nimbus's lighting step: atmosphere lookups, stratus field, cumulus
/// shadow map, rain simulation; then the cloud shadows baked into the sun's
/// light texture (before Bevy's main pass, which reads it).
#[allow(clippy::too_many_arguments)]
pub(crate) fn nimbus_lighting(
    view: ViewQuery<&ExtractedView>,
    renderer: Option<Res<NimbusRenderer>>,
    prepared: Res<Prepared>,
    extracted: Res<Extracted>,
    bake: Res<CloudShadowBake>,
    images: Res<RenderAssets<GpuImage>>,
    mut ctx: RenderContext,
) {
    if prepared.view != Some(view.entity()) {
        return;
    }
    let Some(renderer) = renderer else {
        return;
    };
    let renderer = renderer.lock();
    renderer.encode_lighting(ctx.command_encoder());
    if prepared.bake
        && let (Some(baker), Some(request)) = (&bake.baker, &extracted.cloud_shadows)
        && let Some(image) = images.get(request.image)
    {
        baker.encode(
            ctx.command_encoder(),
            renderer.frame_resources(),
            &image.texture_view,
        );
    }
}

/// Sky, clouds, rain, mist and air into the camera's HDR main texture by
/// Bevy's depth (after Bevy's opaque meshes, before its transparent ones).
pub(crate) fn nimbus_composite(
    view: ViewQuery<(&ViewTarget, &ViewDepthTexture)>,
    renderer: Option<Res<NimbusRenderer>>,
    prepared: Res<Prepared>,
    mut ctx: RenderContext,
) {
    if prepared.view != Some(view.entity()) {
        return;
    }
    let Some(renderer) = renderer else {
        return;
    };
    let (target, depth) = view.into_inner();
    let targets = FrameTargets {
        output: target.main_texture_view(),
        depth: depth.view(),
        load: TargetLoad::Keep,
    };
    renderer.lock().encode(ctx.command_encoder(), &targets);
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::camera::CameraProjection;
    use bevy::camera::PerspectiveProjection;
    use bevy::math::Vec3;
    use bevy::transform::components::Transform;

    /// Bevy's perspective becomes nimbus's: same field of view, aspect and
    /// near plane, reverse-Z, infinite far; a world point projects to the
    /// same pixel through both.
    #[test]
    fn bevy_perspective_is_nimbus_view() {
        let projection = PerspectiveProjection {
            fov: 1.1,
            aspect_ratio: 16.0 / 9.0,
            near: 0.25,
            ..Default::default()
        };
        let clip_from_view = projection.get_clip_from_view();
        let pose =
            Transform::from_xyz(3.0, 2.0, 10.0).looking_at(Vec3::new(0.0, 5.0, -20.0), Vec3::Y);
        let view = nimbus_view(pose.to_matrix(), clip_from_view).expect("Bevy's perspective");
        let Projection::Perspective {
            fov_y_rad,
            aspect,
            near_m,
            far_m,
            ..
        } = view.projection
        else {
            panic!("not a perspective: {:?}", view.projection);
        };
        assert!((fov_y_rad - 1.1).abs() < 1e-6);
        assert!((aspect - 16.0 / 9.0).abs() < 1e-6);
        assert!((near_m - 0.25).abs() < 1e-7);
        assert_eq!(far_m, None);
        assert_eq!(view.depth, DepthConvention::Reverse);
        let point = Vec3::new(1.0, 4.0, -15.0);
        let bevy_clip = clip_from_view * pose.to_matrix().inverse() * point.extend(1.0);
        let nimbus_clip = view.nimbus_clip_from_world()
            * glam::DVec4::new(
                f64::from(point.x),
                f64::from(point.y),
                f64::from(point.z),
                1.0,
            );
        let bevy_ndc = bevy_clip.truncate() / bevy_clip.w;
        let nimbus_ndc = nimbus_clip.truncate() / nimbus_clip.w;
        for (b, n) in bevy_ndc.to_array().iter().zip(nimbus_ndc.to_array()) {
            assert!(
                (f64::from(*b) - n).abs() < 1e-4,
                "{bevy_ndc} vs {nimbus_ndc}"
            );
        }
    }

    /// An orthographic camera is refused with a line, not drawn wrong.
    #[test]
    fn orthographic_is_refused() {
        let ortho = Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 0.1, 100.0);
        let e = nimbus_view(Mat4::IDENTITY, ortho).expect_err("orthographic");
        assert!(e.contains("orthographic"), "{e}");
    }
}
