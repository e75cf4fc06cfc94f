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

use super::StepEvent;

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

/// Writes one LEB128 varint into `buf` at `*n`; false when it does not fit.
fn put_varint(buf: &mut [u8], n: &mut usize, mut v: u32) -> bool {
    loop {
        let Some(slot) = buf.get_mut(*n) else { return false };
        let b = (v & 0x7f) as u8;
        v >>= 7;
        *slot = if v != 0 { b | 0x80 } else { b };
        *n += 1;
        if v == 0 {
            return true;
        }
    }
}

fn varint_len(v: u32) -> usize {
    match v {
        0..=0x7f => 1,
        0x80..=0x3fff => 2,
        0x4000..=0x1f_ffff => 3,
        0x20_0000..=0xfff_ffff => 4,
        _ => 5,
    }
}

/// Reads a varint from `buf` at `*pos`.
fn get_varint(buf: &[u8], pos: &mut usize) -> Result<u32, StreamError> {
    let mut v: u64 = 0;
    for i in 0..5 {
        let b = *buf.get(*pos).ok_or(StreamError::Truncated)?;
        *pos += 1;
        v |= ((b & 0x7f) as u64) << (7 * i);
        if b & 0x80 == 0 {
            return u32::try_from(v).map_err(|_| StreamError::Varint);
        }
    }
    Err(StreamError::Varint)
}

const fn zigzag(v: i32) -> u32 {
    ((v << 1) ^ (v >> 31)) as u32
}

const fn unzigzag(v: u32) -> i32 {
    ((v >> 1) as i32) ^ -((v & 1) as i32)
}

/// Builds blocks from events, folding equal-code events with a constant dt step into runs.
/// No allocation: each finished block is handed to `emit` as a byte slice.
#[derive(Clone, Debug)]
pub struct BlockEncoder {
    seq: u16,
    payload: [u8; MAX_PAYLOAD],
    len: usize,
    events: u16,
    /// Open run: code, first dt, add, count (count 1 = a single pending event).
    run: Option<(u8, u32, i32, u32)>,
    /// dt of the last event in the open run.
    run_last: u32,
    /// Data blocks and events finished so far, for the end block.
    total_blocks: u32,
    total_events: u32,
}

impl Default for BlockEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl BlockEncoder {
    pub const fn new() -> Self {
        BlockEncoder {
            seq: 0,
            payload: [0; MAX_PAYLOAD],
            len: 0,
            events: 0,
            run: None,
            run_last: 0,
            total_blocks: 0,
            total_events: 0,
        }
    }

    /// Data blocks finished so far (before [`Self::finish`]: the next block's sequence number).
    pub fn blocks(&self) -> u32 {
        self.total_blocks
    }

    /// Adds one event; may finish a block through `emit`.
    pub fn push(&mut self, ev: StepEvent, emit: &mut impl FnMut(&[u8])) -> Result<(), StreamError> {
        if ev.dt_ticks > MAX_DT_TICKS {
            return Err(StreamError::DtRange);
        }
        let code = ev.code();
        if let Some((c, first, add, count)) = self.run {
            let step = ev.dt_ticks as i64 - self.run_last as i64;
            let same_step = count == 1 || step == add as i64;
            if c == code && same_step && count < u16::MAX as u32 && i32::try_from(step).is_ok() {
                let add = if count == 1 { step as i32 } else { add };
                self.run = Some((c, first, add, count + 1));
                self.run_last = ev.dt_ticks;
                return Ok(());
            }
            self.flush_run(emit);
        }
        self.run = Some((code, ev.dt_ticks, 0, 1));
        self.run_last = ev.dt_ticks;
        Ok(())
    }

    /// Writes the open run (or single event) into the payload, finishing the block first if it
    /// would not fit.
    fn flush_run(&mut self, emit: &mut impl FnMut(&[u8])) {
        let Some((code, first, add, count)) = self.run.take() else { return };
        let mut buf = [0u8; 15];
        let mut n = 0;
        if count == 1 {
            put_varint(&mut buf, &mut n, first << 3 | code as u32);
        } else {
            put_varint(&mut buf, &mut n, first << 3 | 4 | code as u32);
            put_varint(&mut buf, &mut n, count);
            put_varint(&mut buf, &mut n, zigzag(add));
        }
        let fits_count = self.events as u32 + count <= u16::MAX as u32;
        if self.len + n > MAX_PAYLOAD || !fits_count {
            self.finish_block(emit);
        }
        // An empty payload always holds one item (15 bytes < MAX_PAYLOAD).
        if let Some(dst) = self.payload.get_mut(self.len..self.len + n) {
            dst.copy_from_slice(&buf[..n]);
            self.len += n;
            self.events += count as u16;
        }
    }

    fn finish_block(&mut self, emit: &mut impl FnMut(&[u8])) {
        if self.events == 0 {
            return;
        }
        let mut block = [0u8; MAX_BLOCK];
        block[0] = MAGIC;
        block[1] = VERSION;
        block[2..4].copy_from_slice(&self.seq.to_le_bytes());
        block[4..6].copy_from_slice(&self.events.to_le_bytes());
        block[6] = self.len as u8;
        let end = HEADER_LEN + self.len;
        block[HEADER_LEN..end].copy_from_slice(&self.payload[..self.len]);
        let crc = CRC32.checksum(&block[..end]);
        block[end..end + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
        emit(&block[..end + CRC_LEN]);
        self.seq = self.seq.wrapping_add(1);
        self.total_blocks = self.total_blocks.wrapping_add(1);
        self.total_events = self.total_events.wrapping_add(self.events as u32);
        self.len = 0;
        self.events = 0;
    }

    /// Ends the stream: the open run, the last (partial) block, then the end block.
    pub fn finish(&mut self, emit: &mut impl FnMut(&[u8])) {
        self.flush_run(emit);
        self.finish_block(emit);
        emit(&end_block(self.seq, self.total_blocks, self.total_events));
        self.seq = self.seq.wrapping_add(1);
    }
}

/// The end block with sequence number `seq`, closing `blocks` data blocks of `events` events.
pub fn end_block(seq: u16, blocks: u32, events: u32) -> [u8; END_BLOCK_LEN] {
    let mut block = [0u8; END_BLOCK_LEN];
    block[0] = MAGIC;
    block[1] = VERSION;
    block[2..4].copy_from_slice(&seq.to_le_bytes());
    // events (bytes 4..6) stay 0: that marks the end block.
    block[6] = END_PAYLOAD_LEN as u8;
    block[HEADER_LEN..HEADER_LEN + 4].copy_from_slice(&blocks.to_le_bytes());
    block[HEADER_LEN + 4..HEADER_LEN + END_PAYLOAD_LEN].copy_from_slice(&events.to_le_bytes());
    let end = HEADER_LEN + END_PAYLOAD_LEN;
    let crc = CRC32.checksum(&block[..end]);
    block[end..].copy_from_slice(&crc.to_le_bytes());
    block
}

/// A checked block: header fields and the payload, ready to iterate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block<'a> {
    pub seq: u16,
    pub events: u16,
    payload: &'a [u8],
}

/// Splits the first block off `bytes`, checking magic, version, length and CRC. Returns the block
/// and the bytes after it.
pub fn parse_block(bytes: &[u8]) -> Result<(Block<'_>, &[u8]), StreamError> {
    let head = bytes.get(..HEADER_LEN).ok_or(StreamError::Truncated)?;
    if head[0] != MAGIC {
        return Err(StreamError::BadMagic);
    }
    if head[1] != VERSION {
        return Err(StreamError::Version(head[1]));
    }
    let seq = u16::from_le_bytes([head[2], head[3]]);
    let events = u16::from_le_bytes([head[4], head[5]]);
    let len = head[6] as usize;
    let end = HEADER_LEN + len;
    let crc_bytes = bytes.get(end..end + CRC_LEN).ok_or(StreamError::Truncated)?;
    let crc = u32::from_le_bytes([crc_bytes[0], crc_bytes[1], crc_bytes[2], crc_bytes[3]]);
    let body = bytes.get(..end).ok_or(StreamError::Truncated)?;
    if CRC32.checksum(body) != crc {
        return Err(StreamError::Crc);
    }
    if events == 0 && len != END_PAYLOAD_LEN {
        return Err(StreamError::Count);
    }
    let payload = bytes.get(HEADER_LEN..end).ok_or(StreamError::Truncated)?;
    let rest = bytes.get(end + CRC_LEN..).ok_or(StreamError::Truncated)?;
    Ok((Block { seq, events, payload }, rest))
}

impl<'a> Block<'a> {
    /// The block's events in order; the iterator yields an error (then stops) on a bad item or
    /// when the count differs from the header.
    pub fn iter(&self) -> BlockEvents<'a> {
        BlockEvents { payload: self.payload, cursor: Cursor::new(self) }
    }

    /// The payload bytes, for [`Cursor::next`].
    pub fn payload(&self) -> &'a [u8] {
        self.payload
    }

    /// For the end block, its totals: (data blocks, events); `None` for a data block.
    pub fn end_totals(&self) -> Option<(u32, u32)> {
        if self.events != 0 {
            return None;
        }
        let word = |at: usize| {
            let b = self.payload.get(at..at + 4)?;
            Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        Some((word(0)?, word(4)?))
    }
}

/// The data blocks of a whole stream in order, each parsed and in sequence, ending at the end
/// block (whose totals are checked; nothing may follow it). Yields each block and its bytes; an
/// error ends the iteration. Header-level only: [`decode_all`] also decodes every event.
#[derive(Clone, Debug)]
pub struct Blocks<'a> {
    rest: &'a [u8],
    offset: usize,
    blocks: u32,
    events: u32,
    done: bool,
}

/// The data blocks of the whole stream `bytes` (see [`Blocks`]).
pub fn blocks(bytes: &[u8]) -> Blocks<'_> {
    Blocks { rest: bytes, offset: 0, blocks: 0, events: 0, done: false }
}

impl Blocks<'_> {
    /// Byte offset of the next block in the stream (of the failing one after an error).
    pub fn offset(&self) -> usize {
        self.offset
    }
}

impl<'a> Iterator for Blocks<'a> {
    type Item = Result<(Block<'a>, &'a [u8]), StreamError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = (|| {
            if self.rest.is_empty() {
                return Err(StreamError::NoEndMark { blocks: self.blocks });
            }
            let (block, rest) = parse_block(self.rest)?;
            let expected = self.blocks as u16;
            if block.seq != expected {
                return Err(StreamError::Sequence { expected, found: block.seq });
            }
            if let Some((end_blocks, end_events)) = block.end_totals() {
                if (end_blocks, end_events) != (self.blocks, self.events) {
                    let (blocks, events) = (self.blocks, self.events);
                    return Err(StreamError::EndMismatch {
                        end_blocks,
                        end_events,
                        blocks,
                        events,
                    });
                }
                if !rest.is_empty() {
                    self.offset += self.rest.len() - rest.len();
                    return Err(StreamError::AfterEnd);
                }
                return Ok(None);
            }
            let raw = &self.rest[..self.rest.len() - rest.len()];
            self.offset += raw.len();
            self.rest = rest;
            self.blocks = self.blocks.wrapping_add(1);
            self.events = self.events.wrapping_add(block.events as u32);
            Ok(Some((block, raw)))
        })();
        fuse(&mut self.done, r)
    }
}

/// An iterator's next item from a step that gives `Ok(None)` at the end: `done` is set at the
/// end and after an error, which is returned once.
fn fuse<T>(done: &mut bool, r: Result<Option<T>, StreamError>) -> Option<Result<T, StreamError>> {
    match r {
        Ok(Some(item)) => Some(Ok(item)),
        Ok(None) => {
            *done = true;
            None
        }
        Err(e) => {
            *done = true;
            Some(Err(e))
        }
    }
}

/// One payload item as encoded: a single event (`count == 1`, `add == 0`) or a run of `count`
/// events on one code with dts `first_dt, first_dt + add, ...`. For readable dumps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Item {
    pub code: u8,
    pub first_dt: u32,
    pub count: u32,
    pub add: i32,
}

impl<'a> Block<'a> {
    /// The block's payload items without expanding runs; stops after the first error.
    pub fn items(&self) -> BlockItems<'a> {
        BlockItems { payload: self.payload, pos: 0, done: false }
    }

    /// Payload bytes (for size reports).
    pub fn payload_len(&self) -> usize {
        self.payload.len()
    }
}

/// Iterator over one block's payload items.
#[derive(Clone, Debug)]
pub struct BlockItems<'a> {
    payload: &'a [u8],
    pos: usize,
    done: bool,
}

impl Iterator for BlockItems<'_> {
    type Item = Result<Item, StreamError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done || self.pos >= self.payload.len() {
            return None;
        }
        let r = (|| {
            let v = get_varint(self.payload, &mut self.pos)?;
            let (code, first_dt) = ((v & 3) as u8, v >> 3);
            if v & 4 == 0 {
                return Ok(Item { code, first_dt, count: 1, add: 0 });
            }
            let count = get_varint(self.payload, &mut self.pos)?;
            let add = unzigzag(get_varint(self.payload, &mut self.pos)?);
            if count < 2 {
                return Err(StreamError::BadRun);
            }
            Ok(Item { code, first_dt, count, add })
        })();
        if r.is_err() {
            self.done = true;
        }
        Some(r)
    }
}

/// Iterator over one block's events (expands runs lazily, no allocation).
#[derive(Clone, Debug)]
pub struct BlockEvents<'a> {
    payload: &'a [u8],
    cursor: Cursor,
}

impl Iterator for BlockEvents<'_> {
    type Item = Result<StepEvent, StreamError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.cursor.next(self.payload)
    }
}

/// Where a block's decoding stands, without borrowing the block: a decoder that keeps the
/// block's bytes in a queue (the link firmware's feeder) resumes it event by event with
/// [`Cursor::next`] on the same payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cursor {
    pos: usize,
    expect: u16,
    seen: u32,
    /// Open run: code, next dt, add, events left.
    run: Option<(u8, i64, i64, u32)>,
    done: bool,
}

impl Cursor {
    /// At the start of `block`.
    pub fn new(block: &Block<'_>) -> Self {
        Cursor { pos: 0, expect: block.events, seen: 0, run: None, done: false }
    }

    /// True once every event was returned or an error was.
    pub fn is_done(&self) -> bool {
        self.done
    }

    /// Events returned so far.
    pub fn seen(&self) -> u32 {
        self.seen
    }

    /// The next event of the block whose payload is `payload` (the one this cursor was made
    /// for; [`Block::payload`]); `None` at the end, an error (then `None`) on a bad item.
    pub fn next(&mut self, payload: &[u8]) -> Option<Result<StepEvent, StreamError>> {
        if self.done {
            return None;
        }
        let r = self.step(payload);
        fuse(&mut self.done, r)
    }

    fn step(&mut self, payload: &[u8]) -> Result<Option<StepEvent>, StreamError> {
        if let Some((code, dt, add, left)) = self.run {
            if !(0..=MAX_DT_TICKS as i64).contains(&dt) {
                return Err(StreamError::BadRun);
            }
            self.run = if left > 1 { Some((code, dt + add, add, left - 1)) } else { None };
            return self.count(StepEvent::from_code(dt as u32, code));
        }
        if self.pos >= payload.len() {
            return if self.seen == self.expect as u32 {
                Ok(None)
            } else {
                Err(StreamError::Count)
            };
        }
        let v = get_varint(payload, &mut self.pos)?;
        let code = (v & 3) as u8;
        let dt = v >> 3;
        if v & 4 == 0 {
            return self.count(StepEvent::from_code(dt, code));
        }
        let count = get_varint(payload, &mut self.pos)?;
        let add = unzigzag(get_varint(payload, &mut self.pos)?) as i64;
        if count < 2 {
            return Err(StreamError::BadRun);
        }
        self.run = Some((code, dt as i64 + add, add, count - 1));
        self.count(StepEvent::from_code(dt, code))
    }

    fn count(&mut self, ev: StepEvent) -> Result<Option<StepEvent>, StreamError> {
        self.seen += 1;
        if self.seen > self.expect as u32 {
            return Err(StreamError::Count);
        }
        Ok(Some(ev))
    }
}

/// Bytes a plain (run-free) varint encoding of `ev` takes; used for size comparisons.
pub fn plain_event_len(ev: &StepEvent) -> usize {
    varint_len(ev.dt_ticks << 3 | ev.code() as u32)
}

/// Test helper: the data blocks of a whole, valid stream, each as its bytes.
#[cfg(test)]
pub(crate) fn data_blocks(bytes: &[u8]) -> std::vec::Vec<&[u8]> {
    blocks(bytes).map(|b| b.expect("a valid stream").1).collect()
}

/// Test helper: the net steps per axis (theta, r) of a whole stream, and its event count.
#[cfg(test)]
pub(crate) fn net_steps(bytes: &[u8]) -> ([i64; 2], u32) {
    let mut net = [0i64; 2];
    let n = decode_all(bytes, |e| net[(e.axis & 1) as usize] += e.signed() as i64)
        .expect("a valid stream");
    (net, n)
}

/// Decodes a whole stream into `out` via a callback: every block checked, in sequence, up to the
/// end block (see [`Blocks`]). Returns the event count.
pub fn decode_all(bytes: &[u8], mut out: impl FnMut(StepEvent)) -> Result<u32, StreamError> {
    let mut n = 0u32;
    for block in blocks(bytes) {
        for ev in block?.0.iter() {
            out(ev?);
            n = n.saturating_add(1);
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn encode(events: &[StepEvent]) -> std::vec::Vec<u8> {
        let mut out = std::vec::Vec::new();
        let mut enc = BlockEncoder::new();
        for &e in events {
            enc.push(e, &mut |b: &[u8]| out.extend_from_slice(b)).unwrap();
        }
        enc.finish(&mut |b: &[u8]| out.extend_from_slice(b));
        out
    }

    fn decode(bytes: &[u8]) -> Result<std::vec::Vec<StepEvent>, StreamError> {
        let mut v = std::vec::Vec::new();
        decode_all(bytes, |e| v.push(e))?;
        Ok(v)
    }

    fn ev(dt: u32, axis: u8, negative: bool) -> StepEvent {
        StepEvent { dt_ticks: dt, axis, negative }
    }

    #[test]
    fn runs_compress_constant_steps() {
        // 1000 radial steps with dt 145, 146, 147, ...: one run item.
        let evs: std::vec::Vec<_> = (0..1000).map(|i| ev(145 + i, 1, false)).collect();
        let bytes = encode(&evs);
        assert_eq!(decode(&bytes).unwrap(), evs);
        // The data block (the end block is a fixed 19 bytes per stream).
        let data = bytes.len() - END_BLOCK_LEN;
        assert!(data < 20, "{data} bytes");
        // The thesis word: 2 bytes per event, and 145 ticks of 10 us still fit its 14 bits.
        assert!(data * 100 < evs.len() * 2);
    }

    #[test]
    fn crc_and_sequence_errors_are_caught() {
        let evs: std::vec::Vec<_> =
            (0..600).map(|i| ev(i * 7919 % 5000, (i % 2) as u8, i % 3 == 0)).collect();
        let mut bytes = encode(&evs);
        assert_eq!(decode(&bytes).unwrap(), evs);
        let (b0, rest) = parse_block(&bytes).unwrap();
        assert!(b0.seq == 0 && !rest.is_empty(), "several blocks");
        let first_len = bytes.len() - rest.len();
        let k = HEADER_LEN + 3;
        bytes[k] ^= 0x10;
        assert_eq!(decode(&bytes), Err(StreamError::Crc));
        bytes[k] ^= 0x10;
        assert_eq!(
            decode(&bytes[first_len..]),
            Err(StreamError::Sequence { expected: 0, found: 1 }),
            "block 0 missing"
        );
        let doubled = [&bytes[..first_len], &bytes[..]].concat();
        assert_eq!(
            decode(&doubled),
            Err(StreamError::Sequence { expected: 1, found: 0 }),
            "block 0 twice"
        );
        assert_eq!(decode(&bytes[..first_len - 1]), Err(StreamError::Truncated));
        let mut v3 = bytes.clone();
        v3[1] = 3;
        assert_eq!(decode(&v3), Err(StreamError::Version(3)));
    }

    /// The data blocks' byte ranges and the end block's start.
    fn block_ends(bytes: &[u8]) -> std::vec::Vec<usize> {
        let mut it = blocks(bytes);
        let mut ends = std::vec::Vec::new();
        while let Some(b) = it.next() {
            b.unwrap();
            ends.push(it.offset());
        }
        ends
    }

    #[test]
    fn a_stream_cut_at_any_block_boundary_is_refused_naming_the_block() {
        let evs: std::vec::Vec<_> =
            (0..900).map(|i| ev(i * 7919 % 5000, (i % 2) as u8, i % 3 == 0)).collect();
        let bytes = encode(&evs);
        assert_eq!(decode(&bytes).unwrap(), evs, "the whole stream reads");
        let ends = block_ends(&bytes);
        assert!(ends.len() >= 3, "{} data blocks", ends.len());
        assert_eq!(bytes.len() - ends[ends.len() - 1], END_BLOCK_LEN);
        assert_eq!(decode(&[]), Err(StreamError::NoEndMark { blocks: 0 }));
        for (k, &cut) in ends.iter().enumerate() {
            let e = decode(&bytes[..cut]).unwrap_err();
            assert_eq!(e, StreamError::NoEndMark { blocks: k as u32 + 1 });
            let text = std::format!("{e}");
            assert!(text.contains(&std::format!("cut after block {k}")), "{text}");
        }
        // An end block moved up (it still follows its own seq) or anything after it.
        let early = [&bytes[..ends[0]], &end_block(1, 1, 0)[..]].concat();
        assert!(matches!(decode(&early), Err(StreamError::EndMismatch { blocks: 1, .. })));
        let after = [&bytes[..], &bytes[..ends[0]]].concat();
        assert_eq!(decode(&after), Err(StreamError::AfterEnd));
    }

    #[test]
    fn an_empty_stream_is_its_end_block_and_a_v1_stream_is_refused() {
        let bytes = encode(&[]);
        assert_eq!(bytes, end_block(0, 0, 0));
        assert_eq!(decode(&bytes), Ok(std::vec::Vec::new()));
        // A v1 file: the same data blocks with version 1 and no end block.
        let mut v1 = encode(&[ev(5, 0, false), ev(7, 1, true)]);
        v1.truncate(v1.len() - END_BLOCK_LEN);
        v1[1] = VERSION_WITHOUT_END_MARK;
        let body = v1.len() - CRC_LEN;
        let crc = CRC32.checksum(&v1[..body]);
        v1[body..].copy_from_slice(&crc.to_le_bytes());
        let e = decode(&v1).unwrap_err();
        assert_eq!(e, StreamError::Version(1));
        assert!(std::format!("{e}").contains("write it again"), "{e}");
    }

    #[test]
    fn zero_dt_and_max_dt_round_trip() {
        let evs = [ev(0, 0, true), ev(0, 1, false), ev(MAX_DT_TICKS, 1, true), ev(3, 0, false)];
        assert_eq!(decode(&encode(&evs)).unwrap(), evs);
        let mut enc = BlockEncoder::new();
        assert_eq!(
            enc.push(ev(MAX_DT_TICKS + 1, 0, false), &mut |_| {}),
            Err(StreamError::DtRange)
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn round_trip(raw in proptest::collection::vec((0u32..400, 0u8..4), 0..700)) {
            let evs: std::vec::Vec<_> = raw.iter().map(|&(dt, c)| StepEvent::from_code(dt, c)).collect();
            prop_assert_eq!(decode(&encode(&evs)).unwrap(), evs);
        }

        #[test]
        fn hostile_bytes_never_panic(mut bytes in proptest::collection::vec(any::<u8>(), 0..300), fix in any::<bool>()) {
            // Half the cases get a valid header and CRC so the payload parser sees hostile items.
            if fix && bytes.len() >= HEADER_LEN + CRC_LEN {
                let len = (bytes.len() - HEADER_LEN - CRC_LEN).min(MAX_PAYLOAD);
                bytes.truncate(HEADER_LEN + len + CRC_LEN);
                bytes[0] = MAGIC;
                bytes[1] = VERSION;
                bytes[2] = 0;
                bytes[3] = 0;
                bytes[6] = len as u8;
                let crc = CRC32.checksum(&bytes[..HEADER_LEN + len]);
                bytes[HEADER_LEN + len..].copy_from_slice(&crc.to_le_bytes());
            }
            let _ = decode_all(&bytes, |_| {});
        }
    }
}
