//! Board side of the link: a pure state machine from requests to responses.
//!
//! [`BoardLink`] never touches hardware; it acts through a [`LinkTarget`] (the firmware's DDA
//! feeder, or [`SimTarget`](super::SimTarget) in tests).
//!
//! # Sequence rules ("nothing lost, nothing repeated")
//!
//! A session starts with `Hello` at any seq `s0`; the board then expects `s0 + 1`.
//! For a request with seq `s`, the board's next expected seq being `n`:
//! * `s == n`: executed, answered (Ack or Nak), its outcome remembered; `n` becomes `n + 1`.
//!   A NAK here still consumes the seq: the request was processed and refused.
//! * `s < n`: a retransmission. Not executed again: the remembered outcome is sent again
//!   (queries such as GetStatus return fresh data). Outcomes are remembered for the last
//!   [`RESULT_MEMORY`] seqs; older ones get `Stale`.
//! * `s > n`: a gap (something was lost): `Nak Sequence` with `Expected { expected: n }`, not
//!   executed, nothing remembered.
//!
//! `Hello` with the current session's seq and nonce is a retransmission; any other valid
//! Hello starts a new session. Hello never touches the machine.
//!
//! # States in which each request is accepted
//!
//! One table decides: the machine's command table ([`crate::machine::state::TABLE`], rendered in
//! `src/machine/MACHINE.md`). A request whose command the table refuses in the target's
//! [`LinkTarget::machine_state`] gets `OutOfState` with `NakDetail::State` and changes nothing.
//! Requests that are not machine commands (Hello, GetConfig, GetStatus, SetStatusPeriod,
//! SetOverride) are accepted in every state. On top of the table the link asks:
//!
//! | Request | Also needs |
//! |---|---|
//! | SetConfig, SetHoming | an empty queue (else `OutOfState`), a valid config (`InvalidConfig` naming the field) |
//! | QueueSegments | credits for the whole batch, every segment valid and inside the soft limits |
//! | Hold | motion to hold (the target refuses an idle DDA with nothing to feed) |
//! | ClearFault | no fault cause still active (the target refuses with `OutOfState`) |
//! | JogOffLimit | a latched LimitSwitch with a switch still closed and nothing else present |
//! | polar: QueueEvents (Queue column) | an event credit, a block that passes every stream check and is the next in sequence (`InvalidSegment` + `NakDetail::Block`), no segments queued (`OutOfState`) |
//! | polar: StartPlayback (Start column) | m, k in 1..=4 (`OutOfRange`), queued events (`OutOfState`) |
//! | turning: ZTableBegin/Chunk/End (Queue column) | no Z job running (`OutOfState`), chunks in order with the announced length and the CRC (`InvalidTable` + `NakDetail::Turning`) |
//! | turning: StartZ (Start column) | a table (`OutOfState`), nothing queued, a spec in range and the pre-start check (`OutOfRange`) |
//! | polar: StartCopy (Start column) | m, k in 1..=4 (`OutOfRange`), nothing queued and no job (`OutOfState`) |
//! | polar: ReadTeach (not a command) | nothing |
//! | milling: ArmForce (Start column) | `CAP_MILLING_JOB` (`Unsupported`), every parameter in range (`OutOfRange` + `NakDetail::Config` naming it), nothing queued or armed (`OutOfState`) |
//! | SetProgramOutputs (not a command) | no e-stop latched or pressed (`OutOfState`) |
//! | ArmProbe (Start column) | `CAP_PROBE` (`Unsupported`), nothing queued, no other job armed, motion at rest (`OutOfState`) |
//! | Sim (not a command; `sim-inputs` feature) | `CAP_SIM_INPUTS`, for `Milling` also `CAP_MILLING_JOB`, for `Probe` also `CAP_PROBE` (`Unsupported`); `Milling`'s parameters in range (`OutOfRange` naming the field) |
//!
//! A board built without the `sim-inputs` feature cannot decode `Sim`; it answers it
//! `Unsupported` (seq consumed) as a board with the feature but without `CAP_SIM_INPUTS` does.
//!
//! The parts: `target` is what the link drives ([`LinkTarget`]), `sequencing` the sequence rules
//! (sessions, the result memory, retransmissions, frames that do not decode), `execute` each
//! request's checks and its call on the target, `commands` which requests are machine commands,
//! `capability` the contract a capability's requests fill ([`CapabilityRequests`]: their
//! column, checks and replays, run in their owner's folder; the rows marked with a capability
//! above are theirs).
//! The board's link state is here.

mod capability;
mod commands;
mod execute;
mod sequencing;
mod target;

pub use capability::{config_nak, plain, range_nak, CapabilityRequests, Nak, RequestContext};
pub use commands::command_kind;
pub use target::LinkTarget;

use crate::protocol::bounded::FixedStr;
use crate::protocol::errors::ErrorCode;
use crate::protocol::messages::*;

/// Outcomes remembered for retransmissions; the host's window must not exceed it.
pub const RESULT_MEMORY: usize = 32;

type Outcome = Result<(), (ErrorCode, NakDetail)>;

#[derive(Clone, Debug)]
struct Memo {
    seq: u32,
    kind: u8,
    credits: u16,
    /// Event credits right after the request (replayed in a `QueueEvents` Ack).
    event_credits: u16,
    outcome: Outcome,
}

#[derive(Clone, Copy, Debug)]
struct Session {
    next_seq: u32,
    hello_seq: u32,
    nonce: u32,
}

/// The board's end of the link.
#[derive(Clone, Debug)]
pub struct BoardLink {
    firmware: FixedStr<FIRMWARE_NAME_LEN>,
    capabilities: u32,
    last_panic: Option<PanicSite>,
    /// Frames that failed their checks or did not decode (`BoardCounters::frames_bad`).
    frames_bad: u32,
    /// The serial port's counts, noted by the firmware ([`BoardLink::note_port`]).
    port: (u32, u32),
    session: Option<Session>,
    memo: [Option<Memo>; RESULT_MEMORY],
    status_period_ms: u16,
    status_due_ms: Option<u64>,
}
