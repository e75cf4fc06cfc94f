//! The wire manipulator's link request: arming a wire job. Carried in the link's envelope
//! (`RequestBody::Capability`); the session hands it to [`WireRequest::execute`].

use serde::{Deserialize, Serialize};

use crate::machine::CommandKind;
use crate::protocol::session::{config_nak, plain, CapabilityRequests, Nak, RequestContext};
use crate::protocol::{ErrorCode, LinkTarget, Reply, MAX_OVERRIDE_BITS};

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum WireRequest {
    /// Arm a wire-manipulator job (`Ready`, nothing queued; needs `CAP_WIRE_JOB`): the next
    /// `segments` segments queued with `QueueSegments` (4 axes: X, Y, beta, alpha) form the
    /// job, and `Start` runs it through the wire-stall retrace controller instead of the plain
    /// feeder. Parameters out of range -> `OutOfRange`.
    ArmWire(WireJobParams),
}

impl WireRequest {
    /// The variant's postcard index.
    pub const fn index(&self) -> u8 {
        match self {
            WireRequest::ArmWire(_) => 0,
        }
    }
}

/// `ArmWire`'s parameters are usable: counts and limits at least 1, overrides in (0, 2.0].
pub fn wire_params_ok(p: &WireJobParams) -> bool {
    let rate_ok = |b: u32| b != 0 && b <= MAX_OVERRIDE_BITS;
    p.debounce_ticks >= 1
        && p.retrace_limit_steps >= 1
        && p.segments >= 1
        && rate_ok(p.retrace_override_bits)
        && rate_ok(p.resume_override_bits)
}

impl CapabilityRequests for WireRequest {
    fn command_kind(&self) -> Option<CommandKind> {
        Some(CommandKind::Start)
    }

    fn execute(&self, cx: &RequestContext, t: &mut impl LinkTarget) -> Result<Reply, Nak> {
        let WireRequest::ArmWire(p) = self;
        if !wire_params_ok(p) {
            return Err(plain(ErrorCode::OutOfRange));
        }
        t.config().validate().map_err(config_nak)?;
        t.arm_wire(p).map_err(|c| cx.refusal(c))?;
        Ok(Reply::None)
    }
}

/// What the wire manipulator's request needs of the board: a wire job armed. Defaults to
/// `Unsupported`, for a target without wire jobs.
pub trait WireTarget {
    /// Arms a wire job with checked parameters (`Ready`, empty queue, no events); refused
    /// with `OutOfState` otherwise. Targets without wire jobs: `Unsupported`.
    fn arm_wire(&mut self, _params: &WireJobParams) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
}

/// A wire job's stall handling (`motion::wire::controller::StallParams`) and length.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WireJobParams {
    /// Consecutive ticks the stall switch must agree before a change counts (>= 1).
    pub debounce_ticks: u16,
    /// Largest retraced distance of one stall, sum of absolute steps over the four axes (>= 1).
    pub retrace_limit_steps: u64,
    /// Feed override while retracing and after the return, `Rate` bits (0 < x <= 2.0).
    pub retrace_override_bits: u32,
    pub resume_override_bits: u32,
    /// Job segments run at `resume_override_bits` after a return.
    pub resume_segments: u32,
    /// Segments in the job (>= 1).
    pub segments: u32,
}
