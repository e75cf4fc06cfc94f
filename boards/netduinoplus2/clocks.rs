//! Clocks: the reset clock (16 MHz HSI) is kept. QEMU does not model the RCC (its registers read
//! as zero), so waiting for a PLL or HSE ready flag would hang; the peripheral clock enables are
//! still written so the same sequence is right on silicon.

use stm32f4::stm32f405 as pac;

pub struct Clocks {
    /// Input clock of TIM2..TIM5. QEMU clocks its STM32 timers at 1 GHz whatever the RCC says.
    pub tim2_hz: u32,
}

pub fn init(rcc: &pac::RCC) -> Clocks {
    rcc.apb1enr().modify(|_, w| w.tim2en().set_bit().tim5en().set_bit());
    Clocks { tim2_hz: 1_000_000_000 }
}
