//! `motionctl milling run` on a board with force jobs (`CAP_MILLING_JOB`): the milling job's move
//! (the Case A machine: one X axis, 1 um per step, 500 mm/s^2; the job's programmed feed) runs
//! as a force job through the board's force chain and control law, with the job's nominal
//! force, thresholds, gains, teeth and spindle speed.
//!
//! Hello -> the board ready (config, ConfigMissing cleared, homed) -> `Sim(Milling)` (a simulator
//! board: the job's cut, and an injected fault if asked) -> status stream -> `ArmForce` -> the
//! move -> `Start` -> the status stream logged (force, override, feed vs board time) until the
//! job ends (Ready) or a fault holds it -> checks against the host model (the same library
//! code: `motion::milling::scenario`): without a fault, the final position exact, the force back
//! within +-10 % of Fnom within 150 ms of the depth step and never above the trip level; with
//! an injected fault, the hold with that fault's code and the position the board counted.

use super::job::MillingJob;
use super::resume::MillingResume;
use crate::journal;
use crate::link::{LinkFailure, Session};
use crate::runner;
use crate::runner::{fault_names, seq_at_or_after};
use crate::transport::Transport;
use anyhow::{anyhow, bail};
use motion::machine::MachineState;
use motion::milling::link_job::{job_params, sim_params};
use motion::milling::link_messages::MillingRequest;
use motion::milling::link_params::ForcePhase;
use motion::milling::scenario as sc;
use motion::protocol::{
    AxisScale, FaultCode, HostConfig, HostEvent, LinkConfig, Reply, RequestBody, SegmentBatch,
    SimForceFault, SimRequest, Status, CAP_SIM_INPUTS,
};
use std::path::Path;
use std::time::{Duration, Instant};

/// Status period during the job (board time): the trace's resolution.
pub const STATUS_PERIOD_MS: u16 = 10;
/// Status poll interval (wall clock), also the link heartbeat.
pub const POLL_EVERY: Duration = Duration::from_millis(5);
/// A job whose board clock and position do not move for this long (wall clock) is stuck.
pub const NO_PROGRESS: Duration = Duration::from_secs(15);
/// The settling limit and band the run is judged by (the acceptance figure): at most 150 ms, or
/// the host model's settling plus [`SETTLE_SLACK_S`] for a job that settles slower.
pub const SETTLE_LIMIT_S: f64 = 0.150;
pub const SETTLE_SLACK_S: f64 = 0.050;
pub const BAND: f64 = 0.10;
/// The window after the depth step the settling is judged over (the scenario's).
pub const WINDOW_S: f64 = 0.400;
/// The feed in the trace is measured over at least this much board time, s.
pub const FEED_WINDOW_S: f64 = 0.020;
/// Penetration where an injected fault starts (the scenario's fault variants'), um.
pub const FAULT_AT_UM: u32 = 5_000;

/// How `runner::home` reports that homing ended: a resume whose board was homed by
/// `ready_board` (after a reset) does not home twice; were the message to change, it would, which
/// is safe.
const HOMED_SAYS: &str = "homed at ";

/// The journal kind of a milling run (`JOB.journal`): `milling run --resume` reads only its own.
pub const JOURNAL_KIND: &str = "milling";

/// What [`run`] needs besides the job.
#[derive(Clone, Debug)]
pub struct MillingRunOptions {
    pub host: HostConfig,
    pub home: bool,
    pub progress: bool,
    /// A fault for the simulated plant to inject 5 mm into the cut (a simulator board only).
    pub fault: SimForceFault,
}

/// One status of the job.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardPoint {
    /// Board time since the start, s.
    pub t_s: f64,
    pub force_n: f64,
    pub peak_n: f64,
    /// The DDA's feed override (what the controller wrote).
    pub override_: f64,
    /// Feed over the last status period, mm/min.
    pub feed_mm_min: f64,
    pub x_steps: i64,
    pub phase: ForcePhase,
}

/// What the run did; `problems` is empty when every check passed.
#[derive(Clone, Debug, Default)]
pub struct MillingRunReport {
    pub trace: Vec<BoardPoint>,
    pub x_steps: i64,
    pub expected_x_steps: i64,
    pub faults: u32,
    pub peak_n: f64,
    /// Board time from the depth step to the last status outside Fnom +- 10 % (400 ms window).
    pub settle_s: Option<f64>,
    /// The host model's settling (the scenario's figure), s.
    pub model_settle_s: Option<f64>,
    /// Feed 300..400 ms after the depth step, mm/min.
    pub feed_after_mm_min: Option<f64>,
    pub updates: u32,
    pub board_ticks: u64,
    pub seconds: f64,
    /// A resumed run: where it went on from, X steps from the job's start.
    pub resumed_from_steps: Option<i64>,
    pub problems: Vec<String>,
}

impl MillingRunReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }

    /// One machine-readable line for scripts (`cargo xtask milling-e2e`).
    pub fn summary_line(&self) -> String {
        let f = |v: Option<f64>| v.map_or("none".to_string(), |v| format!("{v:.4}"));
        format!(
            "milling-summary x={} expected_x={} faults={:#x} fault={} peak_n={:.0} settle_s={} \
             model_settle_s={} feed_after_mm_min={} updates={} board_ticks={} points={} ok={}",
            self.x_steps,
            self.expected_x_steps,
            self.faults,
            fault_names(self.faults).replace(", ", "+"),
            self.peak_n,
            f(self.settle_s),
            f(self.model_settle_s),
            f(self.feed_after_mm_min),
            self.updates,
            self.board_ticks,
            self.trace.len(),
            self.ok()
        )
    }
}

/// The Case A machine as the link's config: X only, 1 um per step.
pub fn link_config() -> LinkConfig {
    let scale =
        AxisScale { steps_per_unit_milli: 1_000_000, soft_min: i64::MIN, soft_max: i64::MAX };
    LinkConfig {
        machine: sc::machine(),
        scale: [scale; motion::MAX_AXES],
        inputs: motion::InputFilterConfig::DEFAULT,
    }
}

/// Judges a board trace: settling after the depth step at `step_at_steps` of X (from the
/// start), the feed 300..400 ms after it (mm/min), the peak force.
pub fn judge(
    trace: &[BoardPoint],
    fnom_n: f64,
    step_at_steps: i64,
) -> (Option<f64>, Option<f64>, f64) {
    let peak = trace.iter().map(|p| p.force_n).fold(0.0, f64::max);
    let Some(step) = trace.iter().find(|p| p.x_steps >= step_at_steps) else {
        return (None, None, peak);
    };
    let t0 = step.t_s;
    let window = trace.iter().filter(|p| p.t_s >= t0 && p.t_s - t0 <= WINDOW_S);
    let last_out = window
        .filter(|p| (p.force_n - fnom_n).abs() > BAND * fnom_n)
        .map(|p| p.t_s - t0)
        .fold(0.0, f64::max);
    let at = |dt: f64| trace.iter().find(|p| p.t_s - t0 >= dt);
    let feed = match (at(0.3), at(0.4)) {
        (Some(a), Some(b)) if b.t_s > a.t_s && b.t_s - t0 <= WINDOW_S + 0.05 => {
            Some((b.x_steps - a.x_steps) as f64 / 1e3 / (b.t_s - a.t_s) * 60.0)
        }
        _ => None,
    };
    (Some(last_out), feed, peak)
}

/// Connects, configures and runs `job` as a force job; see the module doc.
pub fn run(
    transport: &mut dyn Transport,
    job: &MillingJob,
    opts: &MillingRunOptions,
) -> anyhow::Result<MillingRunReport> {
    run_with(transport, job, opts, &mut runner::Unattended)
}

/// As [`run`], with `hook` asked every pass of the job's loop (it may hold, resume or abort the
/// job: the grbl bridge's sender does).
pub fn run_with(
    transport: &mut dyn Transport,
    job: &MillingJob,
    opts: &MillingRunOptions,
    hook: &mut dyn runner::JobHook,
) -> anyhow::Result<MillingRunReport> {
    run_resumable(transport, job, opts, None, None, hook)
}

/// As [`run_with`], keeping the job's cursor in `journal` (the position along its move, so a
/// run cut by a board reset or a power loss can go on), and from `resume` when given: the
/// spindle on, the approach, then the force job re-armed from there ([`super::resume`]).
pub fn run_resumable(
    transport: &mut dyn Transport,
    job: &MillingJob,
    opts: &MillingRunOptions,
    mut journal: Option<journal::Writer>,
    resume: Option<&MillingResume>,
    hook: &mut dyn runner::JobHook,
) -> anyhow::Result<MillingRunReport> {
    if resume.is_some() && opts.fault != SimForceFault::None {
        bail!("a resumed milling run injects no fault: run the fault case from the job's start");
    }
    let t0 = Instant::now();
    let say = |m: &str| {
        if opts.progress {
            eprintln!("motionctl: {m}");
        }
    };
    let setup = &job.setup;
    let params = job_params(&setup.control, &setup.chain, 0);
    motion::milling::link_job::check_job(&params)
        .map_err(|f| anyhow!("the milling job's force setup is out of range: {f}"))?;
    let sim = match resume {
        Some(r) => r.sim_params(job),
        None => sim_params(&setup.plant, opts.fault, FAULT_AT_UM),
    };
    let cfg = link_config();
    let tick_hz = cfg.machine.tick_hz as f64;
    // The host model: the same force code without the link (its settling, for the report).
    let (model, _) = super::simulate::run(job)?;
    let mut s = Session::new(transport, opts.host);
    let link = |e: LinkFailure| anyhow!("{e}");
    let info = s.connect().map_err(link)?;
    crate::board_link::require_capability(&info, &motion::milling::CAPABILITY)?;
    let simulated = info.capabilities & CAP_SIM_INPUTS != 0;
    if opts.fault != SimForceFault::None && !simulated {
        bail!(
            "the board ({:?}) has no simulated plant: no fault to inject",
            info.firmware.as_str()
        );
    }
    say(&format!("connected to {}: firmware {:?}", s.describe(), info.firmware.as_str()));
    let (query, status) = (runner::ask, runner::ask_status);
    // A resume homes: the journal's position counts from the job's origin, which only homing
    // brings the machine back to (a reset board does not know where it stands).
    let homed_now = std::cell::Cell::new(false);
    let watch_homing = |m: &str| {
        homed_now.set(homed_now.get() || m.starts_with(HOMED_SAYS));
        say(m)
    };
    let home = opts.home || resume.is_some();
    runner::ready_board(
        &mut s,
        cfg,
        runner::Home::allowed(home),
        "milling machine (X)",
        &watch_homing,
    )
    .map_err(|e| anyhow!("{e}"))?;
    if resume.is_some() && !homed_now.get() {
        runner::home(&mut s, cfg.machine.tick_hz, &|m| say(m)).map_err(|e| anyhow!("{e}"))?;
    }
    // The job's origin: where the homed machine stands, before any approach.
    let x0 = status(&mut s)?.positions[0];
    if let Some(r) = resume {
        say(&format!(
            "resuming at move 1 of 1, X {:.3} mm of {:.3} (the journal's cursor): homed, the \
             force loop re-armed with Fnom {:.0} N after the approach",
            r.from_mm(),
            setup.move_steps as f64 / 1e3,
            job.fnom_n
        ));
        super::resume::restore(&mut s, r, x0, cfg.machine.tick_hz, &|m| say(m))?;
    }
    if simulated {
        query(&mut s, RequestBody::Sim(SimRequest::Milling(sim)), "Sim(Milling)")?;
        say("sent the simulated plant (eq 4.17 cut)");
    }
    query(&mut s, RequestBody::SetStatusPeriod { ms: STATUS_PERIOD_MS }, "SetStatusPeriod")?;
    s.streaming = true;
    query(&mut s, RequestBody::from(MillingRequest::ArmForce(params)), "ArmForce")?;
    let seg = resume.map_or_else(|| setup.segment(), |r| r.rest);
    let batch = SegmentBatch::from_slice(&[seg]).ok_or_else(|| anyhow!("segment batch"))?;
    query(&mut s, RequestBody::QueueSegments(batch), "QueueSegments")?;
    let base = status(&mut s)?;
    query(&mut s, RequestBody::Start, "Start")?;
    let start_seq = base.next_seq;
    say("armed the force job, queued the move, started");

    let model_ticks = setup.max_ticks;
    let mut watch = runner::JobWatch::new(model_ticks, 2.0, sc::TICK_HZ as u64 * 10, NO_PROGRESS);
    let mut latest = base.clone();
    let mut report = MillingRunReport {
        expected_x_steps: setup.move_steps as i64,
        resumed_from_steps: resume.map(|r| r.from_steps),
        ..Default::default()
    };
    let mut last_poll = Instant::now();
    let mut poll_seq: Option<u32> = None;
    // Statuses of the last FEED_WINDOW_S of board time: the feed is measured across them (two
    // statuses a few ticks apart read a step or two of travel as a large feed).
    let mut prev: std::collections::VecDeque<(u64, i64)> = Default::default();
    let window_ticks = (FEED_WINDOW_S * tick_hz) as u64;
    let mut ran = false;
    let mut steer = runner::Steer::default();
    let mut record = |st: &Status, trace: &mut Vec<BoardPoint>| {
        let x = st.positions[0] - x0;
        while prev.len() > 1 && prev[1].0 + window_ticks <= st.tick {
            prev.pop_front();
        }
        let feed = match prev.front() {
            Some(&(t, px)) if st.tick > t => {
                (x - px) as f64 / 1e3 / ((st.tick - t) as f64 / tick_hz) * 60.0
            }
            _ => 0.0,
        };
        prev.push_back((st.tick, x));
        trace.push(BoardPoint {
            t_s: st.tick.saturating_sub(base.tick) as f64 / tick_hz,
            force_n: st.force_mn as f64 / 1e3,
            peak_n: st.force_peak_mn as f64 / 1e3,
            override_: st.override_bits as f64 / (1u64 << 30) as f64,
            feed_mm_min: feed,
            x_steps: x,
            phase: ForcePhase::from_u8(st.force_phase),
        });
    };
    loop {
        s.pump(Duration::from_millis(2)).map_err(link)?;
        for n in s.notices.drain(..) {
            say(&n);
        }
        let mut fresh = Vec::new();
        for (seq, result) in s.take_answers() {
            if Some(seq) == poll_seq {
                poll_seq = None;
                if let Ok(Reply::Status(st)) = result {
                    fresh.push(st);
                }
            }
        }
        while let Some(ev) = s.events.pop_front() {
            match ev {
                HostEvent::Status(st) => fresh.push(st),
                HostEvent::SessionLost(code) => {
                    bail!("{}", lost_session(LinkFailure::SessionLost(code), journal.as_ref()))
                }
                _ => {}
            }
        }
        fresh.sort_by_key(|st| st.tick);
        for st in fresh {
            if st.tick > latest.tick || report.trace.is_empty() {
                if st.tick > base.tick {
                    record(&st, &mut report.trace);
                }
                latest = st;
            }
        }
        if last_poll.elapsed() >= POLL_EVERY && poll_seq.is_none() && s.host.window_free() > 0 {
            poll_seq = Some(s.send(RequestBody::GetStatus).map_err(link)?);
            last_poll = Instant::now();
        }
        // The job ran (a status after the Start showed it running or holding), then ended.
        let after_start = seq_at_or_after(latest.next_seq, start_seq.wrapping_add(1));
        if after_start && matches!(latest.machine, MachineState::Running | MachineState::Holding) {
            ran = true;
        }
        let ended = matches!(latest.machine, MachineState::Ready | MachineState::Fault);
        if ran {
            // The cursor: how far along the move the board's last status puts the tool.
            // A resumed run's cursor never goes back before its resume point (the approach's
            // last stretch is in the slot already cut).
            let x = latest.positions[0] - x0;
            let x = resume.map_or(x, |r| x.max(r.from_steps));
            if let Some(j) = journal.as_mut() {
                if let Some(w) = j.update_along(1, 0, x) {
                    say(&w);
                }
            }
        }
        if ran && after_start && ended {
            break;
        }
        steer.step(&mut s, hook, &latest, &mut watch)?;
        if steer.held() {
            continue;
        }
        if let Err(why) = watch.check(latest.tick, latest.positions[0] as u64 ^ latest.tick) {
            let _ = s.request(RequestBody::Abort);
            bail!("the job {why}: aborted");
        }
    }
    // A hold decelerates: wait until the axis is at rest (two statuses >= 5 ms of board time
    // apart at the same position), at most 5 s of wall time.
    let mut fin = status(&mut s)?;
    let settle_wall = Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(5));
        let st = status(&mut s)?;
        if st.tick >= fin.tick + sc::TICK_HZ as u64 / 200 {
            let rest = st.positions == fin.positions;
            fin = st;
            if rest {
                break;
            }
        }
        if settle_wall.elapsed() > Duration::from_secs(5) {
            break;
        }
    }
    let _ = s.request(RequestBody::SetStatusPeriod { ms: 0 });
    report.x_steps = fin.positions[0] - x0;
    report.faults = fin.faults;
    report.updates = fin.force_updates;
    report.board_ticks = fin.tick.saturating_sub(base.tick);
    report.seconds = t0.elapsed().as_secs_f64();
    let (fnom_n, trip_n) = (job.fnom_n, job.trip_n);
    let (settle, feed_after, peak) = judge(&report.trace, fnom_n, job.step_at_steps());
    // A run resumed inside the cut meets the work again at the resume point, not at the wall:
    // the settling after the depth step is judged only where it met the work as the first did.
    let judge_settling = resume.is_none_or(|r| r.before_the_wall(job));
    report.settle_s = settle;
    report.feed_after_mm_min = feed_after;
    report.peak_n = peak.max(fin.force_peak_mn as f64 / 1e3);
    report.model_settle_s = model.figure("settle_us").map(|us| us as f64 / 1e6);
    let p = &mut report.problems;
    let fault_code = match opts.fault {
        SimForceFault::None => None,
        SimForceFault::Saturated { .. } => Some(FaultCode::ForceSaturated),
        SimForceFault::Stuck { .. } => Some(FaultCode::ForceStuck),
        SimForceFault::SpindleStop => Some(FaultCode::SpindleStopped),
    };
    match fault_code {
        None => {
            if report.x_steps != report.expected_x_steps {
                p.push(format!(
                    "final X {} steps != host model {}",
                    report.x_steps, report.expected_x_steps
                ));
            }
            if fin.faults != 0 {
                p.push(format!("faults latched: {}", fault_names(fin.faults)));
            }
            let limit = report
                .model_settle_s
                .map_or(SETTLE_LIMIT_S, |m| (m + SETTLE_SLACK_S).max(SETTLE_LIMIT_S));
            match settle {
                _ if !judge_settling => {}
                Some(t) if t <= limit => {}
                Some(t) => p.push(format!(
                    "force outside Fnom +-10 % until {:.0} ms after the depth step (limit {:.0} \
                     ms: 150 ms or the host model's {} ms + 50 ms)",
                    t * 1e3,
                    limit * 1e3,
                    report.model_settle_s.map_or("-".into(), |m| format!("{:.0}", m * 1e3))
                )),
                None => p.push("the cut never reached the depth step".into()),
            }
            if report.peak_n > trip_n {
                p.push(format!("force {:.0} N above the trip level {trip_n:.0} N", report.peak_n));
            }
            if resume.is_some() && report.updates == 0 {
                p.push("the force loop made no control update after the resume".into());
            }
        }
        Some(code) => {
            if fin.faults != code.bit() {
                p.push(format!(
                    "expected the fault {} alone, the board latched {}",
                    code.name(),
                    fault_names(fin.faults)
                ));
            }
            if fin.machine != MachineState::Fault {
                p.push(format!("expected the machine in Fault, it is {:?}", fin.machine));
            }
            if !(0..report.expected_x_steps).contains(&report.x_steps) {
                p.push(format!("held at X {} steps: not inside the move", report.x_steps));
            }
            // Position intact: the board's count does not move once held.
            let again = status(&mut s)?;
            if again.positions[0] != fin.positions[0] {
                p.push("the position moved after the hold".into());
            }
            // Leave the board usable: drop the job, clear the fault.
            let _ = s.request(RequestBody::Abort);
            let _ = s.request(RequestBody::ClearFault);
        }
    }
    if resume.is_some() {
        // The resume switched the spindle on: the job's end switches it off.
        let off = RequestBody::SetProgramOutputs(motion::protocol::ProgramOutputs::OFF);
        query(&mut s, off, "SetProgramOutputs (spindle off)")?;
        say("spindle off (the job's end)");
    }
    if let Some(j) = &journal {
        if report.x_steps == report.expected_x_steps {
            j.finished();
        }
    }
    Ok(report)
}

/// The error of a run whose board lost its session (a reset, a power loss): with a journal, how
/// to go on.
fn lost_session(why: LinkFailure, journal: Option<&journal::Writer>) -> String {
    match journal.and_then(|j| j.feed_axis_steps().map(|x| (j.path().display(), x))) {
        Some((path, x)) => format!(
            "{why}: the journal ({path}) keeps the cut at X {:.3} mm; `motionctl milling run \
             JOB --resume` homes, re-arms the force loop and goes on from there",
            x as f64 / 1e3
        ),
        None => format!("{why}: the job cannot resume (no journal was kept)"),
    }
}

/// The board trace as CSV: time (s), force and tooth peak (N), override, feed (mm/min), X
/// (steps of 1 um), controller phase.
pub fn write_csv(path: &Path, trace: &[BoardPoint]) -> anyhow::Result<()> {
    let mut out = String::from("t_s,force_n,peak_n,override,feed_mm_min,x_steps,phase\n");
    for p in trace {
        out.push_str(&format!(
            "{:.5},{:.1},{:.1},{:.4},{:.2},{},{}\n",
            p.t_s,
            p.force_n,
            p.peak_n,
            p.override_,
            p.feed_mm_min,
            p.x_steps,
            p.phase.name()
        ));
    }
    std::fs::write(path, out).map_err(|e| anyhow!("writing {}: {e}", path.display()))?;
    Ok(())
}

/// The board trace as the figure's samples.
pub fn plot_points(trace: &[BoardPoint]) -> Vec<super::figure::Sample> {
    trace.iter().map(|p| (p.t_s, p.force_n, p.feed_mm_min, p.override_)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(t_s: f64, force_n: f64, x_steps: i64) -> BoardPoint {
        BoardPoint {
            t_s,
            force_n,
            peak_n: force_n,
            override_: 1.0,
            feed_mm_min: 0.0,
            x_steps,
            phase: ForcePhase::Cutting,
        }
    }

    /// The judge finds the last status outside the band inside the window, the feed over
    /// 300..400 ms, and the peak; a trace that never reaches the step has no settling.
    #[test]
    fn judge_reads_settling_feed_and_peak() {
        let mut trace = vec![point(0.0, 3900.0, 9_000)];
        // Step at 0.1 s (x = 10 000); out of band until 0.16 s; 3.3 mm/s from 0.4 s.
        for i in 0..60 {
            let t = 0.1 + i as f64 * 0.01;
            let f = if t < 0.165 { 12_000.0 } else { 4_100.0 };
            let x = 10_000 + (i as f64 * 0.01 * 3_300.0) as i64;
            trace.push(point(t, f, x));
        }
        let (settle, feed, peak) = judge(&trace, 4100.0, 10_000);
        assert!((settle.unwrap() - 0.06).abs() < 1e-9, "{settle:?}");
        assert!((feed.unwrap() - 198.0).abs() < 3.0, "{feed:?}");
        assert_eq!(peak, 12_000.0);
        assert_eq!(judge(&trace[..1], 4100.0, 10_000).0, None);
    }
}
