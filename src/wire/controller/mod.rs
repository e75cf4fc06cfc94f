//! Runs a wire job on the DDA with wire-stall recovery and the wire power output.
//!
//! On a debounced stall the controller cuts the wire power, holds the feed, and once the DDA
//! reports `Held` aborts it (positions stay exactly what was stepped). It then retraces the
//! executed path backwards, one recorded piece at a time (each as a rest-to-rest segment over
//! the piece's own duration and ramp), until the stall clears or the retraced distance would
//! pass the limit (fault [`FaultCode::WireStall`]). A stall that clears in the middle of a
//! retrace piece holds and aborts again there. Then the power comes back on and the controller
//! replays the retraced pieces forward to the stall point, finishes the interrupted segment and
//! continues the job at a reduced feed override. Every target is an absolute step position, so
//! no step is lost however often it stops. E-stop aborts at once and cuts the power.
//!
//! Split by rate: [`WireController::tick`] is the timer-interrupt part (debounce, e-stop, hold,
//! the DDA tick, completions: integer adds and compares, no division); [`WireController::feed`]
//! is the feeder-task part (segment preparation, abort bookkeeping and retrace planning, which
//! divide in [`Preparer::prepare`] and [`Dda::positions`](crate::dda::Dda::positions)), called whenever the DDA has room or
//! the controller changed phase.

mod feed;
mod recovery;
mod setup_and_status;
mod tick;
mod wire_controller;

pub use wire_controller::WireController;

use super::history::{History, Piece, Replay};
use super::job::JobSegment;
use crate::config::MAX_AXES;
use crate::dda::{Preparer, READY_DEPTH};
use crate::machine::debounce::Debouncer;
use crate::protocol::errors::FaultCode;
use crate::segment::Rate;
use heapless::Deque;

/// Stall handling parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StallParams {
    /// Consecutive ticks the switch must agree before a change counts.
    pub debounce_ticks: u16,
    /// Largest retraced distance, sum of absolute steps over the four axes.
    pub retrace_limit_steps: u64,
    /// Feed override while retracing (the thesis retraced at the cutting feed).
    pub retrace_override: Rate,
    /// Feed override from the return until `resume_segments` job segments have completed.
    pub resume_override: Rate,
    pub resume_segments: u32,
}

/// Where the controller is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Feeding job segments.
    Running,
    /// Stall seen: holding, waiting for `Held` to abort.
    Stopping,
    /// Running backwards along the history.
    Retracing,
    /// The stall cleared in the middle of a retrace piece: holding there.
    RetraceStopping,
    /// Replaying the retraced pieces and the interrupted segment's rest.
    Returning,
    /// The job is complete.
    Done,
    /// Stopped for good with this fault; wire power off.
    Faulted(FaultCode),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Job segment with its table index.
    Job(u32),
    Retrace,
    Return,
}

/// A segment handed to the DDA and not completed yet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Flight {
    kind: Kind,
    piece: Piece,
}

/// Tag bit of recovery segments (job segments carry their table index).
pub const RECOVERY_ID: u32 = 1 << 31;

/// Counters for reports and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StallStats {
    pub stalls: u32,
    pub retrace_segments: u32,
    pub return_segments: u32,
    /// Retrace pieces left in the middle because the stall cleared.
    pub retrace_interrupts: u32,
    /// Largest retraced distance of one stall, L1 steps.
    pub max_retrace_steps: u64,
    /// Tick of the first stall detection and of the first return to `Running` after it.
    pub first_stall_tick: u64,
    pub first_resume_tick: u64,
}

/// Where the controller reads the job's segments: a constant table ([`JobSegment`] slices, the
/// scenarios) or the link's streamed window ([`super::link_job::WireQueue`]). Segment `k` is the
/// `k`th of the job; the controller asks again for a segment it fed but did not start (after a
/// stall), so a stream must keep every segment from the oldest one not yet completed
/// ([`WireCore::oldest_needed`]). Cheap and division-free: asked from the tick.
pub trait JobTable {
    /// Segment `k`, if it is here (a stream may not have received it yet).
    fn segment(&self, k: usize) -> Option<JobSegment>;
    /// The job has no segment `k` and never will: it has `k` or fewer segments.
    fn ended(&self, k: usize) -> bool;
}

impl JobTable for [JobSegment] {
    #[inline]
    fn segment(&self, k: usize) -> Option<JobSegment> {
        self.get(k).copied()
    }

    #[inline]
    fn ended(&self, k: usize) -> bool {
        k >= self.len()
    }
}

/// The retrace controller without its DDA and job: the DDA is the caller's (the link
/// firmware's `Motion` resource, or [`WireController`]'s own), the job any [`JobTable`].
#[derive(Clone, Debug)]
pub struct WireCore {
    prep: Preparer,
    next_job: usize,
    in_flight: Deque<Flight, { READY_DEPTH + 2 }>,
    /// End of the last segment handed to the DDA (the position once it is idle).
    pos: [i32; 4],
    history: History,
    replay: Replay,
    stall_in: Debouncer,
    stalled: bool,
    phase: Phase,
    wire_on: bool,
    params: StallParams,
    done_seen: u32,
    retraced_steps: u64,
    resume_left: u32,
    recovery_ids: u32,
    stats: StallStats,
}

fn pos4(p: [i64; MAX_AXES]) -> [i32; 4] {
    // Wire positions stay within +-2^31 steps (a few metres of travel); saturate otherwise.
    p[..4].iter().enumerate().fold([0; 4], |mut a, (i, &v)| {
        a[i] = v.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        a
    })
}

fn add(a: [i32; 4], b: [i32; 4]) -> [i32; 4] {
    [
        a[0].wrapping_add(b[0]),
        a[1].wrapping_add(b[1]),
        a[2].wrapping_add(b[2]),
        a[3].wrapping_add(b[3]),
    ]
}

#[cfg(test)]
mod tests;
