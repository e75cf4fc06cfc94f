//! The planned segment: what the planner (host or firmware) hands to the DDA through the queue.

use crate::config::{MachineConfig, MAX_AXES};

/// Fraction of a segment's nominal speed, Q2.30: 1.0 is the planned feed, 2.0 the largest override.
pub type Rate = fixed::types::U2F30;

/// Longest segment in ticks at nominal speed; the planner splits longer moves.
pub const MAX_SEGMENT_TICKS: u32 = (1 << 31) - 1;

/// One straight move in step space, planned: nominal duration, junction speeds and ramp slope.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Segment {
    /// Signed steps per axis; exactly these are emitted.
    pub steps: [i32; MAX_AXES],
    /// Ticks the segment takes at rate 1.0 (its planned feed, override 1.0).
    pub duration_ticks: u32,
    /// Planned speed at entry and exit, as fractions of this segment's nominal speed (<= 1.0).
    pub entry_rate: Rate,
    pub exit_rate: Rate,
    /// Rate change per tick that keeps every axis within its acceleration limit (> 0).
    pub accel_per_tick: Rate,
    /// Caller's tag, reported back when the segment completes.
    pub id: u32,
}

/// Order hash of completed segments: FNV-1a over each id (LE bytes) in completion order. The
/// board reports it and the host recomputes it, so a lost, repeated or reordered segment shows.
pub const ORDER_HASH_START: u32 = 0x811c_9dc5;

pub const fn order_hash(prev: u32, id: u32) -> u32 {
    let b = id.to_le_bytes();
    let mut h = prev;
    let mut i = 0;
    while i < 4 {
        h = (h ^ b[i] as u32).wrapping_mul(0x0100_0193);
        i += 1;
    }
    h
}

/// Why a segment was refused; nothing was queued.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SegmentError {
    /// `duration_ticks` is 0 or above `MAX_SEGMENT_TICKS`.
    Duration,
    /// An axis moves more than one step per tick, or faster than its `max_rate_hz`.
    AxisRate { axis: u8 },
    /// An axis outside `axis_count` moves.
    UnusedAxis { axis: u8 },
    /// Entry or exit rate above 1.0.
    JunctionRate,
    /// `accel_per_tick` is zero.
    Accel,
    /// No axis moves.
    Empty,
}

impl Segment {
    /// Checks the segment against the machine; the DDA relies on every property checked here.
    pub fn check(&self, cfg: &MachineConfig) -> Result<(), SegmentError> {
        let t = self.duration_ticks;
        if t == 0 || t > MAX_SEGMENT_TICKS {
            return Err(SegmentError::Duration);
        }
        if self.entry_rate > Rate::ONE || self.exit_rate > Rate::ONE {
            return Err(SegmentError::JunctionRate);
        }
        if self.accel_per_tick == Rate::ZERO {
            return Err(SegmentError::Accel);
        }
        let mut moving = false;
        for (i, &s) in self.steps.iter().enumerate() {
            let d = s.unsigned_abs();
            if d == 0 {
                continue;
            }
            moving = true;
            if i >= cfg.axis_count as usize {
                return Err(SegmentError::UnusedAxis { axis: i as u8 });
            }
            // Nominal axis rate d / t * tick_hz must not exceed max_rate_hz.
            let too_fast =
                d as u64 * cfg.tick_hz as u64 > cfg.axes[i].max_rate_hz as u64 * t as u64;
            if d > t || too_fast {
                return Err(SegmentError::AxisRate { axis: i as u8 });
            }
        }
        if !moving {
            return Err(SegmentError::Empty);
        }
        Ok(())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Segment {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "Segment {{ id: {=u32}, steps: {=[?]}, ticks: {=u32}, entry: {=u32}, exit: {=u32}, accel: {=u32} }}",
            self.id,
            &self.steps[..],
            self.duration_ticks,
            self.entry_rate.to_bits(),
            self.exit_rate.to_bits(),
            self.accel_per_tick.to_bits()
        )
    }
}
