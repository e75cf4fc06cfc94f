//! The stream dump: one line per item with cumulative times that match the events', block
//! headers, and an error line for a corrupted block.

use motion::polar::stream::BlockEncoder;
use motion::polar::StepEvent;
use motionctl::polar::dump::dump;

fn encode(events: &[StepEvent]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut enc = BlockEncoder::new();
    for &e in events {
        enc.push(e, &mut |b: &[u8]| out.extend_from_slice(b)).unwrap();
    }
    enc.finish(&mut |b: &[u8]| out.extend_from_slice(b));
    out
}

fn ev(dt: u32, axis: u8, negative: bool) -> StepEvent {
    StepEvent { dt_ticks: dt, axis, negative }
}

#[test]
fn dump_lines_carry_cumulative_time() {
    // A run of 50 radial steps with growing dt, a simultaneous pair, then enough scattered
    // events for several blocks.
    let mut evs: Vec<StepEvent> = (0..50).map(|i| ev(100 + 3 * i, 1, false)).collect();
    evs.push(ev(40, 0, true));
    evs.push(ev(0, 1, true));
    evs.extend((0..400u32).map(|i| ev(i * 7919 % 3000, (i % 2) as u8, i % 3 == 0)));
    let bytes = encode(&evs);
    let mut text = String::new();
    let sum = dump(&bytes, 100_000, &mut text).unwrap();
    print!("{}", text.lines().take(8).collect::<Vec<_>>().join("\n"));
    println!("\n...\n{}", text.lines().last().unwrap());
    let total: u64 = evs.iter().map(|e| e.dt_ticks as u64).sum();
    assert_eq!(sum.events, evs.len() as u64);
    assert_eq!(sum.end_ticks, total);
    assert!(sum.blocks >= 2, "{sum:?}");
    assert_eq!(text.lines().filter(|l| l.starts_with("block ")).count() as u32, sum.blocks);
    // Every item line's time is the cumulative time of an event, in order.
    let mut cum = Vec::new();
    let mut t = 0u64;
    for e in &evs {
        t += e.dt_ticks as u64;
        cum.push(t);
    }
    let mut k = 0usize;
    let mut item_lines = 0;
    for line in text.lines().filter(|l| l.starts_with("  t ")) {
        item_lines += 1;
        let first: u64 = line[4..].split(' ').next().unwrap().parse().unwrap();
        assert_eq!(first, cum[k], "{line}");
        k += line
            .split("run ")
            .nth(1)
            .map_or(1, |r| r.split(' ').next().unwrap().parse::<usize>().unwrap());
        if let Some(last) = line.split("last at t ").nth(1) {
            assert_eq!(last.parse::<u64>().unwrap(), cum[k - 1], "{line}");
        }
    }
    assert_eq!(k, evs.len());
    assert_eq!(item_lines as u64, sum.items);
    assert!(sum.items < evs.len() as u64, "the run is one line");
    // A flipped payload bit: the dump stops with an error line.
    let mut bad = bytes.clone();
    bad[9] ^= 0x40;
    let mut text = String::new();
    assert!(dump(&bad, 100_000, &mut text).is_err());
    assert!(text.lines().last().unwrap().starts_with("error: Crc"), "{text}");
}

/// A stream file with a block dropped or repeated (a bad copy, a concatenation) is refused by
/// the dump at the block where the sequence breaks, not printed as if whole.
#[test]
fn a_dropped_or_duplicated_block_is_named() {
    use motion::polar::stream::{parse_block, StreamError};
    let evs: Vec<StepEvent> =
        (0..600u32).map(|i| ev(i * 7919 % 3000, (i % 2) as u8, false)).collect();
    let bytes = encode(&evs);
    let (_, rest) = parse_block(&bytes).unwrap();
    let first = &bytes[..bytes.len() - rest.len()];
    let (_, rest2) = parse_block(rest).unwrap();
    let second = &rest[..rest.len() - rest2.len()];
    assert!(!rest2.is_empty(), "at least three blocks");
    let cases: [(Vec<u8>, u16, u16); 2] = [
        ([first, rest2].concat(), 1, 2),                 // block 1 dropped
        ([first, second, second, rest2].concat(), 2, 1), // block 1 twice
    ];
    for (file, expected, found) in cases {
        let mut text = String::new();
        let e = dump(&file, 100_000, &mut text).unwrap_err();
        assert_eq!(e, StreamError::Sequence { expected, found });
        let want = format!("has seq {found}, expected {expected}: a block was dropped");
        assert!(text.lines().last().unwrap().contains(&want), "{text}");
    }
}

/// A stream file cut exactly at a block boundary (every one of them) is refused with the block
/// after which it was cut; the whole file dumps to its end mark; a version-1 file (no end mark)
/// is refused with how to write it again.
#[test]
fn a_stream_cut_at_a_block_boundary_or_of_version_1_is_refused() {
    use motion::polar::stream::{blocks, StreamError, END_BLOCK_LEN, VERSION_WITHOUT_END_MARK};
    let evs: Vec<StepEvent> =
        (0..900u32).map(|i| ev(i * 7919 % 3000, (i % 2) as u8, i % 5 == 0)).collect();
    let bytes = encode(&evs);
    let mut text = String::new();
    let sum = dump(&bytes, 100_000, &mut text).unwrap();
    assert!(text.lines().last().unwrap().starts_with("end mark: "), "{text}");
    let mut it = blocks(&bytes);
    let mut ends = Vec::new();
    while it.next().is_some() {
        ends.push(it.offset());
    }
    assert_eq!(ends.len() as u32, sum.blocks);
    assert!(sum.blocks >= 3, "{sum:?}");
    for (k, &cut) in ends.iter().enumerate() {
        let mut text = String::new();
        let e = dump(&bytes[..cut], 100_000, &mut text).unwrap_err();
        assert_eq!(e, StreamError::NoEndMark { blocks: k as u32 + 1 });
        let last = text.lines().last().unwrap();
        assert!(
            last.contains(&format!("no end mark: the stream is cut after block {k}")),
            "{last}"
        );
    }
    // Version 1: the data blocks with the old version byte and their CRC, no end block.
    let mut v1 = bytes[..bytes.len() - END_BLOCK_LEN].to_vec();
    let mut at = 0;
    for &end in &ends {
        v1[at + 1] = VERSION_WITHOUT_END_MARK;
        let crc = motion::protocol::CRC32.checksum(&v1[at..end - 4]);
        v1[end - 4..end].copy_from_slice(&crc.to_le_bytes());
        at = end;
    }
    let mut text = String::new();
    assert_eq!(dump(&v1, 100_000, &mut text), Err(StreamError::Version(1)));
    assert!(text.contains("has no end mark") && text.contains("polar digitize"), "{text}");
}
