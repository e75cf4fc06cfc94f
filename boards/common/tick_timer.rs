//! TIM2 as the DDA tick: a 32-bit up-counter whose update interrupt fires at `tick_hz`.
//! Shared by every board; only the timer input clock differs.

use stm32f4::stm32f405 as pac;

pub struct TickTimer {
    tim: pac::TIM2,
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
        TickTimer { tim }
    }

    pub fn start(&mut self) {
        self.tim.cnt().write(|w| w.cnt().set(0));
        self.tim.dier().write(|w| w.uie().enabled());
        self.tim.cr1().modify(|_, w| w.cen().enabled());
    }

    /// Acknowledges the update interrupt; call first thing in the tick handler.
    #[inline(always)]
    pub fn clear_update(&mut self) {
        self.tim.sr().write(|w| w.uif().clear());
    }

    /// Stops ticking for good (end of job, e-stop).
    pub fn stop(&mut self) {
        self.tim.cr1().modify(|_, w| w.cen().disabled());
        self.tim.dier().write(|w| w.uie().disabled());
        self.tim.sr().write(|w| w.uif().clear());
    }
}
