//! `motionctl polar copy` against the in-process copy board (`BoardLink` + `CopySim`, whose
//! copy, teach recorder and simulated encoders are the firmware's `motion::polar` code): a
//! limacon template copied at 3:2 with teach through a noisy link, the taught stream read back
//! whole (nothing lost), the board's steps equal the host model (`CopyMode` fed the recorded
//! counts), and the stream replayed with `polar run` at speed 2 lands on the copied positions
//! at 1:1.

use motion::polar::playback::SizeScale;
use motion::protocol::HostConfig;
use motionctl::noise::Noisy;
use motionctl::polar::copy::{copy, limacon_trace, model, parse_trace, CopyOptions};
use motionctl::polar::copy_sim::CopySimBoard;
use motionctl::polar::run::{self, PolarRunOptions};
use motionctl::polar::sim::EventSim;

fn opts(trace: Vec<[i32; 2]>, m: u8, k: u8) -> CopyOptions {
    CopyOptions {
        scale: SizeScale::new(m, k).unwrap(),
        teach: true,
        host: HostConfig { rto_ms: 30, window: 8 },
        home: true,
        progress: false,
        trace: Some(trace),
        seconds: 0.0,
    }
}

#[test]
fn limacon_copy_at_3_2_teaches_a_stream_that_replays_at_1_1() {
    let trace = limacon_trace(0.6, 40);
    let last = *trace.last().unwrap();
    let mut t = Noisy::new(CopySimBoard::new(8.0), 0.005, 3);
    let r = copy(&mut t, &opts(trace, 3, 2)).unwrap();
    println!("{}", r.machine_line());
    assert!(r.ok(), "{:?}", r.problems);
    // The encoders moved exactly along the template (limacon r = 3 + 2 cos theta, in).
    assert_eq!(r.encoder_moves, [last[0] as i64, last[1] as i64]);
    let dtheta = 2.0 * std::f64::consts::PI / 16000.0;
    let expect_c = ((2.0 * (last[0] as f64 * dtheta).cos() - 2.0) / 0.001).round() as i64;
    assert_eq!(r.encoder_moves[1], expect_c);
    // Every count is one taught event (both axes move one way on this piece), none lost.
    assert_eq!(r.lost_events, 0);
    let total = r.encoder_moves[0].abs() + r.encoder_moves[1].abs();
    assert_eq!(r.taught_events as i64, total);
    // The board's steps: theta 1:1, r at 3:2, and equal to the host model.
    assert_eq!(r.positions, r.model.positions);
    assert_eq!(r.positions[0], r.encoder_moves[0]);
    assert!((r.positions[1] - r.encoder_moves[1] * 3 / 2).abs() <= 1, "{:?}", r.positions);

    // Replay the taught stream at speed 2, size 1:1: the copied positions at 1:1.
    let mut t = EventSim::new(8.0);
    let ropts = PolarRunOptions {
        speed: 2.0,
        scale: SizeScale::ONE,
        host: HostConfig { rto_ms: 30, window: 8 },
        home: true,
        progress: false,
    };
    let rr = run::run(&mut t, &r.stream, &ropts).unwrap();
    assert!(rr.ok(), "{:?}", rr.problems);
    assert_eq!(rr.events_fired, r.taught_events);
    assert_eq!(rr.positions, [r.encoder_moves[0], r.encoder_moves[1]]);
    // At speed 2 the replay takes half the recorded ticks (rounded per event).
    let at1 = model(&r.stream, SizeScale::ONE).unwrap().ticks;
    assert!(
        rr.model_ticks * 2 <= at1 + 4 && rr.model_ticks * 2 + 4 >= at1,
        "{} vs {at1}",
        rr.model_ticks
    );
}

#[test]
fn trace_files_parse_and_bad_lines_are_errors() {
    assert_eq!(parse_trace("# t\n10, -3\n\n20,4 # c\n").unwrap(), vec![[10, -3], [20, 4]]);
    assert!(parse_trace("10;3\n").is_err());
    assert!(parse_trace("x,3\n").is_err());
}
