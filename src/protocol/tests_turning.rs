//! Session tests of the Z-slide requests: chunked table upload (order, length, CRC),
//! uploads refused while a Z job runs, `StartZ` without a table, `Sim(Spindle)` gating, the Z
//! fields of `Status`, and that every refusal changes nothing. The target wraps [`SimTarget`]
//! with the link firmware's own Z code (`ZRequests`, `ZJob`).

use super::tests::config;
use super::*;
use crate::config::MAX_AXES;
use crate::machine::MachineState;
use crate::segment::{Rate, Segment};
use crate::turning::douglass_table::DOUGLASS_POWER;
use crate::turning::link_job::{
    table_link_bytes, LinkTable, ZJob, ZJobSpec, ZOutputSpec, ZTableHeader, MAX_TABLE_BYTES,
};
use crate::turning::link_messages::TurningRequest;
use crate::turning::link_requests::{self as zr, ZNak, ZRequests};
use crate::turning::scenario as sc;

/// SimTarget plus the firmware's Z code; `z_active` plays the machine's `runs(TURNING_JOB)`.
struct ZTarget {
    sim: SimTarget,
    req: ZRequests,
    job: ZJob,
    z_active: bool,
    // The last `Sim(Spindle)` speed (the hook exists with the `sim-inputs` feature only).
    #[cfg(feature = "sim-inputs")]
    sim_rpm_milli: Option<u32>,
}

impl ZTarget {
    fn new() -> Self {
        let mut job = ZJob::new();
        // The spindle turns at 360 rpm at the test config's tick rate.
        job.sense(
            0,
            crate::spindle::speed_turn_q32_per_tick(360_000, config().machine.tick_hz),
            None,
        );
        ZTarget {
            sim: SimTarget::new(config(), 8),
            req: ZRequests::new(),
            job,
            z_active: false,
            #[cfg(feature = "sim-inputs")]
            sim_rpm_milli: None,
        }
    }
}

impl LinkTarget for ZTarget {
    fn state(&self) -> LinkState {
        self.sim.state()
    }
    fn machine_state(&self) -> MachineState {
        self.sim.machine_state()
    }
    fn credits(&self) -> u16 {
        self.sim.credits()
    }
    fn queue_capacity(&self) -> u16 {
        self.sim.queue_capacity()
    }
    fn config(&self) -> LinkConfig {
        self.sim.config()
    }
    fn planned_position(&self) -> [i64; MAX_AXES] {
        self.sim.planned_position()
    }
    fn status(&self) -> Status {
        let mut s = self.sim.status();
        zr::status(&self.job, self.sim.config.machine.tick_hz, &mut s);
        s
    }
    fn set_config(&mut self, cfg: &LinkConfig) -> Result<(), ErrorCode> {
        self.sim.set_config(cfg)
    }
    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode> {
        self.sim.queue_segment(seg)
    }
    fn start(&mut self) -> Result<(), ErrorCode> {
        self.sim.start()
    }
    fn hold(&mut self) -> Result<(), ErrorCode> {
        self.sim.hold()
    }
    fn resume(&mut self) -> Result<(), ErrorCode> {
        self.sim.resume()
    }
    fn abort(&mut self) -> Result<(), ErrorCode> {
        self.sim.abort()?;
        self.z_active = false;
        self.job.drop_run();
        Ok(())
    }
    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode> {
        self.sim.set_override(rate)
    }
    fn clear_fault(&mut self) -> Result<(), ErrorCode> {
        self.sim.clear_fault()
    }
    fn home(&mut self) -> Result<(), ErrorCode> {
        self.sim.home()
    }
    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode> {
        self.sim.set_homing(homing)
    }
    fn jog_off_limit(&mut self) -> Result<(), ErrorCode> {
        self.sim.jog_off_limit()
    }
    #[cfg(feature = "sim-inputs")]
    fn sim(&mut self, req: &SimRequest) -> Result<(), ErrorCode> {
        match *req {
            SimRequest::Spindle { rpm_milli, .. } => self.sim_rpm_milli = Some(rpm_milli),
            _ => return Err(ErrorCode::Unsupported),
        }
        Ok(())
    }
}

impl crate::polar::link_messages::PolarTarget for ZTarget {}

impl crate::turning::link_messages::TurningTarget for ZTarget {
    fn z_table_begin(&mut self, h: &ZTableHeader) -> Result<(), ZNak> {
        self.req.begin(h, self.z_active)
    }
    fn z_table_chunk(&mut self, index: u16, bytes: &[u8]) -> Result<(), ZNak> {
        self.req.chunk(index, bytes, self.z_active)
    }
    fn z_table_end(&mut self, crc: u32) -> Result<(), ZNak> {
        let t = self.req.end(crc, self.z_active)?;
        zr::install(&mut self.job, t.clone(), self.z_active)?;
        self.req.installed(t);
        Ok(())
    }
    fn start_z(&mut self, spec: &ZJobSpec) -> Result<(), ZNak> {
        // The machine's Start column passed in the session; the firmware's machine refuses a
        // start with segments queued, as here.
        if self.sim.queue_len() != 0 {
            return Err((ErrorCode::OutOfState, NakDetail::None));
        }
        // As the firmware: prepared on the link's table copy, begun in the job.
        let speed = self.job.sensed_speed_turn_q32_per_tick();
        let p = self.req.prepare(spec, self.sim.config.machine.tick_hz, speed, self.z_active)?;
        zr::begin(&mut self.job, p, self.z_active)?;
        self.z_active = true;
        self.sim.machine = MachineState::Running;
        Ok(())
    }
}

impl crate::milling::link_messages::MillingTarget for ZTarget {}

impl crate::wire::link_messages::WireTarget for ZTarget {}

fn douglass() -> (ZTableHeader, std::vec::Vec<u8>) {
    let mut buf = std::vec![0u8; MAX_TABLE_BYTES];
    let (h, n) = table_link_bytes(&DOUGLASS_POWER, &mut buf).unwrap();
    buf.truncate(n);
    (h, buf)
}

fn spec() -> ZJobSpec {
    let c = sc::command_config();
    ZJobSpec {
        output: ZOutputSpec::Steps { axis: 0, steps_per_in: 100_000 },
        x_axis: 1,
        x_steps_per_in: 1000,
        x_negative: false,
        x_start_in_q24: 0,
        x_end_in_q24: 1 << 24,
        x_feed_in_q24_per_tick: 1 << 8,
        cubic: true,
        advance_ticks_q16: c.advance_ticks_q16,
        engage_ticks: c.engage_ticks,
        blend_start_x_in_q24: 1 << 23,
        blend_end_x_in_q24: 1 << 24,
        max_velocity_uin_per_s: c.max_velocity_uin_per_s,
        max_accel_uin_per_s2: c.max_accel_uin_per_s2,
        min_speed_turn_q32_per_tick: c.min_speed_turn_q32_per_tick,
    }
}

struct Rig {
    b: BoardLink,
    t: ZTarget,
    seq: u32,
}

impl Rig {
    fn new(caps: u32) -> Self {
        let mut b = BoardLink::new("test", caps | CAP_TURNING_JOB);
        let mut t = ZTarget::new();
        let r = b.handle(
            &Request { seq: 0, body: RequestBody::Hello { version: PROTOCOL_VERSION, nonce: 1 } },
            &mut t,
        );
        assert!(matches!(r, Response::Ack { .. }));
        Rig { b, t, seq: 1 }
    }

    fn send(&mut self, body: RequestBody) -> Result<(), (ErrorCode, NakDetail)> {
        // Every request survives the link.
        let req = Request { seq: self.seq, body };
        let mut buf = [0u8; MAX_FRAME_LINK];
        let frame = encode_frame(&req, &mut buf).expect("fits a frame");
        assert!(frame.len() <= MAX_FRAME_LINK);
        self.seq += 1;
        match self.b.handle(&req, &mut self.t) {
            Response::Ack { .. } => Ok(()),
            Response::Nak { code, detail, .. } => Err((code, detail)),
            other => panic!("{other:?}"),
        }
    }

    /// Begin, chunks of `chunk` bytes, end with `crc`; the first refusal.
    fn upload(
        &mut self,
        h: ZTableHeader,
        b: &[u8],
        chunk: usize,
        crc: u32,
    ) -> Result<(), (ErrorCode, NakDetail)> {
        self.send(RequestBody::from(TurningRequest::ZTableBegin(h)))?;
        for (i, c) in b.chunks(chunk).enumerate() {
            let bytes = BlockBytes::from_slice(c).unwrap();
            self.send(RequestBody::from(TurningRequest::ZTableChunk { index: i as u16, bytes }))?;
        }
        self.send(RequestBody::from(TurningRequest::ZTableEnd { crc }))
    }
}

fn is_douglass(t: &LinkTable) -> bool {
    let LinkTable::Power(p) = t else { return false };
    p.len() == DOUGLASS_POWER.len() && (0..p.len()).all(|r| p.row(r) == DOUGLASS_POWER.row(r))
}

#[test]
fn new_requests_round_trip_and_fit_a_frame() {
    let (h, b) = douglass();
    let bodies = [
        RequestBody::from(TurningRequest::ZTableBegin(h)),
        RequestBody::from(TurningRequest::ZTableChunk {
            index: u16::MAX,
            bytes: BlockBytes::from_slice(&b[..MAX_Z_CHUNK]).unwrap(),
        }),
        RequestBody::from(TurningRequest::ZTableEnd { crc: u32::MAX }),
        RequestBody::from(TurningRequest::StartZ(ZJobSpec {
            x_start_in_q24: i32::MIN,
            x_end_in_q24: i32::MIN,
            x_feed_in_q24_per_tick: i32::MIN,
            advance_ticks_q16: u32::MAX,
            engage_ticks: u32::MAX,
            blend_start_x_in_q24: i32::MIN,
            blend_end_x_in_q24: i32::MIN,
            max_velocity_uin_per_s: u32::MAX,
            max_accel_uin_per_s2: u32::MAX,
            min_speed_turn_q32_per_tick: u32::MAX,
            x_steps_per_in: u32::MAX,
            output: ZOutputSpec::Dac { codes_per_in: u32::MAX, mid_code: u16::MAX },
            ..spec()
        })),
    ];
    let kinds: std::vec::Vec<u8> = bodies.iter().map(|b| b.kind()).collect();
    // The envelope's capability kinds start at 64; turning is second (8 kinds each).
    assert_eq!(kinds, [72, 73, 74, 75]);
    for body in bodies {
        let req = Request { seq: u32::MAX, body };
        let mut buf = [0u8; MAX_FRAME_LINK];
        let frame = encode_frame(&req, &mut buf).expect("fits");
        let mut d = FrameDecoder::<MAX_FRAME>::new();
        let mut got = None;
        for &byte in frame {
            if let Some(f) = d.push(byte) {
                got = Some(decode_request(f.unwrap()).unwrap());
            }
        }
        assert_eq!(got, Some(req));
    }
    // The largest Status (the Z fields too) fitting an Ack: `largest_messages_fit_the_frame_buffers`.
    // An oversized chunk does not decode (BlockBytes caps it) or is refused by the session.
    let mut r = Rig::new(0);
    let big = BlockBytes::from_slice(&[0; MAX_Z_CHUNK + 1]).unwrap();
    assert_eq!(
        r.send(RequestBody::from(TurningRequest::ZTableChunk { index: 0, bytes: big })),
        Err((ErrorCode::OutOfRange, NakDetail::None))
    );
}

#[test]
fn upload_installs_the_table_in_order_and_refusals_replace_nothing() {
    let (h, b) = douglass();
    let crc = CRC32.checksum(&b);
    let mut r = Rig::new(0);
    r.upload(h, &b, MAX_Z_CHUNK, crc).unwrap();
    assert!(is_douglass(r.t.job.table()));
    // A second table (every coefficient halved) with a bad CRC: refused, the first stays.
    let half: std::vec::Vec<u8> = b
        .chunks(4)
        .flat_map(|c| (i32::from_le_bytes([c[0], c[1], c[2], c[3]]) / 2).to_le_bytes())
        .collect();
    let bad_crc = CRC32.checksum(&half) ^ 0x8000_0000;
    let e = r.upload(h, &half, 100, bad_crc).unwrap_err();
    assert_eq!(
        e,
        (ErrorCode::InvalidTable, NakDetail::Turning { reason: 6, expected: None, fault: None })
    );
    assert!(is_douglass(r.t.job.table()));
    // Out of order: the NAK names the chunk expected; the upload is still open at it.
    r.send(RequestBody::from(TurningRequest::ZTableBegin(h))).unwrap();
    r.send(RequestBody::from(TurningRequest::ZTableChunk {
        index: 0,
        bytes: BlockBytes::from_slice(&half[..100]).unwrap(),
    }))
    .unwrap();
    let e = r.send(RequestBody::from(TurningRequest::ZTableChunk {
        index: 2,
        bytes: BlockBytes::from_slice(&half[100..200]).unwrap(),
    }));
    assert_eq!(
        e,
        Err((
            ErrorCode::InvalidTable,
            NakDetail::Turning { reason: 3, expected: Some(1), fault: None }
        ))
    );
    assert_eq!(r.t.req.expected(), Some(1));
    // End before every byte: Short, nothing replaced.
    let e = r.send(RequestBody::from(TurningRequest::ZTableEnd { crc: CRC32.checksum(&half) }));
    assert_eq!(
        e,
        Err((
            ErrorCode::InvalidTable,
            NakDetail::Turning { reason: 5, expected: None, fault: None }
        ))
    );
    assert!(is_douglass(r.t.job.table()));
    // A chunk without an upload.
    let e = r.send(RequestBody::from(TurningRequest::ZTableChunk {
        index: 0,
        bytes: BlockBytes::from_slice(&half[..4]).unwrap(),
    }));
    assert_eq!(
        e,
        Err((
            ErrorCode::InvalidTable,
            NakDetail::Turning { reason: 2, expected: None, fault: None }
        ))
    );
    // A bad header.
    let e = r.send(RequestBody::from(TurningRequest::ZTableBegin(ZTableHeader { form: 9, ..h })));
    assert_eq!(
        e,
        Err((
            ErrorCode::InvalidTable,
            NakDetail::Turning { reason: 1, expected: None, fault: None }
        ))
    );
    // The right CRC: the halved table replaces the first.
    r.upload(h, &half, 100, CRC32.checksum(&half)).unwrap();
    let LinkTable::Power(p) = r.t.job.table() else { panic!() };
    assert_eq!(p.row(40).unwrap()[1], DOUGLASS_POWER.row(40).unwrap()[1] / 2);
    // A retransmitted chunk is answered from memory, not applied twice.
    r.send(RequestBody::from(TurningRequest::ZTableBegin(h))).unwrap();
    let c0 = RequestBody::from(TurningRequest::ZTableChunk {
        index: 0,
        bytes: BlockBytes::from_slice(&b[..100]).unwrap(),
    });
    r.send(c0.clone()).unwrap();
    let again = r.b.handle(&Request { seq: r.seq - 1, body: c0 }, &mut r.t);
    assert!(matches!(again, Response::Ack { .. }));
    assert_eq!(r.t.req.expected(), Some(1));
}

#[test]
fn start_without_table_and_uploads_while_running_are_refused_and_change_nothing() {
    let mut r = Rig::new(0);
    let before = (r.t.sim.clone(), r.t.job.state_code(), r.t.z_active);
    let e = r.send(RequestBody::from(TurningRequest::StartZ(spec())));
    assert_eq!(e, Err((ErrorCode::OutOfState, NakDetail::State(MachineState::Ready))));
    assert_eq!((r.t.sim.clone(), r.t.job.state_code(), r.t.z_active), before);
    let (h, b) = douglass();
    r.upload(h, &b, MAX_Z_CHUNK, CRC32.checksum(&b)).unwrap();
    // A spec out of range (X axis = Z axis): OutOfRange, nothing started.
    let e = r.send(RequestBody::from(TurningRequest::StartZ(ZJobSpec { x_axis: 0, ..spec() })));
    assert_eq!(e, Err((ErrorCode::OutOfRange, NakDetail::None)));
    assert!(!r.t.job.is_running());
    // The spindle below the spec's minimum: the pre-start check's fault in the detail.
    let e = r.send(RequestBody::from(TurningRequest::StartZ(ZJobSpec {
        min_speed_turn_q32_per_tick: u32::MAX >> 1,
        ..spec()
    })));
    assert_eq!(
        e,
        Err((
            ErrorCode::OutOfRange,
            NakDetail::Turning {
                reason: 0,
                expected: None,
                fault: Some(FaultCode::SpindleStopped)
            }
        ))
    );
    assert_eq!(r.t.sim.machine, MachineState::Ready);
    r.send(RequestBody::from(TurningRequest::StartZ(spec()))).unwrap();
    assert_eq!(r.t.sim.machine, MachineState::Running);
    // Running: a second start and every upload step are refused (Start/Queue columns pass in
    // Running or not, the Z job refuses), the table stays.
    let e = r.send(RequestBody::from(TurningRequest::StartZ(spec())));
    assert_eq!(e.unwrap_err().0, ErrorCode::OutOfState);
    let e = r.send(RequestBody::from(TurningRequest::ZTableBegin(h)));
    assert_eq!(e, Err((ErrorCode::OutOfState, NakDetail::State(MachineState::Running))));
    let e = r.send(RequestBody::from(TurningRequest::ZTableEnd { crc: 0 }));
    assert_eq!(e, Err((ErrorCode::OutOfState, NakDetail::State(MachineState::Running))));
    assert!(is_douglass(r.t.job.table()));
    // Status carries the Z fields: engaging (state 2: following with the weight ramping up),
    // X at its start, rpm as sensed.
    let Ok(()) = r.send(RequestBody::GetStatus) else { panic!() };
    let s = r.b.status(&r.t);
    assert_eq!((s.z_state, s.z_x_in_q24), (2, 0));
    assert!((s.z_spindle_rpm_milli - 360_000).abs() <= 1, "{}", s.z_spindle_rpm_milli);
    // Abort ends it; an upload is accepted again.
    r.send(RequestBody::Abort).unwrap();
    r.send(RequestBody::from(TurningRequest::ZTableBegin(h))).unwrap();
}

#[cfg(feature = "sim-inputs")]
#[test]
fn sim_spindle_needs_cap_sim_inputs() {
    let spindle = |rpm_milli| RequestBody::Sim(SimRequest::Spindle { rpm_milli, index: true });
    let mut r = Rig::new(0);
    assert_eq!(r.send(spindle(360_000)), Err((ErrorCode::Unsupported, NakDetail::None)));
    assert_eq!(r.t.sim_rpm_milli, None);
    let mut r = Rig::new(CAP_SIM_INPUTS);
    r.send(spindle(432_000)).unwrap();
    assert_eq!(r.t.sim_rpm_milli, Some(432_000));
}
