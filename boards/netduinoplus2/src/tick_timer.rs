//! TIM2 as the DDA tick (the F405's driver), counting its ticks for the simulated spindle: a
//! real spindle turns with time, not with the number of times the firmware reads it, so the
//! sim turns by the ticks that passed since its last reading (`spindle.rs`). A firmware path
//! that read the spindle twice in one tick, or skipped it, would be seen as on a real board.
//! The count costs the QEMU board's tick three instructions the F405's does not have.

use core::sync::atomic::{AtomicU32, Ordering::Relaxed};

use board_stm32f405::pac;

/// Tick interrupts acknowledged since boot (wrapping).
static TICKS: AtomicU32 = AtomicU32::new(0);

/// Ticks since boot, wrapping: the sim spindle's clock.
#[inline(always)]
pub(crate) fn ticks() -> u32 {
    TICKS.load(Relaxed)
}

pub struct TickTimer(board_stm32f405::TickTimer);

/// Ticks per TIM2 update: one, or a stream's half buffer of slots (`step_stream.rs`).
#[cfg(not(feature = "step-stream"))]
const TICKS_PER_UPDATE: u32 = 1;
#[cfg(feature = "step-stream")]
const TICKS_PER_UPDATE: u32 = board_contract::STREAM_SLOTS as u32;

impl TickTimer {
    /// TIM2 at `tick_hz`, or with the streamed step output at the fill rate, `tick_hz` slots
    /// per second / `STREAM_SLOTS`.
    pub fn new(tim: pac::TIM2, timer_clock_hz: u32, tick_hz: u32) -> Self {
        let update_hz = tick_hz / TICKS_PER_UPDATE;
        TickTimer(board_stm32f405::TickTimer::new(tim, timer_clock_hz, update_hz))
    }
}

/// TIM2's rate control in ticks (slots) per second.
pub struct TickRate(board_stm32f405::TickRate);

impl board_contract::TickRate for TickRate {
    /// Whole fills per update, and an update period the timer makes exactly.
    fn supports(&self, tick_hz: u32) -> bool {
        tick_hz.is_multiple_of(TICKS_PER_UPDATE) && self.0.supports(tick_hz / TICKS_PER_UPDATE)
    }

    fn set(&mut self, tick_hz: u32) -> bool {
        self.supports(tick_hz) && self.0.set(tick_hz / TICKS_PER_UPDATE)
    }
}

impl board_contract::TickTimer for TickTimer {
    type Rate = TickRate;

    fn rate_control(&self) -> Self::Rate {
        TickRate(self.0.rate_control())
    }

    fn start(&mut self) {
        self.0.start()
    }

    /// Acknowledges the update interrupt and counts its ticks (only the tick task calls this).
    /// A stream's fill runs its slots' ticks at once, as on a board whose DMA plays them: the
    /// spindle, read on each, turns by the whole fill at its start.
    #[inline(always)]
    fn clear_update(&mut self) {
        self.0.clear_update();
        TICKS.store(TICKS.load(Relaxed).wrapping_add(TICKS_PER_UPDATE), Relaxed);
    }

    #[inline(always)]
    fn update_pending(&self) -> bool {
        self.0.update_pending()
    }

    fn stop(&mut self) {
        self.0.stop()
    }
}
