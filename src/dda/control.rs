//! The DDA from the tasks' side: feed commands, scheduled commands, the ready queue, abort and
//! the figures the machine and Status read. Not interrupt-rate code except where noted.

use super::*;

impl Dda {
    /// Applies a feed command; it acts on the next tick.
    pub fn apply(&mut self, cmd: Command) {
        self.leave_fast();
        match cmd {
            Command::SetOverride(r) => self.ovr = self.arbiter.set(OverrideSource::Operator, r),
            Command::CapabilityOverride(r) => {
                self.ovr = self.arbiter.set(OverrideSource::Capability, r)
            }
            Command::Hold => self.holding = true,
            Command::Resume => self.holding = false,
        }
    }

    /// Applies `cmd` on tick `at` (on the next tick if `at` has passed). Commands scheduled for the
    /// same tick apply in the order they were scheduled.
    pub fn schedule(&mut self, at: u64, cmd: Command) -> Result<(), Command> {
        self.leave_fast();
        self.scheduled.push((at, cmd)).map_err(|(_, c)| c)?;
        self.next_due = self.next_due.min(at);
        Ok(())
    }

    /// Room for prepared segments.
    /// The running segment has no successor in the ready queue, and only just enough of it is
    /// left (plus `margin_vticks`) to ramp from the current rate to a stop within it: a feed
    /// hold issued now ends on the path instead of at the segment's end at its exit rate.
    /// Multiplies and compares only (the machine's tick asks it while the host is late).
    #[inline]
    pub fn stop_due(&self, margin_vticks: u32) -> bool {
        if self.remaining == 0 || !self.ready.is_empty() {
            return false;
        }
        // During a cruise the budget is only brought up to date on leaving it.
        let budget = if self.cruise_len != 0 {
            self.budget.saturating_sub(self.cruise_vticks() as u64 * self.two_dr)
        } else {
            self.budget
        };
        let exit_sq = (self.seg_exit as u64 * self.seg_exit as u64) >> RATE_FRAC_BITS;
        // budget = exit^2 + 2 dr * left; stopping from `rate` takes rate^2 / (2 dr) of `left`.
        self.live_rate_sq() + exit_sq + margin_vticks as u64 * self.two_dr >= budget
    }

    pub fn ready_free(&self) -> usize {
        READY_DEPTH - self.ready.len()
    }

    /// Queues a copy of a prepared segment; when full, the caller still holds it.
    pub fn push(&mut self, seg: &Prepared) -> Result<(), QueueFull> {
        self.idle_ticks = 0;
        self.ready.push_back(*seg).map_err(|_| QueueFull)
    }

    /// Stops at once (no deceleration) and drops every queued segment. Steps not yet on the pins
    /// are discarded, so the positions stay exactly what was stepped.
    pub fn abort(&mut self) {
        self.leave_fast();
        self.origin = self.positions();
        self.pending = [0; MAX_AXES];
        self.gated = 0;
        self.remaining = 0;
        self.ready.clear();
        self.scheduled.clear();
        self.next_due = u64::MAX;
        self.rate = 0;
        self.rate_sq = 0;
        self.phase = 0;
        self.holding = false;
    }

    /// Position of every axis in steps, counting only steps that reached the pins. Take it in
    /// the same critical section as [`Dda::now`] for a consistent snapshot.
    pub fn positions(&self) -> [i64; MAX_AXES] {
        let mut pos = self.origin;
        let remaining = if self.cruise_len != 0 {
            self.remaining - self.cruise_vticks()
        } else {
            self.remaining
        };
        if remaining != 0 {
            let done = (self.t - remaining) as u64;
            for (i, lane) in self.lanes.iter().enumerate() {
                let d = lane.d as u64;
                let s = ((done * d + self.h as u64) / self.t as u64) as i64;
                pos[i] += if self.seg_dir & (1 << i) != 0 { -s } else { s };
            }
        }
        for (p, pending) in pos.iter_mut().zip(self.pending) {
            *p -= pending as i64;
        }
        pos
    }

    /// Ticks run so far.
    pub fn now(&self) -> u64 {
        if self.cruise_len != 0 {
            self.now + self.cruise_elapsed() as u64
        } else {
            self.now
        }
    }

    pub fn state(&self) -> MotionState {
        let busy = self.remaining != 0 || !self.ready.is_empty() || self.gated != 0;
        match (busy, self.holding, self.rate) {
            (false, _, _) => MotionState::Idle,
            (true, true, 0) => MotionState::Held,
            (true, true, _) => MotionState::Stopping,
            (true, false, _) => MotionState::Moving,
        }
    }

    pub fn is_idle(&self) -> bool {
        self.state() == MotionState::Idle
    }

    /// Current virtual-clock rate in the active segment's units (1.0 = planned feed).
    pub fn rate(&self) -> Rate {
        Rate::from_bits(self.rate)
    }

    /// The override the DDA runs at: the operator's factor times the capability's.
    pub fn feed_override(&self) -> Rate {
        Rate::from_bits(self.ovr)
    }

    /// One source's own factor (the operator's is what a sender's override shows).
    pub fn override_factor(&self, source: OverrideSource) -> Rate {
        self.arbiter.factor(source)
    }

    pub fn segments_done(&self) -> u32 {
        self.segments_done
    }

    pub fn last_done_id(&self) -> Option<u32> {
        self.last_done_id
    }

    /// [`order_hash`] over the ids of every completed segment, in order.
    pub fn done_hash(&self) -> u32 {
        self.done_hash
    }

    /// Segments that ended at speed with nothing queued behind them (an abrupt stop).
    pub fn underruns(&self) -> u32 {
        self.underruns
    }

    /// Steps held back by DIR timing or pulse spacing and released later (never lost).
    pub fn deferred_steps(&self) -> u32 {
        self.deferred_steps
    }

    /// True while ticks take a fast run (cruise or ramp, [`Dda::fast_run`]).
    pub fn in_cruise(&self) -> bool {
        self.cruise_ticks != 0
    }

    /// Runs every tick through the full path. The fast runs must be indistinguishable
    /// from it; tests compare the two.
    pub fn disable_cruise_path(&mut self) {
        self.leave_fast();
        self.cruise_enabled = false;
    }

    pub fn timing(&self) -> &TickTiming {
        &self.timing
    }
}
