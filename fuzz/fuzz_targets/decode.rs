//! The board's receive path on arbitrary bytes: the input is fed (1) as a raw byte stream through
//! `FrameDecoder` into `BoardLink`, and (2) split at 0xFF into messages that are framed with a
//! valid CRC first, so postcard decoding and the session logic are reached too. Every answer must
//! encode, and the host side must survive every answer and every chunk. Any panic is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;
use motion::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use motion::protocol::*;

fn config() -> LinkConfig {
    LinkConfig {
        machine: MachineConfig {
            tick_hz: 100_000,
            timing: StepTiming {
                pulse_ns: 2_500,
                dir_setup_ns: 5_000,
                dir_hold_ns: 12_000,
            },
            axis_count: 3,
            axes: [AxisLimits {
                max_rate_hz: 40_000,
                accel_steps_per_s2: 200_000,
                junction_jerk_hz: 0,
            }; MAX_AXES],
        },
        scale: [AxisScale {
            steps_per_unit_milli: 80_000,
            soft_min: -1_000_000,
            soft_max: 1_000_000,
        }; MAX_AXES],
        inputs: motion::InputFilterConfig::DEFAULT,
    }
}

fuzz_target!(|data: &[u8]| {
    let mut target = SimTarget::new(config(), 8);
    let mut board = BoardLink::new("fuzz", CAP_DDA);
    let mut host = HostLink::new(HostConfig::default());
    host.connect(0);
    let mut out = [0u8; MAX_FRAME_LINK];
    // Open a session at seq 0 so requests starting with seq 1 execute.
    let hello = Request {
        seq: 0,
        body: RequestBody::Hello {
            version: PROTOCOL_VERSION,
            nonce: 0,
        },
    };
    let _ = board.handle(&hello, &mut target);

    let answer = |resp: Response, host: &mut HostLink| {
        if let Response::Nak {
            code: ErrorCode::Internal,
            ..
        } = resp
        {
            panic!("internal error: {resp:?}");
        }
        let mut buf = [0u8; MAX_FRAME_LINK];
        let f = encode_frame(&resp, &mut buf).expect("answers always fit");
        let mut d = FrameDecoder::<MAX_FRAME>::new();
        for &b in f {
            if let Some(r) = d.push(b) {
                let _ = host.receive_message(r.expect("own frames decode"));
            }
        }
    };

    let mut rx = FrameDecoder::<MAX_FRAME>::new();
    for &b in data {
        if let Some(r) = rx.push(b) {
            let resp = board.on_frame(r, &mut target);
            answer(resp, &mut host);
        }
    }
    for (i, chunk) in data.split(|&b| b == 0xFF).enumerate() {
        let _ = host.receive_message(chunk);
        let Ok(f) = encode_payload_frame(chunk, &mut out) else {
            continue;
        };
        for &b in f {
            if let Some(r) = rx.push(b) {
                let resp = board.on_frame(r, &mut target);
                answer(resp, &mut host);
            }
        }
        if i % 3 == 2 {
            target.complete_one();
        }
        assert!(target.queue_len() <= 8);
        let _ = board.poll(i as u64 * 7, &target);
        let _ = host.poll_transmit(i as u64 * 50);
    }
});
