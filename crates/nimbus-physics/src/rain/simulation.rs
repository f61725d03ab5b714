//! The drop dynamics, step by step: the CPU reference of the GPU rain
//! simulation (`nimbus-render/src/rain/simulation.wgsl` runs the same
//! function for every drop, in f32, with the same random numbers).
//!
//! Each drop has a position, a velocity, a diameter, a state (dead, alive,
//! leaving) and an id, its index (Blanchard 2023, §4.2.1–4.2.2). In one fixed
//! step of `dt`:
//! - an alive drop moves under gravity and quadratic drag on its velocity
//!   relative to the air (see [`crate::rain::drag`]), integrated
//!   semi-implicitly: the drag factor k = (g/v_t²)·|u| is taken from the
//!   step's start and the drag term from its end,
//!   v' = (v + dt·(g + k·W)) / (1 + dt·k), x' = x + dt·v'.
//!   This is stable for any step (small drops relax in 0.1 s), keeps the
//!   steady state exact (u = −v_t·ŷ in still air, v = W horizontally), and
//!   needs no previous position as the seed's Verlet scheme does, which
//!   cannot handle velocity-dependent forces without one;
//! - a drop whose segment from x to x' goes under cover (the ground, a
//!   roof) splashes at the crossing and becomes a *ghost*: it goes on
//!   moving, unseen, until it leaves the box. Each id is thus a slot
//!   following one trajectory through the box, and a trajectory under
//!   cover carries no drop: the rain's density stays the Marshall–Palmer
//!   one in the open and is zero under cover. (Recycling hit drops at once
//!   instead would crowd the open part of the box with every drop of the
//!   count);
//! - a drop that leaves the box is *leaving*: it is still drawn in this
//!   frame (its streak is partly inside), and re-enters in the next step;
//! - a leaving drop re-enters on the upstream boundary
//!   ([`crate::rain::rain_box`]) with a new diameter, at its terminal
//!   velocity relative to the wind (Blanchard's initial condition a₀ = 0,
//!   with drag on the relative velocity): it lives on if its id is below the
//!   drop count the local intensity asks for, else it dies; entering under
//!   cover it is a ghost. Intensity
//!   changes thus never make drops pop in or out: they are decided only at
//!   the boundary (§4.2.2);
//! - a dead drop re-enters the same way, with the probability per step of
//!   a drop of the surrounding rain crossing into the box,
//!   dt·(inflow rate)/volume, so a rising intensity fills the box from its
//!   upstream side at the rain's own pace.
//!
//! The count for an intensity I is the Marshall–Palmer number of drops at
//! least d_min across in the box, V·(N₀/Λ)·e^(−Λ·d_min) (Blanchard 2023,
//! §4.2.2), capped at the buffer's capacity; diameters are drawn from the
//! same distribution. A rain-zone map scales the intensity over the ground,
//! and there is no rain above the clouds' base (`ceiling_m`).

use crate::rain::drag::{GRAVITY_M_S2, terminal_speed_m_s_f32};
use crate::rain::dsd::{number_density_per_m3, sample_diameter_mm};
use crate::rain::rain_box::RainBox;
use crate::rain::random::uniform;
use crate::rain::wind::WindField;
use crate::rain::zones::RainZones;
use glam::Vec3;
use rayon::prelude::*;

/// Length of one simulation step, s (fixed, independent of the frame rate).
pub const STEP_S: f32 = 1.0 / 120.0;
/// Most steps simulated for one frame; a longer gap skips simulated time.
pub const MAX_STEPS_PER_FRAME: u32 = 8;
/// Fewest drops a parallel task steps. A drop's step is a fraction of a
/// microsecond, so a smaller task costs more in rayon's scheduling (waking
/// and joining the workers at every step, 120 steps a second) than it saves:
/// 1,500 drops split over two workers ran 6× slower than on one thread.
/// Boxes of fewer drops step on the calling thread.
const DROPS_PER_TASK: usize = 16_384;

/// Purposes of the random numbers of a step (the `salt` of [`uniform`]).
pub mod salt {
    /// Three numbers placing a drop inside the box (0, 1, 2).
    pub const INSIDE: u32 = 0;
    /// The diameter.
    pub const DIAMETER: u32 = 3;
    /// Four numbers placing a drop on the inflow boundary (4–7).
    pub const INFLOW: u32 = 4;
    /// Whether a dead drop re-enters in this step.
    pub const REVIVE: u32 = 8;
    /// Candidate diameters of an entering drop (16–31).
    pub const ENTRY_DIAMETER: u32 = 16;
    /// Their acceptance tests (32–47).
    pub const ENTRY_ACCEPT: u32 = 32;
    /// Candidates tried.
    pub const ENTRY_TRIES: u32 = 16;
}

/// A drop's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DropState {
    /// Not in the rain (its id is above the count, or it is waiting to enter).
    Dead = 0,
    /// Falling in the box.
    Alive = 1,
    /// Left the box in this step: drawn, then recycled.
    Leaving = 2,
    /// Following its trajectory under cover (after a hit): not drawn,
    /// recycled when it leaves the box.
    Ghost = 3,
}

impl DropState {
    /// From the GPU's u32.
    pub fn from_u32(value: u32) -> Self {
        match value {
            1 => Self::Alive,
            2 => Self::Leaving,
            3 => Self::Ghost,
            _ => Self::Dead,
        }
    }
}

/// One drop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drop {
    /// Position, world m.
    pub position_m: Vec3,
    /// Diameter, mm.
    pub diameter_mm: f32,
    /// Velocity, world m/s.
    pub velocity_m_s: Vec3,
    /// State.
    pub state: DropState,
}

/// What the rain is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RainParams {
    /// Intensity where the zone factor is 1, mm/h.
    pub intensity_mm_h: f32,
    /// Smallest simulated diameter, mm.
    pub min_diameter_mm: f32,
    /// Largest diameter, mm (the distribution is clamped there).
    pub max_diameter_mm: f32,
    /// Capacity: most drops simulated.
    pub max_drops: u32,
    /// No rain above this height (the cloud base), m.
    pub ceiling_m: f32,
}

impl Default for RainParams {
    fn default() -> Self {
        Self {
            intensity_mm_h: 5.0,
            min_diameter_mm: 0.5,
            max_diameter_mm: 6.0,
            max_drops: 1 << 20,
            ceiling_m: f32::INFINITY,
        }
    }
}

/// Drops in a box of `volume_m3` for an intensity, uncapped.
pub fn expected_drop_count(intensity_mm_h: f32, min_diameter_mm: f32, volume_m3: f32) -> f64 {
    number_density_per_m3(intensity_mm_h as f64, min_diameter_mm as f64) * volume_m3 as f64
}

/// The drop count for an intensity: the expectation rounded down and capped.
pub fn target_drop_count(params: &RainParams, intensity_mm_h: f32, volume_m3: f32) -> u32 {
    expected_drop_count(intensity_mm_h, params.min_diameter_mm, volume_m3)
        .floor()
        .min(params.max_drops as f64) as u32
}

/// A drop hitting the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Splash {
    /// Where, world m.
    pub position_m: Vec3,
    /// The drop's velocity at impact, m/s.
    pub velocity_m_s: Vec3,
    /// The drop's diameter, mm.
    pub diameter_mm: f32,
}

/// Everything a step depends on besides the drop.
#[derive(Clone, Copy, Debug)]
pub struct StepInputs<'a> {
    /// The rain.
    pub params: RainParams,
    /// The box at the end of the step.
    pub rain_box: RainBox,
    /// The wind.
    pub wind: &'a WindField,
    /// Where it rains.
    pub zones: &'a RainZones,
    /// Time at the end of the step, s.
    pub time_s: f32,
    /// Index of the step (keys the random numbers).
    pub step: u32,
    /// Step length, s.
    pub dt_s: f32,
    /// Height of a flat ground, m (−∞ for none). The GPU tests cover with
    /// its rain shadow map instead; both stop a drop where its segment
    /// goes under cover.
    pub ground_height_m: f32,
}

impl StepInputs<'_> {
    /// Intensity at `p`: the scene's, scaled by the zone map, none above the ceiling.
    pub fn local_intensity_mm_h(&self, p: Vec3) -> f32 {
        if p.y > self.params.ceiling_m {
            return 0.0;
        }
        self.params.intensity_mm_h * self.zones.factor_at(p.x, p.z)
    }

    /// Whether drop `id` is in the rain at `p`.
    pub fn is_active(&self, id: u32, p: Vec3) -> bool {
        id < target_drop_count(
            &self.params,
            self.local_intensity_mm_h(p),
            self.rain_box.volume_m3(),
        )
    }

    /// Whether `p` is under cover.
    pub fn is_covered(&self, p: Vec3) -> bool {
        p.y < self.ground_height_m
    }

    fn diameter_mm(&self, id: u32) -> f32 {
        self.diameter_from(uniform(id, self.step, salt::DIAMETER))
    }

    fn diameter_from(&self, u: f32) -> f32 {
        sample_diameter_mm(
            u as f64,
            self.params.intensity_mm_h as f64,
            self.params.min_diameter_mm as f64,
            self.params.max_diameter_mm as f64,
        ) as f32
    }

    /// The terminal velocity of a drop of `d_mm` in the wind at `p`.
    fn terminal_velocity_m_s(&self, d_mm: f32, p: Vec3) -> Vec3 {
        self.wind.velocity_m_s(p, self.time_s) - Vec3::Y * terminal_speed_m_s_f32(d_mm)
    }
}

/// A drop placed uniformly in the box (at start-up or after a jump of the camera).
pub fn initial_drop(id: u32, inputs: &StepInputs<'_>) -> Drop {
    let u = [0, 1, 2].map(|k| uniform(id, inputs.step, salt::INSIDE + k));
    let p = inputs.rain_box.sample_inside(u);
    let d = inputs.diameter_mm(id);
    Drop {
        position_m: p,
        diameter_mm: d,
        velocity_m_s: inputs.terminal_velocity_m_s(d, p),
        state: entry_state(id, p, inputs),
    }
}

/// The state of a drop placed at `p`: dead above the count the local
/// intensity asks for; else a ghost under cover (it follows its trajectory
/// undrawn, so that the open part of the box keeps the Marshall–Palmer
/// density), else alive.
fn entry_state(id: u32, p: Vec3, inputs: &StepInputs<'_>) -> DropState {
    if !inputs.is_active(id, p) {
        DropState::Dead
    } else if inputs.is_covered(p) {
        DropState::Ghost
    } else {
        DropState::Alive
    }
}

/// The diameter of a drop crossing into the box. What crosses a surface is
/// the flux N(D)·|u(D)|, not the distribution in the volume N(D): fast, large
/// drops cross more often (and leave sooner). Candidates from N(D) are
/// accepted with probability |u(D)|/|u|max, u the velocity relative to the
/// box (exact for the sphere, whose inflow is proportional to |u|; for the
/// box and frustum the projected area also varies with direction, which
/// this neglects). After [`salt::ENTRY_TRIES`] rejections the last
/// candidate is taken (a bias below 10⁻³).
fn entering_diameter_mm(id: u32, inputs: &StepInputs<'_>) -> f32 {
    let relative_wind = inputs.wind.mean_m_s - inputs.rain_box.velocity_m_s;
    let bound = relative_wind.length() + terminal_speed_m_s_f32(inputs.params.max_diameter_mm);
    let mut d = inputs.params.min_diameter_mm;
    for k in 0..salt::ENTRY_TRIES {
        d = inputs.diameter_from(uniform(id, inputs.step, salt::ENTRY_DIAMETER + k));
        let speed = (relative_wind - Vec3::Y * terminal_speed_m_s_f32(d)).length();
        if uniform(id, inputs.step, salt::ENTRY_ACCEPT + k) * bound <= speed {
            break;
        }
    }
    d
}

/// A drop entering on the upstream boundary (alive, or dead where it may not rain).
fn entering_drop(id: u32, inputs: &StepInputs<'_>) -> Drop {
    let d = entering_diameter_mm(id, inputs);
    // The flux is sampled with the mean wind; the drop then starts at its
    // terminal velocity in the local wind.
    let mean_velocity = inputs.wind.mean_m_s - Vec3::Y * terminal_speed_m_s_f32(d);
    let u = [0, 1, 2, 3].map(|k| uniform(id, inputs.step, salt::INFLOW + k));
    let dead = Drop {
        position_m: inputs.rain_box.center_m,
        diameter_mm: d,
        velocity_m_s: mean_velocity,
        state: DropState::Dead,
    };
    let Some(p) = inputs.rain_box.sample_inflow(mean_velocity, u, inputs.dt_s) else {
        return dead;
    };
    if !inputs.rain_box.contains(p) {
        return dead;
    }
    Drop {
        position_m: p,
        velocity_m_s: inputs.terminal_velocity_m_s(d, p),
        state: entry_state(id, p, inputs),
        ..dead
    }
}

/// One step of one drop; the splash when it hit something.
pub fn step_drop(id: u32, drop: Drop, inputs: &StepInputs<'_>) -> (Drop, Option<Splash>) {
    match drop.state {
        DropState::Leaving => (entering_drop(id, inputs), None),
        DropState::Dead => {
            let d = inputs.diameter_mm(id);
            let velocity = inputs.wind.mean_m_s - Vec3::Y * terminal_speed_m_s_f32(d);
            let rate = inputs.rain_box.inflow_rate_m3_s(velocity) / inputs.rain_box.volume_m3();
            if uniform(id, inputs.step, salt::REVIVE) < inputs.dt_s * rate {
                (entering_drop(id, inputs), None)
            } else {
                (drop, None)
            }
        }
        DropState::Alive | DropState::Ghost => {
            let dt = inputs.dt_s;
            let x = drop.position_m;
            let v = drop.velocity_m_s;
            let wind = inputs.wind.velocity_m_s(x, inputs.time_s);
            let v_t = terminal_speed_m_s_f32(drop.diameter_mm);
            let k = GRAVITY_M_S2 as f32 / (v_t * v_t) * (v - wind).length();
            let gravity = Vec3::new(0.0, -GRAVITY_M_S2 as f32, 0.0);
            let v_next = (v + (gravity + wind * k) * dt) / (1.0 + dt * k);
            let x_next = x + v_next * dt;
            let moved = Drop {
                position_m: x_next,
                velocity_m_s: v_next,
                ..drop
            };
            if !inputs.rain_box.contains(x_next) {
                // A ghost's exit is not drawn: it re-enters in the next step.
                return (
                    Drop {
                        state: DropState::Leaving,
                        ..moved
                    },
                    None,
                );
            }
            if drop.state == DropState::Alive && inputs.is_covered(x_next) {
                // The crossing of the segment with the cover (a plane here,
                // the rain shadow map's depth on the GPU).
                let t =
                    ((x.y - inputs.ground_height_m) / (x.y - x_next.y).max(1e-9)).clamp(0.0, 1.0);
                let splash = Splash {
                    position_m: x + (x_next - x) * t,
                    velocity_m_s: v_next,
                    diameter_mm: drop.diameter_mm,
                };
                return (
                    Drop {
                        state: DropState::Ghost,
                        ..moved
                    },
                    Some(splash),
                );
            }
            (moved, None)
        }
    }
}

/// Summary of a simulation's drops.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RainStatistics {
    /// Drops alive or leaving (those drawn).
    pub drops: u64,
    /// Mean diameter of those, mm.
    pub mean_diameter_mm: f64,
    /// Their mean velocity, m/s.
    pub mean_velocity_m_s: [f64; 3],
    /// Position or velocity components that are not finite, over all drops.
    pub non_finite_values: u64,
}

/// A CPU rain simulation: the reference the GPU one is tested against, and
/// what `nimbus rain stats` runs.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// The rain.
    pub params: RainParams,
    /// The wind.
    pub wind: WindField,
    /// Where it rains.
    pub zones: RainZones,
    /// Flat ground height, m (−∞ for none).
    pub ground_height_m: f32,
    /// The drops; their count is the largest drop count asked for so far.
    pub drops: Vec<Drop>,
    /// Simulated time, s.
    pub time_s: f32,
    /// Steps taken.
    pub step: u32,
    /// The box after the last step.
    pub rain_box: RainBox,
    /// Drops that re-entered (leaving → alive) over all steps.
    pub recycled: u64,
    /// Splashes over all steps.
    pub splashes: u64,
}

impl Simulation {
    /// A simulation with drops placed in the box at time 0.
    pub fn new(
        params: RainParams,
        wind: WindField,
        zones: RainZones,
        rain_box: RainBox,
        ground_height_m: f32,
    ) -> Self {
        let mut simulation = Self {
            params,
            wind,
            zones,
            ground_height_m,
            drops: Vec::new(),
            time_s: 0.0,
            step: 0,
            rain_box,
            recycled: 0,
            splashes: 0,
        };
        let count = target_drop_count(&params, params.intensity_mm_h, rain_box.volume_m3());
        let inputs = simulation.inputs(rain_box, STEP_S);
        simulation.drops = (0..count)
            .into_par_iter()
            .with_min_len(DROPS_PER_TASK)
            .map(|id| initial_drop(id, &inputs))
            .collect();
        simulation
    }

    fn inputs(&self, rain_box: RainBox, dt_s: f32) -> StepInputs<'_> {
        StepInputs {
            params: self.params,
            rain_box,
            wind: &self.wind,
            zones: &self.zones,
            time_s: self.time_s,
            step: self.step,
            dt_s,
            ground_height_m: self.ground_height_m,
        }
    }

    /// Changes the intensity; drops are added (dead, entering at the
    /// boundary) when the count grows, never removed.
    pub fn set_intensity(&mut self, intensity_mm_h: f32) {
        self.params.intensity_mm_h = intensity_mm_h;
        let count =
            target_drop_count(&self.params, intensity_mm_h, self.rain_box.volume_m3()) as usize;
        if count > self.drops.len() {
            let dead = Drop {
                position_m: self.rain_box.center_m,
                diameter_mm: self.params.min_diameter_mm,
                velocity_m_s: Vec3::ZERO,
                state: DropState::Dead,
            };
            self.drops.resize(count, dead);
        }
    }

    /// One step with the box moved to `rain_box`.
    pub fn step(&mut self, rain_box: RainBox) {
        self.time_s += STEP_S;
        self.step += 1;
        self.rain_box = rain_box;
        // The drops leave `self` while they step, so that the inputs can
        // borrow the rest of it.
        let mut drops = std::mem::take(&mut self.drops);
        let inputs = self.inputs(rain_box, STEP_S);
        let (recycled, splashes) = drops
            .par_iter_mut()
            .with_min_len(DROPS_PER_TASK)
            .enumerate()
            .map(|(id, drop)| {
                let was_leaving = drop.state == DropState::Leaving;
                let (next, splash) = step_drop(id as u32, *drop, &inputs);
                *drop = next;
                (
                    (was_leaving && next.state == DropState::Alive) as u64,
                    splash.is_some() as u64,
                )
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        self.drops = drops;
        self.recycled += recycled;
        self.splashes += splashes;
    }

    /// Statistics of the drops in the rain.
    pub fn statistics(&self) -> RainStatistics {
        let mut s = RainStatistics::default();
        let mut sum_d = 0.0;
        let mut sum_v = [0.0f64; 3];
        for drop in &self.drops {
            let values = [drop.position_m.to_array(), drop.velocity_m_s.to_array()];
            s.non_finite_values +=
                values.iter().flatten().filter(|v| !v.is_finite()).count() as u64;
            if matches!(drop.state, DropState::Alive | DropState::Leaving) {
                s.drops += 1;
                sum_d += drop.diameter_mm as f64;
                for (a, b) in sum_v.iter_mut().zip(drop.velocity_m_s.to_array()) {
                    *a += b as f64;
                }
            }
        }
        if s.drops > 0 {
            s.mean_diameter_mm = sum_d / s.drops as f64;
            s.mean_velocity_m_s = sum_v.map(|v| v / s.drops as f64);
        }
        s
    }
}

#[cfg(test)]
mod tests;
