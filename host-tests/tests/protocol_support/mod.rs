//! Shared helpers of the `protocol_*` tests: a seeded generator, the link config and segments
//! they use, and framing a message the way the board's receive path sees it.
#![allow(dead_code)]

use motion::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use motion::protocol::*;
use motion::segment::{Rate, Segment};

/// xorshift64*: deterministic, no dependencies.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 > 1.0 - p
    }
    pub fn byte(&mut self) -> u8 {
        self.next() as u8
    }
}

pub fn config() -> LinkConfig {
    LinkConfig {
        machine: MachineConfig {
            tick_hz: 100_000,
            timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 12_000 },
            axis_count: 3,
            axes: [AxisLimits {
                max_rate_hz: 40_000,
                accel_steps_per_s2: 200_000,
                junction_jerk_hz: 500,
            }; MAX_AXES],
        },
        scale: [AxisScale {
            steps_per_unit_milli: 80_000,
            soft_min: -10_000_000,
            soft_max: 10_000_000,
        }; MAX_AXES],
        inputs: motion::InputFilterConfig::DEFAULT,
    }
}

pub fn seg(id: u32, steps: [i32; 3]) -> Segment {
    let d = steps.iter().map(|s| s.unsigned_abs()).max().unwrap_or(0);
    Segment {
        steps: [steps[0], steps[1], steps[2], 0, 0, 0],
        duration_ticks: d.saturating_mul(3).max(100),
        entry_rate: Rate::from_num(0.5),
        exit_rate: Rate::from_num(0.25),
        accel_per_tick: Rate::from_bits(1 << 18),
        id,
    }
}

/// Requests and responses (host-tests has no serde dependency of its own).
pub trait Message {
    fn encode<'a>(&self, buf: &'a mut [u8]) -> Result<&'a [u8], EncodeError>;
}
impl Message for Request {
    fn encode<'a>(&self, buf: &'a mut [u8]) -> Result<&'a [u8], EncodeError> {
        encode_frame(self, buf)
    }
}
impl Message for Response {
    fn encode<'a>(&self, buf: &'a mut [u8]) -> Result<&'a [u8], EncodeError> {
        encode_frame(self, buf)
    }
}

pub fn frame(msg: &impl Message) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LINK];
    msg.encode(&mut buf).expect("message fits a frame").to_vec()
}

/// Every complete frame's result in `bytes`.
pub fn deframe(d: &mut FrameDecoder<MAX_FRAME>, bytes: &[u8]) -> Vec<Result<Vec<u8>, FrameError>> {
    bytes.iter().filter_map(|&b| d.push(b).map(|r| r.map(|m| m.to_vec()))).collect()
}

/// The Hello that opens a session, with `seq` as its nonce too.
pub fn hello(seq: u32) -> Request {
    Request { seq, body: RequestBody::Hello { version: PROTOCOL_VERSION, nonce: seq } }
}
