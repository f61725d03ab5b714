// import passes/rain/rain_types.wgsl
// The wind the drops fall through, the GPU twin of
// nimbus_physics::rain::wind: the mean wind, the primitives (uniform,
// source, vortex, gust front) and the gridded field (a .npy file, fixed to
// the ground or carried by the mean wind), sampled trilinearly.

@group(1) @binding(3) var<storage, read> wind_grid: array<vec4<f32>>;

fn gust_profile(behind_m: f32, width_m: f32) -> f32 {
    if (behind_m <= 0.0) {
        return 0.0;
    }
    let s = behind_m / max(width_m, 1e-3);
    return s * exp(1.0 - s);
}

fn primitive_wind(p: WindPrimitive, x: vec3<f32>, t: f32) -> vec3<f32> {
    let kind = u32(p.center.w);
    let c = p.center.xyz + p.drift.xyz * t;
    let d = x - c;
    let speed = p.axis.w;
    let radius = p.drift.w;
    let r_core = max(radius, 1e-3);
    if (kind == 0u) {
        var fade = 1.0;
        if (radius > 0.0) {
            let q = min(dot(d, d) / (radius * radius), 1.0);
            fade = (1.0 - q) * (1.0 - q);
        }
        return p.axis.xyz * (speed * fade);
    }
    if (kind == 1u) {
        let r = length(d);
        if (r < 1e-6) {
            return vec3<f32>(0.0);
        }
        var s = speed * (r_core / r) * (r_core / r);
        if (r < r_core) {
            s = speed * r / r_core;
        }
        return d * (s / r);
    }
    if (kind == 2u) {
        let radial = d - p.axis.xyz * dot(d, p.axis.xyz);
        let rho = length(radial);
        if (rho < 1e-6) {
            return vec3<f32>(0.0);
        }
        var s = speed * r_core / rho;
        if (rho < r_core) {
            s = speed * rho / r_core;
        }
        return cross(p.axis.xyz, radial) * (s / rho);
    }
    let period = max(p.gust.x, 1e-3);
    let run_m = p.gust.y * period;
    let phase = t / period;
    let front_m = (phase - floor(phase)) * run_m - 0.5 * run_m;
    let behind = front_m - dot(d, p.axis.xyz);
    let g = gust_profile(behind, radius) + gust_profile(behind + run_m, radius);
    return p.axis.xyz * (speed * g);
}

fn wind_grid_at(i: i32, j: i32, k: i32) -> vec3<f32> {
    let n = vec3<i32>(rain.wind_grid.xyz);
    let wrap = ((vec3<i32>(i, j, k) % n) + n) % n;
    return wind_grid[u32(wrap.x + n.x * (wrap.y + n.y * wrap.z))].xyz;
}

// Trilinear sample relative to the grid's point (0, 0, 0), wrapping around.
fn wind_grid_sample(p: vec3<f32>) -> vec3<f32> {
    let g = p / rain.wind_mean.w;
    let base = floor(g);
    let f = g - base;
    let i = i32(base.x);
    let j = i32(base.y);
    let k = i32(base.z);
    let x00 = mix(wind_grid_at(i, j, k), wind_grid_at(i + 1, j, k), f.x);
    let x10 = mix(wind_grid_at(i, j + 1, k), wind_grid_at(i + 1, j + 1, k), f.x);
    let x01 = mix(wind_grid_at(i, j, k + 1), wind_grid_at(i + 1, j, k + 1), f.x);
    let x11 = mix(wind_grid_at(i, j + 1, k + 1), wind_grid_at(i + 1, j + 1, k + 1), f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
}

fn wind_at(p: vec3<f32>, t: f32) -> vec3<f32> {
    var w = rain.wind_mean.xyz;
    if (rain.counts.w > 0u) {
        var q = p - rain.wind_grid_origin.xyz;
        if (rain.wind_grid.w == 1u) {
            q -= rain.wind_mean.xyz * t;
        }
        w += wind_grid_sample(q);
    }
    for (var i = 0u; i < min(rain.counts.z, 16u); i++) {
        w += primitive_wind(rain.primitives[i], p, t);
    }
    return w;
}

