//! The messages themselves: the largest of every kind fits the frame buffers, every request's
//! kind is its postcard index, and the board counters' differences survive a wrap.

use super::*;
use crate::milling::link_messages::MillingRequest;
use crate::polar::link_messages::PolarRequest;
use crate::turning::link_messages::TurningRequest;
use crate::wire::link_messages::WireJobParams;
use crate::wire::link_messages::WireRequest;

fn extreme_config() -> LinkConfig {
    LinkConfig {
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
        state: LinkState::Faulted,
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
        RequestBody::from(PolarRequest::QueueEvents(EventBlock {
            bytes: BlockBytes::from_slice(&[0xFF; MAX_EVENT_BLOCK]).unwrap(),
            last: true,
        })),
        RequestBody::from(PolarRequest::StartPlayback { m: u8::MAX, k: u8::MAX }),
        RequestBody::from(WireRequest::ArmWire(WireJobParams {
            debounce_ticks: u16::MAX,
            retrace_limit_steps: u64::MAX,
            retrace_override_bits: u32::MAX,
            resume_override_bits: u32::MAX,
            resume_segments: u32::MAX,
            segments: u32::MAX,
        })),
        // -- Z-slide job --
        RequestBody::from(TurningRequest::ZTableBegin(crate::turning::link_job::ZTableHeader {
            form: u8::MAX,
            rows: u16::MAX,
            x0_in_q24: i32::MIN,
            dx_in_q24: i32::MIN,
        })),
        RequestBody::from(TurningRequest::ZTableChunk {
            index: u16::MAX,
            bytes: BlockBytes::from_slice(&[0xFF; MAX_Z_CHUNK]).unwrap(),
        }),
        RequestBody::from(TurningRequest::ZTableEnd { crc: u32::MAX }),
        RequestBody::from(TurningRequest::StartZ(crate::turning::link_job::ZJobSpec {
            output: crate::turning::link_job::ZOutputSpec::Steps {
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
        })),
        // -- force job --
        RequestBody::from(MillingRequest::ArmForce(
            crate::protocol::tests_milling::extreme_force_params(),
        )),
        // -- copy mode --
        RequestBody::from(PolarRequest::StartCopy { m: u8::MAX, k: u8::MAX, teach: true }),
        RequestBody::from(PolarRequest::ReadTeach { block: u16::MAX }),
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
            SimRequest::Milling(crate::protocol::tests_milling::extreme_sim_params()),
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
    let mut out = [0u8; MAX_FRAME_LINK];
    let mut largest = (0, 0);
    for r in extreme_requests() {
        let n = postcard::to_slice(&r, &mut [0u8; 1024]).unwrap().len();
        largest.0 = largest.0.max(n);
        let f = encode_frame(&r, &mut out).expect("request fits");
        assert!(f.len() <= MAX_FRAME_LINK);
    }
    for r in extreme_responses() {
        let n = postcard::to_slice(&r, &mut [0u8; 1024]).unwrap().len();
        largest.1 = largest.1.max(n);
        let f = encode_frame(&r, &mut out).expect("response fits");
        assert!(f.len() <= MAX_FRAME_LINK);
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
    use crate::capabilities::requests::{KIND_BASE, MAX_REQUESTS_PER_CAPABILITY};
    let mut capability_requests = 0;
    for r in extreme_requests() {
        let mut buf = [0u8; 1024];
        let b = postcard::to_slice(&r.body, &mut buf).unwrap();
        match &r.body {
            // The envelope's index, the capability's place in it, the request's own index.
            RequestBody::Capability(c) => {
                let (place, index) = (b[1], b[2]);
                assert_eq!(c.place_and_index(), (place, index), "{:?}", r.body);
                assert!(index < MAX_REQUESTS_PER_CAPABILITY);
                assert_eq!(r.body.kind(), KIND_BASE + place * MAX_REQUESTS_PER_CAPABILITY + index);
                capability_requests += 1;
            }
            // Every other kind is its postcard variant index.
            _ => assert_eq!(b[0], r.body.kind(), "{:?}", r.body),
        }
        assert!(r.body.kind() < KIND_BASE || matches!(r.body, RequestBody::Capability(_)));
    }
    assert_eq!(capability_requests, 10, "every capability request is in extreme_requests");
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
