//! SPI1 for the external sensor options (`resolver-spi`: AD2S1210 resolver-to-digital
//! converter; `force-spi`: ADS131M04 force ADC), as a small `embedded_hal::spi::SpiDevice`
//! over the PAC: blocking byte exchanges, the chip select as a `GpioOut`, the SPI mode set per
//! device. The PAC rather than `stm32f4xx-hal`: the boards already own every peripheral
//! through the PAC (clocks, pins, the other drivers), and the HAL would bring its own clock and
//! pin setup and a second copy of the register layer for one bus that needs sixty lines.
//!
//! Pins (README.md): SCK PA5, MISO PA6, MOSI PA7 (AF5, taken from the on-chip resolver's
//! analog inputs and FORCE2, whose front ends are then off); chip select PC14. `resolver-spi`:
//! SAMPLE PC15, A0 PA2, A1 PA3. `force-spi`: DRDY PA2 (input), SYNC/RESET PC15 (held high).

use core::convert::Infallible;

#[cfg(feature = "resolver-spi")]
use board_drivers::ad2s1210::Ad2s1210;
#[cfg(feature = "force-spi")]
use board_drivers::ads131m04::Ads131m04;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::OutputPin;
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

#[cfg(feature = "force-spi")]
use super::pins::GpioIn;
use super::pins::{configure_one, GpioOut, Mode, Pin, Port};
use crate::pac;

/// Core clock, for [`CycleDelay`].
const CORE_HZ: u32 = 168_000_000;
/// CR1.BR = 0b011: PCLK2 84 MHz / 16 = 5.25 MHz (both chips take up to 25 MHz).
const BAUD_DIV16: u16 = 0b011 << 3;
const CR1_CPHA: u16 = 1 << 0;
const CR1_CPOL: u16 = 1 << 1;
const CR1_MSTR: u16 = 1 << 2;
const CR1_SPE: u16 = 1 << 6;
const CR1_SSI: u16 = 1 << 8;
const CR1_SSM: u16 = 1 << 9;
const SR_RXNE: u16 = 1 << 0;
const SR_TXE: u16 = 1 << 1;
const SR_BSY: u16 = 1 << 7;

const fn pin(name: &'static str, port: Port, pin: u8, mode: Mode) -> Pin {
    Pin { name, port, pin, mode }
}

const AF5: Mode = Mode::Alternate { af: 5, pull_up: false };
const BUS_PINS: [Pin; 4] = [
    pin("SPI1_SCK", Port::A, 5, AF5),
    pin("SPI1_MISO", Port::A, 6, Mode::Alternate { af: 5, pull_up: true }),
    pin("SPI1_MOSI", Port::A, 7, AF5),
    pin("SPI_CS", Port::C, 14, Mode::Output { high: true }),
];
#[cfg(feature = "resolver-spi")]
const RESOLVER_PINS: [Pin; 3] = [
    pin("RES_SAMPLE", Port::C, 15, Mode::Output { high: true }),
    pin("RES_A0", Port::A, 2, Mode::Output { high: false }),
    pin("RES_A1", Port::A, 3, Mode::Output { high: false }),
];
#[cfg(feature = "force-spi")]
const FORCE_PINS: [Pin; 2] = [
    pin("FORCE_DRDY", Port::A, 2, Mode::InputPullUp),
    pin("FORCE_SYNC_RESET", Port::C, 15, Mode::Output { high: true }),
];

/// The bus, configured (master, 8 bit, software NSS), before a device claims it.
pub struct Bus(pac::SPI1);

/// Clocks are on (`clocks::enable_peripherals`); configures the bus and every option pin.
pub fn init(spi: pac::SPI1, _rcc: &pac::RCC, a: &pac::GPIOA, c: &pac::GPIOC) -> Bus {
    for p in &BUS_PINS {
        configure_one(a, c, p);
    }
    #[cfg(feature = "resolver-spi")]
    for p in &RESOLVER_PINS {
        configure_one(a, c, p);
    }
    #[cfg(feature = "force-spi")]
    for p in &FORCE_PINS {
        configure_one(a, c, p);
    }
    // SAFETY: CR1 bits as RM0090 28.5.1 defines them.
    spi.cr1().write(|w| unsafe { w.bits(CR1_MSTR | BAUD_DIV16 | CR1_SSM | CR1_SSI) });
    Bus(spi)
}

/// One device on SPI1: its chip select and SPI mode.
pub struct Spi1Device {
    spi: pac::SPI1,
    cs: GpioOut,
    mode_bits: u16,
}

impl Spi1Device {
    /// `cpol`/`cpha`: the device's SPI mode.
    pub fn new(bus: Bus, cs: GpioOut, cpol: bool, cpha: bool) -> Self {
        let mode_bits = if cpol { CR1_CPOL } else { 0 } | if cpha { CR1_CPHA } else { 0 };
        Spi1Device { spi: bus.0, cs, mode_bits }
    }

    fn byte(&mut self, out: u8) -> u8 {
        while self.spi.sr().read().bits() & SR_TXE == 0 {}
        // SAFETY: DR takes any 8-bit value in 8-bit frame mode.
        self.spi.dr().write(|w| unsafe { w.bits(out as u16) });
        while self.spi.sr().read().bits() & SR_RXNE == 0 {}
        self.spi.dr().read().bits() as u8
    }
}

impl ErrorType for Spi1Device {
    type Error = Infallible;
}

impl SpiDevice<u8> for Spi1Device {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        let cr1 = CR1_MSTR | BAUD_DIV16 | CR1_SSM | CR1_SSI | self.mode_bits;
        // SAFETY: CR1 as in `init`, with this device's CPOL/CPHA, then enabled.
        self.spi.cr1().write(|w| unsafe { w.bits(cr1) });
        self.spi.cr1().write(|w| unsafe { w.bits(cr1 | CR1_SPE) });
        let Ok(()) = self.cs.set_low();
        for op in operations.iter_mut() {
            match op {
                Operation::Read(buf) => buf.iter_mut().for_each(|b| *b = self.byte(0)),
                Operation::Write(buf) => {
                    for &b in buf.iter() {
                        // The byte clocked in while writing is not wanted.
                        let _ = self.byte(b);
                    }
                }
                Operation::Transfer(read, write) => {
                    for i in 0..read.len().max(write.len()) {
                        let r = self.byte(write.get(i).copied().unwrap_or(0));
                        if let Some(slot) = read.get_mut(i) {
                            *slot = r;
                        }
                    }
                }
                Operation::TransferInPlace(buf) => {
                    buf.iter_mut().for_each(|b| *b = self.byte(*b));
                }
                Operation::DelayNs(ns) => CycleDelay.delay_ns(*ns),
            }
        }
        while self.spi.sr().read().bits() & SR_BSY != 0 {}
        let Ok(()) = self.cs.set_high();
        self.spi.cr1().write(|w| unsafe { w.bits(cr1) });
        Ok(())
    }
}

/// Busy-wait delays from the 168 MHz core clock.
pub struct CycleDelay;

impl DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        let cycles = (ns as u64 * CORE_HZ as u64).div_ceil(1_000_000_000);
        cortex_m::asm::delay(cycles.max(1) as u32);
    }
}

/// The AD2S1210 on SPI1 (SPI mode 3, as the Linux IIO driver sets it up).
#[cfg(feature = "resolver-spi")]
pub type Resolver = Ad2s1210<Spi1Device, GpioOut, GpioOut, GpioOut, CycleDelay>;

#[cfg(feature = "resolver-spi")]
pub fn resolver(bus: Bus) -> Resolver {
    let dev = Spi1Device::new(bus, GpioOut::new(Port::C, 14), true, true);
    Ad2s1210::new(
        dev,
        GpioOut::new(Port::A, 2),
        GpioOut::new(Port::A, 3),
        GpioOut::new(Port::C, 15),
        CycleDelay,
    )
}

/// The ADS131M04 on SPI1 (SPI mode 1).
#[cfg(feature = "force-spi")]
pub type ForceSpi = Ads131m04<Spi1Device, GpioIn>;

#[cfg(feature = "force-spi")]
pub fn force(bus: Bus) -> ForceSpi {
    let dev = Spi1Device::new(bus, GpioOut::new(Port::C, 14), false, true);
    Ads131m04::new(dev, GpioIn::new(Port::A, 2))
}
