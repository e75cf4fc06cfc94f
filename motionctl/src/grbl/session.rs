//! The bridge's loop: bytes from the sender (real-time commands at once, lines in order under
//! back-pressure), program lines through the interpreter and the planner, segments to the board
//! through the link as its credits allow, and the board's state back as grbl states.
//!
//! The board's state is reconciled with what the sender asked for: a hold wanted and the board
//! running sends `Hold`; no hold wanted and the board holding sends `Resume`; segments queued on
//! a board that is `Ready` send `Start`. Each reconciling request waits for a status newer than
//! itself, so a request is never repeated on stale news.

use super::endpoint::Endpoint;
use super::pipeline::{MoveError, Out, Pipeline};
use super::program::{Program, Step};
use super::protocol::{self, alarm, error, realtime, Line, Realtime, RxBuffer, WELCOME};
use super::report::{Report, State};
use super::settings::{self, SetError, Settings};
use crate::job::{Feed, Item, Machine, MoveCmd, Target};
use crate::link::{describe_rejection, Session};
use crate::runner::{self, fault_names, seq_at_or_after};
use anyhow::{anyhow, bail, Result};
use motion::machine::MachineState;
use motion::protocol::{
    FaultCode, ProgramOutputs, Reply, RequestBody, SegmentBatch, Status, WireState,
    MAX_OVERRIDE_BITS, MAX_SEGMENTS_PER_FRAME,
};
use motion_gcode::canon::Units;
use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Segments waiting on the host before the bridge stops taking lines (the sender then waits
/// for its `ok`s, as with a full grbl planner).
const HOST_QUEUE_MAX: usize = 48;
/// The sender went quiet this long: the planned moves end at rest and go to the board.
const QUIET_FLUSH: Duration = Duration::from_millis(20);
/// Less than this much motion left on the board: flush now rather than risk running dry.
const LOW_WATER_S: f64 = 0.06;
/// The host speaks at least this often (the board holds a job after 1 s of silence).
const HEARTBEAT: Duration = Duration::from_millis(100);
/// Longest piece of a jog, seconds.
const JOG_PIECE_S: f64 = 0.1;
/// Longest wait for a hold to stop the machine before a reset drops its queue.
const STOP_WAIT: Duration = Duration::from_secs(5);

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
    /// The machine file's text, which [`settings::machine_with`] edits.
    pub machine_src: String,
    pub overlay: std::path::PathBuf,
    /// The settings now (the machine file's, with the overlay's over them).
    pub settings: Settings,
    pub startup: [String; 2],
}

/// grbl's build info (`$I`).
const VERSION: &str = "[VER:1.1h.20190825:";

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
            ovr: [100; 3],
            feed_now: 0.0,
            startup_lines: persist.startup,
            machine_path: persist.machine_path,
            machine_src: persist.machine_src,
            overlay: persist.overlay,
            kept: Vec::new(),
            stop_wanted: false,
            build_info: String::new(),
            interrupt: Arc::new(AtomicBool::new(false)),
        }
    }

    /// Serves senders until interrupted (then stops the machine) or the link fails.
    pub fn run(&mut self) -> Result<()> {
        loop {
            if self.interrupt.load(Ordering::SeqCst) {
                self.stop_motion()?;
                return Ok(());
            }
            let wait = if self.busy() { 1 } else { 5 };
            let input = self.ep.poll(Duration::from_millis(wait))?;
            if input.opened {
                eprintln!("motionctl: a sender connected on {}", self.ep.describe());
                self.soft_reset()?;
            }
            for b in input.data {
                self.byte(b)?;
            }
            if input.closed {
                eprintln!("motionctl: the sender closed {}; motion stopped", self.ep.describe());
                self.stop_motion()?;
                self.rx.clear();
            }
            self.lines()?;
            self.link()?;
        }
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
    }

    fn state(&self) -> State {
        if self.homing {
            State::Home
        } else if self.alarm.is_some() {
            State::Alarm
        } else if self.check {
            State::Check
        } else if self.door {
            State::Door
        } else if self.hold || self.paused {
            let stopping = self.latest.machine == MachineState::Running
                || (self.latest.machine == MachineState::Holding
                    && self.latest.state != WireState::Held);
            State::Hold { stopping }
        } else if self.moving() {
            if self.jog {
                State::Jog
            } else {
                State::Run
            }
        } else {
            State::Idle
        }
    }

    /// Machine position, mm.
    fn mpos(&self) -> Vec<f64> {
        self.spm.iter().enumerate().map(|(i, s)| self.latest.positions[i] as f64 / s).collect()
    }

    /// Work coordinate offset (G5x + G92 + tool length on Z), mm, per machine axis.
    fn wco(&self) -> Vec<f64> {
        let m = self.prog.modal();
        let k = if m.units == Units::Inches { 25.4 } else { 1.0 };
        self.gaxis
            .iter()
            .map(|&g| {
                let tool = if g == 2 { m.tool_length_offset[2] } else { 0.0 };
                match (m.g5x_offset.get(g), m.g92_offset.get(g)) {
                    (Some(a), Some(b)) => (a + b + tool) * k,
                    _ => 0.0,
                }
            })
            .collect()
    }

    fn report(&self) -> String {
        let state = self.state();
        let moving = matches!(state, State::Run | State::Jog | State::Hold { stopping: true });
        let m = self.prog.modal();
        let used = self.motion.pending_moves
            + self.motion.queued_segments()
            + self.latest.queue_depth as usize;
        let spindle_on = m.spindle != motion_gcode::Spindle::Stopped;
        Report {
            state,
            mpos: self.mpos(),
            wco: self.wco(),
            planner_free: protocol::PLANNER_BLOCKS.saturating_sub(used),
            rx_free: self.rx.free(),
            feed: if moving { self.feed_now * self.ovr[0] as f64 / 100.0 } else { 0.0 },
            speed: if spindle_on { m.speed } else { 0.0 },
            overrides: self.ovr,
            accessories: ProgramOutputs::from_bits(self.latest.outputs),
            mask: self.settings.get(settings::STATUS_MASK) as u16,
            inches: self.settings.flag(settings::REPORT_INCHES),
        }
        .line()
    }

    // ---- real-time bytes

    fn byte(&mut self, b: u8) -> Result<()> {
        let Some(r) = realtime(b) else {
            self.rx.push(b);
            return Ok(());
        };
        match r {
            Realtime::Status => {
                let line = self.report();
                self.say(&line);
            }
            Realtime::FeedHold if self.jog && self.moving() => self.stop_motion()?,
            Realtime::FeedHold => {
                if self.alarm.is_none() && !self.check {
                    self.hold = true;
                }
            }
            Realtime::SafetyDoor => {
                if self.alarm.is_none() && !self.check {
                    if self.jog && self.moving() {
                        self.stop_motion()?;
                    }
                    self.door = true;
                    self.hold = true;
                }
            }
            Realtime::CycleStart => {
                self.door = false;
                self.hold = false;
                if self.paused {
                    self.paused = false;
                    if matches!(self.motion.out.front(), Some(Out::Pause)) {
                        self.motion.out.pop_front();
                    }
                }
            }
            Realtime::Reset => self.soft_reset()?,
            Realtime::JogCancel => {
                if self.jog {
                    self.stop_motion()?;
                }
            }
            Realtime::Feed(c) => {
                let v = c.apply(self.ovr[0]);
                if v != self.ovr[0] {
                    self.ovr[0] = v;
                    self.send_override()?;
                }
            }
            Realtime::Rapid(v) => self.ovr[1] = v,
            Realtime::Spindle(c) => self.ovr[2] = c.apply(self.ovr[2]),
            Realtime::Accessory(_) | Realtime::Ignored => {}
        }
        Ok(())
    }

    fn send_override(&mut self) -> Result<()> {
        let f = self.ovr[0] as f64 / 100.0;
        let rate_bits = ((f * (1u64 << 30) as f64).round() as u32).min(MAX_OVERRIDE_BITS);
        let seq = self.s.send(RequestBody::SetOverride { rate_bits }).map_err(link_err)?;
        self.pending.insert(seq, Pending::Ignore);
        Ok(())
    }

    // ---- board requests

    fn request(&mut self, body: RequestBody, what: &str) -> Result<Reply> {
        match self.s.request(body).map_err(link_err)? {
            Ok(r) => Ok(r),
            Err(r) => bail!("{what} refused: {}", describe_rejection(&r)),
        }
    }

    fn refresh(&mut self) -> Result<()> {
        let st = runner::ask_status(&mut self.s)?;
        self.latest = st;
        self.latest_at = Instant::now();
        Ok(())
    }

    /// Waits until every segment batch sent has been answered.
    fn settle_batches(&mut self) -> Result<()> {
        let start = Instant::now();
        while self.pending.values().any(|p| matches!(p, Pending::Batch { .. })) {
            if start.elapsed() > STOP_WAIT {
                bail!("the board did not answer queued segments");
            }
            self.s.pump(Duration::from_millis(2)).map_err(link_err)?;
            self.answers();
        }
        Ok(())
    }

    /// Stops the machine on its path (hold, then abort the rest), drops everything queued, and
    /// starts counting again from where the board stands.
    fn stop_motion(&mut self) -> Result<()> {
        self.settle_batches()?;
        self.refresh()?;
        if matches!(self.latest.machine, MachineState::Running | MachineState::Holding) {
            if self.latest.machine == MachineState::Running {
                let _ = self.request(RequestBody::Hold, "Hold");
            }
            let start = Instant::now();
            loop {
                self.refresh()?;
                let running =
                    matches!(self.latest.machine, MachineState::Running | MachineState::Holding);
                if !running || self.latest.state == WireState::Held || start.elapsed() > STOP_WAIT {
                    break;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            self.request(RequestBody::Abort, "Abort")?;
        } else if self.latest.queue_depth > 0 {
            self.request(RequestBody::Abort, "Abort")?;
        }
        self.refresh()?;
        self.rebase();
        Ok(())
    }

    /// Nothing queued anywhere: counting starts again at the board's state.
    fn rebase(&mut self) {
        self.pending.retain(|_, p| !matches!(p, Pending::Batch { .. } | Pending::Control));
        self.control_seq = None;
        self.base_done = self.latest.segments_done;
        self.sent = 0;
        self.acked = 0;
        self.popped = 0;
        self.inflight.clear();
        self.motion.reset(&self.latest.positions);
        self.hold = false;
        self.door = false;
        self.paused = false;
        self.jog = false;
        self.dwell_until = None;
        if !self.prog.ended() {
            let at = self.motion.pos_mm.clone();
            self.prog.sync(&at);
        }
    }

    /// Ctrl-X, and a sender connecting: stop, forget the queue, power-on parser state,
    /// welcome.
    fn soft_reset(&mut self) -> Result<()> {
        self.stop_motion()?;
        // As grbl's reset: the spindle and coolant stop with the motion.
        self.switch_outputs(ProgramOutputs::OFF)?;
        self.rx.clear();
        self.check = false;
        if self.ovr[0] != 100 {
            self.ovr[0] = 100;
            self.send_override()?;
        }
        self.ovr = [100; 3];
        self.feed_now = 0.0;
        self.new_program();
        self.motion.soft_limits = self.settings.flag(settings::SOFT_LIMITS);
        self.say("");
        self.say(WELCOME);
        if self.alarm.is_some() {
            self.say("[MSG:'$H'|'$X' to unlock]");
        } else {
            self.startup();
        }
        Ok(())
    }

    /// The `$N0`, `$N1` startup lines, each answered `>LINE:ok` or `>LINE:error:N` (grbl runs
    /// them after a reset, and after homing when it starts in alarm).
    fn startup(&mut self) {
        for i in 0..2 {
            let line = self.startup_lines[i].clone();
            if line.is_empty() {
                continue;
            }
            let answer = match self.gcode(&line) {
                None => "ok".to_string(),
                Some(n) => format!("error:{n}"),
            };
            self.say(&format!(">{line}:{answer}"));
            if self.alarm.is_some() {
                break;
            }
        }
    }

    /// A fresh interpreter at the commanded position, keeping the offsets grbl keeps in EEPROM.
    fn new_program(&mut self) {
        let kept = if self.prog.ended() { Vec::new() } else { self.prog.persistent() };
        let kept = if kept.is_empty() { self.kept.clone() } else { kept };
        self.kept = kept.clone();
        self.prog = Program::with_parameters(self.machine, &self.motion.pos_mm, kept);
    }

    /// A board fault becomes a grbl alarm.
    fn on_faults(&mut self, bits: u32) {
        let new = bits & !self.faults_seen;
        self.faults_seen = bits;
        if new == 0 {
            return;
        }
        let first = FaultCode::ALL.iter().copied().find(|f| new & f.bit() != 0);
        let n = match first {
            Some(FaultCode::LimitSwitch) => alarm::HARD_LIMIT,
            Some(FaultCode::SoftLimit) => alarm::SOFT_LIMIT,
            Some(FaultCode::HomingFailed) => alarm::HOMING_FAIL_RESET,
            Some(FaultCode::EStop) => alarm::ESTOP,
            Some(f) => alarm::BOARD_FAULT_BASE + f.bit().trailing_zeros() as u8,
            None => alarm::ABORT_CYCLE,
        };
        self.alarm = Some(n);
        self.say(&format!("ALARM:{n}"));
        let names = fault_names(new);
        let why = first.map(|f| f.description()).unwrap_or("");
        self.say(&format!("[MSG:board fault {names}: {why}]"));
        // The board dropped its queue.
        self.pending.retain(|_, p| !matches!(p, Pending::Batch { .. }));
        self.rebase();
    }

    fn on_status(&mut self, st: Status) {
        if seq_at_or_after(st.next_seq, self.latest.next_seq) {
            self.latest = st;
            self.latest_at = Instant::now();
        }
    }

    fn answers(&mut self) {
        for (seq, result) in self.s.take_answers() {
            let Some(p) = self.pending.remove(&seq) else { continue };
            match (p, result) {
                (Pending::Batch { n }, Ok(_)) => self.acked += n,
                (Pending::Batch { .. }, Err(r)) => {
                    eprintln!("motionctl: the board refused segments: {}", describe_rejection(&r));
                    self.stop_wanted = true;
                    if self.alarm.is_none() {
                        self.alarm = Some(alarm::ABORT_CYCLE);
                        self.say(&format!("ALARM:{}", alarm::ABORT_CYCLE));
                        self.say("[MSG:the board refused queued motion]");
                    }
                }
                (Pending::Poll, Ok(Reply::Status(st))) => self.on_status(st),
                _ => {}
            }
        }
    }

    // ---- the link side

    fn link(&mut self) -> Result<()> {
        self.s.pump(Duration::from_millis(1)).map_err(link_err)?;
        for n in self.s.notices.drain(..) {
            eprintln!("motionctl: {n}");
        }
        while let Some(ev) = self.s.events.pop_front() {
            match ev {
                motion::protocol::HostEvent::Status(st) => self.on_status(st),
                motion::protocol::HostEvent::SessionLost(code) => {
                    bail!("{}", crate::link::LinkFailure::SessionLost(code))
                }
                _ => {}
            }
        }
        self.answers();
        let done = self.done();
        while self.popped < done && self.inflight.pop_front().is_some() {
            self.popped += 1;
        }
        if self.latest.faults != self.faults_seen {
            let bits = self.latest.faults;
            self.on_faults(bits);
        }
        if self.stop_wanted {
            // What is left of a refused job stops and is dropped.
            self.stop_wanted = false;
            self.stop_motion()?;
        }
        if self.alarm.is_some() {
            return Ok(());
        }

        // Flush the planner when the sender has gone quiet or the board runs low.
        if self.motion.dirty && !self.rx.has_line() {
            let quiet = self.motion.last_push.elapsed();
            let left = self.remaining_s();
            if quiet >= QUIET_FLUSH || (left < LOW_WATER_S && quiet >= Duration::from_millis(2)) {
                self.motion.flush();
            }
        }

        self.front_events()?;
        self.send_segments()?;
        self.reconcile()?;

        // Heartbeat.
        if self.s.host.sent_frames != self.last_tx.0 {
            self.last_tx = (self.s.host.sent_frames, Instant::now());
        } else if self.last_tx.1.elapsed() >= HEARTBEAT && self.s.host.window_free() > 0 {
            let seq = self.s.send(RequestBody::GetStatus).map_err(link_err)?;
            self.pending.insert(seq, Pending::Poll);
        }
        Ok(())
    }

    /// Seconds of motion left on the board and on the way (an estimate from the last status).
    fn remaining_s(&self) -> f64 {
        let ticks: u64 =
            self.inflight.iter().map(|&t| t as u64).sum::<u64>() + self.motion.queued_ticks();
        ticks as f64 / self.tick_hz - self.latest_at.elapsed().as_secs_f64()
    }

    /// Everything sent has run and the board is still.
    fn drained(&self) -> bool {
        !self.pending.values().any(|p| matches!(p, Pending::Batch { .. }))
            && self.acked >= self.sent
            && self.done() >= self.acked
            && self.latest.queue_depth == 0
            && !matches!(self.latest.machine, MachineState::Running | MachineState::Holding)
    }

    /// Spindle and coolant, pause and dwell events once the motion before them is done.
    fn front_events(&mut self) -> Result<()> {
        while let Some(&front) = self.motion.out.front() {
            match front {
                Out::Segment(_) => break,
                _ if !self.drained() => break,
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
    fn switch_outputs(&mut self, to: ProgramOutputs) -> Result<()> {
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

    fn send_segments(&mut self) -> Result<()> {
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
    fn reconcile(&mut self) -> Result<()> {
        if self.pending.values().any(|p| matches!(p, Pending::Control)) {
            return Ok(());
        }
        if self.control_seq.is_some_and(|c| !seq_at_or_after(self.latest.next_seq, c + 1)) {
            return Ok(());
        }
        let want_hold = self.hold || self.paused || self.door;
        let body = match self.latest.machine {
            MachineState::Running if want_hold => RequestBody::Hold,
            MachineState::Holding if !want_hold => RequestBody::Resume,
            MachineState::Ready if !want_hold && self.latest.queue_depth > 0 => RequestBody::Start,
            _ => return Ok(()),
        };
        let seq = self.s.send(body).map_err(link_err)?;
        self.pending.insert(seq, Pending::Control);
        self.control_seq = Some(seq);
        Ok(())
    }

    // ---- lines

    fn lines(&mut self) -> Result<()> {
        while self.rx.has_line() {
            if self.motion.queued_segments() > HOST_QUEUE_MAX
                || self.motion.out.len() > 4 * HOST_QUEUE_MAX
            {
                break;
            }
            match self.rx.pop_line() {
                Some(Line::Overflow) => self.error(error::OVERFLOW),
                Some(Line::Text(t)) => self.line(&t)?,
                None => break,
            }
        }
        Ok(())
    }

    fn line(&mut self, text: &str) -> Result<()> {
        let t = text.trim();
        if t.is_empty() || t == "%" {
            self.ok();
            return Ok(());
        }
        if t.starts_with('$') {
            return self.dollar(t);
        }
        if self.alarm.is_some() || (self.jog && self.moving()) {
            self.error(error::SYSTEM_GC_LOCK);
            return Ok(());
        }
        match self.gcode(t) {
            None => self.ok(),
            Some(n) => self.error(n),
        }
        Ok(())
    }

    /// A program line: `None` when it ran (its `[MSG:]`s said), else grbl's error number
    /// (after any alarm it raised).
    fn gcode(&mut self, t: &str) -> Option<u8> {
        if self.prog.ended() {
            self.new_program();
        }
        self.jog = false;
        let block = match self.prog.run(t) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("motionctl: `{t}`: {} (error:{})", e.message, e.code);
                return Some(e.code);
            }
        };
        // Every target checked before any is queued: a block runs whole or not at all.
        let mut from = self.motion.pos_mm.clone();
        for s in &block.steps {
            if let Step::Item(Item::Move(MoveCmd { target: Target::Absolute(t), .. })) = s {
                let to: Vec<f64> = t.iter().zip(&from).map(|(t, p)| t.unwrap_or(*p)).collect();
                if let Err(e) = self.motion.check(&from, &to) {
                    return Some(self.refuse_move(e));
                }
                from = to;
            }
        }
        for s in block.steps {
            match s {
                Step::Item(Item::Move(MoveCmd { target: Target::Absolute(t), feed, .. })) => {
                    if let Feed::MmPerMin(f) = feed {
                        self.feed_now = f;
                    } else {
                        self.feed_now = self.rapid_mm_min();
                    }
                    if let Err(e) = self.motion.push_move(&t, feed, self.check) {
                        return Some(self.refuse_move(e));
                    }
                }
                Step::Item(Item::Move(_)) => {}
                Step::Item(Item::Outputs(o)) if !self.check => {
                    self.motion.push_event(Out::Outputs(o))
                }
                Step::Item(Item::Pause) if !self.check => self.motion.push_event(Out::Pause),
                Step::Item(Item::Dwell(d)) if !self.check => self.motion.push_event(Out::Dwell(d)),
                _ => {}
            }
        }
        for m in block.messages {
            self.say(&format!("[MSG:{m}]"));
        }
        // G10 L2/L20 write origins grbl keeps across resets (and program ends).
        if t.to_ascii_uppercase().contains("G10") && !self.prog.ended() {
            self.kept = self.prog.persistent();
        }
        None
    }

    fn rapid_mm_min(&self) -> f64 {
        self.machine.axes.iter().map(|a| a.max_rate_mm_s * 60.0).fold(f64::INFINITY, f64::min)
    }

    /// Says what a refused move raised; grbl's error number for its line.
    fn refuse_move(&mut self, e: MoveError) -> u8 {
        match e {
            MoveError::SoftLimit(m) if !self.check => {
                eprintln!("motionctl: soft limit: {m}");
                // What is queued stops: the program cannot continue past this block.
                let _ = self.stop_motion();
                self.alarm = Some(alarm::SOFT_LIMIT);
                self.say(&format!("ALARM:{}", alarm::SOFT_LIMIT));
                self.say(&format!("[MSG:{m}]"));
                error::SYSTEM_GC_LOCK
            }
            MoveError::SoftLimit(m) | MoveError::Invalid(m) => {
                eprintln!("motionctl: {m}");
                error::INVALID_TARGET
            }
        }
    }

    // ---- $ commands

    fn dollar(&mut self, raw: &str) -> Result<()> {
        let upper: String = raw.to_ascii_uppercase();
        let cmd: String = upper.chars().filter(|c| !c.is_whitespace()).collect();
        let idle = !self.moving();
        match cmd.as_str() {
            "$" => {
                self.say("[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]");
                self.ok();
            }
            "$$" => {
                if self.moving() && !self.jog {
                    self.error(error::IDLE_ERROR);
                    return Ok(());
                }
                for l in self.settings.listing() {
                    self.say(&l);
                }
                self.ok();
            }
            "$#" => {
                if !idle {
                    self.error(error::IDLE_ERROR);
                    return Ok(());
                }
                self.parameters();
                self.ok();
            }
            "$G" => {
                if self.prog.ended() {
                    self.new_program();
                }
                let codes = self.prog.modal().codes().join(" ");
                self.say(&format!("[GC:{codes}]"));
                self.ok();
            }
            "$I" => {
                let v = format!("{VERSION}{}]", self.build_info);
                self.say(&v);
                self.say(&format!(
                    "[OPT:V,{},{}]",
                    protocol::PLANNER_BLOCKS,
                    protocol::RX_BUFFER_SIZE
                ));
                self.ok();
            }
            "$N" => {
                for i in 0..2 {
                    let l = format!("$N{i}={}", self.startup_lines[i]);
                    self.say(&l);
                }
                self.ok();
            }
            "$C" => {
                if self.check {
                    self.say("[MSG:Disabled]");
                    self.ok();
                    self.soft_reset()?;
                } else if self.alarm.is_some() || !idle {
                    self.error(error::IDLE_ERROR);
                } else {
                    self.check = true;
                    self.say("[MSG:Enabled]");
                    self.ok();
                }
            }
            "$X" => self.unlock()?,
            "$H" => self.home()?,
            "$SLP" => {
                self.stop_motion()?;
                self.say("[MSG:Sleeping]");
                self.ok();
            }
            "$RST=$" | "$RST=#" | "$RST=*" => {
                if !idle {
                    self.error(error::IDLE_ERROR);
                    return Ok(());
                }
                if cmd != "$RST=#" {
                    let mut next = self.settings.clone();
                    next.restore();
                    // The machine file's own values, on the board too if they differ.
                    match settings::machine_with(&self.machine_src, &next) {
                        Ok(m) => {
                            if let Err(why) = self.install_machine(m, true)? {
                                self.say(&format!("[MSG:{cmd}: {why}]"));
                                self.error(error::SETTING_READ_FAIL);
                                return Ok(());
                            }
                        }
                        Err(why) => {
                            self.say(&format!(
                                "[MSG:{cmd}: {}: {why}]",
                                self.machine_path.display()
                            ));
                            self.error(error::SETTING_READ_FAIL);
                            return Ok(());
                        }
                    }
                    self.settings = next;
                    self.motion.soft_limits = self.settings.flag(settings::SOFT_LIMITS);
                    if cmd == "$RST=*" {
                        self.startup_lines = [String::new(), String::new()];
                    }
                    self.save();
                }
                if cmd != "$RST=$" {
                    for p in 1..=6 {
                        let _ = self.prog.run(&format!("G10 L2 P{p} X0 Y0 Z0"));
                    }
                    let _ = self.prog.run("G92.1");
                    self.kept = self.prog.persistent();
                }
                self.ok();
            }
            _ if cmd.starts_with("$J=") => {
                self.jog_line(&upper[upper.find('=').unwrap_or(0) + 1..])
            }
            _ if cmd.starts_with("$N0=") || cmd.starts_with("$N1=") => {
                let i = if cmd.starts_with("$N0") { 0 } else { 1 };
                let text = raw.split_once('=').map_or("", |(_, t)| t).trim().to_string();
                if !idle {
                    self.error(error::IDLE_ERROR);
                    return Ok(());
                }
                if !text.is_empty() {
                    // Checked as a program line on a scratch interpreter: nothing runs now.
                    let mut scratch = Program::with_parameters(
                        self.machine,
                        &self.motion.pos_mm,
                        self.kept.clone(),
                    );
                    if let Err(e) = scratch.run(&text) {
                        eprintln!(
                            "motionctl: startup line `{text}`: {} (error:{})",
                            e.message, e.code
                        );
                        self.say(&format!("[MSG:$N{i}: {}]", e.message));
                        self.error(e.code);
                        return Ok(());
                    }
                }
                self.startup_lines[i] = text;
                self.save();
                self.ok();
            }
            _ if cmd.starts_with("$I=") => {
                let text = raw.split_once('=').map_or("", |(_, t)| t).trim();
                self.build_info = text.chars().take(80).collect();
                self.ok();
            }
            _ => self.setting(&cmd)?,
        }
        Ok(())
    }

    fn setting(&mut self, cmd: &str) -> Result<()> {
        let Some((n, v)) = cmd[1..].split_once('=') else {
            self.error(error::INVALID_STATEMENT);
            return Ok(());
        };
        let Ok(num) = n.parse::<u16>() else {
            self.error(error::INVALID_STATEMENT);
            return Ok(());
        };
        if !n.chars().all(|c| c.is_ascii_digit()) {
            self.error(error::INVALID_STATEMENT);
            return Ok(());
        }
        if self.moving() {
            self.error(error::IDLE_ERROR);
            return Ok(());
        }
        let mut next = self.settings.clone();
        match next.set(n, v) {
            Ok(()) => {}
            Err(SetError::BadNumber) => {
                self.error(error::BAD_NUMBER_FORMAT);
                return Ok(());
            }
            Err(SetError::Unknown) => {
                self.error(error::INVALID_STATEMENT);
                return Ok(());
            }
            Err(SetError::Negative) => {
                self.error(error::NEGATIVE_VALUE);
                return Ok(());
            }
        }
        let axes = self.machine.axes.len();
        if settings::is_machine_field(num, axes) && next.get(num) != self.settings.get(num) {
            let machine = match settings::machine_with(&self.machine_src, &next) {
                Ok(m) => m,
                Err(why) => {
                    eprintln!("motionctl: ${num}={v}: {why}");
                    self.say(&format!("[MSG:${num}={v}: {why}]"));
                    self.error(settings::OUT_OF_RANGE);
                    return Ok(());
                }
            };
            if let Err(why) = self.install_machine(machine, settings::is_board_field(num, axes))? {
                self.say(&format!("[MSG:${num}={v}: {why}]"));
                self.error(error::SETTING_READ_FAIL);
                return Ok(());
            }
        }
        self.settings = next;
        self.motion.soft_limits = self.settings.flag(settings::SOFT_LIMITS);
        self.save();
        self.ok();
        Ok(())
    }

    /// Writes the overlay; a failure is told (the setting is in effect for this session).
    fn save(&mut self) {
        let o = settings::Overlay {
            settings: self.settings.changed(),
            startup: self.startup_lines.clone(),
        };
        if let Err(e) = o.write(&self.overlay, &self.machine_path) {
            eprintln!("motionctl: {e:#}");
            self.say(&format!("[MSG:not saved, in effect until the bridge stops: {e:#}]"));
        }
    }

    /// The bridge runs `machine` from now on; with `board`, the board gets its config first
    /// (through [`runner::ready_board`], as at start: only when it differs from the board's).
    /// A new config loses the board's homing: the bridge is then in alarm until `$H`. The
    /// inner error says why the board refused (nothing changed then).
    fn install_machine(&mut self, machine: Machine, board: bool) -> Result<Result<(), String>> {
        let (cfg, wire) = match super::board_config(&machine) {
            Ok(c) => c,
            Err(e) => return Ok(Err(format!("{e:#}"))),
        };
        if board {
            self.stop_motion()?;
            let say = |m: &str| eprintln!("motionctl: {m}");
            let r = runner::ready_board(
                &mut self.s,
                wire,
                false,
                "machine with the grbl settings",
                &say,
            );
            runner::ask(
                &mut self.s,
                RequestBody::SetStatusPeriod { ms: super::STATUS_MS },
                "SetStatusPeriod",
            )?;
            self.refresh()?;
            self.faults_seen = self.latest.faults;
            if let Err(e) = r {
                let config_now = runner::ask(&mut self.s, RequestBody::GetConfig, "GetConfig")?;
                if config_now != Reply::Config(wire) {
                    return Ok(Err(e));
                }
                // The config is in; the board lost its homing.
                eprintln!("motionctl: {e}");
                self.say("[MSG:the board has the new config and must be homed: '$H' to home]");
                self.alarm = Some(alarm::HOMING_REQUIRED);
            }
        }
        // Machines live as long as the bridge (the interpreter borrows them); one per change.
        let machine: &'static Machine = Box::leak(Box::new(machine));
        self.machine = machine;
        self.spm = machine.axes.iter().map(|a| a.steps_per_mm).collect();
        self.tick_hz = cfg.tick_hz.max(1) as f64;
        let soft = self.motion.soft_limits;
        self.motion = Pipeline::new(machine, cfg);
        self.motion.soft_limits = soft;
        self.rebase();
        let kept = self.kept.clone();
        self.prog = Program::with_parameters(machine, &self.motion.pos_mm, kept);
        Ok(Ok(()))
    }

    /// `$#`: coordinate systems, G28, G30, G92, tool length offset, probe.
    fn parameters(&mut self) {
        if self.prog.ended() {
            self.new_program();
        }
        let inches = self.settings.flag(settings::REPORT_INCHES);
        let fmt = |v: &[f64]| -> String {
            v.iter()
                .map(|&x| if inches { format!("{:.4}", x / 25.4) } else { format!("{x:.3}") })
                .collect::<Vec<_>>()
                .join(",")
        };
        let gaxis = self.gaxis.clone();
        let mut block = |base: u32| -> Vec<f64> {
            let nums: Vec<u32> = gaxis.iter().map(|&g| base + g as u32).collect();
            self.prog.parameters(&nums)
        };
        let mut lines = Vec::new();
        for (i, name) in ["G54", "G55", "G56", "G57", "G58", "G59"].iter().enumerate() {
            let v = block(5221 + 20 * i as u32);
            lines.push(format!("[{name}:{}]", fmt(&v)));
        }
        let g28 = block(5161);
        let g30 = block(5181);
        let g92 = block(5211);
        lines.push(format!("[G28:{}]", fmt(&g28)));
        lines.push(format!("[G30:{}]", fmt(&g30)));
        lines.push(format!("[G92:{}]", fmt(&g92)));
        let m = self.prog.modal();
        let k = if m.units == Units::Inches { 25.4 } else { 1.0 };
        let tlo = m.tool_length_offset[2] * k;
        lines.push(format!("[TLO:{}]", fmt(&[tlo])));
        let zeros = vec![0.0; self.gaxis.len()];
        lines.push(format!("[PRB:{}:0]", fmt(&zeros)));
        for l in lines {
            self.say(&l);
        }
    }

    fn unlock(&mut self) -> Result<()> {
        if self.alarm.is_none() {
            self.ok();
            return Ok(());
        }
        self.refresh()?;
        if self.latest.faults != 0 {
            if let Err(e) = self.request(RequestBody::ClearFault, "ClearFault") {
                self.say(&format!("[MSG:{e}]"));
                self.error(error::SYSTEM_GC_LOCK);
                return Ok(());
            }
            self.refresh()?;
            self.faults_seen = self.latest.faults;
        }
        if self.latest.machine == MachineState::Idle {
            self.alarm = Some(alarm::HOMING_REQUIRED);
            self.say("[MSG:the board runs no motion until homed: '$H' to home]");
            self.ok();
            return Ok(());
        }
        self.alarm = None;
        self.rebase();
        self.say("[MSG:Caution: Unlocked]");
        self.ok();
        Ok(())
    }

    fn home(&mut self) -> Result<()> {
        if !self.settings.flag(settings::HOMING) {
            self.error(error::SETTING_DISABLED);
            return Ok(());
        }
        if self.check || (self.moving() && self.alarm.is_none()) {
            self.error(error::IDLE_ERROR);
            return Ok(());
        }
        self.stop_motion()?;
        if self.latest.faults != 0 {
            let _ = self.request(RequestBody::ClearFault, "ClearFault");
            self.refresh()?;
            self.faults_seen = self.latest.faults;
        }
        self.homing = true;
        let tick_hz = self.tick_hz as u32;
        let result = runner::home(&mut self.s, tick_hz, &|m: &str| eprintln!("motionctl: {m}"));
        self.homing = false;
        self.refresh()?;
        self.faults_seen = self.latest.faults;
        match result {
            Ok(()) => {
                self.alarm = None;
                self.rebase();
                self.startup();
                self.ok();
            }
            Err(e) => {
                eprintln!("motionctl: {e}");
                self.alarm = Some(alarm::HOMING_FAIL_RESET);
                self.say(&format!("ALARM:{}", alarm::HOMING_FAIL_RESET));
                self.say(&format!("[MSG:{e}]"));
                self.error(error::SYSTEM_GC_LOCK);
            }
        }
        Ok(())
    }

    /// `$J=`: G20/G21, G90/G91, G53, axis words and F; one move that ends at rest.
    fn jog_line(&mut self, body: &str) {
        if self.alarm.is_some() {
            return self.error(error::SYSTEM_GC_LOCK);
        }
        if self.check || self.hold || self.door || (self.moving() && !self.jog) {
            return self.error(error::IDLE_ERROR);
        }
        let jog = match parse_jog(body, self.machine) {
            Ok(j) => j,
            Err(n) => return self.error(n),
        };
        if self.prog.ended() {
            self.new_program();
        }
        let modal = self.prog.modal();
        let inches = jog.inches.unwrap_or(modal.units == Units::Inches);
        let k = if inches { 25.4 } else { 1.0 };
        let incremental = jog.incremental.unwrap_or(!modal.absolute) && !jog.machine_coords;
        let wco = self.wco();
        let from = self.motion.pos_mm.clone();
        let mut target: Vec<Option<f64>> = vec![None; from.len()];
        for (i, v) in jog.axes.iter().enumerate() {
            let Some(v) = v else { continue };
            let mm = v * k;
            target[i] = Some(if incremental {
                from[i] + mm
            } else if jog.machine_coords {
                mm
            } else {
                mm + wco[i]
            });
        }
        let to: Vec<f64> = target.iter().zip(&from).map(|(t, p)| t.unwrap_or(*p)).collect();
        if self.motion.check(&from, &to).is_err() {
            return self.error(error::TRAVEL_EXCEEDED);
        }
        let feed = jog.feed * k;
        self.feed_now = feed;
        // Pieces of at most JOG_PIECE_S each, so a cancel stops within one piece even on a
        // board that cannot stop inside a segment.
        let len = from.iter().zip(&to).map(|(a, b)| (b - a) * (b - a)).sum::<f64>().sqrt();
        let pieces = (len / (feed / 60.0) / JOG_PIECE_S).ceil().clamp(1.0, 2000.0) as usize;
        for p in 1..=pieces {
            let f = p as f64 / pieces as f64;
            let t: Vec<Option<f64>> = from
                .iter()
                .zip(&to)
                .zip(&target)
                .map(|((a, b), t)| t.map(|_| if p == pieces { *b } else { a + (b - a) * f }))
                .collect();
            if self.motion.push_move(&t, Feed::MmPerMin(feed), false).is_err() {
                self.motion.flush();
                return self.error(error::INVALID_JOG_COMMAND);
            }
        }
        self.motion.flush();
        self.jog = true;
        self.ok();
    }
}

/// A parsed `$J=` line.
#[derive(Clone, Debug, PartialEq)]
pub struct Jog {
    pub axes: Vec<Option<f64>>,
    pub feed: f64,
    pub inches: Option<bool>,
    pub incremental: Option<bool>,
    pub machine_coords: bool,
}

/// Parses a jog's words (what follows `$J=`); errors are grbl's numbers.
pub fn parse_jog(body: &str, machine: &Machine) -> Result<Jog, u8> {
    let mut jog = Jog {
        axes: vec![None; machine.axes.len()],
        feed: 0.0,
        inches: None,
        incremental: None,
        machine_coords: false,
    };
    let mut feed = None;
    let chars: Vec<char> = body.chars().filter(|c| !c.is_whitespace()).collect();
    let mut i = 0;
    while i < chars.len() {
        let letter = chars[i].to_ascii_uppercase();
        if !letter.is_ascii_alphabetic() {
            return Err(error::EXPECTED_COMMAND_LETTER);
        }
        i += 1;
        let start = i;
        while i < chars.len() && (chars[i].is_ascii_digit() || matches!(chars[i], '.' | '-' | '+'))
        {
            i += 1;
        }
        let text: String = chars[start..i].iter().collect();
        let v: f64 = text.parse().map_err(|_| error::BAD_NUMBER_FORMAT)?;
        if !v.is_finite() {
            return Err(error::BAD_NUMBER_FORMAT);
        }
        match letter {
            'G' => match text.as_str() {
                "20" => jog.inches = Some(true),
                "21" => jog.inches = Some(false),
                "90" => jog.incremental = Some(false),
                "91" => jog.incremental = Some(true),
                "53" => jog.machine_coords = true,
                _ => return Err(error::INVALID_JOG_COMMAND),
            },
            'F' => {
                if feed.replace(v).is_some() {
                    return Err(error::WORD_REPEATED);
                }
            }
            _ => {
                let Some(a) = machine.axis_index(&letter.to_string()) else {
                    return Err(error::INVALID_JOG_COMMAND);
                };
                if jog.axes[a].replace(v).is_some() {
                    return Err(error::WORD_REPEATED);
                }
            }
        }
    }
    match feed {
        Some(f) if f > 0.0 => jog.feed = f,
        _ => return Err(error::UNDEFINED_FEED_RATE),
    }
    if jog.axes.iter().all(Option::is_none) {
        return Err(error::NO_AXIS_WORDS);
    }
    Ok(jog)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine() -> Machine {
        let src = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/corpus-machine.toml"
        ))
        .unwrap();
        crate::job::parse_machine_toml(&src).unwrap()
    }

    #[test]
    fn jog_lines_parse_as_grbl_reads_them() {
        let m = machine();
        let j = parse_jog("G91X10.5Y-2F500", &m).unwrap();
        assert_eq!(j.axes, vec![Some(10.5), Some(-2.0), None]);
        assert_eq!((j.feed, j.incremental), (500.0, Some(true)));
        assert_eq!(parse_jog("G91 X1", &m), Err(error::UNDEFINED_FEED_RATE));
        assert_eq!(parse_jog("G91 F100", &m), Err(error::NO_AXIS_WORDS));
        assert_eq!(parse_jog("G1 X1 F100", &m), Err(error::INVALID_JOG_COMMAND));
        assert_eq!(parse_jog("X1..2 F100", &m), Err(error::BAD_NUMBER_FORMAT));
        assert_eq!(parse_jog("X1 X2 F100", &m), Err(error::WORD_REPEATED));
        assert_eq!(parse_jog("A1 F100", &m), Err(error::INVALID_JOG_COMMAND));
        assert_eq!(parse_jog("#1 F100", &m), Err(error::EXPECTED_COMMAND_LETTER));
    }
}
