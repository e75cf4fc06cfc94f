//! The feeder-task part of [`WireCore`]: job segments to the DDA, the phase steps of a stall,
//! and the rest-to-rest recovery segments (setup-rate: the preparer divides).

use super::{add, Flight, JobTable, Kind, Phase, WireCore, RECOVERY_ID};
use crate::config::MAX_AXES;
use crate::dda::{Command, Dda, MotionState};
use crate::segment::{Rate, Segment, SegmentError};
use crate::wire::history::Piece;

impl WireCore {
    /// Feeder task: hands segments to the DDA and plans the recovery moves (divides).
    pub fn feed<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
    ) -> Result<(), SegmentError> {
        match self.phase {
            Phase::Running => self.feed_job(dda, job)?,
            Phase::Stopping | Phase::RetraceStopping => {
                let s = dda.state();
                if (s == MotionState::Held || s == MotionState::Idle) && self.stop_here(dda) {
                    self.phase = if self.phase == Phase::Stopping && self.stalled {
                        dda.apply(Command::CapabilityOverride(self.params.retrace_override));
                        self.retraced_steps = 0;
                        Phase::Retracing
                    } else {
                        self.start_return(dda);
                        Phase::Returning
                    };
                }
            }
            Phase::Retracing => {
                if self.in_flight.is_empty() && dda.is_idle() {
                    if !self.stalled {
                        self.start_return(dda);
                        self.phase = Phase::Returning;
                    } else {
                        self.retrace_next(dda)?;
                    }
                }
            }
            Phase::Returning => {
                if self.in_flight.is_empty() && dda.is_idle() {
                    self.return_next(dda, job)?;
                }
            }
            Phase::Done | Phase::Faulted(_) => {}
        }
        Ok(())
    }

    pub(super) fn feed_job<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
    ) -> Result<(), SegmentError> {
        while dda.ready_free() > 0 && !self.in_flight.is_full() {
            let Some(js) = job.segment(self.next_job) else {
                if job.ended(self.next_job) && self.in_flight.is_empty() && dda.is_idle() {
                    self.phase = Phase::Done;
                }
                return Ok(());
            };
            let mut seg = js.segment(self.next_job as u32);
            if job.ended(self.next_job + 1) {
                // A job (or a slice of one) always ends at rest.
                seg.exit_rate = Rate::ZERO;
            }
            let end = add(self.pos, js.steps);
            let piece = Piece {
                start: self.pos,
                end,
                duration_ticks: js.duration_ticks,
                accel_q30: js.accel_q30,
            };
            self.push(dda, seg, Kind::Job(self.next_job as u32), piece)?;
            self.next_job += 1;
        }
        Ok(())
    }

    pub(super) fn push(
        &mut self,
        dda: &mut Dda,
        seg: Segment,
        kind: Kind,
        piece: Piece,
    ) -> Result<(), SegmentError> {
        let p = self.prep.prepare(&seg)?;
        if dda.push(&p).is_err() || self.in_flight.push_back(Flight { kind, piece }).is_err() {
            // Callers check room first.
            return Err(SegmentError::Duration);
        }
        self.pos = piece.end;
        Ok(())
    }

    /// A rest-to-rest recovery segment from the current position to `piece.end` over the
    /// piece's duration and ramp; nothing when already there.
    pub(super) fn push_recovery(
        &mut self,
        dda: &mut Dda,
        kind: Kind,
        piece: Piece,
    ) -> Result<bool, SegmentError> {
        // Mid-piece after an interrupted retrace: only the part left, in its share of time.
        let piece = if self.pos == piece.start { piece } else { piece.part(self.pos, piece.end) };
        let d = piece.steps_to_end(self.pos);
        if d == [0; 4] {
            return Ok(false);
        }
        let mut steps = [0i32; MAX_AXES];
        steps[..4].copy_from_slice(&d);
        self.recovery_ids = self.recovery_ids.wrapping_add(1);
        let seg = Segment {
            steps,
            duration_ticks: piece.duration_ticks,
            entry_rate: Rate::ZERO,
            exit_rate: Rate::ZERO,
            accel_per_tick: Rate::from_bits(piece.accel_q30.max(1)),
            id: RECOVERY_ID | (self.recovery_ids & !RECOVERY_ID),
        };
        self.push(dda, seg, kind, piece)?;
        Ok(true)
    }
}
