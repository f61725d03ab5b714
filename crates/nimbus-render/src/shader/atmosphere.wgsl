// import shader/common.wgsl
// The atmosphere model of Hillaire (EGSR 2020) on the GPU: parameters,
// densities, ray geometry, the LUT parametrisations and the ray-march that
// integrates single and multiple scattering. The GPU twin of
// nimbus_physics::atmosphere, whose tests define the expected values; every
// function here mirrors the one of the same name there. Radii and distances
// in metres, coefficients per metre, luminance per unit solar irradiance.
// Needs no bindings: textures are passed as arguments.

struct Atmosphere {
    rayleigh_scattering: vec3<f32>,
    bottom_radius_m: f32,
    mie_scattering: vec3<f32>,
    top_radius_m: f32,
    mie_extinction: vec3<f32>,
    rayleigh_scale_height_m: f32,
    ozone_absorption: vec3<f32>,
    mie_scale_height_m: f32,
    ground_albedo: vec3<f32>,
    mie_asymmetry: f32,
    // Solar irradiance at the top of the atmosphere, W·m⁻² per channel.
    sun_irradiance_top: vec3<f32>,
    ozone_peak_altitude_m: f32,
    ozone_half_width_m: f32,
    // 1 draws the air between the camera and what it sees, 0 leaves it out.
    aerial_perspective_scale: f32,
    _padding1: f32,
    _padding2: f32,
    // Mean albedo of the ground the scene draws (terrain or flat ground):
    // what reflects light onto the clouds, the rain and the air. ground_albedo
    // is the planet's far ground of the sky's multiple scattering.
    near_ground_albedo: vec3<f32>,
    _padding3: f32,
    // Where the clouds' environment (Lighting.clouds_sh) is taken: the mean
    // centre of the cumulus clouds, world m.
    clouds_observer_m: vec3<f32>,
    // Half the side of the drawn ground's square about the origin, m;
    // beyond it the open sea.
    near_ground_half_extent_m: f32,
    // Diffuse albedo of the sea's water body.
    water_albedo: vec3<f32>,
    // GGX roughness α of the sea's surface.
    water_ggx_alpha: f32,
}

const TRANSMITTANCE_LUT_SIZE: vec2<f32> = vec2<f32>(256.0, 64.0);
const MULTIPLE_SCATTERING_LUT_SIZE: vec2<f32> = vec2<f32>(64.0, 32.0);
const SKY_VIEW_LUT_SIZE: vec2<f32> = vec2<f32>(192.0, 108.0);
const AERIAL_PERSPECTIVE_SIZE: vec3<f32> = vec3<f32>(32.0, 32.0, 32.0);
const AERIAL_PERSPECTIVE_MAX_DISTANCE_M: f32 = 128000.0;
const ATMOSPHERE_PI: f32 = 3.14159265358979;

fn sub_uv_from_unit(x: vec2<f32>, size: vec2<f32>) -> vec2<f32> {
    return 0.5 / size + x * (1.0 - 1.0 / size);
}

fn unit_from_sub_uv(u: vec2<f32>, size: vec2<f32>) -> vec2<f32> {
    return (u - 0.5 / size) / (1.0 - 1.0 / size);
}

fn extinction_at(a: Atmosphere, h: f32) -> vec3<f32> {
    let hh = max(h, 0.0);
    let rayleigh = exp(-hh / a.rayleigh_scale_height_m);
    let mie = exp(-hh / a.mie_scale_height_m);
    let ozone = max(1.0 - abs(hh - a.ozone_peak_altitude_m) / a.ozone_half_width_m, 0.0);
    return a.rayleigh_scattering * rayleigh + a.mie_extinction * mie + a.ozone_absorption * ozone;
}

fn rayleigh_scattering_at(a: Atmosphere, h: f32) -> vec3<f32> {
    return a.rayleigh_scattering * exp(-max(h, 0.0) / a.rayleigh_scale_height_m);
}

fn mie_scattering_at(a: Atmosphere, h: f32) -> vec3<f32> {
    return a.mie_scattering * exp(-max(h, 0.0) / a.mie_scale_height_m);
}

fn distance_to_top(a: Atmosphere, r: f32, mu: f32) -> f32 {
    let discriminant = r * r * (mu * mu - 1.0) + a.top_radius_m * a.top_radius_m;
    return max(-r * mu + sqrt(max(discriminant, 0.0)), 0.0);
}

fn distance_to_bottom(a: Atmosphere, r: f32, mu: f32) -> f32 {
    let discriminant = r * r * (mu * mu - 1.0) + a.bottom_radius_m * a.bottom_radius_m;
    return max(-r * mu - sqrt(max(discriminant, 0.0)), 0.0);
}

fn ray_hits_ground(a: Atmosphere, r: f32, mu: f32) -> bool {
    return mu < 0.0 && r * r * (mu * mu - 1.0) + a.bottom_radius_m * a.bottom_radius_m >= 0.0;
}

fn distance_to_boundary(a: Atmosphere, r: f32, mu: f32) -> f32 {
    if (ray_hits_ground(a, r, mu)) {
        return distance_to_bottom(a, r, mu);
    }
    return distance_to_top(a, r, mu);
}

fn altitude_along(a: Atmosphere, r: f32, mu: f32, t: f32) -> f32 {
    return sqrt(max(t * t + 2.0 * r * mu * t + r * r, 0.0)) - a.bottom_radius_m;
}

fn horizon_length(a: Atmosphere) -> f32 {
    return sqrt(a.top_radius_m * a.top_radius_m - a.bottom_radius_m * a.bottom_radius_m);
}

// Bruneton 2017, GetTransmittanceTextureUvFromRMu (unit coordinates).
fn transmittance_unit_from_r_mu(a: Atmosphere, r: f32, mu: f32) -> vec2<f32> {
    let h = horizon_length(a);
    let rho = sqrt(max(r * r - a.bottom_radius_m * a.bottom_radius_m, 0.0));
    let d = distance_to_top(a, r, mu);
    let d_min = a.top_radius_m - r;
    let d_max = rho + h;
    return vec2<f32>((d - d_min) / (d_max - d_min), rho / h);
}

fn transmittance_r_mu_from_unit(a: Atmosphere, x: vec2<f32>) -> vec2<f32> {
    let h = horizon_length(a);
    let rho = h * x.y;
    let r = sqrt(rho * rho + a.bottom_radius_m * a.bottom_radius_m);
    let d_min = a.top_radius_m - r;
    let d_max = rho + h;
    let d = d_min + x.x * (d_max - d_min);
    var mu = 1.0;
    if (d > 0.0) {
        mu = clamp((h * h - rho * rho - d * d) / (2.0 * r * d), -1.0, 1.0);
    }
    return vec2<f32>(r, mu);
}

fn multiple_scattering_unit_from_r_mu_s(a: Atmosphere, r: f32, mu_s: f32) -> vec2<f32> {
    return clamp(vec2<f32>(0.5 * mu_s + 0.5, (r - a.bottom_radius_m) / (a.top_radius_m - a.bottom_radius_m)),
        vec2<f32>(0.0), vec2<f32>(1.0));
}

fn horizon_zenith_angle(a: Atmosphere, r: f32) -> f32 {
    let cos_beta = sqrt(max(r * r - a.bottom_radius_m * a.bottom_radius_m, 0.0)) / r;
    return ATMOSPHERE_PI - acos(clamp(cos_beta, -1.0, 1.0));
}

// Returns (view zenith angle, cosine of the azimuth from the sun).
fn sky_view_angles_from_unit(a: Atmosphere, r: f32, x: vec2<f32>) -> vec2<f32> {
    let horizon = horizon_zenith_angle(a, r);
    let beta = ATMOSPHERE_PI - horizon;
    var zenith: f32;
    if (x.y < 0.5) {
        let c = 1.0 - 2.0 * x.y;
        zenith = horizon * (1.0 - c * c);
    } else {
        let c = 2.0 * x.y - 1.0;
        zenith = horizon + beta * c * c;
    }
    return vec2<f32>(zenith, 1.0 - 2.0 * x.x * x.x);
}

fn sky_view_unit_from_angles(a: Atmosphere, r: f32, zenith: f32, cos_azimuth: f32) -> vec2<f32> {
    let horizon = horizon_zenith_angle(a, r);
    let beta = ATMOSPHERE_PI - horizon;
    var y: f32;
    if (zenith < horizon) {
        y = 0.5 * (1.0 - sqrt(max(1.0 - zenith / horizon, 0.0)));
    } else {
        y = 0.5 * (1.0 + sqrt(clamp((zenith - horizon) / beta, 0.0, 1.0)));
    }
    return vec2<f32>(sqrt((1.0 - clamp(cos_azimuth, -1.0, 1.0)) * 0.5), y);
}

fn rayleigh_phase(cos_theta: f32) -> f32 {
    return 3.0 * (1.0 + cos_theta * cos_theta) / (16.0 * ATMOSPHERE_PI);
}

// Cornette & Shanks, Applied Optics 31, 1992, eq. 8.
fn cornette_shanks_phase(cos_theta: f32, g: f32) -> f32 {
    let g2 = g * g;
    return 3.0 * (1.0 - g2) * (1.0 + cos_theta * cos_theta)
        / (8.0 * ATMOSPHERE_PI * (2.0 + g2) * pow(1.0 + g2 - 2.0 * g * cos_theta, 1.5));
}

// Transmittance to space from radius r towards μ_s; zero in the planet's shadow.
fn sample_sun_transmittance(lut: texture_2d<f32>, s: sampler, a: Atmosphere, r: f32, mu_s: f32) -> vec3<f32> {
    if (ray_hits_ground(a, r, mu_s)) {
        return vec3<f32>(0.0);
    }
    let uv = sub_uv_from_unit(transmittance_unit_from_r_mu(a, r, mu_s), TRANSMITTANCE_LUT_SIZE);
    return textureSampleLevel(lut, s, uv, 0.0).rgb;
}

fn sample_multiple_scattering(lut: texture_2d<f32>, s: sampler, a: Atmosphere, r: f32, mu_s: f32) -> vec3<f32> {
    let uv = sub_uv_from_unit(multiple_scattering_unit_from_r_mu_s(a, r, mu_s), MULTIPLE_SCATTERING_LUT_SIZE);
    return textureSampleLevel(lut, s, uv, 0.0).rgb;
}

// (radius, μ_s) at distance t from an observer at radius r along `dir`
// (local frame, +Y up at the observer), with the sun along `sun`.
fn radius_and_mu_s_along(r: f32, dir: vec3<f32>, t: f32, sun: vec3<f32>) -> vec2<f32> {
    let position = vec3<f32>(0.0, r, 0.0) + dir * t;
    let radius = length(position);
    return vec2<f32>(radius, dot(position, sun) / radius);
}

struct ScatteringResult {
    luminance: vec3<f32>,
    transmittance: vec3<f32>,
    // The parts of AtmosphereTables::air_path: the sun's single scattering,
    // and ∫ σ T ds of the molecules and of the aerosols.
    sun_single: vec3<f32>,
    rayleigh_weight: vec3<f32>,
    mie_weight: vec3<f32>,
}

// Single scattering (Rayleigh and Cornette–Shanks phases) plus Ψ_ms σ_s
// multiple scattering along `length` metres of the view ray, samples placed
// quadratically; per unit solar irradiance. Mirrors
// AtmosphereTables::air_path.
fn scatter_along(
    transmittance_lut: texture_2d<f32>,
    multiple_scattering_lut: texture_2d<f32>,
    s: sampler,
    a: Atmosphere,
    r: f32,
    view: vec3<f32>,
    sun: vec3<f32>,
    length_m: f32,
    steps: u32,
) -> ScatteringResult {
    let cos_theta = dot(view, sun);
    let phase_r = rayleigh_phase(cos_theta);
    let phase_m = cornette_shanks_phase(cos_theta, a.mie_asymmetry);
    var luminance = vec3<f32>(0.0);
    var throughput = vec3<f32>(1.0);
    var sun_single = vec3<f32>(0.0);
    var rayleigh_weight = vec3<f32>(0.0);
    var mie_weight = vec3<f32>(0.0);
    var t_previous = 0.0;
    for (var i = 0u; i < steps; i = i + 1u) {
        let f = f32(i + 1u) / f32(steps);
        let t_next = length_m * f * f;
        let dt = t_next - t_previous;
        let t = 0.5 * (t_previous + t_next);
        t_previous = t_next;
        let rm = radius_and_mu_s_along(r, view, t, sun);
        let h = rm.x - a.bottom_radius_m;
        let extinction = extinction_at(a, h);
        let rayleigh = rayleigh_scattering_at(a, h);
        let mie = mie_scattering_at(a, h);
        let sun_t = sample_sun_transmittance(transmittance_lut, s, a, rm.x, rm.y);
        let ms = sample_multiple_scattering(multiple_scattering_lut, s, a, rm.x, rm.y);
        let single = sun_t * (rayleigh * phase_r + mie * phase_m);
        let source = single + ms * (rayleigh + mie);
        let step_t = exp(-extinction * dt);
        let integral = select(vec3<f32>(dt), (1.0 - step_t) / extinction, extinction > vec3<f32>(0.0));
        let weight = throughput * integral;
        luminance += weight * source;
        sun_single += weight * single;
        rayleigh_weight += weight * rayleigh;
        mie_weight += weight * mie;
        throughput *= step_t;
    }
    return ScatteringResult(luminance, throughput, sun_single, rayleigh_weight, mie_weight);
}

// Radius of an observer at `height_m` above sea level; kept at least a metre
// above the ground so that integrations never start below it.
fn observer_radius(a: Atmosphere, height_m: f32) -> f32 {
    return a.bottom_radius_m + max(height_m, 1.0);
}

// Sky radiance in world direction `direction` from the sky-view LUT of an
// observer at radius r, the sun in world direction `sun` (+Y is the local up).
fn sky_view_lookup(lut: texture_2d<f32>, s: sampler, a: Atmosphere, r: f32, direction: vec3<f32>, sun: vec3<f32>)
    -> vec3<f32> {
    let zenith = acos(clamp(direction.y, -1.0, 1.0));
    var cos_azimuth = 1.0;
    let horizontal = vec2<f32>(direction.x, direction.z);
    let sun_horizontal = vec2<f32>(sun.x, sun.z);
    if (dot(horizontal, horizontal) > 1e-12 && dot(sun_horizontal, sun_horizontal) > 1e-12) {
        cos_azimuth = dot(normalize(horizontal), normalize(sun_horizontal));
    }
    let uv = sub_uv_from_unit(sky_view_unit_from_angles(a, r, zenith, cos_azimuth), SKY_VIEW_LUT_SIZE);
    return textureSampleLevel(lut, s, uv, 0.0).rgb;
}
