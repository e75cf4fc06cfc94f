//! A board inside motionctl: the firmware's link state machine ([`BoardLink`]) over the pure-Rust
//! [`SimTarget`], behind the [`Transport`] trait. Queued segments complete in real time (scaled
//! by `speed`), and the periodic status stream runs on the wall clock. For tests of the runner,
//! and for `motionctl run --sim` (hidden) to try a job without hardware.

use crate::sim_link::SimLink;
use crate::transport::Transport;
use motion::protocol::LinkTarget as _;
use motion::protocol::{
    BoardLink, LinkConfig, SimTarget, CAP_DDA, CAP_HOLD_RESUME, CAP_OVERRIDE, CAP_PROBE,
    CAP_SIM_INPUTS, CAP_SOFT_LIMITS, CAP_STATUS_STREAM,
};
use motion::{Rate, MAX_AXES};
use std::io;
use std::time::{Duration, Instant};

/// Queue capacity of the simulated board.
pub const SIM_CAPACITY: u16 = 32;

/// Trouble the simulated board can be told to have, for tests.
#[derive(Clone, Copy, Debug, Default)]
pub struct SimTrouble {
    /// Reset (lose the session and the queue) once this many segments are done.
    pub reset_at_segment: Option<u32>,
    /// Once this many segments are done, drop every byte both ways for this long (the
    /// machine is frozen meanwhile).
    pub silence_at_segment: Option<(u32, Duration)>,
}

pub struct SimBoard {
    pub board: BoardLink,
    pub target: SimTarget,
    link: SimLink,
    start: Instant,
    last: Instant,
    /// Machine ticks owed to the running queue.
    budget_ticks: f64,
    /// Machine time per wall time.
    pub speed: f64,
    pub trouble: SimTrouble,
    silent_until: Option<Instant>,
    /// Frames received, and reconnects asked for.
    pub frames_in: u64,
    pub reconnects: u64,
    /// Times the queue ran dry under a segment at speed (the firmware holds then).
    pub starve_holds: u64,
    /// When `Some`, the machine positions after every segment executed, in order: the path the
    /// machine took. Kept through a reset (a reset does not undo motion).
    pub path: Option<Vec<[i64; MAX_AXES]>>,
}

impl SimBoard {
    pub fn new(capacity: u16, speed: f64) -> Self {
        // Probe moves against the simulated surface `Sim(Probe)` sets (`run --sim-probe`).
        let caps = CAP_DDA
            | CAP_STATUS_STREAM
            | CAP_OVERRIDE
            | CAP_HOLD_RESUME
            | CAP_SOFT_LIMITS
            | CAP_PROBE
            | CAP_SIM_INPUTS;
        let now = Instant::now();
        SimBoard {
            board: BoardLink::new("motionctl-sim", caps),
            target: SimTarget::new(LinkConfig::UNSET, capacity),
            link: SimLink::new(),
            start: now,
            last: now,
            budget_ticks: 0.0,
            speed,
            trouble: SimTrouble::default(),
            silent_until: None,
            frames_in: 0,
            reconnects: 0,
            starve_holds: 0,
            path: None,
        }
    }

    /// The board `--sim` talks to: real-time machine, 32-slot queue.
    pub fn bench_machine() -> Self {
        SimBoard::new(SIM_CAPACITY, 1.0)
    }

    fn now_ms(&self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    fn silent(&mut self) -> bool {
        match self.silent_until {
            Some(t) if Instant::now() < t => true,
            Some(_) => {
                self.silent_until = None;
                false
            }
            None => false,
        }
    }

    /// Runs the machine up to now and emits a due status.
    fn advance(&mut self) {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        let tick_hz = self.target.config.machine.tick_hz as f64;
        // During a silence the machine is frozen too, so a test of the link is not an
        // underrun test.
        if self.silent_until.is_none_or(|t| now >= t) {
            self.budget_ticks += dt * tick_hz * self.speed;
        }
        while self.budget_ticks > 0.0 {
            match self.target.complete_one() {
                Some(seg) => {
                    self.budget_ticks -= seg.duration_ticks as f64;
                    if let Some(path) = self.path.as_mut() {
                        path.push(self.target.positions);
                    }
                    // As the firmware: a segment that ends at speed with nothing behind it
                    // holds the job until the host sends more (a pause, counted, not a fault).
                    if seg.exit_rate != Rate::ZERO && self.target.queue_len() == 0 {
                        self.target.starve_holds = self.target.starve_holds.wrapping_add(1);
                        self.starve_holds += 1;
                    }
                }
                None => {
                    self.budget_ticks = 0.0;
                    break;
                }
            }
        }
        let done = self.target.segments_done;
        if self.trouble.reset_at_segment.is_some_and(|n| done >= n) {
            self.trouble.reset_at_segment = None;
            let speed = self.speed;
            let (reconnects, path) = (self.reconnects, self.path.take());
            *self = SimBoard::new(self.target.queue_capacity(), speed);
            self.reconnects = reconnects;
            self.path = path;
        }
        if let Some((n, len)) = self.trouble.silence_at_segment {
            if done >= n {
                self.trouble.silence_at_segment = None;
                self.silent_until = Some(now + len);
            }
        }
        if let Some(resp) = self.board.poll(self.now_ms(), &self.target) {
            self.link.emit(&resp);
        }
    }
}

impl Transport for SimBoard {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.advance();
        if self.silent() {
            return Ok(());
        }
        self.frames_in += self.link.receive(bytes, &mut self.board, &mut self.target);
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        self.advance();
        if self.silent() {
            self.link.clear();
        }
        if self.link.is_empty() {
            SimLink::idle_wait(timeout);
            self.advance();
            if self.silent() {
                self.link.clear();
            }
        }
        Ok(self.link.take())
    }

    fn reconnect(&mut self) -> io::Result<()> {
        self.reconnects += 1;
        self.link.reset();
        Ok(())
    }

    fn describe(&self) -> String {
        "the simulated board".into()
    }
}
