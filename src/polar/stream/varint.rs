//! The payload's integers: LEB128 varints (at most 5 bytes for a u32) and zigzag for the signed
//! run step.

use super::StreamError;

/// Writes one LEB128 varint into `buf` at `*n`; false when it does not fit.
pub(super) fn put_varint(buf: &mut [u8], n: &mut usize, mut v: u32) -> bool {
    loop {
        let Some(slot) = buf.get_mut(*n) else { return false };
        let b = (v & 0x7f) as u8;
        v >>= 7;
        *slot = if v != 0 { b | 0x80 } else { b };
        *n += 1;
        if v == 0 {
            return true;
        }
    }
}

pub(super) fn varint_len(v: u32) -> usize {
    match v {
        0..=0x7f => 1,
        0x80..=0x3fff => 2,
        0x4000..=0x1f_ffff => 3,
        0x20_0000..=0xfff_ffff => 4,
        _ => 5,
    }
}

/// Reads a varint from `buf` at `*pos`.
pub(super) fn get_varint(buf: &[u8], pos: &mut usize) -> Result<u32, StreamError> {
    let mut v: u64 = 0;
    for i in 0..5 {
        let b = *buf.get(*pos).ok_or(StreamError::Truncated)?;
        *pos += 1;
        v |= ((b & 0x7f) as u64) << (7 * i);
        if b & 0x80 == 0 {
            return u32::try_from(v).map_err(|_| StreamError::Varint);
        }
    }
    Err(StreamError::Varint)
}

pub(super) const fn zigzag(v: i32) -> u32 {
    ((v << 1) ^ (v >> 31)) as u32
}

pub(super) const fn unzigzag(v: u32) -> i32 {
    ((v >> 1) as i32) ^ -((v & 1) as i32)
}
