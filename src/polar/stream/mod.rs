//! Step-event stream, version 2: blocks of delta-coded events with interval runs and a CRC, closed
//! by an end block.
//!
//! Why not the thesis's word (14-bit time at 33 us + 2 axis bits): 0.54 s is the longest gap, there
//! is no integrity check, and every event costs 2 bytes even on long straight runs. Here:
//!
//! Block = `MAGIC (0xB5) | VERSION (2) | seq u16 LE | events u16 LE | len u8 | payload[len] | crc32 LE`
//! (CRC-32/ISO-HDLC over everything before it). A block decodes on its own: no state crosses a
//! block boundary, so a long contour streams block by block and a lost block shows as a `seq` gap.
//!
//! The end block closes a whole stream: `events == 0` (a data block holds at least one event) and
//! an 8-byte payload `data blocks u32 LE | events u32 LE`, the totals of the blocks before it; its
//! seq is the next one. Without it a file cut exactly at a block boundary would read as a whole,
//! shorter stream. Readers of a whole stream ([`blocks`], [`decode_all`]) require it, check its
//! counts and refuse anything after it. On the link the host sends data blocks only (its
//! `EventBlock::last` flag marks the end) and the board refuses an end block there; the board's
//! taught-stream blocks (copy jobs) end with one. Version 1 had no end block: a v1 file is
//! refused ([`StreamError::Version`]) and has to be written again from its source.
//!
//! Payload items, each a LEB128 varint `v` (u32, at most 5 bytes):
//! - `v & 4 == 0`: one event, `code = v & 3` (bit 0 axis, bit 1 negative), `dt = v >> 3`.
//! - `v & 4 != 0`: a run (Klipper's interval/count/add): `code = v & 3`, first `dt = v >> 3`, then
//!   varint `count` (>= 2) and zigzag varint `add`: events `dt, dt+add, dt+2*add, ...` on one code.
//!
//! The decoder checks lengths, CRC, varint width, run counts and every dt for overflow: hostile
//! bytes give an error, never a panic (a proptest feeds it random bytes).
//!
//! The parts: `encoder` writes blocks, `block` checks and decodes one block, `whole_stream`
//! reads a whole stream (sequence and end block), `varint` is the payload's integer coding and
//! `error` names every refusal. The format's figures are here.

mod block;
mod encoder;
mod error;
#[cfg(test)]
mod tests;
mod varint;
mod whole_stream;

pub use block::{parse_block, Block, BlockEvents, BlockItems, Cursor, Item};
pub use encoder::{end_block, plain_event_len, BlockEncoder};
pub use error::StreamError;
pub use whole_stream::{blocks, decode_all, Blocks};
#[cfg(test)]
pub(crate) use whole_stream::{data_blocks, net_steps};

pub const MAGIC: u8 = 0xB5;
pub const VERSION: u8 = 2;
/// The version before the end block existed: refused, its cuts cannot be told from its end.
pub const VERSION_WITHOUT_END_MARK: u8 = 1;
/// Bytes before the payload.
pub const HEADER_LEN: usize = 7;
pub const CRC_LEN: usize = 4;
/// Largest payload of one block (fits the length byte and a link frame).
pub const MAX_PAYLOAD: usize = 240;
/// Largest encoded block.
pub const MAX_BLOCK: usize = HEADER_LEN + MAX_PAYLOAD + CRC_LEN;
/// Largest dt one event can carry (29 bits after the 3 tag bits of a u32 varint).
pub const MAX_DT_TICKS: u32 = (1 << 29) - 1;

/// Payload of the end block: data blocks u32 LE, events u32 LE.
pub const END_PAYLOAD_LEN: usize = 8;
/// Bytes of the end block.
pub const END_BLOCK_LEN: usize = HEADER_LEN + END_PAYLOAD_LEN + CRC_LEN;

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
