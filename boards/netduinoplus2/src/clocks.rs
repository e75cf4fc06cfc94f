//! Clocks: the reset clock (16 MHz HSI) is kept. QEMU does not model the RCC (its registers read
//! as zero), so waiting for a PLL or HSE ready flag would hang; the peripheral clock enables are
//! still written so the same sequence is right on silicon.

use crate::pac;

pub struct Clocks {
    /// Input clock of TIM2..TIM5. QEMU clocks its STM32 timers at 1 GHz whatever the RCC says.
    pub tim2_hz: u32,
    /// APB2 (USART1) clock: the 16 MHz HSI, undivided after reset. QEMU ignores the baud rate.
    pub pclk2_hz: u32,
}

pub fn init(rcc: &pac::RCC) -> Clocks {
    rcc.apb1enr().modify(|_, w| w.tim2en().set_bit().tim5en().set_bit());
    rcc.apb2enr().modify(|_, w| w.usart1en().set_bit());
    // Read back so the enables have taken effect before the first register access (errata 2.2.13).
    let _ = rcc.apb2enr().read();
    Clocks { tim2_hz: 1_000_000_000, pclk2_hz: 16_000_000 }
}
