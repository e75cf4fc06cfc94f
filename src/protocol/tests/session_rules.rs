//! The board's session and sequence rules: Hello first, each seq once, the result memory,
//! refusals that change nothing, malformed input, and the status stream's period.

use super::*;

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
