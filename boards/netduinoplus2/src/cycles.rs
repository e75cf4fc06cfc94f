//! TIM5 free-running at the 1 GHz QEMU timer clock. Under `-icount shift=0` one instruction
//! takes exactly 1 ns of virtual time, so the counter counts executed instructions.

use crate::pac;

pub struct CycleCounter {
    tim: pac::TIM5,
}

impl CycleCounter {
    pub fn new(tim: pac::TIM5) -> Self {
        // SAFETY: 0 is a valid prescaler.
        tim.psc().write(|w| unsafe { w.bits(0) });
        tim.arr().write(|w| w.arr().set(u32::MAX));
        tim.egr().write(|w| w.ug().set_bit());
        tim.cr1().write(|w| w.cen().enabled());
        CycleCounter { tim }
    }
}

impl board_contract::CycleCounter for CycleCounter {
    /// Current count; differences wrap correctly for intervals below 2^32.
    #[inline(always)]
    fn now(&self) -> u32 {
        self.tim.cnt().read().bits()
    }
}
