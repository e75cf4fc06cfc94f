//! Streaming to the board: segments as credits allow, the spindle and coolant, pauses and dwells
//! once the motion before them is done, and Hold, Resume or Start to match the sender's wishes.

use super::{link_err, Bridge, Pending};
use crate::grbl::pipeline::Out;
use crate::runner::seq_at_or_after;
use anyhow::Result;
use motion::machine::MachineState;
use motion::protocol::{ProgramOutputs, RequestBody, SegmentBatch, MAX_SEGMENTS_PER_FRAME};
use std::time::{Duration, Instant};

impl Bridge<'_> {
    /// Everything sent has run and the board is still.
    pub(super) fn drained(&self) -> bool {
        !self.pending.values().any(|p| matches!(p, Pending::Batch { .. }))
            && self.acked >= self.sent
            && self.done() >= self.acked
            && self.latest.queue_depth == 0
            && !matches!(self.latest.machine, MachineState::Running | MachineState::Holding)
    }

    /// Spindle and coolant, pause and dwell events once the motion before them is done; a
    /// probe move armed then, and its result taken once it has ended (the segments its trip
    /// dropped never complete, so that end is the probe's to tell).
    pub(super) fn front_events(&mut self) -> Result<()> {
        while let Some(&front) = self.motion.out.front() {
            match front {
                Out::Segment(_) => break,
                Out::ProbeEnd => {
                    if !self.probe_ended()? {
                        break;
                    }
                }
                _ if !self.drained() => break,
                Out::Probe(kind) => {
                    if !self.arm_probe(kind)? {
                        break;
                    }
                }
                Out::Outputs(to) => {
                    self.motion.out.pop_front();
                    self.switch_outputs(to)?;
                }
                Out::Pause => {
                    // Cycle start takes it off the queue.
                    self.paused = true;
                    break;
                }
                Out::Dwell(s) => {
                    let until = *self.dwell_until.get_or_insert_with(|| {
                        let s = if s.is_finite() { s.clamp(0.0, 1e6) } else { 0.0 };
                        Instant::now() + Duration::from_secs_f64(s)
                    });
                    if Instant::now() < until {
                        break;
                    }
                    self.dwell_until = None;
                    self.motion.out.pop_front();
                }
            }
        }
        Ok(())
    }

    /// Switches the board's spindle and coolant (`SetProgramOutputs`) and reads its status back
    /// (the report's `A:` field shows what the board drives). A refusal (an e-stop latched) is
    /// said on stderr; the fault itself becomes the alarm.
    pub(super) fn switch_outputs(&mut self, to: ProgramOutputs) -> Result<()> {
        let now = ProgramOutputs::from_bits(self.latest.outputs);
        if to == now {
            return Ok(());
        }
        let words = crate::outputs::describe_change(now, to);
        match crate::outputs::switch(&mut self.s, to).map_err(link_err)? {
            Ok(_) => eprintln!("motionctl: {words}"),
            Err(e) => eprintln!("motionctl: {words}: {e}"),
        }
        self.refresh()
    }

    pub(super) fn send_segments(&mut self) -> Result<()> {
        while self.s.host.window_free() > 0 {
            let credits = self.s.host.segment_credits() as usize;
            let room = credits.min(MAX_SEGMENTS_PER_FRAME);
            let mut batch = SegmentBatch::default();
            while batch.len() < room {
                let Some(Out::Segment(seg)) = self.motion.out.front().copied() else { break };
                if batch.push(seg).is_err() {
                    break;
                }
                self.motion.out.pop_front();
                self.inflight.push_back(seg.duration_ticks);
            }
            if batch.is_empty() {
                break;
            }
            let n = batch.len() as u32;
            let seq = self.s.send(RequestBody::QueueSegments(batch)).map_err(link_err)?;
            self.pending.insert(seq, Pending::Batch { n });
            self.sent += n;
        }
        Ok(())
    }

    /// Hold, Resume or Start as the sender's wishes and the board's state say.
    pub(super) fn reconcile(&mut self) -> Result<()> {
        if self.pending.values().any(|p| matches!(p, Pending::Control)) {
            return Ok(());
        }
        if self.control_seq.is_some_and(|c| !seq_at_or_after(self.latest.next_seq, c + 1)) {
            return Ok(());
        }
        let want_hold = self.hold || self.paused || self.door || self.spindle_holds();
        let body = match self.latest.machine {
            MachineState::Running if want_hold => RequestBody::Hold,
            MachineState::Holding if !want_hold => RequestBody::Resume,
            MachineState::Ready
                if !want_hold && self.latest.queue_depth > 0 && self.probe_allows_start() =>
            {
                RequestBody::Start
            }
            _ => return Ok(()),
        };
        let start = body == RequestBody::Start;
        let seq = self.s.send(body).map_err(link_err)?;
        self.pending.insert(seq, Pending::Control);
        self.control_seq = Some(seq);
        if start {
            self.probe_started(seq);
        }
        Ok(())
    }
}
