//! The step-only tick: while nothing but the job's stepping has work, most ticks only step.
//!
//! A full tick ([`Machine::tick`]) reads and debounces the inputs, watches the faults, applies
//! holds, keeps the job's books and leaves the outputs. While all of that is quiet -- inputs
//! released and steady, no fault cause, no pending hold or resume, no homing, jog or starve, no
//! probe move, no source job unless its step source allows step-only ticks
//! ([`StepSource::step_only_ticks`]: a playback, a wire job and a Z job with step outputs do;
//! a force job is a plain job to the machine) -- the next [`SUPERVISE_TICKS`]` - 1` ticks can be
//! [`Machine::fast_tick`]s: the job's step source, the step counters (`pending.rs`; a run is
//! never longer than every axis's room to its soft limits), nothing else. The board skips reading its inputs on those ticks too. A
//! full tick then comes round at least every [`SUPERVISE_TICKS`] ticks ([`supervise_ticks`]: the
//! same 80 us at a faster tick, up to [`MAX_SUPERVISE_TICKS`]), and at once after any command,
//! fault, output change or background work (each sets the count to 0).
//!
//! What that costs in reaction time, at the 100 kHz default tick: a limit switch or sensor fault
//! is seen at most `SUPERVISE_TICKS - 1` ticks (70 us) later, against a 2 ms switch debounce; the
//! e-stop's own interrupt has already cut the step drivers, and the board takes a full tick as
//! soon as it has fired. Soft limits still hold on every step: near one the runs shorten, down to full ticks. The job bookkeeping runs on
//! every full tick in this mode, so it keeps its [`JOB_WATCH_TICKS`] period and the starve margin.
//!
//! A board whose ticks cannot all afford a full one (a streamed step output's fill at 500 kHz)
//! runs full ticks on at most every [`STREAM_SAMPLE_STRIDE`]-th tick while the machine is not
//! quiet, and [`Machine::held_tick`]s between: the DDA and the step counters with the soft
//! limits checked on every step, nothing when frozen. The inputs are then sampled every
//! [`STREAM_SAMPLE_STRIDE`] ticks and the switch debounce counts those samples
//! ([`Machine::set_sample_stride`]); homing, probing and jog-off see their switch up to that
//! many ticks later (10 us at 500 kHz).

use super::pending::PendingSteps;
use super::{DdaSource, Inputs, Machine, StepSource, JOB_WATCH_TICKS};
use crate::dda::{Dda, StepOutput, TickSink};
use crate::machine::MachineState;

/// [`Machine::fast_fill`]'s sink: the step counters and the direction, `sense`, then the
/// board's sink.
struct Counting<'a, S, K> {
    pending: PendingSteps,
    dir: u8,
    sense: S,
    sink: &'a mut K,
}

impl<W, S: FnMut(), K: TickSink<W>> TickSink<W> for Counting<'_, S, K> {
    #[inline(always)]
    fn put(&mut self, slot: &mut W, step: StepOutput) {
        (self.sense)();
        self.dir = step.dir();
        // No soft-limit check: the run granted stays inside them (`arm_fast`).
        if step.rise() != 0 {
            self.pending.add(step.rise(), self.dir);
        }
        self.sink.put(slot, step);
    }
}

/// Ticks from one full tick to the next while the machine is quiet, at the default tick (the
/// job bookkeeping's period, so that a quiet job is watched as often as a busy one).
pub const SUPERVISE_TICKS: u8 = JOB_WATCH_TICKS;

/// The supervision period in time: [`SUPERVISE_TICKS`] at the default 100 kHz tick (80 us). A
/// faster tick (a streamed step output's slot clock) keeps the period, not the count, up to
/// [`MAX_SUPERVISE_TICKS`]: the full tick's cost is then spread over more slots.
pub const SUPERVISE_HZ: u32 = 12_500;

/// The longest run between full ticks: the job bookkeeping must come round well inside the
/// starve margin (at most two virtual ticks pass per tick; 2 x 24 = 48 of 64).
pub const MAX_SUPERVISE_TICKS: u8 = 24;

/// Ticks from one full tick to the next while the machine is quiet at `tick_hz`: one
/// [`SUPERVISE_HZ`] period, at least [`SUPERVISE_TICKS`], at most [`MAX_SUPERVISE_TICKS`].
pub const fn supervise_ticks(tick_hz: u32) -> u8 {
    let n = tick_hz / SUPERVISE_HZ;
    if n < SUPERVISE_TICKS as u32 {
        SUPERVISE_TICKS
    } else if n > MAX_SUPERVISE_TICKS as u32 {
        MAX_SUPERVISE_TICKS
    } else {
        n as u8
    }
}

/// A streamed step output's fill runs a full tick on at most every this many slots while the
/// machine is not quiet ([`Machine::held_tick`] between): 8 full ticks of a 40-slot fill, whose
/// cost (700 to 900 cycles each) and the held ticks' then fit a half at a 500 kHz slot clock,
/// where a full tick on every slot does not. Inputs are then sampled every 10 us.
pub const STREAM_SAMPLE_STRIDE: u8 = 5;

const _: () = assert!(2 * MAX_SUPERVISE_TICKS as u32 <= super::STARVE_MARGIN_VTICKS * 3 / 4);
const _: () = assert!(STREAM_SAMPLE_STRIDE <= MAX_SUPERVISE_TICKS);
// A run's steps fit the step counters' byte lanes (`pending.rs`): at most one per tick.
const _: () = assert!((MAX_SUPERVISE_TICKS as u32) < 256);

impl Machine {
    /// A step-only tick, if the last full tick found everything quiet and fewer than
    /// [`SUPERVISE_TICKS`] ticks have passed since: the DDA and the step counters.
    /// `None`: run [`Machine::tick`] (or `tick_with`) instead. Interrupt rate: a few
    /// compares and adds beside the DDA tick.
    #[inline(always)]
    pub fn fast_tick(&mut self, dda: &mut Dda) -> Option<StepOutput> {
        self.fast_tick_with(dda, &mut DdaSource)
    }

    /// [`Machine::fast_tick`] with the steps from `source`, the job's own (a Z job whose
    /// [`StepSource::step_only_ticks`] allows it): only the source's tick, the step counters
    /// and the soft limits. The job's end is then seen on the next full tick.
    #[inline(always)]
    pub fn fast_tick_with(
        &mut self,
        dda: &mut Dda,
        source: &mut impl StepSource,
    ) -> Option<StepOutput> {
        self.fast_tick_sensing(dda, source, || {})
    }

    /// [`Machine::fast_tick_with`] that runs `sense` (the board's reading of a sensor it reads
    /// once per tick, the spindle's) first, and only if the tick is granted: on `None` the full
    /// tick that runs instead reads it, so no tick reads it twice. No check beyond the one
    /// [`Machine::fast_tick`] makes.
    #[inline(always)]
    pub fn fast_tick_sensing(
        &mut self,
        dda: &mut Dda,
        source: &mut impl StepSource,
        sense: impl FnOnce(),
    ) -> Option<StepOutput> {
        if self.fast_left == 0 {
            return None;
        }
        sense();
        self.fast_left -= 1;
        self.ticks += 1;
        let step = source.tick(dda, self.paused);
        self.last_dir = step.dir();
        // No soft-limit check: the run granted stays inside them (`arm_fast`).
        if step.rise() != 0 {
            self.pending.add(step.rise(), step.dir());
        }
        Some(step)
    }

    /// [`Machine::fast_tick`] on as many of `out`'s slots in a row as the machine grants, in
    /// one call (a streamed step output's fill): each tick's output put in its slot by `sink`,
    /// `sense` once per tick; the count done (0: none granted, a full tick is due). The same
    /// ticks as one `fast_tick` per slot, but the DDA runs them a fast run at a time
    /// ([`Dda::ticks_into`]).
    #[inline(always)]
    pub fn fast_fill<W>(
        &mut self,
        dda: &mut Dda,
        out: &mut [W],
        sense: impl FnMut(),
        sink: &mut impl TickSink<W>,
    ) -> usize {
        let n = out.len().min(self.fast_left as usize);
        if n == 0 {
            return 0;
        }
        self.fast_left -= n as u8;
        self.ticks += n as u64;
        let mut counting = Counting { pending: self.pending, dir: self.last_dir, sense, sink };
        dda.ticks_into(&mut out[..n], &mut counting);
        (self.pending, self.last_dir) = (counting.pending, counting.dir);
        n
    }

    /// For a board that runs a full tick on at most every `stride`-th tick and
    /// [`Machine::held_tick`]s between them (a streamed step output's fill, whose slots cannot
    /// all afford one): the input filter's debounce is counted in those samples from now on.
    pub fn set_sample_stride(&mut self, stride: u8) {
        self.sample_stride = stride.max(1);
        let cfg = self.cfg;
        self.set_filter_ticks(&cfg);
    }

    /// A tick between two full ticks of a board that runs them only every
    /// [`Machine::set_sample_stride`] ticks, when no step-only run was granted: the DDA and the
    /// step counters, with the soft limits checked on every step as the full tick does. The
    /// inputs, holds and the state's watches (homing, probing, jog-off, the job's books) wait
    /// for the next full tick, at most `stride - 1` ticks away; a frozen machine steps nothing.
    /// A plain job's ticks only (the DDA's steps): a capability's job takes full ticks.
    #[inline]
    pub fn held_tick(&mut self, dda: &mut Dda) -> StepOutput {
        self.ticks += 1;
        if self.frozen {
            return StepOutput::new(0, 0, self.last_dir, 0);
        }
        // The soft-limit check reads `raw`: the step-only ticks' lanes go in first.
        self.pending.fold_into(&mut self.raw);
        let step = DdaSource.tick(dda, self.paused);
        self.last_dir = step.dir();
        if step.rise() != 0 {
            self.count(step);
        }
        step
    }

    /// The next tick may be a step-only one ([`Machine::fast_tick`] would step): a board that
    /// reads a sensor for the source first (the Z job's spindle) reads it only then.
    #[inline(always)]
    pub fn step_only_due(&self) -> bool {
        self.fast_left != 0
    }

    /// End of a full tick: grants the next [`supervise_ticks`]` - 1` ticks (or the fewer the
    /// source takes) to [`Machine::fast_tick`] when nothing but the DDA has work. `raw`: this tick's inputs
    /// before the debounce.
    /// `source`: the job's step source, which may refuse step-only ticks
    /// ([`StepSource::step_only_ticks`]) or shorten their run ([`StepSource::step_only_run`]).
    #[inline]
    pub(super) fn arm_fast(&mut self, raw: &Inputs, source: &impl StepSource) {
        let source_ok = source.step_only_ticks();
        // The machine's own state first: a capability job (every tick of one comes here) is
        // told apart by a few flag tests, before the inputs are looked at.
        let machine_quiet = !(self.starved || self.probe.watching())
            && (source_ok || self.source.is_none())
            && self.active == 0
            && !(self.frozen || self.abort_pending || self.hold_pending || self.resume_pending)
            && self.jog.is_none()
            && matches!(
                self.state,
                MachineState::Idle
                    | MachineState::Ready
                    | MachineState::Running
                    | MachineState::Holding
            );
        let quiet = machine_quiet
            && raw.limit_min | raw.limit_max == 0
            && !raw.estop
            && raw.sensor_faults == 0
            && raw.link_ok
            && !raw.tick_overrun
            && raw.probe == self.switch_filter.probe_level()
            && self.switch_filter.quiet();
        if quiet {
            let mut run = self.supervise_ticks - 1;
            // Soft limits armed: no longer than every axis stays inside them, one step a tick.
            if self.homed && self.state != MachineState::Homing {
                run = self.limit_room_left(run);
            } else {
                self.limit_room = 0;
            }
            self.fast_left = source.step_only_run(run);
            // The full tick that ends this run keeps the job's books.
            self.job_watch_in = 1;
        } else {
            self.fast_left = 0;
        }
    }

    /// Ticks, at most `want`, that every axis stays inside its soft limits at one step a tick:
    /// what is left of the last [`pending::room`](super::pending::room) (ticks since counted
    /// off), worked out again only when that is less than `want`.
    #[inline]
    fn limit_room_left(&mut self, want: u8) -> u8 {
        let mut left = self.limit_room.saturating_sub(self.ticks.wrapping_sub(self.room_since));
        if left < want as u64 {
            let (min, max) = (&self.raw_limits.min_steps, &self.raw_limits.max_steps);
            let axes = self.cfg.link.machine.axis_count as usize;
            self.limit_room = super::pending::room(&self.raw, min, max, axes);
            self.room_since = self.ticks;
            left = self.limit_room;
        }
        left.min(want as u64) as u8
    }
}

#[cfg(test)]
mod tests;
