//! Session tests of `SetProgramOutputs` over [`SimTarget`]: accepted in program order, shown in
//! `Status::outputs`, refused while an e-stop is latched, and switched off by the e-stop.

use super::tests::config;
use super::*;
use crate::machine::{MachineState, Outputs};

pub(super) fn req(seq: u32, body: RequestBody) -> Request {
    Request { seq, body }
}

/// A session with a fresh [`SimTarget`] announcing `caps`.
pub(super) fn open_with(caps: u32) -> (BoardLink, SimTarget) {
    let mut link = BoardLink::new("outputs-test", caps);
    let mut t = SimTarget::new(config(), 8);
    let r =
        link.handle(&req(0, RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 3 }), &mut t);
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    (link, t)
}

fn open() -> (BoardLink, SimTarget) {
    open_with(CAP_DDA)
}

pub(super) fn status(link: &mut BoardLink, t: &mut SimTarget, seq: u32) -> Status {
    match link.handle(&req(seq, RequestBody::GetStatus), t) {
        Response::Ack { reply: Reply::Status(s), .. } => s,
        other => panic!("{other:?}"),
    }
}

const fn o(spindle: SpindleDir, mist: bool, flood: bool) -> ProgramOutputs {
    ProgramOutputs { spindle, mist, flood }
}

#[test]
fn program_outputs_switch_in_order_and_show_in_status() {
    let (mut link, mut t) = open();
    assert_eq!(status(&mut link, &mut t, 1).outputs, 0, "off after boot");
    // Wire power belongs to the wire job: a program switch keeps it.
    t.outputs.wire_power = true;
    let steps = [
        (o(SpindleDir::Cw, false, false), OUT_SPINDLE),
        (o(SpindleDir::Cw, false, true), OUT_SPINDLE | OUT_FLOOD),
        (o(SpindleDir::Cw, true, true), OUT_SPINDLE | OUT_FLOOD | OUT_MIST),
        (o(SpindleDir::Ccw, false, false), OUT_SPINDLE | OUT_SPINDLE_CCW),
        (ProgramOutputs::OFF, 0),
    ];
    let mut seq = 2;
    for (want, bits) in steps {
        let r = link.handle(&req(seq, RequestBody::SetProgramOutputs(want)), &mut t);
        assert!(matches!(r, Response::Ack { reply: Reply::None, .. }), "{want:?}: {r:?}");
        let st = status(&mut link, &mut t, seq + 1);
        assert_eq!(st.outputs, bits, "{want:?}");
        assert_eq!(ProgramOutputs::from_bits(st.outputs), want);
        assert!(t.outputs.wire_power);
        seq += 2;
    }
    // A retransmission is not executed again: the switch after it stands.
    let r = link
        .handle(&req(seq, RequestBody::SetProgramOutputs(o(SpindleDir::Cw, true, false))), &mut t);
    assert!(matches!(r, Response::Ack { .. }));
    let _ = link.handle(&req(seq + 1, RequestBody::SetProgramOutputs(ProgramOutputs::OFF)), &mut t);
    let again = link
        .handle(&req(seq, RequestBody::SetProgramOutputs(o(SpindleDir::Cw, true, false))), &mut t);
    assert!(matches!(again, Response::Ack { .. }), "{again:?}");
    assert_eq!(status(&mut link, &mut t, seq + 2).outputs, 0);
}

#[test]
fn an_estop_switches_everything_off_and_refuses_switching_on() {
    let (mut link, mut t) = open();
    let all = o(SpindleDir::Ccw, true, true);
    let r = link.handle(&req(1, RequestBody::SetProgramOutputs(all)), &mut t);
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    t.outputs.wire_power = true;
    t.raise_fault(FaultCode::EStop);
    assert_eq!(t.outputs, Outputs::SAFE, "the e-stop kills spindle, coolant and wire power");
    assert_eq!(status(&mut link, &mut t, 2).outputs, 0);
    let before = t.clone();
    let r = link.handle(&req(3, RequestBody::SetProgramOutputs(all)), &mut t);
    match r {
        Response::Nak { code: ErrorCode::OutOfState, detail: NakDetail::State(s), .. } => {
            assert_eq!(s, MachineState::Fault)
        }
        other => panic!("not refused while the e-stop is latched: {other:?}"),
    }
    assert_eq!(t, before, "a refusal changes nothing");
    assert_eq!(status(&mut link, &mut t, 4).outputs, 0);
    // A fault that only stops motion leaves the program's outputs alone.
    let (mut link, mut t) = open();
    let _ = link.handle(&req(1, RequestBody::SetProgramOutputs(all)), &mut t);
    t.raise_fault(FaultCode::SoftLimit);
    assert_eq!(status(&mut link, &mut t, 2).outputs, all.bits());
}

#[test]
fn a_target_without_program_outputs_refuses_them_as_unsupported() {
    struct Plain(SimTarget);
    // No capability's hooks: every one answers `Unsupported`.
    impl crate::polar::link_messages::PolarTarget for Plain {}
    impl crate::turning::link_messages::TurningTarget for Plain {}
    impl crate::milling::link_messages::MillingTarget for Plain {}
    impl crate::wire::link_messages::WireTarget for Plain {}
    impl LinkTarget for Plain {
        fn state(&self) -> LinkState {
            self.0.state()
        }
        fn machine_state(&self) -> MachineState {
            self.0.machine_state()
        }
        fn credits(&self) -> u16 {
            self.0.credits()
        }
        fn queue_capacity(&self) -> u16 {
            self.0.queue_capacity()
        }
        fn config(&self) -> LinkConfig {
            self.0.config()
        }
        fn planned_position(&self) -> [i64; crate::config::MAX_AXES] {
            self.0.planned_position()
        }
        fn status(&self) -> Status {
            self.0.status()
        }
        fn set_config(&mut self, cfg: &LinkConfig) -> Result<(), ErrorCode> {
            self.0.set_config(cfg)
        }
        fn queue_segment(&mut self, seg: &crate::segment::Segment) -> Result<(), ErrorCode> {
            self.0.queue_segment(seg)
        }
        fn start(&mut self) -> Result<(), ErrorCode> {
            self.0.start()
        }
        fn hold(&mut self) -> Result<(), ErrorCode> {
            self.0.hold()
        }
        fn resume(&mut self) -> Result<(), ErrorCode> {
            self.0.resume()
        }
        fn abort(&mut self) -> Result<(), ErrorCode> {
            self.0.abort()
        }
        fn set_override(&mut self, rate: crate::segment::Rate) -> Result<(), ErrorCode> {
            self.0.set_override(rate)
        }
        fn clear_fault(&mut self) -> Result<(), ErrorCode> {
            self.0.clear_fault()
        }
        fn home(&mut self) -> Result<(), ErrorCode> {
            self.0.home()
        }
        fn set_homing(&mut self, h: &HomingConfig) -> Result<(), ErrorCode> {
            self.0.set_homing(h)
        }
        fn jog_off_limit(&mut self) -> Result<(), ErrorCode> {
            self.0.jog_off_limit()
        }
    }
    let mut link = BoardLink::new("plain", CAP_DDA);
    let mut t = Plain(SimTarget::new(config(), 8));
    let _ =
        link.handle(&req(0, RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 1 }), &mut t);
    let r = link.handle(&req(1, RequestBody::SetProgramOutputs(ProgramOutputs::OFF)), &mut t);
    assert!(
        matches!(r, Response::Nak { code: ErrorCode::Unsupported, .. }),
        "the default is Unsupported: {r:?}"
    );
}
