//! A simulated spindle for tests and scenarios: exact angle (turns + `u32` fraction) advanced by
//! a commanded speed each tick, and what an encoder timer and a resolver's ADC would read.

use crate::trig::{cos_q30, sin_q30};

/// The true spindle: whole turns and a `u32` fraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimSpindle {
    turns: u32,
    frac_turn_q32: u32,
    /// Set by the last [`SimSpindle::advance`] when it crossed the zero angle forwards.
    crossed_zero: bool,
}

impl SimSpindle {
    pub const fn new(frac_turn_q32: u32) -> Self {
        Self { turns: 0, frac_turn_q32, crossed_zero: false }
    }

    /// Advances one tick at `speed_turn_q32_per_tick` (non-negative: the sim turns forwards).
    #[inline]
    pub fn advance(&mut self, speed_turn_q32_per_tick: u32) {
        let (f, carry) = self.frac_turn_q32.overflowing_add(speed_turn_q32_per_tick);
        self.frac_turn_q32 = f;
        self.crossed_zero = carry;
        if carry {
            self.turns = self.turns.wrapping_add(1);
        }
    }

    /// The last [`SimSpindle::advance`] crossed the zero angle (an index pulse is due).
    pub const fn crossed_zero(&self) -> bool {
        self.crossed_zero
    }
    pub const fn angle_turn_q32(&self) -> u32 {
        self.frac_turn_q32
    }
    pub const fn turns(&self) -> u32 {
        self.turns
    }

    /// The encoder timer's count (free-running `u16`) for `counts_per_rev`, and the count the
    /// index latched if the zero mark passed this tick.
    #[inline]
    pub fn encoder(&self, counts_per_rev: u32) -> (u16, Option<u16>) {
        let base = self.turns.wrapping_mul(counts_per_rev);
        let within = ((self.frac_turn_q32 as u64 * counts_per_rev as u64) >> 32) as u32;
        let count = base.wrapping_add(within) as u16;
        (count, if self.crossed_zero { Some(base as u16) } else { None })
    }

    /// Resolver ADC samples `(sin, cos)` of amplitude `amplitude_lsb` (offset removed), plus a
    /// deterministic noise term in `-noise..=noise` from `seed` (a 32-bit LCG the caller keeps).
    #[inline]
    pub fn resolver(&self, amplitude_lsb: i32, noise_lsb: i32, seed: &mut u32) -> (i16, i16) {
        let mut n = || {
            *seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            if noise_lsb <= 0 {
                0
            } else {
                // Top bits of the LCG, mapped onto the noise range by a multiply (no division).
                let span = (2 * noise_lsb + 1) as i64;
                (((*seed >> 16) as i64 * span) >> 16) as i32 - noise_lsb
            }
        };
        let s = ((amplitude_lsb as i64 * sin_q30(self.frac_turn_q32) as i64) >> 30) as i32 + n();
        let c = ((amplitude_lsb as i64 * cos_q30(self.frac_turn_q32) as i64) >> 30) as i32 + n();
        (s.clamp(-32768, 32767) as i16, c.clamp(-32768, 32767) as i16)
    }
}
