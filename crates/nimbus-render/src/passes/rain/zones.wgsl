// import passes/rain/rain_types.wgsl
// The rain zones (nimbus_physics::rain::zones): where it rains and how
// hard, as a factor of the scene's intensity on a square map around the
// camera built on the CPU (areas, drifting with the clouds; the stratus
// layer's coverage), read bilinearly between texel centres and clamped at
// the edges. Shared by the simulation (which drops are active) and the
// mist (its extinction), at binding 4 of their group 1. The arithmetic is
// the CPU twin's (a + (b − a)·t), so the two agree to f32 rounding.

@group(1) @binding(4) var<storage, read> zone_factors: array<f32>;

fn zone_factor(x: f32, z: f32) -> f32 {
    let n = i32(rain.flags.x);
    let gx = (x - rain.zones.x) / rain.zones.z - 0.5;
    let gz = (z - rain.zones.y) / rain.zones.z - 0.5;
    let fx = floor(gx);
    let fz = floor(gz);
    let tx = gx - fx;
    let tz = gz - fz;
    let i = i32(fx);
    let j = i32(fz);
    let i0 = clamp(i, 0, n - 1);
    let i1 = clamp(i + 1, 0, n - 1);
    let j0 = clamp(j, 0, n - 1);
    let j1 = clamp(j + 1, 0, n - 1);
    let a00 = zone_factors[u32(i0 + n * j0)];
    let a10 = zone_factors[u32(i1 + n * j0)];
    let a01 = zone_factors[u32(i0 + n * j1)];
    let a11 = zone_factors[u32(i1 + n * j1)];
    let a = a00 + (a10 - a00) * tx;
    let b = a01 + (a11 - a01) * tx;
    return a + (b - a) * tz;
}
