//! The built-in limacon step-event stream: limacon 3 + 2 cos (in), pole 6.5 in at 70 deg, tool
//! 0.125 in, Vt 1.746 cm/s, 100 kHz ticks: 19 036 events in 156 blocks and the end block. The bytes are generated
//! by motionctl's digitizer into `limacon_stream.bin` beside this file
//! (motionctl/tests/polar_stream_golden.rs checks it is current; REGENERATE=1 rewrites it).

/// The stream, block after block (`super::stream`'s format).
pub const BYTES: &[u8] = include_bytes!("limacon_stream.bin");

#[cfg(test)]
mod tests {
    use super::BYTES;
    use crate::polar::stream::{blocks, decode_all};
    use crate::protocol::CRC32;

    /// The data file holds the version-2 stream (the blocks of the version-1 table it replaced,
    /// 38 945 bytes, plus the end block): its length and CRC-32, and it decodes to the same
    /// 19 036 events in 156 verified blocks.
    #[test]
    fn data_file_is_the_generated_stream() {
        assert_eq!(BYTES.len(), 38_945 + crate::polar::stream::END_BLOCK_LEN);
        assert_eq!(CRC32.checksum(BYTES), 0x6058_cf7a);
        let mut events = 0;
        decode_all(BYTES, |_| events += 1).unwrap();
        assert_eq!(events, 19_036);
        assert_eq!(blocks(BYTES).map(Result::unwrap).count(), 156);
    }
}
