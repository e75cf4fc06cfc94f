//! Host -> board: the request, its body (one variant per command, in encoding order) and its kind.

use serde::{Deserialize, Serialize};

use super::link_config::{HomingConfig, LinkConfig};
use crate::capabilities::requests::CapabilityRequest;
use crate::machine::ProbeKind;
use crate::protocol::bounded::SegmentBatch;
use crate::protocol::program_outputs::ProgramOutputs;
#[cfg(feature = "sim-inputs")]
use crate::protocol::sim::messages::SimRequest;

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
    /// After a limit fault: move the tripped axes slowly off their switches (`Fault` only).
    JogOffLimit,
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
    /// A capability's request (`crate::capabilities::requests`): the envelope's variant index
    /// names the capability, then its own enum's index the request. The session hands it to
    /// its owner; see each capability's `link_messages`.
    Capability(CapabilityRequest),
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
pub const KIND_SIM: u8 = 18;

impl RequestBody {
    /// Stable small number per request: its postcard variant index, or for a capability's
    /// request [`KIND_BASE`](crate::capabilities::requests::KIND_BASE) + 8 x the capability's
    /// place + the request's own index (what the session's result memory tells requests by).
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
            RequestBody::JogOffLimit => 14,
            RequestBody::SetProgramOutputs(_) => 15,
            RequestBody::ArmProbe(_) => 16,
            // Postcard index 17, then the capability's place and its own index.
            RequestBody::Capability(c) => c.kind(),
            #[cfg(feature = "sim-inputs")]
            RequestBody::Sim(_) => KIND_SIM,
        }
    }

    /// Event blocks this request queues if it succeeds (one event credit each).
    pub fn block_count(&self) -> u16 {
        match self {
            RequestBody::Capability(c) => c.event_blocks(),
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
