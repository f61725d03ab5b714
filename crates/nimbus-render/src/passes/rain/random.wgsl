// import passes/rain/rain_types.wgsl
// The rain's random numbers, the GPU twin of nimbus_physics::rain::random:
// one uniform number per (drop id, step, salt), the same hash as the CPU.

fn uniform_random(id: u32, step_index: u32, salt: u32) -> f32 {
    let h = pcg_hash(id ^ pcg_hash(step_index ^ pcg_hash(salt)));
    return (f32(h >> 8u) + 0.5) * (1.0 / 16777216.0);
}

const SALT_INSIDE: u32 = 0u;
const SALT_DIAMETER: u32 = 3u;
const SALT_INFLOW: u32 = 4u;
const SALT_REVIVE: u32 = 8u;
const SALT_ENTRY_DIAMETER: u32 = 16u;
const SALT_ENTRY_ACCEPT: u32 = 32u;
const ENTRY_TRIES: u32 = 16u;

