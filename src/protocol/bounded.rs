//! Fixed-capacity containers with hand-written serde impls (heapless is used without its `serde`
//! feature). Decoding refuses anything longer than the capacity instead of truncating.

use core::fmt;
use core::marker::PhantomData;
use core::ops::Deref;

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::segment::Segment;

/// Most segments in one `QueueSegments` request.
pub const MAX_SEGMENTS_PER_FRAME: usize = 4;

/// A string of at most `N` bytes (UTF-8), e.g. the firmware name or a config field name.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FixedStr<const N: usize>(heapless::String<N>);

impl<const N: usize> FixedStr<N> {
    /// `s` cut to at most `N` bytes, at a character boundary.
    pub fn truncated(s: &str) -> Self {
        let mut end = s.len().min(N);
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        let mut out = heapless::String::new();
        // Cannot fail: `end <= N`.
        let _ = out.push_str(&s[..end]);
        FixedStr(out)
    }

    /// The last at most `N` bytes of `s`, from a character boundary (a path's tail names its
    /// file).
    pub fn tail(s: &str) -> Self {
        let mut start = s.len().saturating_sub(N);
        while !s.is_char_boundary(start) {
            start += 1;
        }
        let mut out = heapless::String::new();
        // Cannot fail: `s.len() - start <= N`.
        let _ = out.push_str(&s[start..]);
        FixedStr(out)
    }

    pub fn as_str(&self) -> &str {
        self.0.as_str()
    }
}

impl<const N: usize> Deref for FixedStr<N> {
    type Target = str;
    fn deref(&self) -> &str {
        self.0.as_str()
    }
}

impl<const N: usize> fmt::Display for FixedStr<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl<const N: usize> Serialize for FixedStr<N> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de, const N: usize> Deserialize<'de> for FixedStr<N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<const N: usize> Visitor<'_> for V<N> {
            type Value = FixedStr<N>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "a string of at most {N} bytes")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
                let mut s = heapless::String::new();
                s.push_str(v).map_err(|_| E::invalid_length(v.len(), &self))?;
                Ok(FixedStr(s))
            }
        }
        d.deserialize_str(V::<N>)
    }
}

/// Up to [`MAX_SEGMENTS_PER_FRAME`] segments, queued all-or-nothing.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SegmentBatch(heapless::Vec<Segment, MAX_SEGMENTS_PER_FRAME>);

impl SegmentBatch {
    /// `None` if `segs` holds more than [`MAX_SEGMENTS_PER_FRAME`] segments.
    pub fn from_slice(segs: &[Segment]) -> Option<Self> {
        heapless::Vec::from_slice(segs).ok().map(SegmentBatch)
    }

    /// `Err(seg)` when full.
    pub fn push(&mut self, seg: Segment) -> Result<(), Segment> {
        self.0.push(seg)
    }
}

impl Deref for SegmentBatch {
    type Target = [Segment];
    fn deref(&self) -> &[Segment] {
        &self.0
    }
}

impl Serialize for SegmentBatch {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(self.0.len()))?;
        for seg in &self.0 {
            seq.serialize_element(seg)?;
        }
        seq.end()
    }
}

impl<'de> Deserialize<'de> for SegmentBatch {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V(PhantomData<Segment>);
        impl<'de> Visitor<'de> for V {
            type Value = SegmentBatch;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "at most {MAX_SEGMENTS_PER_FRAME} segments")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                // Check the announced length first so a huge count costs nothing.
                if seq.size_hint().is_some_and(|n| n > MAX_SEGMENTS_PER_FRAME) {
                    return Err(de::Error::invalid_length(seq.size_hint().unwrap_or(0), &self));
                }
                let mut v = heapless::Vec::new();
                while let Some(seg) = seq.next_element::<Segment>()? {
                    v.push(seg).map_err(|_| de::Error::invalid_length(v.len() + 1, &self))?;
                }
                Ok(SegmentBatch(v))
            }
        }
        d.deserialize_seq(V(PhantomData))
    }
}

/// Most bytes of one step-event block on the link ([`crate::polar::stream::MAX_BLOCK`]).
pub const MAX_EVENT_BLOCK: usize = crate::polar::stream::MAX_BLOCK;

/// The bytes of one step-event stream block (v1, `src/polar/stream/block.rs`): postcard bytes
/// (length-prefixed), refused above [`MAX_EVENT_BLOCK`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BlockBytes(heapless::Vec<u8, MAX_EVENT_BLOCK>);

impl BlockBytes {
    /// `None` if `bytes` is longer than [`MAX_EVENT_BLOCK`].
    pub fn from_slice(bytes: &[u8]) -> Option<Self> {
        heapless::Vec::from_slice(bytes).ok().map(BlockBytes)
    }
}

impl Deref for BlockBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.0
    }
}

impl Serialize for BlockBytes {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

impl<'de> Deserialize<'de> for BlockBytes {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = BlockBytes;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "at most {MAX_EVENT_BLOCK} bytes")
            }
            fn visit_bytes<E: de::Error>(self, v: &[u8]) -> Result<Self::Value, E> {
                BlockBytes::from_slice(v).ok_or_else(|| E::invalid_length(v.len(), &self))
            }
        }
        d.deserialize_bytes(V)
    }
}

/// One step-event block for `QueueEvents`; `last` marks the stream's final block (the board's
/// playback finishes after it instead of waiting for more: an empty queue before it is an
/// underrun).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EventBlock {
    pub bytes: BlockBytes,
    pub last: bool,
}
