//! ADS131M04-class 4-channel simultaneous-sampling 24-bit delta-sigma ADC on SPI (mode 1:
//! CPOL 0, CPHA 1), with its active-low DRDY output as an `InputPin`.
//!
//! Protocol implemented (ADS131M04 data sheet, "SPI Communication Frames" and "Commands"),
//! at the power-up word length of 24 bits:
//!
//! * Every exchange is one frame of [`FRAME_WORDS`] words. In: a command word (16-bit command,
//!   zero padded), the data words of a `WREG`, zeros; the input CRC is not checked by the
//!   device at power-up (MODE.RX_CRC_EN = 0). Out: a response word, the four channels'
//!   conversions (24-bit two's complement, MSB first) and a CRC-16-CCITT (polynomial 0x1021,
//!   seed 0xFFFF) of the words before it, which [`Ads131m04`] checks.
//! * The response word answers the command of the *previous* frame: `NULL` -> the STATUS
//!   register; `RESET` -> 0xFF24 (0xFF20 | channel count); `STANDBY` -> 0x0022; `WAKEUP` ->
//!   0x0033; `LOCK` / `UNLOCK` -> the command; `RREG` of one register -> its content; `WREG` of
//!   n registers at a -> 0x4000 | a << 7 | (n - 1). A command therefore takes two frames here:
//!   the command, then a `NULL` that carries its answer (and a fresh sample).
//! * Commands: NULL 0x0000, RESET 0x0011, STANDBY 0x0022, WAKEUP 0x0033, LOCK 0x0555,
//!   UNLOCK 0x0655, RREG 0xA000 | a << 7 | (n - 1), WREG 0x6000 | a << 7 | (n - 1).
//! * Registers used: ID 0x00 (0x24xx: four channels), STATUS 0x01 (LOCK D15, F_RESYNC D14,
//!   REG_MAP D13, CRC_ERR D12, CRC_TYPE D11, RESET D10, WLENGTH D9:D8, DRDY3..0 D3:D0),
//!   MODE 0x02, CLOCK 0x03, GAIN1 0x04 (PGAGAINn in D(4n+2):D(4n)), CFG 0x06, CHn_CFG
//!   0x09 + 5n.

use embedded_hal::digital::InputPin;
use embedded_hal::spi::SpiDevice;

#[cfg(test)]
mod tests;

pub const CHANNELS: usize = 4;
/// Bytes per word at the power-up word length.
pub const WORD_BYTES: usize = 3;
/// Response, four channels, CRC.
pub const FRAME_WORDS: usize = 2 + CHANNELS;
pub const FRAME_BYTES: usize = FRAME_WORDS * WORD_BYTES;

/// Register addresses.
pub mod reg {
    pub const ID: u8 = 0x00;
    pub const STATUS: u8 = 0x01;
    pub const MODE: u8 = 0x02;
    pub const CLOCK: u8 = 0x03;
    pub const GAIN1: u8 = 0x04;
    pub const CFG: u8 = 0x06;
    /// CHn_CFG of channel `n`.
    pub const fn ch_cfg(n: u8) -> u8 {
        0x09 + 5 * n
    }
}

/// Command words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    Null,
    Reset,
    Standby,
    Wakeup,
    Lock,
    Unlock,
    /// Read one register.
    Rreg(u8),
    /// Write one register.
    Wreg(u8),
}

impl Command {
    pub const fn word(self) -> u16 {
        match self {
            Command::Null => 0x0000,
            Command::Reset => 0x0011,
            Command::Standby => 0x0022,
            Command::Wakeup => 0x0033,
            Command::Lock => 0x0555,
            Command::Unlock => 0x0655,
            Command::Rreg(a) => 0xA000 | (a as u16 & 0x3F) << 7,
            Command::Wreg(a) => 0x6000 | (a as u16 & 0x3F) << 7,
        }
    }

    /// The response word the next frame must carry, where it is fixed.
    pub const fn acknowledgement(self) -> Option<u16> {
        match self {
            Command::Reset => Some(0xFF20 | CHANNELS as u16),
            Command::Standby | Command::Wakeup | Command::Lock | Command::Unlock => {
                Some(self.word())
            }
            Command::Wreg(a) => Some(0x4000 | (a as u16 & 0x3F) << 7),
            Command::Null | Command::Rreg(_) => None,
        }
    }
}

/// The STATUS register.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Status(pub u16);

impl Status {
    pub const fn locked(self) -> bool {
        self.0 & 1 << 15 != 0
    }
    /// The device has reset since MODE.RESET was last written 0 (mirrors MODE D10).
    pub const fn reset(self) -> bool {
        self.0 & 1 << 10 != 0
    }
    /// The device saw a bad input CRC (only with RX_CRC_EN).
    pub const fn crc_error(self) -> bool {
        self.0 & 1 << 12 != 0
    }
    /// Word length code: 0 = 16, 1 = 24, 2 = 32 bit (zero padded), 3 = 32 bit (sign extended).
    pub const fn word_length_code(self) -> u8 {
        (self.0 >> 8) as u8 & 0b11
    }
    /// Channel `n` has a new conversion.
    pub const fn drdy(self, n: usize) -> bool {
        self.0 & 1 << n != 0
    }
}

/// One frame's output: the response word and the four conversions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Frame {
    pub response: u16,
    /// Sign-extended 24-bit two's complement codes.
    pub channels: [i32; CHANNELS],
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<E> {
    Spi(E),
    /// The DRDY pin could not be read.
    Pin,
    /// The output frame's CRC does not match its contents.
    Crc {
        sent: u16,
        computed: u16,
    },
    /// A command was not acknowledged as the data sheet says.
    Response {
        command: u16,
        expected: u16,
        got: u16,
    },
}

/// CRC-16-CCITT as the device computes it (polynomial 0x1021, seed 0xFFFF, no reflection).
pub const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// A 24-bit two's complement code as i32.
pub const fn sign_extend_24(b: [u8; 3]) -> i32 {
    (((b[0] as u32) << 24 | (b[1] as u32) << 16 | (b[2] as u32) << 8) as i32) >> 8
}

/// A code in microvolts at PGA `gain` (1..=128): full scale +/-1.2 V is +/-2^23 codes.
pub const fn code_to_uv(code: i32, gain: u8) -> i32 {
    const FULL_SCALE_UV: i64 = 1_200_000;
    let g = if gain == 0 { 1 } else { gain as i64 };
    (code as i64 * FULL_SCALE_UV / (1 << 23) / g) as i32
}

/// The ADC: an SPI device (8-bit words) and its DRDY line.
pub struct Ads131m04<Spi, Drdy> {
    spi: Spi,
    drdy: Drdy,
}

impl<Spi, Drdy, E> Ads131m04<Spi, Drdy>
where
    Spi: SpiDevice<u8, Error = E>,
    Drdy: InputPin,
{
    pub fn new(spi: Spi, drdy: Drdy) -> Self {
        Ads131m04 { spi, drdy }
    }

    pub fn release(self) -> (Spi, Drdy) {
        (self.spi, self.drdy)
    }

    /// DRDY is low: a conversion waits to be read.
    pub fn data_ready(&mut self) -> Result<bool, Error<E>> {
        self.drdy.is_low().map_err(|_| Error::Pin)
    }

    /// One frame: `command` (with `data`, for a WREG) out, the checked output frame in.
    pub fn exchange(&mut self, command: Command, data: Option<u16>) -> Result<Frame, Error<E>> {
        let mut buf = [0u8; FRAME_BYTES];
        buf[..2].copy_from_slice(&command.word().to_be_bytes());
        if let Some(d) = data {
            buf[WORD_BYTES..WORD_BYTES + 2].copy_from_slice(&d.to_be_bytes());
        }
        self.spi.transfer_in_place(&mut buf).map_err(Error::Spi)?;
        let crc_at = FRAME_BYTES - WORD_BYTES;
        let sent = u16::from_be_bytes([buf[crc_at], buf[crc_at + 1]]);
        let computed = CRC16.checksum(&buf[..crc_at]);
        if sent != computed {
            return Err(Error::Crc { sent, computed });
        }
        let mut channels = [0; CHANNELS];
        for (i, c) in channels.iter_mut().enumerate() {
            let at = WORD_BYTES * (1 + i);
            *c = sign_extend_24([buf[at], buf[at + 1], buf[at + 2]]);
        }
        Ok(Frame { response: u16::from_be_bytes([buf[0], buf[1]]), channels })
    }

    /// A command and the `NULL` frame that carries its answer, checked against the data
    /// sheet's acknowledgement; returns that second frame.
    fn command(&mut self, command: Command, data: Option<u16>) -> Result<Frame, Error<E>> {
        self.exchange(command, data)?;
        let f = self.exchange(Command::Null, None)?;
        if let Some(expected) = command.acknowledgement() {
            if f.response != expected {
                return Err(Error::Response { command: command.word(), expected, got: f.response });
            }
        }
        Ok(f)
    }

    /// Reads the conversions now waiting (call when [`Ads131m04::data_ready`]), with the STATUS
    /// the `NULL` of the previous frame asked for. After any other command, run one more
    /// `NULL` frame first (every method here does).
    pub fn read(&mut self) -> Result<(Status, [i32; CHANNELS]), Error<E>> {
        let f = self.exchange(Command::Null, None)?;
        Ok((Status(f.response), f.channels))
    }

    pub fn reset(&mut self) -> Result<(), Error<E>> {
        self.command(Command::Reset, None).map(drop)
    }

    pub fn standby(&mut self) -> Result<(), Error<E>> {
        self.command(Command::Standby, None).map(drop)
    }

    pub fn wakeup(&mut self) -> Result<(), Error<E>> {
        self.command(Command::Wakeup, None).map(drop)
    }

    pub fn read_register(&mut self, address: u8) -> Result<u16, Error<E>> {
        self.command(Command::Rreg(address), None).map(|f| f.response)
    }

    pub fn write_register(&mut self, address: u8, value: u16) -> Result<(), Error<E>> {
        self.command(Command::Wreg(address), Some(value)).map(drop)
    }

    /// Sets PGA gains (1, 2, 4, ..., 128 per channel; anything else is rounded down to a
    /// power of two) in GAIN1.
    pub fn set_gains(&mut self, gains: [u8; CHANNELS]) -> Result<(), Error<E>> {
        self.write_register(reg::GAIN1, gain_register(gains))
    }

    /// The channel count from the ID register (4 for the ADS131M04).
    pub fn channel_count(&mut self) -> Result<u8, Error<E>> {
        self.read_register(reg::ID).map(|id| (id >> 8) as u8 & 0x0F)
    }
}

/// The GAIN1 register for per-channel PGA gains (code = log2(gain), 3 bits per channel, 4
/// bits apart).
pub const fn gain_register(gains: [u8; CHANNELS]) -> u16 {
    let mut v = 0u16;
    let mut i = 0;
    while i < CHANNELS {
        let g = if gains[i] == 0 { 1 } else { gains[i] };
        let code = 7 - g.leading_zeros() as u16;
        v |= code << (4 * i);
        i += 1;
    }
    v
}
