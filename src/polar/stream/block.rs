//! One block on its own: its header and CRC checked, its payload read as items or as events (the
//! cursor lets a feeder that keeps the bytes resume it event by event).

use super::varint::{get_varint, unzigzag};
use super::{
    StreamError, CRC32, CRC_LEN, END_PAYLOAD_LEN, HEADER_LEN, MAGIC, MAX_DT_TICKS, VERSION,
};
use crate::polar::StepEvent;

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

/// An iterator's next item from a step that gives `Ok(None)` at the end: `done` is set at the
/// end and after an error, which is returned once.
pub(super) fn fuse<T>(
    done: &mut bool,
    r: Result<Option<T>, StreamError>,
) -> Option<Result<T, StreamError>> {
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
