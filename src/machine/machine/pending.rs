//! The step-only ticks' steps, counted in byte lanes and folded into the positions on the next
//! full tick.
//!
//! Counting a step into an `i64` position and checking it against both soft limits costs tens
//! of instructions per axis, on every tick an axis steps: at a streamed output's slot clock,
//! with four axes stepping every other slot, that was a quarter of the fill. Here a step-only
//! tick adds its rises to two pairs of words whose bytes are per-axis counts (one multiply
//! spreads four rise bits into four bytes), and the full tick that ends the run adds the net
//! counts to the positions. The soft limits need no check on those ticks: the full tick grants
//! a run only as long as every axis is at least that many steps inside its limits
//! ([`room`]), and an axis steps at most once per tick.

use crate::config::MAX_AXES;

/// Lanes per word: four bytes.
const LANES: usize = 4;
/// Spreads bits 0..3 of `x` into the low bit of bytes 0..3: `x * (1 + 2^7 + 2^14 + 2^21)`
/// places bit `k` at bit `8k`, and the partial products never overlap, so nothing carries.
const SPREAD: u32 = 0x0020_4081;
const LANE_BITS: u32 = 0x0101_0101;

#[inline(always)]
const fn spread4(x: u32) -> u32 {
    (x & 0xf).wrapping_mul(SPREAD) & LANE_BITS
}

/// Up and down steps per axis since the last fold: axes 0..3 in word 0's bytes, 4..5 in
/// word 1's. A byte counts to 255; a run is far shorter (`fast.rs` asserts it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct PendingSteps {
    up: [u32; 2],
    down: [u32; 2],
}

const _: () = assert!(MAX_AXES <= 2 * LANES);

impl PendingSteps {
    pub(super) const fn new() -> Self {
        PendingSteps { up: [0; 2], down: [0; 2] }
    }

    /// One tick's rising edges (`dir`: a set bit steps that axis down). Interrupt rate: the
    /// rises and directions of axes 0..3 spread into lanes (a multiply each), split by an
    /// and-not and an and; axes 4 and 5 only when one of them rose. Spreading commutes with
    /// the bitwise ops, so this is counting `rise & !dir` up and `rise & dir` down.
    #[inline(always)]
    pub(super) fn add(&mut self, rise: u8, dir: u8) {
        let (rise, dir) = (rise as u32, dir as u32);
        let (r, d) = (spread4(rise), spread4(dir));
        self.up[0] = self.up[0].wrapping_add(r & !d);
        self.down[0] = self.down[0].wrapping_add(r & d);
        if rise >> LANES != 0 {
            let (r, d) = (spread4(rise >> LANES), spread4(dir >> LANES));
            self.up[1] = self.up[1].wrapping_add(r & !d);
            self.down[1] = self.down[1].wrapping_add(r & d);
        }
    }

    /// Net steps per axis (up minus down).
    pub(super) fn net(&self) -> [i64; MAX_AXES] {
        let lane = |w: &[u32; 2], i: usize| ((w[i / LANES] >> (8 * (i % LANES))) & 0xff) as i64;
        core::array::from_fn(|i| lane(&self.up, i) - lane(&self.down, i))
    }

    /// Adds the net steps to `positions` and starts counting again.
    #[inline]
    pub(super) fn fold_into(&mut self, positions: &mut [i64; MAX_AXES]) {
        if *self == Self::new() {
            return;
        }
        for (p, n) in positions.iter_mut().zip(self.net()) {
            *p += n;
        }
        *self = Self::new();
    }
}

/// Steps every axis can take, at one per tick in either direction, before one could leave its
/// soft limits `min..=max` (per axis, the first `axes`): how many ticks need no check. 0 when an
/// axis is on or past a limit. The machine keeps the answer and counts it down
/// (`Machine::limit_room_left`), so this runs once in a long while, not on every full tick.
pub(super) fn room(
    positions: &[i64; MAX_AXES],
    min: &[i64; MAX_AXES],
    max: &[i64; MAX_AXES],
    axes: usize,
) -> u64 {
    let mut room = i64::MAX;
    for i in 0..axes.min(MAX_AXES) {
        // Saturating: an axis without limits has them at the ends of i64.
        let (down, up) = (positions[i].saturating_sub(min[i]), max[i].saturating_sub(positions[i]));
        room = room.min(down).min(up);
    }
    room.max(0) as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rises_count_per_axis_and_direction_and_fold_into_the_positions() {
        let mut p = PendingSteps::new();
        // Axes 0, 2, 5 up; axis 4 down; then axes 0 and 4 down, axis 1 up.
        p.add(0b11_0101, 0b01_0000);
        p.add(0b01_0011, 0b01_0001);
        for _ in 0..200 {
            p.add(0b10_0000, 0);
        }
        assert_eq!(p.net(), [0, 1, 1, 0, -2, 201]);
        let mut pos = [10, 20, 30, 40, 50, 60];
        p.fold_into(&mut pos);
        assert_eq!(pos, [10, 21, 31, 40, 48, 261]);
        assert_eq!(p, PendingSteps::new());
    }

    #[test]
    fn every_rise_pattern_spreads_into_its_own_lanes() {
        for rise in 0..64u8 {
            for dir in [0u8, 0x3f, 0b10_1010] {
                let mut p = PendingSteps::new();
                p.add(rise, dir);
                let want: [i64; MAX_AXES] = core::array::from_fn(|i| {
                    let stepped = rise & (1 << i) != 0;
                    match (stepped, dir & (1 << i) != 0) {
                        (false, _) => 0,
                        (true, false) => 1,
                        (true, true) => -1,
                    }
                });
                assert_eq!(p.net(), want, "rise {rise:#b} dir {dir:#b}");
            }
        }
    }

    #[test]
    fn room_is_the_nearest_limit_on_any_axis() {
        let (min, max) = ([-100; MAX_AXES], [100; MAX_AXES]);
        let mut pos = [0; MAX_AXES];
        assert_eq!(room(&pos, &min, &max, 3), 100);
        pos[2] = 90;
        assert_eq!(room(&pos, &min, &max, 3), 10);
        pos[1] = -95;
        assert_eq!(room(&pos, &min, &max, 3), 5);
        // Axes past `axes` do not count.
        pos[4] = 100;
        assert_eq!(room(&pos, &min, &max, 3), 5);
        pos[0] = 100;
        assert_eq!(room(&pos, &min, &max, 3), 0);
        pos[0] = 101;
        assert_eq!(room(&pos, &min, &max, 3), 0);
        // No limits: the ends of i64.
        let (min, max) = ([i64::MIN; MAX_AXES], [i64::MAX; MAX_AXES]);
        assert_eq!(room(&[-7; MAX_AXES], &min, &max, 6), i64::MAX as u64 - 6);
    }
}
