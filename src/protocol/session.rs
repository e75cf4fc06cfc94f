//! Board side of the link: a pure state machine from requests to responses.
//!
//! [`BoardLink`] never touches hardware; it acts through a [`LinkTarget`] (the firmware's DDA
//! feeder, or [`SimTarget`](super::SimTarget) in tests).
//!
//! # Sequence rules ("nothing lost, nothing repeated")
//!
//! A session starts with `Hello` at any seq `s0`; the board then expects `s0 + 1`.
//! For a request with seq `s`, the board's next expected seq being `n`:
//! * `s == n`: executed, answered (Ack or Nak), its outcome remembered; `n` becomes `n + 1`.
//!   A NAK here still consumes the seq: the request was processed and refused.
//! * `s < n`: a retransmission. Not executed again: the remembered outcome is sent again
//!   (queries such as GetStatus return fresh data). Outcomes are remembered for the last
//!   [`RESULT_MEMORY`] seqs; older ones get `Stale`.
//! * `s > n`: a gap (something was lost): `Nak Sequence` with `Expected { expected: n }`, not
//!   executed, nothing remembered.
//!
//! `Hello` with the current session's seq and nonce is a retransmission; any other valid
//! Hello starts a new session. Hello never touches the machine.
//!
//! # States in which each request is accepted
//!
//! One table decides: the machine's command table ([`crate::machine::state::TABLE`], rendered in
//! `src/machine/MACHINE.md`). A request whose command the table refuses in the target's
//! [`LinkTarget::machine_state`] gets `OutOfState` with `NakDetail::State` and changes nothing.
//! Requests that are not machine commands (Hello, GetConfig, GetStatus, SetStatusPeriod,
//! SetOverride) are accepted in every state. On top of the table the link asks:
//!
//! | Request | Also needs |
//! |---|---|
//! | SetConfig, SetHoming | an empty queue (else `OutOfState`), a valid config (`InvalidConfig` naming the field) |
//! | QueueSegments | credits for the whole batch, every segment valid and inside the soft limits |
//! | Hold | motion to hold (the target refuses an idle DDA with nothing to feed) |
//! | ClearFault | no fault cause still active (the target refuses with `OutOfState`) |
//! | JogOffLimit | a latched LimitSwitch with a switch still closed and nothing else present |
//! | QueueEvents (Queue column) | an event credit, a block that passes every stream check and is the next in sequence (`InvalidSegment` + `NakDetail::Block`), no segments queued (`OutOfState`) |
//! | StartPlayback (Start column) | m, k in 1..=4 (`OutOfRange`), queued events (`OutOfState`) |
//! | ZTableBegin/Chunk/End (Queue column) | no Z job running (`OutOfState`), chunks in order with the announced length and the CRC (`InvalidTable` + `NakDetail::ZSlide`) |
//! | StartZ (Start column) | a table (`OutOfState`), nothing queued, a spec in range and the pre-start check (`OutOfRange`) |
//! | StartCopy (Start column) | m, k in 1..=4 (`OutOfRange`), nothing queued and no job (`OutOfState`) |
//! | ReadTeach (not a command) | nothing |
//! | ArmForce (Start column) | `CAP_FORCE_JOB` (`Unsupported`), every parameter in range (`OutOfRange` + `NakDetail::Config` naming it), nothing queued or armed (`OutOfState`) |
//! | SetProgramOutputs (not a command) | no e-stop latched or pressed (`OutOfState`) |
//! | ArmProbe (Start column) | `CAP_PROBE` (`Unsupported`), nothing queued, no other job armed, motion at rest (`OutOfState`) |
//! | Sim (not a command; `sim-inputs` feature) | `CAP_SIM_INPUTS`, for `Milling` also `CAP_FORCE_JOB`, for `Probe` also `CAP_PROBE` (`Unsupported`); `Milling`'s parameters in range (`OutOfRange` naming the field) |
//!
//! A board built without the `sim-inputs` feature cannot decode `Sim`; it answers it
//! `Unsupported` (seq consumed) as a board with the feature but without `CAP_SIM_INPUTS` does.

use super::bounded::FixedStr;
use super::errors::{ErrorCode, SegmentReason};
use super::frame::FrameError;
use super::messages::*;
use super::program_outputs::ProgramOutputs;
use crate::config::{ConfigError, MAX_AXES};
use crate::machine::{cell, Cell, CommandKind, MachineState, ProbeKind};
use crate::polar::feed::check_block;
use crate::polar::playback::SizeScale;
use crate::segment::{Rate, Segment};
use crate::zslide::link_job::{ZJobSpec, ZTableHeader};
use crate::zslide::link_requests::ZNak;

#[cfg(feature = "sim-inputs")]
use super::sim::messages::SimRequest;

/// Outcomes remembered for retransmissions; the host's window must not exceed it.
pub const RESULT_MEMORY: usize = 32;

/// What the board's link drives. Every method that returns `Err` must have changed nothing.
pub trait LinkTarget {
    /// How the axes move.
    fn state(&self) -> WireState;
    /// Where the machine is in its life cycle: what the command table checks.
    fn machine_state(&self) -> MachineState;
    /// Free slots in the segment queue.
    fn credits(&self) -> u16;
    fn queue_capacity(&self) -> u16;
    fn config(&self) -> WireConfig;
    /// Position (steps) after every queued segment, for the soft-limit check.
    fn planned_position(&self) -> [i64; MAX_AXES];
    /// Current status; `BoardLink` fills in `credits` and `next_seq`.
    fn status(&self) -> Status;
    /// Called with a validated config, only while Idle with an empty queue.
    fn set_config(&mut self, cfg: &WireConfig) -> Result<(), ErrorCode>;
    /// Called with checked segments, never more than `credits()`.
    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode>;
    fn start(&mut self) -> Result<(), ErrorCode>;
    fn hold(&mut self) -> Result<(), ErrorCode>;
    fn resume(&mut self) -> Result<(), ErrorCode>;
    /// Stops at once and empties the queue (allowed in every state).
    fn abort(&mut self) -> Result<(), ErrorCode>;
    /// `rate` is within 0..=2.0.
    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode>;
    fn clear_fault(&mut self) -> Result<(), ErrorCode>;
    fn home(&mut self) -> Result<(), ErrorCode>;
    /// Called with homing parameters validated against the current config, only with an empty
    /// queue.
    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode>;
    /// Moves the axes off the limit switches they tripped (refused with `OutOfState` when there
    /// is nothing to jog off).
    fn jog_off_limit(&mut self) -> Result<(), ErrorCode>;
    /// Free event-block slots (event credits). Targets without event jobs have none.
    fn event_credits(&self) -> u16 {
        0
    }
    /// The stream block seq the target takes next (0 for a new job); `None` once the host
    /// marked a block as the last.
    fn next_event_block(&self) -> Option<u16> {
        None
    }
    /// Events are queued or an event job runs: segments are refused (`OutOfState`) until it
    /// ends or is aborted.
    fn events_pending(&self) -> bool {
        false
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
    /// Arms a wire job with checked parameters (`Ready`, empty queue, no events); refused
    /// with `OutOfState` otherwise. Targets without wire jobs: `Unsupported`.
    fn arm_wire(&mut self, _params: &WireJobParams) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    // -- Z-slide job --
    /// `ZTableBegin` (see `motion::zslide::link_requests::ZRequests`). A refusal changes
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
    // -- copy mode --
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
    // -- force job --
    /// Arms a force job with checked parameters (`Ready`, empty queue, no events, no other job
    /// armed; else `OutOfState`). `OutOfRange` from the target means the sample rate does not
    /// fit the board (the NAK names `sample_hz`). Targets without force jobs: `Unsupported`.
    fn arm_force(&mut self, _params: &ForceJobParams) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
    /// A simulator board's test hook, only called when the board announces `CAP_SIM_INPUTS`
    /// (and `CAP_FORCE_JOB` for `Milling`, whose parameters are checked). Only with the
    /// `sim-inputs` feature: production targets have no hooks to implement.
    #[cfg(feature = "sim-inputs")]
    fn sim(&mut self, _req: &SimRequest) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }

    /// Switches the spindle and coolant (`SetProgramOutputs`), keeping the other outputs;
    /// `OutOfState` while an e-stop is latched or pressed. Targets without these outputs:
    /// `Unsupported`.
    fn set_program_outputs(&mut self, _o: ProgramOutputs) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }

    /// Marks the next `Start` as a probe move of `kind` (`ArmProbe`); `OutOfState` with
    /// something queued or another job armed. Targets without a probe input: `Unsupported`.
    fn arm_probe(&mut self, _kind: ProbeKind) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
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

type Outcome = Result<(), (ErrorCode, NakDetail)>;

/// The message is a `RequestBody::Sim` (its body's variant index, a one-byte varint, follows
/// the seq).
#[cfg(not(feature = "sim-inputs"))]
fn is_sim_request(msg: &[u8]) -> bool {
    match postcard::take_from_bytes::<u32>(msg) {
        Ok((_, rest)) => rest.first() == Some(&KIND_SIM),
        Err(_) => false,
    }
}

/// `kind` recorded for a request that passed its CRC but did not decode.
const MALFORMED_KIND: u8 = 0xFF;
const KIND_HELLO: u8 = RequestBody::Hello { version: 0, nonce: 0 }.kind();
const KIND_GET_CONFIG: u8 = RequestBody::GetConfig.kind();
const KIND_GET_STATUS: u8 = RequestBody::GetStatus.kind();
pub(crate) const KIND_QUEUE_EVENTS: u8 = 14;
const KIND_READ_TEACH: u8 = RequestBody::ReadTeach { block: 0 }.kind();

#[derive(Clone, Debug)]
struct Memo {
    seq: u32,
    kind: u8,
    credits: u16,
    /// Event credits right after the request (replayed in a `QueueEvents` Ack).
    event_credits: u16,
    outcome: Outcome,
}

#[derive(Clone, Copy, Debug)]
struct Session {
    next_seq: u32,
    hello_seq: u32,
    nonce: u32,
}

/// The board's end of the link.
#[derive(Clone, Debug)]
pub struct BoardLink {
    firmware: FixedStr<FIRMWARE_NAME_LEN>,
    capabilities: u32,
    last_panic: Option<PanicSite>,
    /// Frames that failed their checks or did not decode (`BoardCounters::frames_bad`).
    frames_bad: u32,
    /// The serial port's counts, noted by the firmware ([`BoardLink::note_port`]).
    port: (u32, u32),
    session: Option<Session>,
    memo: [Option<Memo>; RESULT_MEMORY],
    status_period_ms: u16,
    status_due_ms: Option<u64>,
}

fn is_before(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) < 0
}

impl BoardLink {
    /// `firmware` (cut to 24 bytes) and `capabilities` (`CAP_*`) are reported in `HelloInfo`.
    pub fn new(firmware: &str, capabilities: u32) -> Self {
        BoardLink {
            firmware: FixedStr::truncated(firmware),
            capabilities,
            last_panic: None,
            frames_bad: 0,
            port: (0, 0),
            session: None,
            memo: [const { None }; RESULT_MEMORY],
            status_period_ms: 0,
            status_due_ms: None,
        }
    }

    /// The serial port's receive overruns and dropped answers so far, for `Status::counters`.
    pub fn note_port(&mut self, usart_overruns: u32, responses_dropped: u32) {
        self.port = (usart_overruns, responses_dropped);
    }

    /// The panic the board found recorded at boot, reported in every `HelloInfo`.
    pub fn set_last_panic(&mut self, site: PanicSite) {
        self.last_panic = Some(site);
    }

    /// The next seq the board will execute, if a session is open.
    pub fn next_seq(&self) -> Option<u32> {
        self.session.map(|s| s.next_seq)
    }

    /// Handles one frame from [`FrameDecoder::push`](super::FrameDecoder::push); always answers.
    pub fn on_frame(
        &mut self,
        frame: Result<&[u8], FrameError>,
        t: &mut impl LinkTarget,
    ) -> Response {
        match frame {
            Ok(msg) => self.handle_message(msg, t),
            Err(e) => {
                self.frames_bad = self.frames_bad.wrapping_add(1);
                self.link_nak(e.error_code(), t)
            }
        }
    }

    /// Handles CRC-checked message bytes.
    pub fn handle_message(&mut self, msg: &[u8], t: &mut impl LinkTarget) -> Response {
        let malformed = match decode_request(msg) {
            Ok(req) => return self.handle(&req, t),
            Err(m) => m,
        };
        #[cfg(not(feature = "sim-inputs"))]
        if let Some(seq) = malformed.seq.filter(|_| is_sim_request(msg)) {
            // A test hook this build has no code for: refused as a board without the
            // simulator capability refuses it, not counted as a bad frame.
            return self.sequenced(seq, KIND_SIM, t, |_, _| {
                Err((ErrorCode::Unsupported, NakDetail::None))
            });
        }
        self.frames_bad = self.frames_bad.wrapping_add(1);
        match malformed {
            Malformed { seq: None } => self.link_nak(ErrorCode::Malformed, t),
            Malformed { seq: Some(seq) } => self.sequenced(seq, MALFORMED_KIND, t, |_, _| {
                Err((ErrorCode::Malformed, NakDetail::None))
            }),
        }
    }

    /// Handles a decoded request.
    pub fn handle(&mut self, req: &Request, t: &mut impl LinkTarget) -> Response {
        if let RequestBody::Hello { version, nonce } = req.body {
            return self.hello(req, version, nonce, t);
        }
        let kind = req.body.kind();
        self.sequenced(req.seq, kind, t, |link, t| link.execute(req, t))
    }

    /// NAK for a frame that carried no readable request.
    pub fn link_nak(&self, code: ErrorCode, t: &impl LinkTarget) -> Response {
        let (seq, detail) = match self.session {
            Some(s) => (s.next_seq, NakDetail::Expected { expected: s.next_seq }),
            None => (0, NakDetail::None),
        };
        Response::Nak { seq, credits: t.credits(), code, detail }
    }

    /// A periodic `Status` when one is due (after `SetStatusPeriod`); call often.
    pub fn poll(&mut self, now_ms: u64, t: &impl LinkTarget) -> Option<Response> {
        if self.status_period_ms == 0 || self.session.is_none() {
            return None;
        }
        let due = *self.status_due_ms.get_or_insert(now_ms);
        if now_ms < due {
            return None;
        }
        self.status_due_ms = Some(now_ms.saturating_add(self.status_period_ms as u64));
        Some(Response::Status(self.status(t)))
    }

    /// The target's status with the link fields filled in.
    pub fn status(&self, t: &impl LinkTarget) -> Status {
        let mut s = t.status();
        s.credits = t.credits();
        s.event_credits = t.event_credits();
        s.next_seq = self.next_seq().unwrap_or(0);
        s.counters.frames_bad = self.frames_bad;
        (s.counters.usart_overruns, s.counters.responses_dropped) = self.port;
        s
    }

    /// `HelloInfo` for the current target.
    pub fn hello_info(&self, t: &impl LinkTarget) -> HelloInfo {
        let cfg = t.config();
        HelloInfo {
            version: PROTOCOL_VERSION,
            firmware: self.firmware.clone(),
            capabilities: self.capabilities,
            axes: cfg.machine.axis_count,
            queue_capacity: t.queue_capacity(),
            tick_hz: cfg.machine.tick_hz,
            max_window: RESULT_MEMORY as u16,
            max_segments_per_frame: super::MAX_SEGMENTS_PER_FRAME as u8,
            last_panic: self.last_panic.clone(),
        }
    }

    fn hello(
        &mut self,
        req: &Request,
        version: u16,
        nonce: u32,
        t: &mut impl LinkTarget,
    ) -> Response {
        if version != PROTOCOL_VERSION {
            return Response::Nak {
                seq: req.seq,
                credits: t.credits(),
                code: ErrorCode::Version,
                detail: NakDetail::None,
            };
        }
        if let Some(s) = self.session {
            if s.hello_seq == req.seq && s.nonce == nonce && is_before(req.seq, s.next_seq) {
                return self.replay(req.seq, req.body.kind(), t);
            }
        }
        self.session =
            Some(Session { next_seq: req.seq.wrapping_add(1), hello_seq: req.seq, nonce });
        self.memo = [const { None }; RESULT_MEMORY];
        self.status_period_ms = 0;
        self.status_due_ms = None;
        let credits = t.credits();
        self.remember(req.seq, req.body.kind(), (credits, t.event_credits()), Ok(()));
        Response::Ack { seq: req.seq, credits, reply: Reply::Hello(self.hello_info(t)) }
    }

    fn sequenced<T: LinkTarget>(
        &mut self,
        seq: u32,
        kind: u8,
        t: &mut T,
        exec: impl FnOnce(&mut Self, &mut T) -> Result<Reply, (ErrorCode, NakDetail)>,
    ) -> Response {
        let Some(s) = self.session else {
            return Response::Nak {
                seq,
                credits: t.credits(),
                code: ErrorCode::NoSession,
                detail: NakDetail::None,
            };
        };
        if seq != s.next_seq {
            if is_before(seq, s.next_seq) {
                return self.replay(seq, kind, t);
            }
            let expected = s.next_seq;
            return Response::Nak {
                seq,
                credits: t.credits(),
                code: ErrorCode::Sequence,
                detail: NakDetail::Expected { expected },
            };
        }
        let result = exec(self, t);
        let credits = (t.credits(), t.event_credits());
        if let Some(s) = self.session.as_mut() {
            s.next_seq = seq.wrapping_add(1);
        }
        match result {
            Ok(reply) => {
                self.remember(seq, kind, credits, Ok(()));
                let reply = match kind {
                    KIND_QUEUE_EVENTS => Reply::EventCredits(credits.1),
                    _ => reply,
                };
                Response::Ack { seq, credits: credits.0, reply }
            }
            Err((code, detail)) => {
                self.remember(seq, kind, credits, Err((code, detail.clone())));
                Response::Nak { seq, credits: credits.0, code, detail }
            }
        }
    }

    fn remember(&mut self, seq: u32, kind: u8, credits: (u16, u16), outcome: Outcome) {
        let (credits, event_credits) = credits;
        self.memo[seq as usize % RESULT_MEMORY] =
            Some(Memo { seq, kind, credits, event_credits, outcome });
    }

    /// Answers a retransmission from memory, executing nothing.
    fn replay(&self, seq: u32, kind: u8, t: &impl LinkTarget) -> Response {
        match &self.memo[seq as usize % RESULT_MEMORY] {
            Some(m) if m.seq == seq && m.kind == kind => match &m.outcome {
                Ok(()) => {
                    // Queries answer with fresh data; nothing is executed again.
                    let reply = match kind {
                        KIND_HELLO => Reply::Hello(self.hello_info(t)),
                        KIND_GET_CONFIG => Reply::Config(t.config()),
                        KIND_GET_STATUS => Reply::Status(self.status(t)),
                        KIND_QUEUE_EVENTS => Reply::EventCredits(m.event_credits),
                        KIND_READ_TEACH => t.teach_resend().map_or(Reply::None, Reply::Teach),
                        _ => Reply::None,
                    };
                    Response::Ack { seq, credits: m.credits, reply }
                }
                Err((code, detail)) => {
                    Response::Nak { seq, credits: m.credits, code: *code, detail: detail.clone() }
                }
            },
            _ => Response::Nak {
                seq,
                credits: t.credits(),
                code: ErrorCode::Stale,
                detail: NakDetail::None,
            },
        }
    }

    fn execute(
        &mut self,
        req: &Request,
        t: &mut impl LinkTarget,
    ) -> Result<Reply, (ErrorCode, NakDetail)> {
        let machine = t.machine_state();
        let out_of_state = Err((ErrorCode::OutOfState, NakDetail::State(machine)));
        if let Some(kind) = command_kind(&req.body) {
            if cell(machine, kind) == Cell::Refused {
                return out_of_state;
            }
        }
        let plain = |code: ErrorCode| (code, NakDetail::None);
        let queue_empty = t.credits() == t.queue_capacity();
        match &req.body {
            // Handled before sequencing; never reaches here.
            RequestBody::Hello { .. } => Err(plain(ErrorCode::Internal)),
            RequestBody::GetConfig => Ok(Reply::Config(t.config())),
            RequestBody::GetStatus => Ok(Reply::Status(self.status(t))),
            RequestBody::SetConfig(cfg) => {
                if !queue_empty {
                    return out_of_state;
                }
                cfg.validate().map_err(config_nak)?;
                t.set_config(cfg).map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::SetHoming(h) => {
                if !queue_empty {
                    return out_of_state;
                }
                crate::machine::BoardConfig::with_homing(t.config(), h)
                    .validate()
                    .map_err(config_nak)?;
                t.set_homing(h).map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::QueueSegments(batch) => {
                if t.events_pending() {
                    return out_of_state;
                }
                if batch.len() > t.credits() as usize {
                    return Err(plain(ErrorCode::QueueFull));
                }
                let cfg = t.config();
                cfg.validate().map_err(config_nak)?;
                let mut pos = t.planned_position();
                for (index, seg) in batch.iter().enumerate() {
                    let index = index as u8;
                    let seg_nak = |(reason, axis)| {
                        (ErrorCode::InvalidSegment, NakDetail::Segment { index, reason, axis })
                    };
                    seg.check(&cfg.machine).map_err(|e| seg_nak(SegmentReason::from_error(e)))?;
                    for (axis, p) in pos.iter_mut().enumerate() {
                        let s = &cfg.scale[axis];
                        if seg.steps[axis] == 0 {
                            continue;
                        }
                        match p.checked_add(seg.steps[axis] as i64) {
                            Some(np) if np >= s.soft_min && np <= s.soft_max => *p = np,
                            _ => return Err(seg_nak((SegmentReason::SoftLimit, Some(axis as u8)))),
                        }
                    }
                }
                for seg in batch.iter() {
                    // Checked above; a failure here is a target bug, reported as Internal.
                    t.queue_segment(seg).map_err(|_| plain(ErrorCode::Internal))?;
                }
                Ok(Reply::None)
            }
            RequestBody::Start => {
                t.config().validate().map_err(config_nak)?;
                t.start().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::QueueEvents(block) => {
                if t.event_credits() == 0 {
                    return Err(plain(ErrorCode::QueueFull));
                }
                let expected = t.next_event_block();
                check_block(&block.bytes, expected).map_err(|e| {
                    (ErrorCode::InvalidSegment, NakDetail::Block { reason: e.code(), expected })
                })?;
                t.queue_events(&block.bytes, block.last).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::StartPlayback { m, k } => {
                let scale = SizeScale::new(*m, *k).ok_or(plain(ErrorCode::OutOfRange))?;
                t.config().validate().map_err(config_nak)?;
                t.start_playback(scale).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::Hold => {
                t.hold().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::Resume => {
                t.resume().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::Abort => {
                t.abort().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::Home => {
                t.home().map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::JogOffLimit => {
                t.jog_off_limit().map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::SetOverride { rate_bits } => {
                if *rate_bits > MAX_OVERRIDE_BITS {
                    return Err(plain(ErrorCode::OutOfRange));
                }
                t.set_override(Rate::from_bits(*rate_bits)).map_err(plain)?;
                Ok(Reply::None)
            }
            RequestBody::SetStatusPeriod { ms } => {
                if *ms != 0 && *ms < MIN_STATUS_PERIOD_MS {
                    return Err(plain(ErrorCode::OutOfRange));
                }
                self.status_period_ms = *ms;
                self.status_due_ms = None;
                Ok(Reply::None)
            }
            RequestBody::ArmWire(p) => {
                if !wire_params_ok(p) {
                    return Err(plain(ErrorCode::OutOfRange));
                }
                t.config().validate().map_err(config_nak)?;
                t.arm_wire(p).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            // -- Z-slide job --
            RequestBody::ZTableBegin(h) => {
                t.z_table_begin(h).map_err(|e| state_detail(e, machine))?;
                Ok(Reply::None)
            }
            RequestBody::ZTableChunk { index, bytes } => {
                if bytes.len() > MAX_Z_CHUNK {
                    return Err(plain(ErrorCode::OutOfRange));
                }
                t.z_table_chunk(*index, bytes).map_err(|e| state_detail(e, machine))?;
                Ok(Reply::None)
            }
            RequestBody::ZTableEnd { crc } => {
                t.z_table_end(*crc).map_err(|e| state_detail(e, machine))?;
                Ok(Reply::None)
            }
            RequestBody::StartZ(spec) => {
                t.config().validate().map_err(config_nak)?;
                t.start_z(spec).map_err(|e| state_detail(e, machine))?;
                Ok(Reply::None)
            }
            // -- copy mode --
            RequestBody::StartCopy { m, k, teach } => {
                let scale = SizeScale::new(*m, *k).ok_or(plain(ErrorCode::OutOfRange))?;
                t.config().validate().map_err(config_nak)?;
                t.start_copy(scale, *teach).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            // -- force job --
            RequestBody::ArmForce(p) => {
                if self.capabilities & CAP_FORCE_JOB == 0 {
                    return Err(plain(ErrorCode::Unsupported));
                }
                crate::force::link_job::check_job(p).map_err(range_nak)?;
                t.config().validate().map_err(config_nak)?;
                t.arm_force(p).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    ErrorCode::OutOfRange => range_nak("sample_hz"),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::ReadTeach { block } => {
                Ok(Reply::Teach(t.read_teach(*block).map_err(plain)?))
            }
            #[cfg(feature = "sim-inputs")]
            RequestBody::Sim(s) => {
                sim(self.capabilities, s, t)?;
                Ok(Reply::None)
            }
            RequestBody::ArmProbe(kind) => {
                if self.capabilities & CAP_PROBE == 0 {
                    return Err(plain(ErrorCode::Unsupported));
                }
                t.arm_probe(*kind).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::SetProgramOutputs(o) => {
                t.set_program_outputs(*o).map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
            RequestBody::ClearFault => {
                t.clear_fault().map_err(|code| match code {
                    ErrorCode::OutOfState => (code, NakDetail::State(machine)),
                    _ => plain(code),
                })?;
                Ok(Reply::None)
            }
        }
    }
}

/// A test hook on a board announcing `capabilities`: without the hooks' capabilities
/// `Unsupported`, changing nothing; a milling plant out of range `OutOfRange` naming the field.
#[cfg(feature = "sim-inputs")]
fn sim(
    capabilities: u32,
    req: &SimRequest,
    t: &mut impl LinkTarget,
) -> Result<(), (ErrorCode, NakDetail)> {
    let needs = match req {
        SimRequest::Milling(_) => CAP_SIM_INPUTS | CAP_FORCE_JOB,
        SimRequest::Probe { .. } => CAP_SIM_INPUTS | CAP_PROBE,
        _ => CAP_SIM_INPUTS,
    };
    if capabilities & needs != needs {
        return Err((ErrorCode::Unsupported, NakDetail::None));
    }
    if let SimRequest::Milling(p) = req {
        crate::force::link_job::check_sim(p).map_err(range_nak)?;
    }
    t.sim(req).map_err(|code| (code, NakDetail::None))
}

/// A target's refusal with the machine state filled into a bare `OutOfState`.
fn state_detail(e: ZNak, machine: MachineState) -> (ErrorCode, NakDetail) {
    match e {
        (ErrorCode::OutOfState, NakDetail::None) => {
            (ErrorCode::OutOfState, NakDetail::State(machine))
        }
        other => other,
    }
}

/// `OutOfRange` naming the parameter (a force job's field).
fn range_nak(field: &'static str) -> (ErrorCode, NakDetail) {
    (ErrorCode::OutOfRange, NakDetail::Config { field: FixedStr::truncated(field), axis: None })
}

fn config_nak(e: ConfigError) -> (ErrorCode, NakDetail) {
    (
        ErrorCode::InvalidConfig,
        NakDetail::Config { field: FixedStr::truncated(e.field), axis: e.axis },
    )
}
