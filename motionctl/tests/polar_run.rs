//! `motionctl polar run` against the in-process board (`BoardLink` + `SimTarget`, whose event
//! playback is the firmware's `EventFeed` + `Playback` code): the built-in limacon stream
//! (19036 events) through a 1 % byte-noise proxy arrives block by block under the event
//! credits, every event fires exactly once, and the final (theta, r) steps equal the host model.

use motion::polar::limacon_stream::BYTES;
use motion::polar::playback::SizeScale;
use motion::polar::stream::decode_all;
use motion::protocol::HostConfig;
use motionctl::noise::Noisy;
use motionctl::polar::run::{self, PolarRunOptions};
use motionctl::polar::sim::EventSim;

fn opts(speed: f64, m: u8, k: u8) -> PolarRunOptions {
    PolarRunOptions {
        speed,
        scale: SizeScale::new(m, k).unwrap(),
        host: HostConfig { rto_ms: 30, window: 8 },
        home: true,
        progress: false,
    }
}

#[test]
fn limacon_stream_plays_exactly_through_a_noisy_link() {
    let mut events = 0u32;
    decode_all(BYTES, |_| events += 1).unwrap();
    // 4x machine time (8x real playback at speed 2): the 8-block queue still covers ~0.2 s of
    // wall time, several retransmission timeouts.
    let mut t = Noisy::new(EventSim::new(1.0), 0.01, 7);
    let o = opts(2.0, 3, 2);
    let r = run::run(&mut t, BYTES, &o).unwrap();
    eprintln!("{}", r.machine_line());
    assert!(r.ok(), "{:?}", r.problems);
    assert_eq!((r.events, r.events_fired), (events, events));
    let model = run::model(BYTES, motion::Rate::from_num(2.0), o.scale).unwrap();
    assert_eq!(r.positions, model.positions);
    assert!(r.blocks > 8, "more blocks than the board holds: {}", r.blocks);
    assert!(r.retransmissions > 0 || r.bad_frames_in > 0, "the noise was felt");
}

#[test]
fn size_scale_changes_the_radial_steps_by_m_over_k() {
    // An open stretch of the stream (its first 20 blocks, the last one marked last): the
    // radial travel scales by m/k (to within the Bresenham remainder), theta not at all.
    let part = run::first_blocks(BYTES, 20).unwrap();
    let one = run::model(&part, motion::Rate::ONE, SizeScale::ONE).unwrap();
    for (m, k) in [(1u8, 4u8), (3, 2), (4, 1)] {
        let mut t = EventSim::new(24.0);
        let r = run::run(&mut t, &part, &opts(1.0, m, k)).unwrap();
        assert!(r.ok(), "{m}:{k} {:?}", r.problems);
        assert_eq!(r.positions[0], one.positions[0], "{m}:{k}");
        let want = one.positions[1] * m as i64;
        assert!((r.positions[1] * k as i64 - want).abs() < k as i64, "{m}:{k}: {:?}", r.positions);
    }
}
