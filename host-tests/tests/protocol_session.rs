//! Link protocol sessions: refusals in every state change nothing (and their retransmissions
//! get the same answer), and the host respects the board's credits and notices a board reset.

mod protocol_support;

use motion::protocol::*;
use motion::segment::Segment;
use protocol_support::{config, deframe, frame, hello, seg};

/// Sends `body` as the next request through the framing and returns the answer.
fn exchange(board: &mut BoardLink, t: &mut SimTarget, seq: u32, body: RequestBody) -> Response {
    let mut d = FrameDecoder::<MAX_FRAME>::new();
    let f = frame(&Request { seq, body });
    let mut out = None;
    for b in f {
        if let Some(r) = d.push(b) {
            out = Some(board.on_frame(r, t));
        }
    }
    let resp = out.unwrap();
    decode_response(&deframe(&mut d, &frame(&resp))[0].clone().unwrap()).unwrap()
}

#[test]
fn refusals_in_every_state_change_nothing() {
    let mut t = SimTarget::new(config(), 8);
    let mut board = BoardLink::new("sim", CAP_DDA);
    let mut seq = 100;
    exchange(&mut board, &mut t, seq, hello(seq).body);
    let mut next = || {
        seq += 1;
        seq
    };
    let q = |segs: &[Segment]| RequestBody::QueueSegments(SegmentBatch::from_slice(segs).unwrap());
    let assert_refused =
        |board: &mut BoardLink, t: &mut SimTarget, seq: u32, body: RequestBody, code: ErrorCode| {
            let before = t.clone();
            let r = exchange(board, t, seq, body.clone());
            match &r {
                Response::Nak { code: c, .. } => assert_eq!(*c, code, "{body:?}"),
                _ => panic!("{body:?} accepted in {:?}: {r:?}", before.state()),
            }
            assert!(*t == before, "{body:?} changed the target");
            // The retransmission gets the same answer and changes nothing either.
            assert_eq!(exchange(board, t, seq, body), r);
            assert!(*t == before);
        };
    let mut big = config();
    big.machine.axes[0].max_rate_hz = 1;
    use ErrorCode::*;
    // Idle.
    assert_refused(&mut board, &mut t, next(), RequestBody::Hold, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Resume, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::ClearFault, OutOfState);
    assert_refused(
        &mut board,
        &mut t,
        next(),
        RequestBody::SetOverride { rate_bits: u32::MAX },
        OutOfRange,
    );
    assert_refused(&mut board, &mut t, next(), RequestBody::SetStatusPeriod { ms: 9 }, OutOfRange);
    assert_refused(&mut board, &mut t, next(), q(&[seg(1, [0, 0, 0])]), InvalidSegment);
    assert_refused(
        &mut board,
        &mut t,
        next(),
        q(&[seg(1, [1, 0, 0]), seg(2, [0, 0, 1_000_000_000])]),
        InvalidSegment,
    );
    assert_refused(&mut board, &mut t, next(), q(&[seg(1, [11_000_000, 0, 0])]), InvalidSegment);
    // A refused Hello does not consume a seq (nor end the session).
    assert_refused(
        &mut board,
        &mut t,
        0,
        RequestBody::Hello { version: PROTOCOL_VERSION + 1, nonce: 1 },
        Version,
    );
    // Moving.
    for _ in 0..2 {
        assert!(matches!(
            exchange(&mut board, &mut t, next(), q(&[seg(1, [10, 0, 0]); 4])),
            Response::Ack { .. }
        ));
    }
    assert!(matches!(
        exchange(&mut board, &mut t, next(), RequestBody::Start),
        Response::Ack { .. }
    ));
    assert_eq!(t.state(), LinkState::Moving);
    assert_refused(&mut board, &mut t, next(), RequestBody::Start, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Resume, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::SetConfig(config()), OutOfState);
    assert_refused(&mut board, &mut t, next(), q(&[seg(1, [10, 0, 0])]), QueueFull);
    // Held.
    assert!(matches!(
        exchange(&mut board, &mut t, next(), RequestBody::Hold),
        Response::Ack { .. }
    ));
    assert_refused(&mut board, &mut t, next(), RequestBody::Hold, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Start, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::SetConfig(big), OutOfState);
    // Faulted.
    t.raise_fault(FaultCode::EStop);
    assert_refused(&mut board, &mut t, next(), q(&[seg(5, [1, 0, 0])]), OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Start, OutOfState);
    assert_refused(&mut board, &mut t, next(), RequestBody::Resume, OutOfState);
    assert!(matches!(
        exchange(&mut board, &mut t, next(), RequestBody::ClearFault),
        Response::Ack { .. }
    ));
    assert_eq!(t.state(), LinkState::Idle);
    // Idle again: an invalid config names its field.
    let r = exchange(&mut board, &mut t, next(), RequestBody::SetConfig(big));
    let before = t.clone();
    assert!(matches!(r, Response::Ack { .. }), "max_rate_hz 1 is valid: {r:?}");
    let mut bad = config();
    bad.scale[1].steps_per_unit_milli = 0;
    let r = exchange(&mut board, &mut t, next(), RequestBody::SetConfig(bad));
    let Response::Nak { code: InvalidConfig, detail: NakDetail::Config { field, axis }, .. } = r
    else {
        panic!("{r:?}")
    };
    assert_eq!((field.as_str(), axis), ("steps_per_unit_milli", Some(1)));
    assert_eq!(bad.validate().unwrap_err().reason, "must be > 0");
    assert!(t == before);
}

#[test]
fn host_respects_credits_and_detects_board_reset() {
    let mut t = SimTarget::new(config(), 5);
    let mut board = BoardLink::new("sim", CAP_DDA);
    let mut host = HostLink::new(HostConfig::default());
    assert_eq!(host.send(RequestBody::Start), Err(SendError::NotConnected));
    host.connect(40);
    let pump = |host: &mut HostLink, board: &mut BoardLink, t: &mut SimTarget| {
        let mut evs = Vec::new();
        while let Some(req) = host.poll_transmit(0) {
            let resp = board.handle(&req, t);
            evs.extend(host.receive(resp));
        }
        evs
    };
    let evs = pump(&mut host, &mut board, &mut t);
    assert!(matches!(evs[..], [HostEvent::Connected(ref i)] if i.queue_capacity == 5));
    assert_eq!(host.segment_credits(), 5);
    let four = SegmentBatch::from_slice(&[seg(1, [1, 0, 0]); 4]).unwrap();
    host.send(RequestBody::QueueSegments(four.clone())).unwrap();
    assert_eq!(host.segment_credits(), 1, "in-flight segments count against credits");
    assert_eq!(
        host.send(RequestBody::QueueSegments(four.clone())),
        Err(SendError::NoCredits { available: 1 })
    );
    pump(&mut host, &mut board, &mut t);
    assert_eq!(host.segment_credits(), 1);
    t.start().unwrap();
    t.complete_one();
    t.complete_one();
    host.send(RequestBody::GetStatus).unwrap();
    pump(&mut host, &mut board, &mut t);
    assert_eq!(host.segment_credits(), 3);
    // The board resets: its next answer is NoSession and the host must reconnect.
    let mut board = BoardLink::new("sim", CAP_DDA);
    host.send(RequestBody::Abort).unwrap();
    let evs = pump(&mut host, &mut board, &mut t);
    assert_eq!(evs, vec![HostEvent::SessionLost(ErrorCode::NoSession)]);
    assert!(!host.is_connected());
    // A board speaking another version refuses the Hello.
    host.connect(1);
    let req = host.poll_transmit(0).unwrap();
    let ev = host.receive(Response::Nak {
        seq: req.seq,
        credits: 0,
        code: ErrorCode::Version,
        detail: NakDetail::None,
    });
    assert!(matches!(
        ev,
        Some(HostEvent::ConnectFailed(Rejection { code: ErrorCode::Version, .. }))
    ));
}
