//! A whole stream: its data blocks in sequence up to the end block, whose totals are checked.

use super::block::{fuse, parse_block, Block};
use super::StreamError;
use crate::polar::StepEvent;

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
