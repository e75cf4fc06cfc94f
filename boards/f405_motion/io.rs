//! The board's other I/O, configured at init so later features find it ready: e-stop (EXTI),
//! spindle encoder (TIM4) and force sensors (ADC1). The host link (USART1) is
//! `../common/host_serial.rs`.

use super::pins::{ESTOP, FORCE_CHANNELS};
use stm32f4::stm32f405 as pac;

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

    /// Acknowledges the interrupt; true if the e-stop line caused it.
    pub fn clear(&mut self) -> bool {
        let pending = self.exti.pr().read().bits() & (1 << ESTOP) != 0;
        // SAFETY: writing 1 clears only this line's pending bit.
        self.exti.pr().write(|w| unsafe { w.bits(1 << ESTOP) });
        pending
    }
}

/// TIM4 in encoder mode 3 (counts both edges of both channels), 16-bit wrap-around count.
pub fn init_spindle_encoder(tim: &pac::TIM4) {
    // SAFETY: CC1S/CC2S = 01 (TI1/TI2 inputs), IC filter 0b0011 (8 samples); SMS = 011.
    unsafe {
        tim.ccmr1_input().write(|w| w.bits(0b01 | 0b0011 << 4 | 0b01 << 8 | 0b0011 << 12));
        tim.smcr().write(|w| w.bits(0b011));
    }
    tim.arr().write(|w| w.arr().set(0xffff));
    tim.cr1().write(|w| w.cen().enabled());
}

/// ADC1 on, 12 bit, clocked at PCLK2/4 = 21 MHz, 84-cycle sampling on the force channels.
pub fn init_force_adc(adc: &pac::ADC1, common: &pac::ADC_COMMON) {
    common.ccr().modify(|_, w| w.adcpre().div4());
    for ch in FORCE_CHANNELS {
        let s = 3 * ch as u32;
        // SAFETY: SMP = 0b100 (84 cycles) for channels 0..9 in SMPR2.
        adc.smpr2().modify(|r, w| unsafe { w.bits((r.bits() & !(0b111 << s)) | (0b100 << s)) });
    }
    adc.cr2().modify(|_, w| w.adon().set_bit());
}
