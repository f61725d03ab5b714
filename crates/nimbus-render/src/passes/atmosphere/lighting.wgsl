// import passes/atmosphere/bindings.wgsl
// import shader/lighting_types.wgsl
// Lighting inputs of the cloud, terrain and rain passes, from the sky-view
// and transmittance LUTs, in one storage buffer (`Lighting`):
// - sh: radiance of the whole environment seen from the camera as order-2
//   real spherical harmonics (Ramamoorthi & Hanrahan 2001): the sky above the
//   horizon, below it the ground (C_ground) through the air and the air's
//   own light;
// - sky_irradiance_up: C_sky, the sky's irradiance on an upward surface;
// - sky_irradiance_bands: C_sky by the band of the zenith angle the light
//   arrives from (sky_band);
// - sun_irradiance: C_sun, the direct solar irradiance at the camera's
//   altitude after atmospheric transmittance (normal incidence);
// - ground_radiance: C_ground, the radiance of a Lambertian ground of the
//   near ground albedo (the scene's terrain) lit by that sun and sky;
// - clouds_sh: the environment as the clouds see it, from
//   atmosphere.clouds_observer_m: above its horizon the camera's sky, below
//   it the ground (C_ground) within the drawn ground's square and beyond it
//   the open sea (the sky's specular reflection, the water body's light and
//   the sun's glint), through the air between them when the aerial
//   perspective is drawn. Twin of SkyLighting::environment_at.
// One workgroup of 64 invocations integrates 1024 Fibonacci directions.
// Mirrors nimbus_physics::sh and the CPU reference in the render tests.

@group(1) @binding(8) var<storage, read_write> lighting_out: Lighting;

const LIGHTING_DIRECTIONS: u32 = 1024u;
const LIGHTING_THREADS: u32 = 64u;

var<workgroup> partial_irradiance: array<vec3<f32>, 64>;
var<workgroup> partial_bands: array<array<vec3<f32>, 4>, 64>;
var<workgroup> partial_sh: array<array<vec3<f32>, 9>, 64>;

// Upper edges of the sky's first three bands in the cosine of the
// incident light's zenith angle (nimbus_physics::transport::sky_source::
// BAND_EDGES: 0, 0.1, 0.3, 0.6, 1).
const SKY_BAND_EDGES = array<f32, 3>(0.1, 0.3, 0.6);

// The band of the sky light arriving from a direction of vertical
// component mu > 0 (twin of sky_source::band_of).
fn sky_band(mu: f32) -> u32 {
    var band = 0u;
    for (var n = 0u; n < 3u; n = n + 1u) {
        if (mu >= SKY_BAND_EDGES[n]) {
            band = n + 1u;
        }
    }
    return band;
}

fn lighting_direction(index: u32) -> vec3<f32> {
    let golden_angle = ATMOSPHERE_PI * (3.0 - sqrt(5.0));
    let y = 1.0 - (2.0 * f32(index) + 1.0) / f32(LIGHTING_DIRECTIONS);
    let radius = sqrt(max(1.0 - y * y, 0.0));
    let phi = golden_angle * f32(index);
    return vec3<f32>(radius * cos(phi), y, radius * sin(phi));
}

// The air's transmittance from radius r along a ray of cosine μ that hits
// the ground, to the ground: T(ground → top)/T(r → top) along the reversed
// ray (both upwards, in the transmittance LUT). Twin of
// nimbus_physics::atmosphere::lighting's ground_transmittance.
fn ground_transmittance(r: f32, mu: f32) -> vec3<f32> {
    let length_m = distance_to_bottom(atmosphere, r, mu);
    let r_ground = atmosphere.bottom_radius_m;
    let mu_ground = clamp((r * mu + length_m) / r_ground, -1.0, 1.0);
    let from_ground = sample_sun_transmittance(transmittance_lut, lut_sampler, atmosphere, r_ground, -mu_ground);
    let from_observer = sample_sun_transmittance(transmittance_lut, lut_sampler, atmosphere, r, -mu);
    return min(from_ground / max(from_observer, vec3<f32>(1e-6)), vec3<f32>(1.0));
}

// March steps of the air between the clouds' observer and the ground
// (nimbus_physics::atmosphere::CLOUDS_AIR_STEPS).
const CLOUDS_AIR_STEPS: u32 = 16u;

// The sea's specular reflectance near the mirror direction at the cosine of
// incidence: Schlick's Fresnel of water (F0 = 0.02, shader/water.wgsl's
// water_fresnel) times the height-correlated Smith masking of the GGX
// surface, 1/(1 + 2Λ). Twin of nimbus_physics::atmosphere::
// sea_specular_reflectance.
fn clouds_sea_reflectance(cos_theta: f32) -> f32 {
    let mu = clamp(cos_theta, 1e-4, 1.0);
    let m = 1.0 - mu;
    let fresnel = 0.02 + 0.98 * m * m * m * m * m;
    let alpha = atmosphere.water_ggx_alpha;
    let tan2 = (1.0 - mu * mu) / (mu * mu);
    let lambda = 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
    return fresnel / (1.0 + 2.0 * lambda);
}

// What the clouds' observer sees along d where it meets the ground: the
// radiance leaving the ground or the sea there (rgb) and whether it is the
// sea (w); d must hit the ground from radius r_observer.
fn clouds_surface(d: vec3<f32>, r_observer: f32, length_m: f32, ground_radiance: vec3<f32>,
    water_irradiance: vec3<f32>) -> vec4<f32> {
    let hit = atmosphere.clouds_observer_m.xz + d.xz * length_m;
    if (all(abs(hit) <= vec2<f32>(atmosphere.near_ground_half_extent_m))) {
        return vec4<f32>(ground_radiance, 0.0);
    }
    // The reversed ray's cosine to the local vertical on the spherical surface.
    let cos_surface = clamp((-r_observer * d.y - length_m) / atmosphere.bottom_radius_m, 0.0, 1.0);
    let fresnel = clouds_sea_reflectance(cos_surface);
    let sky = sky_view_radiance(vec3<f32>(d.x, -d.y, d.z));
    return vec4<f32>(fresnel * sky + (1.0 - fresnel) * atmosphere.water_albedo / ATMOSPHERE_PI * water_irradiance, 1.0);
}

// The SH coefficients the workgroup's threads left in partial_sh, summed.
fn summed_partial_sh() -> array<vec3<f32>, 9> {
    var total: array<vec3<f32>, 9>;
    for (var c = 0u; c < 9u; c = c + 1u) {
        total[c] = vec3<f32>(0.0);
    }
    for (var t = 0u; t < LIGHTING_THREADS; t = t + 1u) {
        for (var c = 0u; c < 9u; c = c + 1u) {
            total[c] += partial_sh[t][c];
        }
    }
    return total;
}

fn sky_view_radiance(direction: vec3<f32>) -> vec3<f32> {
    let r = observer_radius(atmosphere, frame.camera_position_m.y);
    return sky_view_lookup(sky_view_lut, lut_sampler, atmosphere, r, direction, frame.sun_direction);
}

@compute @workgroup_size(64)
fn lighting_main(@builtin(local_invocation_index) thread: u32) {
    let weight = 4.0 * ATMOSPHERE_PI / f32(LIGHTING_DIRECTIONS);
    let per_thread = LIGHTING_DIRECTIONS / LIGHTING_THREADS;

    // Pass 1: the sky's irradiance on an upward surface.
    var e_up = vec3<f32>(0.0);
    var e_bands = array<vec3<f32>, 4>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = 0u; k < per_thread; k = k + 1u) {
        let d = lighting_direction(thread * per_thread + k);
        if (d.y > 0.0) {
            let e = sky_view_radiance(d) * d.y * weight;
            e_up += e;
            e_bands[sky_band(d.y)] += e;
        }
    }
    partial_irradiance[thread] = e_up;
    partial_bands[thread] = e_bands;
    workgroupBarrier();
    var sky_irradiance_up = vec3<f32>(0.0);
    for (var t = 0u; t < LIGHTING_THREADS; t = t + 1u) {
        sky_irradiance_up += partial_irradiance[t];
    }

    // The sun at the camera, and the ground it and the sky light.
    let r = observer_radius(atmosphere, frame.camera_position_m.y);
    let mu_s = frame.sun_direction.y;
    let sun_irradiance = atmosphere.sun_irradiance_top
        * sample_sun_transmittance(transmittance_lut, lut_sampler, atmosphere, r, mu_s);
    let ground_radiance = atmosphere.near_ground_albedo / ATMOSPHERE_PI
        * (sun_irradiance * max(mu_s, 0.0) + sky_irradiance_up);

    // Pass 2: project the environment on the SH basis: the sky above, and
    // below the horizon the ground seen through the air with the air's own
    // light (the sky-view LUT integrates the air to the ground).
    var sh: array<vec3<f32>, 9>;
    for (var c = 0u; c < 9u; c = c + 1u) {
        sh[c] = vec3<f32>(0.0);
    }
    for (var k = 0u; k < per_thread; k = k + 1u) {
        let d = lighting_direction(thread * per_thread + k);
        var radiance = sky_view_radiance(d);
        if (ray_hits_ground(atmosphere, r, d.y)) {
            radiance += ground_transmittance(r, d.y) * ground_radiance;
        }
        let y = sh_basis(d);
        for (var c = 0u; c < 9u; c = c + 1u) {
            sh[c] += radiance * y[c] * weight;
        }
    }
    partial_sh[thread] = sh;
    workgroupBarrier();
    var total: array<vec3<f32>, 9>;
    if (thread == 0u) {
        total = summed_partial_sh();
    }
    workgroupBarrier();

    // Pass 3: the environment as the clouds see it (twin of
    // SkyLighting::environment_at).
    let r_clouds = observer_radius(atmosphere, atmosphere.clouds_observer_m.y);
    let water_irradiance = sun_irradiance * max(mu_s, 0.0) + sky_irradiance_up;
    let through_air = atmosphere.aerial_perspective_scale > 0.0;
    for (var c = 0u; c < 9u; c = c + 1u) {
        sh[c] = vec3<f32>(0.0);
    }
    for (var k = 0u; k < per_thread; k = k + 1u) {
        let d = lighting_direction(thread * per_thread + k);
        var radiance = sky_view_radiance(d);
        if (ray_hits_ground(atmosphere, r_clouds, d.y)) {
            let length_m = distance_to_bottom(atmosphere, r_clouds, d.y);
            radiance = clouds_surface(d, r_clouds, length_m, ground_radiance, water_irradiance).xyz;
            if (through_air) {
                let air = scatter_along(transmittance_lut, multiple_scattering_lut, lut_sampler, atmosphere,
                    r_clouds, d, frame.sun_direction, length_m, CLOUDS_AIR_STEPS);
                radiance = air.luminance * atmosphere.sun_irradiance_top + air.transmittance * radiance;
            }
        }
        let y = sh_basis(d);
        for (var c = 0u; c < 9u; c = c + 1u) {
            sh[c] += radiance * y[c] * weight;
        }
    }
    partial_sh[thread] = sh;
    workgroupBarrier();
    if (thread == 0u) {
        for (var c = 0u; c < 9u; c = c + 1u) {
            lighting_out.sh[c] = vec4<f32>(total[c], 0.0);
        }
        var clouds_total = summed_partial_sh();
        // The sun's glint where its mirror direction meets the sea.
        let glint = vec3<f32>(frame.sun_direction.x, -frame.sun_direction.y, frame.sun_direction.z);
        if (mu_s > 0.0 && ray_hits_ground(atmosphere, r_clouds, glint.y)) {
            let length_m = distance_to_bottom(atmosphere, r_clouds, glint.y);
            let surface = clouds_surface(glint, r_clouds, length_m, ground_radiance, water_irradiance);
            if (surface.w > 0.5) {
                var transmittance = vec3<f32>(1.0);
                if (through_air) {
                    transmittance = ground_transmittance(r_clouds, glint.y);
                }
                let e = clouds_sea_reflectance(mu_s) * sun_irradiance * transmittance;
                let y = sh_basis(glint);
                for (var c = 0u; c < 9u; c = c + 1u) {
                    clouds_total[c] += e * y[c];
                }
            }
        }
        for (var c = 0u; c < 9u; c = c + 1u) {
            lighting_out.clouds_sh[c] = vec4<f32>(clouds_total[c], 0.0);
        }
        lighting_out.sky_irradiance_up = vec4<f32>(sky_irradiance_up, 0.0);
        for (var b = 0u; b < 4u; b = b + 1u) {
            var e = vec3<f32>(0.0);
            for (var t = 0u; t < LIGHTING_THREADS; t = t + 1u) {
                e += partial_bands[t][b];
            }
            lighting_out.sky_irradiance_bands[b] = vec4<f32>(e, 0.0);
        }
        lighting_out.sun_irradiance = vec4<f32>(sun_irradiance, 0.0);
        lighting_out.ground_radiance = vec4<f32>(ground_radiance, 0.0);
        // Incident-light meter (ISO 2720, calibration C = 250 lx·s for a flat
        // receptor, ISO 100) on a horizontal surface at the camera:
        // EV100 = log2(E S / C). Its exposure is the pre-exposure with
        // automatic exposure; the exposure pass refines it from the image.
        let illuminance_lux = 683.0 * dot(sun_irradiance * max(mu_s, 0.0) + sky_irradiance_up,
            vec3<f32>(0.2126, 0.7152, 0.0722));
        let incident_ev100 = log2(max(illuminance_lux, 1e-4) * 100.0 / 250.0);
        var pre_exposure = frame.exposure_scale;
        if (frame.auto_exposure != 0u) {
            pre_exposure = 683.0 / (1.2 * exp2(incident_ev100 - frame.exposure_compensation_ev));
        }
        lighting_out.exposure = vec4<f32>(pre_exposure, incident_ev100, 0.0, 0.0);
    }
}
