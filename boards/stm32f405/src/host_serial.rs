//! USART1 as the host link: 8N1, interrupt driven, no DMA (QEMU does not model it). The driver
//! only moves bytes; framing and buffering live in the firmware (`firmware/src/link/`).
//!
//! Errors: an overrun, framing or noise error is cleared by the SR-then-DR read every
//! [`HostSerial::read_byte`] does; the byte stream then has a hole that the frame CRC catches
//! (the host retransmits). [`HostSerial::overruns`] counts overruns.
//!
//! QEMU 7.2 models RXNE and its interrupt; its TX is synchronous (TXE always reads as set) and it
//! raises no TXE interrupt, so transmitting must start by writing while [`HostSerial::write_byte`]
//! succeeds and only rely on the TXE interrupt for the rest (which then never arrives, and is not
//! needed, under QEMU).
use crate::pac;

pub struct HostSerial {
    usart: pac::USART1,
    overruns: u32,
}

impl HostSerial {
    /// 8N1 at `baud` from the `pclk2_hz` APB2 clock (16x oversampling), transmitter and receiver
    /// on, interrupts off. The USART1 clock gate must already be enabled.
    pub fn new(usart: pac::USART1, pclk2_hz: u32, baud: u32) -> Self {
        // USARTDIV in 12.4 fixed point is pclk / baud, rounded.
        let brr = (pclk2_hz + baud / 2) / baud;
        // SAFETY: BRR holds mantissa and fraction of USARTDIV (16x oversampling); the rates in use
        // give 139 (16 MHz, 115200) and 182 (84 MHz, 460800).
        usart.brr().write(|w| unsafe { w.bits(brr as u16) });
        usart.cr1().write(|w| w.ue().set_bit().te().set_bit().re().set_bit());
        HostSerial { usart, overruns: 0 }
    }
}

impl board_contract::HostSerial for HostSerial {
    /// The received byte, if one is waiting. Reading SR then DR also clears ORE/FE/NE.
    #[inline]
    fn read_byte(&mut self) -> Option<u8> {
        let sr = self.usart.sr().read();
        if sr.ore().bit_is_set() {
            self.overruns = self.overruns.wrapping_add(1);
        }
        if sr.rxne().bit_is_set() || sr.ore().bit_is_set() {
            Some(self.usart.dr().read().bits() as u8)
        } else {
            None
        }
    }

    /// Writes `byte` if the transmit register is empty; false (nothing written) otherwise.
    #[inline]
    fn write_byte(&mut self, byte: u8) -> bool {
        if self.usart.sr().read().txe().bit_is_clear() {
            return false;
        }
        // SAFETY: DR takes any 8-bit value in 8N1 mode.
        self.usart.dr().write(|w| unsafe { w.bits(byte as u16) });
        true
    }

    /// RXNE (and overrun) interrupt on.
    fn listen_rx(&mut self) {
        self.usart.cr1().modify(|_, w| w.rxneie().set_bit());
    }

    /// TXE interrupt on or off (call with the port's owner locked: CR1 is read-modify-written).
    #[inline]
    fn listen_tx(&mut self, on: bool) {
        self.usart.cr1().modify(|_, w| w.txeie().bit(on));
    }

    /// Receive overruns seen so far (bytes lost because the ISR was late).
    fn overruns(&self) -> u32 {
        self.overruns
    }
}
