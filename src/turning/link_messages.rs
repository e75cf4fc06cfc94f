//! Turning's link requests: the Z coefficient-table upload and the Z-slide job's start. Carried
//! in the link's envelope (`RequestBody::Capability`); the session hands them to
//! [`TurningRequest::execute`], which calls the target's Z hooks (the board's side is
//! [`super::link_requests::ZRequests`]).

use serde::{Deserialize, Serialize};

use super::link_job::{ZJobSpec, ZTableHeader};
use super::link_requests::ZNak;
use crate::machine::CommandKind;
use crate::protocol::bounded::BlockBytes;
use crate::protocol::session::{config_nak, plain, CapabilityRequests, Nak, RequestContext};
use crate::protocol::{ErrorCode, LinkTarget, NakDetail, Reply, MAX_Z_CHUNK};

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
// Fixed capacity is the point (no allocation on the board); boxing is not an option.
#[allow(clippy::large_enum_variant)]
pub enum TurningRequest {
    /// Opens a Z coefficient-table upload (drops an unfinished one). Queue column; refused
    /// (`OutOfState`) while a Z job runs; a bad header -> `InvalidTable`.
    ZTableBegin(ZTableHeader),
    /// Table bytes `index` (0, 1, ... in order; at most [`MAX_Z_CHUNK`] bytes): little-endian
    /// `i32` coefficients, row after row. Out of order or too long -> `InvalidTable` (the
    /// upload is dropped, the active table stays).
    ZTableChunk { index: u16, bytes: BlockBytes },
    /// Ends the upload: every byte, the CRC-32 over them and the table checks, then the table
    /// replaces the active one. Any refusal replaces nothing.
    ZTableEnd { crc: u32 },
    /// Starts a Z job with the active table (Start column; `Ready`, nothing queued). No table
    /// or a job already there -> `OutOfState`; spec out of range -> `OutOfRange`; the pre-start
    /// check (spindle speed, slide limits) -> `OutOfRange` with `NakDetail::Turning { fault }`.
    StartZ(ZJobSpec),
}

impl TurningRequest {
    /// The variant's postcard index.
    pub const fn index(&self) -> u8 {
        match self {
            TurningRequest::ZTableBegin(_) => 0,
            TurningRequest::ZTableChunk { .. } => 1,
            TurningRequest::ZTableEnd { .. } => 2,
            TurningRequest::StartZ(_) => 3,
        }
    }
}

impl CapabilityRequests for TurningRequest {
    fn command_kind(&self) -> Option<CommandKind> {
        Some(match self {
            TurningRequest::StartZ(_) => CommandKind::Start,
            _ => CommandKind::Queue,
        })
    }

    fn execute(&self, cx: &RequestContext, t: &mut impl LinkTarget) -> Result<Reply, Nak> {
        match self {
            TurningRequest::ZTableBegin(h) => t.z_table_begin(h),
            TurningRequest::ZTableChunk { index, bytes } => {
                if bytes.len() > MAX_Z_CHUNK {
                    return Err(plain(ErrorCode::OutOfRange));
                }
                t.z_table_chunk(*index, bytes)
            }
            TurningRequest::ZTableEnd { crc } => t.z_table_end(*crc),
            TurningRequest::StartZ(spec) => {
                t.config().validate().map_err(config_nak)?;
                t.start_z(spec)
            }
        }
        .map_err(|e| cx.with_state(e))?;
        Ok(Reply::None)
    }
}

/// What turning's requests need of the board: the Z table upload and the Z job's start.
/// Every method defaults to `Unsupported`, for a target without Z jobs.
pub trait TurningTarget {
    /// `ZTableBegin` (see `motion::turning::link_requests::ZRequests`). A refusal changes
    /// nothing; `OutOfState` with `NakDetail::None` gets the machine state filled in.
    fn z_table_begin(&mut self, _h: &ZTableHeader) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
    /// `ZTableChunk` with at most `MAX_Z_CHUNK` bytes.
    fn z_table_chunk(&mut self, _index: u16, _bytes: &[u8]) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
    /// `ZTableEnd`: the checked table replaces the active one, or nothing changes.
    fn z_table_end(&mut self, _crc: u32) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
    /// `StartZ` (Start column passed, config valid).
    fn start_z(&mut self, _spec: &ZJobSpec) -> Result<(), ZNak> {
        Err((ErrorCode::Unsupported, NakDetail::None))
    }
}
