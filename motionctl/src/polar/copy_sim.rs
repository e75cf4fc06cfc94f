//! The simulated board for copy jobs (`motionctl polar copy --sim`, and the host tests): the
//! firmware's `BoardLink` over `motion::protocol::CopySim` (the firmware's `CopyMode`,
//! `TeachRecorder` and simulated-encoder slew), ticked on the wall clock `speed` times faster
//! than real time.

use crate::transport::Transport;
use motion::protocol::{
    encode_frame, BoardLink, CopySim, FrameDecoder, SimTarget, CAP_COPY_JOB, CAP_DDA, CAP_EVENTS,
    CAP_HOLD_RESUME, CAP_OVERRIDE, CAP_SIM_INPUTS, CAP_SOFT_LIMITS, CAP_STATUS_STREAM, MAX_FRAME,
    MAX_FRAME_WIRE,
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
    decoder: FrameDecoder<MAX_FRAME>,
    out: Vec<u8>,
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
            target: CopySim::new(SimTarget::new(motion::polar::job::wire_config(), 32)),
            decoder: FrameDecoder::new(),
            out: Vec::new(),
            start: now,
            last: now,
            owed_ticks: 0.0,
            speed,
        }
    }

    fn emit(&mut self, resp: &motion::protocol::Response) {
        let mut buf = [0u8; MAX_FRAME_WIRE];
        if let Ok(f) = encode_frame(resp, &mut buf) {
            self.out.extend_from_slice(f);
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
            self.emit(&resp);
        }
    }
}

impl Transport for CopySimBoard {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.advance();
        for &b in bytes {
            if let Some(frame) = self.decoder.push(b) {
                let resp = self.board.on_frame(frame, &mut self.target);
                self.emit(&resp);
            }
        }
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        self.advance();
        if self.out.is_empty() {
            std::thread::sleep(timeout.min(Duration::from_millis(1)));
            self.advance();
        }
        Ok(std::mem::take(&mut self.out))
    }

    fn reconnect(&mut self) -> io::Result<()> {
        self.decoder.reset();
        Ok(())
    }

    fn describe(&self) -> String {
        format!("the simulated copy board ({}x real time)", self.speed)
    }
}
