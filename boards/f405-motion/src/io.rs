//! The e-stop's edge interrupt (EXTI). The capability peripherals have their own drivers
//! (`force_adc.rs`, `spindle_timer.rs`, `resolver_adc.rs`, `z_dac.rs`); the host link (USART1)
//! is `board_stm32f405::HostSerial`.

use super::pins::ESTOP;
use crate::pac;

/// E-stop input on PB12, EXTI line 12, rising edge (the normally-closed loop opened).
pub struct EStop {
    exti: pac::EXTI,
}

impl EStop {
    pub fn new(exti: pac::EXTI, syscfg: &pac::SYSCFG) -> Self {
        // EXTICR4 covers lines 12..15; port B is source 0b0001.
        let s = 4 * (ESTOP - 12);
        // SAFETY: 4-bit port selector written with a valid port (B).
        syscfg.exticr4().modify(|r, w| unsafe { w.bits((r.bits() & !(0xf << s)) | (0b0001 << s)) });
        // SAFETY: these registers hold one bit per EXTI line.
        unsafe {
            exti.rtsr().modify(|r, w| w.bits(r.bits() | 1 << ESTOP));
            exti.pr().write(|w| w.bits(1 << ESTOP));
            exti.imr().modify(|r, w| w.bits(r.bits() | 1 << ESTOP));
        }
        EStop { exti }
    }
}

impl board_contract::EStopLine for EStop {
    /// Acknowledges the interrupt; true if the e-stop line caused it.
    fn clear(&mut self) -> bool {
        let pending = self.exti.pr().read().bits() & (1 << ESTOP) != 0;
        // SAFETY: writing 1 clears only this line's pending bit.
        self.exti.pr().write(|w| unsafe { w.bits(1 << ESTOP) });
        pending
    }
}
