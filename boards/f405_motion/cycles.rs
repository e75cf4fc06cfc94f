//! DWT.CYCCNT: core clock cycles, for benchmarks.
// Only the bench firmware reads the counter.
#![cfg_attr(feature = "link", allow(dead_code))]

pub struct CycleCounter;

impl CycleCounter {
    pub fn new(core: &mut cortex_m::Peripherals) -> Self {
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
        CycleCounter
    }

    #[inline(always)]
    pub fn now(&self) -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
}
