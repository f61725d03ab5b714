// import shader/common.wgsl
// import shader/lighting_types.wgsl
// Exposure pass: meters the frame and decides the exposure the tone mapper
// applies. With automatic exposure, the log-average luminance of a 64×64 grid
// of samples of the HDR target gives the reflected-light meter's exposure
// (ISO 2720, calibration K = 12.5 cd·s/m² at ISO 100: EV100 = log2(L S / K)),
// plus compensation, approached exponentially over `adaptation_time_s` in
// animations (Pattanaik et al., "Time-dependent visual adaptation", 2000,
// use a similar first-order model). With manual exposure it passes the
// scene's EV100 through. Needs common.wgsl and lighting_types.wgsl.

struct ExposureState {
    // EV100 applied to this frame's output.
    ev100: f32,
    // Multiplies the HDR target's values in the tone mapper: final exposure
    // over the pre-exposure the drawing passes used.
    tonemap_scale: f32,
    // Log-average luminance of the frame, cd/m².
    average_luminance_cd_m2: f32,
    // Time of the frame that set ev100, s.
    time_s: f32,
    // 1 once a frame has been metered.
    valid: u32,
    _padding0: u32,
    _padding1: u32,
    _padding2: u32,
}

@group(1) @binding(0) var hdr: texture_2d<f32>;
@group(1) @binding(1) var<storage, read> lighting: Lighting;
@group(1) @binding(2) var<storage, read_write> state: ExposureState;

const METER_GRID: u32 = 64u;
const METER_THREADS: u32 = 256u;
const REFLECTED_METER_K: f32 = 12.5;

var<workgroup> partial_log_luminance: array<f32, 256>;

fn exposure_scale_from_ev100(ev100: f32) -> f32 {
    return 683.0 / (1.2 * exp2(ev100));
}

@compute @workgroup_size(256)
fn exposure_main(@builtin(local_invocation_index) thread: u32) {
    let size = vec2<f32>(textureDimensions(hdr));
    let pre_exposure = lighting.exposure.x;
    let samples = METER_GRID * METER_GRID;
    var sum = 0.0;
    for (var k = thread; k < samples; k = k + METER_THREADS) {
        let grid = vec2<f32>(f32(k % METER_GRID), f32(k / METER_GRID));
        let pixel = vec2<u32>((grid + 0.5) / f32(METER_GRID) * size);
        let value = textureLoad(hdr, pixel, 0).rgb;
        let luminance = 683.0 * dot(value, vec3<f32>(0.2126, 0.7152, 0.0722)) / pre_exposure;
        sum += log2(max(luminance, 1e-4));
    }
    partial_log_luminance[thread] = sum;
    workgroupBarrier();
    if (thread != 0u) {
        return;
    }
    var total = 0.0;
    for (var t = 0u; t < METER_THREADS; t = t + 1u) {
        total += partial_log_luminance[t];
    }
    let average = exp2(total / f32(samples));
    let target_ev = log2(average * 100.0 / REFLECTED_METER_K) - frame.exposure_compensation_ev;
    var ev = log2(683.0 / (1.2 * frame.exposure_scale));
    if (frame.auto_exposure != 0u) {
        let dt = frame.time_s - state.time_s;
        ev = target_ev;
        if (state.valid == 1u && frame.adaptation_time_s > 0.0 && dt > 0.0) {
            ev = state.ev100 + (target_ev - state.ev100) * (1.0 - exp(-dt / frame.adaptation_time_s));
        }
    }
    state.ev100 = ev;
    state.tonemap_scale = exposure_scale_from_ev100(ev) / pre_exposure;
    state.average_luminance_cd_m2 = average;
    state.time_s = frame.time_s;
    state.valid = 1u;
}
