//! The messages. Wire form: postcard (varints for integers, enum variants as varint indices in
//! declaration order). Compatibility rule: new variants and fields go at the end, and anything
//! that changes the meaning of existing bytes bumps [`PROTOCOL_VERSION`].

use serde::{Deserialize, Serialize};

use super::bounded::{BlockBytes, EventBlock, FixedStr, SegmentBatch};
use super::errors::{ErrorCode, FaultCode, SegmentReason};
use super::program_outputs::ProgramOutputs;
#[cfg(feature = "sim-inputs")]
use super::sim::messages::SimRequest;
use crate::config::{
    AxisLimits, ConfigError, InputFilterConfig, MachineConfig, StepTiming, TickTiming, MAX_AXES,
};
use crate::dda::MotionState;
use crate::machine::{HomeAxis, MachineState, ProbeKind};
use crate::segment::Rate;
use crate::zslide::link_job::{ZJobSpec, ZTableHeader};

pub const PROTOCOL_VERSION: u16 = 9;
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
/// Soft limits in [`WireConfig`] are enforced when segments are queued.
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
pub const CAP_ZSLIDE_JOB: u32 = 1 << 9;
/// Most table bytes in one `ZTableChunk`.
pub const MAX_Z_CHUNK: usize = 192;
// -- force job --
/// `ArmForce` (constant-force milling jobs) is honoured; `Sim(Milling)` too with `CAP_SIM_INPUTS`.
pub const CAP_FORCE_JOB: u32 = 1 << 10;
// -- copy mode --
/// `StartCopy` / `ReadTeach` (copy mode from two encoders, teach recording) are honoured.
pub const CAP_COPY_JOB: u32 = 1 << 11;
/// `ArmProbe` (G38.x probe moves on the board's debounced probe input) is honoured.
pub const CAP_PROBE: u32 = 1 << 12;

/// Host -> board.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Request {
    /// Consecutive per session, starting at the Hello's seq; see `session` for the rules.
    pub seq: u32,
    pub body: RequestBody,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
// Fixed capacity is the point (no allocation on the board); boxing is not an option.
#[allow(clippy::large_enum_variant)]
pub enum RequestBody {
    /// Opens a session (seq numbering restarts at this request's seq). `nonce` tells a
    /// retransmitted Hello (same seq and nonce: answered again, nothing reset) from a new host.
    Hello {
        version: u16,
        nonce: u32,
    },
    GetConfig,
    /// In `Idle`, `Ready` (loses homing) or `Fault`, with an empty queue.
    SetConfig(WireConfig),
    /// All-or-nothing: every segment is checked (and credits counted) before any is queued.
    QueueSegments(SegmentBatch),
    Start,
    Hold,
    Resume,
    Abort,
    /// Feed override, `Rate` bits, 0..=2.0.
    SetOverride {
        rate_bits: u32,
    },
    GetStatus,
    /// Unsolicited `Status` every `ms` (0 = off, else >= MIN_STATUS_PERIOD_MS).
    SetStatusPeriod {
        ms: u16,
    },
    ClearFault,
    /// Run the homing sequence (`Idle` or `Ready`); the machine reports `Homing`, then `Ready`.
    Home,
    /// Replace the homing parameters (a `SetConfig` that keeps the machine config; loses homing).
    SetHoming(HomingConfig),
    /// Queue one block of a recorded step-event stream (v1, with its CRC) for an event job.
    /// Checked whole (CRC, every event, block sequence from 0) before anything is queued; costs
    /// one *event* credit (`Status::event_credits`, `Reply::EventCredits`). Refused while
    /// segments are queued (a job is either segments or events).
    QueueEvents(EventBlock),
    /// Start the event job: play the queued events with radial size scale `m`:`k` (each 1..=4,
    /// else `OutOfRange`); speed scale = the feed override (0.25..=2). Needs queued events.
    StartPlayback {
        m: u8,
        k: u8,
    },
    /// After a limit fault: move the tripped axes slowly off their switches (`Fault` only).
    JogOffLimit,
    /// Arm a wire-manipulator job (`Ready`, nothing queued; needs `CAP_WIRE_JOB`): the next
    /// `segments` segments queued with `QueueSegments` (4 axes: X, Y, beta, alpha) form the
    /// job, and `Start` runs it through the wire-stall retrace controller instead of the plain
    /// feeder. Parameters out of range -> `OutOfRange`.
    ArmWire(WireJobParams),
    // -- Z-slide job --
    /// Opens a Z coefficient-table upload (drops an unfinished one). Queue column; refused
    /// (`OutOfState`) while a Z job runs; a bad header -> `InvalidTable`.
    ZTableBegin(ZTableHeader),
    /// Table bytes `index` (0, 1, ... in order; at most [`MAX_Z_CHUNK`] bytes): little-endian
    /// `i32` coefficients, row after row. Out of order or too long -> `InvalidTable` (the
    /// upload is dropped, the active table stays).
    ZTableChunk {
        index: u16,
        bytes: BlockBytes,
    },
    /// Ends the upload: every byte, the CRC-32 over them and the table checks, then the table
    /// replaces the active one. Any refusal replaces nothing.
    ZTableEnd {
        crc: u32,
    },
    /// Starts a Z job with the active table (Start column; `Ready`, nothing queued). No table
    /// or a job already there -> `OutOfState`; spec out of range -> `OutOfRange`; the pre-start
    /// check (spindle speed, slide limits) -> `OutOfRange` with `NakDetail::ZSlide { fault }`.
    StartZ(ZJobSpec),
    // -- force job --
    /// Arm the constant-force loop for the next segment job (`Ready`, nothing queued, no other
    /// job armed; needs `CAP_FORCE_JOB`): from its `Start` on, force samples run through the
    /// force chain and the control law, whose feed override drives the DDA; force faults hold
    /// the feed through the machine's fault model. Parameters out of range -> `OutOfRange` with
    /// `NakDetail::Config` naming the field.
    ArmForce(ForceJobParams),
    // -- copy mode --
    /// Start a copy job (`Ready`, nothing queued; needs `CAP_COPY_JOB`): from the next tick the
    /// arm and carriage encoders drive theta and r live, r scaled `m`:`k` (each 1..=4, else
    /// `OutOfRange`); the encoders' counts now are the job's origin. With `teach`, every
    /// encoder count is recorded with its tick interval for `ReadTeach` (a new recording; the
    /// last one is dropped). Runs until `Abort` or a fault; `Hold`/`Resume` as for a job.
    StartCopy {
        m: u8,
        k: u8,
        teach: bool,
    },
    /// The recording's stream block `block` (v1, seq from 0), answered with `Reply::Teach`.
    /// Asking for `block` tells the board the host has every block before it (they are
    /// dropped); asking again for the same block answers it again. Accepted in every state.
    ReadTeach {
        block: u16,
    },
    /// The spindle (off, clockwise, counterclockwise) and coolant (mist, flood) a program
    /// switches, all at once, from the next tick on; the wire power and the Z DAC are left as
    /// they are. Not a machine command: accepted in every state but refused (`OutOfState`,
    /// nothing changes) while an e-stop is latched or pressed. Faults that kill the outputs
    /// (e-stop and the other `Kill` reactions) switch these off too. The host sends it once the
    /// motion before it is done (program order); `Status::outputs` shows the result.
    SetProgramOutputs(ProgramOutputs),
    /// Marks the next `Start` as a probe move of this kind (G38.2..G38.5; the table's Start
    /// column, but only in `Ready` with nothing queued and no other job armed; needs
    /// `CAP_PROBE`): the segments queued after it run as the probe move, watched by the tick on
    /// the debounced probe input. The trip latches every axis's position
    /// (`Status::probe_steps`), the machine stops with a feed-hold deceleration and drops the
    /// rest of the move, and the job ends in `Ready`; see `src/machine/probe.rs` and
    /// `Status::probe_phase`.
    ArmProbe(ProbeKind),
    /// A simulator board's test hook ([`SimRequest`]; only with `CAP_SIM_INPUTS`, else
    /// `Unsupported`). Compiled only with the `sim-inputs` feature: a board built without it
    /// does not decode the variant and answers it `Unsupported` all the same.
    ///
    /// Stays the last variant: compiled out, it must not shift any other variant's index. A
    /// new request goes before it, and [`KIND_SIM`] moves up by one.
    #[cfg(feature = "sim-inputs")]
    Sim(SimRequest),
}

/// The postcard index of `RequestBody::Sim`, known with and without the `sim-inputs` feature
/// (a board without it recognises the request it cannot decode).
pub const KIND_SIM: u8 = 27;

// -- force job --
/// Contact strategy of a force job (`motion::force::control::ContactStrategy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ForceStrategy {
    /// Straight into the PI.
    Direct,
    /// Algorithm A: feed `slow_bits` (`Rate` bits) for `hold_ms`, then the PI.
    SlowHold { slow_bits: u32, hold_ms: u16 },
    /// Algorithm B: stop `stop_ms`, then `reduced_gain_q16` of the gains for `reduced_ms`.
    StopReduced { stop_ms: u16, reduced_ms: u16, reduced_gain_q16: u32 },
}

/// One force channel's calibration on the wire (`motion::force::chain::ChannelCal`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ForceCal {
    /// ADC counts at zero force (the first guess; the chain tares it while cutting air).
    pub zero_counts: u16,
    /// Millinewtons per count, Q16 (negative for a reversed sensor; not 0).
    pub mn_per_count_q16: i32,
}

/// A force job's parameters (`ArmForce`), in the firmware's units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ForceJobParams {
    /// Nominal force, contact threshold and trip level, mN (0 < contact < nominal < trip).
    pub fnom_mn: u32,
    pub contact_mn: u32,
    pub trip_mn: u32,
    /// PI gains: proportional (override per unit error, Q16) while F > Fnom (dec) and F < Fnom
    /// (inc); integral (1/s, Q16).
    pub kp_dec_q16: u32,
    pub kp_inc_q16: u32,
    pub ki_dec_per_s_q16: u32,
    pub ki_inc_per_s_q16: u32,
    /// Gain normalisation by the measured cutting stiffness (v Fnom / F).
    pub normalise: bool,
    /// The error scale without normalisation (its floor with it), Q16.
    pub fixed_scale_q16: u32,
    /// Feed clamps while cutting and the feed in air, `Rate` bits (0..=2.0, min <= max).
    pub feed_min_bits: u32,
    pub feed_max_bits: u32,
    pub feed_air_bits: u32,
    pub strategy: ForceStrategy,
    /// Below the contact threshold this long = air; standstill at start while the chain tares.
    pub air_after_ms: u16,
    pub tare_ms: u16,
    /// Cutter flutes (1..=64) and spindle speeds (nominal, and the minimum below which the
    /// feed holds with `SpindleStopped`), milli-revolutions per second.
    pub flutes: u8,
    pub spindle_mrev_s: u32,
    pub min_spindle_mrev_s: u32,
    /// The feed axis (its position drives the feed-per-tooth measure and the sim plant) and its
    /// steps per second at override 1.0 (the job's planned feed).
    pub axis: u8,
    pub steps_per_s_at_one: u32,
    /// ADC sample rate (a whole divisor of the tick rate on a tick-sampled board; the control
    /// rate is a fifth of it, >= 1 kHz).
    pub sample_hz: u32,
    /// Force channels (2 or 3) and their calibration; the ADC's full scale (counts).
    pub channels: u8,
    pub cal: [ForceCal; 3],
    pub adc_max_counts: u16,
    /// Saturation: samples within `rail_margin_counts` of a rail, `saturated_samples` in a row;
    /// stuck: `stuck_samples` identical samples in a row while cutting.
    pub rail_margin_counts: u16,
    pub saturated_samples: u16,
    pub stuck_samples: u16,
    /// Tare time constant as a shift (1..=16).
    pub tare_shift: u8,
}

/// `Status::force_phase`: where the force job is (its controller's mode while it runs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum ForcePhase {
    /// No force job since boot (or since a job was dropped before starting).
    #[default]
    None = 0,
    /// Armed, waiting for `Start`.
    Armed = 1,
    /// Feed 0 while the chain learns the zero.
    Tare = 2,
    Air = 3,
    /// Algorithm A's slow feed, Algorithm B's stop and reduced gain.
    ContactSlow = 4,
    ContactStop = 5,
    Reduced = 6,
    Cutting = 7,
    /// A force fault latched the feed hold.
    Faulted = 8,
    /// The job ended (or was dropped after it started).
    Ended = 9,
}

impl ForcePhase {
    pub const ALL: [ForcePhase; 10] = [
        ForcePhase::None,
        ForcePhase::Armed,
        ForcePhase::Tare,
        ForcePhase::Air,
        ForcePhase::ContactSlow,
        ForcePhase::ContactStop,
        ForcePhase::Reduced,
        ForcePhase::Cutting,
        ForcePhase::Faulted,
        ForcePhase::Ended,
    ];

    /// The phase a `Status::force_phase` byte names (`None` for an unknown byte).
    pub fn from_u8(b: u8) -> ForcePhase {
        ForcePhase::ALL.get(b as usize).copied().unwrap_or(ForcePhase::None)
    }

    pub const fn name(self) -> &'static str {
        match self {
            ForcePhase::None => "none",
            ForcePhase::Armed => "armed",
            ForcePhase::Tare => "tare",
            ForcePhase::Air => "air",
            ForcePhase::ContactSlow => "contact_slow",
            ForcePhase::ContactStop => "contact_stop",
            ForcePhase::Reduced => "reduced",
            ForcePhase::Cutting => "cutting",
            ForcePhase::Faulted => "faulted",
            ForcePhase::Ended => "ended",
        }
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

/// How the machine homes: `order[..count]` are the axes homed in turn (0 = home where it
/// stands), each with its `axes[axis]` parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct HomingConfig {
    pub order: [u8; MAX_AXES],
    pub count: u8,
    pub axes: [HomeAxis; MAX_AXES],
}

impl HomingConfig {
    /// No switches: `Home` takes the current position as it is.
    pub const NONE: HomingConfig =
        HomingConfig { order: [0; MAX_AXES], count: 0, axes: [HomeAxis::UNUSED; MAX_AXES] };
}

impl RequestBody {
    /// Stable small number per variant (its postcard index).
    pub const fn kind(&self) -> u8 {
        match self {
            RequestBody::Hello { .. } => 0,
            RequestBody::GetConfig => 1,
            RequestBody::SetConfig(_) => 2,
            RequestBody::QueueSegments(_) => 3,
            RequestBody::Start => 4,
            RequestBody::Hold => 5,
            RequestBody::Resume => 6,
            RequestBody::Abort => 7,
            RequestBody::SetOverride { .. } => 8,
            RequestBody::GetStatus => 9,
            RequestBody::SetStatusPeriod { .. } => 10,
            RequestBody::ClearFault => 11,
            RequestBody::Home => 12,
            RequestBody::SetHoming(_) => 13,
            RequestBody::QueueEvents(_) => 14,
            RequestBody::StartPlayback { .. } => 15,
            RequestBody::JogOffLimit => 16,
            RequestBody::ArmWire(_) => 17,
            // -- Z-slide job --
            RequestBody::ZTableBegin(_) => 18,
            RequestBody::ZTableChunk { .. } => 19,
            RequestBody::ZTableEnd { .. } => 20,
            RequestBody::StartZ(_) => 21,
            // -- force job --
            RequestBody::ArmForce(_) => 22,
            // -- copy mode --
            RequestBody::StartCopy { .. } => 23,
            RequestBody::ReadTeach { .. } => 24,
            RequestBody::SetProgramOutputs(_) => 25,
            RequestBody::ArmProbe(_) => 26,
            #[cfg(feature = "sim-inputs")]
            RequestBody::Sim(_) => KIND_SIM,
        }
    }

    /// Event blocks this request queues if it succeeds (one event credit each).
    pub fn block_count(&self) -> u16 {
        match self {
            RequestBody::QueueEvents(_) => 1,
            _ => 0,
        }
    }

    /// Segments this request queues if it succeeds.
    pub fn segment_count(&self) -> u16 {
        match self {
            RequestBody::QueueSegments(b) => b.len() as u16,
            _ => 0,
        }
    }
}

/// Board -> host. Every request gets exactly one `Ack` or `Nak` carrying its seq; `Status` and
/// `Fault` frames are unsolicited.
///
/// `credits` = free slots in the board's segment queue right after it executed every request up
/// to a point `T`: for an `Ack`/`Nak` of a request, `T = seq` (a retransmitted request is answered
/// with the credits remembered from its execution); for a NAK with `NakDetail::Expected`,
/// `T = expected - 1`; for a `Status`, `T = next_seq - 1`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)]
pub enum Response {
    Ack { seq: u32, credits: u16, reply: Reply },
    Nak { seq: u32, credits: u16, code: ErrorCode, detail: NakDetail },
    Status(Status),
    Fault { code: FaultCode, tick: u64 },
}

/// Data returned with an `Ack`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)]
pub enum Reply {
    None,
    Hello(HelloInfo),
    Config(WireConfig),
    Status(Status),
    /// The answer to `QueueEvents`: free event-block slots right after it (`T = seq`).
    EventCredits(u16),
    // -- copy mode --
    /// The answer to `ReadTeach`.
    Teach(TeachChunk),
}

/// One `ReadTeach` answer. `bytes` empty and `ended` false: the block is not recorded yet (ask
/// again later); `ended`: the recording is over and nothing follows `bytes`. A recording with
/// `lost_events > 0` is incomplete (the host did not read fast enough).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TeachChunk {
    /// The block seq asked for.
    pub block: u16,
    /// The block, v1 stream format with its CRC (empty when there is none).
    pub bytes: BlockBytes,
    pub ended: bool,
    /// Events recorded and events lost (teach queue full) since `StartCopy`.
    pub taught_events: u32,
    pub lost_events: u32,
}

/// Counts of recovered trouble since boot. Each is modular (u32, wraps after 2^32): compare two
/// readings with `wrapping_sub`, as [`BoardCounters::since`] does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BoardCounters {
    /// Received bytes lost because the USART's data register was not read in time.
    pub usart_overruns: u32,
    /// Frames that failed COBS, length or CRC checks, or did not decode as a request.
    pub frames_bad: u32,
    /// Answers that did not fit the transmit queue whole and were dropped (the host resends).
    pub responses_dropped: u32,
    /// Ticks that started after their period had passed.
    pub tick_overruns: u32,
    /// Steps the DDA held back a tick (direction setup or a step pulse still high).
    pub steps_deferred: u32,
    /// Times a segment job held on the path because the host had not sent the next segment
    /// in time (it resumed when the segment came).
    pub starve_holds: u32,
}

impl BoardCounters {
    /// Counts from `earlier` to `self`, correct across one wrap of each counter.
    pub fn since(&self, earlier: &BoardCounters) -> BoardCounters {
        BoardCounters {
            usart_overruns: self.usart_overruns.wrapping_sub(earlier.usart_overruns),
            frames_bad: self.frames_bad.wrapping_sub(earlier.frames_bad),
            responses_dropped: self.responses_dropped.wrapping_sub(earlier.responses_dropped),
            tick_overruns: self.tick_overruns.wrapping_sub(earlier.tick_overruns),
            steps_deferred: self.steps_deferred.wrapping_sub(earlier.steps_deferred),
            starve_holds: self.starve_holds.wrapping_sub(earlier.starve_holds),
        }
    }
}

/// More about a NAK.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum NakDetail {
    None,
    /// Link-level NAK (Crc, Framing, Overflow, unreadable Malformed) or `Sequence`: no request
    /// was executed, and the board's next expected seq is `expected` (`seq` repeats it).
    Expected {
        expected: u32,
    },
    /// `InvalidSegment`: the `index`th segment of the batch failed `reason`.
    Segment {
        index: u8,
        reason: SegmentReason,
        axis: Option<u8>,
    },
    /// `InvalidConfig`: the offending field (names as in `ConfigError::field`).
    Config {
        field: FixedStr<FIELD_NAME_LEN>,
        axis: Option<u8>,
    },
    /// `OutOfState`: the machine state the board is in (see the command table in
    /// `src/machine/MACHINE.md`).
    State(MachineState),
    /// `InvalidSegment` for a `QueueEvents` block: `reason` = `polar::feed::BlockError::code`
    /// (1..=8 stream checks, 1 truncated ... 4 CRC ..., 9 trailing bytes, 10 sequence, 11 after
    /// the last block); `expected` = the block seq the board expects next (`None` after the
    /// last block).
    Block {
        reason: u8,
        expected: Option<u16>,
    },
    // -- Z-slide job --
    /// A refused Z request: `reason` = `ZTableError::code` for an upload step (1 header, 2 no
    /// upload, 3 sequence, 4 too long, 5 short, 6 CRC, 7 table), 0 for a start; `expected` =
    /// the chunk index the board wanted (sequence); `fault` = what the pre-start check found.
    ZSlide {
        reason: u8,
        expected: Option<u16>,
        fault: Option<FaultCode>,
    },
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct HelloInfo {
    pub version: u16,
    pub firmware: FixedStr<FIRMWARE_NAME_LEN>,
    /// `CAP_*` bits.
    pub capabilities: u32,
    /// Axes in the current config.
    pub axes: u8,
    /// Segment queue size (credits when empty).
    pub queue_capacity: u16,
    pub tick_hz: u32,
    /// Requests the board remembers for retransmission: the host's window must not exceed it.
    pub max_window: u16,
    pub max_segments_per_frame: u8,
    /// Where the firmware panicked before the last reset, if it did (also latched as the
    /// `Panicked` fault).
    pub last_panic: Option<PanicSite>,
}

/// A source location the firmware panicked at: the file's path (its last
/// [`PANIC_FILE_LEN`] bytes), line and column.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PanicSite {
    pub file: FixedStr<PANIC_FILE_LEN>,
    pub line: u32,
    pub column: u32,
}

/// Motion state on the wire.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WireState {
    #[default]
    Idle,
    Moving,
    /// Hold requested, decelerating.
    Stopping,
    Held,
    /// A fault is latched: motion stopped; `ClearFault` (or `Abort`) needed.
    Faulted,
}

impl From<MotionState> for WireState {
    fn from(s: MotionState) -> Self {
        match s {
            MotionState::Idle => WireState::Idle,
            MotionState::Moving => WireState::Moving,
            MotionState::Stopping => WireState::Stopping,
            MotionState::Held => WireState::Held,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// DDA tick count.
    pub tick: u64,
    /// Steps, per axis.
    pub positions: [i64; MAX_AXES],
    pub state: WireState,
    /// Feed override, `Rate` bits.
    pub override_bits: u32,
    /// Segments queued, not yet finished.
    pub queue_depth: u16,
    /// Free queue slots (filled in by `BoardLink`).
    pub credits: u16,
    pub segments_done: u32,
    pub last_done_id: Option<u32>,
    /// `segment::order_hash` over every completed segment id, in completion order.
    pub done_hash: u32,
    /// Latched faults: bit n set = `FaultCode` n.
    pub faults: u32,
    pub sensors: [i32; SENSOR_CHANNELS],
    /// Board's next expected seq (filled in by `BoardLink`); `credits` hold after `next_seq - 1`.
    pub next_seq: u32,
    /// The machine's state (`src/machine/MACHINE.md`): `state` says how the axes move, this
    /// says what the board accepts.
    pub machine: MachineState,
    /// Fault causes present now (`FaultCode` bits): `ClearFault` is refused while one is.
    pub causes: u32,
    /// The homing is trusted (positions are machine coordinates).
    pub homed: bool,
    /// Free event-block slots (`QueueEvents` credits, counted like `credits`).
    pub event_credits: u16,
    /// Events the current (or last) event job has fired.
    pub events_fired: u32,
    /// Event blocks queued and not yet decoded into the playback.
    pub event_blocks: u16,
    /// The current (or last) wire job: stalls detected, retrace and return segments run, the
    /// largest retraced distance of one stall (L1 steps), and the wire power output now.
    pub wire_stalls: u32,
    pub wire_retraces: u32,
    pub wire_returns: u32,
    pub wire_max_retrace_steps: u64,
    pub wire_power: bool,
    // -- Z-slide job --
    /// The current (or last) Z job: `ZJob::state_code` (`ZState`) (0 none, 1 idle/engaging,
    /// 2 running, 3 finished, 4 faulted), commanded X (inches Q24), Z command (inches Q32),
    /// the largest following error (nanoinches), Z steps emitted, the DAC code, and the spindle
    /// speed the board senses (thousandths of rpm).
    pub z_state: u8,
    pub z_x_in_q24: i32,
    pub z_cmd_in_q32: i32,
    pub z_max_following_nin: i64,
    pub z_steps: i64,
    pub z_dac_code: u16,
    pub z_spindle_rpm_milli: i64,
    // -- force job --
    /// The current (or last) force job: the chain's latest force (resultant) and its tooth
    /// peak, mN; the controller's override (`Rate` bits); its phase (`ForcePhase` as u8: 0 no
    /// job); control updates run.
    pub force_mn: u32,
    pub force_peak_mn: u32,
    pub force_override_bits: u32,
    pub force_phase: u8,
    pub force_updates: u32,
    // -- copy mode --
    /// A copy job runs (or holds).
    pub copy_running: bool,
    /// The copy encoders' counts now (arm, carriage), read every tick.
    pub encoder_counts: [i32; 2],
    /// The current (or last) copy job: events recorded and events lost (teach).
    pub taught_events: u32,
    pub lost_events: u32,
    /// What the board recovered from without a fault, counted since boot.
    pub counters: BoardCounters,
    /// The program outputs the board drives now (`SetProgramOutputs`), `OUT_*` bits: bit 0
    /// spindle on, bit 1 spindle counterclockwise (with bit 0), bit 2 mist, bit 3 flood.
    pub outputs: u8,
    /// The current (or last) probe move: `machine::ProbePhase` as u8 (0 none, 1 armed,
    /// 2 moving, 3 tripped, 4 missed, 5 refused, 6 dropped), the machine position of every axis
    /// latched at the trip (steps; meaningful when tripped), and the debounced probe input now.
    pub probe_phase: u8,
    pub probe_steps: [i64; MAX_AXES],
    pub probe_input: bool,
}

/// Per-axis scale and soft limits, alongside the step-space `MachineConfig`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct AxisScale {
    /// Steps per user unit (mm or degree) times 1000, e.g. 80 steps/mm = 80_000.
    pub steps_per_unit_milli: u32,
    /// Soft limits in steps (inclusive); `i64::MIN` / `i64::MAX` = none.
    pub soft_min: i64,
    pub soft_max: i64,
}

impl AxisScale {
    pub const UNUSED: AxisScale =
        AxisScale { steps_per_unit_milli: 0, soft_min: i64::MIN, soft_max: i64::MAX };
}

/// The configuration as set and read over the link.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WireConfig {
    pub machine: MachineConfig,
    pub scale: [AxisScale; MAX_AXES],
    /// How long a limit switch must hold a new level, and the e-stop stay released, before the
    /// machine believes it.
    pub inputs: InputFilterConfig,
}

impl WireConfig {
    /// A placeholder that fails validation (tick_hz 0): the board's state before any SetConfig.
    pub const UNSET: WireConfig = WireConfig {
        machine: MachineConfig {
            tick_hz: 0,
            timing: StepTiming { pulse_ns: 0, dir_setup_ns: 0, dir_hold_ns: 0 },
            axis_count: 0,
            axes: [AxisLimits::UNUSED; MAX_AXES],
        },
        scale: [AxisScale::UNUSED; MAX_AXES],
        inputs: InputFilterConfig::DEFAULT,
    };

    /// `MachineConfig::validate` plus the scale and input-filter checks; the same code runs on both ends, so the
    /// host can call it for the full reason behind an `InvalidConfig` NAK.
    pub fn validate(&self) -> Result<TickTiming, ConfigError> {
        let timing = self.machine.validate()?;
        let used = (self.machine.axis_count as usize).min(MAX_AXES);
        for (i, s) in self.scale.iter().enumerate().take(used) {
            let bad = |field, reason| Err(ConfigError { field, axis: Some(i as u8), reason });
            if s.steps_per_unit_milli == 0 {
                return bad("steps_per_unit_milli", "must be > 0");
            }
            if s.soft_min > s.soft_max {
                return bad("soft_min", "must be <= soft_max");
            }
        }
        self.inputs.validate()?;
        Ok(timing)
    }
}

/// A request that passed its CRC but did not decode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Malformed {
    /// The leading seq, if at least that could be read.
    pub seq: Option<u32>,
}

/// Decodes a request from verified frame bytes; trailing bytes are an error.
pub fn decode_request(msg: &[u8]) -> Result<Request, Malformed> {
    match postcard::take_from_bytes::<Request>(msg) {
        Ok((req, [])) => Ok(req),
        _ => Err(Malformed { seq: postcard::take_from_bytes::<u32>(msg).ok().map(|(s, _)| s) }),
    }
}

/// Decodes a response from verified frame bytes; trailing bytes are an error.
pub fn decode_response(msg: &[u8]) -> Option<Response> {
    match postcard::take_from_bytes::<Response>(msg) {
        Ok((resp, [])) => Some(resp),
        _ => None,
    }
}
