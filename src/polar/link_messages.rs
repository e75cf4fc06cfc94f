//! Polar contouring's link requests: recorded step-event blocks and their playback, copy jobs
//! and the teach recording. Carried in the link's envelope (`RequestBody::Capability`); the
//! session hands them to [`PolarRequest::execute`].

use serde::{Deserialize, Serialize};

use super::feed::check_block;
use super::playback::SizeScale;
use crate::machine::CommandKind;
use crate::protocol::bounded::EventBlock;
use crate::protocol::session::{config_nak, plain, CapabilityRequests, Nak, RequestContext};
use crate::protocol::{ErrorCode, LinkTarget, NakDetail, Reply, TeachChunk};

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
// Fixed capacity is the point (no allocation on the board); boxing is not an option.
#[allow(clippy::large_enum_variant)]
pub enum PolarRequest {
    /// Queue one block of a recorded step-event stream (v1, with its CRC) for an event job.
    /// Checked whole (CRC, every event, block sequence from 0) before anything is queued; costs
    /// one *event* credit (`Status::event_credits`, answered with `Reply::EventCredits`).
    /// Refused while segments are queued (a job is either segments or events).
    QueueEvents(EventBlock),
    /// Start the event job: play the queued events with radial size scale `m`:`k` (each 1..=4,
    /// else `OutOfRange`); speed scale = the feed override (0.25..=2). Needs queued events.
    StartPlayback { m: u8, k: u8 },
    /// Start a copy job (`Ready`, nothing queued; needs `CAP_COPY_JOB`): from the next tick the
    /// arm and carriage encoders drive theta and r live, r scaled `m`:`k` (each 1..=4, else
    /// `OutOfRange`); the encoders' counts now are the job's origin. With `teach`, every
    /// encoder count is recorded with its tick interval for `ReadTeach` (a new recording; the
    /// last one is dropped). Runs until `Abort` or a fault; `Hold`/`Resume` as for a job.
    StartCopy { m: u8, k: u8, teach: bool },
    /// The recording's stream block `block` (v1, seq from 0), answered with `Reply::Teach`.
    /// Asking for `block` tells the board the host has every block before it (they are
    /// dropped); asking again for the same block answers it again. Accepted in every state.
    ReadTeach { block: u16 },
}

/// `PolarRequest::QueueEvents`'s own index.
const QUEUE_EVENTS: u8 = 0;
/// `PolarRequest::ReadTeach`'s own index.
const READ_TEACH: u8 = 3;

impl PolarRequest {
    /// The variant's postcard index.
    pub const fn index(&self) -> u8 {
        match self {
            PolarRequest::QueueEvents(_) => QUEUE_EVENTS,
            PolarRequest::StartPlayback { .. } => 1,
            PolarRequest::StartCopy { .. } => 2,
            PolarRequest::ReadTeach { .. } => READ_TEACH,
        }
    }
}

impl CapabilityRequests for PolarRequest {
    fn command_kind(&self) -> Option<CommandKind> {
        match self {
            PolarRequest::QueueEvents(_) => Some(CommandKind::Queue),
            PolarRequest::StartPlayback { .. } | PolarRequest::StartCopy { .. } => {
                Some(CommandKind::Start)
            }
            PolarRequest::ReadTeach { .. } => None,
        }
    }

    fn event_blocks(&self) -> u16 {
        match self {
            PolarRequest::QueueEvents(_) => 1,
            _ => 0,
        }
    }

    fn execute(&self, cx: &RequestContext, t: &mut impl LinkTarget) -> Result<Reply, Nak> {
        match self {
            PolarRequest::QueueEvents(block) => {
                if t.event_credits() == 0 {
                    return Err(plain(ErrorCode::QueueFull));
                }
                let expected = t.next_event_block();
                check_block(&block.bytes, expected).map_err(|e| {
                    (ErrorCode::InvalidSegment, NakDetail::Block { reason: e.code(), expected })
                })?;
                t.queue_events(&block.bytes, block.last).map_err(|c| cx.refusal(c))?;
                Ok(Reply::EventCredits(t.event_credits()))
            }
            PolarRequest::StartPlayback { m, k } => {
                let scale = SizeScale::new(*m, *k).ok_or(plain(ErrorCode::OutOfRange))?;
                t.config().validate().map_err(config_nak)?;
                t.start_playback(scale).map_err(|c| cx.refusal(c))?;
                Ok(Reply::None)
            }
            PolarRequest::StartCopy { m, k, teach } => {
                let scale = SizeScale::new(*m, *k).ok_or(plain(ErrorCode::OutOfRange))?;
                t.config().validate().map_err(config_nak)?;
                t.start_copy(scale, *teach).map_err(|c| cx.refusal(c))?;
                Ok(Reply::None)
            }
            PolarRequest::ReadTeach { block } => {
                Ok(Reply::Teach(t.read_teach(*block).map_err(plain)?))
            }
        }
    }

    fn replay(index: u8, t: &impl LinkTarget, event_credits: u16) -> Reply {
        match index {
            QUEUE_EVENTS => Reply::EventCredits(event_credits),
            // The oldest block still held, read again without dropping anything.
            READ_TEACH => t.teach_resend().map_or(Reply::None, Reply::Teach),
            _ => Reply::None,
        }
    }
}

/// What polar's requests need of the board: event jobs and copy jobs. Every method has a
/// default for a target without them (`Unsupported`, or nothing to resend).
pub trait PolarTarget {
    /// The stream block seq the target takes next (0 for a new job); `None` once the host
    /// marked a block as the last.
    fn next_event_block(&self) -> Option<u16> {
        None
    }
    /// Called with a block that passed every stream check and is `next_event_block()`, only
    /// with an event credit free.
    fn queue_events(&mut self, _block: &[u8], _last: bool) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// Starts the event job with radial size scale `scale` (checked).
    fn start_playback(&mut self, _scale: SizeScale) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// Starts a copy job with a checked size scale (`Ready`, nothing queued, no job; else
    /// `OutOfState`). Targets without copy jobs: `Unsupported`.
    fn start_copy(&mut self, _scale: SizeScale, _teach: bool) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// `ReadTeach { block }` (see `polar::copy_link::TeachRecorder::read`).
    fn read_teach(&mut self, _block: u16) -> Result<TeachChunk, ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// The answer a retransmitted `ReadTeach` gets again: the oldest block still held (the one
    /// the last `ReadTeach` asked for), read without dropping anything.
    fn teach_resend(&self) -> Option<TeachChunk> {
        None
    }
}
