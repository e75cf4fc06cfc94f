//! The board's link receive path under hostile input: a million inputs of random bytes, random
//! (often valid) requests, and those frames damaged, truncated and spliced.

mod protocol_support;

use std::time::Instant;

use motion::protocol::*;
use motion::segment::Rate;
use protocol_support::{config, frame, hello, seg, Rng};

/// `v` as postcard's varint (how a request's seq starts its bytes).
fn varint(mut v: u32, out: &mut Vec<u8>) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// A request that is often valid, aimed near the board's next seq.
fn random_request(rng: &mut Rng, next_seq: u32) -> Request {
    let seq = match rng.below(8) {
        0 => rng.next() as u32,
        1..=2 => next_seq.wrapping_sub(rng.below(40) as u32),
        _ => next_seq.wrapping_add(rng.below(2) as u32),
    };
    let small = |rng: &mut Rng| (rng.below(400) as i32 - 200) * (rng.below(4) != 0) as i32;
    let body = match rng.below(15) {
        0 if rng.chance(0.9) => RequestBody::GetConfig,
        0 => RequestBody::Hello {
            version: if rng.chance(0.9) { PROTOCOL_VERSION } else { rng.next() as u16 },
            nonce: rng.below(4) as u32,
        },
        1 => RequestBody::GetConfig,
        2 => {
            let mut c = config();
            match rng.below(6) {
                0 => c.machine.tick_hz = rng.next() as u32,
                1 => c.machine.axis_count = rng.below(8) as u8,
                2 => c.machine.timing.pulse_ns = rng.below(100_000) as u32,
                3 => c.scale[rng.below(6) as usize].soft_min = rng.next() as i64,
                4 => c.machine.axes[rng.below(6) as usize].max_rate_hz = rng.next() as u32,
                _ => {}
            }
            RequestBody::SetConfig(c)
        }
        3..=5 => {
            let mut b = SegmentBatch::default();
            for _ in 0..rng.below(5) {
                let mut s = seg(rng.next() as u32, [small(rng), small(rng), small(rng)]);
                if rng.chance(0.2) {
                    s.duration_ticks = rng.next() as u32;
                    s.steps[rng.below(6) as usize] = rng.next() as i32;
                    s.exit_rate = Rate::from_bits(rng.next() as u32);
                    s.accel_per_tick = Rate::from_bits(rng.below(3) as u32);
                }
                let _ = b.push(s);
            }
            RequestBody::QueueSegments(b)
        }
        6 => RequestBody::Start,
        7 => RequestBody::Hold,
        8 => RequestBody::Resume,
        9 => {
            if rng.chance(0.3) {
                RequestBody::Abort
            } else {
                RequestBody::GetStatus
            }
        }
        10 => RequestBody::SetOverride { rate_bits: rng.next() as u32 >> rng.below(4) },
        11 => RequestBody::SetStatusPeriod { ms: rng.next() as u16 >> rng.below(16) },
        12 if rng.chance(0.5) => RequestBody::Home,
        12 => RequestBody::JogOffLimit,
        13 => {
            let mut h = HomingConfig::NONE;
            h.count = rng.below(3) as u8;
            h.order[0] = rng.below(4) as u8;
            h.axes[h.order[0] as usize].search_hz = rng.below(100_000) as u32;
            RequestBody::SetHoming(h)
        }
        _ => RequestBody::ClearFault,
    };
    Request { seq, body }
}

/// The board's whole receive path on a million inputs (`FUZZ_INPUTS` for longer runs, as
/// `cargo xtask bench` does): random bytes, valid frames of random (often valid) requests, and
/// those frames bit-flipped, truncated and spliced. A panic fails the test; every answer must
/// frame, and the queue must never be overrun.
#[test]
fn board_survives_a_million_hostile_inputs() {
    let inputs: u64 =
        std::env::var("FUZZ_INPUTS").ok().and_then(|v| v.parse().ok()).unwrap_or(1_000_000);
    let t0 = Instant::now();
    let mut rng = Rng::new(0xF022);
    let mut target = SimTarget::new(config(), 16);
    let mut board = BoardLink::new("fuzz", CAP_DDA);
    let mut rx = FrameDecoder::<MAX_FRAME>::new();
    let mut host = HostLink::new(HostConfig::default());
    host.connect(3);
    let mut host_rx = FrameDecoder::<MAX_FRAME>::new();
    let mut out = [0u8; MAX_FRAME_LINK];
    let mut recent: Vec<Vec<u8>> = vec![frame(&hello(0))];
    let (mut frames_ok, mut frame_errors, mut acks, mut naks) = (0u64, 0u64, 0u64, 0u64);
    let mut input = Vec::with_capacity(1024);
    for i in 0..inputs {
        input.clear();
        let next = board.next_seq().unwrap_or(0);
        match rng.below(10) {
            0..=1 => {
                for _ in 0..rng.below(400) {
                    input.push(if rng.chance(0.05) { 0 } else { rng.byte() });
                }
            }
            2..=4 => {
                let f = frame(&random_request(&mut rng, next));
                input.extend_from_slice(&f);
                if recent.len() < 64 {
                    recent.push(f);
                } else {
                    let k = rng.below(64) as usize;
                    recent[k] = f;
                }
            }
            5..=6 => {
                let f = &recent[rng.below(recent.len() as u64) as usize];
                input.extend_from_slice(f);
                for _ in 0..1 + rng.below(3) {
                    let k = rng.below(input.len() as u64) as usize;
                    input[k] ^= 1 << rng.below(8);
                }
            }
            7 => {
                let f = &recent[rng.below(recent.len() as u64) as usize];
                input.extend_from_slice(&f[..rng.below(f.len() as u64) as usize]);
            }
            8 => {
                let a = &recent[rng.below(recent.len() as u64) as usize];
                let b = &recent[rng.below(recent.len() as u64) as usize];
                input.extend_from_slice(&a[..rng.below(a.len() as u64) as usize]);
                input.extend_from_slice(&b[rng.below(b.len() as u64) as usize..]);
            }
            _ => {
                // Valid COBS + CRC around random message bytes: exercises postcard decoding.
                let mut m = Vec::new();
                if rng.chance(0.5) {
                    varint(next, &mut m);
                }
                m.extend((0..1 + rng.below(60)).map(|_| rng.byte()));
                input.extend_from_slice(encode_payload_frame(&m, &mut out).unwrap());
            }
        }
        for &b in &input {
            let Some(r) = rx.push(b) else { continue };
            if r.is_ok() {
                frames_ok += 1
            } else {
                frame_errors += 1
            }
            let resp = board.on_frame(r, &mut target);
            match &resp {
                Response::Ack { .. } => acks += 1,
                Response::Nak { code, .. } => {
                    assert_ne!(*code, ErrorCode::Internal, "{resp:?}");
                    naks += 1
                }
                _ => {}
            }
            // Every answer frames, and the host side survives it too.
            let f = encode_frame(&resp, &mut out).expect("answers always fit");
            for &b in f {
                if let Some(Ok(m)) = host_rx.push(b) {
                    let _ = host.receive_message(m);
                }
            }
        }
        assert!(target.queue_len() <= 16);
        if rng.chance(0.2) {
            target.complete_one();
        }
        if rng.chance(0.001) {
            target.raise_fault(FaultCode::ALL[rng.below(8) as usize]);
        }
        if let Some(s) = board.poll(i, &target) {
            encode_frame(&s, &mut out).unwrap();
        }
        // Random bytes at the host's receive path too.
        if rng.chance(0.05) {
            for _ in 0..rng.below(200) {
                if let Some(Ok(m)) = host_rx.push(rng.byte()) {
                    let _ = host.receive_message(m);
                }
            }
        }
        let _ = host.poll_transmit(i);
    }
    println!(
        "fuzz: {inputs} inputs in {:?}: {frames_ok} CRC-valid frames, {frame_errors} bad frames, \
         {acks} acks, {naks} naks, {} segments queued",
        t0.elapsed(),
        target.queued_total
    );
    assert!(
        acks > 10_000 && target.queued_total > 1_000,
        "the fuzzer reaches the interesting paths"
    );
}
