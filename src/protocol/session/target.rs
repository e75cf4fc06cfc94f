//! What the board's link drives: the firmware's machine, or a simulator in tests.

use crate::config::MAX_AXES;
use crate::machine::{MachineState, ProbeKind};
use crate::polar::playback::SizeScale;
use crate::protocol::errors::ErrorCode;
use crate::protocol::messages::*;
use crate::protocol::program_outputs::ProgramOutputs;
use crate::segment::{Rate, Segment};
use crate::turning::link_job::{ZJobSpec, ZTableHeader};
use crate::turning::link_requests::ZNak;

#[cfg(feature = "sim-inputs")]
use crate::protocol::sim::messages::SimRequest;

/// What the board's link drives. Every method that returns `Err` must have changed nothing.
pub trait LinkTarget {
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
    /// The stream block seq the target takes next (0 for a new job); `None` once the host
    /// marked a block as the last.
    fn next_event_block(&self) -> Option<u16> {
        None
    }
    /// Events are queued or an event job runs: segments are refused (`OutOfState`) until it
    /// ends or is aborted.
    fn events_pending(&self) -> bool {
        false
    }
    /// Called with a block that passed every stream check and is `next_event_block()`, only
    /// with an event credit free.
    fn queue_events(&mut self, _block: &[u8], _last: bool) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// Starts the event job with radial size scale `scale` (checked).
    fn start_playback(&mut self, _scale: SizeScale) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// Arms a wire job with checked parameters (`Ready`, empty queue, no events); refused
    /// with `OutOfState` otherwise. Targets without wire jobs: `Unsupported`.
    fn arm_wire(&mut self, _params: &WireJobParams) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    // -- Z-slide job --
    /// `ZTableBegin` (see `motion::turning::link_requests::ZRequests`). A refusal changes
    /// nothing; `OutOfState` with `NakDetail::None` gets the machine state filled in.
    fn z_table_begin(&mut self, _h: &ZTableHeader) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
    /// `ZTableChunk` with at most `MAX_Z_CHUNK` bytes.
    fn z_table_chunk(&mut self, _index: u16, _bytes: &[u8]) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
    /// `ZTableEnd`: the checked table replaces the active one, or nothing changes.
    fn z_table_end(&mut self, _crc: u32) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
    /// `StartZ` (Start column passed, config valid).
    fn start_z(&mut self, _spec: &ZJobSpec) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
    // -- copy mode --
    /// Starts a copy job with a checked size scale (`Ready`, nothing queued, no job; else
    /// `OutOfState`). Targets without copy jobs: `Unsupported`.
    fn start_copy(&mut self, _scale: SizeScale, _teach: bool) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// `ReadTeach { block }` (see `polar::copy_link::TeachRecorder::read`).
    fn read_teach(&mut self, _block: u16) -> Result<TeachChunk, ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// The answer a retransmitted `ReadTeach` gets again: the oldest block still held (the one
    /// the last `ReadTeach` asked for), read without dropping anything.
    fn teach_resend(&self) -> Option<TeachChunk> {
        None
    }
    // -- force job --
    /// Arms a force job with checked parameters (`Ready`, empty queue, no events, no other job
    /// armed; else `OutOfState`). `OutOfRange` from the target means the sample rate does not
    /// fit the board (the NAK names `sample_hz`). Targets without force jobs: `Unsupported`.
    fn arm_force(&mut self, _params: &ForceJobParams) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
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
