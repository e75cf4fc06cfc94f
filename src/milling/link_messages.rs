//! Milling's link request: arming the constant-force loop for the next segment job. Carried in
//! the link's envelope (`RequestBody::Capability`); the session hands it to
//! [`MillingRequest::execute`].

use crate::milling::link_params::ForceJobParams;
use serde::{Deserialize, Serialize};

use super::link_job::check_job;
use crate::machine::CommandKind;
use crate::protocol::session::{
    config_nak, plain, range_nak, CapabilityRequests, Nak, RequestContext,
};
use crate::protocol::{ErrorCode, LinkTarget, Reply, CAP_MILLING_JOB};

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum MillingRequest {
    /// Arm the constant-force loop for the next segment job (`Ready`, nothing queued, no other
    /// job armed; needs `CAP_MILLING_JOB`): from its `Start` on, force samples run through the
    /// force chain and the control law, whose feed override drives the DDA; force faults hold
    /// the feed through the machine's fault model. Parameters out of range -> `OutOfRange` with
    /// `NakDetail::Config` naming the field.
    ArmForce(ForceJobParams),
}

impl MillingRequest {
    /// The variant's postcard index.
    pub const fn index(&self) -> u8 {
        match self {
            MillingRequest::ArmForce(_) => 0,
        }
    }
}

impl CapabilityRequests for MillingRequest {
    fn command_kind(&self) -> Option<CommandKind> {
        Some(CommandKind::Start)
    }

    fn execute(&self, cx: &RequestContext, t: &mut impl LinkTarget) -> Result<Reply, Nak> {
        let MillingRequest::ArmForce(p) = self;
        if !cx.has(CAP_MILLING_JOB) {
            return Err(plain(ErrorCode::Unsupported));
        }
        check_job(p).map_err(range_nak)?;
        t.config().validate().map_err(config_nak)?;
        t.arm_force(p).map_err(|code| match code {
            ErrorCode::OutOfRange => range_nak("sample_hz"),
            _ => cx.refusal(code),
        })?;
        Ok(Reply::None)
    }
}

/// What milling's request needs of the board: a force job armed. Defaults to `Unsupported`,
/// for a target without force jobs.
pub trait MillingTarget {
    /// Arms a force job with checked parameters (`Ready`, empty queue, no events, no other job
    /// armed; else `OutOfState`). `OutOfRange` from the target means the sample rate does not
    /// fit the board (the NAK names `sample_hz`). Targets without force jobs: `Unsupported`.
    fn arm_force(&mut self, _params: &ForceJobParams) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
}
