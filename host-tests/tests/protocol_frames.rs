//! Link protocol framing: every request and response round trips through frames, corruption
//! (every single-bit error, random multi-byte damage, truncation, splices) is detected, and the
//! error-code table renders.

mod protocol_support;

use motion::polar::link_messages::PolarRequest;
use motion::wire::link_messages::WireJobParams;
use motion::wire::link_messages::WireRequest;
use std::collections::HashSet;

use motion::machine::MachineState;
use motion::protocol::*;
use protocol_support::{config, deframe, frame, seg, Rng};

fn all_requests() -> Vec<Request> {
    let segs = [seg(1, [100, -200, 3]), seg(u32::MAX, [i32::MIN, i32::MAX, 0])];
    let mut extreme = config();
    extreme.machine.tick_hz = u32::MAX;
    extreme.scale[5] =
        AxisScale { steps_per_unit_milli: u32::MAX, soft_min: i64::MIN, soft_max: i64::MAX };
    [
        RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 0xDEAD_BEEF },
        RequestBody::GetConfig,
        RequestBody::SetConfig(config()),
        RequestBody::SetConfig(extreme),
        RequestBody::QueueSegments(SegmentBatch::from_slice(&segs).unwrap()),
        RequestBody::QueueSegments(
            SegmentBatch::from_slice(&[segs[1]; MAX_SEGMENTS_PER_FRAME]).unwrap(),
        ),
        RequestBody::QueueSegments(SegmentBatch::default()),
        RequestBody::Start,
        RequestBody::Hold,
        RequestBody::Resume,
        RequestBody::Abort,
        RequestBody::SetOverride { rate_bits: MAX_OVERRIDE_BITS },
        RequestBody::GetStatus,
        RequestBody::SetStatusPeriod { ms: 250 },
        RequestBody::ClearFault,
        RequestBody::Home,
        RequestBody::SetHoming(HomingConfig::NONE),
        RequestBody::JogOffLimit,
        RequestBody::from(PolarRequest::QueueEvents(EventBlock {
            bytes: BlockBytes::from_slice(&[0xB5, 1, 2, 3]).unwrap(),
            last: false,
        })),
        RequestBody::from(PolarRequest::StartPlayback { m: 3, k: 2 }),
        RequestBody::from(WireRequest::ArmWire(WireJobParams {
            debounce_ticks: 50,
            retrace_limit_steps: 40_000,
            retrace_override_bits: 1 << 29,
            resume_override_bits: 1 << 29,
            resume_segments: 2,
            segments: 91,
        })),
        RequestBody::Sim(SimRequest::Inject { wire_stall: true }),
    ]
    .into_iter()
    .enumerate()
    .map(|(i, body)| Request { seq: [0, 1, 127, 128, u32::MAX][i % 5], body })
    .collect()
}

fn all_responses() -> Vec<Response> {
    let status = Status {
        tick: u64::MAX,
        positions: [i64::MIN, -1, 0, 1, i64::MAX, 42],
        state: LinkState::Stopping,
        override_bits: MAX_OVERRIDE_BITS,
        queue_depth: 3,
        credits: 13,
        segments_done: 99,
        last_done_id: Some(7),
        done_hash: 0xdead_beef,
        faults: FaultCode::EStop.bit() | FaultCode::SensorFault.bit(),
        sensors: [i32::MIN, 0, 5, i32::MAX],
        next_seq: 1234,
        machine: MachineState::Holding,
        causes: FaultCode::EStop.bit(),
        homed: true,
        event_credits: 7,
        events_fired: 19_036,
        event_blocks: 1,
        wire_stalls: 2,
        wire_retraces: 3,
        wire_returns: 4,
        wire_max_retrace_steps: 8_738,
        wire_power: true,
        // -- Z-slide job --
        ..Status::default()
    };
    let hello = HelloInfo {
        version: PROTOCOL_VERSION,
        firmware: FixedStr::truncated("motion-board 0.1.0 (f405)"),
        capabilities: CAP_DDA | CAP_STATUS_STREAM | CAP_SOFT_LIMITS,
        axes: 3,
        queue_capacity: 16,
        tick_hz: 100_000,
        max_window: RESULT_MEMORY as u16,
        max_segments_per_frame: MAX_SEGMENTS_PER_FRAME as u8,
        last_panic: Some(PanicSite {
            file: FixedStr::tail("firmware/src/bin/link.rs"),
            line: 281,
            column: 25,
        }),
    };
    let mut v = vec![
        Response::Ack { seq: 0, credits: 0, reply: Reply::None },
        Response::Ack { seq: 5, credits: 16, reply: Reply::Hello(hello) },
        Response::Ack { seq: u32::MAX, credits: u16::MAX, reply: Reply::Config(config()) },
        Response::Ack { seq: 9, credits: 2, reply: Reply::Status(status.clone()) },
        Response::Status(Status::default()),
        Response::Status(status),
    ];
    for &code in FaultCode::ALL {
        v.push(Response::Fault { code, tick: 77 });
    }
    let details = [
        NakDetail::None,
        NakDetail::Expected { expected: 3 },
        NakDetail::Segment { index: 2, reason: SegmentReason::AxisRate, axis: Some(1) },
        NakDetail::Segment { index: 0, reason: SegmentReason::Duration, axis: None },
        NakDetail::Config { field: FixedStr::truncated("accel_steps_per_s2"), axis: Some(4) },
        NakDetail::State(MachineState::Holding),
    ];
    for (i, &code) in ErrorCode::ALL.iter().enumerate() {
        v.push(Response::Nak {
            seq: i as u32,
            credits: 1,
            code,
            detail: details[i % details.len()].clone(),
        });
    }
    v
}

#[test]
fn every_message_round_trips_through_frames() {
    let mut d = FrameDecoder::<MAX_FRAME>::new();
    let reqs = all_requests();
    let resps = all_responses();
    let mut stream = Vec::new();
    for r in &reqs {
        stream.extend(frame(r));
        stream.push(0); // empty frames are ignored
    }
    let got = deframe(&mut d, &stream);
    assert_eq!(got.len(), reqs.len());
    for (g, r) in got.iter().zip(&reqs) {
        assert_eq!(&decode_request(g.as_ref().unwrap()).unwrap(), r);
    }
    let stream: Vec<u8> = resps.iter().flat_map(frame).collect();
    let got = deframe(&mut d, &stream);
    assert_eq!(got.len(), resps.len());
    for (g, r) in got.iter().zip(&resps) {
        assert_eq!(&decode_response(g.as_ref().unwrap()).unwrap(), r);
    }
    // The kinds are all covered.
    let kinds: HashSet<u8> = reqs.iter().map(|r| r.body.kind()).collect();
    assert_eq!(kinds.len(), 19);
}

#[test]
fn corruption_is_detected() {
    let mut d = FrameDecoder::<MAX_FRAME>::new();
    let mut frames: Vec<Vec<u8>> = all_requests().iter().map(frame).collect();
    frames.extend(all_responses().iter().map(frame));
    let mut undetected = 0;
    let mut trials = 0;
    // Every single-bit error in every frame.
    for f in &frames {
        for bit in 0..(f.len() - 1) * 8 {
            let mut g = f.clone();
            g[bit / 8] ^= 1 << (bit % 8);
            g.push(0); // in case the flip removed the delimiter's neighbour
            trials += 1;
            for r in deframe(&mut d, &g) {
                undetected += r.is_ok() as u32;
            }
        }
    }
    // Random multi-byte corruption, truncation and splices.
    let mut rng = Rng::new(7);
    for _ in 0..200_000 {
        let f = &frames[rng.below(frames.len() as u64) as usize];
        let mut g = f[..f.len() - 1].to_vec();
        match rng.below(3) {
            0 => {
                for _ in 0..1 + rng.below(4) {
                    let i = rng.below(g.len() as u64) as usize;
                    g[i] ^= 1 + rng.below(255) as u8;
                }
            }
            1 => g.truncate(rng.below(g.len() as u64) as usize),
            _ => {
                let h = &frames[rng.below(frames.len() as u64) as usize];
                let cut = rng.below(g.len() as u64) as usize;
                g.truncate(cut);
                g.extend_from_slice(&h[rng.below(h.len() as u64) as usize..h.len() - 1]);
                if g == f[..f.len() - 1] {
                    continue;
                }
            }
        }
        g.push(0);
        trials += 1;
        // A splice can legitimately contain a whole valid frame; only the original garbled one
        // must not get through.
        for m in deframe(&mut d, &g).into_iter().flatten() {
            let is_whole_frame = frames.iter().any(|x| {
                deframe(&mut FrameDecoder::<MAX_FRAME>::new(), x)[0].as_ref().ok() == Some(&m)
            });
            undetected += !is_whole_frame as u32;
        }
    }
    println!("corruption: {trials} corrupted frames, {undetected} undetected");
    assert_eq!(undetected, 0);
}

#[test]
fn error_table_renders() {
    let mut s = String::new();
    markdown_table(&mut s).unwrap();
    for (code, name, desc) in ErrorCode::TABLE {
        assert!(s.contains(&format!("| {code} | {name} | {desc} |")));
    }
    assert_eq!(ErrorCode::Sequence.code(), 6);
    assert_eq!(ErrorCode::from_code(7), Some(ErrorCode::QueueFull));
    assert_eq!(ErrorCode::QueueFull.name(), "QueueFull");
}
