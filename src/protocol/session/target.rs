//! What the board's link drives: the firmware's machine, or a simulator in tests.

use crate::capabilities::requests::CapabilityTargets;
use crate::config::MAX_AXES;
use crate::machine::{MachineState, ProbeKind};
use crate::protocol::errors::ErrorCode;
use crate::protocol::messages::*;
use crate::protocol::program_outputs::ProgramOutputs;
use crate::segment::{Rate, Segment};

#[cfg(feature = "sim-inputs")]
use crate::protocol::sim::messages::SimRequest;

/// What the board's link drives. Every method that returns `Err` must have changed nothing.
/// A capability's own hooks are its target trait's ([`CapabilityTargets`]).
pub trait LinkTarget: CapabilityTargets {
    /// How the axes move.
    fn state(&self) -> LinkState;
    /// Where the machine is in its life cycle: what the command table checks.
    fn machine_state(&self) -> MachineState;
    /// Free slots in the segment queue.
    fn credits(&self) -> u16;
    fn queue_capacity(&self) -> u16;
    fn config(&self) -> LinkConfig;
    /// Position (steps) after every queued segment, for the soft-limit check.
    fn planned_position(&self) -> [i64; MAX_AXES];
    /// Current status; `BoardLink` fills in `credits` and `next_seq`.
    fn status(&self) -> Status;
    /// Called with a validated config, only while Idle with an empty queue.
    fn set_config(&mut self, cfg: &LinkConfig) -> Result<(), ErrorCode>;
    /// Called with checked segments, never more than `credits()`.
    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode>;
    fn start(&mut self) -> Result<(), ErrorCode>;
    fn hold(&mut self) -> Result<(), ErrorCode>;
    fn resume(&mut self) -> Result<(), ErrorCode>;
    /// Stops at once and empties the queue (allowed in every state).
    fn abort(&mut self) -> Result<(), ErrorCode>;
    /// `rate` is within 0..=2.0.
    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode>;
    fn clear_fault(&mut self) -> Result<(), ErrorCode>;
    fn home(&mut self) -> Result<(), ErrorCode>;
    /// Called with homing parameters validated against the current config, only with an empty
    /// queue.
    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode>;
    /// Moves the axes off the limit switches they tripped (refused with `OutOfState` when there
    /// is nothing to jog off).
    fn jog_off_limit(&mut self) -> Result<(), ErrorCode>;
    /// Free event-block slots (event credits). Targets without event jobs have none.
    fn event_credits(&self) -> u16 {
        0
    }
    /// Events are queued or an event job runs: segments are refused (`OutOfState`) until it
    /// ends or is aborted.
    fn events_pending(&self) -> bool {
        false
    }
    /// A simulator board's test hook, only called when the board announces `CAP_SIM_INPUTS`
    /// (and `CAP_MILLING_JOB` for `Milling`, whose parameters are checked). Only with the
    /// `sim-inputs` feature: production targets have no hooks to implement.
    #[cfg(feature = "sim-inputs")]
    fn sim(&mut self, _req: &SimRequest) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }

    /// Switches the spindle and coolant (`SetProgramOutputs`), keeping the other outputs;
    /// `OutOfState` while an e-stop is latched or pressed. Targets without these outputs:
    /// `Unsupported`.
    fn set_program_outputs(&mut self, _o: ProgramOutputs) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }

    /// Marks the next `Start` as a probe move of `kind` (`ArmProbe`); `OutOfState` with
    /// something queued or another job armed. Targets without a probe input: `Unsupported`.
    fn arm_probe(&mut self, _kind: ProbeKind) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
}
