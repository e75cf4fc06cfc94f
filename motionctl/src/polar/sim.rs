//! The simulated board for event jobs (`motionctl polar run --sim`): [`SimBoard`] (the
//! firmware's `BoardLink` over `SimTarget`) with its event playback ticked on the wall clock
//! (`SimTarget::run_events`, the firmware's own `EventFeed` and `Playback` code), `speed` times
//! faster than real time.

use crate::noise::NoiseStats;
use crate::sim_board::SimBoard;
use crate::transport::Transport;
use motion::protocol::{
    BoardLink, CAP_DDA, CAP_EVENTS, CAP_HOLD_RESUME, CAP_OVERRIDE, CAP_PROBE, CAP_SIM_INPUTS,
    CAP_SOFT_LIMITS, CAP_STATUS_STREAM, CAP_WIRE_JOB,
};
use std::io;
use std::time::{Duration, Instant};

/// Machine time per wall time of `--sim` event jobs: fast enough for tests, slow enough that
/// the host streams blocks under credits while the playback runs.
pub const SIM_SPEED: f64 = 8.0;

/// What the simulated board announces: `SimBoard`'s capabilities plus event jobs.
const CAPS: u32 =
    CAP_DDA | CAP_STATUS_STREAM | CAP_OVERRIDE | CAP_HOLD_RESUME | CAP_SOFT_LIMITS | CAP_EVENTS;

pub struct EventSim {
    pub board: SimBoard,
    last: Instant,
    /// Machine ticks owed to the playback (fractional carry).
    owed_ticks: f64,
    pub speed: f64,
}

impl EventSim {
    pub fn new(speed: f64) -> Self {
        let mut board = SimBoard::bench_machine();
        // The same board, announcing event jobs (its SimTarget plays them).
        board.board = BoardLink::new("motionctl-sim", CAPS);
        EventSim { board, last: Instant::now(), owed_ticks: 0.0, speed }
    }

    /// The same board with its segments too at `speed` times real time (the grbl bridge's
    /// `--sim`: G-code with probe moves against the surface `--sim-probe` sets, event jobs and
    /// wire jobs on one board; `SimTarget` runs an armed wire job's segments as plain ones,
    /// without stall handling).
    pub fn scaled(capacity: u16, speed: f64) -> Self {
        let mut board = SimBoard::new(capacity, speed);
        let caps = CAPS | CAP_WIRE_JOB | CAP_PROBE | CAP_SIM_INPUTS;
        board.board = BoardLink::new("motionctl-sim", caps);
        EventSim { board, last: Instant::now(), owed_ticks: 0.0, speed }
    }

    /// Runs the event playback up to now.
    fn advance(&mut self) {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        let tick_hz = self.board.target.config.machine.tick_hz as f64;
        self.owed_ticks += dt * tick_hz * self.speed;
        let whole = self.owed_ticks.floor();
        self.owed_ticks -= whole;
        self.board.target.run_events(whole as u64);
    }
}

impl Transport for EventSim {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.advance();
        self.board.send(bytes)
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        self.advance();
        self.board.recv(timeout)
    }

    fn reconnect(&mut self) -> io::Result<()> {
        self.board.reconnect()
    }

    fn describe(&self) -> String {
        format!("the simulated board ({}x real time)", self.speed)
    }

    fn noise_stats(&self) -> Option<(NoiseStats, NoiseStats)> {
        None
    }
}
