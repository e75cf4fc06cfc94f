//! `motionctl polar copy`: copy mode (the template digitizer driving the machine live) with
//! "teach" recording, on the board through the host link.
//!
//! Hello -> the polar machine's config and homing (`runner::ready_board`) -> GetStatus (the
//! encoders' counts now are the origin) -> `StartCopy { m, k, teach }` -> on a simulator board
//! (`CAP_SIM_INPUTS`), the template trace as `Sim(Encoders)` targets, waiting for the encoders to
//! reach each one (on a real board the operator moves the arm for `--seconds`) -> `Abort` ->
//! `ReadTeach` until the recording ends -> verify:
//! * no event lost, the stream decodes, its events = the board's taught count, and its net
//!   counts = the encoders' moves;
//! * the board's final (theta, r) steps = the host model: the firmware's own `CopyMode` fed the
//!   counts the taught stream records, tick by tick, with the same size scale.

use crate::link::{LinkFailure, Session};
use crate::runner;
use crate::transport::Transport;
use motion::polar::copy::CopyMode;
use motion::polar::link_messages::PolarRequest;
use motion::polar::playback::SizeScale;
use motion::polar::stream::decode_all;
use motion::protocol::{
    HostConfig, Reply, RequestBody, SimRequest, Status, CAP_COPY_JOB, CAP_SIM_INPUTS,
};
use std::time::{Duration, Instant};

/// A template trace: encoder count waypoints (arm, carriage) relative to the copy's origin.
pub type Trace = Vec<[i32; 2]>;

/// The built-in template: a piece of the limacon r = 3 + 2 cos(theta) in (the thesis's test
/// contour) about its own pole, theta from 0 to `theta_end_rad`, one waypoint every `step`
/// arm counts, at the thesis's resolutions (dTheta = 2 pi / 16000, dR = 0.001 in).
pub fn limacon_trace(theta_end_rad: f64, step: i32) -> Trace {
    let r_at = |th: f64| 3.0 + 2.0 * th.cos();
    let end = (theta_end_rad / super::DTHETA_RAD).round() as i32;
    let mut out = Vec::new();
    let mut a = 0;
    loop {
        a = (a + step.max(1)).min(end);
        let th = a as f64 * super::DTHETA_RAD;
        let c = ((r_at(th) - r_at(0.0)) / super::DR_IN).round() as i32;
        out.push([a, c]);
        if a >= end {
            return out;
        }
    }
}

/// A trace file: one `arm_counts,carriage_counts` waypoint per line (`#` comments).
pub fn parse_trace(text: &str) -> anyhow::Result<Trace> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (a, c) = line
            .split_once(',')
            .ok_or_else(|| anyhow::anyhow!("line {}: expected ARM,CARRIAGE", i + 1))?;
        let num = |t: &str| {
            t.trim().parse::<i32>().map_err(|_| anyhow::anyhow!("line {}: bad count {t:?}", i + 1))
        };
        out.push([num(a)?, num(c)?]);
    }
    Ok(out)
}

/// What `copy` needs.
#[derive(Clone, Debug)]
pub struct CopyOptions {
    pub scale: SizeScale,
    pub teach: bool,
    pub host: HostConfig,
    pub home: bool,
    pub progress: bool,
    /// Waypoints for a simulator board; `None`: a real board, copy for `seconds`.
    pub trace: Option<Trace>,
    pub seconds: f64,
}

/// The host model of a taught stream: the counts it records and what `CopyMode` makes of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CopyModel {
    pub events: u32,
    /// Net encoder counts (arm, carriage).
    pub counts: [i64; 2],
    /// Final (theta, r) steps at the size scale.
    pub positions: [i64; 2],
    /// Ticks from the start to the last event.
    pub ticks: u64,
}

/// Replays the counts a taught stream records through the firmware's `CopyMode`.
pub fn model(bytes: &[u8], scale: SizeScale) -> anyhow::Result<CopyModel> {
    let mut events = Vec::new();
    decode_all(bytes, |e| events.push(e)).map_err(|e| anyhow::anyhow!("taught stream: {e}"))?;
    let mut c = CopyMode::new([0, 0], scale, false);
    let mut counts = [0i32; 2];
    let mut i = 0;
    let mut tick = 0u64;
    // Counts as the board saw them: every event of a tick applied, then the tick.
    while i < events.len() {
        let dt = events[i].dt_ticks.max(1) as u64;
        for _ in 1..dt {
            c.tick(counts);
            tick += 1;
        }
        let mut first = true;
        while i < events.len() && (first || events[i].dt_ticks == 0) {
            let e = events[i];
            let a = (e.axis & 1) as usize;
            counts[a] = counts[a].wrapping_add(e.signed());
            first = false;
            i += 1;
        }
        c.tick(counts);
        tick += 1;
    }
    // The pins finish what was taken (bounded: a step every second tick per axis).
    let mut drain = 0;
    while !c.caught_up(counts) && drain < 10_000_000 {
        c.tick(counts);
        drain += 1;
    }
    Ok(CopyModel {
        events: events.len() as u32,
        counts: [counts[0] as i64, counts[1] as i64],
        positions: c.position(),
        ticks: tick,
    })
}

/// What a copy did; `problems` is empty when every check passed.
#[derive(Clone, Debug, Default)]
pub struct CopyReport {
    pub waypoints: usize,
    pub blocks: usize,
    pub taught_events: u32,
    pub lost_events: u32,
    pub stream_events: u32,
    /// Encoder moves (arm, carriage) from the start to the end.
    pub encoder_moves: [i64; 2],
    pub positions: [i64; 2],
    pub model: CopyModel,
    pub board_ticks: u64,
    pub seconds: f64,
    pub retransmissions: u64,
    /// The taught stream (its blocks and the end block), empty without teach.
    pub stream: Vec<u8>,
    pub problems: Vec<String>,
}

impl CopyReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }

    /// One `key=value` line for scripts (the xtask end-to-end step parses it).
    pub fn machine_line(&self) -> String {
        format!(
            "copy-summary ok={} waypoints={} blocks={} taught={} lost={} stream_events={} \
             arm={} carriage={} theta={} r={} theta_model={} r_model={} model_ticks={} \
             board_ticks={} seconds={:.3} retransmissions={}",
            self.ok() as u8,
            self.waypoints,
            self.blocks,
            self.taught_events,
            self.lost_events,
            self.stream_events,
            self.encoder_moves[0],
            self.encoder_moves[1],
            self.positions[0],
            self.positions[1],
            self.model.positions[0],
            self.model.positions[1],
            self.model.ticks,
            self.board_ticks,
            self.seconds,
            self.retransmissions,
        )
    }
}

/// Board ticks to wait after the encoders reached the last waypoint (the copy's pins drain).
const SETTLE_TICKS: u64 = 2_000;
/// A waypoint the encoders do not reach in this long (wall clock) is a stuck board.
const STUCK: Duration = Duration::from_secs(15);

/// Connects, starts a copy, drives or waits, reads the recording back; see the module doc.
pub fn copy(transport: &mut dyn Transport, opts: &CopyOptions) -> anyhow::Result<CopyReport> {
    use anyhow::{anyhow, bail};
    let t0 = Instant::now();
    let say = |m: &str| {
        if opts.progress {
            eprintln!("motionctl: {m}");
        }
    };
    let cfg = motion::polar::job::link_config();
    let mut s = Session::new(transport, opts.host);
    let link = |e: LinkFailure| anyhow!("{e}");
    let info = s.connect().map_err(link)?;
    if info.capabilities & CAP_COPY_JOB == 0 {
        bail!("the board ({:?}) has no copy mode (no CAP_COPY_JOB)", info.firmware.as_str());
    }
    if opts.trace.is_some() && info.capabilities & CAP_SIM_INPUTS == 0 {
        bail!("--template needs a simulator board (CAP_SIM_INPUTS); on hardware move the arm");
    }
    say(&format!("connected to {}: firmware {:?}", s.describe(), info.firmware.as_str()));
    let (query, status) = (runner::ask, runner::ask_status);
    runner::ready_board(
        &mut s,
        cfg,
        runner::Home::allowed(opts.home),
        "polar machine (theta, r)",
        &|m| say(m),
    )
    .map_err(|e| anyhow!("{e}"))?;
    let base = status(&mut s)?;
    let origin = base.encoder_counts;
    if opts.trace.is_some() {
        // The simulated encoders stay where they are until the first waypoint.
        let body = RequestBody::Sim(SimRequest::Encoders {
            arm_counts: origin[0],
            carriage_counts: origin[1],
        });
        query(&mut s, body, "Sim(Encoders)")?;
    }
    let body = RequestBody::from(PolarRequest::StartCopy {
        m: opts.scale.m,
        k: opts.scale.k,
        teach: opts.teach,
    });
    query(&mut s, body, "StartCopy")?;
    say(&format!(
        "copying at size {}:{} from encoder counts {origin:?}",
        opts.scale.m, opts.scale.k
    ));

    let mut report = CopyReport::default();
    let mut next_block = 0u16;
    let mut read_teach = |s: &mut Session, report: &mut CopyReport| -> anyhow::Result<bool> {
        loop {
            let Reply::Teach(c) = query(
                s,
                RequestBody::from(PolarRequest::ReadTeach { block: next_block }),
                "ReadTeach",
            )?
            else {
                bail!("the board answered ReadTeach without a block");
            };
            report.taught_events = c.taught_events;
            report.lost_events = c.lost_events;
            if !c.bytes.is_empty() {
                report.stream.extend_from_slice(&c.bytes);
                next_block = next_block.wrapping_add(1);
                report.blocks += 1;
            }
            if c.ended {
                return Ok(true);
            }
            if c.bytes.is_empty() {
                return Ok(false);
            }
        }
    };
    let check_fault = |st: &Status| -> anyhow::Result<()> {
        if st.faults != 0 {
            bail!("the board faulted (fault bits {:#x}) during the copy", st.faults);
        }
        Ok(())
    };
    let mut latest = base.clone();
    if let Some(trace) = &opts.trace {
        report.waypoints = trace.len();
        for (i, w) in trace.iter().enumerate() {
            let target = [origin[0].wrapping_add(w[0]), origin[1].wrapping_add(w[1])];
            let body = RequestBody::Sim(SimRequest::Encoders {
                arm_counts: target[0],
                carriage_counts: target[1],
            });
            query(&mut s, body, "Sim(Encoders)")?;
            let since = Instant::now();
            loop {
                if opts.teach {
                    read_teach(&mut s, &mut report)?;
                }
                latest = status(&mut s)?;
                check_fault(&latest)?;
                if latest.encoder_counts == target {
                    break;
                }
                if since.elapsed() > STUCK {
                    let _ = s.request(RequestBody::Abort);
                    bail!("waypoint {i}: encoders at {:?}, not {target:?}", latest.encoder_counts);
                }
            }
        }
        let reached = latest.tick;
        while latest.tick < reached + SETTLE_TICKS {
            latest = status(&mut s)?;
            check_fault(&latest)?;
        }
    } else {
        say(&format!("move the arm: copying for {} s", opts.seconds));
        let until = Instant::now() + Duration::from_secs_f64(opts.seconds.max(0.0));
        while Instant::now() < until {
            if opts.teach {
                read_teach(&mut s, &mut report)?;
            }
            latest = status(&mut s)?;
            check_fault(&latest)?;
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    if !latest.copy_running {
        report.problems.push("the copy job was not running at the end".into());
    }
    query(&mut s, RequestBody::Abort, "Abort")?;
    let fin = status(&mut s)?;
    if opts.teach {
        let since = Instant::now();
        while !read_teach(&mut s, &mut report)? {
            if since.elapsed() > STUCK {
                bail!("the recording did not end after the abort");
            }
        }
    }
    report.encoder_moves = [
        fin.encoder_counts[0].wrapping_sub(origin[0]) as i64,
        fin.encoder_counts[1].wrapping_sub(origin[1]) as i64,
    ];
    report.positions = [fin.positions[0] - base.positions[0], fin.positions[1] - base.positions[1]];
    report.board_ticks = fin.tick.saturating_sub(base.tick);
    report.seconds = t0.elapsed().as_secs_f64();
    report.retransmissions = s.host.retransmissions;
    if fin.faults != 0 {
        report.problems.push(format!("faults latched: {:#x}", fin.faults));
    }
    if opts.teach {
        report.model = model(&report.stream, opts.scale)?;
        report.stream_events = report.model.events;
        if report.lost_events != 0 {
            report.problems.push(format!(
                "the recording is incomplete: {} events lost (the host read too slowly)",
                report.lost_events
            ));
        }
        if report.stream_events != report.taught_events {
            report.problems.push(format!(
                "{} events in the stream, the board taught {}",
                report.stream_events, report.taught_events
            ));
        }
        if report.model.counts != report.encoder_moves {
            report.problems.push(format!(
                "the stream's net counts {:?} != the encoders' moves {:?}",
                report.model.counts, report.encoder_moves
            ));
        }
        if report.model.positions != report.positions {
            report.problems.push(format!(
                "final (theta, r) {:?} != host model {:?} steps",
                report.positions, report.model.positions
            ));
        }
    }
    Ok(report)
}
