//! The board's queue of step-event blocks between the host link and the playback: blocks arrive
//! verified (CRC, every event decodes, sequence), wait whole, and are decoded a few events at a
//! time into the [`Playback`] queue by the feeder. Shared by the link firmware and the
//! simulated board ([`crate::protocol::SimTarget`]); no allocation.
//!
//! Credits are counted in blocks: a block's slot frees once its last event went to the playback.

use super::playback::Playback;
use super::stream::{parse_block, Cursor, StreamError, MAX_BLOCK};
use super::StepEvent;
use heapless::{Deque, Vec};

/// Blocks the link firmware holds (credits when empty): ~2 KB of RAM, ~1000 events of the
/// limacon stream, ~0.5 s of playback at 2x speed.
pub const EVENT_QUEUE_BLOCKS: usize = 8;

/// Why a block was refused; nothing was queued.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockError {
    /// The block failed the stream checks (length, magic, version, CRC, items, count).
    Stream(StreamError),
    /// Bytes after the block: a request carries exactly one block.
    Trailing,
    /// Not the next block of the stream (`expected` is).
    Sequence { expected: u16 },
    /// The host already sent the stream's last block.
    AfterLast,
    /// A stream file's end block: files end with one, the link's `last` flag ends a stream.
    EndMark,
}

impl BlockError {
    /// A stable small number for the link's NAK detail: 1..=8 are [`StreamError::code`],
    /// 9 trailing bytes, 10 sequence, 11 after the last block, 12 an end block.
    pub const fn code(self) -> u8 {
        match self {
            BlockError::Stream(e) => e.code(),
            BlockError::Trailing => 9,
            BlockError::Sequence { .. } => 10,
            BlockError::AfterLast => 11,
            BlockError::EndMark => 12,
        }
    }
}

/// Checks one block completely (header, CRC, every event) and that it is block `expected`
/// (`None`: the last block was already sent). Returns its event count. Planning-rate work: one
/// CRC over at most [`MAX_BLOCK`] bytes and one decoding pass.
pub fn check_block(bytes: &[u8], expected: Option<u16>) -> Result<u16, BlockError> {
    let (block, rest) = parse_block(bytes).map_err(BlockError::Stream)?;
    if !rest.is_empty() {
        return Err(BlockError::Trailing);
    }
    if block.end_totals().is_some() {
        return Err(BlockError::EndMark);
    }
    let expected = expected.ok_or(BlockError::AfterLast)?;
    if block.seq != expected {
        return Err(BlockError::Sequence { expected });
    }
    for ev in block.iter() {
        ev.map_err(BlockError::Stream)?;
    }
    Ok(block.events)
}

/// Verified blocks waiting for the playback, and the decoding position in the oldest.
#[derive(Clone, Debug)]
pub struct EventFeed<const N: usize> {
    blocks: Deque<Vec<u8, MAX_BLOCK>, N>,
    /// Decoding position in `blocks.front()`; `None` before its first event.
    cursor: Option<Cursor>,
    next_seq: u16,
    /// The host marked a block as the stream's last.
    last_queued: bool,
    /// The last block was decoded completely: the playback was told to finish.
    finished: bool,
    /// Events admitted since [`EventFeed::clear`].
    pub events_admitted: u32,
}

impl<const N: usize> Default for EventFeed<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> EventFeed<N> {
    pub const fn new() -> Self {
        EventFeed {
            blocks: Deque::new(),
            cursor: None,
            next_seq: 0,
            last_queued: false,
            finished: false,
            events_admitted: 0,
        }
    }

    /// Drops every block and starts a new stream (block 0 next).
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Free block slots.
    pub fn credits(&self) -> u16 {
        (N - self.blocks.len()) as u16
    }

    pub const fn capacity(&self) -> u16 {
        N as u16
    }

    /// Blocks waiting (including the one being decoded).
    pub fn blocks(&self) -> usize {
        self.blocks.len()
    }

    /// The sequence number the next block must carry; `None` once the last block was queued.
    pub fn expected(&self) -> Option<u16> {
        (!self.last_queued).then_some(self.next_seq)
    }

    /// Nothing was queued since the last [`EventFeed::clear`].
    pub fn is_unused(&self) -> bool {
        self.next_seq == 0 && !self.last_queued
    }

    /// The whole stream went to the playback.
    pub fn is_finished(&self) -> bool {
        self.finished
    }

    /// Checks and stores one block; `last` marks the stream's end. Nothing changes on an error.
    pub fn push(&mut self, bytes: &[u8], last: bool) -> Result<u16, PushError> {
        if self.blocks.is_full() {
            return Err(PushError::Full);
        }
        let events = check_block(bytes, self.expected()).map_err(PushError::Block)?;
        let stored = Vec::from_slice(bytes).map_err(|_| PushError::Block(BlockError::Trailing))?;
        // Cannot fail: checked for room above.
        let _ = self.blocks.push_back(stored);
        self.next_seq = self.next_seq.wrapping_add(1);
        self.last_queued |= last;
        self.events_admitted = self.events_admitted.saturating_add(events as u32);
        Ok(events)
    }

    /// Decodes up to `out.len()` events into `out`; returns how many, and whether the stream
    /// ended with them (then call `Playback::finish` after pushing them). Stops early when no
    /// block is waiting. A block that fails to decode (it was checked when queued, so only a
    /// memory fault could do it) ends the stream there: the host's event count check catches it.
    pub fn take(&mut self, out: &mut [StepEvent]) -> (usize, bool) {
        let mut n = 0;
        while n < out.len() && !self.finished {
            let Some(bytes) = self.blocks.front() else { break };
            let next = match parse_block(bytes) {
                Ok((block, _)) => {
                    let cursor = self.cursor.get_or_insert_with(|| Cursor::new(&block));
                    cursor.next(block.payload())
                }
                Err(e) => Some(Err(e)),
            };
            match next {
                Some(Ok(ev)) => {
                    if let Some(slot) = out.get_mut(n) {
                        *slot = ev;
                    }
                    n += 1;
                }
                Some(Err(_)) => {
                    self.blocks.clear();
                    self.cursor = None;
                    self.last_queued = true;
                    self.finished = true;
                }
                None => {
                    self.blocks.pop_front();
                    self.cursor = None;
                    if self.blocks.is_empty() && self.last_queued {
                        self.finished = true;
                    }
                }
            }
        }
        (n, self.finished)
    }

    /// Moves events into `play` until it is full or no block is waiting; finishes it at the
    /// stream's end. Returns the events moved. (The firmware instead moves small batches from
    /// [`EventFeed::take`] under short locks.)
    pub fn fill(&mut self, play: &mut Playback) -> usize {
        let mut moved = 0;
        let mut buf = [StepEvent::default(); 16];
        loop {
            let room = play.free().min(buf.len());
            if room == 0 && !self.finished {
                return moved;
            }
            let (n, finished) = self.take(&mut buf[..room]);
            for &ev in &buf[..n] {
                // Cannot fail: `room` slots were free.
                let _ = play.push(ev);
            }
            moved += n;
            if finished {
                play.finish();
                return moved;
            }
            if n < room {
                return moved;
            }
        }
    }
}

/// Why [`EventFeed::push`] refused a block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PushError {
    /// No free block slot (no credits).
    Full,
    Block(BlockError),
}

#[cfg(test)]
mod tests {
    use super::super::limacon_stream::BYTES;
    use super::super::playback::SizeScale;
    use super::super::stream::{decode_all, end_block};
    use super::*;

    /// The built-in stream split into its data blocks.
    fn blocks() -> std::vec::Vec<&'static [u8]> {
        super::super::stream::data_blocks(BYTES)
    }

    #[test]
    fn blocks_stream_through_the_feed_in_order_and_finish_the_playback() {
        let mut want = std::vec::Vec::new();
        let total = decode_all(BYTES, |e| want.push(e)).unwrap();
        let bl = blocks();
        let mut feed = EventFeed::<4>::new();
        let mut play = Playback::new(SizeScale::ONE);
        let mut next = 0;
        let mut ticks = 0u64;
        while !play.done() && ticks < 100_000_000 {
            while next < bl.len() && feed.credits() > 0 {
                feed.push(bl[next], next + 1 == bl.len()).unwrap();
                next += 1;
            }
            feed.fill(&mut play);
            // Never starved: the feed refills before every tick.
            assert!(!play.starved(), "starved at tick {ticks}");
            play.tick();
            ticks += 1;
        }
        assert_eq!(play.fired(), total);
        assert_eq!(feed.events_admitted, total);
        assert_eq!(want.len() as u32, total);
        assert!(bl.len() > 4, "the test must wrap the 4-block queue: {} blocks", bl.len());
    }

    #[test]
    fn bad_blocks_are_refused_and_change_nothing() {
        let bl = blocks();
        let mut feed = EventFeed::<2>::new();
        let mut bad = bl[0].to_vec();
        let k = bad.len() - 6;
        bad[k] ^= 1;
        assert_eq!(
            feed.push(&bad, false),
            Err(PushError::Block(BlockError::Stream(StreamError::Crc)))
        );
        assert_eq!(
            feed.push(bl[1], false),
            Err(PushError::Block(BlockError::Sequence { expected: 0 }))
        );
        let mut two = bl[0].to_vec();
        two.extend_from_slice(bl[1]);
        assert_eq!(feed.push(&two, false), Err(PushError::Block(BlockError::Trailing)));
        // The end block of a file is not sent over the link.
        assert_eq!(
            feed.push(&end_block(0, 0, 0), true),
            Err(PushError::Block(BlockError::EndMark))
        );
        assert!(feed.is_unused() && feed.credits() == 2 && feed.events_admitted == 0);
        feed.push(bl[0], false).unwrap();
        feed.push(bl[1], true).unwrap();
        assert_eq!(feed.push(bl[2], false), Err(PushError::Full));
        let mut play = Playback::new(SizeScale::ONE);
        while !feed.is_finished() {
            feed.fill(&mut play);
            while play.queued() > 0 {
                play.tick();
            }
        }
        assert_eq!(feed.push(bl[2], false), Err(PushError::Block(BlockError::AfterLast)));
    }
}
