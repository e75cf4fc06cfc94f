//! The simulator board's test hooks (`RequestBody::Sim`, announced by `CAP_SIM_INPUTS`): built
//! only with the `sim-inputs` feature, which the QEMU board's build turns on and the real
//! board's goes without (its session then refuses the hooks undecoded, `Unsupported`). Each
//! hook still asks the board, so a build with the feature on a board without the simulated
//! input answers `Unsupported` too.

use motion::machine::Inputs;
use motion::protocol::{ErrorCode, SimMillingParams, SimRequest};
use rtic::Mutex;

use super::{milling, Motion};
use crate::board;
use board_contract::{ConfigStorage as _, CopyEncoders as _, MachineIo as _, SpindleEncoder as _};

/// Runs one hook (the session checked the capabilities and the plant's ranges).
pub fn apply(motion: &mut impl Mutex<T = Motion>, req: &SimRequest) -> Result<(), ErrorCode> {
    let done = match *req {
        SimRequest::Inject { wire_stall } => board::MachineIo::inject_wire_stall(wire_stall),
        SimRequest::Spindle { rpm_milli, index } => {
            let tick_hz = motion.lock(|m| m.machine.config().link.machine.tick_hz);
            return spindle(tick_hz, rpm_milli, index);
        }
        SimRequest::Milling(p) => return motion.lock(|m| milling(m, &p)),
        SimRequest::Encoders { arm_counts, carriage_counts } => {
            board::CopyEncoders::set_sim_target([arm_counts, carriage_counts])
        }
        SimRequest::Probe { surface } => {
            if !board::MachineIo::SIM_INPUTS {
                return Err(ErrorCode::Unsupported);
            }
            motion.lock(|m| m.sim_probe = surface);
            true
        }
        SimRequest::CorruptConfig => board::ConfigStorage::corrupt_at_next_boot(),
    };
    if done {
        Ok(())
    } else {
        Err(ErrorCode::Unsupported)
    }
}

/// The tick's inputs with the simulated probe (`Sim(Probe)`) read from the machine's step
/// counters, when a surface is set (interrupt rate: one test without one; with one, the
/// 6-axis position sum and a compare).
#[inline]
pub fn with_probe(m: &Motion, inputs: &Inputs) -> Inputs {
    match m.sim_probe {
        Some(s) => Inputs { probe: inputs.probe || s.active(&m.machine.positions()), ..*inputs },
        None => *inputs,
    }
}

/// `Spindle`: the rpm as a speed at the current tick rate (divides: USART task).
fn spindle(tick_hz: u32, rpm_milli: u32, index: bool) -> Result<(), ErrorCode> {
    if !board::Spindle::SIM {
        return Err(ErrorCode::Unsupported);
    }
    let Some(speed) = motion::spindle::checked_speed_turn_q32_per_tick(rpm_milli, tick_hz) else {
        return Err(ErrorCode::OutOfRange);
    };
    if board::Spindle::set_sim(speed as u32, index) {
        Ok(())
    } else {
        Err(ErrorCode::Unsupported)
    }
}

/// `Milling`: the plant the next armed force job samples (a tick-sampled board only).
fn milling(m: &mut Motion, p: &SimMillingParams) -> Result<(), ErrorCode> {
    if !milling::TICK_SAMPLED {
        return Err(ErrorCode::Unsupported);
    }
    m.milling.sim = Some(*p);
    Ok(())
}
