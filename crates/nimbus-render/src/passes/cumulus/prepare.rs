//! Per-frame preparation: shapes generated or loaded, the field placed, this frame's instances selected and uploaded.

use super::field::{
    drift_field, field_area, level_of_detail, place_field, shadow_clip_from_world,
    sphere_in_frustum,
};
use super::gpu_types::{CloudPlacement, CumulusInstance, CumulusUniform};
use super::shadow::{ShadowContent, ShadowKey};
use super::variants::{CumulusVariant, VariantParams};
use super::{
    CumulusError, CumulusPass, Draw, DropletTables, FieldCloud, FieldKey, GpuLod, GpuVariant,
    PHASE_TEXELS, SHADOW_FILTER_TEXELS, SHADOW_LOD, TransferKey, transfer, variants,
};
use super::{in_cloud, interior};
use crate::core::background::Precompute;
use crate::frame::FrameUniform;
use crate::frame::cloud_lighting::{load_optics, optics_params};
use crate::frame::cloud_shadow::{CloudShadowMap, CloudShadowUniform, SHADOW_MAP_SIZE};
use crate::scene::{CumulusSettings, Scene, StratusSettings};
use glam::{DVec3, Vec3};
use nimbus_physics::cumulus::forward_peak::{self, ForwardPeakTable};
use nimbus_physics::cumulus::shading::{CLOUD_ASYMMETRY, CumulusShadingModel};
use nimbus_physics::optics::tables::CloudOpticsParams;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use wgpu::util::DeviceExt;

/// The clouds' droplets: the stratus layer's size distribution, the default
/// one without a layer (the same phase function `nimbus export` gives the
/// cumulus volumes).
fn droplet_params(scene: &Scene) -> CloudOpticsParams {
    match &scene.stratus {
        Some(layer) => optics_params(layer),
        None => optics_params(&StratusSettings::default()),
    }
}

/// The droplets' forward-peak table, their phase function without the
/// peak resampled on [`PHASE_TEXELS`] texels (RGBA), and δ-M's 1 − f.
fn droplet_tables(params: &CloudOpticsParams) -> DropletTables {
    let optics = load_optics(params);
    let n = optics.peak_removed.len() / 3;
    let mut phase_rgba = vec![0.0f32; 4 * PHASE_TEXELS];
    for i in 0..PHASE_TEXELS {
        let x = i as f64 / (PHASE_TEXELS - 1) as f64 * (n - 1) as f64;
        let j = (x.floor() as usize).min(n - 2);
        let t = (x - j as f64) as f32;
        for c in 0..3 {
            let (a, b) = (
                optics.peak_removed[3 * j + c],
                optics.peak_removed[3 * j + 3 + c],
            );
            phase_rgba[4 * i + c] = a + t * (b - a);
        }
        phase_rgba[4 * i + 3] = 1.0;
    }
    DropletTables {
        forward_peak: ForwardPeakTable::from_optics(&optics),
        phase_rgba,
        truncation: 1.0 - optics.forward_fraction[1],
    }
}

impl CumulusPass {
    /// Computes (on a worker thread under [`Precompute::Background`]) and
    /// uploads the forward-peak table F(θ, τ) when the droplets change:
    /// from the stratus layer's droplet size distribution (the default one
    /// without a layer; the same phase function `nimbus export` gives the
    /// cumulus volumes), its optical tables cached on disk. Whether the
    /// table of this scene's droplets is uploaded.
    fn update_forward_peak(
        &mut self,
        queue: &wgpu::Queue,
        scene: &Scene,
        precompute: Precompute,
    ) -> bool {
        let params = droplet_params(scene);
        let key = params.cache_hash();
        if self.forward_peak_key == Some(key) {
            return true;
        }
        let Some(tables) = self.forward_peak.request_current(&params, precompute, || {
            let job = params.clone();
            move || Arc::new(droplet_tables(&job))
        }) else {
            return false;
        };
        let tables = tables.clone();
        queue.write_texture(
            self.phase_table.as_image_copy(),
            bytemuck::cast_slice(&tables.phase_rgba),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(PHASE_TEXELS as u32 * 16),
                rows_per_image: None,
            },
            self.phase_table.size(),
        );
        self.transport_truncation = tables.truncation;
        let table = &tables.forward_peak;
        queue.write_texture(
            self.forward_peak_table.as_image_copy(),
            bytemuck::cast_slice(&table.rgba_texels()),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(forward_peak::ANGLES as u32 * 16),
                rows_per_image: None,
            },
            self.forward_peak_table.size(),
        );
        self.forward_peak_key = Some(key);
        true
    }

    /// The work under way on worker threads.
    pub fn pending(&self) -> impl Iterator<Item = &'static str> {
        [
            self.shapes.pending(),
            self.forward_peak.pending(),
            self.transfers.pending(),
            self.in_cloud.pending(),
        ]
        .into_iter()
        .flatten()
    }

    /// Blocks until the work under way has finished (the next
    /// [`Self::prepare`] uploads it).
    pub fn wait(&mut self) {
        self.shapes.wait();
        self.forward_peak.wait();
        self.transfers.wait();
        self.in_cloud.wait();
    }

    /// Requests (on a worker thread under [`Precompute::Background`]) the
    /// transport model's transfers of the variants for the field's scales,
    /// and uploads them once computed. Whether the variants' buffers hold
    /// this key's.
    fn update_transfers(
        &mut self,
        queue: &wgpu::Queue,
        key: TransferKey,
        precompute: Precompute,
    ) -> Result<bool, CumulusError> {
        if self.transfer_uploaded.as_ref() == Some(&key) {
            return Ok(true);
        }
        let Some((_, variants)) = &self.variants else {
            return Ok(false);
        };
        let Some(result) = self.transfers.request_current(&key, precompute, || {
            // Copied only when a computation starts, not every frame.
            let shapes: Vec<Arc<CumulusVariant>> =
                variants.iter().map(|v| v.shape.clone()).collect();
            let job = key.clone();
            move || {
                let optics = load_optics(&job.optics);
                transfer::load_or_compute(
                    &crate::core::cache::cache_dir(),
                    &job.params,
                    &shapes,
                    &optics,
                )
            }
        }) else {
            return Ok(false);
        };
        let transfers = result.clone()?;
        let Some((_, variants)) = &self.variants else {
            return Ok(false);
        };
        for (variant, t) in variants.iter().zip(&transfers) {
            for (lod, data) in variant.lods.iter().zip(&t.lods) {
                queue.write_buffer(&lod.transfer, 0, bytemuck::cast_slice(data));
            }
        }
        self.transfer_uploaded = Some(key);
        Ok(true)
    }

    /// Nothing drawn this frame: no clouds, no shadow.
    fn disable(&mut self, queue: &wgpu::Queue, shadow_map: &CloudShadowMap) {
        self.moved.clear();
        self.enabled = false;
        self.shadow_enabled = false;
        self.shadow_redraw = false;
        shadow_map.write(queue, &CloudShadowUniform::default());
    }

    /// Whether the frame has clouds to draw.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Whether the shadow map is drawn this frame: the clouds cast shadows
    /// and what the map holds is not this frame's already.
    pub fn shadow_redrawn(&self) -> bool {
        self.shadow_enabled && self.shadow_redraw
    }

    /// Makes the next [`Self::prepare`] redraw the shadow map.
    pub fn invalidate_shadow(&self) {
        self.shadow_drawn.store(false, Ordering::Release);
    }

    /// The clouds of the last prepared frame, where the wind has carried
    /// them (see [`CloudPlacement`]).
    pub fn placed_clouds(&self) -> Vec<CloudPlacement> {
        self.moved.iter().map(FieldCloud::placement).collect()
    }

    /// The variants' generation parameters (`None` without cumulus).
    pub fn variant_params(&self) -> Option<&VariantParams> {
        self.variants.as_ref().map(|v| &v.0)
    }

    /// The placed clouds' footprints as (x, z, radius), m: their bounding
    /// spheres seen from below (where rain under cumulus falls).
    pub fn footprints_m(&self) -> Vec<[f32; 3]> {
        self.moved
            .iter()
            .map(|c| [c.centre_m.x as f32, c.centre_m.z as f32, c.radius_m as f32])
            .collect()
    }

    /// The mean centre of the field's clouds this frame (of their bounding
    /// spheres), world m; None without clouds.
    pub fn mean_centre_m(&self) -> Option<[f64; 3]> {
        if self.moved.is_empty() {
            return None;
        }
        let sum: DVec3 = self.moved.iter().map(|c| c.centre_m).sum();
        Some((sum / self.moved.len() as f64).to_array())
    }

    /// Number of clouds in the field and number drawn this frame.
    pub fn cloud_counts(&self) -> (usize, usize) {
        let drawn = self.draws.iter().map(|d| d.instances.len()).sum();
        (self.field.as_ref().map_or(0, |f| f.1.len()), drawn)
    }

    /// Generates (or loads) the shapes, places the field, and selects and
    /// uploads this frame's instances and shadow transform. Under
    /// [`Precompute::Background`] the shapes and the forward-peak table are
    /// made on worker threads and no cloud is drawn until both are ready.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        frame: &FrameUniform,
        shadow_map: &CloudShadowMap,
        width: u32,
        height: u32,
        precompute: Precompute,
    ) -> Result<(), CumulusError> {
        self.draws.clear();
        self.shadow_draws.clear();
        self.in_cloud.clear();
        let Some(settings) = &scene.cumulus else {
            self.disable(queue, shadow_map);
            return Ok(());
        };
        let params = VariantParams::from(settings);
        // Both requested before either is waited for, so that they run side by side.
        let shapes = self
            .shapes
            .request_current(&params, precompute, || {
                let job = params.clone();
                move || variants::load_or_generate(&crate::core::cache::cache_dir(), &job)
            })
            .cloned();
        let volume = settings.shading.model == CumulusShadingModel::Volume;
        let transport = settings.shading.model == CumulusShadingModel::Transport;
        // The droplets' tables are needed by the forward peak, the transport
        // model and the in-cloud march (its phase function and δ-M factor).
        let peak_ready = self.update_forward_peak(queue, scene, precompute);
        let shapes = match shapes {
            Some(shapes) => shapes?,
            None => {
                self.disable(queue, shadow_map);
                return Ok(());
            }
        };
        if !peak_ready {
            self.disable(queue, shadow_map);
            return Ok(());
        }
        if self.variants.as_ref().map(|v| &v.0) != Some(&params) {
            let gpu = shapes
                .into_iter()
                .map(|shape| GpuVariant {
                    lods: shape
                        .lods
                        .iter()
                        .map(|lod| GpuLod {
                            vertices: device.create_buffer_init(
                                &wgpu::util::BufferInitDescriptor {
                                    label: Some("cumulus vertices"),
                                    contents: bytemuck::cast_slice(&lod.vertices),
                                    usage: wgpu::BufferUsages::VERTEX,
                                },
                            ),
                            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                                label: Some("cumulus indices"),
                                contents: bytemuck::cast_slice(&lod.indices),
                                usage: wgpu::BufferUsages::INDEX,
                            }),
                            index_count: lod.indices.len() as u32,
                            transfer: device.create_buffer(&wgpu::BufferDescriptor {
                                label: Some("cumulus transfer"),
                                size: (lod.vertices.len().max(1)
                                    * std::mem::size_of::<transfer::TransferVertex>())
                                    as u64,
                                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                                mapped_at_creation: false,
                            }),
                        })
                        .collect(),
                    shape,
                })
                .collect();
            self.variants = Some((params.clone(), gpu));
            self.transfer_uploaded = None;
            self.field = None;
            self.shadow_content = None;
        }
        let Some((_, variants)) = &self.variants else {
            return Ok(());
        };
        let (area_centre_m, area_side_m) = field_area(scene, settings);
        let key = FieldKey {
            placement: CumulusSettings {
                shading: Default::default(),
                terms: Default::default(),
                ..settings.clone()
            },
            area_centre_m,
            area_side_m,
        };
        if self.field.as_ref().map(|f| &f.0) != Some(&key) {
            let shapes: Vec<&CumulusVariant> = variants.iter().map(|v| &*v.shape).collect();
            let clouds = place_field(settings, area_centre_m, area_side_m, &shapes);
            self.field = Some((key, clouds));
        }
        let Some((key, placed)) = &self.field else {
            return Ok(());
        };
        // The same placement and drift as `cumulus_field_at` (the exports').
        let drift = scene.cloud_drift_m(f64::from(frame.time_s));
        self.moved.clear();
        self.moved.extend(drift_field(
            settings,
            placed,
            key.area_centre_m,
            key.area_side_m,
            drift,
        ));
        let mut uniform = CumulusUniform::new(settings, &scene.atmosphere, scene.sun.direction());
        // The volume model shades the clouds beyond those it marches as the
        // transport model does (none when it can march them all).
        let meshes_shaded = !volume || self.moved.len() > in_cloud::MAX_MARCHED_CLOUDS;
        if (transport || volume) && meshes_shaded && !self.moved.is_empty() {
            // The transfer's scales: the field's smallest and largest, to a
            // thousandth (a field edited by a hair keeps its transfer).
            let round = |s: f64| (s * 1000.0).round() / 1000.0;
            let (lo, hi) = self.moved.iter().fold((f64::MAX, 0.0f64), |(lo, hi), c| {
                let s = f64::from(c.instance.offset_scale[3]);
                (lo.min(s), hi.max(s))
            });
            let scales = [round(lo), round(hi)];
            let optics = droplet_params(scene);
            let key = TransferKey {
                params: transfer::TransferParams {
                    variants: params.clone(),
                    density_per_m: settings.shading.density_per_m,
                    corona_thickness_m: settings.shading.corona_thickness_m,
                    scales,
                    optics_hash: optics.cache_hash(),
                    photons: transfer::TRANSFER_PHOTONS,
                },
                optics,
            };
            if self.update_transfers(queue, key, precompute)? {
                let span = (scales[1] / scales[0]).ln();
                uniform.flags[2] = 1;
                uniform.transport = [
                    scales[0].ln() as f32,
                    if span > 1e-9 {
                        (1.0 / span) as f32
                    } else {
                        0.0
                    },
                    self.transport_truncation,
                    PHASE_TEXELS as f32,
                ];
            }
        }
        let clouds = &self.moved;
        let Some((_, variants)) = &self.variants else {
            return Ok(());
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        // The camera in or near a cloud: the march takes it over.
        if !clouds.is_empty() {
            let optics = droplet_params(scene);
            let round = |s: f64| (s * 1000.0).round() / 1000.0;
            let (lo, hi) = clouds.iter().fold((f64::MAX, 0.0f64), |(lo, hi), c| {
                let s = f64::from(c.instance.offset_scale[3]);
                (lo.min(s), hi.max(s))
            });
            let key = in_cloud::InteriorKey {
                params: interior::InteriorParams {
                    variants: params.clone(),
                    density_per_m: settings.shading.density_per_m,
                    corona_thickness_m: settings.shading.corona_thickness_m,
                    scales: [round(lo), round(hi)],
                    optics_hash: optics.cache_hash(),
                },
                optics,
            };
            let shapes: Vec<Arc<CumulusVariant>> =
                variants.iter().map(|v| v.shape.clone()).collect();
            let view = in_cloud::MarchView {
                volume,
                clip_from_world: frame.clip_from_world(),
                size: (width, height),
                layer_slab_m: scene
                    .stratus
                    .as_ref()
                    .map(|layer| [layer.base_m, layer.base_m + layer.thickness_m]),
            };
            self.in_cloud.ensure_scene_depth(view.size);
            self.in_cloud.prepare(
                queue,
                DVec3::from_array(frame.camera_position_m.map(f64::from)),
                clouds,
                &shapes,
                key,
                DVec3::from_array(frame.sun_direction.map(f64::from)),
                self.transport_truncation,
                precompute,
                &view,
            )?;
        }
        let active = self.in_cloud.active().to_vec();

        // Instances: the camera's (culled, by level of detail), then the shadow's (all).
        let clip_from_world = frame.clip_from_world();
        let camera = Vec3::from_array(frame.camera_position_m);
        let mut camera_list: Vec<(usize, usize, CumulusInstance)> = Vec::new();
        for (index, cloud) in clouds.iter().enumerate() {
            let mut instance = cloud.instance;
            if let Some(a) = active.iter().find(|a| a.cloud == index) {
                // Drawn by the march alone once it has fully taken over.
                if a.fade >= 1.0 {
                    continue;
                }
                instance.rotation_noise[3] = a.fade;
            }
            if !sphere_in_frustum(
                &clip_from_world,
                cloud.centre_m.as_vec3(),
                cloud.radius_m as f32,
            ) {
                continue;
            }
            let distance = (cloud.centre_m.as_vec3() - camera).length() as f64 - cloud.radius_m;
            let lod = level_of_detail(
                cloud.finest_cell_m,
                distance,
                f64::from(frame.pixel_angle_rad),
                variants[cloud.variant].lods.len(),
            );
            camera_list.push((cloud.variant, lod, instance));
        }
        camera_list.sort_by_key(|(v, l, _)| (*v, *l));
        let mut data: Vec<CumulusInstance> = Vec::with_capacity(camera_list.len() + clouds.len());
        let push_runs = |list: &[(usize, usize, CumulusInstance)],
                         draws: &mut Vec<Draw>,
                         data: &mut Vec<CumulusInstance>| {
            for (v, l, inst) in list {
                let at = data.len() as u32;
                data.push(*inst);
                match draws.last_mut() {
                    Some(d) if d.variant == *v && d.lod == *l && d.instances.end == at => {
                        d.instances.end = at + 1
                    }
                    _ => draws.push(Draw {
                        variant: *v,
                        lod: *l,
                        instances: at..at + 1,
                    }),
                }
            }
        };
        push_runs(&camera_list, &mut self.draws, &mut data);
        let sun = scene.sun.direction();
        let to_sun = DVec3::from_array(sun);
        self.shadow_enabled = to_sun.y > 0.0 && !clouds.is_empty() && settings.terms.shadow;
        self.shadow_redraw = false;
        if self.shadow_enabled {
            let shapes: Vec<(usize, usize)> = clouds
                .iter()
                .map(|cloud| {
                    let lods = variants[cloud.variant].lods.len();
                    (cloud.variant, SHADOW_LOD.min(lods - 1))
                })
                .collect();
            let key = ShadowKey {
                uniform: uniform.without_sun(),
                shapes,
            };
            let centres_m: Vec<DVec3> = clouds.iter().map(|c| c.centre_m).collect();
            // The map kept (translated with the field's drift) where its
            // clouds and sun are this frame's; else redrawn.
            let kept = self
                .shadow_content
                .as_ref()
                .filter(|_| self.shadow_drawn.load(Ordering::Acquire))
                .and_then(|held| {
                    let matrix =
                        held.reused_transform(&key, &centres_m, drift, to_sun, SHADOW_MAP_SIZE)?;
                    Some((matrix, held.depth_m))
                });
            let (matrix, depth_m) = match kept {
                Some(kept) => kept,
                None => {
                    let mut shadow_list: Vec<(usize, usize, CumulusInstance)> = key
                        .shapes
                        .iter()
                        .zip(clouds)
                        .map(|(&(variant, lod), cloud)| (variant, lod, cloud.instance))
                        .collect();
                    shadow_list.sort_by_key(|(v, l, _)| (*v, *l));
                    push_runs(&shadow_list, &mut self.shadow_draws, &mut data);
                    let spheres: Vec<(DVec3, f64)> =
                        clouds.iter().map(|c| (c.centre_m, c.radius_m)).collect();
                    let (matrix, depth_m) = shadow_clip_from_world(to_sun, &spheres);
                    self.shadow_content = Some(ShadowContent {
                        key,
                        centres_m,
                        drift_m: drift,
                        to_sun,
                        clip_from_world: matrix,
                        depth_m,
                    });
                    self.shadow_drawn.store(false, Ordering::Release);
                    self.shadow_redraw = true;
                    (matrix, depth_m)
                }
            };
            shadow_map.write(
                queue,
                &CloudShadowUniform {
                    clip_from_world: matrix.to_cols_array_2d(),
                    params: [
                        depth_m as f32,
                        settings.shading.density_per_m as f32,
                        CLOUD_ASYMMETRY as f32,
                        SHADOW_MAP_SIZE as f32,
                    ],
                    flags: [1, SHADOW_FILTER_TEXELS, 0, 0],
                },
            );
        } else {
            shadow_map.write(queue, &CloudShadowUniform::default());
        }
        self.enabled = !self.draws.is_empty();
        let bytes = (data.len().max(1) * std::mem::size_of::<CumulusInstance>()) as u64;
        if self.instances.as_ref().is_none_or(|b| b.size() < bytes) {
            self.instances = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cumulus instances"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if let Some(buffer) = &self.instances {
            queue.write_buffer(buffer, 0, bytemuck::cast_slice(&data));
        }
        self.ensure_fringe_targets(device, width, height);
        Ok(())
    }
}
