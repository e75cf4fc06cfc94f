//! Why a stream or a block was refused, in words that name the place.

use super::{MAX_DT_TICKS, VERSION, VERSION_WITHOUT_END_MARK};

/// Why a block was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamError {
    /// Shorter than its header, length byte or CRC say.
    Truncated,
    BadMagic,
    /// A version this decoder does not speak.
    Version(u8),
    Crc,
    /// A varint longer than 5 bytes or above u32.
    Varint,
    /// A run with count < 2, or a dt outside 0..=MAX_DT_TICKS.
    BadRun,
    /// The payload holds a different number of events than the header says.
    Count,
    /// dt above MAX_DT_TICKS (encoder side).
    DtRange,
    /// A block whose sequence number is not the next one: a block was dropped, duplicated or
    /// reordered.
    Sequence {
        expected: u16,
        found: u16,
    },
    /// The stream ends without its end block after `blocks` whole data blocks: the file was cut
    /// at a block boundary.
    NoEndMark {
        blocks: u32,
    },
    /// The end block's totals differ from the data blocks before it.
    EndMismatch {
        end_blocks: u32,
        end_events: u32,
        blocks: u32,
        events: u32,
    },
    /// Bytes after the end block.
    AfterEnd,
}

impl core::fmt::Display for StreamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            StreamError::Truncated => {
                f.write_str("Truncated: a block is shorter than its header, length or CRC say")
            }
            StreamError::BadMagic => f.write_str("BadMagic: not a step-event stream block"),
            StreamError::Version(VERSION_WITHOUT_END_MARK) => write!(
                f,
                "Version(1): a version-1 stream has no end mark, so a file cut at a block \
                 boundary cannot be told from a whole one; refused: write it again with this \
                 motionctl (`polar digitize ... --out FILE`, or `polar copy --teach FILE`)"
            ),
            StreamError::Version(v) => {
                write!(f, "Version({v}): a stream version this reader does not speak ({VERSION})")
            }
            StreamError::Crc => f.write_str("Crc: the block's CRC does not match its bytes"),
            StreamError::Varint => f.write_str("Varint: an item longer than 5 bytes or above u32"),
            StreamError::BadRun => f.write_str("BadRun: a run with count < 2 or a dt out of range"),
            StreamError::Count => {
                f.write_str("Count: the payload holds another event count than the header says")
            }
            StreamError::DtRange => write!(f, "DtRange: a dt above {MAX_DT_TICKS} ticks"),
            StreamError::Sequence { expected, found } => write!(
                f,
                "block has seq {found}, expected {expected}: a block was dropped, duplicated or \
                 reordered"
            ),
            StreamError::NoEndMark { blocks: 0 } => {
                f.write_str("no end mark: the stream is cut before its first block")
            }
            StreamError::NoEndMark { blocks } => write!(
                f,
                "no end mark: the stream is cut after block {} (the file ends at a block \
                 boundary without its end block)",
                blocks - 1
            ),
            StreamError::EndMismatch { end_blocks, end_events, blocks, events } => write!(
                f,
                "the end mark counts {end_blocks} blocks and {end_events} events, the stream \
                 holds {blocks} blocks and {events} events"
            ),
            StreamError::AfterEnd => f.write_str("bytes after the end mark"),
        }
    }
}

impl StreamError {
    /// A stable small number per error, for the link's NAK detail.
    pub const fn code(self) -> u8 {
        match self {
            StreamError::Truncated => 1,
            StreamError::BadMagic => 2,
            StreamError::Version(_) => 3,
            StreamError::Crc => 4,
            StreamError::Varint => 5,
            StreamError::BadRun => 6,
            StreamError::Count => 7,
            StreamError::DtRange => 8,
            StreamError::Sequence { .. } => 9,
            // Whole-stream errors (never in a NAK), numbered past the link's block codes.
            StreamError::NoEndMark { .. } => 13,
            StreamError::EndMismatch { .. } => 14,
            StreamError::AfterEnd => 15,
        }
    }
}
