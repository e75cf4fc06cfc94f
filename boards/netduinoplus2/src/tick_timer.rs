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

impl TickTimer {
    pub fn new(tim: pac::TIM2, timer_clock_hz: u32, tick_hz: u32) -> Self {
        TickTimer(board_stm32f405::TickTimer::new(tim, timer_clock_hz, tick_hz))
    }
}

impl board_contract::TickTimer for TickTimer {
    type Rate = board_stm32f405::TickRate;

    fn rate_control(&self) -> Self::Rate {
        self.0.rate_control()
    }

    fn start(&mut self) {
        self.0.start()
    }

    /// Acknowledges the update interrupt and counts the tick (only the tick task calls this).
    #[inline(always)]
    fn clear_update(&mut self) {
        self.0.clear_update();
        TICKS.store(TICKS.load(Relaxed).wrapping_add(1), Relaxed);
    }

    #[inline(always)]
    fn update_pending(&self) -> bool {
        self.0.update_pending()
    }

    fn stop(&mut self) {
        self.0.stop()
    }
}
