//! `motionctl polar run STREAM.bin`: plays a recorded step-event stream on the board as an
//! event job and checks what it did.
//!
//! Hello -> the board idle (only `ConfigMissing` may be latched: it is cleared after the config)
//! -> the polar machine's config (`motion::polar::job::link_config`, at the stream's tick rate)
//! -> Home if needed (and allowed) -> `SetOverride` (the speed scale) -> the stream's blocks in
//! `QueueEvents` requests as event credits allow (the last one marked) -> `StartPlayback` once
//! the board's block queue is full or the whole stream is queued -> wait until the job is done
//! (a [`runner::JobHook`] may hold, resume or abort it meanwhile) -> verify: events fired ==
//! events in the file, and the final (theta, r) steps == the host
//! model (the firmware's own `Playback`, run here with the same size scale and speed).

use crate::link::{describe_rejection, LinkFailure, Session};
use crate::runner;
use crate::runner::{fault_names, seq_at_or_after};
use crate::transport::Transport;
use motion::machine::MachineState;
use motion::polar::link_messages::PolarRequest;
use motion::polar::playback::{Playback, SizeScale};
use motion::polar::stream::decode_all;
use motion::protocol::{BlockBytes, EventBlock, HostConfig, HostEvent, Reply, RequestBody};
use motion::segment::Rate;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Status period during the job.
pub const STATUS_PERIOD_MS: u16 = 40;
/// Longest a run may take in board time: the model's ticks at the chosen speed times
/// [`SLOWDOWN`] plus [`SLACK_SECONDS`] (starvation holds and their ramps). Board time, so a
/// simulator slower than real time is not taken for a slow job (see [`runner::JobWatch`]).
pub const SLACK_SECONDS: u64 = 10;
pub const SLOWDOWN: f64 = 2.0;
/// A job whose fired-event count does not move for this long (wall clock) is stuck: aborted.
pub const NO_PROGRESS: Duration = Duration::from_secs(15);

/// What `run` needs besides the stream.
#[derive(Clone, Debug)]
pub struct PolarRunOptions {
    /// Speed scale 0.25..=2 (the feed override).
    pub speed: f64,
    pub scale: SizeScale,
    pub host: HostConfig,
    /// Home the board first if it is not homed.
    pub home: bool,
    /// Print progress lines on stderr.
    pub progress: bool,
}

impl Default for PolarRunOptions {
    fn default() -> Self {
        PolarRunOptions {
            speed: 1.0,
            scale: SizeScale::ONE,
            host: HostConfig { rto_ms: 50, window: 8 },
            home: true,
            progress: false,
        }
    }
}

/// The host model of a stream: events, final (theta, r) steps and ticks at `speed` and `scale`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Model {
    pub events: u32,
    pub positions: [i64; 2],
    pub ticks: u64,
}

/// Splits a stream file into its data blocks (each checked whole, in sequence, up to the end
/// block, which stays here: the link's `last` flag ends the stream on the board).
pub fn blocks(bytes: &[u8]) -> anyhow::Result<Vec<&[u8]>> {
    decode_all(bytes, |_| {}).map_err(|e| anyhow::anyhow!("not a valid event stream: {e}"))?;
    motion::polar::stream::blocks(bytes)
        .map(|b| b.map(|(_, raw)| raw).map_err(|e| anyhow::anyhow!("{e}")))
        .collect()
}

/// The first `n` data blocks of the whole stream `bytes` as a whole stream of their own (an open
/// stretch of a contour): those blocks and an end block with their totals.
pub fn first_blocks(bytes: &[u8], n: usize) -> anyhow::Result<Vec<u8>> {
    let all = blocks(bytes)?;
    let part = all.get(..n).ok_or_else(|| {
        anyhow::anyhow!("the stream has {} data blocks, {n} were asked for", all.len())
    })?;
    let mut out = part.concat();
    // Checked whole by `blocks` above.
    let events: u32 =
        motion::polar::stream::blocks(bytes).take(n).flatten().map(|(b, _)| b.events as u32).sum();
    // Sequence numbers wrap at 16 bits, as the encoder's do.
    out.extend_from_slice(&motion::polar::stream::end_block(n as u16, n as u32, events));
    Ok(out)
}

/// Runs the firmware's playback over the whole stream (no link, no feeder latency).
pub fn model(bytes: &[u8], speed: Rate, scale: SizeScale) -> anyhow::Result<Model> {
    let mut events = Vec::new();
    decode_all(bytes, |e| events.push(e)).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut p = Playback::new(scale);
    p.set_rate(speed);
    let mut it = events.into_iter();
    let mut ticks = 0u64;
    while !p.done() {
        while p.free() > 0 {
            match it.next() {
                Some(e) => {
                    let _ = p.push(e);
                }
                None => {
                    p.finish();
                    break;
                }
            }
        }
        p.tick();
        ticks += 1;
    }
    Ok(Model { events: p.fired(), positions: p.position(), ticks })
}

/// What a run did; `problems` is empty when every check passed.
#[derive(Clone, Debug, Default)]
pub struct PolarReport {
    pub blocks: usize,
    pub events: u32,
    pub events_fired: u32,
    pub positions: [i64; 2],
    pub expected_positions: [i64; 2],
    pub model_ticks: u64,
    /// Board ticks from the status before the start to the first status showing the job done
    /// (an upper bound of the job's ticks, by at most one status period and the start latency).
    pub board_ticks: u64,
    pub seconds: f64,
    pub frames_out: u64,
    pub retransmissions: u64,
    pub link_naks: u64,
    pub bad_frames_in: u64,
    pub min_event_credits: u16,
    pub problems: Vec<String>,
}

impl PolarReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }

    /// One `key=value` line for scripts (the xtask end-to-end step parses it).
    pub fn machine_line(&self) -> String {
        format!(
            "polar-summary ok={} blocks={} events={} events_fired={} theta={} r={} \
             theta_model={} r_model={} model_ticks={} board_ticks={} seconds={:.3} \
             frames_out={} retransmissions={} link_naks={} bad_frames_in={}",
            self.ok() as u8,
            self.blocks,
            self.events,
            self.events_fired,
            self.positions[0],
            self.positions[1],
            self.expected_positions[0],
            self.expected_positions[1],
            self.model_ticks,
            self.board_ticks,
            self.seconds,
            self.frames_out,
            self.retransmissions,
            self.link_naks,
            self.bad_frames_in,
        )
    }
}

enum Pending {
    Block,
    Start,
    Poll,
}

/// Connects, configures and plays `bytes` (a v1 stream) as an event job; see the module doc.
pub fn run(
    transport: &mut dyn Transport,
    bytes: &[u8],
    opts: &PolarRunOptions,
) -> anyhow::Result<PolarReport> {
    run_with(transport, bytes, opts, &mut runner::Unattended)
}

/// As [`run`], with `hook` asked every pass of the job's loop once the playback started (it may
/// hold, resume or abort the job: the grbl bridge's sender does).
pub fn run_with(
    transport: &mut dyn Transport,
    bytes: &[u8],
    opts: &PolarRunOptions,
    hook: &mut dyn runner::JobHook,
) -> anyhow::Result<PolarReport> {
    use anyhow::{anyhow, bail};
    let t0 = Instant::now();
    let say = |m: &str| {
        if opts.progress {
            eprintln!("motionctl: {m}");
        }
    };
    if !(0.25..=2.0).contains(&opts.speed) {
        bail!("--speed must be within 0.25..=2, got {}", opts.speed);
    }
    let speed = Rate::from_num(opts.speed);
    let blocks = blocks(bytes)?;
    let model = model(bytes, speed, opts.scale)?;
    let cfg = motion::polar::job::link_config();
    say(&format!(
        "{} blocks, {} events; host model at speed {} and size {}:{}: {} ticks ({:.2} s), \
         final (theta, r) = {:?} steps",
        blocks.len(),
        model.events,
        opts.speed,
        opts.scale.m,
        opts.scale.k,
        model.ticks,
        model.ticks as f64 / cfg.machine.tick_hz as f64,
        model.positions
    ));

    let mut s = Session::new(transport, opts.host);
    let link = |e: LinkFailure| anyhow!("{e}");
    let info = s.connect().map_err(link)?;
    if info.capabilities & motion::protocol::CAP_EVENTS == 0 {
        bail!("the board ({:?}) does not play event jobs (no CAP_EVENTS)", info.firmware.as_str());
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
    query(&mut s, RequestBody::SetOverride { rate_bits: speed.to_bits() }, "SetOverride")?;
    query(&mut s, RequestBody::SetStatusPeriod { ms: STATUS_PERIOD_MS }, "SetStatusPeriod")?;
    s.streaming = true;
    let base = status(&mut s)?;

    let mut report = PolarReport {
        blocks: blocks.len(),
        events: model.events,
        model_ticks: model.ticks,
        min_event_credits: u16::MAX,
        ..PolarReport::default()
    };
    let mut pending: HashMap<u32, Pending> = HashMap::new();
    let mut next = 0usize;
    let mut acked = 0usize;
    let mut start_seq: Option<u32> = None;
    let mut started = false;
    let mut latest = base.clone();
    let mut start_tick: Option<u64> = None;
    let mut poll_in_flight = false;
    let mut last_poll = Instant::now();
    let mut last_tx = (s.host.sent_frames, Instant::now());
    let mut last_say = Instant::now();
    let slack_ticks = SLACK_SECONDS * u64::from(cfg.machine.tick_hz);
    let mut watch = runner::JobWatch::new(model.ticks, SLOWDOWN, slack_ticks, NO_PROGRESS);
    let mut steer = runner::Steer::default();

    loop {
        s.pump(Duration::from_millis(5)).map_err(link)?;
        for n in s.notices.drain(..) {
            say(&n);
        }
        for (seq, result) in s.take_answers() {
            let Some(p) = pending.remove(&seq) else { continue };
            match (p, result) {
                (Pending::Block, Ok(_)) => acked += 1,
                (Pending::Block, Err(r)) => {
                    bail!("the board refused block {acked}: {}", describe_rejection(&r))
                }
                (Pending::Start, Ok(_)) => started = true,
                (Pending::Start, Err(r)) => {
                    bail!("the board refused StartPlayback: {}", describe_rejection(&r))
                }
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
                // Announced before this job (e.g. ConfigMissing at boot, cleared above).
                HostEvent::Fault { tick, .. } if tick < base.tick => {}
                HostEvent::Fault { code, tick } => bail!(
                    "board fault {} ({}) at tick {tick}, after {} events",
                    code.name(),
                    code.description(),
                    latest.events_fired
                ),
                HostEvent::SessionLost(code) => {
                    bail!("{}: the job cannot resume safely", LinkFailure::SessionLost(code))
                }
                _ => {}
            }
        }
        if latest.faults != 0 {
            bail!(
                "the board faulted ({}) after {} of {} events",
                fault_names(latest.faults),
                latest.events_fired,
                model.events
            );
        }
        report.min_event_credits = report.min_event_credits.min(latest.event_credits);

        // Blocks, as event credits and the window allow.
        while next < blocks.len() && s.host.window_free() > 0 && s.host.event_credits() > 0 {
            let bytes = BlockBytes::from_slice(blocks[next])
                .ok_or_else(|| anyhow!("block {next} is longer than a link block"))?;
            let last = next + 1 == blocks.len();
            let seq = s
                .send(RequestBody::from(PolarRequest::QueueEvents(EventBlock { bytes, last })))
                .map_err(link)?;
            pending.insert(seq, Pending::Block);
            next += 1;
        }

        // Start once the board's block queue is full or the whole stream is queued.
        let queued_all = acked == next && (next == blocks.len() || s.host.event_credits() == 0);
        if start_seq.is_none() && acked > 0 && queued_all {
            start_tick = Some(latest.tick);
            let body =
                RequestBody::from(PolarRequest::StartPlayback { m: opts.scale.m, k: opts.scale.k });
            let seq = s.send(body).map_err(link)?;
            pending.insert(seq, Pending::Start);
            start_seq = Some(seq);
            say(&format!("{acked} blocks queued: StartPlayback {}:{}", opts.scale.m, opts.scale.k));
        }

        // Starved of credits, or quiet for a while: ask for a status.
        let starved = next < blocks.len() && s.host.event_credits() == 0;
        let quiet =
            s.host.sent_frames == last_tx.0 && last_tx.1.elapsed() >= runner::HEARTBEAT_EVERY;
        if s.host.sent_frames != last_tx.0 {
            last_tx = (s.host.sent_frames, Instant::now());
        }
        if (starved && last_poll.elapsed() >= Duration::from_millis(10) || quiet)
            && !poll_in_flight
            && s.host.window_free() > 0
        {
            let seq = s.send(RequestBody::GetStatus).map_err(link)?;
            pending.insert(seq, Pending::Poll);
            poll_in_flight = true;
            last_poll = Instant::now();
        }

        if opts.progress && last_say.elapsed() >= Duration::from_secs(1) {
            last_say = Instant::now();
            say(&format!(
                "{} / {} events fired, {acked} / {} blocks acknowledged, state {:?}",
                latest.events_fired,
                model.events,
                blocks.len(),
                latest.machine
            ));
        }

        // Done: the start was answered, and a later status shows the job over.
        let after_start = start_seq.is_some_and(|ss| seq_at_or_after(latest.next_seq, ss + 1));
        if started && after_start && latest.machine == MachineState::Ready && next == blocks.len() {
            break;
        }
        steer.step(&mut s, hook, &latest, &mut watch)?;
        let overdue = match started && !steer.held() {
            true => watch.check(latest.tick, u64::from(latest.events_fired)).err(),
            false => None,
        };
        if let Some(why) = overdue {
            let _ = s.request(RequestBody::Abort);
            bail!(
                "the job {why}: aborted after {} of {} events",
                latest.events_fired,
                model.events
            );
        }
    }

    let fin = status(&mut s)?;
    let _ = s.request(RequestBody::SetStatusPeriod { ms: 0 });
    report.events_fired = fin.events_fired;
    report.positions = [fin.positions[0] - base.positions[0], fin.positions[1] - base.positions[1]];
    report.expected_positions = model.positions;
    report.board_ticks = latest.tick.saturating_sub(start_tick.unwrap_or(latest.tick));
    report.seconds = t0.elapsed().as_secs_f64();
    report.frames_out = s.host.sent_frames;
    report.retransmissions = s.host.retransmissions;
    report.link_naks = s.stats.link_naks;
    report.bad_frames_in = s.stats.bad_frames_in;
    if report.events_fired != model.events {
        report
            .problems
            .push(format!("{} events fired, {} in the stream", report.events_fired, model.events));
    }
    if report.positions != model.positions {
        report.problems.push(format!(
            "final (theta, r) {:?} != host model {:?} steps",
            report.positions, model.positions
        ));
    }
    if fin.faults != 0 {
        report.problems.push(format!("faults latched: {}", fault_names(fin.faults)));
    }
    Ok(report)
}
