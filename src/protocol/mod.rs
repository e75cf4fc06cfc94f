//! Host <-> board link protocol, shared by the firmware and the host tools. The specification,
//! with the generated code tables, is `src/protocol/PROTOCOL.md`.
//!
//! * [`frame`]: `COBS(postcard(message) ++ crc32_le) ++ 0x00` framing ([`encode_frame`],
//!   [`FrameDecoder`]).
//! * [`messages`]: [`Request`] (host -> board, with a seq) and [`Response`] (board -> host).
//! * [`program_outputs`]: the spindle and coolant state a program switches ([`ProgramOutputs`]).
//! * [`errors`]: the numbered NAK codes, segment-check reasons and fault codes, with their
//!   documentation tables ([`markdown_table`]).
//! * [`session`]: [`BoardLink`], the board's sequence/ACK state machine over a [`LinkTarget`].
//! * [`host`]: [`HostLink`], the host's window, retransmission and credit accounting.
//! * [`sim`]: the simulator board's test hooks ([`SimRequest`] in `RequestBody::Sim`, with the
//!   `sim-inputs` feature) and [`SimTarget`] / [`CopySim`], fake machines for tests, fuzzing and
//!   loopback (with the feature, or in this crate's tests).
//!
//! Reliability: every request carries a seq; the board executes seqs strictly in order, exactly
//! once, and answers each with an Ack or a Nak; the host retransmits (go-back-N) until answered.
//! Flow control: every answer carries the board's free segment-queue slots ("credits"), and the
//! host never sends more segments than it knows to be free. Nothing in the board path allocates
//! or panics, whatever bytes arrive.

pub mod bounded;
pub mod errors;
pub mod frame;
pub mod host;
pub mod messages;
pub mod program_outputs;
pub mod session;
pub mod sim;

pub use bounded::{
    BlockBytes, EventBlock, FixedStr, SegmentBatch, MAX_EVENT_BLOCK, MAX_SEGMENTS_PER_FRAME,
};
pub use errors::{markdown_table, ErrorCode, FaultCode, SegmentReason};
pub use frame::{
    encode_frame, encode_payload_frame, EncodeError, FrameDecoder, FrameError, CRC32, MAX_FRAME,
    MAX_FRAME_LINK, MAX_MESSAGE,
};
pub use host::{HostConfig, HostEvent, HostLink, Rejection, SendError};
pub use messages::*;
pub use program_outputs::{
    ProgramOutputs, SpindleDir, OUT_FLOOD, OUT_MIST, OUT_SPINDLE, OUT_SPINDLE_CCW,
};
pub use session::{command_kind, BoardLink, LinkTarget, RESULT_MEMORY};
#[cfg(feature = "sim-inputs")]
pub use sim::SimRequest;
#[cfg(any(test, feature = "sim-inputs"))]
pub use sim::{CopySim, SimTarget};
pub use sim::{SimForceFault, SimMillingParams, SimProbeSurface};

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_turning;
// -- force job --
#[cfg(test)]
mod tests_copy;
#[cfg(test)]
mod tests_milling;
#[cfg(test)]
mod tests_outputs;
#[cfg(test)]
mod tests_probe;
