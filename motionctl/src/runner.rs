//! `motionctl run`: streams a planned job to the board and checks what it did.
//!
//! Hello (protocol version) -> the board must be idle with an empty queue -> `SetConfig` from the
//! job's `[machine]` (skipped when the board already has it) -> `SetStatusPeriod` -> the
//! segments of [`crate::plan::Stream`] in `QueueSegments` batches as credits allow, `Start` once
//! the queue is full (or everything before the next event is queued), the spindle and coolant
//! switched (`SetProgramOutputs`, read back from the board's status) once the motion before them
//! is done,
//! program pauses (M0) held until the operator presses Enter -> wait until every segment is done
//! and the board is idle -> verify: segments done == sent, the board's order hash == the hash of
//! the ids sent (every segment exactly once, in order), final positions == the host model's.

use crate::convert::Program;
use crate::csv_log::CsvLog;
use crate::job::Job;
use crate::link::{describe_rejection, LinkFailure, Session};
use crate::noise::NoiseStats;
use crate::plan::Output;
use crate::progress::Progress;
use crate::transport::Transport;
use motion::dda::Command;
use motion::machine::MachineState;
use motion::protocol::{
    AxisScale, BoardCounters, ErrorCode, FaultCode, HostConfig, HostEvent, ProgramOutputs, Reply,
    RequestBody, SegmentBatch, Status, WireConfig, MAX_SEGMENTS_PER_FRAME,
};
use motion::segment::{order_hash, Segment};
use motion::{Rate, MAX_AXES};
use std::collections::{HashMap, VecDeque};
use std::fmt::Write as _;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

/// Default status period: 25 Hz, so the stream stays at or above 20 Hz however it is counted.
pub const DEFAULT_STATUS_PERIOD_MS: u16 = 40;

pub struct RunOptions {
    /// Wait for Enter at a program pause; otherwise continue at once (and say so).
    pub interactive: bool,
    pub status_period_ms: u16,
    pub host: HostConfig,
    /// Most segments per `QueueSegments` (1..=4); fewer while the link is noisy.
    pub max_batch: usize,
    pub csv: Option<CsvLog>,
    pub progress: bool,
    /// Set by Ctrl-C: abort the board and stop.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// Home the board first if it is not homed (else such a board refuses the job).
    pub home: bool,
    /// Keep the run journal (the line executing, for `run --resume`).
    pub journal: Option<crate::journal::Writer>,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            interactive: false,
            status_period_ms: DEFAULT_STATUS_PERIOD_MS,
            host: HostConfig { rto_ms: 100, window: 8 },
            max_batch: MAX_SEGMENTS_PER_FRAME,
            csv: None,
            progress: false,
            interrupt: None,
            home: false,
            journal: None,
        }
    }
}

/// What a run did; `problems` is empty when every check passed.
#[derive(Clone, Debug, Default)]
pub struct RunReport {
    pub segments: u32,
    pub acked: u32,
    pub done: u32,
    pub done_hash: u32,
    pub expected_hash: u32,
    pub positions: Vec<i64>,
    pub expected_positions: Vec<i64>,
    pub seconds: f64,
    /// From the first batch sent to the last segment done.
    pub stream_seconds: f64,
    pub acked_per_s: f64,
    pub frames_out: u64,
    pub retransmissions: u64,
    pub link_naks: u64,
    pub bad_frames_in: u64,
    pub reconnects: u64,
    pub statuses: u64,
    pub status_hz_board: f64,
    pub status_hz_wall: f64,
    pub capacity: u16,
    /// Segments queued and not finished (the board's queue plus the DDA's own ready queue).
    pub max_queue_depth: u16,
    /// Credits seen in status reports: never above `capacity` (else the queue overflowed).
    pub min_credits: u16,
    pub max_credits: u16,
    pub queue_full_naks: u64,
    pub noise: Option<(NoiseStats, NoiseStats)>,
    /// The board's counters over the run (its final Status's less its first).
    pub board: BoardCounters,
    /// Every spindle/coolant switch in program order, as the board showed it right after.
    pub output_switches: Vec<crate::outputs::Switched>,
    /// The board's `Status::outputs` at the end.
    pub final_outputs: u8,
    pub problems: Vec<String>,
}

impl RunReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }

    /// The summary as one JSON object: positions per axis in steps and in mm (`"mm"`), or in
    /// degrees (`"deg"`) for the rotary axes A, B, C (`axes` = name and steps per unit), the
    /// checks, the times and the link's and the board's counts.
    pub fn json(&self, axes: &[(String, f64)]) -> serde_json::Value {
        let mut pos = serde_json::Map::new();
        for (i, (name, spm)) in axes.iter().enumerate() {
            let steps = self.positions.get(i).copied().unwrap_or(0);
            let rotary = ["A", "B", "C"].iter().any(|r| name.eq_ignore_ascii_case(r));
            let mut axis = serde_json::json!({
                "steps": steps,
                "model_steps": self.expected_positions.get(i).copied().unwrap_or(0),
            });
            axis[if rotary { "deg" } else { "mm" }] = serde_json::json!(steps as f64 / spm);
            pos.insert(name.clone(), axis);
        }
        serde_json::json!({
            "ok": self.ok(),
            "segments": self.segments,
            "acked": self.acked,
            "done": self.done,
            "order_hash_ok": self.done_hash == self.expected_hash,
            "positions_ok": self.positions == self.expected_positions,
            "positions": pos,
            "seconds": self.seconds,
            "stream_seconds": self.stream_seconds,
            "frames_out": self.frames_out,
            "retransmissions": self.retransmissions,
            "link_naks": self.link_naks,
            "bad_frames_in": self.bad_frames_in,
            "reconnects": self.reconnects,
            "statuses": self.statuses,
            "board": {
                "usart_overruns": self.board.usart_overruns,
                "frames_bad": self.board.frames_bad,
                "responses_dropped": self.board.responses_dropped,
                "tick_overruns": self.board.tick_overruns,
                "steps_deferred": self.board.steps_deferred,
                "starve_holds": self.board.starve_holds,
            },
            "output_switches": self.output_switches.len(),
            "final_outputs": self.final_outputs,
            "problems": self.problems,
        })
    }

    /// One `key=value` line for scripts (the xtask end-to-end test and bench parse it).
    pub fn machine_line(&self) -> String {
        format!(
            "motionctl-summary ok={} segments={} acked={} done={} hash_ok={} positions_ok={} \
             seconds={:.3} stream_seconds={:.3} acked_per_s={:.1} frames_out={} \
             retransmissions={} link_naks={} bad_frames_in={} reconnects={} statuses={} \
             status_hz_board={:.2} status_hz_wall={:.2} capacity={} max_queue_depth={} \
             min_credits={} max_credits={} queue_full_naks={}",
            self.ok() as u8,
            self.segments,
            self.acked,
            self.done,
            (self.done_hash == self.expected_hash) as u8,
            (self.positions == self.expected_positions) as u8,
            self.seconds,
            self.stream_seconds,
            self.acked_per_s,
            self.frames_out,
            self.retransmissions,
            self.link_naks,
            self.bad_frames_in,
            self.reconnects,
            self.statuses,
            self.status_hz_board,
            self.status_hz_wall,
            self.capacity,
            self.max_queue_depth,
            self.min_credits,
            self.max_credits,
            self.queue_full_naks,
        )
    }

    /// The human summary.
    pub fn text(&self, axes: &[(String, f64)]) -> String {
        let mut t = String::new();
        let hash = if self.done_hash == self.expected_hash { "==" } else { "!=" };
        let _ = writeln!(
            t,
            "segments   {} sent, {} acknowledged, {} executed; order hash {:#010x} {hash} \
             expected {:#010x}",
            self.segments, self.acked, self.done, self.done_hash, self.expected_hash
        );
        let mut pos = String::new();
        for (i, (name, spm)) in axes.iter().enumerate() {
            let got = self.positions.get(i).copied().unwrap_or(0);
            let want = self.expected_positions.get(i).copied().unwrap_or(0);
            let eq = if got == want { "==" } else { "!=" };
            let _ = write!(pos, "{name} {:.4} mm ({got} steps {eq} {want})  ", got as f64 / spm);
        }
        let _ = writeln!(t, "positions  {} (host model)", pos.trim_end());
        let _ = writeln!(
            t,
            "time       {:.2} s total, {:.2} s streaming, {:.1} segments/s acknowledged",
            self.seconds, self.stream_seconds, self.acked_per_s
        );
        let _ = writeln!(
            t,
            "link       {} frames out, {} retransmitted, {} NAKs for garbled/missing requests, \
             {} garbled frames in, {} reconnects",
            self.frames_out,
            self.retransmissions,
            self.link_naks,
            self.bad_frames_in,
            self.reconnects
        );
        let _ = writeln!(
            t,
            "status     {} reports while streaming: {:.1} Hz board time, {:.1} Hz wall time",
            self.statuses, self.status_hz_board, self.status_hz_wall
        );
        let _ = writeln!(
            t,
            "queue      capacity {} (credits seen {}..={}), deepest {} incl. the DDA's ready \
             queue, {} QueueFull NAKs",
            self.capacity,
            self.min_credits,
            self.max_credits,
            self.max_queue_depth,
            self.queue_full_naks
        );
        let c = &self.board;
        let _ = writeln!(
            t,
            "board      {} USART overruns, {} bad frames, {} answers dropped, {} tick overruns, \
             {} steps deferred, {} holds for a late host",
            c.usart_overruns,
            c.frames_bad,
            c.responses_dropped,
            c.tick_overruns,
            c.steps_deferred,
            c.starve_holds
        );
        if !self.output_switches.is_empty() {
            let _ = writeln!(
                t,
                "outputs    {} spindle/coolant switches; at the end: {}",
                self.output_switches.len(),
                crate::outputs::describe(ProgramOutputs::from_bits(self.final_outputs))
            );
        }
        if let Some((to, from)) = self.noise {
            let _ = writeln!(
                t,
                "noise      to board {} bytes ({} corrupted, {} dropped); from board {} bytes \
                 ({} corrupted, {} dropped)",
                to.bytes, to.corrupted, to.dropped, from.bytes, from.corrupted, from.dropped
            );
        }
        t
    }
}

/// Why a run stopped early.
#[derive(Debug)]
pub struct RunError {
    pub message: String,
    /// What was learnt before it stopped (for the summary).
    pub report: Option<Box<RunReport>>,
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for RunError {}

fn err(message: impl Into<String>) -> RunError {
    RunError { message: message.into(), report: None }
}

/// The job's machine as the board's `WireConfig`: the step-space config plus per-axis scale and
/// soft limits (rounded to steps the same way move targets are).
pub fn wire_config(job: &Job, program: &Program) -> WireConfig {
    let mut scale = [AxisScale::UNUSED; MAX_AXES];
    for (s, a) in scale.iter_mut().zip(&job.machine.axes) {
        *s = AxisScale {
            steps_per_unit_milli: (a.steps_per_mm * 1000.0).round() as u32,
            soft_min: (a.min_mm * a.steps_per_mm).round() as i64,
            soft_max: (a.max_mm * a.steps_per_mm).round() as i64,
        };
    }
    WireConfig { machine: program.config, scale, inputs: job.machine.input_filter() }
}

/// (name, steps per mm) of the job's axes.
pub fn axes_of(job: &Job) -> Vec<(String, f64)> {
    job.machine.axes.iter().map(|a| (a.name.clone(), a.steps_per_mm)).collect()
}

/// The names of the fault codes set in `bits`, comma-separated.
pub fn fault_names(bits: u32) -> String {
    let names: Vec<&str> =
        FaultCode::ALL.iter().filter(|f| bits & f.bit() != 0).map(|f| f.name()).collect();
    names.join(", ")
}

/// `a` at or after `b` in seq order.
pub fn seq_at_or_after(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) >= 0
}

enum Pending {
    Batch {
        n: u32,
    },
    Start,
    Feed(&'static str),
    /// GetStatus while starved of credits.
    Poll,
}

/// Shortest interval between credit polls.
const POLL_EVERY: Duration = Duration::from_millis(10);
/// Longest the host stays silent during a job: the board holds the job and latches LinkLost
/// after `LINK_TIMEOUT_MS` (1 s of machine time) without a valid frame. Machine time can run
/// ahead of wall time (QEMU's clock runs ~3.5x fast while the guest idles), hence the margin.
pub const HEARTBEAT_EVERY: Duration = Duration::from_millis(100);

fn status_of(reply: Reply) -> Option<Status> {
    match reply {
        Reply::Status(s) => Some(s),
        _ => None,
    }
}

fn link_err(e: LinkFailure) -> RunError {
    err(e.to_string())
}

/// One request answered: the board's reply, or an error naming `what` with the refusal (a
/// link failure as it is). The job runners' one way to ask.
pub fn ask(s: &mut Session, body: RequestBody, what: &str) -> anyhow::Result<Reply> {
    match s.request(body).map_err(|e| anyhow::anyhow!("{e}"))? {
        Ok(r) => Ok(r),
        Err(r) => anyhow::bail!("{what} refused: {}", describe_rejection(&r)),
    }
}

/// The board's status now ([`ask`] with `GetStatus`).
pub fn ask_status(s: &mut Session) -> anyhow::Result<Status> {
    match ask(s, RequestBody::GetStatus, "GetStatus")? {
        Reply::Status(st) => Ok(st),
        _ => anyhow::bail!("the board answered GetStatus without a status"),
    }
}

/// Brings a connected board to `Ready` with `cfg`, as every job runner starts: refuses a board
/// with a latched fault other than `ConfigMissing` / `ConfigCorrupt` or one that is busy, sends
/// `cfg` when the board's differs (or a fault is latched), clears either of those two (the
/// faults sending the config removes; a corrupt record is reported), and homes when the board is not homed and `home` allows it. `what` names
/// the machine in messages. Returns the board's status from before the config was sent.
pub fn ready_board(
    s: &mut Session,
    cfg: WireConfig,
    home_allowed: bool,
    what: &str,
    say: &dyn Fn(&str),
) -> Result<Status, String> {
    let query = |s: &mut Session, body: RequestBody, name: &str| -> Result<Reply, String> {
        match s.request(body).map_err(|e| e.to_string())? {
            Ok(r) => Ok(r),
            Err(r) => Err(format!("{name} refused: {}", describe_rejection(&r))),
        }
    };
    let status = |s: &mut Session| -> Result<Status, String> {
        match query(s, RequestBody::GetStatus, "GetStatus")? {
            Reply::Status(st) => Ok(st),
            _ => Err("the board answered GetStatus without a status".into()),
        }
    };
    let st = status(s)?;
    // The two faults that sending a config removes; anything else needs the operator.
    let config_missing = FaultCode::ConfigMissing.bit();
    let config_corrupt = FaultCode::ConfigCorrupt.bit();
    let replaceable = config_missing | config_corrupt;
    if st.faults & !replaceable != 0 {
        return Err(format!(
            "the board has faults latched ({}): find the cause, then `motionctl clear-fault`",
            fault_names(st.faults)
        ));
    }
    if !matches!(st.machine, MachineState::Idle | MachineState::Ready | MachineState::Fault)
        || st.queue_depth != 0
    {
        return Err(format!(
            "the board is busy (state {:?}, {} segments queued): run `motionctl abort` first",
            st.machine, st.queue_depth
        ));
    }
    if query(s, RequestBody::GetConfig, "GetConfig")? == Reply::Config(cfg) && st.faults == 0 {
        say(&format!("the board already has the {what}'s config"));
    } else {
        query(s, RequestBody::SetConfig(cfg), &format!("SetConfig ({what})"))?;
        say(&format!("sent the {what}'s config"));
    }
    if st.faults == config_missing {
        query(s, RequestBody::ClearFault, "ClearFault")?;
        say("cleared ConfigMissing (the board had no stored config)");
    } else if st.faults == config_corrupt {
        query(s, RequestBody::ClearFault, "ClearFault")?;
        say(&format!(
            "cleared ConfigCorrupt: the board's stored config failed its check and was replaced by \
             the {what}'s (check the board's flash if this happens again)"
        ));
    }
    let now = status(s)?;
    if now.machine != MachineState::Ready {
        if !home_allowed {
            return Err(format!(
                "the board is not homed (state {:?}): home it (`motionctl home`) or pass --home",
                now.machine
            ));
        }
        home(s, cfg.machine.tick_hz, say).map_err(|e| e.to_string())?;
    }
    Ok(st)
}

/// Watches a running job against two limits: `limit_ticks` of board time since the first
/// check, and `stuck_after` of wall time without the job's progress marker moving.
///
/// Board time bounds the job's length, not wall time: on a loaded host a simulator's clock runs
/// far slower than the wall clock (CI measured QEMU at about 1/11 of real time), while a real
/// board's clock is real time. The wall clock only catches a job that stopped moving.
#[derive(Debug)]
pub struct JobWatch {
    limit_ticks: u64,
    stuck_after: Duration,
    start_tick: Option<u64>,
    marker: (u64, Instant),
}

/// Why [`JobWatch::check`] gave up on a job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Overdue {
    /// The job ran `ticks` of board time, more than `limit` allows.
    BoardTime { ticks: u64, limit: u64 },
    /// The progress marker did not move for this long (wall clock).
    Stuck(Duration),
}

impl std::fmt::Display for Overdue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Overdue::BoardTime { ticks, limit } => {
                write!(f, "ran {ticks} board ticks, more than its limit of {limit}")
            }
            Overdue::Stuck(d) => write!(f, "made no progress for {} s", d.as_secs()),
        }
    }
}

impl JobWatch {
    /// A limit of `planned_ticks` times `slowdown` plus `slack_ticks` of board time.
    pub fn new(planned_ticks: u64, slowdown: f64, slack_ticks: u64, stuck_after: Duration) -> Self {
        JobWatch {
            limit_ticks: (planned_ticks as f64 * slowdown) as u64 + slack_ticks,
            stuck_after,
            start_tick: None,
            marker: (0, Instant::now()),
        }
    }

    pub fn limit_ticks(&self) -> u64 {
        self.limit_ticks
    }

    /// Checks the board's `tick` and the job's progress `marker` (any count that moves while the
    /// job does); the first call starts the board-time budget.
    pub fn check(&mut self, tick: u64, marker: u64) -> Result<(), Overdue> {
        let start = *self.start_tick.get_or_insert(tick);
        let ticks = tick.saturating_sub(start);
        if ticks > self.limit_ticks {
            return Err(Overdue::BoardTime { ticks, limit: self.limit_ticks });
        }
        if marker != self.marker.0 {
            self.marker = (marker, Instant::now());
        } else if self.marker.1.elapsed() > self.stuck_after {
            return Err(Overdue::Stuck(self.stuck_after));
        }
        Ok(())
    }
}

/// Longest homing may take in board time (the board's own search-distance limit normally
/// ends a failed search first), and in wall time without the position moving.
pub const HOMING_BOARD_SECONDS: u64 = 120;
pub const HOMING_STUCK: Duration = Duration::from_secs(30);

/// Sends `Home` and waits until the board is `Ready` (homed), polling its status; `tick_hz` is
/// the board's tick rate, for the board-time limit.
pub fn home(s: &mut Session, tick_hz: u32, say: &dyn Fn(&str)) -> Result<(), RunError> {
    match s.request(RequestBody::Home).map_err(link_err)? {
        Ok(_) => say("homing"),
        Err(r) => return Err(err(format!("Home refused: {}", describe_rejection(&r)))),
    }
    let mut watch: Option<JobWatch> = None;
    loop {
        let st = match s.request(RequestBody::GetStatus).map_err(link_err)? {
            Ok(Reply::Status(st)) => st,
            Ok(_) => return Err(err("the board answered GetStatus without a status")),
            Err(r) => return Err(err(format!("GetStatus refused: {}", describe_rejection(&r)))),
        };
        match st.machine {
            MachineState::Ready => {
                say(&format!("homed at {:?} steps", &st.positions[..]));
                return Ok(());
            }
            MachineState::Homing => {}
            m => {
                return Err(err(format!(
                    "homing ended in {m:?} (faults: {})",
                    fault_names(st.faults).if_empty("none")
                )))
            }
        }
        let watch = watch.get_or_insert_with(|| {
            JobWatch::new(0, 1.0, HOMING_BOARD_SECONDS * u64::from(tick_hz), HOMING_STUCK)
        });
        let moved: u64 = st.positions.iter().fold(0u64, |h, &p| h.rotate_left(7) ^ p as u64);
        if let Err(why) = watch.check(st.tick, moved) {
            let _ = s.request(RequestBody::Abort);
            return Err(err(format!("homing {why}: aborted")));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

trait IfEmpty {
    fn if_empty(self, alt: &str) -> String;
}

impl IfEmpty for String {
    fn if_empty(self, alt: &str) -> String {
        if self.is_empty() {
            alt.to_string()
        } else {
            self
        }
    }
}

/// One output and the G-code line it came from, if any.
type Tagged = (Output, Option<usize>);

type Pull<'a> = Box<dyn FnMut() -> Option<Result<Tagged, String>> + 'a>;

/// What a run sends, in order, pulled only as the link takes it: a planned slice, or a stream
/// planned while it runs (a G-code file read a second time).
pub struct Outputs<'a> {
    pull: Pull<'a>,
    peeked: Option<Tagged>,
    ended: bool,
    /// Segments in all, and the sum of their nominal durations (ticks at override 1.0).
    segments: u32,
    planned_ticks: u64,
    /// The host model's length of the job, ticks (ramps make it longer than the nominal sum).
    model_ticks: u64,
}

impl<'a> Outputs<'a> {
    /// Everything already planned.
    pub fn planned(outputs: &'a [Output]) -> Self {
        let mut segments = 0u32;
        let mut planned_ticks = 0u64;
        for o in outputs {
            if let Output::Segment(s) = o {
                segments += 1;
                planned_ticks += s.duration_ticks as u64;
            }
        }
        let mut it = outputs.iter();
        Outputs {
            pull: Box::new(move || it.next().map(|o| Ok((*o, None)))),
            peeked: None,
            ended: false,
            segments,
            planned_ticks,
            model_ticks: planned_ticks,
        }
    }

    /// A stream planned as it is pulled; `segments`, `planned_ticks` and `model_ticks` from a
    /// pass that planned the same job before. Each output's line from `next` (G-code's).
    pub fn streamed(
        next: impl FnMut() -> Option<Result<Tagged, String>> + 'a,
        segments: u32,
        planned_ticks: u64,
        model_ticks: u64,
    ) -> Self {
        Outputs {
            pull: Box::new(next),
            peeked: None,
            ended: false,
            segments,
            planned_ticks,
            model_ticks,
        }
    }

    pub fn segments(&self) -> u32 {
        self.segments
    }

    /// The next output, not taken.
    fn peek(&mut self) -> Result<Option<Tagged>, String> {
        if self.peeked.is_none() && !self.ended {
            match (self.pull)() {
                Some(Ok(t)) => self.peeked = Some(t),
                Some(Err(e)) => {
                    self.ended = true;
                    return Err(e);
                }
                None => self.ended = true,
            }
        }
        Ok(self.peeked)
    }

    fn advance(&mut self) {
        self.peeked = None;
    }
}

/// Where a run is, for the operator: the line of the segment executing and the planned time
/// left.
struct Whereabouts {
    /// Sent and not yet done, oldest first: (line, nominal ticks).
    in_flight: VecDeque<(Option<usize>, u64)>,
    done: u32,
    done_ticks: u64,
    planned_ticks: u64,
    /// Machine ticks per nominal tick (the host model's length over the nominal sum).
    stretch: f64,
    tick_hz: f64,
}

impl Whereabouts {
    fn sent(&mut self, line: Option<usize>, seg: &Segment) {
        self.in_flight.push_back((line, seg.duration_ticks as u64));
    }

    fn update(&mut self, done: u32) {
        while self.done < done {
            let Some((_, ticks)) = self.in_flight.pop_front() else { break };
            self.done += 1;
            self.done_ticks += ticks;
        }
    }

    /// The line being executed (or next) and seconds left at `override_factor`.
    fn at(&self, override_factor: f64) -> (Option<usize>, Option<f64>) {
        let line = self.in_flight.front().and_then(|f| f.0);
        let left = self.planned_ticks.saturating_sub(self.done_ticks) as f64 * self.stretch;
        let eta = (override_factor > 0.0).then(|| left / self.tick_hz / override_factor);
        (line, eta)
    }
}

/// The next output; a stream that cannot go on (its file changed since it was checked) aborts
/// the board and ends the run.
fn peek(
    outputs: &mut Outputs<'_>,
    s: &mut Session,
    latest: &Status,
    base: &Status,
) -> Result<Option<Tagged>, RunError> {
    outputs.peek().map_err(|e| {
        let aborted = matches!(s.request(RequestBody::Abort), Ok(Ok(_)));
        err(format!(
            "{e}; {} sent to the board; {} of {} segments were done",
            if aborted { "Abort" } else { "Abort could not be" },
            latest.segments_done.wrapping_sub(base.segments_done),
            outputs.segments
        ))
    })
}

/// Connects, configures and streams `outputs`; `expected_steps` = the host model's final
/// positions (steps from the job's start).
pub fn run(
    transport: &mut dyn Transport,
    job: &Job,
    program: &Program,
    outputs: &[Output],
    expected_steps: &[i64; MAX_AXES],
    opts: RunOptions,
) -> Result<RunReport, RunError> {
    run_outputs(transport, job, program, Outputs::planned(outputs), expected_steps, opts)
}

/// [`run`] with the outputs pulled from `outputs` as the link takes them (a stream planned
/// while it runs). `program` gives the machine and the feed commands; its items are not read.
pub fn run_outputs(
    transport: &mut dyn Transport,
    job: &Job,
    program: &Program,
    mut outputs: Outputs<'_>,
    expected_steps: &[i64; MAX_AXES],
    mut opts: RunOptions,
) -> Result<RunReport, RunError> {
    let t0 = Instant::now();
    let axes = axes_of(job);
    let n_axes = axes.len();
    let total: u32 = outputs.segments;
    let mut progress = Progress::new(total as u64, axes.clone(), opts.progress);
    let mut s = Session::new(transport, opts.host);
    s.interrupt = opts.interrupt.clone();
    let say = |p: &Progress, m: &str| p.println(&format!("motionctl: {m}"));

    // --- Hello, state check, config, status stream.
    let info = s.connect().map_err(link_err)?;
    say(
        &progress,
        &format!(
            "connected to {}: firmware {:?}, protocol v{}, queue {} segments, window {}",
            s.describe(),
            info.firmware.as_str(),
            info.version,
            info.queue_capacity,
            info.max_window
        ),
    );
    let query = |s: &mut Session, body: RequestBody, what: &str| -> Result<Reply, RunError> {
        match s.request(body).map_err(link_err)? {
            Ok(r) => Ok(r),
            Err(r) => Err(err(format!("{what} refused: {}", describe_rejection(&r)))),
        }
    };
    let want = wire_config(job, program);
    ready_board(&mut s, want, opts.home, "job's machine", &|m| say(&progress, m)).map_err(|e| {
        let why = want.validate().err().map(|e| format!(" ({e:?})")).unwrap_or_default();
        err(format!("{e}{why}"))
    })?;
    query(&mut s, RequestBody::SetStatusPeriod { ms: opts.status_period_ms }, "SetStatusPeriod")?;
    s.streaming = opts.status_period_ms > 0;
    let base = status_of(query(&mut s, RequestBody::GetStatus, "GetStatus")?)
        .ok_or_else(|| err("the board answered GetStatus without a status"))?;
    if base.positions[..n_axes].iter().any(|&p| p != 0) {
        say(
            &progress,
            &format!(
                "note: the board is not at 0 ({:?} steps); the job runs relative to there",
                &base.positions[..n_axes]
            ),
        );
    }
    let tick_hz = program.config.tick_hz.max(1) as f64;

    // --- Streaming.
    let mut report = RunReport {
        segments: total,
        capacity: info.queue_capacity,
        min_credits: u16::MAX,
        expected_hash: base.done_hash,
        ..RunReport::default()
    };
    let mut pending: HashMap<u32, Pending> = HashMap::new();
    let mut whereabouts = Whereabouts {
        in_flight: VecDeque::new(),
        done: 0,
        done_ticks: 0,
        planned_ticks: outputs.planned_ticks,
        stretch: if outputs.planned_ticks > 0 {
            outputs.model_ticks as f64 / outputs.planned_ticks as f64
        } else {
            1.0
        },
        tick_hz: program.config.tick_hz.max(1) as f64,
    };
    let mut sent_segs = 0u32;
    let mut last_batch_seq: Option<u32> = None;
    let mut start_seq: Option<u32> = None;
    let mut last_start_seq: Option<u32> = None;
    let mut ever_started = false;
    let mut start_tick: Option<u64> = None;
    let mut feed_cmds: Vec<(u64, Command)> = program.commands.clone();
    feed_cmds.sort_by_key(|c| c.0);
    let mut feed_next = 0usize;
    let mut latest = base.clone();
    let mut batch_limit = opts.max_batch.clamp(1, MAX_SEGMENTS_PER_FRAME);
    let mut clean_acks = 0u32;
    let mut seen_link_naks = 0u64;
    let mut stream_start: Option<Instant> = None;
    let mut last_ack_at = Instant::now();
    // Status-rate window: (first wall, first tick), (last wall, last tick), count.
    let mut rate_first: Option<(Instant, u64)> = None;
    let mut rate_last: Option<(Instant, u64)> = None;
    let mut rate_count = 0u64;
    let mut pause_wait: Option<mpsc::Receiver<()>> = None;
    // A dwell under way: when it ends.
    let mut dwell_until: Option<Instant> = None;
    let mut finished_at: Option<Instant> = None;
    let mut poll_in_flight = false;
    let mut last_tx = (s.host.sent_frames, Instant::now());
    let mut last_poll = Instant::now();
    let job_done = |st: &Status| st.segments_done.wrapping_sub(base.segments_done);
    // The spindle and coolant as the board has them (switched in program order from here).
    let mut switched = ProgramOutputs::from_bits(base.outputs);

    loop {
        s.pump(Duration::from_millis(5)).map_err(link_err)?;
        for n in s.notices.drain(..) {
            say(&progress, &n);
        }
        if opts.interrupt.as_ref().is_some_and(|f| f.load(Ordering::SeqCst)) {
            let aborted = matches!(s.request(RequestBody::Abort), Ok(Ok(_)));
            // An operator's stop stops the spindle and coolant too (the board's Abort stops
            // motion only).
            if switched != ProgramOutputs::OFF {
                let _ = s.request(RequestBody::SetProgramOutputs(ProgramOutputs::OFF));
            }
            return Err(err(format!(
                "interrupted: {} sent to the board; {} of {total} segments were done",
                if aborted { "Abort" } else { "Abort could not be" },
                job_done(&latest)
            )));
        }

        // Answers.
        for (seq, result) in s.take_answers() {
            let Some(p) = pending.remove(&seq) else { continue };
            match (p, result) {
                (Pending::Batch { n }, Ok(_)) => {
                    report.acked += n;
                    last_ack_at = Instant::now();
                    clean_acks += 1;
                }
                (Pending::Batch { .. }, Err(r)) => {
                    if r.code == ErrorCode::QueueFull {
                        report.queue_full_naks += 1;
                    }
                    // In Fault, say which: the operator's next step depends on it.
                    let faults = match latest.faults {
                        0 => String::new(),
                        bits => format!("; latched faults: {}", fault_names(bits)),
                    };
                    return Err(err(format!(
                        "the board refused segments after {} acknowledged: {}{faults}",
                        report.acked,
                        describe_rejection(&r)
                    )));
                }
                (Pending::Start, Ok(_)) => {
                    start_seq = None;
                    last_start_seq = Some(seq);
                    ever_started = true;
                }
                (Pending::Start, Err(r)) if r.code == ErrorCode::OutOfState => {
                    // Already moving: nothing to do.
                    start_seq = None;
                    last_start_seq = Some(seq);
                }
                (Pending::Start, Err(r)) => {
                    return Err(err(format!("the board refused Start: {}", describe_rejection(&r))))
                }
                (Pending::Feed(what), Err(r)) => say(
                    &progress,
                    &format!("feed command {what} refused: {}", describe_rejection(&r)),
                ),
                (Pending::Feed(_), Ok(_)) => {}
                (Pending::Poll, Ok(reply)) => {
                    poll_in_flight = false;
                    if let Some(st) = status_of(reply) {
                        if st.faults == 0 && seq_at_or_after(st.next_seq, latest.next_seq) {
                            report.max_queue_depth = report.max_queue_depth.max(st.queue_depth);
                            latest = st;
                        }
                    }
                }
                (Pending::Poll, Err(_)) => poll_in_flight = false,
            }
        }

        // Everything else the board said.
        while let Some(ev) = s.events.pop_front() {
            match ev {
                HostEvent::Status(st) => {
                    report.max_queue_depth = report.max_queue_depth.max(st.queue_depth);
                    report.min_credits = report.min_credits.min(st.credits);
                    report.max_credits = report.max_credits.max(st.credits);
                    let done = job_done(&st);
                    if let Some(csv) = opts.csv.as_mut() {
                        let wall_ms = t0.elapsed().as_millis() as u64;
                        let host = (s.host.retransmissions, s.stats.bad_frames_in);
                        csv.row(wall_ms, &st, done, host)
                            .map_err(|e| err(format!("writing the CSV log: {e}")))?;
                    }
                    if ever_started && finished_at.is_none() {
                        let now = Instant::now();
                        rate_first.get_or_insert((now, st.tick));
                        rate_last = Some((now, st.tick));
                        rate_count += 1;
                        start_tick.get_or_insert(st.tick);
                    }
                    if st.faults != 0 {
                        return Err(err(format!(
                            "the board faulted ({}) after {done} of {total} segments",
                            fault_names(st.faults)
                        )));
                    }
                    latest = st;
                }
                // A fault announced before this job's first status (e.g. the ConfigMissing a
                // fresh board latched at boot, cleared above) is history, not this job's.
                HostEvent::Fault { code, tick } if tick < base.tick => {
                    say(
                        &progress,
                        &format!("note: earlier board fault {} at tick {tick}", code.name()),
                    );
                }
                HostEvent::Fault { code, tick } => {
                    return Err(err(format!(
                        "board fault {} ({}) at tick {tick}, after {} of {total} segments",
                        code.name(),
                        code.description(),
                        job_done(&latest)
                    )));
                }
                HostEvent::SessionLost(code) => {
                    let why = LinkFailure::SessionLost(code);
                    return Err(err(format!(
                        "{why}; the job cannot resume safely ({} of {total} segments were done \
                         at the last report): home the machine and run the job again",
                        job_done(&latest)
                    )));
                }
                _ => {}
            }
        }

        // Shrink batches while the link is noisy (a garbled batch costs a retransmission of the
        // whole window), grow them back when it is clean.
        if s.stats.link_naks > seen_link_naks {
            seen_link_naks = s.stats.link_naks;
            batch_limit = (batch_limit / 2).max(1);
            clean_acks = 0;
        } else if clean_acks >= 16 {
            batch_limit = (batch_limit + 1).min(opts.max_batch.clamp(1, MAX_SEGMENTS_PER_FRAME));
            clean_acks = 0;
        }

        // Events (spindle and coolant, pause, dwell) once the motion before them is done.
        while let Some((out, _)) = peek(&mut outputs, &mut s, &latest, &base)? {
            if matches!(out, Output::Segment(_)) {
                break;
            }
            let before_done = report.acked == sent_segs && job_done(&latest) >= sent_segs;
            if !before_done {
                break;
            }
            match out {
                Output::Outputs(first) => {
                    let mut to = first;
                    outputs.advance();
                    // Switches with no motion between them (M9 is two calls, a program end
                    // three) are one request.
                    while let Some((Output::Outputs(next), _)) =
                        peek(&mut outputs, &mut s, &latest, &base)?
                    {
                        to = next;
                        outputs.advance();
                    }
                    if to != switched {
                        let words = crate::outputs::describe_change(switched, to);
                        say(&progress, &words);
                        let st =
                            crate::outputs::switch(&mut s, to).map_err(link_err)?.map_err(|e| {
                                err(format!(
                                    "{e}; {} of {total} segments were done",
                                    job_done(&latest)
                                ))
                            })?;
                        let shown = st.outputs;
                        if shown != to.bits() {
                            report.problems.push(format!(
                                "{words}: the board's status shows {} instead",
                                crate::outputs::describe(ProgramOutputs::from_bits(shown))
                            ));
                        }
                        report.output_switches.push(crate::outputs::Switched {
                            to,
                            shown,
                            segments_done: job_done(&st),
                        });
                        switched = to;
                    }
                }
                Output::Pause if !opts.interactive => {
                    say(&progress, "program pause (M0): not interactive, continuing at once");
                    outputs.advance();
                }
                Output::Pause => match &pause_wait {
                    None => {
                        say(
                            &progress,
                            "program pause (M0): the machine is stopped; press Enter to continue",
                        );
                        let (tx, rx) = mpsc::channel();
                        std::thread::spawn(move || {
                            let mut line = String::new();
                            let _ = std::io::stdin().read_line(&mut line);
                            let _ = tx.send(());
                        });
                        pause_wait = Some(rx);
                        break;
                    }
                    Some(rx) => {
                        if rx.try_recv().is_err() {
                            break;
                        }
                        pause_wait = None;
                        say(&progress, "continuing");
                        outputs.advance();
                    }
                },
                Output::Dwell(seconds) => {
                    let until = *dwell_until.get_or_insert_with(|| {
                        say(&progress, &format!("dwell (G4) {seconds:.3} s at rest"));
                        Instant::now() + Duration::from_millis(crate::plan::dwell_ms(seconds))
                    });
                    if Instant::now() < until {
                        break;
                    }
                    dwell_until = None;
                    outputs.advance();
                }
                Output::Segment(_) => unreachable!("checked above"),
            }
        }

        // Segments, as credits and the window allow.
        while s.host.window_free() > 0 {
            let mut batch = SegmentBatch::default();
            let credits = s.host.segment_credits() as usize;
            let room = batch_limit.min(credits);
            while batch.len() < room {
                let Some((Output::Segment(seg), line)) =
                    peek(&mut outputs, &mut s, &latest, &base)?
                else {
                    break;
                };
                if batch.push(seg).is_err() {
                    break;
                }
                whereabouts.sent(line, &seg);
                outputs.advance();
            }
            if batch.is_empty() {
                break;
            }
            let n = batch.len() as u32;
            let ids: Vec<u32> = batch.iter().map(|g| g.id).collect();
            let seq = s.send(RequestBody::QueueSegments(batch)).map_err(link_err)?;
            for id in ids {
                report.expected_hash = order_hash(report.expected_hash, id);
            }
            pending.insert(seq, Pending::Batch { n });
            sent_segs += n;
            last_batch_seq = Some(seq);
            stream_start.get_or_insert_with(Instant::now);
        }

        // Starved of credits with segments to send: ask instead of waiting for the stream.
        let more =
            matches!(peek(&mut outputs, &mut s, &latest, &base)?, Some((Output::Segment(_), _)));
        if more
            && !poll_in_flight
            && s.host.segment_credits() == 0
            && s.host.window_free() > 0
            && last_poll.elapsed() >= POLL_EVERY
        {
            let seq = s.send(RequestBody::GetStatus).map_err(link_err)?;
            pending.insert(seq, Pending::Poll);
            poll_in_flight = true;
            last_poll = Instant::now();
        }

        // Heartbeat: a job the host has gone quiet on (everything sent, long segments running)
        // still hears from it, so the board does not take the silence for a lost link.
        if s.host.sent_frames != last_tx.0 {
            last_tx = (s.host.sent_frames, Instant::now());
        } else if last_tx.1.elapsed() >= HEARTBEAT_EVERY
            && !poll_in_flight
            && s.host.window_free() > 0
        {
            let seq = s.send(RequestBody::GetStatus).map_err(link_err)?;
            pending.insert(seq, Pending::Poll);
            poll_in_flight = true;
            last_poll = Instant::now();
        }

        // Start: first once the queue is full or everything before the next event is queued;
        // again whenever a fresh status shows the board idle with segments waiting.
        let waiting = report.acked > job_done(&latest);
        let fresh = last_start_seq.is_none_or(|ls| seq_at_or_after(latest.next_seq, ls + 1));
        let nothing_more =
            !matches!(peek(&mut outputs, &mut s, &latest, &base)?, Some((Output::Segment(_), _)));
        let ready = ever_started
            || (report.acked == sent_segs && (s.host.segment_credits() == 0 || nothing_more));
        if start_seq.is_none() && waiting && fresh && latest.machine == MachineState::Ready && ready
        {
            let seq = s.send(RequestBody::Start).map_err(link_err)?;
            pending.insert(seq, Pending::Start);
            start_seq = Some(seq);
        }

        // The job's feed commands, at their machine time (as seen in the status stream).
        if let Some(t_start) = start_tick {
            while let Some(&(at, cmd)) = feed_cmds.get(feed_next) {
                if latest.tick.saturating_sub(t_start) < at {
                    break;
                }
                let (body, what) = match cmd {
                    Command::SetOverride(r) => {
                        (RequestBody::SetOverride { rate_bits: r.to_bits() }, "override")
                    }
                    Command::Hold => (RequestBody::Hold, "hold"),
                    Command::Resume => (RequestBody::Resume, "resume"),
                    // Only the board's own controllers set the capability factor; a job file
                    // cannot schedule one (convert.rs makes operator overrides only).
                    Command::CapabilityOverride(_) => {
                        feed_next += 1;
                        continue;
                    }
                };
                let seq = s.send(body).map_err(link_err)?;
                pending.insert(seq, Pending::Feed(what));
                feed_next += 1;
            }
        }

        whereabouts.update(job_done(&latest));
        let (line, eta) = whereabouts.at(Rate::from_bits(latest.override_bits).to_num::<f64>());
        if let Some(warning) = opts.journal.as_mut().and_then(|j| j.update(line, job_done(&latest)))
        {
            say(&progress, &warning);
        }
        progress.update(report.acked as u64, job_done(&latest) as u64, Some(&latest), line, eta);

        // Done?
        let all_sent = peek(&mut outputs, &mut s, &latest, &base)?.is_none()
            && pending.values().all(|p| matches!(p, Pending::Poll | Pending::Feed(_)));
        let after_batches = last_batch_seq.is_none_or(|b| seq_at_or_after(latest.next_seq, b + 1));
        if all_sent
            && after_batches
            && job_done(&latest) == total
            && latest.machine == MachineState::Ready
            && latest.queue_depth == 0
        {
            finished_at.get_or_insert_with(Instant::now);
            break;
        }
    }

    // --- Verify with a fresh status.
    let fin = status_of(query(&mut s, RequestBody::GetStatus, "GetStatus")?)
        .ok_or_else(|| err("the board answered GetStatus without a status"))?;
    let _ = s.request(RequestBody::SetStatusPeriod { ms: 0 });
    progress.finish();
    if let Some(csv) = opts.csv.as_mut() {
        // The log ends with the board's final state even when noise took the last periodic
        // status: this one was asked for, and answered reliably.
        let wall_ms = t0.elapsed().as_millis() as u64;
        let host = (s.host.retransmissions, s.stats.bad_frames_in);
        csv.row(wall_ms, &fin, job_done(&fin), host)
            .map_err(|e| err(format!("writing the CSV log: {e}")))?;
        csv.flush().map_err(|e| err(format!("writing the CSV log: {e}")))?;
    }
    report.done = job_done(&fin);
    report.done_hash = fin.done_hash;
    report.positions = fin.positions[..n_axes].to_vec();
    report.expected_positions =
        (0..n_axes).map(|i| base.positions[i] + expected_steps[i]).collect();
    report.seconds = t0.elapsed().as_secs_f64();
    if let Some(st) = stream_start {
        report.stream_seconds =
            finished_at.unwrap_or_else(Instant::now).duration_since(st).as_secs_f64();
        let ack_span = last_ack_at.duration_since(st).as_secs_f64();
        report.acked_per_s = if ack_span > 0.0 { report.acked as f64 / ack_span } else { 0.0 };
    }
    report.frames_out = s.host.sent_frames;
    report.retransmissions = s.host.retransmissions;
    report.link_naks = s.stats.link_naks;
    report.bad_frames_in = s.stats.bad_frames_in;
    report.reconnects = s.stats.reconnects;
    report.noise = s.transport().noise_stats();
    report.board = fin.counters.since(&base.counters);
    report.final_outputs = fin.outputs;
    report.statuses = rate_count;
    if let (Some((w0, k0)), Some((w1, k1))) = (rate_first, rate_last) {
        let n = rate_count.saturating_sub(1) as f64;
        let wall = w1.duration_since(w0).as_secs_f64();
        let board = k1.saturating_sub(k0) as f64 / tick_hz;
        report.status_hz_wall = if wall > 0.0 { n / wall } else { 0.0 };
        report.status_hz_board = if board > 0.0 { n / board } else { 0.0 };
    }
    if report.done != total {
        report.problems.push(format!("{} segments done, {total} sent", report.done));
    }
    if report.done_hash != report.expected_hash {
        report.problems.push(format!(
            "order hash {:#010x} != expected {:#010x}: a segment was lost, repeated or reordered",
            report.done_hash, report.expected_hash
        ));
    }
    if report.positions != report.expected_positions {
        report.problems.push(format!(
            "final positions {:?} != host model {:?} steps",
            report.positions, report.expected_positions
        ));
    }
    if report.max_credits > report.capacity || report.queue_full_naks > 0 {
        report.problems.push(format!(
            "queue overflow: credits up to {} of capacity {}, {} QueueFull NAKs",
            report.max_credits, report.capacity, report.queue_full_naks
        ));
    }
    report.min_credits = report.min_credits.min(report.max_credits);
    opts.csv = None;
    if report.ok() {
        if let Some(j) = &opts.journal {
            j.finished();
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::{JobWatch, Overdue, Whereabouts};
    use motion::segment::{Rate, Segment};
    use std::collections::VecDeque;
    use std::time::Duration;

    #[test]
    fn whereabouts_give_the_executing_line_and_the_planned_time_left() {
        let seg = |ticks: u32| Segment {
            steps: [1, 0, 0, 0, 0, 0],
            duration_ticks: ticks,
            entry_rate: Rate::ONE,
            exit_rate: Rate::ONE,
            accel_per_tick: Rate::ONE,
            id: 0,
        };
        let mut w = Whereabouts {
            in_flight: VecDeque::new(),
            done: 0,
            done_ticks: 0,
            planned_ticks: 6_000,
            stretch: 1.5,
            tick_hz: 1_000.0,
        };
        assert_eq!(w.at(1.0), (None, Some(9.0)));
        w.sent(Some(7), &seg(1_000));
        w.sent(Some(7), &seg(1_000));
        w.sent(Some(9), &seg(2_000));
        assert_eq!(w.at(1.0), (Some(7), Some(9.0)));
        w.update(2);
        // 4000 nominal ticks left, 1.5 machine ticks each, at 1 kHz.
        assert_eq!(w.at(1.0), (Some(9), Some(6.0)));
        assert_eq!(w.at(0.5), (Some(9), Some(12.0)));
        assert_eq!(w.at(0.0), (Some(9), None));
        w.update(3);
        assert_eq!(w.at(1.0), (None, Some(3.0)));
    }

    #[test]
    fn job_watch_bounds_board_time_not_wall_time() {
        let mut w = JobWatch::new(1000, 2.0, 500, Duration::from_secs(60));
        assert_eq!(w.limit_ticks(), 2500);
        // Started at tick 10_000; a slow clock is fine as long as the job moves.
        for (i, tick) in (10_000..=12_500).step_by(100).enumerate() {
            assert_eq!(w.check(tick, i as u64), Ok(()));
        }
        assert_eq!(w.check(12_501, 99), Err(Overdue::BoardTime { ticks: 2501, limit: 2500 }));
    }

    #[test]
    fn job_watch_calls_a_job_stuck_only_while_its_marker_stands_still() {
        let mut w = JobWatch::new(1000, 1.0, 0, Duration::from_millis(20));
        assert_eq!(w.check(0, 1), Ok(()));
        std::thread::sleep(Duration::from_millis(30));
        assert_eq!(w.check(1, 2), Ok(()), "the marker moved: not stuck");
        std::thread::sleep(Duration::from_millis(30));
        assert_eq!(w.check(2, 2), Err(Overdue::Stuck(Duration::from_millis(20))));
    }
}
