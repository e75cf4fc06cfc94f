//! The messages. Link form: postcard (varints for integers, enum variants as varint indices in
//! declaration order). Compatibility rule: new variants and fields go at the end, and anything
//! that changes the meaning of existing bytes bumps [`PROTOCOL_VERSION`].
//!
//! The parts: `requests` (host -> board), `replies` (board -> host: Ack/Nak and what they
//! carry), `status` (the status report and the board's counters), `link_config` (the config and
//! homing as set over the link) and `decode`. A capability's requests and their parameters are
//! its own (`link_messages` in its folder), carried in `RequestBody::Capability`.
//! The version, the capability bits and the sizes every part shares are here.

mod decode;
mod link_config;
mod replies;
mod requests;
mod status;

pub use decode::{decode_request, decode_response, Malformed};
pub use link_config::{AxisScale, HomingConfig, LinkConfig};
pub use replies::{HelloInfo, NakDetail, PanicSite, Reply, Response, TeachChunk};
pub use requests::{Request, RequestBody, KIND_SIM};
pub use status::{BoardCounters, LinkState, Status};

use crate::segment::Rate;

pub const PROTOCOL_VERSION: u16 = 10;
/// Sensor channels reported in [`Status`].
pub const SENSOR_CHANNELS: usize = 4;
/// Longest firmware name in [`HelloInfo`].
pub const FIRMWARE_NAME_LEN: usize = 24;
/// Longest source path a [`PanicSite`] carries (the tail is kept: it names the file).
pub const PANIC_FILE_LEN: usize = 40;
/// Longest config field name in an `InvalidConfig` NAK.
pub const FIELD_NAME_LEN: usize = 24;
/// Largest feed override, as `Rate` bits (2.0).
pub const MAX_OVERRIDE_BITS: u32 = 2 << Rate::FRAC_NBITS;
/// Fastest periodic status stream.
pub const MIN_STATUS_PERIOD_MS: u16 = 10;

/// Capability bits in [`HelloInfo::capabilities`].
pub const CAP_DDA: u32 = 1 << 0;
/// `SetStatusPeriod` streams unsolicited `Status` frames.
pub const CAP_STATUS_STREAM: u32 = 1 << 1;
/// `SetOverride` is honoured.
pub const CAP_OVERRIDE: u32 = 1 << 2;
/// `Hold` / `Resume` are honoured.
pub const CAP_HOLD_RESUME: u32 = 1 << 3;
/// Soft limits in [`LinkConfig`] are enforced when segments are queued.
pub const CAP_SOFT_LIMITS: u32 = 1 << 4;
/// `Status::sensors` carries real readings.
pub const CAP_SENSORS: u32 = 1 << 5;
/// `QueueEvents` / `StartPlayback` (recorded step-event jobs) are honoured.
pub const CAP_EVENTS: u32 = 1 << 6;
/// `ArmWire` (wire-manipulator jobs with wire-stall retrace) is honoured.
pub const CAP_WIRE_JOB: u32 = 1 << 7;
/// `Sim` requests drive simulated inputs (a simulator board only: QEMU has no GPIO; the
/// firmware is built with the `sim-inputs` feature).
pub const CAP_SIM_INPUTS: u32 = 1 << 8;
// -- Z-slide job --
/// Z-slide jobs (`ZTableBegin`/`ZTableChunk`/`ZTableEnd`, `StartZ`) are honoured.
pub const CAP_TURNING_JOB: u32 = 1 << 9;
/// Most table bytes in one `ZTableChunk`.
pub const MAX_Z_CHUNK: usize = 192;
// -- force job --
/// `ArmForce` (constant-force milling jobs) is honoured; `Sim(Milling)` too with `CAP_SIM_INPUTS`.
pub const CAP_MILLING_JOB: u32 = 1 << 10;
// -- copy mode --
/// `StartCopy` / `ReadTeach` (copy mode from two encoders, teach recording) are honoured.
pub const CAP_COPY_JOB: u32 = 1 << 11;
/// `ArmProbe` (G38.x probe moves on the board's debounced probe input) is honoured.
pub const CAP_PROBE: u32 = 1 << 12;
