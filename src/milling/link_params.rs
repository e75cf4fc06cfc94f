//! The force job's parameters on the link (`ArmForce`), in the firmware's units, and its phase
//! in `Status`.

use serde::{Deserialize, Serialize};

/// Contact strategy of a force job (`motion::milling::control::ContactStrategy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ForceStrategy {
    /// Straight into the PI.
    Direct,
    /// Algorithm A: feed `slow_bits` (`Rate` bits) for `hold_ms`, then the PI.
    SlowHold { slow_bits: u32, hold_ms: u16 },
    /// Algorithm B: stop `stop_ms`, then `reduced_gain_q16` of the gains for `reduced_ms`.
    StopReduced { stop_ms: u16, reduced_ms: u16, reduced_gain_q16: u32 },
}

/// One force channel's calibration on the link (`motion::milling::chain::ChannelCal`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ForceCal {
    /// ADC counts at zero force (the first guess; the chain tares it while cutting air).
    pub zero_counts: u16,
    /// Millinewtons per count, Q16 (negative for a reversed sensor; not 0).
    pub mn_per_count_q16: i32,
}

/// A force job's parameters (`ArmForce`), in the firmware's units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ForceJobParams {
    /// Nominal force, contact threshold and trip level, mN (0 < contact < nominal < trip).
    pub fnom_mn: u32,
    pub contact_mn: u32,
    pub trip_mn: u32,
    /// PI gains: proportional (override per unit error, Q16) while F > Fnom (dec) and F < Fnom
    /// (inc); integral (1/s, Q16).
    pub kp_dec_q16: u32,
    pub kp_inc_q16: u32,
    pub ki_dec_per_s_q16: u32,
    pub ki_inc_per_s_q16: u32,
    /// Gain normalisation by the measured cutting stiffness (v Fnom / F).
    pub normalise: bool,
    /// The error scale without normalisation (its floor with it), Q16.
    pub fixed_scale_q16: u32,
    /// Feed clamps while cutting and the feed in air, `Rate` bits (0..=2.0, min <= max).
    pub feed_min_bits: u32,
    pub feed_max_bits: u32,
    pub feed_air_bits: u32,
    pub strategy: ForceStrategy,
    /// Below the contact threshold this long = air; standstill at start while the chain tares.
    pub air_after_ms: u16,
    pub tare_ms: u16,
    /// Cutter flutes (1..=64) and spindle speeds (nominal, and the minimum below which the
    /// feed holds with `SpindleStopped`), milli-revolutions per second.
    pub flutes: u8,
    pub spindle_mrev_s: u32,
    pub min_spindle_mrev_s: u32,
    /// The feed axis (its position drives the feed-per-tooth measure and the sim plant) and its
    /// steps per second at override 1.0 (the job's planned feed).
    pub axis: u8,
    pub steps_per_s_at_one: u32,
    /// ADC sample rate (a whole divisor of the tick rate on a tick-sampled board; the control
    /// rate is a fifth of it, >= 1 kHz).
    pub sample_hz: u32,
    /// Force channels (2 or 3) and their calibration; the ADC's full scale (counts).
    pub channels: u8,
    pub cal: [ForceCal; 3],
    pub adc_max_counts: u16,
    /// Saturation: samples within `rail_margin_counts` of a rail, `saturated_samples` in a row;
    /// stuck: `stuck_samples` identical samples in a row while cutting.
    pub rail_margin_counts: u16,
    pub saturated_samples: u16,
    pub stuck_samples: u16,
    /// Tare time constant as a shift (1..=16).
    pub tare_shift: u8,
}

/// `Status::force_phase`: where the force job is (its controller's mode while it runs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum ForcePhase {
    /// No force job since boot (or since a job was dropped before starting).
    #[default]
    None = 0,
    /// Armed, waiting for `Start`.
    Armed = 1,
    /// Feed 0 while the chain learns the zero.
    Tare = 2,
    Air = 3,
    /// Algorithm A's slow feed, Algorithm B's stop and reduced gain.
    ContactSlow = 4,
    ContactStop = 5,
    Reduced = 6,
    Cutting = 7,
    /// A force fault latched the feed hold.
    Faulted = 8,
    /// The job ended (or was dropped after it started).
    Ended = 9,
}

impl ForcePhase {
    pub const ALL: [ForcePhase; 10] = [
        ForcePhase::None,
        ForcePhase::Armed,
        ForcePhase::Tare,
        ForcePhase::Air,
        ForcePhase::ContactSlow,
        ForcePhase::ContactStop,
        ForcePhase::Reduced,
        ForcePhase::Cutting,
        ForcePhase::Faulted,
        ForcePhase::Ended,
    ];

    /// The phase a `Status::force_phase` byte names (`None` for an unknown byte).
    pub fn from_u8(b: u8) -> ForcePhase {
        ForcePhase::ALL.get(b as usize).copied().unwrap_or(ForcePhase::None)
    }

    pub const fn name(self) -> &'static str {
        match self {
            ForcePhase::None => "none",
            ForcePhase::Armed => "armed",
            ForcePhase::Tare => "tare",
            ForcePhase::Air => "air",
            ForcePhase::ContactSlow => "contact_slow",
            ForcePhase::ContactStop => "contact_stop",
            ForcePhase::Reduced => "reduced",
            ForcePhase::Cutting => "cutting",
            ForcePhase::Faulted => "faulted",
            ForcePhase::Ended => "ended",
        }
    }
}
