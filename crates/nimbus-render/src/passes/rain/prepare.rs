//! Per-frame preparation: the state built for the settings, the drop buffers grown to the target count, the steps planned.

use super::compaction::GROUP_WORDS;
use super::gpu_types::{RainSegmentUniform, RainStepUniform, drops_per_buffer};
use super::settings::{
    mean_rain_direction, occlusion_from_world, rain_box, rain_params, rain_uniform, rain_zones,
    step_uniform,
};
use super::{
    DROP_BYTES, DropBuffers, DropSegment, FramePlan, OCCLUSION_REACH_ABOVE_M, OcclusionView,
    RainError, RainKey, RainPass, RainState, SPLASH_BYTES, SPLASH_CAPACITY, STEP_STRIDE,
    SharedBuffers, WORKGROUP_SIZE, ZONE_MAP_SIZE, ZonesKey,
};
use crate::core::background::Precompute;
use crate::core::binding::PerViewGroups;
use crate::core::{binding, limits};
use crate::frame::Camera;
use crate::scene::{RainSettings, Scene};
use glam::Vec3;
use nimbus_physics::rain::simulation::{MAX_STEPS_PER_FRAME, STEP_S, target_drop_count};
use nimbus_physics::rain::wind::WindField;
use nimbus_physics::rain::zones::RainZones;
use nimbus_physics::terrain::Terrain;

impl RainPass {
    pub(super) fn create_state(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        key: RainKey,
        capacity: u32,
        wind: WindField,
        (zones_key, zone_map): (ZonesKey, RainZones),
    ) -> RainState {
        use wgpu::util::DeviceExt;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let splashes = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain splashes"),
            size: SPLASH_CAPACITY as u64 * SPLASH_BYTES,
            usage: storage | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        queue.write_buffer(
            &splashes,
            0,
            &vec![0u8; (SPLASH_CAPACITY as u64 * SPLASH_BYTES) as usize],
        );
        let splash_head = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rain splash head"),
            contents: bytemuck::bytes_of(&0u32),
            usage: storage | wgpu::BufferUsages::COPY_SRC,
        });
        let grid_data: Vec<[f32; 4]> = wind
            .grid
            .as_ref()
            .map(|t| t.velocities_m_s.clone())
            .unwrap_or_else(|| vec![[0.0; 4]]);
        let wind_grid = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rain wind grid"),
            contents: bytemuck::cast_slice(&grid_data),
            usage: storage,
        });
        // Room for the largest map, so that a new map needs no new bindings.
        let zones = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain zones"),
            size: ZONE_MAP_SIZE as u64 * ZONE_MAP_SIZE as u64 * 4,
            usage: storage,
            mapped_at_creation: false,
        });
        queue.write_buffer(&zones, 0, bytemuck::cast_slice(&zone_map.factors));
        let shared = SharedBuffers {
            splashes,
            splash_head,
            wind_grid,
            zones,
            occlusion_view: self.occlusion_texture.create_view(&Default::default()),
            mist_group: PerViewGroups::default(),
        };
        RainState {
            key,
            zones_key,
            drops: self.create_drop_buffers(device, &shared, capacity),
            shared,
            zone_map,
            wind,
            occlusion_drawn: None,
            dispatched: 0,
            time_s: f32::NEG_INFINITY,
            step: 0,
            camera_m: Vec3::ZERO,
            forward: Vec3::NEG_Z,
            warned_cap: false,
        }
    }

    /// Buffers for `capacity` drops, split by [`drops_per_buffer`], bound
    /// with the rain's other buffers.
    pub(super) fn create_drop_buffers(
        &self,
        device: &wgpu::Device,
        shared: &SharedBuffers,
        capacity: u32,
    ) -> DropBuffers {
        use wgpu::util::DeviceExt;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let per_buffer = drops_per_buffer(&device.limits(), self.drops_per_buffer_cap);
        let buffers = capacity.max(1).div_ceil(per_buffer);
        let draw_args_stride = (device.limits().min_storage_buffer_offset_alignment as u64).max(16);
        let draw_args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rain draw arguments"),
            size: draw_args_stride * buffers as u64,
            usage: storage | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let segments = (0..buffers)
            .map(|index| {
                let first_drop = index * per_buffer;
                let held = per_buffer.min(capacity.max(1) - first_drop);
                let drops = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("rain drops"),
                    size: held as u64 * DROP_BYTES,
                    usage: storage | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let visible = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("rain visible drops"),
                    size: held as u64 * 4,
                    usage: storage | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                // The stable compactions' bit masks and offsets, per
                // workgroup of drops.
                let groups = held.div_ceil(WORKGROUP_SIZE) as u64;
                let group_masks = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("rain group masks"),
                    size: groups * GROUP_WORDS as u64 * 4,
                    usage: storage,
                    mapped_at_creation: false,
                });
                let group_offsets = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("rain group offsets"),
                    size: groups * 4,
                    usage: storage,
                    mapped_at_creation: false,
                });
                let segment = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("rain drops' range"),
                    contents: bytemuck::bytes_of(&RainSegmentUniform {
                        range: [first_drop, held, 0, 0],
                    }),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                let simulation_group = binding::sequential_bind_group(
                    device,
                    "rain simulation",
                    &self.simulation_layout,
                    vec![
                        self.uniform.as_entire_binding(),
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &self.steps,
                            offset: 0,
                            size: wgpu::BufferSize::new(
                                std::mem::size_of::<RainStepUniform>() as u64
                            ),
                        }),
                        drops.as_entire_binding(),
                        shared.wind_grid.as_entire_binding(),
                        shared.zones.as_entire_binding(),
                        wgpu::BindingResource::TextureView(&shared.occlusion_view),
                        shared.splashes.as_entire_binding(),
                        shared.splash_head.as_entire_binding(),
                        segment.as_entire_binding(),
                        group_masks.as_entire_binding(),
                    ],
                );
                let visibility_group = binding::sequential_bind_group(
                    device,
                    "rain visibility",
                    &self.visibility_layout,
                    vec![
                        self.uniform.as_entire_binding(),
                        drops.as_entire_binding(),
                        visible.as_entire_binding(),
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &draw_args,
                            offset: index as u64 * draw_args_stride,
                            size: wgpu::BufferSize::new(16),
                        }),
                        segment.as_entire_binding(),
                        group_masks.as_entire_binding(),
                        group_offsets.as_entire_binding(),
                    ],
                );
                DropSegment {
                    first_drop,
                    capacity: held,
                    drops,
                    visible,
                    group_masks,
                    simulation_group,
                    visibility_group,
                }
            })
            .collect();
        DropBuffers {
            capacity,
            segments,
            draw_args,
            draw_args_stride,
            draw_groups: PerViewGroups::default(),
        }
    }

    /// Replaces the drops' buffers by ones for `capacity` drops, copying
    /// the drops over: the rain goes on where it was, the new drops dead
    /// until they enter at the box's upstream side.
    pub(super) fn grow_drop_buffers(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        capacity: u32,
    ) {
        let Some(state) = &self.state else { return };
        let grown = self.create_drop_buffers(device, &state.shared, capacity);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("rain buffers grown"),
        });
        // Buffers hold the same drops per buffer whatever the capacity:
        // buffer i of the old drops goes to the start of buffer i.
        for (from, to) in state.drops.segments.iter().zip(&grown.segments) {
            encoder.copy_buffer_to_buffer(&from.drops, 0, &to.drops, 0, from.drops.size());
        }
        queue.submit([encoder.finish()]);
        if let Some(state) = &mut self.state {
            state.drops = grown;
        }
    }

    /// Updates the simulation's inputs for a frame at `time_s`: the steps
    /// to run since the last frame, the box, wind and zones, and whether
    /// the rain shadow map must be redrawn.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        camera: &Camera,
        time_s: f32,
        cumulus_footprints_m: &[[f32; 3]],
        occluder_generations: [u64; 3],
        occluder_strides: &[u64],
        ground: Option<&Terrain>,
        precompute: Precompute,
    ) -> Result<(), RainError> {
        for &stride in occluder_strides {
            if !self.occluders.iter().any(|(s, _)| *s == stride) {
                let pipeline = self.occluder_pipeline(device, stride);
                self.occluders.push((stride, pipeline));
            }
        }
        let Some(settings) = scene.rain.clone() else {
            self.settings = None;
            self.state = None;
            return Ok(());
        };
        let key = RainKey::new(scene, &settings);
        let params = rain_params(scene, &settings);
        let mut rain_box = rain_box(&settings, camera);
        let volume = rain_box.volume_m3();
        let max_drops = settings.max_drops.min(u32::MAX as u64) as u32;
        let target = target_drop_count(&params, params.intensity_mm_h, volume);
        // Buffers for the drops this intensity asks for with a margin, up to
        // the cap; a larger count later grows them, keeping the drops.
        let capacity = ((target as u64 * 5 / 4).max(4096) as u32).min(max_drops);
        let zones_key = ZonesKey::new(scene, &settings, time_s as f64, cumulus_footprints_m);
        let zone_map = || rain_zones(scene, &settings, time_s as f64, cumulus_footprints_m);
        if self.state.as_ref().map(|s| &s.key) != Some(&key) {
            self.state = None;
            let wind = scene.wind_field().map_err(RainError::WindField)?;
            if let Some(grid) = &wind.grid {
                let bytes = std::mem::size_of_val(grid.velocities_m_s.as_slice()) as u64;
                limits::check_buffer_size(device, "wind.field.file", bytes)?;
            }
            let zones = (zones_key.clone(), zone_map());
            self.state = Some(self.create_state(device, queue, key, capacity, wind, zones));
        } else if self
            .state
            .as_ref()
            .is_some_and(|s| target > s.drops.capacity && s.drops.capacity < max_drops)
        {
            self.grow_drop_buffers(device, queue, capacity);
        }
        self.settings = Some(settings.clone());
        let Some(state) = self.state.as_mut() else {
            return Ok(());
        };
        // The wind's mean and primitives follow the scene (keyframed wind);
        // its grid is the key's.
        let wind = scene
            .wind
            .as_ref()
            .map(crate::scene::WindSettings::field_without_grid)
            .unwrap_or_default();
        state.wind.mean_m_s = wind.mean_m_s;
        state.wind.primitives = wind.primitives;
        if state.zones_key != zones_key {
            // The map follows drifting clouds every frame and costs
            // milliseconds: made on a worker thread (the newest finished one
            // is used, a frame or so late) unless precomputation blocks.
            let ready = self.zones_job.request(zones_key, precompute, || {
                let (scene, settings) = (scene.clone(), settings.clone());
                let footprints = cumulus_footprints_m.to_vec();
                let t = time_s as f64;
                move || rain_zones(&scene, &settings, t, &footprints)
            });
            if let Some((key, map)) = ready
                && *key != state.zones_key
            {
                state.zone_map = map.clone();
                let factors = bytemuck::cast_slice(&state.zone_map.factors);
                queue.write_buffer(&state.shared.zones, 0, factors);
                state.zones_key = key.clone();
            }
        }
        let wanted = nimbus_physics::rain::simulation::expected_drop_count(
            params.intensity_mm_h,
            params.min_diameter_mm,
            volume,
        );
        if wanted > max_drops as f64 && !state.warned_cap {
            eprintln!(
                "nimbus: warning: {} mm/h in a {:.0} m³ rain box asks for {wanted:.0} drops; capped at rain.max_drops = {max_drops}",
                settings.intensity_mm_h, volume
            );
            state.warned_cap = true;
        }
        // Start anew on the first frame, when time runs backwards, or when
        // the camera jumps farther than the box.
        let jumped = (rain_box.center_m - state.camera_m).length() > rain_box.bounding_radius_m();
        let restart = !state.time_s.is_finite() || time_s < state.time_s - STEP_S || jumped;
        let mut steps: Vec<RainStepUniform> = Vec::new();
        // Time since the last frame (none after a restart: the box does not move).
        let frame_dt = if restart { 0.0 } else { time_s - state.time_s };
        if restart {
            state.dispatched = target;
            // Place the drops a few steps early, so that splashes are under
            // way in the first frame.
            let warm_up = MAX_STEPS_PER_FRAME - 1;
            state.time_s = time_s - warm_up as f32 * STEP_S;
            state.camera_m = rain_box.center_m;
            state.forward = rain_box.basis[2];
            state.step += 1;
            steps.push(step_uniform(&rain_box, state.time_s, state.step, true));
            queue.write_buffer(&state.shared.splash_head, 0, bytemuck::bytes_of(&0u32));
            queue.write_buffer(
                &state.shared.splashes,
                0,
                &vec![0u8; (SPLASH_CAPACITY as u64 * SPLASH_BYTES) as usize],
            );
        } else {
            state.dispatched = state.dispatched.max(target);
            // The box moves and turns with the camera between frames.
            if frame_dt > 0.0 {
                rain_box.velocity_m_s = (rain_box.center_m - state.camera_m) / frame_dt;
                let turn = state.forward.cross(rain_box.basis[2]);
                let angle = state.forward.dot(rain_box.basis[2]).clamp(-1.0, 1.0).acos();
                rain_box.angular_velocity_rad_s = turn.normalize_or_zero() * (angle / frame_dt);
            }
        }
        let available = ((time_s - state.time_s) / STEP_S).floor().max(0.0) as u32;
        let count = available.min(MAX_STEPS_PER_FRAME - steps.len() as u32);
        if available > count {
            // A long gap (a slow frame, a jump in an animation): skip time.
            state.time_s = time_s - count as f32 * STEP_S;
        }
        let start_m = state.camera_m;
        let start_time = state.time_s;
        for k in 1..=count {
            let t = start_time + k as f32 * STEP_S;
            let fraction = if frame_dt > 0.0 {
                ((t - (time_s - frame_dt)) / frame_dt).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let mut b = rain_box;
            b.center_m = start_m.lerp(rain_box.center_m, fraction);
            state.step += 1;
            steps.push(step_uniform(&b, t, state.step, false));
        }
        state.time_s = start_time + count as f32 * STEP_S;
        state.camera_m = rain_box.center_m;
        state.forward = rain_box.basis[2];
        for (i, s) in steps.iter().enumerate() {
            queue.write_buffer(&self.steps, i as u64 * STEP_STRIDE, bytemuck::bytes_of(s));
        }
        // The rain shadow map: redrawn when the rain's direction, the box's
        // neighbourhood (snapped to a quarter of its radius) or the scene changes.
        let direction = mean_rain_direction(&params, state.wind.mean_m_s);
        let snap = (rain_box.bounding_radius_m() * 0.25).max(1.0);
        let snapped = (rain_box.center_m / snap).round();
        let view = OcclusionView {
            centre_m: [snapped.x as i32, snapped.y as i32, snapped.z as i32],
            direction: direction.to_array(),
            occluder_generations,
        };
        let redraw_occlusion = state.occlusion_drawn != Some(view);
        let occlusion_radius = rain_box.bounding_radius_m() * 1.25 + snap;
        let occlusion = occlusion_from_world(
            snapped * snap,
            direction,
            occlusion_radius,
            OCCLUSION_REACH_ABOVE_M,
        );
        if redraw_occlusion {
            queue.write_buffer(
                &self.occlusion_uniform,
                0,
                bytemuck::bytes_of(&occlusion.to_cols_array_2d()),
            );
            state.occlusion_drawn = Some(view);
        }
        let mist_ground = mist_column_ground(scene, &settings, camera, ground);
        let uniform = rain_uniform(
            &settings,
            &params,
            &rain_box,
            state,
            camera,
            occlusion,
            &self.drop,
            mist_ground,
        );
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        // The indirect draws' arguments: 6 vertices, instances counted by the cull.
        for index in 0..state.drops.segments.len() as u64 {
            queue.write_buffer(
                &state.drops.draw_args,
                index * state.drops.draw_args_stride,
                bytemuck::cast_slice(&[6u32, 0, 0, 0]),
            );
        }
        self.plan = FramePlan {
            steps,
            redraw_occlusion,
        };
        Ok(())
    }
}

/// The ground the mist's column stands on (passes/rain/mist.wgsl takes the
/// mist's light as a plane-parallel slab's at the camera): the rendered
/// surface's height under the camera, m, and the mean albedo within the
/// mist's transport length 1/((1 − g)β) of it (held between 200 m and
/// 3 km, as the shader's disc of the sun through the layer), over which
/// the mist mixes the ground's light. Until the terrain is generated (in
/// the background), the procedural ground's height and the atmosphere's
/// ground albedo.
fn mist_column_ground(
    scene: &Scene,
    settings: &RainSettings,
    camera: &Camera,
    ground: Option<&Terrain>,
) -> [f32; 4] {
    let eye = camera.position_m;
    let extinction_per_m = nimbus_physics::rain::dsd::extinction_per_m(
        settings.intensity_mm_h,
        0.0,
        settings.max_diameter_mm,
    );
    let asymmetry = nimbus_physics::rain::mist_slab::MIST_SLAB_ASYMMETRY;
    let radius_m = (1.0 / ((1.0 - asymmetry) * extinction_per_m).max(1e-6)).clamp(200.0, 3000.0);
    let (height_m, albedo) = match ground {
        Some(terrain) => (
            terrain.surface_height_at(eye.x, eye.z),
            terrain.mean_albedo_within(eye.x, eye.z, radius_m),
        ),
        None if scene.ground.terrain => (
            nimbus_physics::terrain::ground_height_m(&scene.terrain, eye.x, eye.z)
                .max(scene.terrain.water_level_m),
            scene.atmosphere.ground_albedo,
        ),
        None => (scene.ground.height_m, scene.atmosphere.ground_albedo),
    };
    [
        height_m as f32,
        albedo[0] as f32,
        albedo[1] as f32,
        albedo[2] as f32,
    ]
}
