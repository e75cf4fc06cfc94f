//! G38.2..G38.5 probe moves, as grbl runs them: the block's answer waits (no further line is
//! taken) until the probe move has ended; the motion before it completes, the board is armed
//! (`ArmProbe`), the probe move's segments are queued and started alone, and once the board is
//! back in `Ready` its latched trip position (read as `motionctl run` reads it,
//! [`runner::probe_ended_as`]) goes out as `[PRB:x,y,z:1]` (machine coordinates; `:0` without
//! contact) before the block's `ok`, is kept for `$#`, and becomes the parser's position: the
//! program goes on from where the axes came to rest. G38.2/G38.4 without contact is the board's
//! `ProbeFail` fault: `ALARM:5`, then `[PRB:...:0]` and the `ok`, as grbl answers.

use super::{Bridge, Pending};
use crate::grbl::pipeline::Out;
use crate::grbl::protocol::alarm;
use crate::job::Feed;
use crate::runner;
use anyhow::Result;
use motion::machine::{ProbeKind, ProbePhase};
use motion::protocol::RequestBody;
use motion::MAX_AXES;

/// A probe move on its way.
#[derive(Debug)]
pub(super) struct ProbeStep {
    kind: ProbeKind,
    /// `ArmProbe` answered; the seq of the `Start` that runs it, once sent.
    armed: bool,
    start_seq: Option<u32>,
    /// What the block answers (`ok`, a startup line's `>LINE:ok`), said after the result.
    answer: Option<String>,
}

/// The last probe result (grbl's probe position, shown by `$#`): machine mm per machine axis,
/// and whether the probe made contact.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct LastProbe {
    pub mm: Vec<f64>,
    pub tripped: bool,
}

impl LastProbe {
    pub(super) fn none(axes: usize) -> Self {
        LastProbe { mm: vec![0.0; axes], tripped: false }
    }
}

impl Bridge<'_> {
    /// A probe move of a block: queued behind the motion before it (or, in check mode, only
    /// followed: the interpreter takes it as no contact at the programmed end, as grbl's check
    /// mode puts the position at the target). `None` when queued, else grbl's error number.
    pub(super) fn queue_probe(
        &mut self,
        kind: ProbeKind,
        target: &[Option<f64>],
        feed: Feed,
    ) -> Option<u8> {
        if let Feed::MmPerMin(f) = feed {
            self.feed_now = f;
        }
        let queued = if self.check {
            self.motion.push_move(target, feed, true)
        } else {
            self.motion.push_probe(target, feed, kind)
        };
        if let Err(e) = queued {
            return Some(self.refuse_move(e));
        }
        if !self.check {
            self.probe = Some(ProbeStep { kind, armed: false, start_seq: None, answer: None });
        }
        None
    }

    /// A block's answer: said now, or kept until its probe move has ended.
    pub(super) fn answer(&mut self, text: String) {
        match self.probe.as_mut() {
            Some(p) if p.answer.is_none() => p.answer = Some(text),
            _ => self.say(&text),
        }
    }

    /// [`Out::Probe`] at the front with everything before it done: arms the board. False while
    /// it waits (the board not at rest yet).
    pub(super) fn arm_probe(&mut self, kind: ProbeKind) -> Result<bool> {
        if self.latest.machine != motion::machine::MachineState::Ready {
            return Ok(false);
        }
        if let Err(e) = self.request(RequestBody::ArmProbe(kind), "ArmProbe") {
            self.probe_refused(&format!("{} probe move: {e}", kind.gcode()))?;
            return Ok(false);
        }
        eprintln!("motionctl: {} probe move", kind.gcode());
        if let Some(p) = self.probe.as_mut() {
            p.armed = true;
        }
        self.motion.out.pop_front();
        Ok(true)
    }

    /// Whether a `Start` may go now: not while an armed probe move's segments are still on
    /// their way (it starts once, with all of them), nor again once it has started.
    pub(super) fn probe_allows_start(&self) -> bool {
        match &self.probe {
            Some(p) if p.armed => {
                p.start_seq.is_none()
                    && matches!(self.motion.out.front(), Some(Out::ProbeEnd))
                    && self.acked == self.sent
                    && !self.pending.values().any(|p| matches!(p, Pending::Batch { .. }))
            }
            _ => true,
        }
    }

    /// The `Start` sent as `seq` runs the armed probe move.
    pub(super) fn probe_started(&mut self, seq: u32) {
        if let Some(p) = self.probe.as_mut().filter(|p| p.armed) {
            p.start_seq = Some(seq);
        }
    }

    /// An armed probe move whose segments cannot all be queued (the board's queue is full with
    /// the move's first ones and cannot run them before the rest): refused with an alarm.
    pub(super) fn probe_check_room(&mut self) -> Result<()> {
        let stuck = self.probe.as_ref().is_some_and(|p| p.armed && p.start_seq.is_none())
            && matches!(self.motion.out.front(), Some(Out::Segment(_)))
            && self.s.host.segment_credits() == 0
            && self.acked == self.sent
            && !self.pending.values().any(|p| matches!(p, Pending::Batch { .. }));
        if stuck {
            let m = format!(
                "probe move: more segments than the board's queue holds ({} queued)",
                self.sent
            );
            self.probe_refused(&m)?;
        }
        Ok(())
    }

    /// [`Out::ProbeEnd`] at the front: once the board has ended the probe move, its result.
    /// False while it runs.
    pub(super) fn probe_ended(&mut self) -> Result<bool> {
        let Some(start) = self.probe.as_ref().and_then(|p| p.start_seq) else {
            return Ok(false);
        };
        let tripped = match runner::probe_ended_as(&self.latest, start) {
            Ok(Some(t)) => t,
            Ok(None) => return Ok(false),
            Err(phase) => {
                let m = format!("probe move: the board ended it as {}", phase.name());
                self.probe_refused(&m)?;
                return Ok(false);
            }
        };
        let o = runner::probe_outcome(&self.latest, &[0; MAX_AXES], self.spm.len(), tripped);
        let mm = |steps: &[i64; MAX_AXES]| -> Vec<f64> {
            self.spm.iter().zip(steps).map(|(spm, s)| *s as f64 / spm).collect()
        };
        let (trip_mm, rest_mm) = (mm(&o.trip_steps), mm(&o.rest_steps));
        // The segments the trip dropped never complete: every segment sent is done or dropped
        // (all were acknowledged before the start, and the board's queue is empty), so counting
        // starts again here.
        self.base_done = self.latest.segments_done;
        (self.sent, self.acked, self.popped) = (0, 0, 0);
        self.inflight.clear();
        self.motion.out.pop_front();
        self.motion.moved_to(&self.latest.positions);
        self.prog.probed(tripped, &trip_mm, &rest_mm);
        // grbl's probe position: where it latched, or where a move without contact ended.
        self.last_probe = LastProbe { mm: if tripped { trip_mm } else { rest_mm }, tripped };
        let kind = self.probe.as_ref().map(|p| p.kind.gcode()).unwrap_or("G38");
        eprintln!("motionctl: {kind} probe move: {}", self.prb_line());
        self.end_probe(true);
        Ok(true)
    }

    /// A fault ended the probe move (the board dropped its queue): grbl's answer after the
    /// alarm, `[PRB:...:0]` for a move that found no contact (G38.2, G38.4: `ProbeFail`), then
    /// the block's `ok`.
    pub(super) fn probe_faulted(&mut self) {
        if self.probe.is_none() {
            return;
        }
        let missed = ProbePhase::from_u8(self.latest.probe_phase) == ProbePhase::Missed;
        if missed {
            self.last_probe.tripped = false;
        }
        self.end_probe(missed);
    }

    /// The probe move is over: its `[PRB:]` line if `report`, then the block's answer.
    pub(super) fn end_probe(&mut self, report: bool) {
        let Some(p) = self.probe.take() else { return };
        if report {
            let l = self.prb_line();
            self.say(&l);
        }
        if let Some(a) = p.answer {
            self.say(&a);
        }
    }

    /// The board would not run the probe move: an alarm naming why, and the block's answer;
    /// what is queued stops.
    fn probe_refused(&mut self, why: &str) -> Result<()> {
        eprintln!("motionctl: {why}");
        self.alarm = Some(alarm::ABORT_CYCLE);
        self.say(&format!("ALARM:{}", alarm::ABORT_CYCLE));
        self.say(&format!("[MSG:{why}]"));
        self.end_probe(false);
        self.stop_motion()
    }

    /// `[PRB:x,y,z:1]`: the last probe result, machine coordinates (inches with `$13=1`).
    pub(super) fn prb_line(&self) -> String {
        let p = &self.last_probe;
        format!("[PRB:{}:{}]", self.axes_text(&p.mm), p.tripped as u8)
    }

    /// Values per machine axis as grbl prints them: mm with 3 decimals, or inches with 4.
    pub(super) fn axes_text(&self, mm: &[f64]) -> String {
        let inches = self.settings.flag(crate::grbl::settings::REPORT_INCHES);
        mm.iter()
            .map(|&x| if inches { format!("{:.4}", x / 25.4) } else { format!("{x:.3}") })
            .collect::<Vec<_>>()
            .join(",")
    }
}
