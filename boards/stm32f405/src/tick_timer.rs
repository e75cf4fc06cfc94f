//! TIM2 as the DDA tick: a 32-bit up-counter whose update interrupt fires at `tick_hz`.
//! Shared by both boards; only the timer input clock differs.

use crate::pac;

pub struct TickTimer {
    tim: pac::TIM2,
    timer_clock_hz: u32,
}

impl TickTimer {
    /// Configures (but does not start) TIM2 for `tick_hz` from a `timer_clock_hz` input clock.
    /// Panics if the tick rate is not an exact divisor of the timer clock: a rounded tick would
    /// make every duration in the job slightly wrong.
    pub fn new(tim: pac::TIM2, timer_clock_hz: u32, tick_hz: u32) -> Self {
        let period = timer_clock_hz / tick_hz;
        assert!(
            period >= 2 && period * tick_hz == timer_clock_hz,
            "tick_hz must divide the timer clock"
        );
        // TIM2 is 32 bits wide: no prescaler needed for any supported tick rate.
        // SAFETY: any 16-bit prescaler value is valid.
        tim.psc().write(|w| unsafe { w.bits(0) });
        tim.arr().write(|w| w.arr().set(period - 1));
        // Only counter overflow raises an update interrupt, not the UG below.
        tim.cr1().write(|w| w.urs().counter_only().arpe().enabled());
        tim.egr().write(|w| w.ug().set_bit());
        tim.sr().write(|w| w.uif().clear());
        TickTimer { tim, timer_clock_hz }
    }
}

impl board_contract::TickTimer for TickTimer {
    type Rate = TickRate;

    /// A handle that changes the tick rate while the timer runs (the host link's SetConfig).
    /// Take at most one.
    fn rate_control(&self) -> TickRate {
        TickRate { timer_clock_hz: self.timer_clock_hz }
    }

    fn start(&mut self) {
        self.tim.cnt().write(|w| w.cnt().set(0));
        self.tim.dier().write(|w| w.uie().enabled());
        self.tim.cr1().modify(|_, w| w.cen().enabled());
    }

    /// Acknowledges the update interrupt; call first thing in the tick handler.
    #[inline(always)]
    fn clear_update(&mut self) {
        self.tim.sr().write(|w| w.uif().clear());
    }

    /// The update flag is set again: read after the tick's work, a whole period passed during
    /// it (an overrun; `motion::machine::OverrunDetector`).
    #[inline(always)]
    fn update_pending(&self) -> bool {
        self.tim.sr().read().uif().bit_is_set()
    }

    /// Stops ticking for good (end of the demo job). The link firmware never stops its tick:
    /// the machine keeps watching its inputs while idle.
    fn stop(&mut self) {
        self.tim.cr1().modify(|_, w| w.cen().disabled());
        self.tim.dier().write(|w| w.uie().disabled());
        self.tim.sr().write(|w| w.uif().clear());
    }
}

/// Changes TIM2's period from outside the tick task. ARR is preloaded (ARPE), so a new period
/// takes effect at the next update: the tick in progress keeps its length.
pub struct TickRate {
    timer_clock_hz: u32,
}

impl board_contract::TickRate for TickRate {
    /// True if `tick_hz` divides the timer clock exactly (see [`TickTimer::new`]) and an
    /// interrupt per tick is asked for at most [`motion::config::MAX_TICK_HZ`].
    fn supports(&self, tick_hz: u32) -> bool {
        tick_hz != 0
            && tick_hz <= motion::config::MAX_TICK_HZ
            && self.timer_clock_hz.is_multiple_of(tick_hz)
            && self.timer_clock_hz / tick_hz >= 2
    }

    /// Sets the tick rate; false (nothing changed) if [`TickRate::supports`] says no.
    fn set(&mut self, tick_hz: u32) -> bool {
        if !self.supports(tick_hz) {
            return false;
        }
        // SAFETY: a single write of the (preloaded) auto-reload register; the tick task owns the
        // rest of TIM2 and never writes ARR after init.
        let tim = unsafe { &*pac::TIM2::ptr() };
        tim.arr().write(|w| w.arr().set(self.timer_clock_hz / tick_hz - 1));
        true
    }
}
