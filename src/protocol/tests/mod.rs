//! Unit tests of the message sizes and the board's sequence rules: the shared fixtures (a config,
//! a segment, request builders) here, the tests by what they test in the files below.

mod event_blocks;
mod messages;
mod session_rules;
mod wire_job;

use super::*;
use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::segment::{Rate, Segment};

pub(crate) fn config() -> LinkConfig {
    LinkConfig {
        machine: MachineConfig {
            tick_hz: 100_000,
            timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 12_000 },
            axis_count: 3,
            axes: [AxisLimits {
                max_rate_hz: 50_000,
                accel_steps_per_s2: 100_000,
                junction_jerk_hz: 0,
            }; MAX_AXES],
        },
        scale: [AxisScale {
            steps_per_unit_milli: 80_000,
            soft_min: -1_000_000,
            soft_max: 1_000_000,
        }; MAX_AXES],
        inputs: crate::config::InputFilterConfig::DEFAULT,
    }
}

pub(crate) fn seg(id: u32, x: i32) -> Segment {
    Segment {
        steps: [x, 0, 0, 0, 0, 0],
        duration_ticks: (2 * x.unsigned_abs()).max(1_000),
        entry_rate: Rate::ZERO,
        exit_rate: Rate::ZERO,
        accel_per_tick: Rate::from_bits(1 << 20),
        id,
    }
}

fn req(seq: u32, body: RequestBody) -> Request {
    Request { seq, body }
}

fn hello(seq: u32, nonce: u32) -> Request {
    req(seq, RequestBody::Hello { version: PROTOCOL_VERSION, nonce })
}

fn queue(seq: u32, segs: &[Segment]) -> Request {
    req(seq, RequestBody::QueueSegments(SegmentBatch::from_slice(segs).unwrap()))
}

fn code(r: &Response) -> Option<ErrorCode> {
    match r {
        Response::Nak { code, .. } => Some(*code),
        _ => None,
    }
}
