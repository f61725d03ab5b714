// Preetham's analytic sky (Preetham, Shirley & Smits, SIGGRAPH 1999, eq. 3
// and appendix A.2): the GPU twin of nimbus_physics::sky::PreethamSky, whose
// tests are the reference. Returns radiance in W·sr⁻¹·m⁻² per channel.

fn perez(abcd: vec4<f32>, e: f32, cos_theta: f32, gamma: f32) -> f32 {
    let ct = max(cos_theta, 1e-4);
    let cg = cos(gamma);
    return (1.0 + abcd.x * exp(abcd.y / ct)) * (1.0 + abcd.z * exp(abcd.w * gamma) + e * cg * cg);
}

fn sky_radiance(direction: vec3<f32>) -> vec3<f32> {
    let s = frame.sky;
    let cos_theta = direction.y;
    let gamma = acos(clamp(dot(direction, frame.sun_direction), -1.0, 1.0));
    let luminance = s.zenith_over_perez.x * perez(s.perez_luminance, s.perez_e_and_fade.x, cos_theta, gamma)
        * s.perez_e_and_fade.w;
    let x = s.zenith_over_perez.y * perez(s.perez_x, s.perez_e_and_fade.y, cos_theta, gamma);
    let y = s.zenith_over_perez.z * perez(s.perez_y, s.perez_e_and_fade.z, cos_theta, gamma);
    if (y <= 0.0) {
        return vec3<f32>(0.0);
    }
    let xyz = vec3<f32>(x * luminance / y, luminance, (1.0 - x - y) * luminance / y);
    // XYZ to linear Rec.709 (IEC 61966-2-1); columns of the matrix.
    let rec709_from_xyz = mat3x3<f32>(
        vec3<f32>(3.2404542, -0.9692660, 0.0556434),
        vec3<f32>(-1.5371385, 1.8760108, -0.2040259),
        vec3<f32>(-0.4985314, 0.0415560, 1.0572252),
    );
    // Luminance-equivalent radiance: divide by K_m = 683 lm/W.
    return max(rec709_from_xyz * xyz, vec3<f32>(0.0)) / 683.0;
}
