//! Framing: `COBS(message ++ crc32_le(message)) ++ 0x00`.
//!
//! `message` is the postcard encoding of a [`Request`](super::Request) or
//! [`Response`](super::Response); the CRC is CRC-32/ISO-HDLC (the zlib/Ethernet CRC) of those
//! bytes, little-endian. COBS removes every 0x00 from the frame, so 0x00 only ever delimits
//! frames and a receiver resynchronises at the next one after any corruption.
//!
//! COBS is the `cobs` crate's (the one postcard's COBS flavour uses); this file adds the CRC, the
//! size limits and the stream reassembly. Nothing here allocates or panics;
//! [`FrameDecoder::push`] does O(1) work per byte, plus O(N) (COBS decode and CRC) at a
//! delimiter.

use serde::Serialize;

/// CRC-32/ISO-HDLC, as used by zlib, Ethernet and PNG.
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Largest postcard-encoded message (without CRC). The largest real messages are the
/// `SetConfig` request, the `Config` reply and a `Status` at extreme values; a test checks they
/// fit.
pub const MAX_MESSAGE: usize = 384;
/// Bytes of CRC after the message.
pub const CRC_LEN: usize = 4;

/// Longest COBS encoding of `n` bytes (at least one byte: an empty input still encodes to one).
pub const fn cobs_max_len(n: usize) -> usize {
    let len = cobs::max_encoding_length(n);
    if len == 0 {
        1
    } else {
        len
    }
}

/// Longest frame on the link, without the 0x00 delimiter: size receive buffers with this.
pub const MAX_FRAME: usize = cobs_max_len(MAX_MESSAGE + CRC_LEN);
/// Longest frame on the link including the 0x00 delimiter: size transmit buffers with this.
pub const MAX_FRAME_LINK: usize = MAX_FRAME + 1;

/// Why a frame could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The message encodes to more than [`MAX_MESSAGE`] bytes (or postcard refused it).
    TooLarge,
    /// The output buffer is too small; [`MAX_FRAME_LINK`] always suffices.
    BufferTooSmall,
}

/// Why a received frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// More than the decoder's capacity before a 0x00; the rest up to the next 0x00 is skipped.
    Overflow,
    /// Not valid COBS.
    Cobs,
    /// The CRC does not match.
    Crc,
    /// Too short to hold a CRC and a message.
    TooShort,
}

impl FrameError {
    /// The NAK code the board answers with.
    pub const fn error_code(self) -> super::ErrorCode {
        match self {
            FrameError::Overflow => super::ErrorCode::Overflow,
            FrameError::Cobs | FrameError::TooShort => super::ErrorCode::Framing,
            FrameError::Crc => super::ErrorCode::Crc,
        }
    }
}

/// Encodes `msg` as one complete frame (delimiter included) into `out`; returns the used prefix.
pub fn encode_frame<'a, T: Serialize + ?Sized>(
    msg: &T,
    out: &'a mut [u8],
) -> Result<&'a [u8], EncodeError> {
    let mut raw = [0u8; MAX_MESSAGE + CRC_LEN];
    let n =
        postcard::to_slice(msg, &mut raw[..MAX_MESSAGE]).map_err(|_| EncodeError::TooLarge)?.len();
    frame_raw(&mut raw, n, out)
}

/// Frames arbitrary message bytes (at most [`MAX_MESSAGE`]); for tests and tools.
pub fn encode_payload_frame<'a>(
    payload: &[u8],
    out: &'a mut [u8],
) -> Result<&'a [u8], EncodeError> {
    let mut raw = [0u8; MAX_MESSAGE + CRC_LEN];
    let n = payload.len();
    if n > MAX_MESSAGE {
        return Err(EncodeError::TooLarge);
    }
    raw[..n].copy_from_slice(payload);
    frame_raw(&mut raw, n, out)
}

fn frame_raw<'a>(
    raw: &mut [u8; MAX_MESSAGE + CRC_LEN],
    n: usize,
    out: &'a mut [u8],
) -> Result<&'a [u8], EncodeError> {
    let crc = CRC32.checksum(&raw[..n]).to_le_bytes();
    raw[n..n + CRC_LEN].copy_from_slice(&crc);
    let len =
        cobs::try_encode(&raw[..n + CRC_LEN], out).map_err(|_| EncodeError::BufferTooSmall)?;
    *out.get_mut(len).ok_or(EncodeError::BufferTooSmall)? = 0;
    Ok(&out[..len + 1])
}

/// Reassembles frames from a byte stream; `N` is the longest frame accepted (without the
/// delimiter), normally [`MAX_FRAME`].
#[derive(Clone, Debug)]
pub struct FrameDecoder<const N: usize> {
    buf: [u8; N],
    len: usize,
    skipping: bool,
}

impl<const N: usize> Default for FrameDecoder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameDecoder<N> {
    pub const fn new() -> Self {
        FrameDecoder { buf: [0; N], len: 0, skipping: false }
    }

    /// Forgets a partial frame; the next byte starts a new one.
    pub fn reset(&mut self) {
        self.len = 0;
        self.skipping = false;
    }

    /// Feeds one byte. At a delimiter, returns the CRC-checked message bytes of the frame it
    /// ends, or why the frame was dropped. Empty frames are ignored. An overlong frame is
    /// reported once, as soon as it overflows, and then skipped up to the next delimiter.
    pub fn push(&mut self, byte: u8) -> Option<Result<&[u8], FrameError>> {
        if byte == 0 {
            let len = core::mem::take(&mut self.len);
            if core::mem::take(&mut self.skipping) || len == 0 {
                return None;
            }
            return Some(self.finish(len));
        }
        if self.skipping {
            return None;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
                None
            }
            None => {
                self.len = 0;
                self.skipping = true;
                Some(Err(FrameError::Overflow))
            }
        }
    }

    fn finish(&mut self, len: usize) -> Result<&[u8], FrameError> {
        let frame = self.buf.get_mut(..len).ok_or(FrameError::Overflow)?;
        let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
        if n <= CRC_LEN {
            return Err(FrameError::TooShort);
        }
        let (msg, crc) = frame[..n].split_at(n - CRC_LEN);
        let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
        if CRC32.checksum(msg) != crc {
            return Err(FrameError::Crc);
        }
        Ok(msg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode_all<const N: usize>(
        d: &mut FrameDecoder<N>,
        bytes: &[u8],
    ) -> Vec<Result<Vec<u8>, FrameError>> {
        let mut out = Vec::new();
        for &b in bytes {
            if let Some(r) = d.push(b) {
                out.push(r.map(|m| m.to_vec()));
            }
        }
        out
    }

    /// Payloads around COBS's 254-byte run length, with and without zeros, frame and decode
    /// back whole; the frame holds no 0x00 but its delimiter and never exceeds the size bound.
    #[test]
    fn payloads_round_trip_at_cobs_run_edges() {
        let mut cases: Vec<Vec<u8>> = vec![vec![], vec![0], vec![0, 0], vec![1], vec![1, 0, 2]];
        for n in [249, 250, 251, 253, 254, 255, 300, MAX_MESSAGE] {
            cases.push((0..n).map(|i| (i % 255 + 1) as u8).collect());
            cases.push((0..n).map(|i| if i % 7 == 0 { 0 } else { i as u8 | 1 }).collect());
            cases.push(vec![0; n]);
        }
        for c in cases {
            let mut out = [0xAA; MAX_FRAME_LINK];
            let f = encode_payload_frame(&c, &mut out).unwrap().to_vec();
            assert!(f.len() <= cobs_max_len(c.len() + CRC_LEN) + 1, "len {}", c.len());
            assert_eq!(f.iter().position(|&b| b == 0), Some(f.len() - 1), "len {}", c.len());
            let mut d = FrameDecoder::<MAX_FRAME>::new();
            // A frame must carry a message besides its CRC.
            let want = if c.is_empty() { Err(FrameError::TooShort) } else { Ok(c.clone()) };
            assert_eq!(decode_all(&mut d, &f), vec![want], "len {}", c.len());
            // One byte short of what the frame needs: refused, not truncated.
            let mut short = vec![0; f.len() - 1];
            assert_eq!(encode_payload_frame(&c, &mut short), Err(EncodeError::BufferTooSmall));
        }
        assert_eq!(MAX_FRAME, MAX_MESSAGE + CRC_LEN + 2, "two COBS overhead bytes at most");
    }

    #[test]
    fn frames_round_trip_and_resync() {
        let mut out = [0u8; MAX_FRAME_LINK];
        let f = encode_payload_frame(&[1, 0, 2, 3], &mut out).unwrap().to_vec();
        let mut d = FrameDecoder::<MAX_FRAME>::new();
        let mut stream = vec![0, 0, 7, 7, 0];
        stream.extend_from_slice(&f);
        stream.extend_from_slice(&f);
        let got = decode_all(&mut d, &stream);
        assert_eq!(got.len(), 3);
        assert!(got[0].is_err(), "garbage before the first frame is one bad frame");
        assert_eq!(got[1].as_deref(), Ok(&[1u8, 0, 2, 3][..]));
        assert_eq!(got[2].as_deref(), Ok(&[1u8, 0, 2, 3][..]));
    }

    #[test]
    fn overflow_is_reported_once_then_resyncs() {
        let mut d = FrameDecoder::<8>::new();
        let mut out = [0u8; 16];
        let f = encode_payload_frame(&[5], &mut out).unwrap().to_vec();
        let mut stream = vec![9u8; 30];
        stream.push(0);
        stream.extend_from_slice(&f);
        let got = decode_all(&mut d, &stream);
        assert_eq!(got, vec![Err(FrameError::Overflow), Ok(vec![5])]);
    }

    #[test]
    fn errors_are_classified() {
        let mut d = FrameDecoder::<MAX_FRAME>::new();
        assert_eq!(decode_all(&mut d, &[1, 1, 1, 0]), vec![Err(FrameError::TooShort)]);
        assert_eq!(decode_all(&mut d, &[5, 1, 0]), vec![Err(FrameError::Cobs)]);
        assert_eq!(decode_all(&mut d, &[6, 1, 2, 3, 4, 5, 0]), vec![Err(FrameError::Crc)]);
        let mut out = [0u8; 4];
        assert_eq!(encode_payload_frame(&[1, 2], &mut out), Err(EncodeError::BufferTooSmall));
        assert_eq!(
            encode_payload_frame(&[1; MAX_MESSAGE + 1], &mut [0; 1000]),
            Err(EncodeError::TooLarge)
        );
    }
}
