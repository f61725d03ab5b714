// The lighting inputs shared by the passes that shade clouds, terrain and
// rain (written by atmosphere/lighting.wgsl; see its header for each field).
// Radiance in W·sr⁻¹·m⁻², irradiance in W·m⁻², per RGB channel in xyz.

struct Lighting {
    sh: array<vec4<f32>, 9>,
    sky_irradiance_up: vec4<f32>,
    sun_irradiance: vec4<f32>,
    ground_radiance: vec4<f32>,
    // x: pre-exposure of this frame's drawing passes (radiance to HDR target
    // values); y: the incident-light meter's EV100 at the camera.
    exposure: vec4<f32>,
    // The environment as the clouds see it: like `sh`, taken at the clouds'
    // mean centre (Atmosphere.clouds_observer_m), whose lower hemisphere is
    // the ground and the sea under them seen from their altitude.
    clouds_sh: array<vec4<f32>, 9>,
    // sky_irradiance_up split by the zenith angle the light arrives from,
    // in the bands of nimbus_physics::transport::sky_source::BAND_EDGES
    // (cosines 0, 0.1, 0.3, 0.6, 1): what the cloud layer's traced sky
    // light is weighted by.
    sky_irradiance_bands: array<vec4<f32>, 4>,
}

// `l` with the environment the clouds see (`clouds_sh`) as its `sh`: what
// the cumulus passes light their clouds with.
fn clouds_lighting(l: Lighting) -> Lighting {
    var c = l;
    c.sh = l.clouds_sh;
    return c;
}

// The nine real spherical harmonics of order ≤ 2 towards d, in the order
// of sh_evaluate's coefficients (twin of nimbus_physics::sh::basis).
fn sh_basis(d: vec3<f32>) -> array<f32, 9> {
    return array<f32, 9>(
        0.282095,
        0.488603 * d.y,
        0.488603 * d.z,
        0.488603 * d.x,
        1.092548 * d.x * d.y,
        1.092548 * d.y * d.z,
        0.315392 * (3.0 * d.z * d.z - 1.0),
        1.092548 * d.x * d.z,
        0.546274 * (d.x * d.x - d.y * d.y),
    );
}

// Nine SH coefficients' function (rgb) towards n, band l scaled by
// `band[l]`, not clamped. Twin of nimbus_physics::sh::radiance (bands 1).
fn sh_evaluate(sh: array<vec4<f32>, 9>, n: vec3<f32>, band: vec3<f32>) -> vec3<f32> {
    var e = band.x * 0.282095 * sh[0].xyz;
    e += band.y * 0.488603 * (sh[1].xyz * n.y + sh[2].xyz * n.z + sh[3].xyz * n.x);
    e += band.z * (1.092548 * (sh[4].xyz * n.x * n.y + sh[5].xyz * n.y * n.z + sh[7].xyz * n.x * n.z)
        + 0.315392 * sh[6].xyz * (3.0 * n.z * n.z - 1.0)
        + 0.546274 * sh[8].xyz * (n.x * n.x - n.y * n.y));
    return e;
}

// The SH environment's radiance convolved with a kernel symmetric about n,
// band l scaled by `band[l]` (Funk–Hecke), clamped at zero.
fn sh_convolved(l: Lighting, n: vec3<f32>, band: vec3<f32>) -> vec3<f32> {
    return max(sh_evaluate(l.sh, n, band), vec3<f32>(0.0));
}

// Irradiance on a surface of unit normal n from the SH environment
// (Ramamoorthi & Hanrahan 2001, eq. 8: Â₀ = π, Â₁ = 2π/3, Â₂ = π/4).
fn sh_irradiance(l: Lighting, n: vec3<f32>) -> vec3<f32> {
    return sh_convolved(l, n, vec3<f32>(3.14159265, 2.0943951, 0.78539816));
}
