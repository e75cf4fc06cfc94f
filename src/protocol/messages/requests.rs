//! Host -> board: the request, its body (one variant per command, in encoding order) and its kind.

use serde::{Deserialize, Serialize};

use super::jobs::{ForceJobParams, WireJobParams};
use super::link_config::{HomingConfig, LinkConfig};
use crate::machine::ProbeKind;
use crate::protocol::bounded::{BlockBytes, EventBlock, SegmentBatch};
use crate::protocol::program_outputs::ProgramOutputs;
#[cfg(feature = "sim-inputs")]
use crate::protocol::sim::messages::SimRequest;
use crate::turning::link_job::{ZJobSpec, ZTableHeader};

/// Host -> board.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Request {
    /// Consecutive per session, starting at the Hello's seq; see `session` for the rules.
    pub seq: u32,
    pub body: RequestBody,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
// Fixed capacity is the point (no allocation on the board); boxing is not an option.
#[allow(clippy::large_enum_variant)]
pub enum RequestBody {
    /// Opens a session (seq numbering restarts at this request's seq). `nonce` tells a
    /// retransmitted Hello (same seq and nonce: answered again, nothing reset) from a new host.
    Hello {
        version: u16,
        nonce: u32,
    },
    GetConfig,
    /// In `Idle`, `Ready` (loses homing) or `Fault`, with an empty queue.
    SetConfig(LinkConfig),
    /// All-or-nothing: every segment is checked (and credits counted) before any is queued.
    QueueSegments(SegmentBatch),
    Start,
    Hold,
    Resume,
    Abort,
    /// Feed override, `Rate` bits, 0..=2.0.
    SetOverride {
        rate_bits: u32,
    },
    GetStatus,
    /// Unsolicited `Status` every `ms` (0 = off, else >= MIN_STATUS_PERIOD_MS).
    SetStatusPeriod {
        ms: u16,
    },
    ClearFault,
    /// Run the homing sequence (`Idle` or `Ready`); the machine reports `Homing`, then `Ready`.
    Home,
    /// Replace the homing parameters (a `SetConfig` that keeps the machine config; loses homing).
    SetHoming(HomingConfig),
    /// Queue one block of a recorded step-event stream (v1, with its CRC) for an event job.
    /// Checked whole (CRC, every event, block sequence from 0) before anything is queued; costs
    /// one *event* credit (`Status::event_credits`, `Reply::EventCredits`). Refused while
    /// segments are queued (a job is either segments or events).
    QueueEvents(EventBlock),
    /// Start the event job: play the queued events with radial size scale `m`:`k` (each 1..=4,
    /// else `OutOfRange`); speed scale = the feed override (0.25..=2). Needs queued events.
    StartPlayback {
        m: u8,
        k: u8,
    },
    /// After a limit fault: move the tripped axes slowly off their switches (`Fault` only).
    JogOffLimit,
    /// Arm a wire-manipulator job (`Ready`, nothing queued; needs `CAP_WIRE_JOB`): the next
    /// `segments` segments queued with `QueueSegments` (4 axes: X, Y, beta, alpha) form the
    /// job, and `Start` runs it through the wire-stall retrace controller instead of the plain
    /// feeder. Parameters out of range -> `OutOfRange`.
    ArmWire(WireJobParams),
    // -- Z-slide job --
    /// Opens a Z coefficient-table upload (drops an unfinished one). Queue column; refused
    /// (`OutOfState`) while a Z job runs; a bad header -> `InvalidTable`.
    ZTableBegin(ZTableHeader),
    /// Table bytes `index` (0, 1, ... in order; at most [`MAX_Z_CHUNK`](super::MAX_Z_CHUNK)
    /// bytes): little-endian `i32` coefficients, row after row. Out of order or too long ->
    /// `InvalidTable` (the upload is dropped, the active table stays).
    ZTableChunk {
        index: u16,
        bytes: BlockBytes,
    },
    /// Ends the upload: every byte, the CRC-32 over them and the table checks, then the table
    /// replaces the active one. Any refusal replaces nothing.
    ZTableEnd {
        crc: u32,
    },
    /// Starts a Z job with the active table (Start column; `Ready`, nothing queued). No table
    /// or a job already there -> `OutOfState`; spec out of range -> `OutOfRange`; the pre-start
    /// check (spindle speed, slide limits) -> `OutOfRange` with `NakDetail::Turning { fault }`.
    StartZ(ZJobSpec),
    // -- force job --
    /// Arm the constant-force loop for the next segment job (`Ready`, nothing queued, no other
    /// job armed; needs `CAP_MILLING_JOB`): from its `Start` on, force samples run through the
    /// force chain and the control law, whose feed override drives the DDA; force faults hold
    /// the feed through the machine's fault model. Parameters out of range -> `OutOfRange` with
    /// `NakDetail::Config` naming the field.
    ArmForce(ForceJobParams),
    // -- copy mode --
    /// Start a copy job (`Ready`, nothing queued; needs `CAP_COPY_JOB`): from the next tick the
    /// arm and carriage encoders drive theta and r live, r scaled `m`:`k` (each 1..=4, else
    /// `OutOfRange`); the encoders' counts now are the job's origin. With `teach`, every
    /// encoder count is recorded with its tick interval for `ReadTeach` (a new recording; the
    /// last one is dropped). Runs until `Abort` or a fault; `Hold`/`Resume` as for a job.
    StartCopy {
        m: u8,
        k: u8,
        teach: bool,
    },
    /// The recording's stream block `block` (v1, seq from 0), answered with `Reply::Teach`.
    /// Asking for `block` tells the board the host has every block before it (they are
    /// dropped); asking again for the same block answers it again. Accepted in every state.
    ReadTeach {
        block: u16,
    },
    /// The spindle (off, clockwise, counterclockwise) and coolant (mist, flood) a program
    /// switches, all at once, from the next tick on; the wire power and the Z DAC are left as
    /// they are. Not a machine command: accepted in every state but refused (`OutOfState`,
    /// nothing changes) while an e-stop is latched or pressed. Faults that kill the outputs
    /// (e-stop and the other `Kill` reactions) switch these off too. The host sends it once the
    /// motion before it is done (program order); `Status::outputs` shows the result.
    SetProgramOutputs(ProgramOutputs),
    /// Marks the next `Start` as a probe move of this kind (G38.2..G38.5; the table's Start
    /// column, but only in `Ready` with nothing queued and no other job armed; needs
    /// `CAP_PROBE`): the segments queued after it run as the probe move, watched by the tick on
    /// the debounced probe input. The trip latches every axis's position
    /// (`Status::probe_steps`), the machine stops with a feed-hold deceleration and drops the
    /// rest of the move, and the job ends in `Ready`; see `src/machine/probe.rs` and
    /// `Status::probe_phase`.
    ArmProbe(ProbeKind),
    /// A simulator board's test hook ([`SimRequest`]; only with `CAP_SIM_INPUTS`, else
    /// `Unsupported`). Compiled only with the `sim-inputs` feature: a board built without it
    /// does not decode the variant and answers it `Unsupported` all the same.
    ///
    /// Stays the last variant: compiled out, it must not shift any other variant's index. A
    /// new request goes before it, and [`KIND_SIM`] moves up by one.
    #[cfg(feature = "sim-inputs")]
    Sim(SimRequest),
}

/// The postcard index of `RequestBody::Sim`, known with and without the `sim-inputs` feature
/// (a board without it recognises the request it cannot decode).
pub const KIND_SIM: u8 = 27;

impl RequestBody {
    /// Stable small number per variant (its postcard index).
    pub const fn kind(&self) -> u8 {
        match self {
            RequestBody::Hello { .. } => 0,
            RequestBody::GetConfig => 1,
            RequestBody::SetConfig(_) => 2,
            RequestBody::QueueSegments(_) => 3,
            RequestBody::Start => 4,
            RequestBody::Hold => 5,
            RequestBody::Resume => 6,
            RequestBody::Abort => 7,
            RequestBody::SetOverride { .. } => 8,
            RequestBody::GetStatus => 9,
            RequestBody::SetStatusPeriod { .. } => 10,
            RequestBody::ClearFault => 11,
            RequestBody::Home => 12,
            RequestBody::SetHoming(_) => 13,
            RequestBody::QueueEvents(_) => 14,
            RequestBody::StartPlayback { .. } => 15,
            RequestBody::JogOffLimit => 16,
            RequestBody::ArmWire(_) => 17,
            // -- Z-slide job --
            RequestBody::ZTableBegin(_) => 18,
            RequestBody::ZTableChunk { .. } => 19,
            RequestBody::ZTableEnd { .. } => 20,
            RequestBody::StartZ(_) => 21,
            // -- force job --
            RequestBody::ArmForce(_) => 22,
            // -- copy mode --
            RequestBody::StartCopy { .. } => 23,
            RequestBody::ReadTeach { .. } => 24,
            RequestBody::SetProgramOutputs(_) => 25,
            RequestBody::ArmProbe(_) => 26,
            #[cfg(feature = "sim-inputs")]
            RequestBody::Sim(_) => KIND_SIM,
        }
    }

    /// Event blocks this request queues if it succeeds (one event credit each).
    pub fn block_count(&self) -> u16 {
        match self {
            RequestBody::QueueEvents(_) => 1,
            _ => 0,
        }
    }

    /// Segments this request queues if it succeeds.
    pub fn segment_count(&self) -> u16 {
        match self {
            RequestBody::QueueSegments(b) => b.len() as u16,
            _ => 0,
        }
    }
}
