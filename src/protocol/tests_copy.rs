//! Session tests of the copy-mode requests over [`CopySim`].

use super::tests::config;
use super::*;
use crate::machine::MachineState;
use crate::polar::link_messages::PolarRequest;
#[cfg(feature = "sim-inputs")]
use crate::polar::stream::net_steps;

fn req(seq: u32, body: RequestBody) -> Request {
    Request { seq, body }
}

/// A session open at seq 0 over a ready copy sim, with `caps`.
fn open(caps: u32) -> (BoardLink, CopySim) {
    let mut link = BoardLink::new("copy-test", caps);
    let mut t = CopySim::new(SimTarget::new(config(), 8));
    let r =
        link.handle(&req(0, RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 7 }), &mut t);
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    (link, t)
}

fn nak_code(r: &Response) -> Option<ErrorCode> {
    match r {
        Response::Nak { code, .. } => Some(*code),
        _ => None,
    }
}

#[cfg(feature = "sim-inputs")]
fn teach(r: &Response) -> TeachChunk {
    match r {
        Response::Ack { reply: Reply::Teach(c), .. } => c.clone(),
        other => panic!("not a Teach answer: {other:?}"),
    }
}

#[test]
fn copy_requests_round_trip() {
    #[allow(unused_mut)]
    let mut bodies = vec![
        RequestBody::from(PolarRequest::StartCopy { m: 3, k: 2, teach: true }),
        RequestBody::from(PolarRequest::ReadTeach { block: 513 }),
    ];
    #[cfg(feature = "sim-inputs")]
    bodies
        .push(RequestBody::Sim(SimRequest::Encoders { arm_counts: -70_000, carriage_counts: 12 }));
    for body in bodies {
        let r = req(9, body);
        let mut buf = [0u8; MAX_MESSAGE];
        let bytes = postcard::to_slice(&r, &mut buf).unwrap();
        assert_eq!(decode_request(bytes), Ok(r));
    }
}

#[test]
fn start_copy_checks_scale_state_and_capability() {
    let caps = CAP_COPY_JOB | CAP_SIM_INPUTS;
    let (mut link, mut t) = open(caps);
    let r = link.handle(
        &req(1, RequestBody::from(PolarRequest::StartCopy { m: 5, k: 1, teach: false })),
        &mut t,
    );
    assert_eq!(nak_code(&r), Some(ErrorCode::OutOfRange));
    let r = link.handle(
        &req(2, RequestBody::from(PolarRequest::StartCopy { m: 1, k: 0, teach: false })),
        &mut t,
    );
    assert_eq!(nak_code(&r), Some(ErrorCode::OutOfRange));
    assert!(!t.copy_running);
    let r = link.handle(
        &req(3, RequestBody::from(PolarRequest::StartCopy { m: 2, k: 1, teach: false })),
        &mut t,
    );
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    assert!(t.copy_running);
    assert_eq!(t.inner.machine, MachineState::Running);
    // Running: a second start and a segment job are refused, the copy goes on.
    let r = link.handle(
        &req(4, RequestBody::from(PolarRequest::StartCopy { m: 2, k: 1, teach: false })),
        &mut t,
    );
    assert_eq!(nak_code(&r), Some(ErrorCode::OutOfState));
    let r = link.handle(&req(5, RequestBody::Start), &mut t);
    assert_eq!(nak_code(&r), Some(ErrorCode::OutOfState));
    // Hold and Abort act on it with the machine's table.
    let r = link.handle(&req(6, RequestBody::Hold), &mut t);
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    assert_eq!(t.inner.machine, MachineState::Holding);
    let r = link.handle(&req(7, RequestBody::Abort), &mut t);
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    assert!(!t.copy_running);
    // Without the capability bit the sim encoders are refused (and StartCopy on a target
    // without copy jobs is Unsupported).
    #[cfg(feature = "sim-inputs")]
    {
        let (mut link, mut t) = open(CAP_COPY_JOB);
        let encoders = SimRequest::Encoders { arm_counts: 1, carriage_counts: 1 };
        let r = link.handle(&req(1, RequestBody::Sim(encoders)), &mut t);
        assert_eq!(nak_code(&r), Some(ErrorCode::Unsupported));
    }
    let mut plain = SimTarget::new(config(), 8);
    let mut link = BoardLink::new("plain", 0);
    link.handle(&req(0, RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 1 }), &mut plain);
    let r = link.handle(
        &req(1, RequestBody::from(PolarRequest::StartCopy { m: 1, k: 1, teach: true })),
        &mut plain,
    );
    assert_eq!(nak_code(&r), Some(ErrorCode::Unsupported));
}

/// A taught copy read block by block over the session, with a lost answer retransmitted: the
/// blocks decode to the encoder moves the host asked for, and the machine's r is scaled 3:2.
#[cfg(feature = "sim-inputs")]
#[test]
fn teach_is_read_back_whole_through_retransmissions() {
    let (mut link, mut t) = open(CAP_COPY_JOB | CAP_SIM_INPUTS);
    let mut seq = 1;
    let mut send = |link: &mut BoardLink, t: &mut CopySim, body| {
        let r = link.handle(&req(seq, body), t);
        seq += 1;
        (r, seq - 1)
    };
    let (r, _) = send(
        &mut link,
        &mut t,
        RequestBody::from(PolarRequest::StartCopy { m: 3, k: 2, teach: true }),
    );
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    // A template path: out and back on both axes, read while it runs.
    let targets = [[400, 100], [250, -300], [600, 40], [600, 40]];
    let mut bytes = Vec::new();
    let mut next = 0u16;
    let mut retransmitted = false;
    for tgt in targets {
        let (r, _) = send(
            &mut link,
            &mut t,
            RequestBody::Sim(SimRequest::Encoders { arm_counts: tgt[0], carriage_counts: tgt[1] }),
        );
        assert!(matches!(r, Response::Ack { .. }), "{r:?}");
        for _ in 0..20 {
            t.run_copy(200);
            let (r, s) =
                send(&mut link, &mut t, RequestBody::from(PolarRequest::ReadTeach { block: next }));
            let c = teach(&r);
            if !c.bytes.is_empty() {
                if !retransmitted {
                    // The answer was lost: the same seq again gets the same block.
                    retransmitted = true;
                    let again = teach(&link.handle(
                        &req(s, RequestBody::from(PolarRequest::ReadTeach { block: next })),
                        &mut t,
                    ));
                    assert_eq!(again.bytes, c.bytes);
                }
                bytes.extend_from_slice(&c.bytes);
                next += 1;
            }
        }
    }
    assert!(retransmitted, "the trace never filled a block");
    let st = link.status(&t);
    assert!(st.copy_running);
    assert_eq!(st.encoder_counts, [600, 40]);
    assert_eq!(&st.positions[..2], &[600, 60]);
    let (r, _) = send(&mut link, &mut t, RequestBody::Abort);
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    let end = loop {
        t.run_copy(1);
        let (r, _) =
            send(&mut link, &mut t, RequestBody::from(PolarRequest::ReadTeach { block: next }));
        let c = teach(&r);
        bytes.extend_from_slice(&c.bytes);
        if !c.bytes.is_empty() {
            next += 1;
        }
        if c.ended {
            break c;
        }
    };
    assert_eq!(end.lost_events, 0);
    let (sum, n) = net_steps(&bytes);
    assert_eq!(sum, [600, 40]);
    assert_eq!(n, end.taught_events);
    // Every count of the path is an event: |400| + |150| + |350| on theta, 100 + 400 + 340 on r.
    assert_eq!(n, 400 + 150 + 350 + 100 + 400 + 340);
}
