//! [`Feed`]: what a request changes besides `Motion` (the segment queue, the event blocks,
//! the preparer and the tick rate, the Z staging buffer, the teach recording).

use heapless::Deque;
use motion::dda::Preparer;
use motion::machine::BoardConfig;
use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};
use motion::polar::feed::{EventFeed, EVENT_QUEUE_BLOCKS};
use motion::segment::Segment;
use motion::turning::link_requests::ZRequests;

use super::SEGMENT_QUEUE;
use crate::board;

/// What a [`Target`] changes besides `Motion`: the segment queue and what rebuilding the DDA
/// needs.
pub(super) struct Feed {
    pub(super) queue: Deque<Segment, SEGMENT_QUEUE>,
    /// Verified event blocks waiting for the playback.
    pub(super) events: EventFeed<EVENT_QUEUE_BLOCKS>,
    pub(super) preparer: Preparer,
    pub(super) tick_rate: board::TickRate,
    /// Milliseconds of DDA time before the current DDA was created (SetConfig restarts its
    /// clock), so the status clock never goes back.
    pub(super) clock_base_ms: u64,
    /// Latched faults already announced with a `Fault` frame.
    pub(super) announced: u32,
    /// A config accepted since the last save, to persist once the machine is at rest.
    pub(super) save_pending: Option<BoardConfig>,
    /// The Z table upload's staging buffer.
    pub(super) z: ZRequests,
    /// The copy job's teach recording, in blocks for `ReadTeach`.
    pub(super) teach: TeachRecorder<TEACH_BLOCKS>,
}
