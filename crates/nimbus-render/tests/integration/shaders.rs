//! Every WGSL module of the renderer is parsed and validated by naga (no GPU
//! needed), and every uniform struct's Rust layout is checked against naga's
//! layout of the WGSL struct, member by member.

use nimbus_render::atmosphere::{AtmosphereUniform, LightingUniform};
use nimbus_render::frame::FrameUniform;
use nimbus_render::renderer::all_modules;
use nimbus_render::sky::SkyPassUniform;
use nimbus_render::tonemap::TonemapUniform;
use std::mem::{offset_of, size_of};

fn parse(name: &str, source: &str) -> naga::Module {
    naga::front::wgsl::parse_str(source)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)))
}

#[test]
fn every_shader_module_parses_and_validates() {
    for (name, source) in all_modules() {
        let module = parse(name, &source);
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&source)));
    }
}

/// Size and member offsets of a WGSL struct, as naga lays it out.
fn wgsl_layout(module: &naga::Module, struct_name: &str) -> (u32, Vec<(String, u32)>) {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).expect("layout");
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(struct_name)
            && let naga::TypeInner::Struct { members, span } = &ty.inner
        {
            return (
                *span,
                members
                    .iter()
                    .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                    .collect(),
            );
        }
    }
    panic!("struct {struct_name} not found");
}

fn module_named(name: &str) -> naga::Module {
    let (_, source) = all_modules()
        .into_iter()
        .find(|(n, _)| *n == name)
        .expect("module");
    parse(name, &source)
}

macro_rules! assert_layout {
    ($module:expr, $wgsl:literal, $rust:ty, [$($field:ident),* $(,)?]) => {{
        let (size, members) = wgsl_layout(&$module, $wgsl);
        assert_eq!(size as usize, size_of::<$rust>(), "size of {} vs {}", $wgsl, stringify!($rust));
        let rust: Vec<(&str, usize)> = vec![$((stringify!($field), offset_of!($rust, $field))),*];
        assert_eq!(members.len(), rust.len(), "member count of {}", $wgsl);
        for ((wgsl_name, wgsl_offset), (rust_name, rust_offset)) in members.iter().zip(rust) {
            assert_eq!(wgsl_name, rust_name, "member order of {}", $wgsl);
            assert_eq!(*wgsl_offset as usize, rust_offset, "offset of {}.{}", $wgsl, wgsl_name);
        }
    }};
}

#[test]
fn frame_uniform_matches_wgsl_layout() {
    let module = module_named("sky");
    assert_layout!(
        module,
        "Frame",
        FrameUniform,
        [
            clip_from_world,
            world_from_clip,
            camera_position_m,
            time_s,
            sun_direction,
            exposure_scale,
            viewport_size_px,
            pixel_angle_rad,
            sun_cos_angular_radius,
            max_pre_exposed,
            auto_exposure,
            exposure_compensation_ev,
            adaptation_time_s,
            view_forward,
            orthographic_pixel_m,
        ]
    );
}

#[test]
fn composite_uniform_matches_wgsl_layout() {
    let module = module_named("composite");
    assert_layout!(
        module,
        "CompositeParams",
        nimbus_render::passes::composite::CompositeUniform,
        [nimbus_clip_from_caller_clip, caller]
    );
}

#[test]
fn depth_occluder_uniform_matches_wgsl_layout() {
    let module = module_named("rain depth occluder");
    assert_layout!(
        module,
        "DepthOccluder",
        nimbus_render::rain::DepthOccluderUniform,
        [world_from_clip, grid, depths]
    );
}

#[test]
fn atmosphere_and_lighting_match_wgsl_layout() {
    let module = module_named("terrain");
    assert_layout!(
        module,
        "Atmosphere",
        AtmosphereUniform,
        [
            rayleigh_scattering,
            bottom_radius_m,
            mie_scattering,
            top_radius_m,
            mie_extinction,
            rayleigh_scale_height_m,
            ozone_absorption,
            mie_scale_height_m,
            ground_albedo,
            mie_asymmetry,
            sun_irradiance_top,
            ozone_peak_altitude_m,
            ozone_half_width_m,
            aerial_perspective_scale,
            _padding1,
            _padding2,
            near_ground_albedo,
            _padding3,
            clouds_observer_m,
            near_ground_half_extent_m,
            water_albedo,
            water_ggx_alpha,
        ]
    );
    assert_layout!(
        module,
        "Lighting",
        LightingUniform,
        [
            sh,
            sky_irradiance_up,
            sun_irradiance,
            ground_radiance,
            exposure,
            clouds_sh,
            sky_irradiance_bands
        ]
    );
}

#[test]
fn exposure_state_matches_wgsl_layout() {
    assert_layout!(
        module_named("exposure"),
        "ExposureState",
        nimbus_render::exposure::ExposureState,
        [
            ev100,
            tonemap_scale,
            average_luminance_cd_m2,
            time_s,
            valid,
            _padding0,
            _padding1,
            _padding2
        ]
    );
}

#[test]
fn pass_uniforms_match_wgsl_layout() {
    assert_layout!(
        module_named("sky"),
        "SkyPassParams",
        SkyPassUniform,
        [
            water_level_m,
            limb_darkening_u,
            terrain_half_extent_m,
            _padding,
            water_albedo,
        ]
    );
    assert_layout!(
        module_named("tonemap"),
        "TonemapParams",
        TonemapUniform,
        [encode_srgb, dither_lsb, code_values, _padding,]
    );
    assert_layout!(
        module_named("stratus layer"),
        "Stratus",
        nimbus_render::stratus::StratusUniform,
        [
            shape,
            motion,
            window,
            extinction,
            forward_fraction,
            forward_spread,
            slab,
            slab_r_beta,
            radiosity,
            flags,
            sizes,
            model,
        ]
    );
    assert_layout!(
        module_named("cumulus"),
        "Cumulus",
        nimbus_render::cumulus::CumulusUniform,
        [
            weights,
            corona,
            detail,
            noise,
            flags,
            sun_at_base,
            sun_per_m,
            extension,
            peak_grid,
            transport,
        ]
    );
    assert_layout!(
        module_named("cumulus in-cloud"),
        "InCloud",
        nimbus_render::cumulus::InCloudUniform,
        [
            offset_scale,
            rotation,
            extinction_min,
            extinction_size,
            light_min,
            light_size,
            light_dims,
        ]
    );
    assert_layout!(
        module_named("cumulus"),
        "CloudShadow",
        nimbus_render::cumulus::CloudShadowUniform,
        [clip_from_world, params, flags,]
    );
    assert_layout!(
        module_named("cumulus"),
        "TerrainShadow",
        nimbus_render::frame::cloud_lighting::TerrainShadowUniform,
        [square,]
    );
}

#[test]
fn rain_records_match_wgsl_layout() {
    use nimbus_render::rain::{
        DropGpu, RainSegmentUniform, RainStepUniform, RainUniform, SPLASH_BYTES,
        WindPrimitiveUniform,
    };
    let module = module_named("rain simulation");
    assert_layout!(
        module,
        "WindPrimitive",
        WindPrimitiveUniform,
        [center, axis, drift, gust]
    );
    assert_layout!(
        module,
        "Rain",
        RainUniform,
        [
            box_right,
            box_up,
            box_forward,
            box_size,
            box_angular_velocity,
            wind_mean,
            drops,
            zones,
            counts,
            flags,
            occlusion_from_world,
            camera_velocity,
            mist,
            mist_ground,
            wind_grid,
            wind_grid_origin,
            drop_sh_weights,
            drop_kernel,
            primitives,
        ]
    );
    assert_layout!(module, "RainSegment", RainSegmentUniform, [range]);
    assert_layout!(
        module,
        "Drop",
        DropGpu,
        [position_m, diameter_mm, velocity_m_s, state]
    );
    assert_eq!(wgsl_layout(&module, "Splash").0 as u64, SPLASH_BYTES);
    // The step uniform is padded to the dynamic-offset stride: its members
    // lead, at the WGSL offsets.
    let (size, members) = wgsl_layout(&module, "RainStep");
    assert!(size as usize <= size_of::<RainStepUniform>());
    let rust = [
        ("box_center", offset_of!(RainStepUniform, box_center)),
        ("box_velocity", offset_of!(RainStepUniform, box_velocity)),
        ("index", offset_of!(RainStepUniform, index)),
    ];
    assert_eq!(members.len(), rust.len());
    for ((wgsl_name, wgsl_offset), (rust_name, rust_offset)) in members.iter().zip(rust) {
        assert_eq!(
            (wgsl_name.as_str(), *wgsl_offset as usize),
            (rust_name, rust_offset)
        );
    }
}

#[test]
fn wgsl_lut_sizes_match_the_physics_constants() {
    use nimbus_physics::atmosphere::*;
    let source = nimbus_render::atmosphere::ATMOSPHERE.source;
    let v2 = |name: &str, [w, h]: [u32; 2]| {
        format!("const {name}: vec2<f32> = vec2<f32>({w}.0, {h}.0);")
    };
    let [x, y, z] = AERIAL_PERSPECTIVE_SIZE;
    for expected in [
        v2("TRANSMITTANCE_LUT_SIZE", TRANSMITTANCE_LUT_SIZE),
        v2("MULTIPLE_SCATTERING_LUT_SIZE", MULTIPLE_SCATTERING_LUT_SIZE),
        v2("SKY_VIEW_LUT_SIZE", SKY_VIEW_LUT_SIZE),
        format!("const AERIAL_PERSPECTIVE_SIZE: vec3<f32> = vec3<f32>({x}.0, {y}.0, {z}.0);"),
        format!(
            "const AERIAL_PERSPECTIVE_MAX_DISTANCE_M: f32 = {}.0;",
            AERIAL_PERSPECTIVE_MAX_DISTANCE_M
        ),
    ] {
        assert!(
            source.contains(&expected),
            "shaders/atmosphere.wgsl lacks `{expected}`"
        );
    }
    let all: String = all_modules().into_iter().map(|(_, s)| s).collect();
    for expected in [
        format!("const SKY_VIEW_STEPS: u32 = {SKY_VIEW_STEPS}u;"),
        format!("const AERIAL_PERSPECTIVE_STEPS: u32 = {AERIAL_PERSPECTIVE_STEPS}u;"),
        format!("const TRANSMITTANCE_STEPS: u32 = {TRANSMITTANCE_STEPS}u;"),
        format!("const DIRECTIONS: u32 = {MULTIPLE_SCATTERING_DIRECTIONS}u;"),
        format!("const STEPS: u32 = {MULTIPLE_SCATTERING_STEPS}u;"),
    ] {
        assert!(all.contains(&expected), "the WGSL lacks `{expected}`");
    }
}
