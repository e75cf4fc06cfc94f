//! Where a tick's steps come from: the [`StepSource`] trait, the DDA's own ([`DdaSource`]), and
//! the tag a capability's source job runs under ([`SourceJob`]).

use crate::dda::{Dda, StepOutput};

/// Where a tick's steps come from: the DDA ([`DdaSource`], segment jobs) or a recorded
/// capability's source job (a step-event playback, a Z slide, a wire job; [`SourceJob`]). The machine runs
/// either through the same tick ([`Machine::tick_with`](super::Machine::tick_with)): fault
/// inputs, e-stop freeze, step counters, soft limits and job end are the same code for both.
pub trait StepSource {
    /// One tick's pins. The source ticks `dda` itself (an event source ticks the idle DDA too,
    /// for its clock and feed commands). `hold`: a feed hold or a hold reaction is in force (the
    /// DDA decelerates on its own; an event source stops its clock). Interrupt rate: integer
    /// work only, bounded, no division.
    fn tick(&mut self, dda: &mut Dda, hold: bool) -> StepOutput;
    /// Nothing left to step: the job is done once the machine sees this while `Running`.
    fn idle(&self, dda: &Dda) -> bool;
    /// Ran dry before its end (a late host): raises `QueueUnderrun`. The DDA reports its own
    /// underruns through `Dda::underruns`, hence the default.
    fn starved(&self) -> bool {
        false
    }
    /// The machine may run this source's ticks as step-only ones between full ticks
    /// ([`Machine::fast_tick_with`](super::Machine::fast_tick_with)): the source drives nothing
    /// but its pins on each tick, and its end, and faults it passes to the machine, may be seen
    /// up to [`SUPERVISE_TICKS`](super::SUPERVISE_TICKS)` - 1` ticks later.
    fn step_only_ticks(&self) -> bool {
        false
    }
    /// How many step-only ticks a full tick grants, at most `max` (the machine's own period):
    /// a source whose ticks differ in cost may take fewer, so that the full tick ending the run
    /// falls on one of its cheap ticks and the two costs never add up in one interrupt.
    fn step_only_run(&self, max: u8) -> u8 {
        max
    }
}

/// Which source job runs: a tag the capability that owns the job chooses (each capability lists
/// its tags in its `motion::capability` entry, and the registry checks that no two share one).
/// The machine runs every source job by the same rules and only keeps the tag, so that the
/// application ticks the owner's source; it never names a capability.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SourceJob(pub u8);

/// The DDA as a [`StepSource`]: what [`Machine::tick`](super::Machine::tick) runs.
#[derive(Clone, Copy, Debug, Default)]
pub struct DdaSource;

impl StepSource for DdaSource {
    #[inline(always)]
    fn tick(&mut self, dda: &mut Dda, _hold: bool) -> StepOutput {
        dda.tick()
    }

    #[inline(always)]
    fn idle(&self, dda: &Dda) -> bool {
        dda.is_idle()
    }

    fn step_only_ticks(&self) -> bool {
        true
    }
}
