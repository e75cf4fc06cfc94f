//! Watchdog feeding gate and tick-overrun detector.

use motion::machine::{OverrunDetector, WatchdogGate};
use proptest::prelude::*;

#[test]
fn fed_only_when_both_checked_in() {
    let g = WatchdogGate::new();
    assert!(!g.poll());
    for _ in 0..10 {
        g.tick_alive();
    }
    // Control task starved: never fed however often the tick runs.
    for _ in 0..5 {
        g.tick_alive();
        assert!(!g.poll());
    }
    g.control_alive();
    assert!(g.poll());
    // Both check-ins were used up by that feed.
    assert!(!g.poll());
    // Tick starved.
    for _ in 0..5 {
        g.control_alive();
        assert!(!g.poll());
    }
    assert_eq!((g.feeds(), g.refusals()), (1, 12));
}

proptest! {
    /// Any interleaving: a poll feeds exactly when both parties checked in since the last feed.
    #[test]
    fn feeds_iff_both_alive_since_last_feed(events in prop::collection::vec(0u8..3, 0..200)) {
        let g = WatchdogGate::new();
        let (mut t, mut c) = (false, false);
        for e in events {
            match e {
                0 => { g.tick_alive(); t = true; }
                1 => { g.control_alive(); c = true; }
                _ => {
                    let want = t && c;
                    prop_assert_eq!(g.poll(), want);
                    if want { t = false; c = false; }
                }
            }
        }
    }
}

#[test]
fn overrun_from_pending_flag_and_cycle_counter() {
    let mut d = OverrunDetector::new();
    assert!(!d.after_tick(false));
    assert!(d.after_tick(true));
    // 168 MHz / 50 kHz = 3360 cycles per tick; the counter wraps between entry and exit.
    let period = 168_000_000 / 50_000;
    assert!(!d.after_tick_cycles(u32::MAX - 100, 3_000, period));
    assert!(d.after_tick_cycles(u32::MAX - 100, period, period));
    assert_eq!(d.overruns(), 2);
}
