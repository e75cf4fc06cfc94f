//! STEP/DIR outputs on GPIOC through BSRR (atomic set/reset, no read-modify-write), in the order
//! the DDA requires: falling edges, DIR writes, rising edges. Every output is also recorded into a
//! [`StepRecorder`] (two branches when nothing rises) so the end-of-job report works on hardware
//! exactly as it does under QEMU.

use super::pins::{DIR_SHIFT, DRV_EN_N, STEP_SHIFT};
use motion::trace::StepRecorder;
use motion::StepOutput;
use stm32f4::stm32f405 as pac;

pub struct StepPort {
    gpio: pac::GPIOC,
    enable: pac::GPIOB,
    recorder: StepRecorder,
}

impl StepPort {
    pub fn new(gpio: pac::GPIOC, enable: pac::GPIOB) -> Self {
        StepPort { gpio, enable, recorder: StepRecorder::new() }
    }

    /// Drivers on (DRV_EN_N low).
    pub fn enable(&mut self) {
        // SAFETY: BSRR accepts any bit pattern.
        self.enable.bsrr().write(|w| unsafe { w.bits(1 << (DRV_EN_N + 16)) });
    }

    /// Drivers off and STEP low.
    pub fn disable(&mut self) {
        force_safe();
    }

    #[inline(always)]
    pub fn apply(&mut self, now: u64, out: &StepOutput) {
        let bsrr = self.gpio.bsrr();
        let (set, reset) = (out.dir() & out.dir_write(), !out.dir() & out.dir_write());
        // SAFETY: BSRR accepts any bit pattern; only STEP/DIR bits are ever set here.
        unsafe {
            bsrr.write(|w| w.bits((out.fall() as u32) << (STEP_SHIFT + 16)));
            bsrr.write(|w| w.bits((set as u32) << DIR_SHIFT | (reset as u32) << (DIR_SHIFT + 16)));
            bsrr.write(|w| w.bits((out.rise() as u32) << STEP_SHIFT));
        }
        self.recorder.record(now, out);
    }

    // The link firmware reports positions from the machine's counters, not the recorder.
    #[cfg_attr(feature = "link", allow(dead_code))]
    pub fn recorder(&self) -> &StepRecorder {
        &self.recorder
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
