//! A NOR flash in RAM that keeps NOR's rules: erase in `ERASE` blocks to 0xFF, write only erased
//! bytes (write once between erases), aligned accesses, and an optional power cut after a number
//! of bytes, which leaves the interrupted write or erase half done. The host tests use it as the
//! flash mock; the QEMU scenarios use an erased one (QEMU's flash is read-only: config missing).

use embedded_storage::nor_flash::{ErrorType, NorFlashError, NorFlashErrorKind};
/// The traits, re-exported so users of the mock need no direct dependency.
pub use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};

/// What went wrong in a [`RamFlash`] access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RamFlashError {
    NotAligned,
    OutOfBounds,
    /// A write to a byte not erased since its last write.
    NotErased {
        offset: u32,
    },
    /// The power was cut (this access may be partly done).
    PowerCut,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            RamFlashError::NotAligned => NorFlashErrorKind::NotAligned,
            RamFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// `N` bytes of NOR flash erased in blocks of `ERASE` bytes, written in units of 4 bytes.
#[derive(Clone, Debug)]
pub struct RamFlash<const N: usize, const ERASE: usize> {
    mem: [u8; N],
    /// Bytes the next writes and erases may still change before the power goes (None: no cut).
    budget: Option<usize>,
    powered: bool,
    pub writes: u32,
    pub erases: u32,
}

impl<const N: usize, const ERASE: usize> Default for RamFlash<N, ERASE> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const ERASE: usize> RamFlash<N, ERASE> {
    /// All erased.
    pub const fn new() -> Self {
        RamFlash { mem: [0xFF; N], budget: None, powered: true, writes: 0, erases: 0 }
    }

    /// Cuts the power once `bytes` more bytes have been written or erased.
    pub fn cut_power_after(&mut self, bytes: usize) {
        self.budget = Some(bytes);
    }

    /// Power back (after a cut): accesses work again, nothing else changes.
    pub fn restore_power(&mut self) {
        self.budget = None;
        self.powered = true;
    }

    pub fn bytes(&self) -> &[u8] {
        &self.mem
    }

    /// Flips bits as a disturbed cell would (tests of corrupt records).
    pub fn corrupt(&mut self, offset: usize, xor: u8) {
        if let Some(b) = self.mem.get_mut(offset) {
            *b ^= xor;
        }
    }

    /// How many of `want` bytes may change before the power goes; a cut turns the power off.
    fn allow(&mut self, want: usize) -> usize {
        match self.budget {
            None => want,
            Some(b) if b >= want => {
                self.budget = Some(b - want);
                want
            }
            Some(b) => {
                self.budget = Some(0);
                self.powered = false;
                b
            }
        }
    }

    fn range(&self, offset: u32, len: usize, align: usize) -> Result<usize, RamFlashError> {
        let off = offset as usize;
        if len > N || off > N - len {
            return Err(RamFlashError::OutOfBounds);
        }
        if !off.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(RamFlashError::NotAligned);
        }
        Ok(off)
    }
}

impl<const N: usize, const ERASE: usize> ErrorType for RamFlash<N, ERASE> {
    type Error = RamFlashError;
}

impl<const N: usize, const ERASE: usize> ReadNorFlash for RamFlash<N, ERASE> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        if !self.powered {
            return Err(RamFlashError::PowerCut);
        }
        let off = self.range(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(self.mem.get(off..off + bytes.len()).unwrap_or_default());
        Ok(())
    }

    fn capacity(&self) -> usize {
        N
    }
}

impl<const N: usize, const ERASE: usize> NorFlash for RamFlash<N, ERASE> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = ERASE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if !self.powered {
            return Err(RamFlashError::PowerCut);
        }
        if to < from {
            return Err(RamFlashError::OutOfBounds);
        }
        let off = self.range(from, (to - from) as usize, ERASE)?;
        let len = (to - from) as usize;
        let n = self.allow(len);
        self.erases += 1;
        for b in self.mem.iter_mut().skip(off).take(n) {
            *b = 0xFF;
        }
        if n < len {
            return Err(RamFlashError::PowerCut);
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        if !self.powered {
            return Err(RamFlashError::PowerCut);
        }
        let off = self.range(offset, bytes.len(), Self::WRITE_SIZE)?;
        if let Some(k) = self.mem.iter().skip(off).take(bytes.len()).position(|&b| b != 0xFF) {
            return Err(RamFlashError::NotErased { offset: (off + k) as u32 });
        }
        let n = self.allow(bytes.len());
        self.writes += 1;
        for (m, &b) in self.mem.iter_mut().skip(off).zip(bytes).take(n) {
            *m = b;
        }
        if n < bytes.len() {
            // The byte being programmed when the power went holds only some of its zero bits.
            if let (Some(m), Some(&b)) = (self.mem.get_mut(off + n), bytes.get(n)) {
                *m = b | 0xA5;
            }
            return Err(RamFlashError::PowerCut);
        }
        Ok(())
    }
}
