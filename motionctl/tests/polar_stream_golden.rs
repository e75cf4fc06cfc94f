//! Regenerates the built-in limacon stream (src/polar/limacon_stream.bin) from the digitizer and
//! fails if the checked-in file differs; REGENERATE=1 rewrites it.

use motion::polar::stream::BlockEncoder;
use motionctl::polar::contour::{Limacon, Polar};
use motionctl::polar::digitize::{digitize, FeedAt, Setup};
use motionctl::polar::work_area::WorkArea;
use motionctl::polar::Resolution;

fn generate() -> Vec<u8> {
    let lim = Polar::closed(Limacon { b: 3.0, a: 2.0 });
    // The thesis's maximum contouring speed, 1.746 cm/s.
    let setup = Setup {
        pole_r_in: 6.5,
        pole_angle_rad: 70f64.to_radians(),
        tool_radius_in: 0.125,
        vt_in_per_s: 1.746 / 2.54,
        res: Resolution::THESIS,
        tick_hz: motion::polar::scenario::TICK_HZ,
        cap_speed: true,
        area: WorkArea::FAHIM_1983,
        feed_at: FeedAt::Centre,
    };
    let d = digitize(&lim, &setup).unwrap();
    let mut bytes = Vec::new();
    let mut enc = BlockEncoder::new();
    for &e in &d.events {
        enc.push(e, &mut |b: &[u8]| bytes.extend_from_slice(b)).unwrap();
    }
    enc.finish(&mut |b: &[u8]| bytes.extend_from_slice(b));
    assert_eq!(d.events.len(), 19_036, "src/polar/limacon_stream.rs documents the event count");
    bytes
}

#[test]
fn limacon_stream_is_current() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../src/polar/limacon_stream.bin");
    let want = generate();
    if std::env::var("REGENERATE").is_ok_and(|v| v == "1") {
        std::fs::write(path, &want).unwrap();
    }
    let have = std::fs::read(path).unwrap();
    assert!(have == want, "src/polar/limacon_stream.bin is stale: run with REGENERATE=1");
    assert_eq!(motion::polar::limacon_stream::BYTES, &want[..]);
}
