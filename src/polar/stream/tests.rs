use super::*;
use crate::polar::StepEvent;
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
    assert_eq!(enc.push(ev(MAX_DT_TICKS + 1, 0, false), &mut |_| {}), Err(StreamError::DtRange));
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
