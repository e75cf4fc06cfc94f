//! What a Z job is started with ([`ZJobSpec`], its [`ZOutputSpec`]) and why a start is refused
//! ([`ZStartError`]).

use crate::protocol::errors::FaultCode;
use serde::{Deserialize, Serialize};

/// The Z output of a job.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ZOutputSpec {
    /// Step/dir on machine axis `axis`, `steps_per_in` (1..=2^24).
    Steps { axis: u8, steps_per_in: u32 },
    /// The 12-bit DAC: `code = mid + z * codes_per_in`.
    Dac { codes_per_in: u32, mid_code: u16 },
}

/// A Z job's parameters (`StartZ`): output, X feed and the [`ZCommandConfig`] fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ZJobSpec {
    pub output: ZOutputSpec,
    /// The X axis (machine axis index), its steps per inch, and whether increasing X is the
    /// axis's negative direction.
    pub x_axis: u8,
    pub x_steps_per_in: u32,
    pub x_negative: bool,
    /// X at the X axis's current position, where the feed stops, and the feed per tick
    /// (inches Q24; the feed > 0).
    pub x_start_in_q24: i32,
    pub x_end_in_q24: i32,
    pub x_feed_in_q24_per_tick: i32,
    /// Cubic (else linear) interpolation in X.
    pub cubic: bool,
    pub advance_ticks_q16: u32,
    pub engage_ticks: u32,
    pub blend_start_x_in_q24: i32,
    pub blend_end_x_in_q24: i32,
    pub max_velocity_uin_per_s: u32,
    pub max_accel_uin_per_s2: u32,
    pub min_speed_turn_q32_per_tick: u32,
}

/// Why a start was refused (nothing changed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZStartError {
    /// No table uploaded.
    NoTable,
    /// A job runs already.
    Running,
    /// Axis, scale or feed out of range.
    Spec,
    /// The generator refused the config.
    Config,
    /// The pre-start check: `ZSlideLimit` or `SpindleStopped`.
    Fault(FaultCode),
}
