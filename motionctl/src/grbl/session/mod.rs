//! The bridge's loop: bytes from the sender (real-time commands at once, lines in order under
//! back-pressure), program lines through the interpreter and the planner, segments to the board
//! through the link as its credits allow, and the board's state back as grbl states.
//!
//! The board's state is reconciled with what the sender asked for: a hold wanted and the board
//! running sends `Hold`; no hold wanted and the board holding sends `Resume`; segments queued on
//! a board that is `Ready` send `Start`. Each reconciling request waits for a status newer than
//! itself, so a request is never repeated on stale news.
//!
//! Here the bridge's state and its loop; further `impl Bridge` blocks, one concern a file (each
//! imports only this module, never a sibling): `realtime` (real-time bytes, the status report),
//! `lines` (program lines into the pipeline), `stream` (segments, spindle and coolant, pauses
//! and dwells to the board; Hold, Resume, Start), `link` (requests, statuses, answers, the
//! loop's link step), `stop` (stopping, soft reset, startup lines), `alarms` (faults and
//! refused moves), `dollar` (`$` commands), `settings_cmds` (commands that change stored
//! settings), `jog` (`$J=`), `spindle_stop` (0x9E during a hold) and `probe` (G38.x probe
//! moves, each run alone with the block's answer after its result).

mod alarms;
mod capability;
mod dollar;
mod jog;
mod lines;
mod link;
mod probe;
mod realtime;
mod settings_cmds;
mod spindle_stop;
mod stop;
mod stream;
#[cfg(test)]
mod tests_probe;

pub use capability::JobSetup;
pub use jog::{parse_jog, Jog};

use super::endpoint::Endpoint;
use super::pipeline::Pipeline;
use super::program::Program;
use super::protocol::RxBuffer;
use super::settings::Settings;
use crate::job::Machine;
use crate::link::Session;
use anyhow::{anyhow, Result};
use motion::machine::MachineState;
use motion::protocol::Status;
use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What a request sent without waiting was for, so its answer is handled when it comes.
enum Pending {
    Batch {
        n: u32,
    },
    /// Hold, Resume or Start, sent to reconcile the board with the sender.
    Control,
    Poll,
    Ignore,
}

/// Where the settings live: the machine file (read, never written) and the overlay the bridge
/// keeps changed settings and startup lines in.
pub struct Persist {
    pub machine_path: std::path::PathBuf,
    /// The machine file's text, which [`super::settings::machine_with`] edits.
    pub machine_src: String,
    pub overlay: std::path::PathBuf,
    /// The settings now (the machine file's, with the overlay's over them).
    pub settings: Settings,
    pub startup: [String; 2],
}

pub struct Bridge<'a> {
    s: Session<'a>,
    ep: &'a mut dyn Endpoint,
    machine: &'static Machine,
    spm: Vec<f64>,
    /// G-code axis index (X 0 .. C 5) of each machine axis.
    gaxis: Vec<usize>,
    tick_hz: f64,
    settings: Settings,
    prog: Program,
    motion: Pipeline,
    rx: RxBuffer,
    latest: Status,
    latest_at: Instant,
    /// Board `segments_done` when counting began; segments sent, acknowledged since then.
    base_done: u32,
    sent: u32,
    acked: u32,
    /// Durations (ticks) of segments sent and not yet known done, oldest first.
    inflight: VecDeque<u32>,
    popped: u32,
    pending: HashMap<u32, Pending>,
    control_seq: Option<u32>,
    last_tx: (u64, Instant),
    faults_seen: u32,
    alarm: Option<u8>,
    hold: bool,
    door: bool,
    /// An M0/M1 reached the front of the queue: held until cycle start.
    paused: bool,
    jog: bool,
    check: bool,
    homing: bool,
    dwell_until: Option<Instant>,
    /// The real-time spindle stop, and the spin-up a resume waits for after it.
    spindle_stop: spindle_stop::SpindleStop,
    spin_up_until: Option<Instant>,
    /// Feed, rapid, spindle override, percent.
    ovr: [u8; 3],
    /// Feed of the last move queued, mm/min.
    feed_now: f64,
    startup_lines: [String; 2],
    machine_path: std::path::PathBuf,
    machine_src: String,
    overlay: std::path::PathBuf,
    /// Offsets kept across resets and program ends (grbl's EEPROM).
    kept: Vec<(usize, f64)>,
    /// The board refused queued motion: stop the rest.
    stop_wanted: bool,
    build_info: String,
    /// Capability jobs (`$MILL=`, `$POLAR=`, `$TURN=`, `$WIRE=`), when set up.
    jobs: Option<JobSetup>,
    /// A probe move on its way (no line is taken until it has ended), and the last result.
    probe: Option<probe::ProbeStep>,
    last_probe: probe::LastProbe,
    pub interrupt: Arc<AtomicBool>,
}

fn link_err(e: crate::link::LinkFailure) -> anyhow::Error {
    anyhow!("{e}")
}

impl<'a> Bridge<'a> {
    /// A bridge on a connected, configured session streaming status (`latest` is a fresh one).
    pub fn new(
        s: Session<'a>,
        ep: &'a mut dyn Endpoint,
        machine: &'static Machine,
        cfg: motion::MachineConfig,
        latest: Status,
        alarm: Option<u8>,
        persist: Persist,
    ) -> Self {
        let mut motion = Pipeline::new(machine, cfg);
        motion.reset(&latest.positions);
        let prog = Program::new(machine, &motion.pos_mm);
        const NAMES: [&str; 6] = ["X", "Y", "Z", "A", "B", "C"];
        let gaxis = machine
            .axes
            .iter()
            .enumerate()
            .map(|(i, a)| NAMES.iter().position(|n| a.name.eq_ignore_ascii_case(n)).unwrap_or(i))
            .collect();
        Bridge {
            s,
            ep,
            machine,
            spm: machine.axes.iter().map(|a| a.steps_per_mm).collect(),
            gaxis,
            tick_hz: cfg.tick_hz.max(1) as f64,
            settings: persist.settings,
            prog,
            motion,
            rx: RxBuffer::default(),
            base_done: latest.segments_done,
            faults_seen: latest.faults,
            latest,
            latest_at: Instant::now(),
            sent: 0,
            acked: 0,
            inflight: VecDeque::new(),
            popped: 0,
            pending: HashMap::new(),
            control_seq: None,
            last_tx: (0, Instant::now()),
            alarm,
            hold: false,
            door: false,
            paused: false,
            jog: false,
            check: false,
            homing: false,
            dwell_until: None,
            spindle_stop: Default::default(),
            spin_up_until: None,
            ovr: [100; 3],
            feed_now: 0.0,
            startup_lines: persist.startup,
            machine_path: persist.machine_path,
            machine_src: persist.machine_src,
            overlay: persist.overlay,
            kept: Vec::new(),
            stop_wanted: false,
            build_info: String::new(),
            jobs: None,
            probe: None,
            last_probe: probe::LastProbe::none(machine.axes.len()),
            interrupt: Arc::new(AtomicBool::new(false)),
        }
    }

    /// Lets senders run capability jobs (`$MILL=`, `$POLAR=`, `$TURN=`, `$WIRE=`).
    pub fn with_jobs(mut self, jobs: JobSetup) -> Self {
        self.jobs = Some(jobs);
        self
    }

    /// Serves senders until interrupted (then stops the machine) or the link fails.
    pub fn run(&mut self) -> Result<()> {
        while !self.step()? {}
        Ok(())
    }

    /// One pass of the loop: what the sender sent, then the board; true once interrupted (the
    /// machine stopped).
    pub fn step(&mut self) -> Result<bool> {
        if self.interrupt.load(Ordering::SeqCst) {
            self.stop_motion()?;
            return Ok(true);
        }
        let wait = if self.busy() { 1 } else { 5 };
        let input = self.ep.poll(Duration::from_millis(wait))?;
        // A sender that closed the port and opened it again: the old one's end first.
        if input.reopened {
            self.sender_closed()?;
        }
        if input.opened {
            eprintln!("motionctl: a sender connected on {}", self.ep.describe());
            self.soft_reset()?;
        }
        for b in input.data {
            self.byte(b)?;
        }
        if input.closed && !input.reopened {
            self.sender_closed()?;
        }
        self.lines()?;
        self.link()?;
        Ok(false)
    }

    fn sender_closed(&mut self) -> Result<()> {
        eprintln!("motionctl: the sender closed {}; motion stopped", self.ep.describe());
        self.stop_motion()?;
        self.rx.clear();
        Ok(())
    }

    fn busy(&self) -> bool {
        self.moving() || self.rx.has_line()
    }

    fn say(&mut self, line: &str) {
        let mut b = Vec::with_capacity(line.len() + 2);
        b.extend_from_slice(line.as_bytes());
        b.extend_from_slice(b"\r\n");
        self.ep.write(&b);
    }

    fn ok(&mut self) {
        self.say("ok");
    }

    fn error(&mut self, n: u8) {
        self.say(&format!("error:{n}"));
    }

    fn done(&self) -> u32 {
        self.latest.segments_done.wrapping_sub(self.base_done)
    }

    /// Motion queued, planned, on its way or running.
    fn moving(&self) -> bool {
        !self.motion.is_empty()
            || self.pending.values().any(|p| matches!(p, Pending::Batch { .. }))
            || self.acked > self.done()
            || self.latest.queue_depth > 0
            || matches!(self.latest.machine, MachineState::Running | MachineState::Holding)
            || self.dwell_until.is_some()
            || self.spin_up_until.is_some()
    }
}
