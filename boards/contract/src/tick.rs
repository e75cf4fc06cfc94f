//! The DDA tick timer and the watchdog.

/// The timer whose update interrupt is the DDA tick.
pub trait TickTimer {
    type Rate: TickRate;
    /// Counting from 0 with the update interrupt on.
    fn start(&mut self);
    /// Stops ticking and clears a pending update.
    fn stop(&mut self);
    /// Acknowledges the update interrupt: first thing in the tick handler.
    fn clear_update(&mut self);
    /// The update flag is set again: read after the tick's work, a whole period passed
    /// during it (an overrun).
    fn update_pending(&self) -> bool;
    /// A handle that retimes the tick from another task (take at most one).
    fn rate_control(&self) -> Self::Rate;
}

/// Changes the tick rate while the timer runs; the tick in progress keeps its length.
pub trait TickRate {
    /// The timer can tick at exactly `tick_hz`.
    fn supports(&self, tick_hz: u32) -> bool;
    /// Sets the rate; false (nothing changed) when not [`TickRate::supports`].
    fn set(&mut self, tick_hz: u32) -> bool;
}

/// The independent watchdog.
pub trait Watchdog {
    /// Starts it with a nominal timeout; it cannot be stopped.
    fn start(&mut self, timeout_ms: u32);
    fn feed(&mut self);
    /// Runs `f` (a flash erase, during which nothing can feed) with the timeout stretched.
    fn stretch<R>(&mut self, f: impl FnOnce() -> R) -> R;
}
