//! The chunked table upload of the link's Z-slide job: a table's link form ([`table_link_bytes`], the
//! host's side), and the board's staging buffer ([`ZTableUpload`], checked whole: byte count,
//! CRC-32, [`CoefficientTable::try_new`]) that yields a [`LinkTable`].

use crate::protocol::CRC32;
use crate::turning::table::{CoefficientTable, TableError, TableForm, MAX_ORDER, MAX_WIDTH};
use serde::{Deserialize, Serialize};

/// Rows an uploaded table may have (the Douglass table has 81).
pub const LINK_TABLE_ROWS: usize = 96;
/// Largest table on the link: harmonic order 8, `LINK_TABLE_ROWS` rows, 4 bytes a coefficient.
pub const MAX_TABLE_BYTES: usize = LINK_TABLE_ROWS * MAX_WIDTH * 4;

/// A table's shape, sent first (`ZTableBegin`). Rows follow as little-endian `i32`
/// coefficients (inches Q32), row after row, `width` per row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ZTableHeader {
    /// 0 = power form `[C00, C01, C02, C03]`; `k` in 1..=8 = harmonic order `k`.
    pub form: u8,
    pub rows: u16,
    pub x0_in_q24: i32,
    pub dx_in_q24: i32,
}

impl ZTableHeader {
    /// The form, if `form` is 0..=8.
    pub const fn table_form(&self) -> Option<TableForm> {
        match self.form {
            0 => Some(TableForm::Power),
            k if k as usize <= MAX_ORDER => Some(TableForm::Harmonic { order: k }),
            _ => None,
        }
    }
    /// Bytes of the rows on the link.
    pub const fn byte_len(&self) -> usize {
        match self.table_form() {
            Some(f) => self.rows as usize * f.width() * 4,
            None => 0,
        }
    }
}

/// A table's link form (the host's side of an upload): its header, and its rows written into
/// `out` as little-endian `i32`s; returns the header and the byte count, `None` if `out` is too
/// short or the table does not fit a [`ZTableHeader`]. Harmonic tables are sent at their order.
pub fn table_link_bytes<const ROWS: usize, const WIDTH: usize>(
    t: &CoefficientTable<ROWS, WIDTH>,
    out: &mut [u8],
) -> Option<(ZTableHeader, usize)> {
    let form = match t.form() {
        TableForm::Power => 0,
        TableForm::Harmonic { order } => order,
    };
    let h = ZTableHeader {
        form,
        rows: u16::try_from(t.len()).ok()?,
        x0_in_q24: t.x0_in_q24(),
        dx_in_q24: t.dx_in_q24(),
    };
    let width = t.form().width();
    let mut n = 0;
    for r in 0..t.len() {
        let row = t.row(r)?;
        for c in row.iter().take(width) {
            out.get_mut(n..n + 4)?.copy_from_slice(&c.to_le_bytes());
            n += 4;
        }
    }
    (n == h.byte_len()).then_some((h, n))
}

/// Why an upload step was refused (nothing replaced; a refused chunk or end drops the upload).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZTableError {
    /// Form not 0..=8, no rows or more than [`LINK_TABLE_ROWS`].
    Header,
    /// A chunk or end without a begun upload.
    NoUpload,
    /// A chunk out of order (`expected` is the index the board wanted).
    Sequence { expected: u16 },
    /// More bytes than the header announced.
    TooLong,
    /// End before every byte arrived.
    Short,
    /// CRC-32 over the whole table differs.
    Crc,
    /// The table itself is invalid (grid, coefficient range).
    Table(TableError),
}

impl ZTableError {
    /// Small stable number for a NAK detail.
    pub const fn code(&self) -> u8 {
        match self {
            ZTableError::Header => 1,
            ZTableError::NoUpload => 2,
            ZTableError::Sequence { .. } => 3,
            ZTableError::TooLong => 4,
            ZTableError::Short => 5,
            ZTableError::Crc => 6,
            ZTableError::Table(_) => 7,
        }
    }
}

/// An uploaded table: power form, or harmonic padded to order 8 (zeros above its order).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
// Fixed capacity is the point (no allocation on the board): one table lives in the tick's
// resource, never moved in the tick.
#[allow(clippy::large_enum_variant)]
pub enum LinkTable {
    #[default]
    None,
    Power(CoefficientTable<LINK_TABLE_ROWS, 4>),
    Harmonic(CoefficientTable<LINK_TABLE_ROWS, MAX_WIDTH>),
}

/// The chunked upload's staging buffer (link side: never touched by the tick).
#[derive(Clone, Debug)]
pub struct ZTableUpload {
    header: Option<ZTableHeader>,
    next_chunk: u16,
    len: usize,
    bytes: [u8; MAX_TABLE_BYTES],
}

impl Default for ZTableUpload {
    fn default() -> Self {
        Self::new()
    }
}

impl ZTableUpload {
    pub const fn new() -> Self {
        Self { header: None, next_chunk: 0, len: 0, bytes: [0; MAX_TABLE_BYTES] }
    }

    /// Starts an upload (drops any unfinished one).
    pub fn begin(&mut self, h: ZTableHeader) -> Result<(), ZTableError> {
        self.header = None;
        if h.table_form().is_none() || h.rows == 0 || h.rows as usize > LINK_TABLE_ROWS {
            return Err(ZTableError::Header);
        }
        self.header = Some(h);
        self.next_chunk = 0;
        self.len = 0;
        Ok(())
    }

    /// Chunk `index` (0, 1, ... in order). A repeated last chunk is refused too: the session
    /// layer answers retransmissions before they get here.
    pub fn chunk(&mut self, index: u16, bytes: &[u8]) -> Result<(), ZTableError> {
        let h = self.header.ok_or(ZTableError::NoUpload)?;
        if index != self.next_chunk {
            return Err(ZTableError::Sequence { expected: self.next_chunk });
        }
        let end = self.len + bytes.len();
        let Some(dst) = self.bytes.get_mut(self.len..end).filter(|_| end <= h.byte_len()) else {
            self.header = None;
            return Err(ZTableError::TooLong);
        };
        dst.copy_from_slice(bytes);
        self.len = end;
        self.next_chunk = self.next_chunk.wrapping_add(1);
        Ok(())
    }

    /// Ends the upload: every byte, the CRC and the table checks; the upload is over either way.
    pub fn end(&mut self, crc: u32) -> Result<LinkTable, ZTableError> {
        let h = self.header.take().ok_or(ZTableError::NoUpload)?;
        let form = h.table_form().ok_or(ZTableError::Header)?;
        let data = self.bytes.get(..self.len).ok_or(ZTableError::Short)?;
        if self.len != h.byte_len() {
            return Err(ZTableError::Short);
        }
        if CRC32.checksum(data) != crc {
            return Err(ZTableError::Crc);
        }
        let width = form.width();
        let coeff = |r: usize, k: usize| -> i32 {
            let i = (r * width + k) * 4;
            match data.get(i..i + 4) {
                Some(&[a, b, c, d]) => i32::from_le_bytes([a, b, c, d]),
                _ => 0,
            }
        };
        let rows = h.rows as usize;
        match form {
            TableForm::Power => {
                let mut t = [[0i32; 4]; LINK_TABLE_ROWS];
                for (r, row) in t.iter_mut().enumerate().take(rows) {
                    for (k, c) in row.iter_mut().enumerate() {
                        *c = coeff(r, k);
                    }
                }
                CoefficientTable::try_new(form, h.x0_in_q24, h.dx_in_q24, rows, t)
                    .map(LinkTable::Power)
            }
            TableForm::Harmonic { .. } => {
                let mut t = [[0i32; MAX_WIDTH]; LINK_TABLE_ROWS];
                for (r, row) in t.iter_mut().enumerate().take(rows) {
                    for (k, c) in row.iter_mut().enumerate().take(width) {
                        *c = coeff(r, k);
                    }
                }
                let padded = TableForm::Harmonic { order: MAX_ORDER as u8 };
                CoefficientTable::try_new(padded, h.x0_in_q24, h.dx_in_q24, rows, t)
                    .map(LinkTable::Harmonic)
            }
        }
        .map_err(ZTableError::Table)
    }

    /// The chunk index the upload expects next, if one is open.
    pub fn expected(&self) -> Option<u16> {
        self.header.map(|_| self.next_chunk)
    }
}
