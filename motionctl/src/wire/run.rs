//! `motionctl wire run` on a board with wire jobs (`CAP_WIRE_JOB`): the planned segments run as
//! a wire job, through the board's wire-stall retrace controller.
//!
//! Hello -> the board idle (only `ConfigMissing` may be latched: cleared after the config) ->
//! the wire machine's config -> Home if needed (and allowed) -> `ArmWire` (stall parameters and
//! the segment count) -> the segments in `QueueSegments` batches as credits allow -> `Start` once
//! the board's queue is full or every segment is queued -> keep streaming -> wait for the job's
//! end -> verify: final X, Y, beta, alpha steps == the host model, no fault latched. With
//! `stall` (a board with `CAP_SIM_INPUTS` only: QEMU) the run closes the simulated wire-stall
//! switch from `at_ticks` after the start for `for_ticks` board ticks (judged from the status
//! stream, so to within a status period) and checks that the board saw it and retraced.

use crate::link::{describe_rejection, LinkFailure, Session};
use crate::runner;
use crate::runner::{fault_names, seq_at_or_after};
use crate::transport::Transport;
use anyhow::{anyhow, bail};
use motion::machine::MachineState;
use motion::protocol::{
    HostConfig, HostEvent, LinkConfig, Reply, RequestBody, SegmentBatch, SimRequest,
    CAP_SIM_INPUTS, MAX_SEGMENTS_PER_FRAME,
};
use motion::segment::Segment;
use motion::wire::link_messages::WireJobParams;
use motion::wire::link_messages::WireRequest;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Status period during the job.
pub const STATUS_PERIOD_MS: u16 = 40;
/// Status poll interval (wall clock), also the link heartbeat.
pub const POLL_EVERY: Duration = Duration::from_millis(5);
/// Longest a run may take in board time: the host model's ticks (stall and retrace included)
/// times [`SLOWDOWN`] plus `slack`. Board time, so a simulator slower than real time is not
/// taken for a slow job (see [`runner::JobWatch`]).
pub const SLACK: Duration = Duration::from_secs(10);
pub const SLOWDOWN: f64 = 2.0;
/// A job whose board clock and positions do not move for this long (wall clock) is stuck.
pub const NO_PROGRESS: Duration = Duration::from_secs(15);

/// A simulated stall: the switch closes `at_ticks` board ticks after the start, for `for_ticks`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimStall {
    pub at_ticks: u64,
    pub for_ticks: u64,
}

/// What [`run`] needs besides the job.
#[derive(Clone, Debug)]
pub struct WireRunOptions {
    /// Stall handling (`segments` is filled in from the job).
    pub params: WireJobParams,
    pub host: HostConfig,
    pub home: bool,
    pub progress: bool,
    pub stall: Option<SimStall>,
    /// Board-time limit on top of [`SLOWDOWN`] times the model's duration.
    pub slack: Duration,
}

/// What the run did; `problems` is empty when every check passed.
#[derive(Clone, Debug, Default)]
pub struct WireRunReport {
    pub segments: usize,
    pub positions: [i64; 4],
    pub expected_positions: [i64; 4],
    pub stalls: u32,
    pub retraces: u32,
    pub returns: u32,
    pub max_retrace_steps: u64,
    pub board_ticks: u64,
    pub seconds: f64,
    pub problems: Vec<String>,
}

impl WireRunReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }
}

#[derive(Clone, Copy, Debug)]
enum Pending {
    Batch(usize),
    Start,
    Poll,
    Inject,
}

/// Connects, configures and runs `segments` as a wire job; see the module doc. `expected` is
/// the host model's final X, Y, beta, alpha steps (relative to the start); `model_ticks` the
/// host model's duration in board ticks.
pub fn run(
    transport: &mut dyn Transport,
    cfg: LinkConfig,
    segments: &[Segment],
    expected: [i64; 4],
    model_ticks: u64,
    opts: &WireRunOptions,
) -> anyhow::Result<WireRunReport> {
    run_with(transport, cfg, segments, expected, model_ticks, opts, &mut runner::Unattended)
}

/// As [`run`], with `hook` asked every pass of the job's loop once the job started (it may
/// hold, resume or abort it: the grbl bridge's sender does).
pub fn run_with(
    transport: &mut dyn Transport,
    cfg: LinkConfig,
    segments: &[Segment],
    expected: [i64; 4],
    model_ticks: u64,
    opts: &WireRunOptions,
    hook: &mut dyn runner::JobHook,
) -> anyhow::Result<WireRunReport> {
    let t0 = Instant::now();
    let say = |m: &str| {
        if opts.progress {
            eprintln!("motionctl: {m}");
        }
    };
    let params = WireJobParams { segments: segments.len() as u32, ..opts.params };
    if !motion::wire::link_messages::wire_params_ok(&params) {
        bail!("unusable wire-job parameters {params:?}");
    }
    let mut s = Session::new(transport, opts.host);
    let link = |e: LinkFailure| anyhow!("{e}");
    let info = s.connect().map_err(link)?;
    crate::board_link::require_capability(&info, &motion::wire::CAPABILITY)?;
    if opts.stall.is_some() && info.capabilities & CAP_SIM_INPUTS == 0 {
        bail!(
            "the board ({:?}) has no simulated inputs: no stall to inject",
            info.firmware.as_str()
        );
    }
    say(&format!("connected to {}: firmware {:?}", s.describe(), info.firmware.as_str()));
    let (query, status) = (runner::ask, runner::ask_status);
    runner::ready_board(
        &mut s,
        cfg,
        runner::Home::allowed(opts.home),
        "wire machine (X, Y, beta, alpha)",
        &|m| say(m),
    )
    .map_err(|e| anyhow!("{e}"))?;
    if opts.stall.is_some() {
        query(&mut s, RequestBody::Sim(SimRequest::Inject { wire_stall: false }), "Sim(Inject)")?;
    }
    query(&mut s, RequestBody::SetStatusPeriod { ms: STATUS_PERIOD_MS }, "SetStatusPeriod")?;
    s.streaming = true;
    let base = status(&mut s)?;
    query(&mut s, RequestBody::from(WireRequest::ArmWire(params)), "ArmWire")?;
    say(&format!("armed a wire job of {} segments", segments.len()));

    let mut report = WireRunReport {
        segments: segments.len(),
        expected_positions: expected,
        ..WireRunReport::default()
    };
    let mut pending: HashMap<u32, Pending> = HashMap::new();
    let (mut next, mut acked) = (0usize, 0usize);
    let mut start_seq: Option<u32> = None;
    let mut started = false;
    let mut latest = base.clone();
    let mut start_tick: Option<u64> = None;
    let mut stall_state = 0u8; // 0 before, 1 closed, 2 released
    let mut poll_in_flight = false;
    let mut last_poll = Instant::now();
    let mut last_say = Instant::now();
    let slack_ticks = (opts.slack.as_secs_f64() * f64::from(cfg.machine.tick_hz)) as u64;
    let mut watch = runner::JobWatch::new(model_ticks, SLOWDOWN, slack_ticks, NO_PROGRESS);
    let mut steer = runner::Steer::default();

    loop {
        s.pump(Duration::from_millis(5)).map_err(link)?;
        for n in s.notices.drain(..) {
            say(&n);
        }
        for (seq, result) in s.take_answers() {
            let Some(p) = pending.remove(&seq) else { continue };
            match (p, result) {
                (Pending::Batch(n), Ok(_)) => acked += n,
                (Pending::Batch(_), Err(r)) => {
                    bail!("the board refused segments after {acked}: {}", describe_rejection(&r))
                }
                (Pending::Start, Ok(_)) => started = true,
                (Pending::Start, Err(r)) => bail!("Start refused: {}", describe_rejection(&r)),
                (Pending::Inject, Err(r)) => {
                    bail!("Sim(Inject) refused: {}", describe_rejection(&r))
                }
                (Pending::Inject, Ok(_)) => {}
                (Pending::Poll, Ok(Reply::Status(st))) => {
                    poll_in_flight = false;
                    if seq_at_or_after(st.next_seq, latest.next_seq) {
                        latest = st;
                    }
                }
                (Pending::Poll, _) => poll_in_flight = false,
            }
        }
        while let Some(ev) = s.events.pop_front() {
            match ev {
                HostEvent::Status(st) if seq_at_or_after(st.next_seq, latest.next_seq) => {
                    latest = st;
                }
                HostEvent::Fault { tick, .. } if tick < base.tick => {}
                HostEvent::Fault { code, tick } => {
                    bail!("board fault {} ({}) at tick {tick}", code.name(), code.description())
                }
                HostEvent::SessionLost(code) => {
                    bail!("{}: the job cannot resume safely", LinkFailure::SessionLost(code))
                }
                _ => {}
            }
        }
        if latest.faults != 0 {
            bail!("the board faulted ({})", fault_names(latest.faults));
        }

        // Segments, as credits and the window allow.
        while next < segments.len() && s.host.window_free() > 0 && s.host.segment_credits() > 0 {
            let n = (segments.len() - next)
                .min(MAX_SEGMENTS_PER_FRAME)
                .min(s.host.segment_credits() as usize);
            let batch = SegmentBatch::from_slice(&segments[next..next + n])
                .ok_or_else(|| anyhow!("batch of {n} segments does not fit a frame"))?;
            let seq = s.send(RequestBody::QueueSegments(batch)).map_err(link)?;
            pending.insert(seq, Pending::Batch(n));
            next += n;
        }
        // Start once the board's queue is full or the whole job is queued.
        let queued = acked == next && (next == segments.len() || s.host.segment_credits() == 0);
        if start_seq.is_none() && acked > 0 && queued && s.host.window_free() > 0 {
            start_tick = Some(latest.tick);
            let seq = s.send(RequestBody::Start).map_err(link)?;
            pending.insert(seq, Pending::Start);
            start_seq = Some(seq);
            say(&format!("{acked} segments queued: Start"));
        }
        // The simulated stall, by board time since the start.
        if let (Some(st), Some(t0), true) = (opts.stall, start_tick, started) {
            let dt = latest.tick.saturating_sub(t0);
            let want = match stall_state {
                0 if dt >= st.at_ticks => Some(true),
                1 if dt >= st.at_ticks + st.for_ticks => Some(false),
                _ => None,
            };
            if let Some(w) = want.filter(|_| s.host.window_free() > 0) {
                let seq =
                    s.send(RequestBody::Sim(SimRequest::Inject { wire_stall: w })).map_err(link)?;
                pending.insert(seq, Pending::Inject);
                stall_state += 1;
                say(&format!(
                    "wire-stall switch {} at tick {dt}",
                    if w { "closed" } else { "open" }
                ));
            }
        }
        // Poll all the time: under QEMU (`-icount sleep=off`) the idle guest's clock runs many
        // times faster than the wall clock, so a 250 ms heartbeat would be seconds of board
        // time and the board would take the silence for a lost link (1 s).
        if last_poll.elapsed() >= POLL_EVERY && !poll_in_flight && s.host.window_free() > 0 {
            let seq = s.send(RequestBody::GetStatus).map_err(link)?;
            pending.insert(seq, Pending::Poll);
            poll_in_flight = true;
            last_poll = Instant::now();
        }
        if opts.progress && last_say.elapsed() >= Duration::from_secs(2) {
            last_say = Instant::now();
            say(&format!(
                "{acked} / {} segments queued, state {:?}, stalls {}, retraces {}, wire power {}",
                segments.len(),
                latest.machine,
                latest.wire_stalls,
                latest.wire_retraces,
                latest.wire_power
            ));
        }
        let after_start = start_seq.is_some_and(|ss| seq_at_or_after(latest.next_seq, ss + 1));
        let stall_done = opts.stall.is_none() || stall_state == 2;
        if started && after_start && latest.machine == MachineState::Ready && next == segments.len()
        {
            if !stall_done {
                report.problems.push("the job ended before the stall was injected".into());
            }
            break;
        }
        if started {
            steer.step(&mut s, hook, &latest, &mut watch)?;
        }
        let moved = latest.positions.iter().fold(latest.tick, |h, &p| h.rotate_left(7) ^ p as u64);
        let overdue = match started && !steer.held() {
            true => watch.check(latest.tick, moved).err(),
            false => None,
        };
        if let Some(why) = overdue {
            let _ = s.request(RequestBody::Abort);
            bail!("the job {why}: aborted");
        }
    }
    if opts.stall.is_some() {
        query(&mut s, RequestBody::Sim(SimRequest::Inject { wire_stall: false }), "Sim(Inject)")?;
    }
    let fin = status(&mut s)?;
    let _ = s.request(RequestBody::SetStatusPeriod { ms: 0 });
    for (a, p) in report.positions.iter_mut().enumerate() {
        *p = fin.positions[a] - base.positions[a];
    }
    report.stalls = fin.wire_stalls;
    report.retraces = fin.wire_retraces;
    report.returns = fin.wire_returns;
    report.max_retrace_steps = fin.wire_max_retrace_steps;
    report.board_ticks = fin.tick.saturating_sub(start_tick.unwrap_or(fin.tick));
    report.seconds = t0.elapsed().as_secs_f64();
    if report.positions != expected {
        report.problems.push(format!(
            "final X, Y, beta, alpha {:?} != host model {:?} steps",
            report.positions, expected
        ));
    }
    if fin.faults != 0 {
        report.problems.push(format!("faults latched: {}", fault_names(fin.faults)));
    }
    if fin.wire_power {
        report.problems.push("the wire power is still on after the job".into());
    }
    if opts.stall.is_some() && (report.stalls == 0 || report.retraces == 0) {
        report.problems.push(format!(
            "a stall was injected but the board saw {} stalls and ran {} retrace segments",
            report.stalls, report.retraces
        ));
    }
    Ok(report)
}
