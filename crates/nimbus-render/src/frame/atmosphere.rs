//! What the whole frame reads of the atmosphere: the lookup tables the
//! atmosphere pass computes (transmittance, multiple scattering, sky view,
//! aerial perspective; Hillaire 2020), the atmosphere's uniform, the lighting
//! inputs the atmosphere's lighting step writes (sun, sky and ground
//! irradiance, the environment's spherical harmonics, exposure) and the
//! sun's irradiance above the atmosphere.
//!
//! [`AtmosphereLookups`] owns these GPU resources; the atmosphere pass writes
//! them, every drawing pass reads them through group 2
//! (`shader/atmosphere_lookup.wgsl`).

use crate::core::binding::{buffer_entry, sampler_entry, sequential_bind_group, texture_entry};
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};
use nimbus_physics::atmosphere::{
    AERIAL_PERSPECTIVE_SIZE, AtmosphereParams, AtmosphereTables, GroundBelow,
    MULTIPLE_SCATTERING_LUT_SIZE, SKY_VIEW_LUT_SIZE, SkyLighting, TRANSMITTANCE_LUT_SIZE,
};
use nimbus_physics::photometry::MAX_LUMINOUS_EFFICACY_LM_PER_W;
use nimbus_physics::sky::SOLAR_ILLUMINANCE_CONSTANT_LUX;

/// The clear sky's lighting at the scene's camera, computed on the CPU: the
/// sun's direction and irradiance after the atmosphere, the sky's
/// irradiance, the ground's radiance and the environment's SH
/// ([`SkyLighting`]), the same quantities the GPU lighting step writes for
/// nimbus's own passes (tested against them in `tests/integration/atmosphere.rs`). For
/// a renderer that embeds nimbus, so that its lights and image-based
/// lighting match nimbus's sky. It builds the atmosphere's tables
/// (`AtmosphereTables::new`: 0.14–0.17 s on one core of a 2-core AMD EPYC
/// with nimbus-physics optimised): call it when the sun or the atmosphere
/// change, off the render thread; with the tables kept, [`SkyLighting::at`]
/// alone takes 3.7 ms.
/// The ground below the horizon is the scene's ([`ground_albedo`]).
/// Clouds are not in it (a layer's shadow and light are nimbus's own).
pub fn sky_lighting(scene: &Scene) -> SkyLighting {
    let tables = AtmosphereTables::new(&scene.atmosphere);
    SkyLighting::at(
        &tables,
        scene.camera.position_m[1],
        scene.sun.direction(),
        solar_irradiance_top().map(f64::from),
        ground_albedo(scene),
    )
}

/// What the clouds' environment is taken over (`Lighting::clouds_sh`):
/// where the clouds are and the ground and sea under them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudsGround {
    /// The clouds' mean centre, world m: the observer of their environment.
    pub observer_m: [f64; 3],
    /// The drawn ground's square, the sea beyond it, and whether the air
    /// between is drawn.
    pub below: GroundBelow,
}

impl CloudsGround {
    /// The ground and sea the scene draws under clouds centred at
    /// `observer_m`: the terrain's square and the open sea beyond it, or,
    /// without a drawn terrain, the flat ground everywhere.
    pub fn of_scene(scene: &Scene, observer_m: [f64; 3]) -> Self {
        Self {
            observer_m,
            below: GroundBelow {
                near_ground_half_extent_m: if scene.ground.terrain {
                    0.5 * scene.terrain.extent_m
                } else {
                    f64::INFINITY
                },
                water_albedo: scene.terrain.albedo.water.map(f64::from),
                water_ggx_alpha: crate::shader::WATER_GGX_ALPHA,
                through_air: scene.camera.aerial_perspective,
            },
        }
    }

    /// Whether the clouds' environment taken for `self` still stands for
    /// `other`: the same ground and sea, and an observer within
    /// [`CLOUDS_OBSERVER_TOLERANCE_M`] of `self`'s.
    pub fn stands_for(&self, other: &Self) -> bool {
        let moved_m2: f64 = (0..3)
            .map(|a| (self.observer_m[a] - other.observer_m[a]).powi(2))
            .sum();
        self.below == other.below && moved_m2 <= CLOUDS_OBSERVER_TOLERANCE_M.powi(2)
    }
}

/// How far the clouds' mean centre may drift before their environment is
/// taken again, m. The clouds drift with the wind every frame, and their
/// lower hemisphere changes over kilometres (the edge of the terrain's
/// square seen from 1.5 km up) and their sky over the air's scale height
/// (~8 km: 100 m of height is ~1 % of the air above): re-taken every 100 m
/// it is within ~1 % of its exact value, and a 10 m/s wind reruns the
/// lighting step every 10 s rather than every frame.
pub const CLOUDS_OBSERVER_TOLERANCE_M: f64 = 100.0;

/// The environment the clouds of `scene` see from `clouds.observer_m`
/// ([`SkyLighting::environment_at`]), computed on the CPU: the same SH the
/// GPU lighting step writes as `Lighting::clouds_sh` (tested against it in
/// `tests/integration/atmosphere.rs`).
pub fn clouds_environment(scene: &Scene, clouds: &CloudsGround) -> [[f64; 3]; 9] {
    let tables = AtmosphereTables::new(&scene.atmosphere);
    let solar = solar_irradiance_top().map(f64::from);
    SkyLighting::at(
        &tables,
        scene.camera.position_m[1],
        scene.sun.direction(),
        solar,
        ground_albedo(scene),
    )
    .environment_at(
        &tables,
        scene.camera.position_m[1],
        clouds.observer_m,
        solar,
        &clouds.below,
    )
}

/// The mean albedo of the ground the scene draws (the terrain's over its
/// square, water included, or the flat ground's): the ground that reflects
/// the sun's and the sky's light onto the clouds, the rain and the air
/// (the environment's lower half, the mist's and the air's light from
/// below). The atmosphere's `ground_albedo` is the planet's far ground,
/// which only the sky's multiple scattering sees (Hillaire 2020); nimbus
/// used it for the near ground too, which lit the clouds from below by a
/// 0.3 ground over terrain of 0.08–0.12 (docs/REALISM.md, "The ground the
/// clouds see"). Generates the terrain at the default resolution: call it
/// when the ground changes.
pub fn ground_albedo(scene: &Scene) -> [f64; 3] {
    if scene.ground.terrain {
        nimbus_physics::terrain::mean_albedo(&scene.terrain)
    } else if let Some(map) = &scene.ground.albedo_map {
        map.map().mean()
    } else {
        scene.ground.albedo
    }
}

/// Solar irradiance at the top of the atmosphere per RGB channel, W·m⁻²:
/// the luminous solar constant (Darula et al. 2005) in nimbus's
/// luminous-equivalent RGB, taken white.
pub fn solar_irradiance_top() -> [f32; 3] {
    [(SOLAR_ILLUMINANCE_CONSTANT_LUX / MAX_LUMINOUS_EFFICACY_LM_PER_W) as f32; 3]
}

/// GPU layout of WGSL `Lighting` (see `shader/lighting_types.wgsl`): the
/// lighting inputs of the cloud, terrain and rain passes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightingUniform {
    /// Environment radiance as order-2 real SH (RGB in xyz), W·sr⁻¹·m⁻².
    pub sh: [[f32; 4]; 9],
    /// C_sky: sky irradiance on an upward surface at the camera, W·m⁻².
    pub sky_irradiance_up: [f32; 4],
    /// C_sun: direct solar irradiance at the camera's altitude, W·m⁻².
    pub sun_irradiance: [f32; 4],
    /// C_ground: radiance of the ground lit by sun and sky, W·sr⁻¹·m⁻².
    pub ground_radiance: [f32; 4],
    /// x: pre-exposure of the drawing passes; y: incident-light EV100 at the camera.
    pub exposure: [f32; 4],
    /// The environment's radiance as the clouds see it (at
    /// [`AtmosphereUniform::clouds_observer_m`], whose lower hemisphere is
    /// the ground and sea under them), order-2 real SH (RGB in xyz),
    /// W·sr⁻¹·m⁻² ([`SkyLighting::environment_at`]).
    pub clouds_sh: [[f32; 4]; 9],
    /// C_sky split by the zenith angle the light arrives from
    /// ([`SkyLighting::sky_irradiance_bands`]), W·m⁻².
    pub sky_irradiance_bands: [[f32; 4]; 4],
}

/// GPU layout of WGSL `Atmosphere`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AtmosphereUniform {
    /// Rayleigh scattering at sea level, m⁻¹.
    pub rayleigh_scattering: [f32; 3],
    /// Planet radius, m.
    pub bottom_radius_m: f32,
    /// Aerosol scattering at sea level, m⁻¹.
    pub mie_scattering: [f32; 3],
    /// Top of the atmosphere, m.
    pub top_radius_m: f32,
    /// Aerosol extinction at sea level, m⁻¹.
    pub mie_extinction: [f32; 3],
    /// Rayleigh scale height, m.
    pub rayleigh_scale_height_m: f32,
    /// Ozone absorption at the peak, m⁻¹.
    pub ozone_absorption: [f32; 3],
    /// Aerosol scale height, m.
    pub mie_scale_height_m: f32,
    /// Ground albedo.
    pub ground_albedo: [f32; 3],
    /// Aerosol asymmetry g.
    pub mie_asymmetry: f32,
    /// Solar irradiance at the top of the atmosphere, W·m⁻².
    pub sun_irradiance_top: [f32; 3],
    /// Ozone peak altitude, m.
    pub ozone_peak_altitude_m: f32,
    /// Ozone half width, m.
    pub ozone_half_width_m: f32,
    /// 1 to draw the air between the camera and what it sees, 0 to leave it
    /// out (`camera.aerial_perspective`).
    pub aerial_perspective_scale: f32,
    /// Padding.
    pub _padding1: f32,
    /// Padding.
    pub _padding2: f32,
    /// Mean albedo of the ground the scene draws ([`ground_albedo`]): the
    /// light it reflects onto the clouds, the rain and the air.
    pub near_ground_albedo: [f32; 3],
    /// Padding.
    pub _padding3: f32,
    /// Where the clouds' environment is taken (`Lighting::clouds_sh`): the
    /// mean centre of the cumulus clouds, world m.
    pub clouds_observer_m: [f32; 3],
    /// Half the side of the drawn ground's square about the origin, m;
    /// beyond it the open sea (a very large value: ground everywhere).
    pub near_ground_half_extent_m: f32,
    /// Diffuse albedo of the sea's water body.
    pub water_albedo: [f32; 3],
    /// GGX roughness α of the sea's surface.
    pub water_ggx_alpha: f32,
}

impl From<&AtmosphereParams> for AtmosphereUniform {
    fn from(p: &AtmosphereParams) -> Self {
        let v = |a: [f64; 3]| a.map(|x| x as f32);
        Self {
            rayleigh_scattering: v(p.rayleigh_scattering_per_m),
            bottom_radius_m: p.bottom_radius_m as f32,
            mie_scattering: v(p.aerosol_scattering_per_m()),
            top_radius_m: p.top_radius_m as f32,
            mie_extinction: v(p.aerosol_extinction_per_m()),
            rayleigh_scale_height_m: p.rayleigh_scale_height_m as f32,
            ozone_absorption: v(p.ozone_absorption_per_m),
            mie_scale_height_m: p.aerosol_scale_height_m as f32,
            ground_albedo: v(p.ground_albedo),
            mie_asymmetry: p.aerosol_asymmetry as f32,
            sun_irradiance_top: solar_irradiance_top(),
            ozone_peak_altitude_m: p.ozone_peak_altitude_m as f32,
            ozone_half_width_m: p.ozone_half_width_m as f32,
            aerial_perspective_scale: 1.0,
            _padding1: 0.0,
            _padding2: 0.0,
            near_ground_albedo: v(p.ground_albedo),
            _padding3: 0.0,
            clouds_observer_m: [0.0; 3],
            near_ground_half_extent_m: f32::MAX,
            water_albedo: [0.0; 3],
            water_ggx_alpha: crate::shader::WATER_GGX_ALPHA as f32,
        }
    }
}

/// The atmosphere's GPU resources that the whole frame reads: the LUTs, the
/// atmosphere uniform and the lighting inputs, with the group-2 lookup
/// layout and bind group of the drawing passes. Created once by the
/// renderer; the atmosphere pass writes every one of them.
#[derive(Debug)]
pub struct AtmosphereLookups {
    /// The atmosphere's parameters (WGSL `Atmosphere`, [`AtmosphereUniform`]).
    pub uniform: wgpu::Buffer,
    /// Transmittance to the top of the atmosphere (`TRANSMITTANCE_LUT_SIZE`, RGBA16F).
    pub transmittance: wgpu::Texture,
    /// Second and higher orders of scattering (`MULTIPLE_SCATTERING_LUT_SIZE`, RGBA16F).
    pub multiple_scattering: wgpu::Texture,
    /// Sky radiance around the camera (`SKY_VIEW_LUT_SIZE`, RGBA16F).
    pub sky_view: wgpu::Texture,
    /// In-scattering and transmittance along the view (`AERIAL_PERSPECTIVE_SIZE`, 3-D, RGBA16F).
    pub aerial_perspective: wgpu::Texture,
    /// The aerial perspective's parts, each like it: the sun's single
    /// scattering and the air's weights for a diffuse field A₀ and A₁
    /// ([`nimbus_physics::atmosphere::under_layer::DiffuseWeights`]) in RGB,
    /// their total W's R, G and B in A; with them the drawing passes light
    /// the air under a cloud layer by the layer's light
    /// (`shader/cloud_layer_lookup.wgsl`).
    pub aerial_perspective_parts: [wgpu::Texture; 3],
    /// The lighting inputs ([`LightingUniform`], storage).
    pub lighting: wgpu::Buffer,
    /// Bilinear, clamped sampler of the LUTs.
    pub sampler: wgpu::Sampler,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
}

fn lut_texture(
    device: &wgpu::Device,
    label: &str,
    size: [u32; 3],
    dimension: wgpu::TextureDimension,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: size[2],
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension,
        format: wgpu::TextureFormat::Rgba16Float,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

impl AtmosphereLookups {
    /// Creates the LUTs (uninitialised until the atmosphere pass runs), the
    /// uniform and lighting buffers, and the lookup group.
    pub fn new(device: &wgpu::Device) -> Self {
        use wgpu::TextureDimension::{D2, D3};
        use wgpu::TextureViewDimension as Dim;
        let uniform_size = std::mem::size_of::<AtmosphereUniform>() as u64;
        let lighting_size = std::mem::size_of::<LightingUniform>() as u64;
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("atmosphere uniform"),
            size: uniform_size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let lighting = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("lighting inputs"),
            size: lighting_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let [tw, th] = TRANSMITTANCE_LUT_SIZE;
        let [mw, mh] = MULTIPLE_SCATTERING_LUT_SIZE;
        let [sw, sh] = SKY_VIEW_LUT_SIZE;
        let [aw, ah, ad] = AERIAL_PERSPECTIVE_SIZE;
        let transmittance = lut_texture(device, "transmittance LUT", [tw, th, 1], D2);
        let multiple_scattering = lut_texture(device, "multiple-scattering LUT", [mw, mh, 1], D2);
        let sky_view = lut_texture(device, "sky-view LUT", [sw, sh, 1], D2);
        let aerial_perspective = lut_texture(device, "aerial-perspective volume", [aw, ah, ad], D3);
        let aerial_perspective_parts = [
            "aerial perspective: the sun's single scattering",
            "aerial perspective: the weight of diffuse light from above",
            "aerial perspective: that weight by the vertical cosine",
        ]
        .map(|label| lut_texture(device, label, [aw, ah, ad], D3));
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("atmosphere LUTs"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let stages = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("atmosphere lookup"),
            entries: &[
                buffer_entry(0, wgpu::BufferBindingType::Uniform, uniform_size, stages),
                sampler_entry(1, stages),
                texture_entry(2, Dim::D2, true, stages),
                texture_entry(3, Dim::D2, true, stages),
                texture_entry(4, Dim::D3, true, stages),
                buffer_entry(
                    5,
                    wgpu::BufferBindingType::Storage { read_only: true },
                    lighting_size,
                    stages,
                ),
                texture_entry(6, Dim::D3, true, stages),
                texture_entry(7, Dim::D3, true, stages),
                texture_entry(8, Dim::D3, true, stages),
            ],
        });
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (transmittance_view, sky_view_view, aerial_view) = (
            view(&transmittance),
            view(&sky_view),
            view(&aerial_perspective),
        );
        let parts_views = aerial_perspective_parts.each_ref().map(view);
        let bind_group = sequential_bind_group(
            device,
            "atmosphere lookup",
            &layout,
            vec![
                uniform.as_entire_binding(),
                wgpu::BindingResource::Sampler(&sampler),
                wgpu::BindingResource::TextureView(&transmittance_view),
                wgpu::BindingResource::TextureView(&sky_view_view),
                wgpu::BindingResource::TextureView(&aerial_view),
                lighting.as_entire_binding(),
                wgpu::BindingResource::TextureView(&parts_views[0]),
                wgpu::BindingResource::TextureView(&parts_views[1]),
                wgpu::BindingResource::TextureView(&parts_views[2]),
            ],
        );
        Self {
            uniform,
            transmittance,
            multiple_scattering,
            sky_view,
            aerial_perspective,
            aerial_perspective_parts,
            lighting,
            sampler,
            layout,
            bind_group,
        }
    }

    /// Layout of the group-2 lookups (`shader/atmosphere_lookup.wgsl`).
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The group-2 lookups.
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// Writes the atmosphere's parameters.
    pub fn write_params(&self, queue: &wgpu::Queue, params: &AtmosphereParams) {
        queue.write_buffer(
            &self.uniform,
            0,
            bytemuck::bytes_of(&AtmosphereUniform::from(params)),
        );
    }
}
