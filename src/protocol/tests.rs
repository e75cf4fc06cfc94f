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
        inputs: crate::config::InputFilterConfig::DEFAULT,
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
        inputs: crate::config::InputFilterConfig::DEFAULT,
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
        event_credits: u16::MAX,
        events_fired: u32::MAX,
        event_blocks: u16::MAX,
        wire_stalls: u32::MAX,
        wire_retraces: u32::MAX,
        wire_returns: u32::MAX,
        wire_max_retrace_steps: u64::MAX,
        wire_power: true,
        // -- Z-slide job --
        z_state: u8::MAX,
        z_x_in_q24: i32::MIN,
        z_cmd_in_q32: i32::MIN,
        z_max_following_nin: i64::MIN,
        z_steps: i64::MIN,
        z_dac_code: u16::MAX,
        z_spindle_rpm_milli: i64::MIN,
        // -- force job --
        force_mn: u32::MAX,
        force_peak_mn: u32::MAX,
        force_override_bits: u32::MAX,
        force_phase: u8::MAX,
        force_updates: u32::MAX,
        // -- copy mode --
        copy_running: true,
        encoder_counts: [i32::MIN; 2],
        taught_events: u32::MAX,
        lost_events: u32::MAX,
        counters: BoardCounters {
            usart_overruns: u32::MAX,
            frames_bad: u32::MAX,
            responses_dropped: u32::MAX,
            tick_overruns: u32::MAX,
            steps_deferred: u32::MAX,
            starve_holds: u32::MAX,
        },
        outputs: u8::MAX,
        probe_phase: u8::MAX,
        probe_steps: [i64::MIN; MAX_AXES],
        probe_input: true,
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
    #[allow(unused_mut)]
    let mut bodies = vec![
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
        RequestBody::QueueEvents(EventBlock {
            bytes: BlockBytes::from_slice(&[0xFF; MAX_EVENT_BLOCK]).unwrap(),
            last: true,
        }),
        RequestBody::StartPlayback { m: u8::MAX, k: u8::MAX },
        RequestBody::ArmWire(WireJobParams {
            debounce_ticks: u16::MAX,
            retrace_limit_steps: u64::MAX,
            retrace_override_bits: u32::MAX,
            resume_override_bits: u32::MAX,
            resume_segments: u32::MAX,
            segments: u32::MAX,
        }),
        // -- Z-slide job --
        RequestBody::ZTableBegin(crate::zslide::link_job::ZTableHeader {
            form: u8::MAX,
            rows: u16::MAX,
            x0_in_q24: i32::MIN,
            dx_in_q24: i32::MIN,
        }),
        RequestBody::ZTableChunk {
            index: u16::MAX,
            bytes: BlockBytes::from_slice(&[0xFF; MAX_Z_CHUNK]).unwrap(),
        },
        RequestBody::ZTableEnd { crc: u32::MAX },
        RequestBody::StartZ(crate::zslide::link_job::ZJobSpec {
            output: crate::zslide::link_job::ZOutputSpec::Steps {
                axis: u8::MAX,
                steps_per_in: u32::MAX,
            },
            x_axis: u8::MAX,
            x_steps_per_in: u32::MAX,
            x_negative: true,
            x_start_in_q24: i32::MIN,
            x_end_in_q24: i32::MIN,
            x_feed_in_q24_per_tick: i32::MIN,
            cubic: true,
            advance_ticks_q16: u32::MAX,
            engage_ticks: u32::MAX,
            blend_start_x_in_q24: i32::MIN,
            blend_end_x_in_q24: i32::MIN,
            max_velocity_uin_per_s: u32::MAX,
            max_accel_uin_per_s2: u32::MAX,
            min_speed_turn_q32_per_tick: u32::MAX,
        }),
        // -- force job --
        RequestBody::ArmForce(crate::protocol::force_tests::extreme_force_params()),
        // -- copy mode --
        RequestBody::StartCopy { m: u8::MAX, k: u8::MAX, teach: true },
        RequestBody::ReadTeach { block: u16::MAX },
        RequestBody::SetProgramOutputs(crate::protocol::ProgramOutputs {
            spindle: crate::protocol::SpindleDir::Ccw,
            mist: true,
            flood: true,
        }),
    ];
    #[cfg(feature = "sim-inputs")]
    bodies.extend(
        [
            SimRequest::Inject { wire_stall: true },
            SimRequest::Spindle { rpm_milli: u32::MAX, index: true },
            SimRequest::Milling(crate::protocol::force_tests::extreme_sim_params()),
            SimRequest::Encoders { arm_counts: i32::MIN, carriage_counts: i32::MIN },
        ]
        .map(RequestBody::Sim),
    );
    bodies.into_iter().map(|body| Request { seq, body }).collect()
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
        last_panic: Some(PanicSite {
            file: FixedStr::tail(&"ÿ".repeat(PANIC_FILE_LEN)),
            line: u32::MAX,
            column: u32::MAX,
        }),
    };
    let mut v = vec![
        Response::Ack { seq, credits, reply: Reply::None },
        Response::Ack { seq, credits, reply: Reply::Hello(hello) },
        Response::Ack { seq, credits, reply: Reply::Config(extreme_config()) },
        Response::Ack { seq, credits, reply: Reply::Status(extreme_status()) },
        Response::Ack { seq, credits, reply: Reply::EventCredits(u16::MAX) },
        // -- copy mode --
        Response::Ack {
            seq,
            credits,
            reply: Reply::Teach(TeachChunk {
                block: u16::MAX,
                bytes: BlockBytes::from_slice(&[0xFF; MAX_EVENT_BLOCK]).unwrap(),
                ended: true,
                taught_events: u32::MAX,
                lost_events: u32::MAX,
            }),
        },
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
        NakDetail::Block { reason: u8::MAX, expected: Some(u16::MAX) },
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
        // Every kind is its postcard variant index (the job blocks were renumbered at merge).
        assert_eq!(b[0], r.body.kind(), "{:?}", r.body);
    }
    let block = RequestBody::QueueEvents(EventBlock::default());
    assert_eq!(block.kind(), super::session::KIND_QUEUE_EVENTS);
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

/// The blocks of the built-in limacon stream.
fn stream_blocks() -> Vec<&'static [u8]> {
    crate::polar::stream::data_blocks(crate::polar::limacon_stream::BYTES)
}

fn events(seq: u32, block: &[u8], last: bool) -> Request {
    req(
        seq,
        RequestBody::QueueEvents(EventBlock {
            bytes: BlockBytes::from_slice(block).unwrap(),
            last,
        }),
    )
}

fn event_credits(r: &Response) -> Option<u16> {
    match r {
        Response::Ack { reply: Reply::EventCredits(c), .. } => Some(*c),
        _ => None,
    }
}

#[test]
fn event_blocks_are_checked_whole_before_anything_is_queued() {
    let bl = stream_blocks();
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA | CAP_EVENTS);
    b.handle(&hello(0, 1), &mut t);
    let before = t.clone();
    // One flipped payload bit: the CRC refuses it, nothing is queued, the NAK says why.
    let mut bad = bl[0].to_vec();
    bad[crate::polar::stream::HEADER_LEN + 2] ^= 0x04;
    let r = b.handle(&events(1, &bad, false), &mut t);
    assert_eq!(
        r,
        Response::Nak {
            seq: 1,
            credits: 4,
            code: ErrorCode::InvalidSegment,
            detail: NakDetail::Block {
                reason: crate::polar::stream::StreamError::Crc.code(),
                expected: Some(0)
            },
        }
    );
    // Out of sequence (block 1 first) and bytes after the block: refused too.
    let r = b.handle(&events(2, bl[1], false), &mut t);
    assert!(
        matches!(r, Response::Nak { detail: NakDetail::Block { reason: 10, .. }, .. }),
        "{r:?}"
    );
    let mut two = bl[0].to_vec();
    two.push(0xB5);
    let r = b.handle(&events(3, &two, false), &mut t);
    assert!(matches!(r, Response::Nak { detail: NakDetail::Block { reason: 9, .. }, .. }), "{r:?}");
    // Size scale outside 1..=4, and a start with nothing queued.
    let r = b.handle(&req(4, RequestBody::StartPlayback { m: 5, k: 1 }), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::OutOfRange));
    let r = b.handle(&req(5, RequestBody::StartPlayback { m: 1, k: 0 }), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::OutOfRange));
    let r = b.handle(&req(6, RequestBody::StartPlayback { m: 1, k: 1 }), &mut t);
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    assert_eq!(t, before, "refusals change nothing");
    assert_eq!(t.events.events_admitted, 0);
}

#[test]
fn event_credits_count_blocks_and_the_machine_table_decides_the_state() {
    let bl = stream_blocks();
    let cap = super::sim::SIM_EVENT_BLOCKS as u16;
    assert!(bl.len() > cap as usize + 2, "{} blocks", bl.len());
    let mut t = SimTarget::new(config(), 4);
    let mut b = BoardLink::new("test", CAP_DDA | CAP_EVENTS);
    b.handle(&hello(0, 1), &mut t);
    let mut s = 1;
    // Segments and events never share a job.
    assert!(matches!(b.handle(&queue(s, &[seg(1, 10)]), &mut t), Response::Ack { .. }));
    s += 1;
    let r = b.handle(&events(s, bl[0], false), &mut t);
    s += 1;
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    b.handle(&req(s, RequestBody::Abort), &mut t);
    s += 1;
    // Credits are blocks: each Ack carries what is left, until none; then QueueFull.
    for (i, block) in bl.iter().take(cap as usize).enumerate() {
        let r = b.handle(&events(s, block, false), &mut t);
        s += 1;
        assert_eq!(event_credits(&r), Some(cap - 1 - i as u16), "{r:?}");
    }
    let r = b.handle(&events(s, bl[cap as usize], false), &mut t);
    s += 1;
    assert_eq!(code(&r), Some(ErrorCode::QueueFull));
    // A retransmitted QueueEvents is answered from memory (credits of the time), not queued.
    let again = b.handle(&events(s - 2, bl[cap as usize - 1], false), &mut t);
    assert_eq!(event_credits(&again), Some(0));
    assert_eq!(t.events.blocks(), cap as usize);
    // Status reports the event credits; segments are refused while events are queued.
    let Response::Ack { reply: Reply::Status(st), .. } =
        b.handle(&req(s, RequestBody::GetStatus), &mut t)
    else {
        panic!()
    };
    s += 1;
    assert_eq!((st.event_credits, st.event_blocks, st.events_fired), (0, cap, 0));
    let r = b.handle(&queue(s, &[seg(2, 10)]), &mut t);
    s += 1;
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    // Start (Ready -> Running, the table's Start column); a second start is refused by it.
    let r = b.handle(&req(s, RequestBody::StartPlayback { m: 3, k: 2 }), &mut t);
    s += 1;
    assert!(matches!(r, Response::Ack { .. }), "{r:?}");
    assert_eq!(t.machine_state(), crate::machine::MachineState::Running);
    let r = b.handle(&req(s, RequestBody::StartPlayback { m: 3, k: 2 }), &mut t);
    s += 1;
    assert!(matches!(
        r,
        Response::Nak {
            code: ErrorCode::OutOfState,
            detail: NakDetail::State(crate::machine::MachineState::Running),
            ..
        }
    ));
    // Playing frees slots; with no block marked last, running dry is an underrun after every
    // admitted event fired.
    let admitted = t.events.events_admitted;
    let in_blocks: u32 = bl[..cap as usize]
        .iter()
        .map(|b| crate::polar::stream::parse_block(b).unwrap().0.events as u32)
        .sum();
    assert_eq!(admitted, in_blocks);
    t.run_events(50_000_000);
    assert_ne!(t.faults & FaultCode::QueueUnderrun.bit(), 0);
    assert_eq!(t.machine_state(), crate::machine::MachineState::Fault);
    assert_eq!(t.playback.fired(), admitted);
    let Response::Ack { reply: Reply::Status(st), .. } =
        b.handle(&req(s, RequestBody::GetStatus), &mut t)
    else {
        panic!()
    };
    assert_eq!((st.events_fired, st.event_credits), (admitted, cap));
}

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
        let r = send(&mut b, &mut t, RequestBody::ArmWire(p));
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
    let r = send(&mut b, &mut t, RequestBody::ArmWire(wire_params()));
    assert_eq!(code(&r), Some(ErrorCode::OutOfState));
    assert_eq!(t, queued);
    // In Fault the table refuses it before the target sees it.
    let _ = send(&mut b, &mut t, RequestBody::Abort);
    t.raise_fault(FaultCode::LimitSwitch);
    let faulted = t.clone();
    let r = send(&mut b, &mut t, RequestBody::ArmWire(wire_params()));
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
    let r = b.handle(&req(1, RequestBody::ArmWire(wire_params())), &mut t);
    assert!(matches!(r, Response::Ack { seq: 1, .. }), "{r:?}");
    assert_eq!(t.wire_armed, Some(wire_params()));
    // Armed twice: refused, the first arming stays.
    let r = b.handle(
        &req(2, RequestBody::ArmWire(WireJobParams { segments: 3, ..wire_params() })),
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
    assert!(wire_params_ok(&wire_params()));
}

#[test]
fn board_counters_since_is_right_across_a_wrap() {
    let earlier = BoardCounters {
        usart_overruns: u32::MAX - 1,
        frames_bad: 5,
        responses_dropped: u32::MAX,
        tick_overruns: 0,
        steps_deferred: 7,
        starve_holds: u32::MAX,
    };
    let now = BoardCounters {
        usart_overruns: 2,
        frames_bad: 9,
        responses_dropped: 0,
        tick_overruns: 3,
        steps_deferred: 7,
        starve_holds: 1,
    };
    let d = now.since(&earlier);
    assert_eq!(
        (
            d.usart_overruns,
            d.frames_bad,
            d.responses_dropped,
            d.tick_overruns,
            d.steps_deferred,
            d.starve_holds
        ),
        (4, 4, 1, 3, 0, 2)
    );
}
