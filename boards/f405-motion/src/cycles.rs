//! DWT.CYCCNT: core clock cycles, for benchmarks.

pub struct CycleCounter;

impl CycleCounter {
    pub fn new(core: &mut cortex_m::Peripherals) -> Self {
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
        CycleCounter
    }
}

impl board_contract::CycleCounter for CycleCounter {
    #[inline(always)]
    fn now(&self) -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
}
