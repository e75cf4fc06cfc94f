//! The `isr-cycles` measurement of the link firmware: the TIM2 handler reads the board's cycle
//! counter (DWT CYCCNT on the F405; TIM5 under QEMU, which with `-icount shift=0` counts
//! instructions) on entry and before it returns and records the difference in [`BINS`]; the
//! status task ([`Logger::poll`], once per millisecond) logs the run so far every 100 ms over
//! defmt:
//!
//! ```text
//! isr-cycles since boot: 100000 runs, mean 640, p50 640, p99 1184, max 1950, cpu 381 per mille at 100000 Hz
//! ```
//!
//! The figures cover the handler from its first to its last instruction; the exception entry
//! and return (12 + 10 cycles on a Cortex-M4 with no FPU state to stack) come on top.
//! Without the feature nothing is recorded and [`Logger`] is empty.

#[cfg(feature = "isr-cycles")]
mod on {
    use motion::cycle_histogram::{CycleBins, CycleHistogram};

    /// The handler's bins.
    pub static BINS: CycleBins = CycleBins::new();

    /// Status-task polls between two log lines (the task runs 1000 times a second): 100 ms, so
    /// a short job logs too.
    const POLLS_PER_LOG: u32 = 100;
    /// The core clock the CPU share is computed against (168 MHz, the F405's).
    const CORE_HZ: u32 = 168_000_000;

    pub struct Logger {
        polls: u32,
        total: CycleHistogram,
    }

    impl Default for Logger {
        fn default() -> Self {
            Self::new()
        }
    }

    impl Logger {
        pub const fn new() -> Self {
            const EMPTY: CycleHistogram = CycleHistogram {
                bins: [0; motion::cycle_histogram::BINS],
                count: 0,
                sum: 0,
                max: 0,
            };
            Logger { polls: 0, total: EMPTY }
        }

        /// Once per status-task run: every 100 ms, the run so far.
        pub fn poll(&mut self, tick_hz: u32) {
            self.polls += 1;
            if self.polls < POLLS_PER_LOG {
                return;
            }
            self.polls = 0;
            BINS.drain_into(&mut self.total);
            log("since boot", &self.total, tick_hz);
        }
    }

    fn log(what: &str, h: &CycleHistogram, tick_hz: u32) {
        defmt::println!(
            "isr-cycles {=str}: {=u64} runs, mean {=u64}, p50 {=u32}, p99 {=u32}, max {=u32}, \
             cpu {=u64} per mille at {=u32} Hz",
            what,
            h.count,
            h.mean(),
            h.percentile(500),
            h.percentile(990),
            h.max,
            h.cpu_per_mille(tick_hz, CORE_HZ),
            tick_hz
        );
    }
}

#[cfg(feature = "isr-cycles")]
pub use on::{Logger, BINS};

/// Without the feature: nothing to log.
#[cfg(not(feature = "isr-cycles"))]
#[derive(Default)]
pub struct Logger;

#[cfg(not(feature = "isr-cycles"))]
impl Logger {
    pub const fn new() -> Self {
        Logger
    }

    #[inline(always)]
    pub fn poll(&mut self, _tick_hz: u32) {}
}
