//! What a run did ([`RunReport`], as text, JSON and one line for scripts) and why one stopped
//! early ([`RunError`]).

use super::path_check::{PathSummary, PATH_LIMIT_STEPS};
use crate::link::LinkFailure;
use crate::noise::NoiseStats;
use motion::machine::ProbeKind;
use motion::protocol::{BoardCounters, ProgramOutputs};
use motion::MAX_AXES;
use std::fmt::Write as _;

/// Where a probe move ended: whether the probe tripped, the position the board latched at the
/// trip and where the axes came to rest, steps from the job's start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeOutcome {
    pub tripped: bool,
    pub trip_steps: [i64; MAX_AXES],
    pub rest_steps: [i64; MAX_AXES],
}

/// A probe move as run, for the report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Probed {
    /// The G-code line.
    pub line: Option<usize>,
    pub kind: ProbeKind,
    pub outcome: ProbeOutcome,
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
    /// Every probe move (G38.x), in program order, as the board ended it.
    pub probes: Vec<Probed>,
    /// The board's positions in its status reports against the planned path.
    pub path: PathSummary,
    pub problems: Vec<String>,
}

impl RunReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }

    /// Names what is wrong with a finished run of `total` segments in `problems`: segments
    /// missing, lost or reordered, positions off the host model, the queue overflowed, the
    /// path executed off the planned one.
    pub(super) fn check(&mut self, total: u32) {
        if self.done != total {
            self.problems.push(format!("{} segments done, {total} sent", self.done));
        }
        if self.done_hash != self.expected_hash {
            self.problems.push(format!(
                "order hash {:#010x} != expected {:#010x}: a segment was lost, repeated or \
                 reordered",
                self.done_hash, self.expected_hash
            ));
        }
        if self.positions != self.expected_positions {
            self.problems.push(format!(
                "final positions {:?} != host model {:?} steps",
                self.positions, self.expected_positions
            ));
        }
        if self.max_credits > self.capacity || self.queue_full_naks > 0 {
            self.problems.push(format!(
                "queue overflow: credits up to {} of capacity {}, {} QueueFull NAKs",
                self.max_credits, self.capacity, self.queue_full_naks
            ));
        }
        if !self.path.ok() {
            self.problems.push(format!(
                "the executed path left the planned one: {} of {} status reports more than \
                 {PATH_LIMIT_STEPS} steps off it (worst {:.2} steps); the first: {}",
                self.path.off_path,
                self.path.samples,
                self.path.max_dev_steps,
                self.path.first_off.as_deref().unwrap_or("?")
            ));
        }
        self.min_credits = self.min_credits.min(self.max_credits);
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
            "path": {
                "samples": self.path.samples,
                "during_probes": self.path.during_probes,
                "skipped_stale": self.path.skipped_stale,
                "max_dev_steps": self.path.max_dev_steps,
                "limit_steps": PATH_LIMIT_STEPS,
                "ok": self.path.ok(),
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
             min_credits={} max_credits={} queue_full_naks={} probes={} probes_tripped={} \
             path_samples={} path_max_dev_steps={:.3} path_ok={}",
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
            self.probes.len(),
            self.probes.iter().filter(|p| p.outcome.tripped).count(),
            self.path.samples,
            self.path.max_dev_steps,
            self.path.ok() as u8,
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
        let _ = writeln!(t, "path       {}", path_text(&self.path));
        let _ = writeln!(t, "board      {}", counters_text(&self.board));
        if !self.output_switches.is_empty() {
            let _ = writeln!(
                t,
                "outputs    {} spindle/coolant switches; at the end: {}",
                self.output_switches.len(),
                crate::outputs::describe(ProgramOutputs::from_bits(self.final_outputs))
            );
        }
        for p in &self.probes {
            let line = p.line.map_or(String::new(), |l| format!(" (line {l})"));
            let mut at = String::new();
            for (i, (name, spm)) in axes.iter().enumerate() {
                let _ = write!(at, "{name} {:.4} ", p.outcome.trip_steps[i] as f64 / spm);
            }
            let _ = match p.outcome.tripped {
                true => writeln!(t, "probe      {}{line}: tripped at {}mm", p.kind.gcode(), at),
                false => writeln!(t, "probe      {}{line}: no trip", p.kind.gcode()),
            };
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

/// The board's error and stall counters in words (the run's report and `motionctl status`).
pub fn counters_text(c: &BoardCounters) -> String {
    format!(
        "{} USART overruns, {} bad frames, {} answers dropped, {} tick overruns, {} steps \
         deferred, {} holds for a late host",
        c.usart_overruns,
        c.frames_bad,
        c.responses_dropped,
        c.tick_overruns,
        c.steps_deferred,
        c.starve_holds
    )
}

/// The path check in words: how many status reports, how far off the planned path.
fn path_text(p: &PathSummary) -> String {
    let mut t = if p.ok() {
        format!(
            "{} status samples, all within {:.2} steps of the planned path",
            p.samples, p.max_dev_steps
        )
    } else {
        format!(
            "{} status samples, {} more than {PATH_LIMIT_STEPS} steps off the planned path \
             (worst {:.2} steps); the first: {}",
            p.samples,
            p.off_path,
            p.max_dev_steps,
            p.first_off.as_deref().unwrap_or("?")
        )
    };
    if p.during_probes > 0 {
        let _ = write!(t, " ({} of them during probe moves)", p.during_probes);
    }
    if p.skipped_stale > 0 {
        let _ = write!(t, "; {} older than one already checked, skipped", p.skipped_stale);
    }
    t
}

pub(super) fn err(message: impl Into<String>) -> RunError {
    RunError { message: message.into(), report: None }
}

pub(super) fn link_err(e: LinkFailure) -> RunError {
    err(e.to_string())
}
