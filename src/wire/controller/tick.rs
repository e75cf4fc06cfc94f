//! The timer-interrupt part of [`WireCore`]: debounce, e-stop, hold, the DDA tick, completions,
//! and whether the feeder has work. Integer adds and compares, no division.

use super::{JobTable, Kind, Phase, WireCore};
use crate::dda::{Command, Dda, MotionState, StepOutput};
use crate::protocol::errors::FaultCode;
use crate::segment::Rate;

impl WireCore {
    /// Timer interrupt: samples the inputs, reacts to e-stop and stall, ticks the DDA and books
    /// completed segments. Bounded, integer only, no division.
    #[inline]
    pub fn tick<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
        stall_raw: bool,
        estop_raw: bool,
    ) -> StepOutput {
        if estop_raw && !matches!(self.phase, Phase::Faulted(_)) {
            self.fault(dda, FaultCode::EStop);
        }
        self.stalled = self.stall_in.update(stall_raw);
        match self.phase {
            Phase::Running | Phase::Returning if self.stalled => {
                self.wire_on = false;
                dda.apply(Command::Hold);
                self.phase = Phase::Stopping;
                if self.stats.stalls == 0 {
                    self.stats.first_stall_tick = dda.now();
                }
                self.stats.stalls += 1;
            }
            Phase::Retracing if !self.stalled && dda.state() == MotionState::Moving => {
                dda.apply(Command::Hold);
                self.phase = Phase::RetraceStopping;
                self.stats.retrace_interrupts += 1;
            }
            _ => {}
        }
        let out = dda.tick();
        while self.done_seen != dda.segments_done() {
            self.done_seen = dda.segments_done();
            self.complete_front(dda);
            let job_done = job.ended(self.next_job) && self.in_flight.is_empty();
            if self.phase == Phase::Running && job_done && dda.is_idle() {
                self.phase = Phase::Done;
            }
        }
        out
    }

    #[cold]
    pub(super) fn complete_front(&mut self, dda: &mut Dda) {
        let Some(f) = self.in_flight.pop_front() else {
            return;
        };
        match f.kind {
            Kind::Job(_) => {
                self.history.push(f.piece);
                if self.resume_left > 0 {
                    self.resume_left -= 1;
                    if self.resume_left == 0 {
                        dda.apply(Command::CapabilityOverride(Rate::ONE));
                    }
                }
            }
            Kind::Return => self.history.push(f.piece),
            Kind::Retrace => {}
        }
    }

    pub(super) fn fault(&mut self, dda: &mut Dda, code: FaultCode) {
        dda.abort();
        self.in_flight.clear();
        self.done_seen = dda.segments_done();
        self.wire_on = false;
        self.phase = Phase::Faulted(code);
    }

    /// True when [`WireCore::feed`] has work: a free DDA slot and a job segment to fill it, or a
    /// stop, retrace or return step due. Cheap and division-free: the timer interrupt asks it
    /// every tick and hands `feed` to the feeder task only when it is true.
    pub fn wants_feed<J: JobTable + ?Sized>(&self, dda: &Dda, job: &J) -> bool {
        let settled = self.in_flight.is_empty() && dda.is_idle();
        match self.phase {
            Phase::Running => {
                (dda.ready_free() > 0
                    && !self.in_flight.is_full()
                    && job.segment(self.next_job).is_some())
                    || (job.ended(self.next_job) && settled)
            }
            Phase::Stopping | Phase::RetraceStopping => {
                matches!(dda.state(), MotionState::Held | MotionState::Idle)
            }
            Phase::Retracing | Phase::Returning => settled,
            Phase::Done | Phase::Faulted(_) => false,
        }
    }
}
