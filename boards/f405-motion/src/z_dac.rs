//! Z-slide command on DAC channel 1 (PA4 = DAC_OUT1): 12-bit right-aligned, output buffer on
//! (drives the amplifier input directly), no trigger (each write reaches the pin one APB1 clock
//! later). The range check is `motion::turning::dac_code`; registers only here.

use crate::pac;
use motion::machine::Z_DAC_MID_SCALE;
use motion::protocol::errors::FaultCode;
use motion::turning::dac_code::dac_register_value;

/// DAC channel 1.
pub struct ZDac {
    dac: pac::DAC,
}

impl ZDac {
    /// Channel 1 on at mid-scale (the slide's rest position): the data register is loaded
    /// before the channel is enabled and again after, so the pin never shows another value.
    pub fn new(dac: pac::DAC) -> Self {
        dac.dhr12r1().write(|w| w.daccdhr().set(Z_DAC_MID_SCALE));
        // BOFF1 = 0 (buffer on), TEN1 = 0 (no trigger), WAVE1 = 0, DMAEN1 = 0; channel 2 off.
        dac.cr().write(|w| w.boff1().enabled().ten1().disabled().en1().enabled());
        dac.dhr12r1().write(|w| w.daccdhr().set(Z_DAC_MID_SCALE));
        ZDac { dac }
    }

    /// Writes a code from `motion::turning::DacScale::code`. A code above 4095 is refused:
    /// mid-scale is written and `ZSlideLimit` returned. Bounded, no division.
    #[inline]
    pub fn write(&mut self, code: u16) -> Result<(), FaultCode> {
        let (value, fault) = dac_register_value(code);
        self.dac.dhr12r1().write(|w| w.daccdhr().set(value));
        match fault {
            None => Ok(()),
            Some(f) => Err(f),
        }
    }

    /// The safe value: mid-scale (`motion::machine::Z_DAC_MID_SCALE`).
    pub fn safe(&mut self) {
        self.dac.dhr12r1().write(|w| w.daccdhr().set(Z_DAC_MID_SCALE));
    }
}

/// Mid-scale from any context (panic, fault, e-stop), like `step_port::force_safe`. Harmless
/// before init: with the DAC clock off the write is ignored and the pin is still analog/high-Z.
pub fn force_safe() {
    // SAFETY: a single write of the data register; the DAC's configuration is untouched.
    unsafe { (*pac::DAC::ptr()).dhr12r1().write(|w| w.daccdhr().set(Z_DAC_MID_SCALE)) };
}
