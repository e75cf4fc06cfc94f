//! The `Sim` variant on the link, with and without the `sim-inputs` feature: it is the last
//! request variant (compiled out, it shifts no other index), and a board without the hooks
//! answers it as a board without `CAP_SIM_INPUTS` does.

use crate::protocol::tests::config;
use crate::protocol::*;

/// `RequestBody` bytes with variant index `kind` and no payload.
fn body_error(kind: u8) -> Option<postcard::Error> {
    postcard::from_bytes::<RequestBody>(&[kind]).err()
}

#[test]
fn sim_is_the_last_request_variant() {
    // One past `KIND_SIM` names no variant (a known one would decode or run out of bytes).
    assert_eq!(body_error(KIND_SIM + 1), Some(postcard::Error::SerdeDeCustom));
    // The variant before it is a production request in both builds.
    assert_ne!(body_error(KIND_SIM - 1), Some(postcard::Error::SerdeDeCustom));
    #[cfg(feature = "sim-inputs")]
    {
        let sim = RequestBody::Sim(SimRequest::Inject { wire_stall: true });
        assert_eq!(sim.kind(), KIND_SIM);
        assert_eq!(postcard::to_slice(&sim, &mut [0; 8]).unwrap(), [KIND_SIM, 0, 1]);
    }
    #[cfg(not(feature = "sim-inputs"))]
    assert_eq!(body_error(KIND_SIM), Some(postcard::Error::SerdeDeCustom));
}

#[test]
fn a_board_without_the_hooks_answers_unsupported() {
    // Seq 1, `Sim(Inject { wire_stall: true })`: decoded and refused for the missing
    // capability with the feature, recognised undecoded without it; the same answer.
    let inject = [1, KIND_SIM, 0, 1];
    let mut t = SimTarget::new(config(), 4);
    let before = t.clone();
    let mut b = BoardLink::new("test", CAP_DDA);
    let hello = RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 1 };
    assert!(matches!(b.handle(&Request { seq: 0, body: hello }, &mut t), Response::Ack { .. }));
    let unsupported = |r: &Response| {
        matches!(
            r,
            Response::Nak { seq: 1, code: ErrorCode::Unsupported, detail: NakDetail::None, .. }
        )
    };
    let r = b.handle_message(&inject, &mut t);
    assert!(unsupported(&r), "{r:?}");
    // A retransmission gets the same answer; the seq was consumed, nothing changed.
    let r = b.handle_message(&inject, &mut t);
    assert!(unsupported(&r), "{r:?}");
    assert_eq!(b.next_seq(), Some(2));
    assert_eq!(t, before);
    assert_eq!(b.status(&t).counters.frames_bad, 0);
    // An index past every variant stays a malformed frame.
    let r = b.handle_message(&[2, KIND_SIM + 1, 0, 1], &mut t);
    assert!(matches!(r, Response::Nak { seq: 2, code: ErrorCode::Malformed, .. }), "{r:?}");
    assert_eq!(b.status(&t).counters.frames_bad, 1);
}

#[cfg(feature = "sim-inputs")]
#[test]
fn corrupt_config_is_the_last_hook_and_a_board_without_a_config_store_refuses_it() {
    // Hook index 5, after `Probe`: the earlier hooks keep their indices.
    let corrupt = RequestBody::Sim(SimRequest::CorruptConfig);
    assert_eq!(postcard::to_slice(&corrupt, &mut [0; 8]).unwrap(), [KIND_SIM, 5]);
    let probe = RequestBody::Sim(SimRequest::Probe { surface: None });
    assert_eq!(postcard::to_slice(&probe, &mut [0; 8]).unwrap(), [KIND_SIM, 4, 0]);
    // The simulated targets keep no config records: refused, nothing changed.
    let mut t = SimTarget::new(config(), 4);
    let before = t.clone();
    assert_eq!(t.sim(&SimRequest::CorruptConfig), Err(ErrorCode::Unsupported));
    assert_eq!(t, before);
}
