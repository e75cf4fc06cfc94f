//! The Bresenham lane kernel: one virtual tick of every moving axis.
//!
//! Lane `i` is axis `i`. Its error `e` lives in `[-t, 0)` and is stored as the u32 `2^32 + e`,
//! so the axis steps exactly when the u32 add `e + d` carries, and the correction `- t` is an
//! add of `2^32 - t`. Bit `i` of the result is set when lane `i` stepped, so the result is the
//! tick's axis mask with no table between them.
//!
//! The kernel always runs a fixed number of lanes: four when the segment moves only axes 0..=3,
//! else all six. An axis that does not move has `d = 0` and never carries, so the extra lanes
//! cost a few instructions and save the per-lane-count dispatch, and every cruise tick of a
//! segment takes the same time.
//!
//! On the Cortex-M4 the kernel is four instructions per lane (`adds`, `it cs`, `addcs`, `adc`)
//! between a load of the lane's pair and a store of its error: the compiler's own code for [`step_portable`] re-derives the
//! carry with a compare and spends about nine. Everything else runs [`step_portable`], and the
//! `dda_lane_kernel` scenario runs both on the same pseudo-random lanes: its QEMU report must
//! equal the host's, so the two implementations cannot drift apart unnoticed.

use crate::config::MAX_AXES;

/// Lanes the narrow kernel runs: a segment moving only axes below this uses it.
pub const NARROW_LANES: usize = 4;

/// One axis of the active segment: Bresenham error and step count, side by side so the kernel
/// loads both with one `ldrd`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Lane {
    /// Bresenham error `e` in `[-t, 0)`, stored as the u32 `2^32 + e`.
    pub err: u32,
    /// Steps of this axis in the segment (0: the axis does not move).
    pub d: u32,
}

/// Every axis's lane, in axis order.
pub type Lanes = [Lane; MAX_AXES];

/// True when a segment moving `active` (axis mask) needs the six-lane kernel.
pub const fn needs_wide(active: u8) -> bool {
    active >> NARROW_LANES != 0
}

/// One virtual tick: lanes `0..4` (all six when `wide`) add `d`, and those that carry also add
/// `minus_t` (`2^32 - t`). Bit `i` of the result: lane `i` stepped; bits 6.. are 0. A u32, so
/// the tick combines it with its edge words without narrowing it.
#[inline(always)]
pub fn step(lanes: &mut Lanes, wide: bool, minus_t: u32) -> u32 {
    #[cfg(target_arch = "arm")]
    {
        thumb2::step(lanes, wide, minus_t)
    }
    #[cfg(not(target_arch = "arm"))]
    {
        step_portable(lanes, wide, minus_t)
    }
}

/// [`step`] in plain Rust: the reference the Thumb-2 kernel is checked against.
#[inline(always)]
pub fn step_portable(lanes: &mut Lanes, wide: bool, minus_t: u32) -> u32 {
    let n = if wide { MAX_AXES } else { NARROW_LANES };
    let mut mask = 0;
    for (i, l) in lanes.iter_mut().enumerate().take(n) {
        let (e, carry) = l.err.overflowing_add(l.d);
        l.err = if carry { e.wrapping_add(minus_t) } else { e };
        mask |= (carry as u32) << i;
    }
    mask
}

#[cfg(target_arch = "arm")]
#[allow(unsafe_code)]
mod thumb2 {
    use super::Lanes;
    use core::arch::asm;

    /// One lane at byte offset `$at` of the lanes: its error plus its step, the correction when
    /// that carries, the carry shifted into the mask.
    macro_rules! lane {
        ($at:literal) => {
            concat!(
                "ldrd {e}, {d}, [{p}, #",
                $at,
                "]\n",
                "adds {e}, {e}, {d}\n",
                "it cs\n",
                "addcs {e}, {e}, {mt}\n",
                "adc {m}, {m}, {m}\n",
                "str {e}, [{p}, #",
                $at,
                "]\n",
            )
        };
    }

    /// Lanes are processed from the highest down, each carry shifted in at bit 0 by `adc`, so
    /// lane `i` ends at bit `i`. A lane at a time through two scratch registers (a load of
    /// its pair, a store of its error): a caller's loop keeps its own state in the registers
    /// that a load of all lanes at once would take.
    #[inline(always)]
    pub fn step(lanes: &mut Lanes, wide: bool, minus_t: u32) -> u32 {
        let p = lanes.as_mut_ptr();
        let mut mask: u32 = 0;
        if wide {
            // SAFETY: `p + 32` is lane 4 of the six `Lane`s (8 bytes each, `repr(C)`) that
            // `lanes` borrows mutably; the block reads and writes lanes 4 and 5 and only the
            // registers it declares.
            unsafe {
                asm!(
                    lane!(40),
                    lane!(32),
                    p = in(reg) p,
                    mt = in(reg) minus_t,
                    m = inout(reg) mask,
                    e = out(reg) _,
                    d = out(reg) _,
                    options(nostack),
                );
            }
        }
        // SAFETY: `p` points at lanes 0..=3 (32 bytes) of the array `lanes` borrows mutably;
        // the block reads and writes only them and the registers it declares.
        unsafe {
            asm!(
                lane!(24),
                lane!(16),
                lane!(8),
                lane!(0),
                p = in(reg) p,
                mt = in(reg) minus_t,
                m = inout(reg) mask,
                e = out(reg) _,
                d = out(reg) _,
                options(nostack),
            );
        }
        mask
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error of each lane after `k` virtual ticks from the segment start is
    /// `k d + h - t (s + 1)` with `s = floor((k d + h) / t)` steps: the kernel reproduces it.
    #[test]
    fn lanes_step_exactly_floor_kd_plus_h_over_t() {
        let t = 1000u32;
        let h = t / 2;
        let d = [0u32, 1, 333, 999, 1000, 7];
        let mut lanes = [Lane::default(); MAX_AXES];
        for (l, &d) in lanes.iter_mut().zip(&d) {
            *l = Lane { err: h.wrapping_sub(t), d };
        }
        let mut steps = [0u64; MAX_AXES];
        for k in 1..=t as u64 {
            let mask = step_portable(&mut lanes, true, t.wrapping_neg());
            for (i, s) in steps.iter_mut().enumerate() {
                *s += (mask >> i & 1) as u64;
                assert_eq!(*s, (k * d[i] as u64 + h as u64) / t as u64, "lane {i} at {k}");
            }
        }
        assert_eq!(steps.map(|s| s as u32), d);
    }

    #[test]
    fn narrow_kernel_leaves_lanes_four_and_five_alone() {
        let mut lanes = [Lane { err: u32::MAX, d: 1 }; MAX_AXES];
        let mask = step_portable(&mut lanes, false, 5);
        assert_eq!(mask, 0b1111);
        assert_eq!(lanes[3], Lane { err: 5, d: 1 });
        assert_eq!(lanes[4], Lane { err: u32::MAX, d: 1 });
        assert!(needs_wide(1 << 4) && !needs_wide(0b1111));
    }
}
