//! The job runner against the in-process board (`BoardLink` + `SimTarget`, see `sim_board`):
//! 2000 segments through a 1 % noise proxy arrive exactly once and in order, a dead link is
//! reopened and the job resumes, a board reset stops the job with a clear error, and a board of
//! another protocol version is named.

use motion::protocol::{
    decode_request, encode_frame, ErrorCode, FrameDecoder, HostConfig, NakDetail, Response,
    MAX_FRAME, MAX_FRAME_LINK,
};
use motionctl::convert::{self, Program};
use motionctl::job::{self, Job};
use motionctl::noise::Noisy;
use motionctl::plan::{self, Output};
use motionctl::runner::{self, RunOptions, RunReport};
use motionctl::sample_job;
use motionctl::sim_board::{SimBoard, SimTrouble, SIM_CAPACITY};
use motionctl::transport::Transport;
use std::time::Duration;

/// The sample zig-zag job of `n` short moves (`motionctl::sample_job`), as streamed in QEMU by
/// `cargo xtask test`.
fn zigzag_job(n: usize) -> String {
    sample_job::job_toml(&sample_job::targets(n))
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
    // The simulated board has no switches: homing takes it where it stands (`--sim` implies
    // `--home` too).
    RunOptions { host: HostConfig { rto_ms, window: 8 }, home: true, ..RunOptions::default() }
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
    assert_eq!(t.inner.starve_holds, 0);
    let (to, from) = (t.to_board.stats, t.from_board.stats);
    assert!(to.corrupted + to.dropped > 0 && from.corrupted + from.dropped > 0);
}

#[test]
fn every_status_report_lies_on_the_planned_path() {
    let p = prepare(&zigzag_job(200));
    let mut board = SimBoard::new(SIM_CAPACITY, 8.0);
    let r = run(&p, &mut board, opts(20)).unwrap();
    assert!(r.ok(), "{:?}", r.problems);
    assert!(r.path.ok() && r.path.samples > 20, "{:?}", r.path);
    // The simulated board completes whole segments: its reports are at segment ends, exactly.
    assert_eq!(r.path.max_dev_steps, 0.0, "{:?}", r.path);
    assert!(r.machine_line().ends_with("path_max_dev_steps=0.000 path_ok=1"));
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
                let mut buf = [0u8; MAX_FRAME_LINK];
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
    let want = format!("does not speak protocol v{}", motion::protocol::PROTOCOL_VERSION);
    assert!(e.contains(&want), "{e}");
}

#[test]
fn an_unhomed_board_refuses_the_job_unless_asked_to_home() {
    let p = prepare(&zigzag_job(10));
    let mut board = SimBoard::new(SIM_CAPACITY, 100.0);
    let e = run(&p, &mut board, RunOptions { home: false, ..opts(20) }).unwrap_err();
    assert!(e.contains("not homed"), "{e}");
    assert_eq!(board.target.segments_done, 0, "nothing ran");
    let r = run(&p, &mut board, opts(20)).unwrap();
    assert!(r.ok(), "{:?}", r.problems);
    assert!(board.target.homed);
}
