//! Arming the wire job: its parameters and the state are checked, refusals change nothing, and
//! the sim's stall injection needs the capability.

use super::*;
use crate::wire::link_messages::WireJobParams;
use crate::wire::link_messages::WireRequest;

fn wire_params() -> WireJobParams {
    WireJobParams {
        debounce_ticks: 20,
        retrace_limit_steps: 40_000,
        retrace_override_bits: Rate::ONE.to_bits(),
        resume_override_bits: Rate::lit("0.5").to_bits(),
        resume_segments: 2,
        segments: 12,
    }
}

#[test]
fn arm_wire_checks_its_parameters_and_the_state_and_refusals_change_nothing() {
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA | CAP_WIRE_JOB);
    b.handle(&hello(0, 1), &mut t);
    let mut s = 1;
    let mut send = |b: &mut BoardLink, t: &mut SimTarget, body: RequestBody| {
        let r = b.handle(&req(s, body), t);
        s += 1;
        r
    };
    let before = t.clone();
    let bad: [fn(&mut WireJobParams); 6] = [
        |p| p.debounce_ticks = 0,
        |p| p.retrace_limit_steps = 0,
        |p| p.segments = 0,
        |p| p.retrace_override_bits = 0,
        |p| p.resume_override_bits = MAX_OVERRIDE_BITS + 1,
        |p| p.retrace_override_bits = u32::MAX,
    ];
    for f in bad {
        let mut p = wire_params();
        f(&mut p);
        let r = send(&mut b, &mut t, RequestBody::from(WireRequest::ArmWire(p)));
        assert_eq!(code(&r), Some(ErrorCode::OutOfRange), "{p:?}");
    }
    // No simulated inputs on this board.
    #[cfg(feature = "sim-inputs")]
    {
        let r = send(&mut b, &mut t, RequestBody::Sim(SimRequest::Inject { wire_stall: true }));
        assert_eq!(code(&r), Some(ErrorCode::Unsupported));
    }
    assert_eq!(t, before, "refusals change nothing");
    // With segments queued (a plain job in the making): out of state, nothing changes.
    let r = send(
        &mut b,
        &mut t,
        RequestBody::QueueSegments(SegmentBatch::from_slice(&[seg(1, 10)]).unwrap()),
    );
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    let queued = t.clone();
    let r = send(&mut b, &mut t, RequestBody::from(WireRequest::ArmWire(wire_params())));
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    assert_eq!(t, queued);
    // In Fault the table refuses it before the target sees it.
    let _ = send(&mut b, &mut t, RequestBody::Abort);
    t.raise_fault(FaultCode::LimitSwitch);
    let faulted = t.clone();
    let r = send(&mut b, &mut t, RequestBody::from(WireRequest::ArmWire(wire_params())));
    assert!(
        matches!(
            r,
            Response::Nak {
                code: ErrorCode::OutOfState,
                detail: NakDetail::State(crate::machine::MachineState::Fault),
                ..
            }
        ),
        "{r:?}"
    );
    assert_eq!(t, faulted);
}

#[test]
fn arm_wire_in_ready_arms_and_sim_inject_needs_the_capability() {
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA | CAP_WIRE_JOB | CAP_SIM_INPUTS);
    b.handle(&hello(0, 1), &mut t);
    let r = b.handle(&req(1, RequestBody::from(WireRequest::ArmWire(wire_params()))), &mut t);
    assert!(matches!(r, Response::Ack { seq: 1, .. }), "{r:?}");
    assert_eq!(t.wire_armed, Some(wire_params()));
    // Armed twice: refused, the first arming stays.
    let r = b.handle(
        &req(
            2,
            RequestBody::from(WireRequest::ArmWire(WireJobParams { segments: 3, ..wire_params() })),
        ),
        &mut t,
    );
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    assert_eq!(t.wire_armed, Some(wire_params()));
    #[cfg(feature = "sim-inputs")]
    {
        let inject = RequestBody::Sim(SimRequest::Inject { wire_stall: true });
        let r = b.handle(&req(3, inject), &mut t);
        assert!(matches!(r, Response::Ack { seq: 3, .. }), "{r:?}");
        assert!(t.sim_wire_stall);
    }
    assert!(crate::wire::link_messages::wire_params_ok(&wire_params()));
}
