//! nimbus's cloud shadows on Bevy's meshes.
//!
//! Bevy lights its meshes itself, so nimbus's lighting include cannot run in
//! their shaders; what Bevy offers for a pattern on a directional light is a
//! light texture (`DirectionalLightTexture`, a "cookie": its red channel
//! multiplies the light, projected along the light over a tile that the
//! light's `GlobalTransform` places and scales). The plugin gives the
//! [`NimbusSun`] such a texture and, each frame after nimbus's lighting step,
//! bakes into it, through nimbus's lighting include
//! (`nimbus_sun_visibility`: the cumulus shadow map's transmittance times
//! the stratus layer's), the fraction of the sun's light that reaches the
//! ground along each texel's sun ray. Every Bevy mesh that receives
//! Bevy's lighting is then shadowed by nimbus's clouds, whatever its
//! material, and Bevy's own shadow maps and ambient light are untouched.
//!
//! The tile ([`NimbusCloudShadows::half_extent_m`], 6 km by default, over
//! [`CLOUD_SHADOW_TEXELS`]² texels: 12 m a texel) follows the camera, snapped
//! to whole texels so that shadows do not crawl as it moves; it repeats
//! beyond its edges (Bevy's tiled light texture). The sun ray of a texel is
//! sampled at [`NimbusCloudShadows::sample_altitude_m`] (0 m): a mesh below
//! every cloud receives the right light; one inside or above a cloud gets the
//! shadow of the ground under it along the sun.
//!
//! Bevy draws light textures through its clustered decals, which need
//! binding arrays (`TEXTURE_BINDING_ARRAY` and non-uniform indexing: Vulkan,
//! DX12, most Metal devices; not WebGL): where the device lacks them the
//! plugin says so once and Bevy's meshes get no cloud shadows.

use crate::{NimbusCamera, NimbusSun};
use bevy::asset::{AssetId, Assets, Handle, RenderAssetUsages};
use bevy::camera::Camera;
use bevy::ecs::prelude::*;
use bevy::image::Image;
use bevy::light::DirectionalLightTexture;
use bevy::log::warn;
use bevy::math::{Mat4, Vec2, Vec3};
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
use bevy::transform::components::{GlobalTransform, Transform};
use bytemuck::{Pod, Zeroable};
use nimbus_render::frame::FrameResources;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::{Arc, Mutex};

/// Texels per side of the cloud shadow texture.
pub const CLOUD_SHADOW_TEXELS: u32 = 1024;

/// The baked texture's format: Bevy's light texture reads its red channel.
/// Alpha is written 0: Bevy 0.19 also blends the texture of a directional
/// light into the base colour of the meshes under it as a clustered decal
/// (seen here: with an opaque `R16Float` texture every Bevy mesh turned
/// red), and a decal of alpha 0 leaves the base colour, metallic and
/// roughness as they are (bevy_pbr's `apply_decals`, Porter–Duff over).
pub const CLOUD_SHADOW_FORMAT: TextureFormat = TextureFormat::Rgba16Float;

/// Cloud shadows on Bevy's meshes: a resource of the main world; changes
/// apply the next frame.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct NimbusCloudShadows {
    /// Shadow Bevy's meshes (a light texture on the [`NimbusSun`]).
    pub enabled: bool,
    /// Half the side of the shadowed square around the camera, m (beyond
    /// it the pattern repeats).
    pub half_extent_m: f32,
    /// Altitude at which each sun ray is sampled, m: below every cloud
    /// base, where the game's ground is.
    pub sample_altitude_m: f32,
}

impl Default for NimbusCloudShadows {
    fn default() -> Self {
        Self {
            enabled: true,
            half_extent_m: 6000.0,
            sample_altitude_m: 0.0,
        }
    }
}

/// The texture the plugin bakes into (the [`NimbusSun`]'s
/// `DirectionalLightTexture`): a resource of the main world.
#[derive(Resource, Clone, Debug)]
pub struct NimbusCloudShadowTexture(pub Handle<Image>);

impl FromWorld for NimbusCloudShadowTexture {
    fn from_world(world: &mut World) -> Self {
        // Fully lit until the first bake: (1, 1, 1, 0) in half floats
        // (1.0 is 0x3C00).
        let lit: Vec<u8> = [0x3C00u16, 0x3C00, 0x3C00, 0]
            .iter()
            .flat_map(|h| h.to_le_bytes())
            .collect();
        let mut image = Image::new_fill(
            Extent3d {
                width: CLOUD_SHADOW_TEXELS,
                height: CLOUD_SHADOW_TEXELS,
                depth_or_array_layers: 1,
            },
            TextureDimension::D2,
            &lit,
            CLOUD_SHADOW_FORMAT,
            RenderAssetUsages::RENDER_WORLD,
        );
        // COPY_SRC: it can be read back (the golden test does).
        image.texture_descriptor.usage = TextureUsages::TEXTURE_BINDING
            | TextureUsages::COPY_DST
            | TextureUsages::COPY_SRC
            | TextureUsages::RENDER_ATTACHMENT;
        let handle = world.resource_mut::<Assets<Image>>().add(image);
        Self(handle)
    }
}

/// The sun light's transform that places the tile: the light's rotation,
/// the camera's position snapped to whole texels across the light, and a
/// uniform scale of `half_extent_m`.
pub fn tile_transform(rotation: bevy::math::Quat, camera_m: Vec3, half_extent_m: f32) -> Transform {
    let texel_m = 2.0 * half_extent_m / CLOUD_SHADOW_TEXELS as f32;
    let local = rotation.inverse() * camera_m;
    let snapped = (Vec2::new(local.x, local.y) / texel_m).round() * texel_m;
    Transform {
        translation: rotation * snapped.extend(0.0),
        rotation,
        scale: Vec3::splat(half_extent_m),
    }
}

/// Where Bevy samples a directional light's texture for world point
/// `position_m` (bevy_pbr's `pbr_lighting.wgsl`, `directional_light`):
/// `local = light_from_world · P`, `uv = local.xy · (−½, ½) + ½`.
pub fn bevy_light_texture_uv(world_from_light: Mat4, position_m: Vec3) -> Vec2 {
    let local = world_from_light.inverse().transform_point3(position_m);
    Vec2::new(local.x, local.y) * Vec2::new(-0.5, 0.5) + 0.5
}

/// The inverse that the bake evaluates (`bake_fragment` in
/// cloud_shadows.wgsl): the world point of texture coordinate `uv` on the
/// sun ray through it, at `altitude_m`. `None` when the sun is at or below
/// the horizon.
pub fn bake_world_point(
    world_from_light: Mat4,
    to_sun: Vec3,
    uv: Vec2,
    altitude_m: f32,
) -> Option<Vec3> {
    if to_sun.y <= 1e-3 {
        return None;
    }
    let local = Vec2::new((0.5 - uv.x) * 2.0, (uv.y - 0.5) * 2.0);
    let on_plane = world_from_light.transform_point3(local.extend(0.0));
    Some(on_plane + to_sun * ((altitude_m - on_plane.y) / to_sun.y))
}

/// The cameras that may carry the weather.
type CameraQuery<'w, 's> =
    Query<'w, 's, (Entity, &'static Camera, &'static GlobalTransform), With<NimbusCamera>>;

/// The sun lights and their light textures.
type SunQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static mut Transform,
        Option<&'static DirectionalLightTexture>,
    ),
    With<NimbusSun>,
>;

/// Gives each [`NimbusSun`] the cloud shadow texture and places its tile
/// around the camera (after the sun's rotation is set).
pub(crate) fn place_cloud_shadows(
    mut commands: Commands,
    settings: Res<NimbusCloudShadows>,
    texture: Option<Res<NimbusCloudShadowTexture>>,
    cameras: CameraQuery,
    mut suns: SunQuery,
    mut said_foreign: Local<bool>,
) {
    let Some(texture) = texture else {
        return;
    };
    let camera_m = cameras
        .iter()
        .filter(|(_, camera, _)| camera.is_active)
        .min_by_key(|(entity, camera, _)| (camera.order, *entity))
        .map_or(Vec3::ZERO, |(_, _, transform)| transform.translation());
    for (entity, mut transform, light_texture) in &mut suns {
        match light_texture {
            Some(own) if own.image != texture.0 => {
                if !*said_foreign {
                    *said_foreign = true;
                    warn!(
                        "nimbus: sun {entity} has a DirectionalLightTexture of its own: \
                         nimbus's cloud shadows are not drawn on Bevy's meshes"
                    );
                }
                continue;
            }
            Some(_) if !settings.enabled => {
                commands.entity(entity).remove::<DirectionalLightTexture>();
                transform.translation = Vec3::ZERO;
                transform.scale = Vec3::ONE;
                continue;
            }
            None if settings.enabled => {
                commands.entity(entity).insert(DirectionalLightTexture {
                    image: texture.0.clone(),
                    tiled: true,
                });
            }
            None => continue,
            Some(_) => {}
        }
        let placed = tile_transform(transform.rotation, camera_m, settings.half_extent_m);
        if transform.translation != placed.translation || transform.scale != placed.scale {
            transform.translation = placed.translation;
            transform.scale = placed.scale;
        }
    }
}

/// What the bake needs from the main world this frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BakeRequest {
    /// The sun light's `GlobalTransform`, as Bevy's decals see it.
    pub world_from_light: Mat4,
    /// The camera's position, m (the ambient probe's).
    pub camera_m: Vec3,
    /// The texture baked into.
    pub image: AssetId<Image>,
    /// [`NimbusCloudShadows::sample_altitude_m`].
    pub sample_altitude_m: f32,
}

/// nimbus's irradiance on an upward surface at the camera, read back from
/// the GPU (W·m⁻², luminous-equivalent, per channel) with whether the
/// camera is under the stratus layer: a resource of both worlds sharing one
/// value, which [`crate::NimbusSun`]'s `drive_ambient` uses for Bevy's
/// ambient light under the layer (where the clear sky's is far too dark).
#[derive(Resource, Clone, Debug, Default)]
pub struct NimbusAmbientProbe(pub(crate) Arc<Mutex<Option<AmbientReading>>>);

/// One reading of the ambient probe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AmbientReading {
    /// Irradiance on an upward surface, per channel (nimbus's units: ×683 for lux).
    pub irradiance_up: [f32; 3],
    /// The camera is under the stratus layer.
    pub under_layer: bool,
}

impl NimbusAmbientProbe {
    /// The last reading (a frame or two old), if any.
    pub fn latest(&self) -> Option<AmbientReading> {
        self.0.lock().ok().and_then(|r| *r)
    }

    fn set(&self, reading: AmbientReading) {
        if let Ok(mut r) = self.0.lock() {
            *r = Some(reading);
        }
    }
}

/// The suns whose light texture is nimbus's, with their transforms.
pub(crate) type ExtractSunQuery<'w, 's> =
    Query<'w, 's, (&'static GlobalTransform, &'static DirectionalLightTexture), With<NimbusSun>>;

/// This frame's bake, if the sun carries nimbus's texture.
pub(crate) fn bake_request(
    settings: &NimbusCloudShadows,
    texture: &NimbusCloudShadowTexture,
    suns: &ExtractSunQuery,
    camera_m: Vec3,
) -> Option<BakeRequest> {
    if !settings.enabled {
        return None;
    }
    suns.iter()
        .find(|(_, light_texture)| light_texture.image == texture.0)
        .map(|(transform, _)| BakeRequest {
            world_from_light: transform.to_matrix(),
            camera_m,
            image: texture.0.id(),
            sample_altitude_m: settings.sample_altitude_m,
        })
}

/// GPU layout of the bake's uniform (WGSL `CloudShadowBake`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub(crate) struct CloudShadowBakeUniform {
    /// World from the light's local space (column-major).
    pub world_from_light: [[f32; 4]; 4],
    /// Sample altitude (m), texels per side, unused, unused.
    pub params: [f32; 4],
    /// The camera's position (m) for the ambient probe; w unused.
    pub camera_m: [f32; 4],
}

/// The bake's WGSL, after nimbus's lighting include.
pub fn bake_shader() -> String {
    nimbus_render::shader::lighting_include() + include_str!("cloud_shadows.wgsl")
}

/// The ambient probe's readback: idle, copied this frame (to be mapped
/// once submitted), mapping, mapped (to be read).
const PROBE_IDLE: u8 = 0;
const PROBE_COPIED: u8 = 1;
const PROBE_MAPPING: u8 = 2;
const PROBE_MAPPED: u8 = 3;

/// The bake's pipeline and uniform on Bevy's device, and the ambient probe.
pub(crate) struct CloudShadowBaker {
    pipeline: wgpu::RenderPipeline,
    uniform: wgpu::Buffer,
    group: wgpu::BindGroup,
    probe_pipeline: wgpu::RenderPipeline,
    probe_view: wgpu::TextureView,
    probe_texture: wgpu::Texture,
    probe_staging: wgpu::Buffer,
    probe_state: Arc<AtomicU8>,
}

impl CloudShadowBaker {
    /// Builds the pipeline against nimbus's frame layouts.
    pub fn new(device: &wgpu::Device, frame: &FrameResources) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("nimbus-bevy cloud shadow bake"),
            entries: &[nimbus_render::binding::uniform_layout_entry(
                0,
                wgpu::ShaderStages::FRAGMENT,
                std::mem::size_of::<CloudShadowBakeUniform>() as u64,
            )],
        });
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("nimbus-bevy cloud shadow bake"),
            size: std::mem::size_of::<CloudShadowBakeUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("nimbus-bevy cloud shadow bake"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            }],
        });
        let pipeline_layout =
            frame
                .layouts()
                .pipeline_layout(device, "nimbus-bevy cloud shadow bake", Some(&layout));
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("nimbus-bevy cloud shadow bake"),
            source: wgpu::ShaderSource::Wgsl(bake_shader().into()),
        });
        let full_screen = |entry: &str, format: TextureFormat| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("nimbus-bevy cloud shadow bake"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("bake_vertex"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipeline = full_screen("bake_fragment", CLOUD_SHADOW_FORMAT);
        let probe_pipeline = full_screen("ambient_fragment", TextureFormat::Rgba32Float);
        let probe_texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("nimbus-bevy ambient probe"),
            size: wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let probe_staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("nimbus-bevy ambient probe"),
            size: 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            uniform,
            group,
            probe_pipeline,
            probe_view: probe_texture.create_view(&Default::default()),
            probe_texture,
            probe_staging,
            probe_state: Arc::new(AtomicU8::new(PROBE_IDLE)),
        }
    }

    /// Starts mapping the probe's copy once the frame that made it is
    /// submitted (Bevy's `RenderSystems::Cleanup`).
    pub fn map_probe(&self) {
        if self
            .probe_state
            .compare_exchange(
                PROBE_COPIED,
                PROBE_MAPPING,
                Ordering::AcqRel,
                Ordering::Acquire,
            )
            .is_ok()
        {
            let state = Arc::clone(&self.probe_state);
            self.probe_staging
                .slice(..)
                .map_async(wgpu::MapMode::Read, move |result| {
                    state.store(
                        if result.is_ok() {
                            PROBE_MAPPED
                        } else {
                            PROBE_IDLE
                        },
                        Ordering::Release,
                    );
                });
        }
    }

    /// Reads a mapped probe into `probe` (polling the device first).
    pub fn read_probe(&self, device: &wgpu::Device, probe: &NimbusAmbientProbe) {
        if self.probe_state.load(Ordering::Acquire) == PROBE_MAPPING {
            let _ = device.poll(wgpu::PollType::Poll);
        }
        if self.probe_state.load(Ordering::Acquire) != PROBE_MAPPED {
            return;
        }
        {
            let bytes = self.probe_staging.slice(..).get_mapped_range();
            let v: [f32; 4] = bytemuck::pod_read_unaligned(&bytes[..16]);
            if v[..3].iter().all(|c| c.is_finite() && *c >= 0.0) {
                probe.set(AmbientReading {
                    irradiance_up: [v[0], v[1], v[2]],
                    under_layer: v[3] > 0.5,
                });
            }
        }
        self.probe_staging.unmap();
        self.probe_state.store(PROBE_IDLE, Ordering::Release);
    }

    /// Writes the uniform for this frame's request.
    pub fn write(&self, queue: &wgpu::Queue, request: &BakeRequest) {
        let value = CloudShadowBakeUniform {
            world_from_light: request.world_from_light.to_cols_array_2d(),
            params: [
                request.sample_altitude_m,
                CLOUD_SHADOW_TEXELS as f32,
                0.0,
                0.0,
            ],
            camera_m: request.camera_m.extend(1.0).to_array(),
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&value));
    }

    /// Records the bake into `target` (the light texture's view), after
    /// nimbus's lighting step in the same encoder.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &FrameResources,
        target: &wgpu::TextureView,
    ) {
        // Cleared to fully lit, alpha 0 (see CLOUD_SHADOW_FORMAT).
        let lit = wgpu::Color {
            r: 1.0,
            g: 1.0,
            b: 1.0,
            a: 0.0,
        };
        let mut pass = full_screen_pass(encoder, "nimbus-bevy cloud shadow bake", target, lit);
        pass.set_pipeline(&self.pipeline);
        frame.bindings().set_on(&mut pass, Some(&self.group));
        pass.draw(0..3, 0..1);
        drop(pass);
        // The ambient probe, when the last one has been read.
        if self.probe_state.load(Ordering::Acquire) != PROBE_IDLE {
            return;
        }
        let mut pass = full_screen_pass(
            encoder,
            "nimbus-bevy ambient probe",
            &self.probe_view,
            wgpu::Color::TRANSPARENT,
        );
        pass.set_pipeline(&self.probe_pipeline);
        frame.bindings().set_on(&mut pass, Some(&self.group));
        pass.draw(0..3, 0..1);
        drop(pass);
        encoder.copy_texture_to_buffer(
            self.probe_texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &self.probe_staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: None,
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
        );
        self.probe_state.store(PROBE_COPIED, Ordering::Release);
    }
}

/// A render pass of one colour target, cleared to `clear`, for a full-screen triangle.
fn full_screen_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    target: &wgpu::TextureView,
    clear: wgpu::Color,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(clear),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Quat;

    /// The bake's texel-to-world mapping inverts Bevy's light texture
    /// lookup: the world point baked for a texel is sampled by Bevy at
    /// that texel, for any sun and tile, and every point of its sun ray too.
    #[test]
    fn bake_inverts_bevy_light_texture_lookup() {
        for (to_sun, camera) in [
            (Vec3::new(0.3, 0.6, -0.5), Vec3::new(120.0, 2.0, -40.0)),
            (Vec3::new(-0.8, 0.2, 0.1), Vec3::new(-3000.0, 80.0, 900.0)),
            (Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO),
        ] {
            let to_sun = to_sun.normalize();
            let up = if to_sun.y.abs() > 0.999 {
                Vec3::Z
            } else {
                Vec3::Y
            };
            let rotation = Transform::IDENTITY.looking_to(-to_sun, up).rotation;
            let tile = tile_transform(rotation, camera, 6000.0);
            let world_from_light = tile.to_matrix();
            for uv in [
                Vec2::new(0.5, 0.5),
                Vec2::new(0.1, 0.8),
                Vec2::new(0.93, 0.02),
            ] {
                let p = bake_world_point(world_from_light, to_sun, uv, 0.0).expect("sun up");
                assert!(p.y.abs() < 1e-2, "altitude {}", p.y);
                for t in [0.0, 500.0, 2500.0] {
                    let back = bevy_light_texture_uv(world_from_light, p + t * to_sun);
                    assert!(back.distance(uv) < 1e-4, "{uv} -> {p} -> {back}");
                }
            }
            // The camera is within half a texel of the tile's centre across the sun.
            let centre = bevy_light_texture_uv(world_from_light, camera);
            assert!(
                (centre - Vec2::splat(0.5)).abs().max_element()
                    <= 0.5 / CLOUD_SHADOW_TEXELS as f32 + 1e-6,
                "{centre}"
            );
        }
        assert!(
            bake_world_point(Mat4::IDENTITY, Vec3::new(1.0, 0.0, 0.0), Vec2::ZERO, 0.0).is_none()
        );
    }

    /// The tile's translation moves by whole texels only: a camera moving
    /// less than a texel across the sun leaves it where it was.
    #[test]
    fn tile_snaps_to_texels() {
        let rotation = Quat::from_rotation_x(-0.7) * Quat::from_rotation_y(0.4);
        let a = tile_transform(rotation, Vec3::new(10.0, 2.0, 10.0), 6000.0);
        let texel_m = 12000.0 / CLOUD_SHADOW_TEXELS as f32;
        let b = tile_transform(rotation, Vec3::new(10.0 + 0.1 * texel_m, 2.0, 10.0), 6000.0);
        let along = rotation.inverse() * (b.translation - a.translation);
        for c in [along.x, along.y] {
            let texels = c / texel_m;
            assert!((texels - texels.round()).abs() < 1e-3, "{texels}");
        }
        assert_eq!(a.scale, Vec3::splat(6000.0));
    }

    /// The uniform's Rust layout is the WGSL struct's (naga's layouter).
    #[test]
    fn bake_uniform_layout_matches_wgsl() {
        let module = naga::front::wgsl::parse_str(&bake_shader()).expect("bake WGSL parses");
        let mut layouter = naga::proc::Layouter::default();
        layouter
            .update(module.to_ctx())
            .expect("layouts of the bake's types");
        let (handle, _) = module
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some("CloudShadowBake"))
            .expect("CloudShadowBake in the WGSL");
        assert_eq!(
            layouter[handle].size as usize,
            std::mem::size_of::<CloudShadowBakeUniform>()
        );
        let mut validator = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        );
        validator.validate(&module).expect("bake WGSL validates");
    }
}
