//! Session tests of the force-job requests: `ArmForce`, `Sim(Milling)`, the Status
//! force fields.

use super::tests::config;
use super::*;
use crate::machine::MachineState;
use crate::milling::link_job::case_a_job;
#[cfg(feature = "sim-inputs")]
use crate::milling::link_job::case_a_sim;
use crate::milling::link_messages::MillingRequest;
use crate::milling::link_params::{ForceCal, ForceJobParams, ForcePhase, ForceStrategy};
use crate::segment::Rate;

pub(crate) fn extreme_force_params() -> ForceJobParams {
    ForceJobParams {
        fnom_mn: u32::MAX,
        contact_mn: u32::MAX,
        trip_mn: u32::MAX,
        kp_dec_q16: u32::MAX,
        kp_inc_q16: u32::MAX,
        ki_dec_per_s_q16: u32::MAX,
        ki_inc_per_s_q16: u32::MAX,
        normalise: true,
        fixed_scale_q16: u32::MAX,
        feed_min_bits: u32::MAX,
        feed_max_bits: u32::MAX,
        feed_air_bits: u32::MAX,
        strategy: ForceStrategy::StopReduced {
            stop_ms: u16::MAX,
            reduced_ms: u16::MAX,
            reduced_gain_q16: u32::MAX,
        },
        air_after_ms: u16::MAX,
        tare_ms: u16::MAX,
        flutes: u8::MAX,
        spindle_mrev_s: u32::MAX,
        min_spindle_mrev_s: u32::MAX,
        axis: u8::MAX,
        steps_per_s_at_one: u32::MAX,
        sample_hz: u32::MAX,
        channels: u8::MAX,
        cal: [ForceCal { zero_counts: u16::MAX, mn_per_count_q16: i32::MIN }; 3],
        adc_max_counts: u16::MAX,
        rail_margin_counts: u16::MAX,
        saturated_samples: u16::MAX,
        stuck_samples: u16::MAX,
        tare_shift: u8::MAX,
    }
}

#[cfg(feature = "sim-inputs")]
pub(crate) fn extreme_sim_params() -> SimMillingParams {
    SimMillingParams {
        kc_mn_per_mm2: u32::MAX,
        b_before_um: u32::MAX,
        b_after_um: u32::MAX,
        step_at_um: u32::MAX,
        wall_steps: i64::MIN,
        nm_per_step: u32::MAX,
        spindle_mrev_s: u32::MAX,
        periodic: true,
        fault: SimForceFault::Saturated { channel: u8::MAX },
        fault_at_um: u32::MAX,
    }
}

const CAPS: u32 = CAP_DDA | CAP_MILLING_JOB | CAP_SIM_INPUTS;

struct Link {
    b: BoardLink,
    t: SimTarget,
    seq: u32,
}

impl Link {
    fn new(caps: u32) -> Self {
        let mut t = SimTarget::new(config(), 4);
        let mut b = BoardLink::new("test", caps);
        let r = b.handle(&Request { seq: 0, body: hello() }, &mut t);
        assert!(matches!(r, Response::Ack { .. }));
        Link { b, t, seq: 1 }
    }

    fn send(&mut self, body: RequestBody) -> Response {
        let r = self.b.handle(&Request { seq: self.seq, body }, &mut self.t);
        self.seq += 1;
        r
    }
}

fn hello() -> RequestBody {
    RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 7 }
}

fn nak(r: &Response) -> Option<(ErrorCode, NakDetail)> {
    match r {
        Response::Nak { code, detail, .. } => Some((*code, detail.clone())),
        _ => None,
    }
}

fn named(field: &str) -> Option<(ErrorCode, NakDetail)> {
    Some((
        ErrorCode::OutOfRange,
        NakDetail::Config { field: FixedStr::truncated(field), axis: None },
    ))
}

#[test]
fn force_requests_round_trip_and_keep_their_kinds() {
    #[allow(unused_mut)]
    let mut bodies = vec![
        RequestBody::from(MillingRequest::ArmForce(case_a_job())),
        RequestBody::from(MillingRequest::ArmForce(extreme_force_params())),
    ];
    #[cfg(feature = "sim-inputs")]
    bodies.extend([
        RequestBody::Sim(SimRequest::Milling(case_a_sim(SimForceFault::SpindleStop))),
        RequestBody::Sim(SimRequest::Milling(extreme_sim_params())),
    ]);
    for body in bodies {
        let req = Request { seq: 9, body };
        let mut buf = [0u8; MAX_MESSAGE];
        let bytes = postcard::to_slice(&req, &mut buf).unwrap();
        assert_eq!(decode_request(bytes), Ok(req.clone()));
    }
    assert_eq!(
        RequestBody::from(MillingRequest::ArmForce(case_a_job())).kind(),
        // The envelope's capability kinds start at 64; milling is third (8 kinds each).
        64 + 2 * 8
    );
    assert_eq!(
        command_kind(&RequestBody::from(MillingRequest::ArmForce(case_a_job()))),
        command_kind(&RequestBody::Start)
    );
    for p in ForcePhase::ALL {
        assert_eq!(ForcePhase::from_u8(p as u8), p);
    }
    assert_eq!(ForcePhase::from_u8(200), ForcePhase::None);
}

#[test]
fn arm_force_refusals_name_the_field_and_change_nothing() {
    let mut l = Link::new(CAPS);
    let before = l.t.clone();
    type Bad = (fn(&mut ForceJobParams), &'static str);
    let bad: [Bad; 6] = [
        (|p| p.contact_mn = p.fnom_mn, "contact_mn"),
        (|p| p.kp_inc_q16 = u32::MAX, "kp_inc_q16"),
        (|p| p.sample_hz = 7, "sample_hz"),
        (|p| p.flutes = 65, "flutes"),
        (|p| p.cal[0].mn_per_count_q16 = 0, "cal.mn_per_count_q16"),
        (|p| p.feed_air_bits = MAX_OVERRIDE_BITS + 1, "feed_air_bits"),
    ];
    for (f, field) in bad {
        let mut p = case_a_job();
        f(&mut p);
        let r = l.send(RequestBody::from(MillingRequest::ArmForce(p)));
        assert_eq!(nak(&r), named(field), "{p:?}");
    }
    let r = l.send(RequestBody::from(MillingRequest::ArmForce(extreme_force_params())));
    assert!(matches!(nak(&r), Some((ErrorCode::OutOfRange, NakDetail::Config { .. }))));
    assert_eq!(l.t, before, "refusals change nothing");
    // Without the capability: Unsupported, nothing changes.
    let mut plain = Link::new(CAP_DDA | CAP_SIM_INPUTS);
    let before = plain.t.clone();
    let r = plain.send(RequestBody::from(MillingRequest::ArmForce(case_a_job())));
    assert_eq!(nak(&r).map(|n| n.0), Some(ErrorCode::Unsupported));
    assert_eq!(plain.t, before);
}

#[cfg(feature = "sim-inputs")]
#[test]
fn sim_milling_needs_both_capabilities_and_names_bad_fields() {
    let milling = |p| RequestBody::Sim(SimRequest::Milling(p));
    let mut l = Link::new(CAPS);
    let before = l.t.clone();
    let mut s = case_a_sim(SimForceFault::None);
    s.spindle_mrev_s = 0;
    assert_eq!(nak(&l.send(milling(s))), named("spindle_mrev_s"));
    let r = l.send(milling(extreme_sim_params()));
    assert_eq!(nak(&r).map(|n| n.0), Some(ErrorCode::OutOfRange));
    assert_eq!(l.t, before, "refusals change nothing");
    assert_eq!(command_kind(&milling(extreme_sim_params())), None);
    for caps in [CAP_DDA | CAP_SIM_INPUTS, CAP_DDA | CAP_MILLING_JOB] {
        let mut plain = Link::new(caps);
        let before = plain.t.clone();
        let r = plain.send(milling(case_a_sim(SimForceFault::None)));
        assert_eq!(nak(&r).map(|n| n.0), Some(ErrorCode::Unsupported));
        assert_eq!(plain.t, before);
    }
    let sim = case_a_sim(SimForceFault::Stuck { channel: 2 });
    assert!(matches!(l.send(milling(sim)), Response::Ack { .. }));
    assert_eq!(l.t.sim_milling, Some(sim));
}

#[test]
fn arm_force_arms_once_in_ready_and_the_table_refuses_it_in_fault() {
    let mut l = Link::new(CAPS);
    assert!(matches!(
        l.send(RequestBody::from(MillingRequest::ArmForce(case_a_job()))),
        Response::Ack { .. }
    ));
    assert_eq!(l.t.force_armed, Some(case_a_job()));
    // Armed twice: refused with the state, the first arming stays.
    let armed = l.t.clone();
    let again = ForceJobParams { fnom_mn: 5_000_000, ..case_a_job() };
    let r = l.send(RequestBody::from(MillingRequest::ArmForce(again)));
    assert_eq!(nak(&r), Some((ErrorCode::OutOfState, NakDetail::State(MachineState::Ready))));
    assert_eq!(l.t, armed);
    // In Fault the command table refuses it before the target sees it.
    let mut f = Link::new(CAPS);
    f.t.raise_fault(FaultCode::ForceStuck);
    let faulted = f.t.clone();
    let r = f.send(RequestBody::from(MillingRequest::ArmForce(case_a_job())));
    assert_eq!(nak(&r), Some((ErrorCode::OutOfState, NakDetail::State(MachineState::Fault))));
    assert_eq!(f.t, faulted);
}

#[test]
fn status_force_fields_round_trip() {
    let st = Status {
        force_mn: 4_100_000,
        force_peak_mn: 4_300_000,
        force_override_bits: Rate::lit("0.26").to_bits(),
        force_phase: ForcePhase::Cutting as u8,
        force_updates: 12_345,
        ..Status::default()
    };
    let resp = Response::Status(st.clone());
    let mut buf = [0u8; MAX_MESSAGE];
    let bytes = postcard::to_slice(&resp, &mut buf).unwrap();
    assert_eq!(decode_response(bytes), Some(resp));
}
