//! Watchdog feeding and tick-overrun detection, pure logic. The independent watchdog is fed only
//! when the tick and the control task both checked in since the last feed, so a stuck task of
//! either kind resets the board. The overrun detector looks at the tick timer after the tick's
//! work: an update already pending again means the work took longer than a tick period.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

/// Both check-ins since the last feed. Atomics so the tick and the control task can check in from
/// their own priorities without a lock; a check-in racing a feed is at worst lost, which only
/// delays a feed (never feeds a starved watchdog).
#[derive(Debug, Default)]
pub struct WatchdogGate {
    tick: AtomicBool,
    control: AtomicBool,
    feeds: AtomicU32,
    refusals: AtomicU32,
}

impl WatchdogGate {
    pub const fn new() -> Self {
        WatchdogGate {
            tick: AtomicBool::new(false),
            control: AtomicBool::new(false),
            feeds: AtomicU32::new(0),
            refusals: AtomicU32::new(0),
        }
    }

    /// Called by the tick interrupt once per tick.
    #[inline]
    pub fn tick_alive(&self) {
        self.tick.store(true, Relaxed);
    }

    /// Called by the control task each pass of its loop.
    pub fn control_alive(&self) {
        self.control.store(true, Relaxed);
    }

    /// True when the watchdog must be fed now: both parties checked in since the last `true`.
    /// Clears both check-ins then. Call it at the feeding period (well inside the IWDG timeout).
    pub fn poll(&self) -> bool {
        if self.tick.load(Relaxed) && self.control.load(Relaxed) {
            self.tick.store(false, Relaxed);
            self.control.store(false, Relaxed);
            self.feeds.fetch_add(1, Relaxed);
            true
        } else {
            self.refusals.fetch_add(1, Relaxed);
            false
        }
    }

    /// Polls that fed.
    pub fn feeds(&self) -> u32 {
        self.feeds.load(Relaxed)
    }

    /// Polls that refused to feed (a starved party).
    pub fn refusals(&self) -> u32 {
        self.refusals.load(Relaxed)
    }
}

/// Detects a tick that overran its period.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OverrunDetector {
    overruns: u32,
}

impl OverrunDetector {
    pub const fn new() -> Self {
        OverrunDetector { overruns: 0 }
    }

    /// After the tick's work: `update_pending` is the tick timer's update flag (TIM2 UIF), which
    /// the tick cleared on entry. Set again means a whole period passed during the work. True on
    /// an overrun.
    #[inline]
    pub fn after_tick(&mut self, update_pending: bool) -> bool {
        self.overruns += update_pending as u32;
        update_pending
    }

    /// The same from a free-running cycle counter (DWT CYCCNT): cycles between tick entry and the
    /// end of its work against the period in cycles. Wrapping subtraction: no division.
    #[inline]
    pub fn after_tick_cycles(&mut self, start: u32, end: u32, period_cycles: u32) -> bool {
        self.after_tick(end.wrapping_sub(start) >= period_cycles)
    }

    pub const fn overruns(&self) -> u32 {
        self.overruns
    }
}
