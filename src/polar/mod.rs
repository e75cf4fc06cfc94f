//! Polar contouring (Fahim 1983): timed single-axis step events on a (theta, r) machine.
//!
//! [`stream`] is the versioned binary event format shared by the host encoder and the firmware
//! decoder; [`playback`] fires decoded events from the DDA tick with speed and size scaling;
//! [`copy`] is the template-digitizer copy mode with teach recording; [`scenario`] plays the
//! built-in [`limacon_stream`] as a closed-loop scenario.

pub mod copy;
pub mod copy_link;
pub mod feed;
pub mod job;
pub mod limacon_stream;
pub mod link_messages;
pub mod playback;
pub mod scenario;
pub mod stream;

use crate::capability::Capability;
use crate::machine::SourceJob;

/// A playback of recorded step events (`StartPlayback`).
pub const PLAYBACK_JOB: SourceJob = SourceJob(1);
/// A copy job: steps from the template digitizer's encoder counts (`StartCopy`).
pub const COPY_JOB: SourceJob = SourceJob(2);

/// Polar contouring's registry entry.
pub const CAPABILITY: Capability = Capability {
    name: "polar",
    title: "polar contouring (Fahim 1983): timed step events on an (r, theta) machine, played \
            back with speed and size scaling, and template copying",
    hello_bits: crate::protocol::CAP_EVENTS | crate::protocol::CAP_COPY_JOB,
    jobs: &[PLAYBACK_JOB, COPY_JOB],
    faults: &[],
};

/// Axis index of the arm angle (theta) in step masks.
pub const AXIS_THETA: u8 = 0;
/// Axis index of the carriage radius (r) in step masks.
pub const AXIS_R: u8 = 1;

/// One recorded single-axis step: wait `dt_ticks` after the previous event, then step `axis`
/// (0 = theta, 1 = r) one resolution, negative when `negative` is set. `dt_ticks == 0` means
/// "simultaneous with the previous event".
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct StepEvent {
    pub dt_ticks: u32,
    pub axis: u8,
    pub negative: bool,
}

impl StepEvent {
    /// The 2-bit code the stream carries: bit 0 = axis, bit 1 = negative.
    #[inline]
    pub const fn code(&self) -> u8 {
        (self.axis & 1) | ((self.negative as u8) << 1)
    }

    #[inline]
    pub const fn from_code(dt_ticks: u32, code: u8) -> Self {
        StepEvent { dt_ticks, axis: code & 1, negative: code & 2 != 0 }
    }

    /// The step as a signed count: -1 or +1.
    #[inline]
    pub const fn signed(&self) -> i32 {
        if self.negative {
            -1
        } else {
            1
        }
    }
}
