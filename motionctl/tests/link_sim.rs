//! The job runner against the in-process board (`BoardLink` + `SimTarget`, see `sim_board`):
//! 2000 segments through a 1 % noise proxy arrive exactly once and in order, a dead link is
//! reopened and the job resumes, a board reset stops the job with a clear error, and a board of
//! another protocol version is named.

use motion::protocol::{
    decode_request, encode_frame, ErrorCode, FrameDecoder, HostConfig, NakDetail, Response,
    MAX_FRAME, MAX_FRAME_WIRE,
};
use motionctl::convert::{self, Program};
use motionctl::job::{self, Job};
use motionctl::noise::Noisy;
use motionctl::plan::{self, Output};
use motionctl::runner::{self, RunOptions, RunReport};
use motionctl::sim_board::{SimBoard, SimTrouble, SIM_CAPACITY};
use motionctl::transport::Transport;
use std::fmt::Write;
use std::time::Duration;

/// A deterministic zig-zag of `n` short moves in X/Y (Z every 7th) with varied feeds, on a
/// 100 steps/mm machine, coordinates in 0.01 mm so every target is a whole step.
fn zigzag_job(n: usize) -> String {
    let mut t = String::from(
        "format = \"motion-job\"\nversion = 1\n\n[machine]\ntick_hz = 20_000\n\
         [machine.timing]\npulse_ns = 2_500\ndir_setup_ns = 5_000\ndir_hold_ns = 5_000\n",
    );
    for (name, spm, rate, accel, jerk, lim) in [
        ("X", 100.0, 60.0, 5000.0, 25.0, 100.0),
        ("Y", 100.0, 60.0, 5000.0, 25.0, 100.0),
        ("Z", 400.0, 20.0, 400.0, 2.0, 20.0),
    ] {
        let _ = write!(
            t,
            "[[machine.axes]]\nname = \"{name}\"\nsteps_per_mm = {spm:.1}\nmax_rate_mm_s = \
             {rate:.1}\naccel_mm_s2 = {accel:.1}\njunction_jerk_mm_s = {jerk:.1}\nmin_mm = \
             -{lim:.1}\nmax_mm = {lim:.1}\n"
        );
    }
    let (mut x, mut y, mut z) = (0i64, 0i64, 0i64); // 0.01 mm
    let mut seed = 12345u64;
    let feeds = [600.0, 900.0, 1200.0, 1500.0, 750.0];
    for i in 0..n {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let r = (seed >> 33) as i64;
        x += if i % 2 == 0 { 20 + r % 30 } else { -(20 + (r >> 8) % 30) };
        y += if (i / 50) % 2 == 0 { 5 + (r >> 16) % 10 } else { -(5 + (r >> 16) % 10) };
        if i % 7 == 3 {
            z = if z == 0 { -(10 + (r >> 24) % 20) } else { 0 };
        }
        x = x.clamp(-9000, 9000);
        y = y.clamp(-9000, 9000);
        let _ = write!(
            t,
            "[[moves]]\nto = {{ X = {:.2}, Y = {:.2}, Z = {:.2} }}\nfeed_mm_min = {:.1}\n",
            x as f64 / 100.0,
            y as f64 / 100.0,
            z as f64 / 100.0,
            feeds[i % feeds.len()]
        );
    }
    t
}

struct Prepared {
    job: Job,
    program: Program,
    outputs: Vec<Output>,
    expected: [i64; motion::MAX_AXES],
}

fn prepare(src: &str) -> Prepared {
    let job = job::parse_toml(src).unwrap();
    let program = convert::convert(&job).unwrap();
    let outputs: Vec<Output> = plan::Stream::new(&program).collect::<Result<_, _>>().unwrap();
    let summary = plan::simulate(&program, |_| {}).unwrap();
    assert!(summary.finished);
    eprintln!(
        "job: {:.2} s of machine time, {} underruns",
        summary.seconds(),
        summary.report.underruns
    );
    let mut expected = [0; motion::MAX_AXES];
    expected.copy_from_slice(&summary.report.positions[..motion::MAX_AXES]);
    assert_eq!(expected, program.final_steps);
    Prepared { job, program, outputs, expected }
}

fn opts(rto_ms: u64) -> RunOptions {
    RunOptions { host: HostConfig { rto_ms, window: 8 }, ..RunOptions::default() }
}

fn run(p: &Prepared, t: &mut dyn Transport, o: RunOptions) -> Result<RunReport, String> {
    runner::run(t, &p.job, &p.program, &p.outputs, &p.expected, o).map_err(|e| e.to_string())
}

fn segments(p: &Prepared) -> usize {
    p.outputs.iter().filter(|o| matches!(o, Output::Segment(_))).count()
}

#[test]
fn zigzag_job_has_2000_segments() {
    let p = prepare(&zigzag_job(2000));
    assert_eq!(segments(&p), 2000);
}

#[test]
fn two_thousand_segments_through_one_percent_noise_arrive_once_in_order() {
    let p = prepare(&zigzag_job(2000));
    // Machine time at 4x: the link must keep a 32-segment queue fed through the noise.
    let board = SimBoard::new(SIM_CAPACITY, 4.0);
    let mut t = Noisy::new(board, 0.01, 7);
    let r = run(&p, &mut t, opts(20)).unwrap();
    eprintln!("{}", r.machine_line());
    assert!(r.ok(), "{:?}", r.problems);
    assert_eq!((r.segments, r.acked, r.done), (2000, 2000, 2000));
    assert_eq!(r.done_hash, r.expected_hash);
    assert_eq!(r.positions, p.expected[..3].to_vec());
    assert!(r.retransmissions > 0 && r.link_naks > 0, "the noise did something");
    assert_eq!(r.queue_full_naks, 0);
    assert!(r.max_credits <= SIM_CAPACITY && r.max_queue_depth <= SIM_CAPACITY);
    assert_eq!(t.inner.underruns, 0);
    let (to, from) = (t.to_board.stats, t.from_board.stats);
    assert!(to.corrupted + to.dropped > 0 && from.corrupted + from.dropped > 0);
}

#[test]
fn a_silent_link_is_reopened_and_the_job_resumes() {
    let p = prepare(&zigzag_job(200));
    let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
    board.trouble = SimTrouble {
        silence_at_segment: Some((60, Duration::from_millis(2500))),
        ..Default::default()
    };
    let r = run(&p, &mut board, opts(20)).unwrap();
    assert!(r.ok(), "{:?}", r.problems);
    assert!(r.reconnects >= 1, "{}", r.machine_line());
    assert_eq!(r.done, 200);
}

#[test]
fn a_board_reset_stops_the_job_with_a_clear_error() {
    let p = prepare(&zigzag_job(200));
    let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
    board.trouble = SimTrouble { reset_at_segment: Some(50), ..Default::default() };
    let e = run(&p, &mut board, opts(20)).unwrap_err();
    assert!(e.contains("the board reset") && e.contains("cannot resume safely"), "{e}");
}

/// Answers every Hello with a `Version` NAK, like a board of another protocol version.
struct OtherVersion {
    dec: FrameDecoder<MAX_FRAME>,
    out: Vec<u8>,
}

impl Transport for OtherVersion {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        for &b in bytes {
            if let Some(Ok(msg)) = self.dec.push(b) {
                let seq = decode_request(msg).map(|r| r.seq).unwrap_or(0);
                let nak = Response::Nak {
                    seq,
                    credits: 0,
                    code: ErrorCode::Version,
                    detail: NakDetail::None,
                };
                let mut buf = [0u8; MAX_FRAME_WIRE];
                self.out.extend_from_slice(encode_frame(&nak, &mut buf).unwrap());
            }
        }
        Ok(())
    }
    fn recv(&mut self, _timeout: Duration) -> std::io::Result<Vec<u8>> {
        Ok(std::mem::take(&mut self.out))
    }
    fn describe(&self) -> String {
        "a board of another protocol version".into()
    }
}

#[test]
fn a_board_of_another_protocol_version_is_named() {
    let p = prepare(&zigzag_job(10));
    let mut t = OtherVersion { dec: FrameDecoder::new(), out: Vec::new() };
    let e = run(&p, &mut t, opts(20)).unwrap_err();
    assert!(e.contains("does not speak protocol v1"), "{e}");
}
