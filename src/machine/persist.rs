//! The board config in NOR flash, through `embedded_storage`'s [`NorFlash`] traits.
//!
//! Two slots (each a whole number of erase blocks) hold alternate generations of one record:
//!
//! | offset | bytes | field |
//! |---:|---:|---|
//! | 0 | 4 | magic `MBCF` |
//! | 4 | 2 | format version ([`RECORD_VERSION`], LE) |
//! | 6 | 2 | payload length (LE) |
//! | 8 | 4 | generation (LE, wrapping; the newer valid slot wins) |
//! | 12 | len | postcard([`BoardConfig`]) |
//! | 12 + len | 4 | CRC-32/ISO-HDLC of bytes 0 .. 12 + len (LE) |
//! | [`RECORD_AREA`] - 4 | 4 | commit word, written last |
//!
//! A save erases the *other* slot, writes the record, then the commit word. A power cut at any
//! point leaves the old slot untouched, so a load finds the old record (or the new one if the
//! commit word made it); a half-written slot fails its commit word or CRC and is ignored. Only
//! with no valid slot at all is the config "missing" (or "corrupt" if a slot held anything).

use super::config::BoardConfig;
use crate::protocol::CRC32;
use embedded_storage::nor_flash::NorFlash;

pub const MAGIC: [u8; 4] = *b"MBCF";
/// Bump when the meaning of the payload changes; older records then load as corrupt.
/// (2: `BoardConfig::following` added.)
pub const RECORD_VERSION: u16 = 3;
/// Bytes a record may use in its slot (the commit word at its end).
pub const RECORD_AREA: usize = 512;
const HEADER: usize = 12;
const CRC_LEN: usize = 4;
const COMMIT: [u8; 4] = [0x5A, 0xA5, 0xC3, 0x3C];
const COMMIT_AT: usize = RECORD_AREA - 4;
/// Longest payload.
pub const MAX_PAYLOAD: usize = COMMIT_AT - HEADER - CRC_LEN;

/// Why no config came out of the flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoadError {
    /// Both slots erased: never saved.
    Missing,
    /// Something was written but no slot holds a complete, valid record of this version.
    Corrupt,
    /// The flash refused a read.
    Flash,
}

impl LoadError {
    /// What the machine's boot makes of it: missing stays missing; anything else (including a
    /// flash that refuses the read) is a corrupt config.
    pub const fn boot(self) -> super::machine::BootConfig {
        match self {
            LoadError::Missing => super::machine::BootConfig::Missing,
            LoadError::Corrupt | LoadError::Flash => super::machine::BootConfig::Corrupt,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SaveError {
    /// The config does not serialise into [`MAX_PAYLOAD`] bytes.
    TooLarge,
    /// The flash refused an erase or write (the old record is still there).
    Flash,
    /// The flash's geometry does not fit (slot smaller than a record, write size above 4).
    Geometry,
}

/// The config store over `F`: slot 0 at `base`, slot 1 at `base + slot_bytes`.
pub struct ConfigStore<F> {
    flash: F,
    base: u32,
    slot_bytes: u32,
}

struct Found {
    generation: u32,
    slot: u32,
    cfg: BoardConfig,
}

// A local on the control task's stack; no allocator to box into.
#[allow(clippy::large_enum_variant)]
enum Slot {
    Erased,
    Invalid,
    Valid(Found),
}

impl<F: NorFlash> ConfigStore<F> {
    /// `slot_bytes` must be a multiple of `F::ERASE_SIZE` and at least [`RECORD_AREA`].
    pub fn new(flash: F, base: u32, slot_bytes: u32) -> Result<Self, SaveError> {
        let erase = F::ERASE_SIZE.max(1);
        let ok = (slot_bytes as usize).is_multiple_of(erase)
            && (base as usize).is_multiple_of(erase)
            && slot_bytes as usize >= RECORD_AREA
            && F::WRITE_SIZE <= 4
            && 4 % F::WRITE_SIZE.max(1) == 0
            && RECORD_AREA.is_multiple_of(F::READ_SIZE.max(1));
        if !ok {
            return Err(SaveError::Geometry);
        }
        Ok(ConfigStore { flash, base, slot_bytes })
    }

    pub fn flash(&mut self) -> &mut F {
        &mut self.flash
    }

    pub fn into_flash(self) -> F {
        self.flash
    }

    fn slot_at(&self, slot: u32) -> u32 {
        self.base + slot * self.slot_bytes
    }

    fn read_slot(&mut self, slot: u32) -> Result<Slot, LoadError> {
        let mut buf = [0u8; RECORD_AREA];
        self.flash.read(self.slot_at(slot), &mut buf).map_err(|_| LoadError::Flash)?;
        if buf.iter().all(|&b| b == 0xFF) {
            return Ok(Slot::Erased);
        }
        Ok(decode(&buf).map_or(Slot::Invalid, |(generation, cfg)| {
            Slot::Valid(Found { generation, slot, cfg })
        }))
    }

    fn newest(&mut self) -> Result<(Option<Found>, bool), LoadError> {
        let a = self.read_slot(0)?;
        let b = self.read_slot(1)?;
        let written = !matches!((&a, &b), (Slot::Erased, Slot::Erased));
        let best = match (a, b) {
            (Slot::Valid(x), Slot::Valid(y)) => {
                Some(if (y.generation.wrapping_sub(x.generation) as i32) > 0 { y } else { x })
            }
            (Slot::Valid(x), _) | (_, Slot::Valid(x)) => Some(x),
            _ => None,
        };
        Ok((best, written))
    }

    /// The newest valid config.
    pub fn load(&mut self) -> Result<BoardConfig, LoadError> {
        match self.newest()? {
            (Some(f), _) => Ok(f.cfg),
            (None, false) => Err(LoadError::Missing),
            (None, true) => Err(LoadError::Corrupt),
        }
    }

    /// Saves `cfg` as the next generation in the slot the newest valid record is not in.
    pub fn save(&mut self, cfg: &BoardConfig) -> Result<(), SaveError> {
        let (best, _) = self.newest().map_err(|_| SaveError::Flash)?;
        let (slot, generation) = match best {
            Some(f) => (1 - f.slot.min(1), f.generation.wrapping_add(1)),
            None => (0, 1),
        };
        let mut buf = [0xFFu8; RECORD_AREA];
        let len = postcard::to_slice(cfg, &mut buf[HEADER..HEADER + MAX_PAYLOAD])
            .map_err(|_| SaveError::TooLarge)?
            .len();
        buf[0..4].copy_from_slice(&MAGIC);
        buf[4..6].copy_from_slice(&RECORD_VERSION.to_le_bytes());
        buf[6..8].copy_from_slice(&(len as u16).to_le_bytes());
        buf[8..12].copy_from_slice(&generation.to_le_bytes());
        let crc = CRC32.checksum(&buf[..HEADER + len]);
        buf[HEADER + len..HEADER + len + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
        // Round the body up to whole 4-byte words (0xFF padding); the commit word is separate.
        let body = (HEADER + len + CRC_LEN).next_multiple_of(4);
        let at = self.slot_at(slot);
        self.flash.erase(at, at + self.slot_bytes).map_err(|_| SaveError::Flash)?;
        self.flash.write(at, &buf[..body]).map_err(|_| SaveError::Flash)?;
        self.flash.write(at + COMMIT_AT as u32, &COMMIT).map_err(|_| SaveError::Flash)?;
        Ok(())
    }
}

/// (generation, config) of a complete record of this version.
fn decode(buf: &[u8; RECORD_AREA]) -> Option<(u32, BoardConfig)> {
    if buf[0..4] != MAGIC || buf[COMMIT_AT..] != COMMIT {
        return None;
    }
    let version = u16::from_le_bytes([buf[4], buf[5]]);
    let len = u16::from_le_bytes([buf[6], buf[7]]) as usize;
    if version != RECORD_VERSION || len > MAX_PAYLOAD {
        return None;
    }
    let generation = u32::from_le_bytes([buf[8], buf[9], buf[10], buf[11]]);
    let crc_at = HEADER + len;
    let stored = buf.get(crc_at..crc_at + CRC_LEN)?;
    let stored = u32::from_le_bytes([stored[0], stored[1], stored[2], stored[3]]);
    if CRC32.checksum(&buf[..crc_at]) != stored {
        return None;
    }
    match postcard::from_bytes::<BoardConfig>(&buf[HEADER..crc_at]) {
        Ok(cfg) => Some((generation, cfg)),
        Err(_) => None,
    }
}
