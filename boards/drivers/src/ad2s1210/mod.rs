//! AD2S1210-class resolver-to-digital converter on SPI (serial interface: /WR-FSYNC as chip
//! select, one 8-bit frame per select), with the mode pins A0/A1 and the SAMPLE pin as
//! `OutputPin`s.
//!
//! Register map implemented (AD2S1210 data sheet, "Register Map" table; the same addresses as
//! the Linux IIO driver `drivers/iio/resolver/ad2s1210.c`). Addresses have D7 = 1; a data byte
//! written to a register has D7 = 0 (7 data bits):
//!
//! | address | register | access | this driver |
//! | --- | --- | --- | --- |
//! | 0x80 / 0x81 | position MSB / LSB | R | [`Ad2s1210::read_register`] (normal-mode reads are faster: [`Ad2s1210::read_position`]) |
//! | 0x82 / 0x83 | velocity MSB / LSB | R | as above ([`Ad2s1210::read_velocity`]) |
//! | 0x88 | LOS threshold | R/W | [`Threshold::Los`] |
//! | 0x89 | DOS overrange threshold | R/W | [`Threshold::DosOverrange`] |
//! | 0x8A | DOS mismatch threshold | R/W | [`Threshold::DosMismatch`] |
//! | 0x8B / 0x8C | DOS reset max / min threshold | R/W | [`Threshold::DosResetMax`] / [`Threshold::DosResetMin`] |
//! | 0x8D / 0x8E | LOT high / low threshold | R/W | [`Threshold::LotHigh`] / [`Threshold::LotLow`] |
//! | 0x91 | excitation frequency (FCW = f_exc * 2^15 / f_CLKIN, 2..20 kHz) | R/W | [`Ad2s1210::set_excitation`] |
//! | 0x92 | control (D6 = 1, D5 phase-lock range 0 = +/-360 deg / 1 = +/-44 deg, D4 hysteresis, D3:D2 encoder resolution, D1:D0 resolution 00 = 10 .. 11 = 16 bit; 0x7E at power-up) | R/W | [`Control`], [`Ad2s1210::configure`] (verified by read-back) |
//! | 0xF0 | software reset (any data) | W | [`Ad2s1210::software_reset`] |
//! | 0xFF | fault (D7 clipping, D6 LOS, D5 DOS overrange, D4 DOS mismatch, D3 LOT, D2 velocity over the tracking rate, D1 phase lock, D0 configuration parity) | R | [`Faults`], [`Ad2s1210::read_faults`], [`Ad2s1210::clear_faults`] |
//!
//! Modes (A0, A1): (0, 0) normal mode, position; (0, 1) normal mode, velocity; (1, 1)
//! configuration mode ((1, 0) is reserved). In normal mode a falling SAMPLE edge latches
//! position and velocity; one 24-bit read then returns the selected 16-bit value (MSB first,
//! left-aligned: at a lower resolution the low bits carry no information) followed by the fault
//! register. In configuration mode a register is read by sending its address in one frame and
//! clocking its content out in the next (the byte sent meanwhile is the fault register's
//! address, a read without side effects).

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::OutputPin;
use embedded_hal::spi::SpiDevice;

#[cfg(test)]
mod tests;

/// Register addresses (D7 = 1).
pub mod reg {
    pub const POSITION_MSB: u8 = 0x80;
    pub const POSITION_LSB: u8 = 0x81;
    pub const VELOCITY_MSB: u8 = 0x82;
    pub const VELOCITY_LSB: u8 = 0x83;
    pub const LOS_THRESHOLD: u8 = 0x88;
    pub const DOS_OVERRANGE_THRESHOLD: u8 = 0x89;
    pub const DOS_MISMATCH_THRESHOLD: u8 = 0x8A;
    pub const DOS_RESET_MAX_THRESHOLD: u8 = 0x8B;
    pub const DOS_RESET_MIN_THRESHOLD: u8 = 0x8C;
    pub const LOT_HIGH_THRESHOLD: u8 = 0x8D;
    pub const LOT_LOW_THRESHOLD: u8 = 0x8E;
    pub const EXCITATION_FREQUENCY: u8 = 0x91;
    pub const CONTROL: u8 = 0x92;
    pub const SOFTWARE_RESET: u8 = 0xF0;
    pub const FAULT: u8 = 0xFF;
}

/// D7 of a data byte must be 0: registers hold 7 bits.
const DATA_MASK: u8 = 0x7F;
/// Control register bit D6, reserved, reads and must be written as 1.
const CONTROL_RESERVED: u8 = 1 << 6;
const PHASE_LOCK_44: u8 = 1 << 5;
const HYSTERESIS: u8 = 1 << 4;
/// The nominal CLKIN the data sheet's tracking rates are given for.
pub const NOMINAL_CLKIN_HZ: u32 = 8_192_000;
/// Excitation range of the oscillator, Hz.
pub const EXCITATION_MIN_HZ: u32 = 2_000;
pub const EXCITATION_MAX_HZ: u32 = 20_000;
/// SAMPLE low and the wait after it, ns: the data sheet asks for 2 CLKIN periods + 20 ns
/// (264 ns at 8.192 MHz) low, and as long again before the read; 1 us covers CLKIN >= 2.5 MHz.
pub const SAMPLE_PULSE_NS: u32 = 1_000;

/// Converter resolution (control D1:D0; encoder emulation D3:D2 uses the same codes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Resolution {
    Bits10 = 0,
    Bits12 = 1,
    Bits14 = 2,
    Bits16 = 3,
}

impl Resolution {
    pub const fn bits(self) -> u32 {
        10 + 2 * self as u32
    }

    const fn from_code(code: u8) -> Resolution {
        match code & 0b11 {
            0 => Resolution::Bits10,
            1 => Resolution::Bits12,
            2 => Resolution::Bits14,
            _ => Resolution::Bits16,
        }
    }

    /// The low bits of a left-aligned 16-bit reading that carry data at this resolution.
    pub const fn mask(self) -> u16 {
        !((1u16 << (16 - self.bits())) - 1)
    }

    /// Maximum tracking rate at [`NOMINAL_CLKIN_HZ`], revolutions per second: full-scale
    /// velocity (+/-0x7FFF) at this resolution (data sheet, "Velocity Output").
    pub const fn max_tracking_rps(self) -> u32 {
        match self {
            Resolution::Bits10 => 2_500,
            Resolution::Bits12 => 1_000,
            Resolution::Bits14 => 500,
            Resolution::Bits16 => 125,
        }
    }
}

/// The control register (0x92).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Control {
    /// Phase-lock range +/-44 deg (true, the power-up value) or +/-360 deg.
    pub phase_lock_44: bool,
    pub hysteresis: bool,
    /// Resolution of the A-quad-B encoder emulation outputs.
    pub encoder_resolution: Resolution,
    /// Resolution of the converter (must match the RES0/RES1 pins' strapping).
    pub resolution: Resolution,
}

impl Control {
    /// The register's power-up value, 0x7E.
    pub const POWER_UP: Control = Control {
        phase_lock_44: true,
        hysteresis: true,
        encoder_resolution: Resolution::Bits16,
        resolution: Resolution::Bits14,
    };

    pub const fn to_bits(self) -> u8 {
        CONTROL_RESERVED
            | if self.phase_lock_44 { PHASE_LOCK_44 } else { 0 }
            | if self.hysteresis { HYSTERESIS } else { 0 }
            | (self.encoder_resolution as u8) << 2
            | self.resolution as u8
    }

    pub const fn from_bits(b: u8) -> Control {
        Control {
            phase_lock_44: b & PHASE_LOCK_44 != 0,
            hysteresis: b & HYSTERESIS != 0,
            encoder_resolution: Resolution::from_code(b >> 2),
            resolution: Resolution::from_code(b),
        }
    }
}

/// The fault register (0xFF).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Faults(pub u8);

impl Faults {
    pub const CLIPPING: u8 = 1 << 7;
    pub const LOSS_OF_SIGNAL: u8 = 1 << 6;
    pub const DOS_OVERRANGE: u8 = 1 << 5;
    pub const DOS_MISMATCH: u8 = 1 << 4;
    pub const LOSS_OF_TRACKING: u8 = 1 << 3;
    pub const VELOCITY: u8 = 1 << 2;
    pub const PHASE_LOCK: u8 = 1 << 1;
    pub const PARITY: u8 = 1 << 0;

    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    pub const fn has(self, bit: u8) -> bool {
        self.0 & bit != 0
    }

    /// A fault that makes the position untrustworthy (signal lost or degraded, tracking lost):
    /// everything but a configuration parity error.
    pub const fn position_invalid(self) -> bool {
        self.0 & !Self::PARITY != 0
    }
}

/// The threshold registers (0x88..0x8E): 7-bit codes, 38 mV per LSB (data sheet).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Threshold {
    Los = 0x88,
    DosOverrange = 0x89,
    DosMismatch = 0x8A,
    DosResetMax = 0x8B,
    DosResetMin = 0x8C,
    LotHigh = 0x8D,
    LotLow = 0x8E,
}

/// One normal-mode reading: the value and the fault register latched with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reading<T> {
    pub value: T,
    pub faults: Faults,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<E> {
    Spi(E),
    /// A mode or SAMPLE pin could not be driven.
    Pin,
    /// A value does not fit its register (7 bits) or the excitation is out of range.
    OutOfRange,
    /// The control register read back differs from what was written.
    Verify {
        wrote: u8,
        read: u8,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Position,
    Velocity,
    Config,
}

/// The converter: SPI device (8-bit frames, SPI mode 3), A0, A1, SAMPLE and a delay.
pub struct Ad2s1210<Spi, A0, A1, Sample, Delay> {
    spi: Spi,
    a0: A0,
    a1: A1,
    sample: Sample,
    delay: Delay,
    mode: Option<Mode>,
    resolution: Resolution,
}

impl<Spi, A0, A1, S, D, E> Ad2s1210<Spi, A0, A1, S, D>
where
    Spi: SpiDevice<u8, Error = E>,
    A0: OutputPin,
    A1: OutputPin,
    S: OutputPin,
    D: DelayNs,
{
    /// The pins as wired; SAMPLE must idle high. Assumes the power-up resolution until
    /// [`Ad2s1210::configure`].
    pub fn new(spi: Spi, a0: A0, a1: A1, sample: S, delay: D) -> Self {
        Ad2s1210 {
            spi,
            a0,
            a1,
            sample,
            delay,
            mode: None,
            resolution: Control::POWER_UP.resolution,
        }
    }

    pub fn release(self) -> (Spi, A0, A1, S, D) {
        (self.spi, self.a0, self.a1, self.sample, self.delay)
    }

    fn set_mode(&mut self, mode: Mode) -> Result<(), Error<E>> {
        if self.mode == Some(mode) {
            return Ok(());
        }
        let (a0, a1) = match mode {
            Mode::Position => (false, false),
            Mode::Velocity => (false, true),
            Mode::Config => (true, true),
        };
        self.a0.set_state(a0.into()).map_err(|_| Error::Pin)?;
        self.a1.set_state(a1.into()).map_err(|_| Error::Pin)?;
        self.mode = Some(mode);
        Ok(())
    }

    /// A SAMPLE pulse: the falling edge latches position, velocity and the fault register.
    pub fn sample(&mut self) -> Result<(), Error<E>> {
        self.sample.set_low().map_err(|_| Error::Pin)?;
        self.delay.delay_ns(SAMPLE_PULSE_NS);
        self.sample.set_high().map_err(|_| Error::Pin)?;
        self.delay.delay_ns(SAMPLE_PULSE_NS);
        Ok(())
    }

    fn read_normal(&mut self, mode: Mode) -> Result<([u8; 2], Faults), Error<E>> {
        self.set_mode(mode)?;
        self.sample()?;
        let mut rx = [0u8; 3];
        self.spi.read(&mut rx).map_err(Error::Spi)?;
        Ok(([rx[0], rx[1]], Faults(rx[2])))
    }

    /// Samples and reads the angle as a 16-bit fraction of a turn (bits below the resolution
    /// cleared), with the faults latched by the same sample.
    pub fn read_position(&mut self) -> Result<Reading<u16>, Error<E>> {
        let (b, faults) = self.read_normal(Mode::Position)?;
        let value = u16::from_be_bytes(b) & self.resolution.mask();
        Ok(Reading { value, faults })
    }

    /// Samples and reads the velocity: signed, full scale (+/-32767, low bits below the
    /// resolution cleared) = the resolution's maximum tracking rate ([`velocity_mrps`]).
    pub fn read_velocity(&mut self) -> Result<Reading<i16>, Error<E>> {
        let (b, faults) = self.read_normal(Mode::Velocity)?;
        let value = (u16::from_be_bytes(b) & self.resolution.mask()) as i16;
        Ok(Reading { value, faults })
    }

    /// Reads one register in configuration mode (two frames: the address, then its content).
    pub fn read_register(&mut self, address: u8) -> Result<u8, Error<E>> {
        self.set_mode(Mode::Config)?;
        self.spi.write(&[address]).map_err(Error::Spi)?;
        let mut rx = [0u8; 1];
        self.spi.transfer(&mut rx, &[reg::FAULT]).map_err(Error::Spi)?;
        Ok(rx[0])
    }

    /// Writes a 7-bit value to a register in configuration mode (address frame, data frame).
    pub fn write_register(&mut self, address: u8, value: u8) -> Result<(), Error<E>> {
        if value > DATA_MASK {
            return Err(Error::OutOfRange);
        }
        self.set_mode(Mode::Config)?;
        self.spi.write(&[address]).map_err(Error::Spi)?;
        self.spi.write(&[value]).map_err(Error::Spi)
    }

    /// Writes the control register and reads it back; later readings use its resolution.
    pub fn configure(&mut self, control: Control) -> Result<(), Error<E>> {
        let wrote = control.to_bits();
        self.write_register(reg::CONTROL, wrote)?;
        let read = self.read_register(reg::CONTROL)? & DATA_MASK;
        if read != wrote {
            return Err(Error::Verify { wrote, read });
        }
        self.resolution = control.resolution;
        Ok(())
    }

    /// The resolution readings are masked to.
    pub fn resolution(&self) -> Resolution {
        self.resolution
    }

    /// Sets the excitation frequency from the CLKIN frequency; returns the frequency code.
    pub fn set_excitation(&mut self, excitation_hz: u32, clkin_hz: u32) -> Result<u8, Error<E>> {
        let fcw = excitation_code(excitation_hz, clkin_hz).ok_or(Error::OutOfRange)?;
        self.write_register(reg::EXCITATION_FREQUENCY, fcw)?;
        Ok(fcw)
    }

    pub fn set_threshold(&mut self, which: Threshold, code: u8) -> Result<(), Error<E>> {
        self.write_register(which as u8, code)
    }

    /// The fault register as the last SAMPLE latched it.
    pub fn read_faults(&mut self) -> Result<Faults, Error<E>> {
        self.read_register(reg::FAULT).map(Faults)
    }

    /// Clears the fault register (data sheet sequence: SAMPLE, read the faults, SAMPLE);
    /// returns what it held. A cause still present sets its bit again at the next sample.
    pub fn clear_faults(&mut self) -> Result<Faults, Error<E>> {
        self.sample()?;
        let faults = self.read_faults()?;
        self.sample()?;
        Ok(faults)
    }

    /// Restarts the tracking loop and the oscillator; the configuration registers keep their
    /// values.
    pub fn software_reset(&mut self) -> Result<(), Error<E>> {
        self.set_mode(Mode::Config)?;
        self.spi.write(&[reg::SOFTWARE_RESET]).map_err(Error::Spi)
    }
}

/// The excitation frequency code FCW = f_exc * 2^15 / f_CLKIN, rounded; `None` outside
/// 2..20 kHz or when the code does not fit 7 bits.
pub fn excitation_code(excitation_hz: u32, clkin_hz: u32) -> Option<u8> {
    if !(EXCITATION_MIN_HZ..=EXCITATION_MAX_HZ).contains(&excitation_hz) || clkin_hz == 0 {
        return None;
    }
    let (num, clk) = ((excitation_hz as u64) << 15, clkin_hz as u64);
    let fcw = (num + clk / 2) / clk;
    u8::try_from(fcw).ok().filter(|&c| c <= DATA_MASK)
}

/// A velocity reading in milli-revolutions per second at `clkin_hz` (the tracking rate scales
/// with CLKIN). Divides: call from a task, never from the tick.
pub fn velocity_mrps(raw: i16, resolution: Resolution, clkin_hz: u32) -> i64 {
    let full_scale_mrps =
        resolution.max_tracking_rps() as i64 * 1_000 * clkin_hz as i64 / NOMINAL_CLKIN_HZ as i64;
    raw as i64 * full_scale_mrps / 0x8000
}
