//! Digitizer throughput (printed, not asserted: timing belongs to `cargo xtask bench`), and the
//! benchmark's output is the same contour the accuracy tests check.

#[test]
fn limacon_digitizer_throughput() {
    let (ms, events) = motionctl::polar::bench::bench_limacon();
    println!("limacon 16000 steps/rev: {events} events, median {ms:.2} ms");
    assert!(events > 19_000, "{events}");
}
