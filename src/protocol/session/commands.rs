//! Which requests are machine commands (the state table decides those).

use crate::machine::CommandKind;
use crate::protocol::messages::*;

/// The machine command a request is, if it is one (queries and link settings are not).
pub fn command_kind(body: &RequestBody) -> Option<CommandKind> {
    Some(match body {
        RequestBody::SetConfig(_) | RequestBody::SetHoming(_) => CommandKind::SetConfig,
        RequestBody::Home => CommandKind::Home,
        RequestBody::QueueSegments(_) => CommandKind::Queue,
        RequestBody::Start | RequestBody::ArmProbe(_) => CommandKind::Start,
        RequestBody::Hold => CommandKind::Hold,
        RequestBody::Resume => CommandKind::Resume,
        RequestBody::Abort => CommandKind::Abort,
        RequestBody::ClearFault => CommandKind::ClearFault,
        RequestBody::JogOffLimit => CommandKind::JogOff,
        RequestBody::Capability(c) => return c.command_kind(),
        RequestBody::Hello { .. }
        | RequestBody::GetConfig
        | RequestBody::GetStatus
        | RequestBody::SetOverride { .. }
        | RequestBody::SetStatusPeriod { .. }
        | RequestBody::SetProgramOutputs(_) => return None,
        #[cfg(feature = "sim-inputs")]
        RequestBody::Sim(_) => return None,
    })
}
