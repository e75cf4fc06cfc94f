//! Board -> host: the response, what an Ack carries, what a NAK says, and the board's hello.

use serde::{Deserialize, Serialize};

use super::link_config::LinkConfig;
use super::status::Status;
use super::{FIELD_NAME_LEN, FIRMWARE_NAME_LEN, PANIC_FILE_LEN};
use crate::machine::MachineState;
use crate::protocol::bounded::{BlockBytes, FixedStr};
use crate::protocol::errors::{ErrorCode, FaultCode, SegmentReason};

/// Board -> host. Every request gets exactly one `Ack` or `Nak` carrying its seq; `Status` and
/// `Fault` frames are unsolicited.
///
/// `credits` = free slots in the board's segment queue right after it executed every request up
/// to a point `T`: for an `Ack`/`Nak` of a request, `T = seq` (a retransmitted request is answered
/// with the credits remembered from its execution); for a NAK with `NakDetail::Expected`,
/// `T = expected - 1`; for a `Status`, `T = next_seq - 1`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)]
pub enum Response {
    Ack { seq: u32, credits: u16, reply: Reply },
    Nak { seq: u32, credits: u16, code: ErrorCode, detail: NakDetail },
    Status(Status),
    Fault { code: FaultCode, tick: u64 },
}

/// Data returned with an `Ack`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)]
pub enum Reply {
    None,
    Hello(HelloInfo),
    Config(LinkConfig),
    Status(Status),
    /// The answer to `QueueEvents`: free event-block slots right after it (`T = seq`).
    EventCredits(u16),
    // -- copy mode --
    /// The answer to `ReadTeach`.
    Teach(TeachChunk),
}

/// One `ReadTeach` answer. `bytes` empty and `ended` false: the block is not recorded yet (ask
/// again later); `ended`: the recording is over and nothing follows `bytes`. A recording with
/// `lost_events > 0` is incomplete (the host did not read fast enough).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TeachChunk {
    /// The block seq asked for.
    pub block: u16,
    /// The block, v1 stream format with its CRC (empty when there is none).
    pub bytes: BlockBytes,
    pub ended: bool,
    /// Events recorded and events lost (teach queue full) since `StartCopy`.
    pub taught_events: u32,
    pub lost_events: u32,
}

/// More about a NAK.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum NakDetail {
    None,
    /// Link-level NAK (Crc, Framing, Overflow, unreadable Malformed) or `Sequence`: no request
    /// was executed, and the board's next expected seq is `expected` (`seq` repeats it).
    Expected {
        expected: u32,
    },
    /// `InvalidSegment`: the `index`th segment of the batch failed `reason`.
    Segment {
        index: u8,
        reason: SegmentReason,
        axis: Option<u8>,
    },
    /// `InvalidConfig`: the offending field (names as in `ConfigError::field`).
    Config {
        field: FixedStr<FIELD_NAME_LEN>,
        axis: Option<u8>,
    },
    /// `OutOfState`: the machine state the board is in (see the command table in
    /// `src/machine/MACHINE.md`).
    State(MachineState),
    /// `InvalidSegment` for a `QueueEvents` block: `reason` = `polar::feed::BlockError::code`
    /// (1..=8 stream checks, 1 truncated ... 4 CRC ..., 9 trailing bytes, 10 sequence, 11 after
    /// the last block); `expected` = the block seq the board expects next (`None` after the
    /// last block).
    Block {
        reason: u8,
        expected: Option<u16>,
    },
    // -- turning job --
    /// A refused Z request: `reason` = `ZTableError::code` for an upload step (1 header, 2 no
    /// upload, 3 sequence, 4 too long, 5 short, 6 CRC, 7 table), 0 for a start; `expected` =
    /// the chunk index the board wanted (sequence); `fault` = what the pre-start check found.
    Turning {
        reason: u8,
        expected: Option<u16>,
        fault: Option<FaultCode>,
    },
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct HelloInfo {
    pub version: u16,
    pub firmware: FixedStr<FIRMWARE_NAME_LEN>,
    /// `CAP_*` bits.
    pub capabilities: u32,
    /// Axes in the current config.
    pub axes: u8,
    /// Segment queue size (credits when empty).
    pub queue_capacity: u16,
    pub tick_hz: u32,
    /// Requests the board remembers for retransmission: the host's window must not exceed it.
    pub max_window: u16,
    pub max_segments_per_frame: u8,
    /// Where the firmware panicked before the last reset, if it did (also latched as the
    /// `Panicked` fault).
    pub last_panic: Option<PanicSite>,
}

/// A source location the firmware panicked at: the file's path (its last
/// [`PANIC_FILE_LEN`] bytes), line and column.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PanicSite {
    pub file: FixedStr<PANIC_FILE_LEN>,
    pub line: u32,
    pub column: u32,
}
