//! Spindle angle and speed sources for the Z slide (Douglass, non-axisymmetric turning): one
//! trait, [`SpindleSource`], implemented by a quadrature encoder with an index pulse
//! ([`encoder::QuadratureEncoder`]) and a resolver with an angle-tracking observer
//! ([`resolver::Resolver`]), plus a simulated spindle that drives both ([`sim::SimSpindle`]).
//!
//! Units: angle as a `u32` fraction of a turn (`_turn_q32`, 2^32 = one turn, wraps exactly);
//! speed in 2^-32 turn per tick (`_turn_q32_per_tick`), so a phase advance of `n` ticks is
//! `angle + speed * n` with no conversion. Both sources update once per tick, integer-only and
//! division-free; their configs divide once, at setup.

pub mod encoder;
pub mod resolver;
pub mod resolver_offset;
pub mod sim;
pub mod timer_encoder;

use crate::protocol::errors::FaultCode;

pub use encoder::{EncoderConfig, QuadratureEncoder};
pub use resolver::{Resolver, ResolverConfig};
pub use sim::SimSpindle;

/// A spindle angle/speed sensor as the Z-command generator sees it.
pub trait SpindleSource {
    /// Spindle angle, fraction of a turn (2^32 = one turn). Only absolute once
    /// [`SpindleSource::is_referenced`].
    fn angle_turn_q32(&self) -> u32;
    /// Angular speed, 2^-32 turn per tick (positive = increasing angle).
    fn speed_turn_q32_per_tick(&self) -> i32;
    /// A latched sensor fault (`EncoderIndex`, `ResolverLoss`), if any.
    fn fault(&self) -> Option<FaultCode>;
    /// True once the angle is tied to the spindle's zero (encoder: an index pulse was seen).
    fn is_referenced(&self) -> bool;
    /// True while the speed estimate is below the source's stop threshold.
    fn is_stopped(&self) -> bool;
}

/// Speed in 2^-32 turn per tick for `rpm` at `tick_hz` (setup code and tests; divides).
pub const fn speed_turn_q32_per_tick(rpm_milli: u64, tick_hz: u32) -> i32 {
    // rpm/60 turns per second / tick_hz, times 2^32; rpm given in thousandths.
    ((rpm_milli << 32) / (60_000 * tick_hz as u64)) as i32
}

/// [`speed_turn_q32_per_tick`] for a speed from outside (a host's request): `None` when it
/// does not fit (half a turn per tick or more), and a tick rate of 0 read as 1.
pub const fn checked_speed_turn_q32_per_tick(rpm_milli: u32, tick_hz: u32) -> Option<i32> {
    let tick_hz = if tick_hz == 0 { 1 } else { tick_hz };
    let speed = ((rpm_milli as u64) << 32) / (60_000 * tick_hz as u64);
    if speed > i32::MAX as u64 {
        None
    } else {
        Some(speed as i32)
    }
}

/// Rpm in thousandths from a speed in 2^-32 turn per tick (reports; divides).
pub const fn rpm_milli(speed_turn_q32_per_tick: i32, tick_hz: u32) -> i64 {
    (speed_turn_q32_per_tick as i64 * 60_000 * tick_hz as i64) >> 32
}

#[cfg(test)]
mod tests;
