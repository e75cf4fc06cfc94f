//! Unit tests of the message sizes and the board's sequence rules.

use super::*;
use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::segment::{Rate, Segment};

pub(crate) fn config() -> WireConfig {
    WireConfig {
        machine: MachineConfig {
            tick_hz: 100_000,
            timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 12_000 },
            axis_count: 3,
            axes: [AxisLimits {
                max_rate_hz: 50_000,
                accel_steps_per_s2: 100_000,
                junction_jerk_hz: 0,
            }; MAX_AXES],
        },
        scale: [AxisScale {
            steps_per_unit_milli: 80_000,
            soft_min: -1_000_000,
            soft_max: 1_000_000,
        }; MAX_AXES],
    }
}

pub(crate) fn seg(id: u32, x: i32) -> Segment {
    Segment {
        steps: [x, 0, 0, 0, 0, 0],
        duration_ticks: (2 * x.unsigned_abs()).max(1_000),
        entry_rate: Rate::ZERO,
        exit_rate: Rate::ZERO,
        accel_per_tick: Rate::from_bits(1 << 20),
        id,
    }
}

fn extreme_config() -> WireConfig {
    WireConfig {
        machine: MachineConfig {
            tick_hz: u32::MAX,
            timing: StepTiming {
                pulse_ns: u32::MAX,
                dir_setup_ns: u32::MAX,
                dir_hold_ns: u32::MAX,
            },
            axis_count: u8::MAX,
            axes: [AxisLimits {
                max_rate_hz: u32::MAX,
                accel_steps_per_s2: u32::MAX,
                junction_jerk_hz: u32::MAX,
            }; MAX_AXES],
        },
        scale: [AxisScale {
            steps_per_unit_milli: u32::MAX,
            soft_min: i64::MIN,
            soft_max: i64::MIN,
        }; MAX_AXES],
    }
}

fn extreme_status() -> Status {
    Status {
        tick: u64::MAX,
        positions: [i64::MIN; MAX_AXES],
        state: WireState::Faulted,
        override_bits: u32::MAX,
        queue_depth: u16::MAX,
        credits: u16::MAX,
        segments_done: u32::MAX,
        last_done_id: Some(u32::MAX),
        done_hash: u32::MAX,
        faults: u32::MAX,
        sensors: [i32::MIN; SENSOR_CHANNELS],
        next_seq: u32::MAX,
        machine: crate::machine::MachineState::Fault,
        causes: u32::MAX,
        homed: true,
    }
}

/// The largest message of every kind, for the size bound.
pub(crate) fn extreme_requests() -> Vec<Request> {
    let s = Segment {
        steps: [i32::MIN; MAX_AXES],
        duration_ticks: u32::MAX,
        entry_rate: Rate::MAX,
        exit_rate: Rate::MAX,
        accel_per_tick: Rate::MAX,
        id: u32::MAX,
    };
    let seq = u32::MAX;
    [
        RequestBody::Hello { version: u16::MAX, nonce: u32::MAX },
        RequestBody::GetConfig,
        RequestBody::SetConfig(extreme_config()),
        RequestBody::QueueSegments(SegmentBatch::from_slice(&[s; MAX_SEGMENTS_PER_FRAME]).unwrap()),
        RequestBody::Start,
        RequestBody::Hold,
        RequestBody::Resume,
        RequestBody::Abort,
        RequestBody::SetOverride { rate_bits: u32::MAX },
        RequestBody::GetStatus,
        RequestBody::SetStatusPeriod { ms: u16::MAX },
        RequestBody::ClearFault,
        RequestBody::Home,
        RequestBody::JogOffLimit,
        RequestBody::SetHoming(HomingConfig {
            order: [u8::MAX; MAX_AXES],
            count: u8::MAX,
            axes: [crate::machine::HomeAxis {
                toward_max: true,
                search_hz: u32::MAX,
                latch_hz: u32::MAX,
                backoff_steps: u32::MAX,
                max_travel_steps: u32::MAX,
                home_pos_steps: i64::MIN,
            }; MAX_AXES],
        }),
    ]
    .into_iter()
    .map(|body| Request { seq, body })
    .collect()
}

pub(crate) fn extreme_responses() -> Vec<Response> {
    let (seq, credits) = (u32::MAX, u16::MAX);
    let name = FixedStr::truncated("ÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿÿ");
    let hello = HelloInfo {
        version: u16::MAX,
        firmware: name.clone(),
        capabilities: u32::MAX,
        axes: u8::MAX,
        queue_capacity: u16::MAX,
        tick_hz: u32::MAX,
        max_window: u16::MAX,
        max_segments_per_frame: u8::MAX,
    };
    let mut v = vec![
        Response::Ack { seq, credits, reply: Reply::None },
        Response::Ack { seq, credits, reply: Reply::Hello(hello) },
        Response::Ack { seq, credits, reply: Reply::Config(extreme_config()) },
        Response::Ack { seq, credits, reply: Reply::Status(extreme_status()) },
        Response::Status(extreme_status()),
        Response::Fault { code: FaultCode::SensorFault, tick: u64::MAX },
    ];
    let details = [
        NakDetail::None,
        NakDetail::Expected { expected: u32::MAX },
        NakDetail::Segment {
            index: u8::MAX,
            reason: SegmentReason::SoftLimit,
            axis: Some(u8::MAX),
        },
        NakDetail::Config {
            field: FixedStr::truncated("abcdefghijklmnopqrstuvwxyz"),
            axis: Some(u8::MAX),
        },
        NakDetail::State(crate::machine::MachineState::Fault),
    ];
    for detail in details {
        for &code in ErrorCode::ALL {
            v.push(Response::Nak { seq, credits, code, detail: detail.clone() });
        }
    }
    v
}

#[test]
fn largest_messages_fit_the_frame_buffers() {
    let mut out = [0u8; MAX_FRAME_WIRE];
    let mut largest = (0, 0);
    for r in extreme_requests() {
        let n = postcard::to_slice(&r, &mut [0u8; 1024]).unwrap().len();
        largest.0 = largest.0.max(n);
        let f = encode_frame(&r, &mut out).expect("request fits");
        assert!(f.len() <= MAX_FRAME_WIRE);
    }
    for r in extreme_responses() {
        let n = postcard::to_slice(&r, &mut [0u8; 1024]).unwrap().len();
        largest.1 = largest.1.max(n);
        let f = encode_frame(&r, &mut out).expect("response fits");
        assert!(f.len() <= MAX_FRAME_WIRE);
    }
    println!(
        "largest request {} / response {} bytes, MAX_MESSAGE {MAX_MESSAGE}",
        largest.0, largest.1
    );
    // Keep some headroom for additions, but not a wasteful amount.
    assert!(largest.0.max(largest.1) + 16 <= MAX_MESSAGE, "{largest:?}");
    assert!(largest.0.max(largest.1) + 96 > MAX_MESSAGE, "{largest:?}");
}

#[test]
fn request_kinds_are_postcard_indices() {
    for r in extreme_requests() {
        let mut buf = [0u8; 1024];
        let b = postcard::to_slice(&r.body, &mut buf).unwrap();
        assert_eq!(b[0], r.body.kind());
    }
}

fn req(seq: u32, body: RequestBody) -> Request {
    Request { seq, body }
}

fn hello(seq: u32, nonce: u32) -> Request {
    req(seq, RequestBody::Hello { version: PROTOCOL_VERSION, nonce })
}

fn queue(seq: u32, segs: &[Segment]) -> Request {
    req(seq, RequestBody::QueueSegments(SegmentBatch::from_slice(segs).unwrap()))
}

fn code(r: &Response) -> Option<ErrorCode> {
    match r {
        Response::Nak { code, .. } => Some(*code),
        _ => None,
    }
}

#[test]
fn requests_need_a_session() {
    let mut t = SimTarget::new(config(), 8);
    let mut b = BoardLink::new("test", CAP_DDA);
    let r = b.handle(&req(0, RequestBody::Start), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::NoSession));
    let r = b.handle(&req(7, RequestBody::Hello { version: 99, nonce: 1 }), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::Version));
    assert_eq!(b.next_seq(), None);
    let r = b.handle(&hello(7, 1), &mut t);
    assert!(matches!(r, Response::Ack { seq: 7, credits: 8, reply: Reply::Hello(_) }), "{r:?}");
    assert_eq!(b.next_seq(), Some(8));
    assert_eq!(t.mutations, 0, "Hello does not touch the machine");
}

#[test]
fn each_seq_executes_once_and_gaps_are_refused() {
    let mut t = SimTarget::new(config(), 8);
    let mut b = BoardLink::new("test", CAP_DDA);
    b.handle(&hello(u32::MAX - 1, 5), &mut t);
    // Wraps from u32::MAX to 0.
    let r1 = b.handle(&queue(u32::MAX, &[seg(1, 10)]), &mut t);
    assert!(matches!(r1, Response::Ack { credits: 7, .. }), "{r1:?}");
    // Gap: seq 1 before 0.
    let r = b.handle(&queue(1, &[seg(3, 10)]), &mut t);
    assert_eq!(
        r,
        Response::Nak {
            seq: 1,
            credits: 7,
            code: ErrorCode::Sequence,
            detail: NakDetail::Expected { expected: 0 }
        }
    );
    let r0 = b.handle(&queue(0, &[seg(2, 10), seg(3, 10)]), &mut t);
    assert!(matches!(r0, Response::Ack { seq: 0, credits: 5, .. }));
    // Retransmissions answer from memory (with the credits of the time) and queue nothing.
    assert_eq!(b.handle(&queue(u32::MAX, &[seg(1, 10)]), &mut t), r1);
    assert_eq!(b.handle(&queue(0, &[seg(2, 10), seg(3, 10)]), &mut t), r0);
    assert_eq!(t.queued_total, 3);
    // A retransmitted Hello is answered again without resetting the session.
    let r = b.handle(&hello(u32::MAX - 1, 5), &mut t);
    assert!(matches!(r, Response::Ack { reply: Reply::Hello(_), .. }));
    assert_eq!(b.next_seq(), Some(1));
    // A different request under an executed seq is Stale.
    assert_eq!(code(&b.handle(&req(0, RequestBody::Abort), &mut t)), Some(ErrorCode::Stale));
    // A new nonce starts a new session.
    b.handle(&hello(0, 6), &mut t);
    assert_eq!(b.next_seq(), Some(1));
    assert_eq!(t.queued_total, 3);
}

#[test]
fn results_are_remembered_for_the_window() {
    let mut t = SimTarget::new(config(), 8);
    let mut b = BoardLink::new("test", CAP_DDA);
    b.handle(&hello(0, 1), &mut t);
    for s in 1..=100 {
        b.handle(&req(s, RequestBody::GetStatus), &mut t);
    }
    let r = b.handle(&req(100 - RESULT_MEMORY as u32 + 1, RequestBody::GetStatus), &mut t);
    assert!(matches!(r, Response::Ack { reply: Reply::Status(_), .. }));
    let r = b.handle(&req(100 - RESULT_MEMORY as u32, RequestBody::GetStatus), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::Stale));
}

#[test]
fn refusals_change_nothing() {
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA);
    b.handle(&hello(0, 1), &mut t);
    let before = t.clone();
    let mut s = 1;
    let mut expect = |b: &mut BoardLink, t: &mut SimTarget, body: RequestBody, want: ErrorCode| {
        let r = b.handle(&req(s, body.clone()), t);
        assert_eq!(code(&r), Some(want), "{body:?} -> {r:?}");
        s += 1;
    };
    let bad = |f: fn(&mut Segment)| {
        let mut x = seg(9, 10);
        f(&mut x);
        RequestBody::QueueSegments(SegmentBatch::from_slice(&[seg(8, 10), x]).unwrap())
    };
    expect(&mut b, &mut t, bad(|s| s.duration_ticks = 0), ErrorCode::InvalidSegment);
    expect(&mut b, &mut t, bad(|s| s.steps[5] = 1), ErrorCode::InvalidSegment);
    expect(&mut b, &mut t, bad(|s| s.steps[0] = 2_000_000), ErrorCode::InvalidSegment);
    expect(&mut b, &mut t, bad(|s| s.steps = [0; 6]), ErrorCode::InvalidSegment);
    expect(&mut b, &mut t, bad(|s| s.exit_rate = Rate::from_num(1.5)), ErrorCode::InvalidSegment);
    expect(&mut b, &mut t, RequestBody::Hold, ErrorCode::OutOfState);
    expect(&mut b, &mut t, RequestBody::Resume, ErrorCode::OutOfState);
    expect(&mut b, &mut t, RequestBody::ClearFault, ErrorCode::OutOfState);
    expect(
        &mut b,
        &mut t,
        RequestBody::SetOverride { rate_bits: MAX_OVERRIDE_BITS + 1 },
        ErrorCode::OutOfRange,
    );
    expect(&mut b, &mut t, RequestBody::SetStatusPeriod { ms: 1 }, ErrorCode::OutOfRange);
    let mut c = config();
    c.machine.tick_hz = 5;
    expect(&mut b, &mut t, RequestBody::SetConfig(c), ErrorCode::InvalidConfig);
    let mut c = config();
    c.scale[2].soft_min = 10;
    c.scale[2].soft_max = 9;
    expect(&mut b, &mut t, RequestBody::SetConfig(c), ErrorCode::InvalidConfig);
    assert_eq!(t, before);

    // The detail names the segment, the reason and the axis.
    let r = b.handle(&req(s, bad(|s| s.steps[1] = 2_000_000)), &mut t);
    s += 1;
    assert_eq!(
        r,
        Response::Nak {
            seq: s - 1,
            credits: 4,
            code: ErrorCode::InvalidSegment,
            detail: NakDetail::Segment { index: 1, reason: SegmentReason::AxisRate, axis: Some(1) },
        }
    );
    // Soft limits count the segments queued before, in the batch and earlier.
    let near = [seg(1, 600_000); 1];
    assert!(matches!(b.handle(&queue(s, &near), &mut t), Response::Ack { .. }));
    s += 1;
    let r = b.handle(&queue(s, &[seg(2, 300_000), seg(3, 300_000)]), &mut t);
    s += 1;
    assert!(
        matches!(
            &r,
            Response::Nak {
                detail: NakDetail::Segment {
                    index: 1,
                    reason: SegmentReason::SoftLimit,
                    axis: Some(0)
                },
                ..
            }
        ),
        "{r:?}"
    );
    assert_eq!(t.queued_total, 1);
    // Too many segments for the credits: none queued.
    let r = b.handle(&queue(s, &[seg(4, -1); 4]), &mut t);
    s += 1;
    assert_eq!(code(&r), Some(ErrorCode::QueueFull));
    assert_eq!(t.queued_total, 1);
    // SetConfig needs an empty queue.
    assert_eq!(
        code(&b.handle(&req(s, RequestBody::SetConfig(config())), &mut t)),
        Some(ErrorCode::OutOfState)
    );
    s += 1;
    let r = b.handle(&req(s, RequestBody::SetConfig(c)), &mut t);
    assert!(matches!(
        &r,
        Response::Nak {
            code: ErrorCode::OutOfState,
            detail: NakDetail::State(crate::machine::MachineState::Ready),
            ..
        }
    ));
}

#[test]
fn malformed_requests_are_consumed_or_reported_at_link_level() {
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA);
    b.handle(&hello(10, 1), &mut t);
    // seq 11, then an unknown body variant.
    let r = b.handle_message(&[11, 200], &mut t);
    assert_eq!(code(&r), Some(ErrorCode::Malformed));
    assert_eq!(b.next_seq(), Some(12));
    assert_eq!(b.handle_message(&[11, 200], &mut t), r, "repeat answered from memory");
    // Trailing bytes are malformed too.
    let r = b.handle_message(&[12, 4, 0], &mut t);
    assert_eq!(code(&r), Some(ErrorCode::Malformed));
    // Unreadable seq: link-level NAK with the expected seq.
    let r = b.handle_message(&[0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF], &mut t);
    assert_eq!(
        r,
        Response::Nak {
            seq: 13,
            credits: 4,
            code: ErrorCode::Malformed,
            detail: NakDetail::Expected { expected: 13 }
        }
    );
    let r = b.on_frame(Err(FrameError::Crc), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::Crc));
    assert_eq!(t.mutations, 0);
}

#[test]
fn status_stream_follows_its_period() {
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA | CAP_STATUS_STREAM);
    assert!(b.poll(0, &t).is_none());
    b.handle(&hello(0, 1), &mut t);
    b.handle(&req(1, RequestBody::SetStatusPeriod { ms: 50 }), &mut t);
    let times: Vec<u64> = (0..200).filter(|&ms| b.poll(ms, &t).is_some()).collect();
    assert_eq!(times, vec![0, 50, 100, 150]);
    let Some(Response::Status(s)) = b.poll(200, &t) else { panic!() };
    assert_eq!((s.next_seq, s.credits), (2, 4));
}
