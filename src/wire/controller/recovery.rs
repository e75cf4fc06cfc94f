//! A stall's recovery steps for [`WireCore`]: stop where the DDA stands, retrace the history
//! backwards, and return along the retraced pieces (feeder task).

use super::{pos4, JobTable, Kind, Phase, WireCore};
use crate::dda::{Command, Dda};
use crate::protocol::errors::FaultCode;
use crate::segment::{Rate, SegmentError};
use crate::wire::history::{l1_steps, sub, Piece};

impl WireCore {
    /// After a hold: abort where the DDA stands and book the interrupted segment: its executed
    /// part joins the history, its rest goes on the replay stack; unstarted job segments are
    /// fed again later from the table.
    pub(super) fn stop_here(&mut self, dda: &mut Dda) -> bool {
        let p = pos4(dda.positions());
        dda.abort();
        self.prep.reset_junction();
        self.done_seen = dda.segments_done();
        let mut ok = true;
        if let Some(f) = self.in_flight.pop_front() {
            if let Kind::Job(k) = f.kind {
                self.next_job = k as usize + 1;
            }
            match f.kind {
                Kind::Job(_) | Kind::Return => {
                    // Executed part (all of it when stopped exactly at its end) and the rest.
                    self.history.push(f.piece.part(f.piece.start, p));
                    ok = self.replay.push(f.piece.part(p, f.piece.end));
                }
                // Its piece is on the replay stack already.
                Kind::Retrace => {}
            }
        }
        self.in_flight.clear();
        self.pos = p;
        if !ok {
            self.fault(dda, FaultCode::WireStall);
        }
        ok
    }

    pub(super) fn retrace_next(&mut self, dda: &mut Dda) -> Result<(), SegmentError> {
        let Some(h) = self.history.pop() else {
            self.fault(dda, FaultCode::WireStall);
            return Ok(());
        };
        let d = l1_steps(sub(h.start, self.pos));
        if self.retraced_steps + d > self.params.retrace_limit_steps || !self.replay.push(h) {
            self.fault(dda, FaultCode::WireStall);
            return Ok(());
        }
        self.retraced_steps += d;
        self.stats.max_retrace_steps = self.stats.max_retrace_steps.max(self.retraced_steps);
        // Backwards: to the piece's start.
        let back = Piece { start: h.end, end: h.start, ..h };
        if self.push_recovery(dda, Kind::Retrace, back)? {
            self.stats.retrace_segments += 1;
        }
        Ok(())
    }

    pub(super) fn start_return(&mut self, dda: &mut Dda) {
        self.wire_on = true;
        dda.apply(Command::CapabilityOverride(self.params.resume_override));
    }

    pub(super) fn return_next<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
    ) -> Result<(), SegmentError> {
        while let Some(r) = self.replay.pop() {
            if self.push_recovery(dda, Kind::Return, r)? {
                self.stats.return_segments += 1;
                return Ok(());
            }
        }
        self.phase = Phase::Running;
        self.resume_left = self.params.resume_segments;
        if self.stats.first_resume_tick == 0 {
            self.stats.first_resume_tick = dda.now();
        }
        if self.resume_left == 0 {
            dda.apply(Command::CapabilityOverride(Rate::ONE));
        }
        self.feed_job(dda, job)
    }
}
