//! The link's envelope for the capabilities' requests: [`CapabilityRequest`] holds one
//! capability's own request enum (declared in its folder, implementing
//! [`CapabilityRequests`]), and `RequestBody::Capability` carries it. The session walks this
//! envelope, never a capability's variants. A fifth capability adds one line to the list below.
//!
//! On the link a capability's request is the envelope's variant index (its place in the list)
//! then its own variant index, so a capability's requests are appended to its own enum and a
//! capability to the end of the list; anything else bumps `PROTOCOL_VERSION`.

use serde::{Deserialize, Serialize};

use crate::machine::CommandKind;
use crate::protocol::session::{CapabilityRequests, Nak, RequestContext};
use crate::protocol::{LinkTarget, Reply, RequestBody};

/// `RequestBody::kind()` of a capability's request: this, plus 8 times its place in the list,
/// plus its own variant index (below 8). The link's own requests stay below it.
pub const KIND_BASE: u8 = 0x40;
/// Variants a capability's request enum may have: its kinds stay apart from the next one's.
pub const MAX_REQUESTS_PER_CAPABILITY: u8 = 8;

macro_rules! capability_requests {
    ($($place:literal: $name:ident($request:path, $target:path),)+) => {
        /// What every capability's requests need of the board: each capability's target trait
        /// (every method with a default, so a target fills only its capabilities').
        pub trait CapabilityTargets: $($target+)+ {}
        impl<T: $($target+)+> CapabilityTargets for T {}

        /// A capability's request, in its place in the envelope.
        #[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
        pub enum CapabilityRequest {
            $($name($request),)+
        }

        impl CapabilityRequest {
            /// Its place in the envelope and its own variant index.
            pub const fn place_and_index(&self) -> (u8, u8) {
                match self {
                    $(CapabilityRequest::$name(r) => ($place, r.index()),)+
                }
            }

            /// The machine command it is (the state table decides those), if it is one.
            pub fn command_kind(&self) -> Option<CommandKind> {
                match self {
                    $(CapabilityRequest::$name(r) => r.command_kind(),)+
                }
            }

            /// Event blocks it queues if it succeeds.
            pub fn event_blocks(&self) -> u16 {
                match self {
                    $(CapabilityRequest::$name(r) => r.event_blocks(),)+
                }
            }

            /// Its owner's checks and call on the target.
            pub fn execute(
                &self,
                cx: &RequestContext,
                t: &mut impl LinkTarget,
            ) -> Result<Reply, Nak> {
                match self {
                    $(CapabilityRequest::$name(r) => r.execute(cx, t),)+
                }
            }
        }

        /// What a retransmission of the capability request of `kind` that succeeded answers.
        pub fn replay(kind: u8, t: &impl LinkTarget, event_credits: u16) -> Reply {
            let (place, index) = (
                kind.wrapping_sub(KIND_BASE) / MAX_REQUESTS_PER_CAPABILITY,
                kind % MAX_REQUESTS_PER_CAPABILITY,
            );
            match place {
                $($place => <$request as CapabilityRequests>::replay(index, t, event_credits),)+
                _ => Reply::None,
            }
        }

        $(impl From<$request> for RequestBody {
            fn from(r: $request) -> RequestBody {
                RequestBody::Capability(CapabilityRequest::$name(r))
            }
        })+
    };
}

capability_requests! {
    0: Polar(crate::polar::link_messages::PolarRequest, crate::polar::link_messages::PolarTarget),
    1: Turning(
        crate::turning::link_messages::TurningRequest,
        crate::turning::link_messages::TurningTarget
    ),
    2: Milling(
        crate::milling::link_messages::MillingRequest,
        crate::milling::link_messages::MillingTarget
    ),
    3: Wire(crate::wire::link_messages::WireRequest, crate::wire::link_messages::WireTarget),
}

impl CapabilityRequest {
    /// Its `RequestBody::kind()`.
    pub const fn kind(&self) -> u8 {
        let (place, index) = self.place_and_index();
        KIND_BASE + place * MAX_REQUESTS_PER_CAPABILITY + index
    }
}

/// The kind belongs to a capability's request (a kind past the last capability's has no owner:
/// [`replay`] answers it `Reply::None`).
pub const fn is_capability_kind(kind: u8) -> bool {
    kind >= KIND_BASE
}
