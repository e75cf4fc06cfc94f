//! Probe moves (G38.2..G38.5) in a run, each a job step of its own: once the motion before it is
//! done the board is armed (`ArmProbe`), the probe move's segments are queued and started alone,
//! and when the board is back in `Ready` its latched trip position and where the axes came to
//! rest go back to the job's source ([`super::outputs::OutputSource::probed`]), which plans the
//! rest from there. The board drops what was left of the move after a trip: those segments are
//! never done, and the order hash is checked over the ones that were.

//!
//! The pieces the grbl bridge's probe step shares are free functions here: reading how a probe
//! move ended from the board's status ([`probe_ended_as`], [`probe_outcome`]) and setting a
//! simulated board's probe surface ([`set_sim_probe`]).

use super::board::{ask, seq_at_or_after};
use super::options::SimProbe;
use super::report::{err, ProbeOutcome, Probed, RunError};
use super::stream::{query, Probing, Stream};
use crate::link::Session;
use crate::plan::Output;
use motion::machine::{MachineState, ProbeKind, ProbePhase};
use motion::protocol::{RequestBody, SimProbeSurface, SimRequest, Status};
use motion::segment::order_hash;
use motion::MAX_AXES;

/// How the probe move started by the `Start` sent as `start_seq` ended, from a status of the
/// board: `Ok(None)` while it has not (the status is older than the `Start`, the board is not
/// back in `Ready` with an empty queue, or the move is still armed or moving), `Ok(Some(tripped))`
/// once it has, `Err(phase)` when the board ended it some other way (refused, dropped).
pub fn probe_ended_as(st: &Status, start_seq: u32) -> Result<Option<bool>, ProbePhase> {
    let after_start = seq_at_or_after(st.next_seq, start_seq.wrapping_add(1));
    if !after_start || st.machine != MachineState::Ready || st.queue_depth != 0 {
        return Ok(None);
    }
    match ProbePhase::from_u8(st.probe_phase) {
        ProbePhase::Tripped => Ok(Some(true)),
        ProbePhase::Missed => Ok(Some(false)),
        ProbePhase::Armed | ProbePhase::Moving => Ok(None),
        other => Err(other),
    }
}

/// Where a probe move that ended as `tripped` latched and left the first `n_axes` axes, steps
/// from `origin` (a run's starting positions; zeros for the board's own machine positions).
pub fn probe_outcome(
    st: &Status,
    origin: &[i64; MAX_AXES],
    n_axes: usize,
    tripped: bool,
) -> ProbeOutcome {
    let mut outcome =
        ProbeOutcome { tripped, trip_steps: [0; MAX_AXES], rest_steps: [0; MAX_AXES] };
    for (i, o) in origin.iter().enumerate().take(n_axes) {
        outcome.trip_steps[i] = st.probe_steps[i] - o;
        outcome.rest_steps[i] = st.positions[i] - o;
    }
    outcome
}

/// Sets a simulated board's probe surface (`--sim-probe`): `sim.at_mm` counts from
/// `origin_steps` (a run's starting positions; zeros for machine coordinates). The error says
/// what is wrong (no such axis, a board that is not simulated).
pub fn set_sim_probe(
    s: &mut Session,
    sim: SimProbe,
    origin_steps: &[i64; MAX_AXES],
    steps_per_mm: &[f64],
) -> Result<(), String> {
    let Some(spm) = steps_per_mm.get(sim.axis).copied() else {
        return Err(format!("--sim-probe: the machine has no axis {}", sim.axis));
    };
    let at_steps = origin_steps[sim.axis] + (sim.at_mm * spm).round() as i64;
    let surface = SimProbeSurface { axis: sim.axis as u8, at_steps, below: sim.below };
    ask(s, RequestBody::Sim(SimRequest::Probe { surface: Some(surface) }), "Sim(Probe)")
        .map(drop)
        .map_err(|e| format!("--sim-probe needs a simulated board (--sim or --qemu): {e}"))
}

impl Stream<'_, '_> {
    /// Arms the board for a probe move once everything before it is done and the board is at
    /// rest; true once armed.
    pub(super) fn arm_probe(
        &mut self,
        kind: ProbeKind,
        line: Option<usize>,
    ) -> Result<bool, RunError> {
        if self.latest.machine != MachineState::Ready || self.latest.queue_depth != 0 {
            return Ok(false);
        }
        let at = self.outputs.at(line);
        query(&mut self.s, RequestBody::ArmProbe(kind), "ArmProbe")
            .map_err(|e| err(format!("{at}{} probe move: {e}", kind.gcode())))?;
        self.say(&format!("{at}{} probe move", kind.gcode()));
        self.probing = Some(Probing {
            kind,
            line,
            done_at_arm: self.job_done(&self.latest),
            hash_at_arm: self.report.expected_hash,
            ids: Vec::new(),
            start_seq: None,
        });
        self.outputs.advance();
        Ok(true)
    }

    /// Whether the run may send `Start` now: not while a probe move's segments are still being
    /// queued (it starts once, with all of them), nor again once it has started.
    pub(super) fn probe_allows_start(&mut self) -> Result<bool, RunError> {
        if self.probing.as_ref().is_none_or(|p| p.start_seq.is_some()) {
            return Ok(self.probing.is_none());
        }
        let all_queued = matches!(self.peek()?, Some((Output::ProbeEnd, _)));
        let Some(p) = &self.probing else { return Ok(true) };
        if !all_queued && self.s.host.segment_credits() == 0 && self.report.acked == self.sent_segs
        {
            let at = self.outputs.at(p.line);
            return Err(err(format!(
                "{at}{} probe move: more segments than the board's queue holds ({} queued)",
                p.kind.gcode(),
                p.ids.len()
            )));
        }
        Ok(all_queued && self.report.acked == self.sent_segs)
    }

    /// `Start` of a probe move was sent as `seq`.
    pub(super) fn probe_started(&mut self, seq: u32) {
        if let Some(p) = self.probing.as_mut() {
            p.start_seq = Some(seq);
        }
    }

    /// The probe move's end ([`Output::ProbeEnd`]): once the board is back in `Ready`, its result
    /// goes to the job's source. True once taken.
    pub(super) fn probe_ended(&mut self) -> Result<bool, RunError> {
        let Some(p) = &self.probing else {
            return Err(err("a probe move's end without its start (a planner bug)"));
        };
        let Some(start) = p.start_seq else { return Ok(false) };
        let st = &self.latest;
        let at = self.outputs.at(p.line);
        let tripped = match probe_ended_as(st, start) {
            Ok(Some(tripped)) => tripped,
            Ok(None) => return Ok(false),
            Err(other) => {
                return Err(err(format!(
                    "{at}{} probe move: the board ended it as {other:?}",
                    p.kind.gcode()
                )))
            }
        };
        let outcome = probe_outcome(st, &self.base.positions, self.n_axes, tripped);
        // The segments done during the probe move are its first ones, in order; the rest were
        // dropped at the trip and never will be.
        let done = self.job_done(st).saturating_sub(p.done_at_arm) as usize;
        let done = done.min(p.ids.len());
        self.report.expected_hash =
            p.ids[..done].iter().fold(p.hash_at_arm, |h, &id| order_hash(h, id));
        self.dropped += (p.ids.len() - done) as u32;
        // The rest of the job is planned from where the axes came to rest.
        self.path.reanchor(st.positions, self.sent_segs);
        let (kind, line) = (p.kind, p.line);
        self.outputs.probed(&outcome).map_err(|e| err(format!("{at}{e}")))?;
        self.say(&format!("{at}{} probe move {}", kind.gcode(), self.describe_probe(&outcome)));
        self.report.probes.push(Probed { line, kind, outcome });
        self.probing = None;
        self.outputs.advance();
        Ok(true)
    }

    fn describe_probe(&self, o: &ProbeOutcome) -> String {
        let mm = |steps: &[i64; MAX_AXES]| {
            let v: Vec<String> = self
                .axes
                .iter()
                .enumerate()
                .map(|(i, (name, spm))| format!("{name} {:.4}", steps[i] as f64 / spm))
                .collect();
            v.join(" ")
        };
        if o.tripped {
            format!(
                "tripped at {} mm, stopped at {} mm (from the job's origin)",
                mm(&o.trip_steps),
                mm(&o.rest_steps)
            )
        } else {
            format!("ended without a trip at {} mm", mm(&o.rest_steps))
        }
    }

    /// A fault during a probe move names the move: the file, its line and the G-code word.
    pub(super) fn probe_context(&self) -> String {
        match &self.probing {
            Some(p) => format!("{}{} probe move: ", self.outputs.at(p.line), p.kind.gcode()),
            None => String::new(),
        }
    }

    /// The simulated probe surface, set on the board before the job (`run --sim-probe`).
    pub(super) fn set_sim_probe(
        &mut self,
        sim: SimProbe,
        steps_per_mm: &[f64],
    ) -> Result<(), RunError> {
        set_sim_probe(&mut self.s, sim, &self.base.positions, steps_per_mm).map_err(err)
    }
}
