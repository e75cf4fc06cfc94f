//! 168 MHz from the 8 MHz HSE crystal: PLL M=8 N=336 P=2 (VCO 336 MHz), Q=7 (48 MHz USB/SDIO).
//! AHB /1 = 168 MHz, APB1 /4 = 42 MHz (its timers run at 2x = 84 MHz), APB2 /2 = 84 MHz.

use crate::pac;

pub struct Clocks {
    pub pclk2_hz: u32,
    /// TIM2..TIM7, TIM12..14: twice PCLK1 because the APB1 prescaler is not 1.
    pub apb1_timer_hz: u32,
    /// TIM1, TIM8..TIM11: twice PCLK2 because the APB2 prescaler is not 1.
    pub apb2_timer_hz: u32,
}

pub fn init(rcc: &pac::RCC, pwr: &pac::PWR, flash: &pac::FLASH) -> Clocks {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    while rcc.cr().read().hserdy().bit_is_clear() {}

    // Scale 1 regulator output: required above 144 MHz.
    rcc.apb1enr().modify(|_, w| w.pwren().set_bit());
    pwr.cr().modify(|_, w| w.vos().set_bit());

    // SAFETY: M, N and Q are within their documented ranges (M 2..=63, N 50..=432, Q 2..=15).
    rcc.pllcfgr().write(|w| unsafe {
        w.pllsrc().hse().pllm().bits(8).plln().bits(336).pllp().div2().pllq().bits(7)
    });
    rcc.cr().modify(|_, w| w.pllon().set_bit());
    while rcc.cr().read().pllrdy().bit_is_clear() {}

    // 5 wait states at 168 MHz and 2.7-3.6 V, before the clock goes up.
    flash
        .acr()
        .modify(|_, w| w.latency().ws5().prften().set_bit().icen().set_bit().dcen().set_bit());
    while !flash.acr().read().latency().is_ws5() {}

    rcc.cfgr().modify(|_, w| w.hpre().div1().ppre1().div4().ppre2().div2());
    rcc.cfgr().modify(|_, w| w.sw().pll());
    while !rcc.cfgr().read().sws().is_pll() {}

    Clocks { pclk2_hz: 84_000_000, apb1_timer_hz: 84_000_000, apb2_timer_hz: 168_000_000 }
}

/// Clock gates of every peripheral the board uses.
pub fn enable_peripherals(rcc: &pac::RCC) {
    rcc.ahb1enr().modify(|_, w| {
        w.gpioaen().set_bit().gpioben().set_bit().gpiocen().set_bit().gpioden().set_bit();
        // DMA2: stream 0 carries the force ADC's scans.
        w.dma2en().set_bit()
    });
    rcc.apb1enr().modify(|_, w| {
        w.tim2en().set_bit().tim4en().set_bit();
        // DAC: Z slide.
        w.dacen().set_bit()
    });
    rcc.apb2enr().modify(|_, w| {
        w.usart1en().set_bit().adc1en().set_bit().syscfgen().set_bit();
        // TIM8: force ADC trigger.
        w.tim8en().set_bit();
        // ADC2: resolver sin/cos; SPI1: the external converters of the SPI options.
        w.adc2en()
            .set_bit()
            .spi1en()
            .bit(cfg!(any(feature = "resolver-spi", feature = "force-spi")))
    });
    // Read back so the enables have taken effect before the first register access (errata 2.2.13).
    let _ = rcc.ahb1enr().read();
    let _ = rcc.apb1enr().read();
    let _ = rcc.apb2enr().read();
}
