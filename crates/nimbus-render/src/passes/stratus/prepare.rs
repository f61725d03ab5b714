//! Per-frame preparation: the resources rebuilt when the layer, its optics or the terrain change, the uniform written.

use super::optics::{forward_peak_mean_square_rad2, load_optics, optics_params};
use super::{
    FORWARD_PEAK_DEG, IN_LAYER_HANDOVER_M, PEAK_TEXELS, PHASE_TEXELS, RadiosityGrid, ResourceKey,
    Resources, StratusError, StratusPass, StratusUniform, cloud_layer_field,
};
use crate::core::background::Precompute;
use crate::frame::cloud_lighting::{CloudLayerResources, CloudLighting};
use crate::passes::stratus::radiosity::RadiosityPass;
use crate::scene::{Scene, StratusShadingModel};
use nimbus_physics::optics::tables::CloudOpticsTables;
use nimbus_physics::terrain::Terrain;
use nimbus_physics::transport::stratus::OneDimensionalTable;
use wgpu::util::DeviceExt;

/// The phase tables' texels (RGB and an unused lane): P_S, P², P_F.
type PhaseTexels = Vec<[f32; 4]>;

impl StratusPass {
    /// The radiosity pass of the current grid.
    pub fn radiosity(&self) -> Option<&RadiosityPass> {
        self.resources.as_ref().map(|r| &r.radiosity)
    }

    /// The thickness window (R32Float, m), written by the frame's compute.
    pub fn thickness_texture(&self) -> Option<&wgpu::Texture> {
        self.resources.as_ref().map(|r| &r.thickness)
    }

    /// The uniform as last written.
    pub fn uniform(&self) -> &StratusUniform {
        &self.current
    }

    /// Whether the camera is level with the layer (within half the thickest
    /// cell of its mid-plane, plus a margin): its tops and bases are then
    /// edge-on, and the layer is drawn by marching each pixel's ray instead
    /// of as the face towards the camera.
    pub(super) fn camera_is_level(&self) -> bool {
        let Some(settings) = &self.settings else {
            return false;
        };
        let mid = self.current.window[0] as f64;
        let reach = 0.5 * settings.thickness_m + 50.0;
        (self.camera_height_m - mid).abs() <= reach
    }

    /// Whether the march is drawn where the faces would be, before the
    /// rain's mist and streaks and the cumulus fringes (`stratus.model =
    /// "volume"` with the camera below the layer's height range: what lies
    /// under the layer is then in front of it), rather than over
    /// everything (the camera in or above the layer, where the mist under
    /// it is behind it).
    pub fn marches_before_overlays(&self) -> bool {
        let Some(settings) = &self.settings else {
            return false;
        };
        let mid = f64::from(self.current.window[0]);
        settings.model == StratusShadingModel::Volume
            && self.camera_height_m < mid - 0.5 * settings.thickness_m
    }

    /// The in-layer march's weight this frame: 1 with the camera inside a
    /// cell (and everywhere with `stratus.model = "volume"`), falling
    /// (smoothstep) to 0 at [`IN_LAYER_HANDOVER_M`] above its top or below
    /// its base; 0 without a layer.
    pub fn in_layer_weight(&self) -> f32 {
        self.in_layer_weight
    }

    /// Whether the scene has a layer to draw (and what it needs is ready).
    pub fn enabled(&self) -> bool {
        self.settings.is_some()
    }

    /// The work under way on a worker thread, if any.
    pub fn pending(&self) -> Option<&'static str> {
        self.optics_tables.pending()
    }

    /// Blocks until the work under way has finished (the next
    /// [`Self::prepare`] uses it).
    pub fn wait(&mut self) {
        self.optics_tables.wait();
    }

    /// Builds what changed and writes the frame's uniform: the layer's
    /// field at `time_s`, the window around the camera, the 1-D model at
    /// the sun's zenith angle. What it builds is bound in the frame's
    /// `cloud_lighting` (group 3), and its uniform and phase tables written there.
    ///
    /// The droplets' optics tables are computed on a worker thread under
    /// [`Precompute::Background`]; until they (and the terrain, `None`)
    /// are ready the layer is not drawn.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        terrain: Option<&Terrain>,
        time_s: f32,
        cloud_lighting: &mut CloudLighting,
        precompute: Precompute,
    ) -> Result<(), StratusError> {
        self.camera_height_m = scene.camera.position_m[1];
        self.in_layer_weight = 0.0;
        let tables = scene
            .stratus
            .as_ref()
            .map(optics_params)
            .and_then(|params| {
                self.optics_tables
                    .request_current(&params, precompute, || {
                        let job = params.clone();
                        move || load_optics(&job)
                    })
                    .cloned()
            });
        // Drawn only once what it needs is ready (and without a layer: the
        // smallest resources keep the bindings valid, built below).
        let ready = scene.stratus.is_none() || (tables.is_some() && terrain.is_some());
        self.settings = scene.stratus.clone().filter(|_| ready);
        if !ready && self.resources.is_some() {
            self.current = StratusUniform::default();
            cloud_lighting.write_layer_uniform(queue, &self.current);
            return Ok(());
        }
        let settings = self.settings.clone();
        let mid_plane_m = settings
            .as_ref()
            .map(|s| s.base_m + 0.5 * s.thickness_m)
            .unwrap_or(0.0);
        let key = ResourceKey {
            // Without a layer, the smallest resources keep the bindings valid.
            resolution: settings.as_ref().map_or(16, |s| s.resolution),
            mid_plane_m: settings.as_ref().map(|_| mid_plane_m),
            optics: settings.as_ref().map(optics_params),
            terrain: settings
                .as_ref()
                .and(terrain)
                .map(|terrain| terrain.params.clone()),
        };
        if self.resources.as_ref().map(|r| &r.key) != Some(&key) {
            let (resources, phase_tables) =
                self.build(device, queue, key, terrain, tables.as_deref())?;
            if let Some(texels) = phase_tables {
                cloud_lighting.write_phase_tables(queue, &texels);
            }
            let inputs = resources.radiosity.input_buffers();
            cloud_lighting.set_layer(
                device,
                settings.as_ref().map(|_| CloudLayerResources {
                    thickness: &resources.thickness_view,
                    ground_received: inputs.ground_received,
                    cloud_received: inputs.cloud_received,
                }),
            );
            self.resources = Some(resources);
        }
        let Some(resources) = &self.resources else {
            return Ok(());
        };
        let Some(settings) = settings else {
            self.current = StratusUniform::default();
            cloud_lighting.write_layer_uniform(queue, &self.current);
            return Ok(());
        };
        let field = cloud_layer_field(scene, &settings);
        let drift = scene.cloud_drift_m(f64::from(time_s));
        self.in_layer_weight = if settings.model == StratusShadingModel::Volume {
            // The march draws the layer from every camera.
            1.0
        } else {
            // The camera's distance outside the cell over it (the layer
            // spans |y − y_mid| < h(x, z)/2, h the field's fine thickness);
            // in a thin part of a cell, its thinness (at a cell's rim h → 0:
            // the camera passing from a gap into a cell at the mid-plane is
            // then outside by the handover distance, and the weight grows
            // with h, not at once).
            let camera = scene.camera.position_m;
            let h_m = field.thickness_with_drift_m(camera[0], camera[2], drift, f64::from(time_s));
            let outside_m = ((camera[1] - mid_plane_m).abs() - 0.5 * h_m)
                .max(IN_LAYER_HANDOVER_M - h_m)
                .max(0.0);
            let x = (1.0 - outside_m / IN_LAYER_HANDOVER_M).clamp(0.0, 1.0);
            (x * x * (3.0 - 2.0 * x)) as f32
        };
        let (threshold, ramp) = field.threshold_and_ramp();
        // Window: `extent_m` square around the camera, its corner snapped to
        // whole texels so that the grid does not swim as the camera moves.
        let n = settings.resolution;
        let texel = settings.extent_m / n as f64;
        let camera = scene.camera.position_m;
        let corner =
            [camera[0], camera[2]].map(|c| ((c - 0.5 * settings.extent_m) / texel).floor() * texel);
        let sun = scene.sun.direction();
        let sun_zenith_deg = sun[1].clamp(-1.0, 1.0).acos().to_degrees();
        let table = OneDimensionalTable::bouthors_2006();
        let p = table.at(sun_zenith_deg);
        let beta = table.beta;
        let grid = resources.grid.unwrap_or(RadiosityGrid {
            size: 8,
            texel_m: 1.0,
            ground_height_m: 0.0,
        });
        let origin = grid.origin_m();
        let (extinction, forward, spread) = resources.optics.unwrap_or_default();
        let clamp_inf = |x: f64| x.clamp(-1e30, 1e30) as f32;
        self.current = StratusUniform {
            shape: [
                (1.0 / settings.feature_size_m) as f32,
                clamp_inf(threshold),
                ramp as f32,
                settings.thickness_m as f32,
            ],
            motion: [
                drift[0] as f32,
                drift[1] as f32,
                (1.0 / settings.evolution_time_s) as f32,
                time_s,
            ],
            window: [
                mid_plane_m as f32,
                settings.extent_m as f32,
                corner[0] as f32,
                corner[1] as f32,
            ],
            extinction: [
                extinction[0],
                extinction[1],
                extinction[2],
                FORWARD_PEAK_DEG.to_radians() as f32,
            ],
            forward_fraction: [forward[0], forward[1], forward[2], 0.0],
            forward_spread: [spread[0], spread[1], spread[2], 0.0],
            slab: [p.b as f32, p.c as f32, p.kappa_c as f32, p.t as f32],
            slab_r_beta: [p.r as f32, beta as f32, self.in_layer_weight, 0.0],
            radiosity: [
                origin[0] as f32,
                origin[1] as f32,
                grid.texel_m as f32,
                grid.ground_height_m as f32,
            ],
            flags: [1, field.fractal().octaves, settings.seed, n],
            sizes: [PHASE_TEXELS as u32, PEAK_TEXELS as u32, grid.size, 0],
            model: [
                u32::from(settings.model != StratusShadingModel::Bnl2006),
                u32::from(settings.model == StratusShadingModel::Volume),
                0,
                0,
            ],
        };
        cloud_lighting.write_layer_uniform(queue, &self.current);
        Ok(())
    }

    /// Builds the resources for `key`, and the phase tables of its
    /// droplets (P_S, P², P_F texels) when it has a layer.
    fn build(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        key: ResourceKey,
        terrain: Option<&Terrain>,
        tables: Option<&CloudOpticsTables>,
    ) -> Result<(Resources, Option<PhaseTexels>), StratusError> {
        let n = key.resolution;
        let thickness = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("stratus thickness"),
            size: wgpu::Extent3d {
                width: n,
                height: n,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let thickness_view = thickness.create_view(&Default::default());
        // The grid sums the terrain's heights: built here, when its inputs
        // change, not every frame.
        let grid = key
            .mid_plane_m
            .zip(terrain)
            .map(|(mid_plane_m, terrain)| RadiosityGrid::new(terrain, mid_plane_m));
        let radiosity_size = grid.map_or(8, |g| g.size);
        let radiosity = RadiosityPass::new(device, radiosity_size)?;
        if let (Some(grid), Some(terrain)) = (&grid, terrain) {
            let rho: Vec<[f32; 4]> = grid
                .ground_reflectance(terrain)
                .iter()
                .map(|r| [r[0], r[1], r[2], 0.0])
                .collect();
            queue.write_buffer(
                radiosity.input_buffers().ground_reflectance,
                0,
                bytemuck::cast_slice(&rho),
            );
        }
        let (phase, optics) = match tables.filter(|_| key.optics.is_some()) {
            Some(tables) => {
                let mut texels: Vec<[f32; 4]> = Vec::new();
                for table in [
                    &tables.peak_removed,
                    &tables.double_scattering,
                    &tables.forward_peak,
                ] {
                    texels.extend(table.chunks(3).map(|c| [c[0], c[1], c[2], 0.0]));
                }
                let spread = forward_peak_mean_square_rad2(&tables.forward_peak, FORWARD_PEAK_DEG);
                debug_assert_eq!(texels.len(), 2 * PHASE_TEXELS + PEAK_TEXELS);
                (
                    Some(texels),
                    Some((tables.extinction_per_m, tables.forward_fraction, spread)),
                )
            }
            None => (None, None),
        };
        let inputs = radiosity.input_buffers();
        let view = || wgpu::BindingResource::TextureView(&thickness_view);
        let compute_group = crate::core::binding::sequential_bind_group(
            device,
            "stratus compute",
            &self.compute_layout,
            vec![
                self.uniform.as_entire_binding(),
                view(),
                inputs.cloud_reflectance.as_entire_binding(),
                inputs.ground_extra.as_entire_binding(),
                inputs.ground_received.as_entire_binding(),
                inputs.cloud_received.as_entire_binding(),
                inputs.cloud_emitted.as_entire_binding(),
            ],
        );
        let indices = crate::core::mesh::grid_indices(n);
        let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("stratus grid indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        let resources = Resources {
            key,
            grid,
            radiosity,
            compute_group,
            thickness,
            thickness_view,
            indices: index_buffer,
            index_count: indices.len() as u32,
            optics,
        };
        Ok((resources, phase))
    }
}
