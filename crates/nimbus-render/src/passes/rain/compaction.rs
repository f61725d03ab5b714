//! CPU twins of the rain's two stable stream compactions, which make the
//! rain's picture the same in every run: the list of drops in view
//! (`visibility.wgsl`: `mark`, `scan`, `scatter`) and the splashes' slots
//! in the ring (`simulation.wgsl`: `simulate` marks, `place_splashes`).
//!
//! Both keep the order of the drops' indices (Blelloch, "Prefix sums and
//! their applications", 1990): per workgroup of [`WORKGROUP_SIZE`] drops a
//! bit mask of [`GROUP_WORDS`] words, an exclusive prefix sum of the
//! workgroups' counts taken by one workgroup of 256 invocations over runs
//! of consecutive workgroups, and each selected drop placed at its
//! workgroup's offset plus the bits set before its own. The functions here
//! follow those steps (the same runs, words and counts) so that their
//! tests check the GPU's arithmetic as well as its result, which must be
//! the plain ordered filter.

use super::WORKGROUP_SIZE;
use super::gpu_types::DropGpu;
use glam::{Mat4, Vec3, Vec4};
use nimbus_physics::rain::simulation::DropState;

/// Words of a workgroup's bit mask (one bit per invocation).
pub const GROUP_WORDS: u32 = WORKGROUP_SIZE / 32;
/// Invocations of the one workgroup that scans the workgroups' counts.
const SCAN_INVOCATIONS: usize = 256;

/// Each workgroup's bit mask of the `selected` items ([`GROUP_WORDS`]
/// words per workgroup of [`WORKGROUP_SIZE`] items), as `mark` and
/// `simulate` write it.
pub fn group_masks(selected: &[bool]) -> Vec<u32> {
    let groups = selected.len().div_ceil(WORKGROUP_SIZE as usize);
    let mut masks = vec![0u32; groups * GROUP_WORDS as usize];
    for (index, _) in selected.iter().enumerate().filter(|(_, s)| **s) {
        masks[index / 32] |= 1 << (index % 32);
    }
    masks
}

/// The exclusive prefix sum of `counts` and their total, taken as the one
/// scanning workgroup does: invocation i sums a run of ⌈n/256⌉ consecutive
/// counts, the runs' sums are scanned (Hillis & Steele), and each run is
/// walked again.
pub fn exclusive_scan(counts: &[u32]) -> (Vec<u32>, u32) {
    let n = counts.len();
    let per_run = n.div_ceil(SCAN_INVOCATIONS);
    let run = |i: usize| {
        let start = (i * per_run).min(n);
        start..(start + per_run).min(n)
    };
    let sums: Vec<u32> = (0..SCAN_INVOCATIONS)
        .map(|i| counts[run(i)].iter().fold(0u32, |a, &c| a.wrapping_add(c)))
        .collect();
    // Hillis–Steele: log2(256) rounds, each adding the sum `stride` back.
    let mut inclusive = sums.clone();
    let mut stride = 1;
    while stride < SCAN_INVOCATIONS {
        let previous = inclusive.clone();
        for i in stride..SCAN_INVOCATIONS {
            inclusive[i] = previous[i].wrapping_add(previous[i - stride]);
        }
        stride *= 2;
    }
    let mut offsets = vec![0u32; n];
    for i in 0..SCAN_INVOCATIONS {
        let mut offset = inclusive[i].wrapping_sub(sums[i]);
        for g in run(i) {
            offsets[g] = offset;
            offset = offset.wrapping_add(counts[g]);
        }
    }
    (offsets, inclusive[SCAN_INVOCATIONS - 1])
}

/// Counts of the bits set in each workgroup's mask.
fn group_counts(masks: &[u32]) -> Vec<u32> {
    masks
        .chunks(GROUP_WORDS as usize)
        .map(|words| words.iter().map(|w| w.count_ones()).sum())
        .collect()
}

/// The place of item `local` of workgroup `group` among the selected ones:
/// its workgroup's offset plus the bits set before its own.
fn place(masks: &[u32], offsets: &[u32], group: usize, local: usize) -> u32 {
    let words = &masks[group * GROUP_WORDS as usize..][..GROUP_WORDS as usize];
    let (word, bit) = (local / 32, local % 32);
    let before: u32 = words[..word].iter().map(|w| w.count_ones()).sum::<u32>()
        + (words[word] & ((1u32 << bit) - 1)).count_ones();
    offsets[group] + before
}

/// The visibility list `visibility.wgsl` builds from which drops are `in_view`
/// (indices into the drops' buffer): `mark`, `scan`, `scatter`. Equal to
/// the indices of the drops in view in increasing order.
pub fn visible_list(in_view: &[bool]) -> Vec<u32> {
    let masks = group_masks(in_view);
    let (offsets, total) = exclusive_scan(&group_counts(&masks));
    let mut list = vec![u32::MAX; total as usize];
    for (index, _) in in_view.iter().enumerate().filter(|(_, v)| **v) {
        let size = WORKGROUP_SIZE as usize;
        list[place(&masks, &offsets, index / size, index % size) as usize] = index as u32;
    }
    list
}

/// The ring's slots of one step's splashes in one drops' buffer, as
/// `place_splashes` gives them: `(index of the drop, slot)` for each drop
/// that `splashed`, in increasing order of the drops, from the ring's
/// `head` on (wrapping at `capacity`); and the new head.
pub fn splash_slots(head: u32, capacity: u32, splashed: &[bool]) -> (Vec<(u32, u32)>, u32) {
    let masks = group_masks(splashed);
    let (offsets, total) = exclusive_scan(&group_counts(&masks));
    let size = WORKGROUP_SIZE as usize;
    let slots = splashed
        .iter()
        .enumerate()
        .filter(|(_, s)| **s)
        .map(|(index, _)| {
            let place = head.wrapping_add(place(&masks, &offsets, index / size, index % size));
            (index as u32, place % capacity.max(1))
        })
        .collect();
    (slots, head.wrapping_add(total))
}

/// Whether `visibility.wgsl` lists a drop: in the rain (alive or leaving)
/// and its streak's bounding sphere meets the frustum of
/// `clip_from_world` (reverse-Z, infinite far plane; Gribb & Hartmann 2001).
/// The streak runs from the drop back along its velocity relative to the
/// camera (`camera_velocity_m_s`) over `exposure_s`.
pub fn streak_in_view(
    drop: &DropGpu,
    clip_from_world: Mat4,
    camera_velocity_m_s: Vec3,
    exposure_s: f32,
) -> bool {
    let state = DropState::from_u32(drop.state);
    if state != DropState::Alive && state != DropState::Leaving {
        return false;
    }
    let head = Vec3::from(drop.position_m);
    let tail = head - (Vec3::from(drop.velocity_m_s) - camera_velocity_m_s) * exposure_s;
    let centre = 0.5 * (head + tail);
    let radius = 0.5 * (head - tail).length() + 0.01;
    let m = clip_from_world.transpose();
    let [r0, r1, r2, r3]: [Vec4; 4] = [m.x_axis, m.y_axis, m.z_axis, m.w_axis];
    [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3 - r2]
        .iter()
        .all(|p| p.truncate().dot(centre) + p.w >= -radius * p.truncate().length())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fixed pseudo-random selection of about `fraction` of `n` items.
    fn selection(n: usize, fraction: f32, seed: u32) -> Vec<bool> {
        (0..n as u32)
            .map(|i| nimbus_physics::rain::random::uniform(i, seed, 7) < fraction)
            .collect()
    }

    /// The compactions keep the order of the items, whatever the number of
    /// workgroups (fewer than the scan's 256 runs, exactly one per run, and
    /// several per run) and however sparse the selection.
    #[test]
    fn the_visible_list_is_the_ordered_filter() {
        for n in [0, 1, 255, 256, 257, 4096, 65_536, 65_536 + 300, 300_001] {
            for (fraction, seed) in [(0.0, 1), (0.003, 2), (0.4, 3), (1.0, 4)] {
                let in_view = selection(n, fraction, seed);
                let expected: Vec<u32> = (0..n as u32).filter(|&i| in_view[i as usize]).collect();
                assert_eq!(visible_list(&in_view), expected, "{n} items, {fraction}");
            }
        }
    }

    #[test]
    fn splashes_take_the_slots_after_the_head_in_order_and_wrap() {
        let splashed = selection(70_000, 0.01, 5);
        let capacity = 512;
        let head = u32::MAX - 100;
        let (slots, new_head) = splash_slots(head, capacity, &splashed);
        let ids: Vec<u32> = (0..70_000u32).filter(|&i| splashed[i as usize]).collect();
        assert_eq!(new_head, head.wrapping_add(ids.len() as u32));
        for (k, ((id, slot), expected_id)) in slots.iter().zip(&ids).enumerate() {
            assert_eq!(id, expected_id);
            assert_eq!(*slot, head.wrapping_add(k as u32) % capacity);
        }
        assert_eq!(slots.len(), ids.len());
    }

    #[test]
    fn a_streak_behind_the_camera_or_a_dead_drop_is_not_in_view() {
        let clip_from_world =
            Mat4::perspective_infinite_reverse_rh(1.0, 16.0 / 9.0, 0.1) * Mat4::IDENTITY;
        let drop = |z: f32, state: DropState| DropGpu {
            position_m: [0.0, 0.0, z],
            diameter_mm: 1.0,
            velocity_m_s: [0.0, -5.0, 0.0],
            state: state as u32,
        };
        let sees = |d: DropGpu| streak_in_view(&d, clip_from_world, Vec3::ZERO, 0.01);
        assert!(sees(drop(-3.0, DropState::Alive)));
        assert!(sees(drop(-3.0, DropState::Leaving)));
        assert!(!sees(drop(-3.0, DropState::Ghost)));
        assert!(!sees(drop(-3.0, DropState::Dead)));
        assert!(!sees(drop(3.0, DropState::Alive)));
    }
}
