//! STEP/DIR outputs on GPIOC through BSRR (atomic set/reset, no read-modify-write), in the order
//! the DDA requires: falling edges, DIR writes, rising edges: one word store each, whatever the
//! number of axes. The shared driver enable is an `OutputPin`.

use super::pins::{GpioOut, DIR_SHIFT, DRV_EN_N, STEP_SHIFT};
use crate::pac;
use embedded_hal::digital::OutputPin;
use motion::StepOutput;

pub struct StepPort {
    gpio: pac::GPIOC,
    /// DRV_EN_N: active low.
    enable_n: GpioOut,
}

impl StepPort {
    pub fn new(gpio: pac::GPIOC, enable_n: GpioOut) -> Self {
        StepPort { gpio, enable_n }
    }
}

impl board_contract::StepPort for StepPort {
    #[inline(always)]
    fn write(&mut self, out: &StepOutput) {
        let bsrr = self.gpio.bsrr();
        let (set, reset) = (out.dir() & out.dir_write(), !out.dir() & out.dir_write());
        // SAFETY: BSRR accepts any bit pattern; only STEP/DIR bits are ever set here.
        unsafe {
            bsrr.write(|w| w.bits((out.fall() as u32) << (STEP_SHIFT + 16)));
            bsrr.write(|w| w.bits((set as u32) << DIR_SHIFT | (reset as u32) << (DIR_SHIFT + 16)));
            bsrr.write(|w| w.bits((out.rise() as u32) << STEP_SHIFT));
        }
    }

    /// Drivers on (DRV_EN_N low).
    fn enable(&mut self) {
        let Ok(()) = self.enable_n.set_low();
    }

    /// Drivers off and STEP low.
    fn disable(&mut self) {
        force_safe();
    }
}

/// Drivers disabled and every STEP low, from any context (panic, fault, e-stop).
pub fn force_safe() {
    // SAFETY: single BSRR writes are atomic and only touch the driver-enable and STEP bits.
    unsafe {
        let b = &*pac::GPIOB::ptr();
        b.bsrr().write(|w| w.bits(1 << DRV_EN_N));
        let c = &*pac::GPIOC::ptr();
        c.bsrr().write(|w| w.bits(0x3f << (STEP_SHIFT + 16)));
    }
}
