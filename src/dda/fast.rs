//! The DDA's fast runs: ticks whose outcome apart from the lanes is known for a stretch, run
//! without [`Dda::full_tick`]'s commands, gates, ramp decisions and edge ring.
//!
//! A run is entered after a moving full tick ([`Dda::try_fast_run`]) when no gate is open, no
//! hold is asked, the rate is at most 1.0 (so at most one virtual tick passes per tick) and
//! pulses last one tick. It does exactly what the full tick would do on each of its ticks; what
//! it leaves out of date (`now`, `remaining`, the budget, `rate_sq`, the edge ring) is brought
//! up to date on leaving ([`Dda::leave_fast`]). Three kinds ([`FastRun`]):
//! - **cruise**: the rate is settled at its target and stays there;
//! - **accelerate**: the rate rises by `dr` every tick towards its target. The run is bounded
//!   on entry so that it never reaches the target and never meets the deceleration point;
//! - **track**: the rate follows the deceleration budget as [`Dda::update_rate`] does: down by
//!   `dr` on a tick that finds `rate_sq >= budget`, else up by `dr` towards its target. In a
//!   deceleration the two alternate (the budget falls by `2 dr` per virtual tick, in steps, and
//!   `rate_sq` by about as much, smoothly), so the choice is made every tick, from the virtual
//!   ticks the run counts.
//!
//! The entry bounds use reciprocals the [`Preparer`](super::Preparer) worked out, so nothing
//! here divides.

use super::*;

/// What a fast run does to the rate on each tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FastRun {
    /// The rate stays where it is.
    Cruise,
    /// The rate rises by the segment's `dr` each tick.
    Accelerate,
    /// The rate follows the deceleration budget, between the floor and the target.
    Track,
}

/// Cruises and climbs shorter than this are tracked instead ([`Dda::try_fast_run`]).
const MIN_PLAIN_RUN: u64 = 8;

/// A run's kind and lane count together: [`Dda::tick`] dispatches on one byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RunFn {
    CruiseNarrow,
    CruiseWide,
    AccelerateNarrow,
    AccelerateWide,
    TrackNarrow,
    TrackWide,
}

impl RunFn {
    fn of(run: FastRun, wide: bool) -> Self {
        match (run, wide) {
            (FastRun::Cruise, false) => RunFn::CruiseNarrow,
            (FastRun::Cruise, true) => RunFn::CruiseWide,
            (FastRun::Accelerate, false) => RunFn::AccelerateNarrow,
            (FastRun::Accelerate, true) => RunFn::AccelerateWide,
            (FastRun::Track, false) => RunFn::TrackNarrow,
            (FastRun::Track, true) => RunFn::TrackWide,
        }
    }

    /// The kind of run.
    fn kind(self) -> FastRun {
        match self {
            RunFn::CruiseNarrow | RunFn::CruiseWide => FastRun::Cruise,
            RunFn::AccelerateNarrow | RunFn::AccelerateWide => FastRun::Accelerate,
            RunFn::TrackNarrow | RunFn::TrackWide => FastRun::Track,
        }
    }
}

/// One tick of a fast run at `rate` on its registers: `phase`, kept less ONE (wrapping: the add
/// carries exactly when a virtual tick is due), and `hist`, the last ticks' rises, a byte each.
/// `Err((fall, rise))`: a step due too soon, which [`Dda::cruise_too_soon`] finishes (`hist` is
/// left as it was, `phase` has taken the tick).
#[inline(always)]
pub(super) fn run_step<const WIDE: bool>(
    lanes: &mut Lanes,
    minus_t: u32,
    dir: u32,
    rate: u32,
    phase: &mut u32,
    hist: &mut u32,
) -> Result<StepOutput, (u8, u8)> {
    let h = *hist;
    // One-tick pulses: what rose last tick (the low byte) falls now.
    let fall = h & 0xff;
    let (p, vtick) = phase.overflowing_add(rate);
    if !vtick {
        *phase = p;
        *hist = h << 8;
        return Ok(StepOutput::falling(fall, dir));
    }
    *phase = p.wrapping_sub(ONE);
    let rise = lanes::step(lanes, WIDE, minus_t);
    // `rise` has no bits past the low byte, so this is `rise & fall`.
    if rise & h != 0 {
        return Err((fall as u8, rise as u8));
    }
    *hist = (h << 8) | rise;
    Ok(StepOutput::falling(fall, dir).with_rise(rise))
}

impl Dda {
    /// A cruise tick: the rate is settled. Out of line (as are the ramps): the idle path stays
    /// free of the register saves the lane kernel needs. One instance per lane count (`WIDE`:
    /// six lanes), picked on entering the run.
    #[inline(never)]
    pub(super) fn cruise_tick<const WIDE: bool>(&mut self) -> StepOutput {
        self.run_tick::<WIDE>(self.rate)
    }

    /// An accelerating tick: the run was bounded on entry, so `rate + dr` is what
    /// [`Dda::update_rate`] would give.
    #[inline(never)]
    pub(super) fn accelerate_tick<const WIDE: bool>(&mut self) -> StepOutput {
        let rate = self.rate + self.dr;
        self.rate = rate;
        self.run_tick::<WIDE>(rate)
    }

    /// A tracking tick (see [`Dda::track_step`]).
    #[inline(never)]
    pub(super) fn track_tick<const WIDE: bool>(&mut self) -> StepOutput {
        match self.track_step::<WIDE>() {
            Some(step) => step,
            None => self.track_ends(),
        }
    }

    /// [`Dda::update_rate`]'s choice with the budget as the virtual ticks counted so far left
    /// it, for a rate that stays within `[floor, target]` (checked on entry, with
    /// `floor <= target`, which makes the choice exactly this), and the tick at that rate.
    /// `None`: the tick would bring the segment's last virtual tick, which is the full tick's
    /// (it ends the segment): nothing was changed, [`Dda::track_ends`] runs it.
    #[inline(always)]
    pub(super) fn track_step<const WIDE: bool>(&mut self) -> Option<StepOutput> {
        let rate = self.rate;
        let rate_sq = (rate as u64 * rate as u64) >> RATE_FRAC_BITS;
        // `two_dr` < 2^32: a 32x32 multiply.
        let spent = self.run_vticks as u64 * (self.two_dr as u32) as u64;
        let new_rate = if rate_sq + spent >= self.budget {
            rate.saturating_sub(self.dr).max(self.floor)
        } else {
            (rate + self.dr).min(self.run_target)
        };
        let vtick = self.phase.overflowing_add(new_rate).1;
        if vtick && self.run_vticks + 1 >= self.remaining {
            return None;
        }
        self.rate = new_rate;
        // Counted before the tick: a step due too soon leaves the run with it.
        self.run_vticks += vtick as u32;
        Some(self.run_tick::<WIDE>(new_rate))
    }

    /// The tick a tracking run hands to the full tick ([`Dda::track_step`]'s `None`).
    #[cold]
    #[inline(never)]
    pub(super) fn track_ends(&mut self) -> StepOutput {
        self.cruise_ticks += 1;
        self.leave_fast();
        self.full_tick()
    }

    /// One tick of a run at `rate` ([`run_step`] on the DDA's own registers).
    #[inline(always)]
    fn run_tick<const WIDE: bool>(&mut self, rate: u32) -> StepOutput {
        let (mut phase, mut hist) = (self.phase, self.hist);
        let step = run_step::<WIDE>(
            &mut self.lanes,
            self.minus_t,
            self.cruise_dir,
            rate,
            &mut phase,
            &mut hist,
        );
        self.phase = phase;
        self.hist = hist;
        match step {
            Ok(step) => step,
            Err((fall, rise)) => self.cruise_too_soon(fall, rise),
        }
    }

    /// Virtual ticks the current run has done (the current tick's included while it runs).
    pub(super) fn cruise_vticks(&self) -> u32 {
        let e = self.cruise_elapsed() as u64;
        let rate0 = self.run_rate0 as u64;
        // Tick k of the run (k = 1..=e) adds its rate to the phase.
        let sum = match self.run_fn.kind() {
            FastRun::Cruise => e * rate0,
            // rate0 + k dr each; the rate stays <= ONE, so the sum stays below e * 2^30.
            FastRun::Accelerate => e * rate0 + self.dr as u64 * (e * (e + 1) / 2),
            FastRun::Track => return self.run_vticks,
        };
        ((self.cruise_phase as u64 + sum) >> RATE_FRAC_BITS) as u32
    }

    /// A step due while the axis's last pulse is still too close: finished as the full tick
    /// would (held back, released when allowed).
    #[cold]
    #[inline(never)]
    pub(super) fn cruise_too_soon(&mut self, fall: u8, rise: u8) -> StepOutput {
        // This tick's edges are settled below, in the rebuilt ring.
        self.hist <<= 8;
        self.leave_fast();
        let slot = (self.now & RING_MASK) as usize;
        self.settle_edges(slot, fall, rise, rise & fall)
    }

    /// Ticks the current run has done (the current one included while it runs).
    pub(super) fn cruise_elapsed(&self) -> u32 {
        self.cruise_len - self.cruise_ticks
    }

    /// `rate_sq` as the full tick keeps it (a run leaves it out of date).
    pub(super) fn live_rate_sq(&self) -> u64 {
        if self.cruise_len != 0 {
            (self.rate as u64 * self.rate as u64) >> RATE_FRAC_BITS
        } else {
            self.rate_sq
        }
    }

    /// Leaves a fast path; after a run, brings `now`, `remaining`, the budget, `rate_sq` and
    /// the edge ring up to date. The ring gets the last [`HIST_TICKS`] ticks from `hist` and
    /// zeros before them: with one-tick pulses and at most [`HIST_TICKS`] ticks of DIR hold,
    /// nothing reads further back (see [`Dda::try_fast_run`]).
    #[inline]
    pub(super) fn leave_fast(&mut self) {
        if self.cruise_len != 0 {
            let vticks = self.cruise_vticks();
            self.remaining -= vticks;
            self.budget -= vticks as u64 * self.two_dr;
            self.rate_sq = (self.rate as u64 * self.rate as u64) >> RATE_FRAC_BITS;
            self.now += self.cruise_elapsed() as u64;
            self.phase = self.phase.wrapping_add(ONE);
            self.ring = [0; TIMING_RING_TICKS as usize];
            for back in 0..HIST_TICKS {
                self.ring[(self.now.wrapping_sub(back as u64) & RING_MASK) as usize] =
                    (self.hist >> (8 * back)) as u8;
            }
            self.cruise_len = 0;
            self.cruise_ticks = 0;
        }
        self.idle_ticks = 0;
    }

    pub(super) fn ticks_until_command(&self) -> u32 {
        self.next_due.saturating_sub(self.now + 1).min(u32::MAX as u64) as u32
    }

    /// After an idle full tick: idle ticks output nothing at all until a command is due or a
    /// segment is pushed, once no pulse is still in flight.
    #[cold]
    #[inline(never)]
    pub(super) fn try_idle(&mut self) {
        let until_command = self.ticks_until_command();
        if self.cruise_enabled && until_command != 0 && self.ring.iter().all(|&r| r == 0) {
            self.idle_ticks = until_command;
        }
    }

    /// After a moving full tick: a fast run while the rate's course is known for a number of
    /// ticks. Each kind stays a tick short of the segment's last virtual tick (at most one
    /// passes per tick), which the full tick handles, and ends before the next command.
    #[cold]
    #[inline(never)]
    pub(super) fn try_fast_run(&mut self) {
        if !self.cruise_enabled || self.remaining == 0 {
            return;
        }
        if self.rate > ONE || self.gated != 0 || self.holding {
            return;
        }
        if self.timing.pulse_ticks != 1 || self.timing.hold_ticks > HIST_TICKS {
            return;
        }
        let target = self.ovr.min(self.cap);
        let rate = self.rate;
        if rate > target || rate < self.floor {
            return;
        }
        // A cruise or climb that would end within a few ticks is tracked instead (a few more
        // instructions per tick, against a full tick every few ticks): up to the end of the
        // segment when the deceleration point is near, else until the target is reached, after
        // which a cruise can begin.
        let (run, n) = if self.rate_sq >= self.budget {
            (FastRun::Track, u64::MAX)
        } else if rate == target {
            // Virtual ticks before rate_sq >= budget could hold: floor((budget - rate_sq) / 2dr).
            let n = self.over_two_dr(self.budget - self.rate_sq);
            if n < MIN_PLAIN_RUN {
                (FastRun::Track, u64::MAX)
            } else {
                (FastRun::Cruise, n)
            }
        } else {
            // Rising to the target (at most ONE) without reaching it: (target - rate) / dr
            // ticks. And short of the deceleration point: after m ticks rate_sq has grown by at
            // most 1 + m * two_dr (the rate stays <= ONE) and the budget has shrunk by at most
            // m * two_dr, so rate_sq < budget holds on every tick while
            // rate_sq + 1 + 2 m two_dr < budget.
            let to_target = self.dr_steps(target.min(ONE) - rate);
            let slack = self.budget.saturating_sub(self.rate_sq + 2);
            let to_budget = self.over_two_dr(slack) / 2 + 1;
            if to_budget < MIN_PLAIN_RUN {
                (FastRun::Track, u64::MAX)
            } else if to_target < MIN_PLAIN_RUN {
                (FastRun::Track, MIN_PLAIN_RUN)
            } else {
                (FastRun::Accelerate, to_target.min(to_budget))
            }
        };
        // Tracking may rise to the target: at most one virtual tick per tick there too.
        if run == FastRun::Track && target > ONE {
            return;
        }
        // At most one virtual tick per tick: n - 1 ticks stay short of the segment's last
        // one. A tracking run counts them and hands the last one to the full tick instead.
        let n = if run == FastRun::Track && n == u64::MAX {
            u32::MAX as u64
        } else {
            n.min(self.remaining as u64)
        };
        let ticks = n.saturating_sub(1).min(self.ticks_until_command() as u64) as u32;
        if ticks == 0 {
            return;
        }
        self.run_fn = RunFn::of(run, self.wide);
        self.run_rate0 = rate;
        self.run_target = target;
        self.run_vticks = 0;
        self.cruise_len = ticks;
        self.cruise_ticks = ticks;
        self.cruise_phase = self.phase;
        self.phase = self.phase.wrapping_sub(ONE);
        self.cruise_dir = StepOutput::dir_bits(self.dir);
        self.hist = 0;
        for back in (0..HIST_TICKS).rev() {
            let rise = self.ring[(self.now.wrapping_sub(back as u64) & RING_MASK) as usize];
            self.hist = (self.hist << 8) | rise as u32;
        }
    }

    /// floor(x / 2dr) or less, from the reciprocal (x < 2^64).
    fn over_two_dr(&self, x: u64) -> u64 {
        let inv = self.inv_two_dr as u64;
        (x >> 32) * inv + (((x & 0xffff_ffff) * inv) >> 32)
    }

    /// Whole `dr` steps in `x` (a rate difference, < 2^32), or fewer: floor(x / dr) from below.
    fn dr_steps(&self, x: u32) -> u64 {
        (x as u64 * self.inv_two_dr as u64) >> 31
    }

    /// The kind of fast run the ticks are taking (`None`: full or idle ticks).
    pub fn fast_run(&self) -> Option<FastRun> {
        (self.cruise_ticks != 0).then_some(self.run_fn.kind())
    }
}
