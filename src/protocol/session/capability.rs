//! The session's contract with a capability's requests. A capability declares its requests as
//! one enum in its own folder and implements [`CapabilityRequests`] for it; the registry
//! (`crate::capabilities::requests`) puts each enum in the link's one envelope,
//! `RequestBody::Capability`, and the session hands the request to its owner with a
//! [`RequestContext`]. The session names no capability.

use super::target::LinkTarget;
use crate::config::ConfigError;
use crate::machine::{CommandKind, MachineState};
use crate::protocol::bounded::FixedStr;
use crate::protocol::errors::ErrorCode;
use crate::protocol::messages::{NakDetail, Reply};

/// A refusal as the link sends it.
pub type Nak = (ErrorCode, NakDetail);

/// A capability's requests, as the session runs them.
pub trait CapabilityRequests {
    /// The machine command the request is (the state table decides those), if it is one.
    fn command_kind(&self) -> Option<CommandKind>;
    /// Event blocks the request queues if it succeeds (one event credit each).
    fn event_blocks(&self) -> u16 {
        0
    }
    /// The request's own checks and its call on the target, once the sequence rules and the
    /// state table let it run. A refusal must have changed nothing.
    fn execute(&self, cx: &RequestContext, t: &mut impl LinkTarget) -> Result<Reply, Nak>;
    /// What a retransmission of the request that succeeded (the capability's own variant
    /// `index`) answers: nothing is executed again. `event_credits`: the event credits right
    /// after the request ran.
    fn replay(index: u8, t: &impl LinkTarget, event_credits: u16) -> Reply {
        let _ = (index, t, event_credits);
        Reply::None
    }
}

/// What a capability's request handler knows of the link.
#[derive(Clone, Copy, Debug)]
pub struct RequestContext {
    /// The machine's state when the request arrived (the command table has passed it).
    pub machine: MachineState,
    /// The board's `HelloInfo` capability bits (`CAP_*`).
    pub capabilities: u32,
}

impl RequestContext {
    /// The board announces every bit of `bits`.
    pub fn has(&self, bits: u32) -> bool {
        self.capabilities & bits == bits
    }

    /// `OutOfState`, naming the machine state.
    pub fn out_of_state(&self) -> Nak {
        (ErrorCode::OutOfState, NakDetail::State(self.machine))
    }

    /// A target's refusal: `OutOfState` names the machine state, any other code goes bare.
    pub fn refusal(&self, code: ErrorCode) -> Nak {
        match code {
            ErrorCode::OutOfState => self.out_of_state(),
            _ => plain(code),
        }
    }

    /// A target's refusal with its detail: a bare `OutOfState` gets the machine state.
    pub fn with_state(&self, e: Nak) -> Nak {
        match e {
            (ErrorCode::OutOfState, NakDetail::None) => self.out_of_state(),
            other => other,
        }
    }
}

/// A refusal without detail.
pub fn plain(code: ErrorCode) -> Nak {
    (code, NakDetail::None)
}

/// `OutOfRange` naming the parameter (a job's field).
pub fn range_nak(field: &'static str) -> Nak {
    (ErrorCode::OutOfRange, NakDetail::Config { field: FixedStr::truncated(field), axis: None })
}

/// `InvalidConfig` naming the field (and axis) the config check refused.
pub fn config_nak(e: ConfigError) -> Nak {
    (
        ErrorCode::InvalidConfig,
        NakDetail::Config { field: FixedStr::truncated(e.field), axis: e.axis },
    )
}
