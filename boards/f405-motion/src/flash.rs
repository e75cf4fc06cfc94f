//! The config record's flash: sectors 2 and 3 of the STM32F405 (16 KiB each at 0x0800_8000 and
//! 0x0800_C000), kept free of code by `_stext` in memory.x, as an `embedded_storage` NOR flash
//! for `motion::machine::persist::ConfigStore` (one slot per sector).
//!
//! Why these sectors: the F405 has one flash bank, so while a sector erases every fetch from
//! flash stalls, interrupts included. A 16 KiB sector erases in 250 ms typical, 500 ms at most
//! (x32 parallelism, datasheet), against 1-2 s for the 128 KiB sectors. The link firmware saves
//! only with the machine at rest and stretches the watchdog around the save (`Watchdog::stretch`).

use crate::pac;
use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// First byte of the region (sector 2) and its size (sectors 2 and 3).
const BASE: u32 = 0x0800_8000;
pub const SECTOR_BYTES: u32 = 16 * 1024;
const FIRST_SECTOR: u8 = 2;
pub const SECTORS: u32 = 2;
const KEY1: u32 = 0x4567_0123;
const KEY2: u32 = 0xCDEF_89AB;
/// CR.PSIZE = 0b10: 32-bit program/erase parallelism (the board runs at 3.3 V).
const PSIZE_X32: u8 = 0b10;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    OutOfBounds,
    NotAligned,
    /// The controller reported a programming or erase error (SR error bits).
    Controller(u32),
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::Controller(_) => NorFlashErrorKind::Other,
        }
    }
}

/// Sectors 2-3 through the flash interface registers.
pub struct ConfigFlash {
    regs: pac::FLASH,
}

impl ConfigFlash {
    pub fn new(regs: pac::FLASH) -> Self {
        ConfigFlash { regs }
    }

    fn check(&self, offset: u32, len: usize) -> Result<(), FlashError> {
        let end = offset as u64 + len as u64;
        if end > (SECTORS * SECTOR_BYTES) as u64 {
            return Err(FlashError::OutOfBounds);
        }
        Ok(())
    }

    fn wait(&self) -> Result<(), FlashError> {
        while self.regs.sr().read().bsy().bit_is_set() {}
        // PGSERR, PGPERR, PGAERR, WRPERR, OPERR (RM0090 3.9.4).
        const ERRORS: u32 = 0b1111_0010;
        let sr = self.regs.sr().read().bits();
        if sr & ERRORS != 0 {
            // SAFETY: writing 1 clears the error flags.
            self.regs.sr().write(|w| unsafe { w.bits(sr & ERRORS) });
            return Err(FlashError::Controller(sr));
        }
        Ok(())
    }

    fn unlocked<R>(&mut self, f: impl FnOnce(&Self) -> R) -> R {
        if self.regs.cr().read().lock().bit_is_set() {
            // SAFETY: the documented key sequence.
            unsafe {
                self.regs.keyr().write(|w| w.bits(KEY1));
                self.regs.keyr().write(|w| w.bits(KEY2));
            }
        }
        let r = f(self);
        self.regs.cr().modify(|_, w| w.lock().set_bit());
        r
    }
}

impl ErrorType for ConfigFlash {
    type Error = FlashError;
}

impl ReadNorFlash for ConfigFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        self.check(offset, bytes.len())?;
        for (i, b) in bytes.iter_mut().enumerate() {
            // SAFETY: inside sectors 2-3, memory-mapped and readable; no code lives there.
            *b = unsafe { core::ptr::read_volatile((BASE + offset + i as u32) as *const u8) };
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        (SECTORS * SECTOR_BYTES) as usize
    }
}

impl NorFlash for ConfigFlash {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = SECTOR_BYTES as usize;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        if !from.is_multiple_of(SECTOR_BYTES) || !to.is_multiple_of(SECTOR_BYTES) || to < from {
            return Err(FlashError::NotAligned);
        }
        self.check(from, (to - from) as usize)?;
        self.unlocked(|f| {
            for s in from / SECTOR_BYTES..to / SECTOR_BYTES {
                f.wait()?;
                let snb = FIRST_SECTOR + s as u8;
                // SAFETY: PSIZE and SNB take the values RM0090 3.9.7 defines; SER selects sector
                // erase, STRT starts it.
                f.regs.cr().write(|w| unsafe { w.psize().bits(PSIZE_X32).snb().bits(snb) });
                f.regs.cr().modify(|_, w| w.ser().set_bit());
                f.regs.cr().modify(|_, w| w.strt().set_bit());
                let r = f.wait();
                f.regs.cr().modify(|_, w| w.ser().clear_bit());
                r?;
            }
            Ok(())
        })
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        if !offset.is_multiple_of(4) || !bytes.len().is_multiple_of(4) {
            return Err(FlashError::NotAligned);
        }
        self.check(offset, bytes.len())?;
        self.unlocked(|f| {
            f.wait()?;
            // SAFETY: PSIZE as above; PG enables programming.
            f.regs.cr().write(|w| unsafe { w.psize().bits(PSIZE_X32) });
            f.regs.cr().modify(|_, w| w.pg().set_bit());
            let mut r = Ok(());
            for (i, word) in bytes.chunks_exact(4).enumerate() {
                let addr = (BASE + offset + 4 * i as u32) as *mut u32;
                let v = u32::from_le_bytes([word[0], word[1], word[2], word[3]]);
                // SAFETY: an aligned word inside sectors 2-3 with PG set.
                unsafe { core::ptr::write_volatile(addr, v) };
                r = f.wait();
                if r.is_err() {
                    break;
                }
            }
            f.regs.cr().modify(|_, w| w.pg().clear_bit());
            r
        })
    }
}
