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

/// The IWDG as the host models it: a down-counter in milliseconds, reloaded by a feed; at zero
/// it resets the MCU, which sets IWDGRSTF (and PINRSTF: the internal reset drives NRST) in
/// RCC_CSR.
struct SimIwdg {
    timeout_ms: u32,
    left_ms: u32,
}

impl SimIwdg {
    /// One millisecond; the csr flags of the reset if it expired.
    fn ms(&mut self, fed: bool) -> Option<u32> {
        use motion::machine::reset_cause::rcc_csr::{IWDGRSTF, PINRSTF};
        if fed {
            self.left_ms = self.timeout_ms;
        }
        self.left_ms = self.left_ms.saturating_sub(1);
        (self.left_ms == 0).then_some(IWDGRSTF | PINRSTF)
    }
}

/// Starve the control task: the gate stops feeding, the (simulated) IWDG resets the board, and
/// the board boots with the reset cause into `Fault` with `WatchdogReset` first; a normal
/// power-on with the same config boots into `Idle`.
#[test]
fn starved_gate_resets_and_the_next_boot_latches_watchdog_reset() {
    use motion::dda::Dda;
    use motion::machine::reset_cause::rcc_csr::{BORRSTF, PINRSTF, PORRSTF};
    use motion::machine::{Machine, MachineCommand, MachineState, ResetCause};
    use motion::protocol::FaultCode;
    use motion::scenarios::faults::{config, Case};

    // 100 ms timeout, polled every 10 ms (the firmware's figures: well inside the timeout).
    const TIMEOUT_MS: u32 = 100;
    const POLL_MS: u32 = 10;
    let g = WatchdogGate::new();
    let mut iwdg = SimIwdg { timeout_ms: TIMEOUT_MS, left_ms: TIMEOUT_MS };
    let mut reset = None;
    for ms in 0..1_000u32 {
        // The tick runs every ms; the control task stops at 300 ms.
        g.tick_alive();
        if ms < 300 {
            g.control_alive();
        }
        let fed = ms % POLL_MS == 0 && g.poll();
        if let Some(csr) = iwdg.ms(fed) {
            reset = Some((ms, csr));
            break;
        }
    }
    let (at_ms, csr) = reset.expect("the starved watchdog reset the board");
    // The last feed is the first poll after the control task's last check-in (299 ms): the
    // reset comes one timeout after it (the counter reloads, then counts down every ms).
    let last_feed = 299u32.next_multiple_of(POLL_MS);
    assert_eq!(at_ms, last_feed + TIMEOUT_MS - 1);
    assert!(g.refusals() >= (TIMEOUT_MS / POLL_MS) - 1);

    let cfg = config(Case::EStop);
    let mut m = Machine::new();
    let cause = ResetCause::from_rcc_csr(csr);
    assert_eq!(cause, ResetCause::IndependentWatchdog);
    assert_eq!(m.boot_after_reset(Ok(cfg), cause), MachineState::Fault);
    assert_eq!(m.faults().first(), Some(FaultCode::WatchdogReset));
    assert_eq!(m.faults().mask(), FaultCode::WatchdogReset.bit());
    assert_eq!(*m.config(), cfg, "the stored config still loads");
    assert_eq!(m.positions(), [0; 6], "counters start at zero after a reset");
    // An event, not a level: ClearFault at once, to Idle (a reset loses the homing).
    let mut dda = Dda::new(&cfg.link.machine).unwrap();
    assert_eq!(m.command(MachineCommand::ClearFault, &mut dda), Ok(MachineState::Idle));

    // The same boot after a power-on: no fault.
    let mut m = Machine::new();
    let cause = ResetCause::from_rcc_csr(PORRSTF | PINRSTF | BORRSTF);
    assert_eq!(m.boot_after_reset(Ok(cfg), cause), MachineState::Idle);
    assert!(m.faults().is_clear());
    // A watchdog reset with the config also gone: both latched, the watchdog first.
    let mut m = Machine::new();
    m.boot_after_reset(Err(motion::machine::BootConfig::Missing), ResetCause::IndependentWatchdog);
    assert_eq!(m.faults().first(), Some(FaultCode::WatchdogReset));
    assert!(m.faults().has(FaultCode::ConfigMissing));
}
