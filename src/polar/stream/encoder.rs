//! The writer: events into blocks (runs folded), and the end block that closes a stream.

use super::varint::{put_varint, varint_len, zigzag};
use super::{
    StreamError, CRC32, CRC_LEN, END_BLOCK_LEN, END_PAYLOAD_LEN, HEADER_LEN, MAGIC, MAX_BLOCK,
    MAX_DT_TICKS, MAX_PAYLOAD, VERSION,
};
use crate::polar::StepEvent;

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

/// Bytes a plain (run-free) varint encoding of `ev` takes; used for size comparisons.
pub fn plain_event_len(ev: &StepEvent) -> usize {
    varint_len(ev.dt_ticks << 3 | ev.code() as u32)
}
