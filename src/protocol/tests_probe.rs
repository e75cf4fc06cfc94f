//! Probe moves on the link: `ArmProbe` and the `Status` probe fields round-trip, the session
//! checks (`CAP_PROBE`, state), and a probe move over [`SimTarget`] against a simulated
//! surface: the trip latches and stops there, the rest of the move is dropped, a miss of an
//! error kind and a wrong initial state are faults.

use super::tests::seg;
use super::tests_outputs::{open_with, req, status};
use super::*;
use crate::machine::{MachineState, ProbeKind, ProbePhase};

fn ack(link: &mut BoardLink, t: &mut SimTarget, seq: u32, body: RequestBody) {
    let r = link.handle(&req(seq, body.clone()), t);
    assert!(matches!(r, Response::Ack { .. }), "{body:?}: {r:?}");
}

/// Arms `kind`, queues X moves of `xs` steps and starts; then runs the queue dry.
fn probe_move(link: &mut BoardLink, t: &mut SimTarget, kind: ProbeKind, xs: &[i32]) -> Status {
    ack(link, t, 1, RequestBody::ArmProbe(kind));
    let batch = SegmentBatch::from_slice(
        &xs.iter().enumerate().map(|(i, &x)| seg(i as u32 + 1, x)).collect::<Vec<_>>(),
    )
    .unwrap();
    ack(link, t, 2, RequestBody::QueueSegments(batch));
    ack(link, t, 3, RequestBody::Start);
    while t.complete_one().is_some() {}
    status(link, t, 4)
}

#[test]
fn arm_probe_and_the_status_fields_round_trip() {
    for (i, kind) in ProbeKind::ALL.into_iter().enumerate() {
        let r = req(9, RequestBody::ArmProbe(kind));
        assert_eq!(r.body.kind(), 16);
        let mut buf = [0u8; 16];
        let bytes = postcard::to_slice(&r, &mut buf).unwrap();
        // seq 9, kind 16, the ProbeKind's index.
        assert_eq!(bytes, [9, 16, i as u8]);
        assert_eq!(decode_request(bytes), Ok(r));
    }
    let st = Status {
        probe_phase: ProbePhase::Tripped as u8,
        probe_steps: [-256, 7, i64::MIN, i64::MAX, 0, 1],
        probe_input: true,
        ..Status::default()
    };
    let mut buf = [0u8; MAX_MESSAGE];
    let bytes = postcard::to_slice(&Response::Status(st.clone()), &mut buf).unwrap();
    assert_eq!(decode_response(bytes), Some(Response::Status(st)));
}

#[test]
fn arm_probe_needs_the_capability_and_a_ready_machine() {
    let (mut link, mut t) = open_with(CAP_DDA);
    let r = link.handle(&req(1, RequestBody::ArmProbe(ProbeKind::Toward)), &mut t);
    assert!(matches!(r, Response::Nak { code: ErrorCode::Unsupported, .. }), "{r:?}");
    let (mut link, mut t) = open_with(CAP_DDA | CAP_PROBE);
    ack(
        &mut link,
        &mut t,
        1,
        RequestBody::QueueSegments(SegmentBatch::from_slice(&[seg(1, 100)]).unwrap()),
    );
    let before = t.clone();
    let r = link.handle(&req(2, RequestBody::ArmProbe(ProbeKind::Toward)), &mut t);
    assert!(
        matches!(
            r,
            Response::Nak {
                code: ErrorCode::OutOfState,
                detail: NakDetail::State(MachineState::Ready),
                ..
            }
        ),
        "{r:?}"
    );
    assert_eq!(t, before, "a refused arm changes nothing");
}

#[test]
fn a_probe_move_trips_on_the_surface_and_drops_the_rest() {
    let (mut link, mut t) = open_with(CAP_DDA | CAP_PROBE);
    t.sim_probe = Some(SimProbeSurface { axis: 0, at_steps: 1_234, below: false });
    let st = probe_move(&mut link, &mut t, ProbeKind::TowardError, &[1_000, 1_000, 1_000]);
    assert_eq!(ProbePhase::from_u8(st.probe_phase), ProbePhase::Tripped);
    assert_eq!(st.probe_steps[0], 1_234);
    assert_eq!(st.positions[0], 1_234, "the sim stops at the trip");
    assert!(st.probe_input);
    assert_eq!((st.machine, st.faults, st.queue_depth), (MachineState::Ready, 0, 0));
    assert_eq!(st.segments_done, 1, "the cut segment is not done, the third never ran");
    // The next job starts from there.
    ack(
        &mut link,
        &mut t,
        5,
        RequestBody::QueueSegments(SegmentBatch::from_slice(&[seg(9, -234)]).unwrap()),
    );
    ack(&mut link, &mut t, 6, RequestBody::Start);
    while t.complete_one().is_some() {}
    let st = status(&mut link, &mut t, 7);
    assert_eq!(st.positions[0], 1_000);
    assert_eq!(ProbePhase::from_u8(st.probe_phase), ProbePhase::Tripped, "kept");
}

#[test]
fn misses_and_wrong_initial_states_are_the_probe_faults() {
    // Never in contact: G38.2 faults, G38.3 does not.
    for (kind, fault) in
        [(ProbeKind::TowardError, FaultCode::ProbeFail.bit()), (ProbeKind::Toward, 0)]
    {
        let (mut link, mut t) = open_with(CAP_DDA | CAP_PROBE);
        let st = probe_move(&mut link, &mut t, kind, &[500]);
        assert_eq!(ProbePhase::from_u8(st.probe_phase), ProbePhase::Missed, "{kind:?}");
        assert_eq!((st.positions[0], st.faults), (500, fault), "{kind:?}");
    }
    // In contact everywhere: an away move trips at once, a toward move is refused.
    let (mut link, mut t) = open_with(CAP_DDA | CAP_PROBE);
    t.sim_probe = Some(SimProbeSurface { axis: 0, at_steps: 0, below: true });
    let st = probe_move(&mut link, &mut t, ProbeKind::TowardError, &[-500]);
    assert_eq!(ProbePhase::from_u8(st.probe_phase), ProbePhase::Refused);
    assert_eq!((st.positions[0], st.faults), (0, FaultCode::ProbeInitial.bit()));
    assert_eq!(st.machine, MachineState::Fault);
    // Away from the surface at 0: G38.4 leaves contact one step up.
    let (mut link, mut t) = open_with(CAP_DDA | CAP_PROBE);
    t.sim_probe = Some(SimProbeSurface { axis: 0, at_steps: 0, below: true });
    let st = probe_move(&mut link, &mut t, ProbeKind::AwayError, &[500]);
    assert_eq!(ProbePhase::from_u8(st.probe_phase), ProbePhase::Tripped);
    assert_eq!((st.probe_steps[0], st.faults), (1, 0));
}

#[cfg(feature = "sim-inputs")]
#[test]
fn the_sim_probe_hook_sets_the_surface() {
    let surface = SimProbeSurface { axis: 2, at_steps: -256, below: true };
    let body = RequestBody::Sim(SimRequest::Probe { surface: Some(surface) });
    let (mut link, mut t) = open_with(CAP_DDA | CAP_SIM_INPUTS);
    let r = link.handle(&req(1, body.clone()), &mut t);
    assert!(matches!(r, Response::Nak { code: ErrorCode::Unsupported, .. }), "needs CAP_PROBE");
    let (mut link, mut t) = open_with(CAP_DDA | CAP_SIM_INPUTS | CAP_PROBE);
    ack(&mut link, &mut t, 1, body);
    assert_eq!(t.sim_probe, Some(surface));
    assert!(!surface.active(&[0; 6]) && surface.active(&[0, 0, -256, 0, 0, 0]));
}
