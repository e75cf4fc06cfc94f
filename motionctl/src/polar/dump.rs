//! Readable text dump of a step-event stream: a header per block (sequence, event count, payload
//! bytes), then one line per payload item, a single event or a run, with the cumulative time of
//! its (first) event in ticks and seconds; the end block closes it (a file without one was cut).
//!
//! ```text
//! block 0: seq 0, 108 events, 238 payload bytes, crc ok
//!   t 0 ticks (0.000000 s): +theta dt 0
//!   t 7 ticks (0.000070 s): run 3 x -r dt 7 add +2, last at t 25
//! ```

use motion::polar::stream::{blocks, StreamError};
use std::fmt::Write;

/// Totals of a dump.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DumpSummary {
    pub blocks: u32,
    pub events: u64,
    pub items: u64,
    pub bytes: usize,
    /// Time of the last event, ticks.
    pub end_ticks: u64,
}

/// Name of an event code: sign and axis.
pub fn code_name(code: u8) -> &'static str {
    match code & 3 {
        0 => "+theta",
        1 => "+r",
        2 => "-theta",
        _ => "-r",
    }
}

/// Writes the dump of `bytes` into `out`; on a bad block writes an `error:` line and returns it.
pub fn dump(bytes: &[u8], tick_hz: u32, out: &mut String) -> Result<DumpSummary, StreamError> {
    let mut sum = DumpSummary { bytes: bytes.len(), ..Default::default() };
    let secs = |t: u64| t as f64 / tick_hz.max(1) as f64;
    let mut t: u64 = 0;
    let fail = |out: &mut String, e: StreamError, at: usize| {
        let _ = writeln!(out, "error: {e} (at byte {at})");
        Err(e)
    };
    let mut it = blocks(bytes);
    loop {
        let at = it.offset();
        let block = match it.next() {
            None => break,
            Some(Ok((block, _))) => block,
            Some(Err(e)) => return fail(out, e, at),
        };
        let _ = writeln!(
            out,
            "block {}: seq {}, {} events, {} payload bytes, crc ok",
            sum.blocks,
            block.seq,
            block.events,
            block.payload_len()
        );
        let mut in_block = 0u64;
        for item in block.items() {
            let item = match item {
                Ok(i) => i,
                Err(e) => return fail(out, e, at),
            };
            let first = t + item.first_dt as u64;
            if item.count == 1 {
                let _ = writeln!(
                    out,
                    "  t {first} ticks ({:.6} s): {} dt {}",
                    secs(first),
                    code_name(item.code),
                    item.first_dt
                );
                t = first;
            } else {
                let n = item.count as i64;
                let total = n * item.first_dt as i64 + item.add as i64 * n * (n - 1) / 2;
                let last = (t as i64 + total).max(0) as u64;
                let _ = writeln!(
                    out,
                    "  t {first} ticks ({:.6} s): run {} x {} dt {} add {:+}, last at t {last}",
                    secs(first),
                    item.count,
                    code_name(item.code),
                    item.first_dt,
                    item.add
                );
                t = last;
            }
            in_block += item.count as u64;
            sum.items += 1;
        }
        if in_block != block.events as u64 {
            return fail(out, StreamError::Count, at);
        }
        sum.events += in_block;
        sum.blocks += 1;
    }
    sum.end_ticks = t;
    let _ = writeln!(
        out,
        "end mark: {} blocks, {} events in {} items, {} bytes, last event at t {} ticks ({:.6} s)",
        sum.blocks,
        sum.events,
        sum.items,
        sum.bytes,
        t,
        secs(t)
    );
    Ok(sum)
}
