//! How often the Z generator updates: every `2^k` ticks, k from [`update_shift`], the ticks
//! between taking its command forward.

use crate::turning::command::MAX_SPEED_TURN_Q32_PER_TICK;

/// Slowest rate the Z generator is updated at: its accuracy is checked from here up.
pub const Z_UPDATE_MIN_HZ: u32 = 20_000;
/// At most `2^MAX_UPDATE_SHIFT` ticks between updates (the interpolation's range).
const MAX_UPDATE_SHIFT: u8 = 3;

/// Ticks between generator updates, as a power of two: the largest that keeps the update rate at
/// or above [`Z_UPDATE_MIN_HZ`] (0 below 40 kHz: every tick) and the spindle's turn per update
/// (at the start's speed) at most half the generator's limit, so the fastest spindle it takes
/// stays that of an update every tick.
pub fn update_shift(tick_hz: u32, speed_turn_q32_per_tick: i32) -> u8 {
    let turn_per_tick = speed_turn_q32_per_tick.unsigned_abs() as u64;
    let mut s = 0;
    while s < MAX_UPDATE_SHIFT
        && tick_hz >> (s + 1) >= Z_UPDATE_MIN_HZ
        && turn_per_tick << (s + 1) <= (MAX_SPEED_TURN_Q32_PER_TICK as u64) / 2
    {
        s += 1;
    }
    s
}

/// A spindle speed per tick as the generator's: per `2^shift` ticks (saturating).
#[inline]
pub(super) fn per_update(speed_turn_q32_per_tick: i32, shift: u8) -> i32 {
    ((speed_turn_q32_per_tick as i64) << shift).clamp(i32::MIN as i64, i32::MAX as i64) as i32
}
