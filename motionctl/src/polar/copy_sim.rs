//! The simulated board for copy jobs (`motionctl polar copy --sim`, and the host tests): the
//! firmware's `BoardLink` over `motion::protocol::CopySim` (the firmware's `CopyMode`,
//! `TeachRecorder` and simulated-encoder slew), ticked on the wall clock `speed` times faster
//! than real time.

use crate::sim_link::SimLink;
use crate::transport::Transport;
use motion::protocol::{
    BoardLink, CopySim, SimTarget, CAP_COPY_JOB, CAP_DDA, CAP_EVENTS, CAP_HOLD_RESUME,
    CAP_OVERRIDE, CAP_SIM_INPUTS, CAP_SOFT_LIMITS, CAP_STATUS_STREAM,
};
use std::io;
use std::time::{Duration, Instant};

/// What the simulated copy board announces.
const CAPS: u32 = CAP_DDA
    | CAP_STATUS_STREAM
    | CAP_OVERRIDE
    | CAP_HOLD_RESUME
    | CAP_SOFT_LIMITS
    | CAP_EVENTS
    | CAP_COPY_JOB
    | CAP_SIM_INPUTS;

pub struct CopySimBoard {
    pub board: BoardLink,
    pub target: CopySim,
    link: SimLink,
    start: Instant,
    last: Instant,
    owed_ticks: f64,
    pub speed: f64,
}

impl CopySimBoard {
    pub fn new(speed: f64) -> Self {
        let now = Instant::now();
        CopySimBoard {
            board: BoardLink::new("motionctl-copy-sim", CAPS),
            target: CopySim::new(SimTarget::new(motion::polar::job::link_config(), 32)),
            link: SimLink::new(),
            start: now,
            last: now,
            owed_ticks: 0.0,
            speed,
        }
    }

    fn advance(&mut self) {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        let tick_hz = self.target.inner.config.machine.tick_hz as f64;
        self.owed_ticks += dt * tick_hz * self.speed;
        let whole = self.owed_ticks.floor();
        self.owed_ticks -= whole;
        self.target.run_copy(whole as u64);
        let now_ms = self.start.elapsed().as_millis() as u64;
        if let Some(resp) = self.board.poll(now_ms, &self.target) {
            self.link.emit(&resp);
        }
    }
}

impl Transport for CopySimBoard {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.advance();
        self.link.receive(bytes, &mut self.board, &mut self.target);
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        self.advance();
        if self.link.is_empty() {
            SimLink::idle_wait(timeout);
            self.advance();
        }
        Ok(self.link.take())
    }

    fn reconnect(&mut self) -> io::Result<()> {
        self.link.reset();
        Ok(())
    }

    fn describe(&self) -> String {
        format!("the simulated copy board ({}x real time)", self.speed)
    }
}
