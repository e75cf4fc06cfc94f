//! Which requests are machine commands (the state table decides those), and the wire job's
//! parameter check.

use crate::machine::CommandKind;
use crate::protocol::messages::*;

/// `ArmWire`'s parameters are usable: counts and limits at least 1, overrides in (0, 2.0].
pub fn wire_params_ok(p: &WireJobParams) -> bool {
    let rate_ok = |b: u32| b != 0 && b <= MAX_OVERRIDE_BITS;
    p.debounce_ticks >= 1
        && p.retrace_limit_steps >= 1
        && p.segments >= 1
        && rate_ok(p.retrace_override_bits)
        && rate_ok(p.resume_override_bits)
}

/// The machine command a request is, if it is one (queries and link settings are not).
pub const fn command_kind(body: &RequestBody) -> Option<CommandKind> {
    Some(match body {
        RequestBody::SetConfig(_) | RequestBody::SetHoming(_) => CommandKind::SetConfig,
        RequestBody::Home => CommandKind::Home,
        RequestBody::QueueSegments(_) | RequestBody::QueueEvents(_) => CommandKind::Queue,
        RequestBody::Start
        | RequestBody::StartPlayback { .. }
        | RequestBody::ArmWire(_)
        | RequestBody::StartCopy { .. }
        | RequestBody::ArmForce(_)
        | RequestBody::ArmProbe(_) => CommandKind::Start,
        RequestBody::Hold => CommandKind::Hold,
        RequestBody::Resume => CommandKind::Resume,
        RequestBody::Abort => CommandKind::Abort,
        RequestBody::ClearFault => CommandKind::ClearFault,
        RequestBody::JogOffLimit => CommandKind::JogOff,
        // -- Z-slide job --
        RequestBody::ZTableBegin(_)
        | RequestBody::ZTableChunk { .. }
        | RequestBody::ZTableEnd { .. } => CommandKind::Queue,
        RequestBody::StartZ(_) => CommandKind::Start,
        RequestBody::Hello { .. }
        | RequestBody::GetConfig
        | RequestBody::GetStatus
        | RequestBody::SetOverride { .. }
        | RequestBody::SetStatusPeriod { .. }
        | RequestBody::ReadTeach { .. }
        | RequestBody::SetProgramOutputs(_) => return None,
        #[cfg(feature = "sim-inputs")]
        RequestBody::Sim(_) => return None,
    })
}
