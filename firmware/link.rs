//! The host link's machine side (link firmware): the protocol state machine ([`BoardLink`]) over
//! [`Machine`], the one state machine and fault model of `motion::machine`.
//!
//! * [`Motion`] (shared by the tick, the USART task, the feeder and the status task; ceiling =
//!   the tick's priority): the DDA and the [`Machine`] wrapped around it. The tick calls
//!   [`Machine::tick`], never `Dda::tick` directly, so every e-stop, limit, sensor, link and
//!   overrun input reaches the fault latch the same tick.
//! * [`Link`] (USART task, feeder, status task): the protocol session, the segment queue between
//!   the host and the feeder, the preparer and the link watchdog.
//! * [`Target`] implements [`LinkTarget`] for one request: every machine command goes through
//!   [`Machine::command`], which consults the one command table; the link only adds its queue.
//! * [`HostPort`]: the serial driver and the transmit byte queue.
//!
//! Event jobs (recorded step events, `motion::polar`): `QueueEvents` blocks are verified by
//! `BoardLink` and wait whole in the link's [`EventFeed`]; `StartPlayback` makes a fresh
//! [`Playback`] (inside [`Motion`], so the tick owns it) pre-filled from the blocks, and starts
//! the job in the same critical section; the feeder decodes the rest a few events at a time
//! ([`Link::feed_events`]) and finishes the playback after the host's last block. The tick runs
//! it through [`Machine::tick_with`]: the same fault inputs, freeze, counters, soft limits and
//! job end as segments. Event credits are blocks.
//!
//! Job life cycle, as the machine's table has it: SetConfig (Idle), Home (-> Homing -> Ready),
//! QueueSegments (Ready/Running/Holding), Start (Ready -> Running); the job ends (Running ->
//! Ready) when every admitted segment has finished and the DDA is at rest. `Abort` stops at
//! once and drops the queue; a fault latches, reacts (kill/stop/hold) and waits for ClearFault.

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use heapless::Deque;
use motion::config::MAX_AXES;
use motion::dda::{Command, MotionState, Prepared, Preparer};
use motion::machine::{
    BoardConfig, BootConfig, Machine, MachineCommand, MachineState, Refusal, ResetCause,
    WatchdogGate,
};
use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};
use motion::polar::feed::{EventFeed, EVENT_QUEUE_BLOCKS};
use motion::polar::playback::{Playback, SizeScale, QUEUE_DEPTH};
use motion::polar::StepEvent;
use motion::protocol::CAP_ZSLIDE_JOB;
use motion::protocol::{
    encode_frame, BoardLink, ErrorCode, FaultCode, ForceJobParams, FrameError, HomingConfig,
    LinkTarget, Response, SimMillingParams, Status, TeachChunk, WireConfig, WireJobParams,
    WireState, CAP_COPY_JOB, CAP_DDA, CAP_EVENTS, CAP_FORCE_JOB, CAP_HOLD_RESUME, CAP_OVERRIDE,
    CAP_SIM_INPUTS, CAP_SOFT_LIMITS, CAP_STATUS_STREAM, CAP_WIRE_JOB, MAX_FRAME_WIRE,
    SENSOR_CHANNELS,
};
use motion::segment::{Rate, Segment, SegmentError};
use motion::wire::link_job::WireJob;
use motion::zslide::link_job::{ZJob, ZJobSpec, ZTableHeader};
use motion::zslide::link_requests::{ZNak, ZRequests};
use motion::Dda;
use rtic::Mutex;

use crate::board;

/// Copy-mode jobs (`StartCopy`, `ReadTeach`): kept apart from the rest of the link.
#[path = "link_copy.rs"]
pub mod link_copy;
/// Constant-force milling jobs (`ArmForce`, issue 4).
#[path = "link_force.rs"]
pub mod link_force;
/// Wire-manipulator jobs (`ArmWire`): kept apart from the rest of the link.
#[path = "link_wire.rs"]
pub mod link_wire;
/// Z-slide jobs (`ZTableBegin`..`StartZ`, `SimSpindle`): kept apart from the rest of the link.
#[path = "link_zslide.rs"]
pub mod link_zslide;

/// Segments the host may have queued beyond the DDA's own ready queue (`credits` when empty).
pub const SEGMENT_QUEUE: usize = 64;
/// Transmit queue; a response that does not fit whole is dropped (the host retransmits).
pub const TX_BUFFER: usize = 1024;
/// How often the status task runs, as a fraction of a second: 1 ms, so a status period of P ms
/// is met to the millisecond.
const POLLS_PER_SECOND: u32 = 1_000;
/// A job (Running or Holding) with no valid frame from the host for this long is a lost link:
/// the machine holds and latches `LinkLost`. motionctl sends at least every 100 ms during a job.
pub const LINK_TIMEOUT_MS: u64 = 1_000;
/// Watchdog timeout (nominal LSI) and how often the status task offers to feed it.
pub const WATCHDOG_TIMEOUT_MS: u32 = 100;
pub const WATCHDOG_POLL_MS: u64 = 10;

/// DDA ticks between two runs of the status task; the tick counts down from it (no division in
/// the tick). Rewritten when SetConfig changes the tick rate.
pub static WAKE_TICKS: AtomicU32 = AtomicU32::new(1);
/// The host link is alive, as the status task judged it; read by the tick.
pub static LINK_OK: AtomicBool = AtomicBool::new(true);
/// The e-stop interrupt saw the loop open: the tick latches EStop even if the level is gone.
pub static ESTOP_EDGE: AtomicBool = AtomicBool::new(false);
/// A config save is erasing flash: every fetch stalls, so the tick that follows finds its timer
/// update pending. That late tick is the save's, not an overrun.
pub static SAVING_CONFIG: AtomicBool = AtomicBool::new(false);
/// Fed only when the tick and the status task both ran since the last feed.
pub static WATCHDOG: WatchdogGate = WatchdogGate::new();
/// The event feed holds events not yet in the playback: the tick wakes the feeder when the
/// playback has room for [`EVENT_REFILL`] of them.
pub static EVENTS_WAITING: AtomicBool = AtomicBool::new(false);
/// The feeder refills the playback once this many slots are free: the other half of the
/// queue covers the feeder's latency (at least 32 ticks: at most 4 events fire per tick).
pub const EVENT_REFILL: usize = QUEUE_DEPTH / 2;
/// Events decoded per critical section: the decoding runs outside the `Motion` lock, the copy
/// into the playback inside it (a few hundred cycles, well inside a tick).
const EVENT_BATCH: usize = 16;

/// What the board announces in `HelloInfo::capabilities`.
pub const CAPABILITIES: u32 = CAP_DDA
    | CAP_STATUS_STREAM
    | CAP_OVERRIDE
    | CAP_HOLD_RESUME
    | CAP_SOFT_LIMITS
    | CAP_EVENTS
    | CAP_WIRE_JOB
    | CAP_ZSLIDE_JOB
    | if link_force::HAS_FORCE_SOURCE { CAP_FORCE_JOB } else { 0 }
    | if board::MachineIo::SIM_INPUTS { CAP_SIM_INPUTS } else { 0 }
    | if board::CopyEncoders::ROUTED { CAP_COPY_JOB } else { 0 };

/// The DDA, the event playback and the machine around them: one resource, so the tick takes
/// one lock.
pub struct Motion {
    pub dda: Dda,
    pub machine: Machine,
    /// The event job's playback (the last job's, for its counts, until the next start).
    pub playback: Playback,
    /// The wire job (the last one, for its counts, until the next `ArmWire`).
    pub wire: Option<WireJob>,
    /// The Z-slide job: the active table and the current (or last) run.
    pub z: ZJob,
    /// The copy job (the last one, for its counts, until the next `StartCopy`).
    pub copy: link_copy::CopyState,
    /// The force job and the simulated plant (issue 4).
    pub force: link_force::ForceSlot,
}

impl Motion {
    /// Boots the machine with `loaded` (the flash record; QEMU has none) after a reset of cause
    /// `reset`, and builds the DDA from the config it ends up with (safe defaults when missing
    /// or corrupt).
    pub fn boot(
        loaded: Result<BoardConfig, BootConfig>,
        reset: ResetCause,
    ) -> Option<(Self, Preparer)> {
        let mut machine = Machine::new();
        machine.boot_after_reset(loaded, reset);
        let cfg = machine.config().wire.machine;
        let dda = Dda::new(&cfg).ok()?;
        let preparer = Preparer::new(&cfg).ok()?;
        WAKE_TICKS.store(wake_ticks(cfg.tick_hz), Relaxed);
        Some((
            Motion {
                dda,
                machine,
                playback: Playback::new(SizeScale::ONE),
                wire: None,
                z: ZJob::new(),
                copy: link_copy::CopyState::new(),
                force: link_force::ForceSlot::default(),
            },
            preparer,
        ))
    }

    /// The state as the link reports it: started with segments still to feed counts as
    /// moving (the feeder is about to run).
    fn wire_state(&self) -> WireState {
        match (self.machine.state(), self.dda.state()) {
            (MachineState::Running, MotionState::Idle) => WireState::Moving,
            (MachineState::Holding, MotionState::Idle) if self.machine.event_job() => {
                WireState::Held
            }
            _ => self.machine.wire_state(&self.dda),
        }
    }
}

/// Ticks between status-task runs at `tick_hz` (>= MIN_TICK_HZ after validation, so >= 10).
fn wake_ticks(tick_hz: u32) -> u32 {
    (tick_hz / POLLS_PER_SECOND).max(1)
}

/// The protocol session and everything the link owns besides [`Motion`].
pub struct Link {
    pub board: BoardLink,
    feed: Feed,
    /// Status clock of the last valid frame from the host.
    last_frame_ms: u64,
    next_watchdog_ms: u64,
}

/// What a [`Target`] changes besides `Motion`: the segment queue and what rebuilding the DDA
/// needs.
struct Feed {
    queue: Deque<Segment, SEGMENT_QUEUE>,
    /// Verified event blocks waiting for the playback.
    events: EventFeed<EVENT_QUEUE_BLOCKS>,
    preparer: Preparer,
    tick_rate: board::TickRate,
    /// Milliseconds of DDA time before the current DDA was created (SetConfig restarts its
    /// clock), so the status clock never goes back.
    clock_base_ms: u64,
    /// Latched faults already announced with a `Fault` frame.
    announced: u32,
    /// A config accepted since the last save, to persist once the machine is at rest.
    save_pending: Option<BoardConfig>,
    /// The Z table upload's staging buffer.
    z: ZRequests,
    /// The copy job's teach recording, in blocks for `ReadTeach`.
    teach: TeachRecorder<TEACH_BLOCKS>,
}

impl Link {
    /// `firmware` is reported in `HelloInfo`.
    pub fn new(firmware: &str, preparer: Preparer, tick_rate: board::TickRate) -> Self {
        Link {
            board: BoardLink::new(firmware, CAPABILITIES),
            feed: Feed {
                queue: Deque::new(),
                events: EventFeed::new(),
                preparer,
                tick_rate,
                clock_base_ms: 0,
                announced: 0,
                save_pending: None,
                z: ZRequests::new(),
                teach: TeachRecorder::new(),
            },
            last_frame_ms: 0,
            next_watchdog_ms: 0,
        }
    }

    /// Handles one frame from the decoder; the response must be sent. The flag is true when the
    /// feeder has work (a Start, segments for a running job, or machine background work).
    pub fn on_frame(
        &mut self,
        frame: Result<&[u8], FrameError>,
        motion: &mut impl Mutex<T = Motion>,
    ) -> (Response, bool) {
        if frame.is_ok() {
            self.last_frame_ms = self.now_ms(motion);
        }
        let mut t = Target::new(&mut self.feed, motion);
        let resp = self.board.on_frame(frame, &mut t);
        (resp, t.wake_feeder)
    }

    /// The status task's periodic work: judge the link, announce a newly latched fault, send
    /// the periodic Status when one is due. Returns the frames to send (a `Fault` first) and
    /// whether the watchdog may be fed now.
    pub fn poll(&mut self, motion: &mut impl Mutex<T = Motion>) -> ([Option<Response>; 2], bool) {
        let now_ms = self.now_ms(motion);
        let (state, latched, first, tick) = motion.lock(|m| {
            let f = m.machine.faults();
            (m.machine.state(), f.mask(), f.first(), m.dda.now())
        });
        let job = matches!(state, MachineState::Running | MachineState::Holding);
        LINK_OK.store(!job || now_ms.saturating_sub(self.last_frame_ms) < LINK_TIMEOUT_MS, Relaxed);
        // Without a session nobody hears a Fault frame; the host reads the latch from its first
        // Status. Announcing it later would report a fault the host may since have cleared.
        if self.board.next_seq().is_none() {
            self.feed.announced = latched;
        }
        let fresh = latched & !self.feed.announced;
        self.feed.announced = latched;
        let fault = match first {
            Some(code) if fresh != 0 => {
                let code = if fresh & code.bit() != 0 { code } else { lowest(fresh) };
                Some(Response::Fault { code, tick })
            }
            _ => None,
        };
        let feed = now_ms >= self.next_watchdog_ms;
        if feed {
            self.next_watchdog_ms = now_ms + WATCHDOG_POLL_MS;
        }
        let t = Target::new(&mut self.feed, motion);
        let status = self.board.poll(now_ms, &t);
        ([fault, status], feed)
    }

    /// The feeder's work: the machine's background (abort after an immediate stop, homing
    /// moves), then the next segment for the DDA, prepared; `None` when there is nothing to feed.
    /// The divisions of preparing happen here, outside the `Motion` lock.
    pub fn next_prepared(
        &mut self,
        motion: &mut impl Mutex<T = Motion>,
    ) -> Option<Result<Prepared, (u32, SegmentError)>> {
        let prep = &mut self.feed.preparer;
        let may_feed = motion.lock(|m| {
            if m.machine.wants_background() {
                m.machine.background(&mut m.dda, prep);
            }
            m.machine.may_feed() && m.dda.ready_free() > 0
        });
        if !may_feed {
            return None;
        }
        let seg = self.feed.queue.pop_front()?;
        Some(self.feed.preparer.prepare(&seg).map_err(|e| (seg.id, e)))
    }

    /// The config to persist, once the machine is at rest (no job, no homing, DDA idle): a save
    /// stalls the flash, and with it the tick, for up to half a second.
    pub fn take_save(&mut self, motion: &mut impl Mutex<T = Motion>) -> Option<BoardConfig> {
        self.feed.save_pending?;
        let at_rest = motion.lock(|m| {
            matches!(
                m.machine.state(),
                MachineState::Idle | MachineState::Ready | MachineState::Fault
            ) && m.dda.is_idle()
                && !m.machine.is_jogging()
        });
        if at_rest {
            self.feed.save_pending.take()
        } else {
            None
        }
    }

    /// The feeder's event work: moves decoded events into the running event job's playback in
    /// small batches (decoded outside the `Motion` lock) until it is full or the blocks run out;
    /// finishes it after the last block. Clears [`EVENTS_WAITING`] once nothing is left to move.
    pub fn feed_events(&mut self, motion: &mut impl Mutex<T = Motion>) {
        let events = &mut self.feed.events;
        loop {
            let room = motion.lock(|m| {
                if m.machine.event_job() && !events.is_finished() {
                    m.playback.free()
                } else {
                    0
                }
            });
            if room == 0 {
                return;
            }
            let mut buf = [StepEvent::default(); EVENT_BATCH];
            let want = room.min(EVENT_BATCH);
            let (n, finished) = events.take(&mut buf[..want]);
            let (head, _) = buf.split_at(n);
            motion.lock(|m| {
                for &ev in head {
                    // Cannot fail: only this task pushes, and `room` slots were free.
                    let _ = m.playback.push(ev);
                }
                if finished {
                    m.playback.finish();
                }
            });
            if finished || n < want {
                // The stream ended, or every queued block went in: QueueEvents wakes us again.
                EVENTS_WAITING.store(false, Relaxed);
                return;
            }
        }
    }

    /// The feeder's wire-job work (segments into the DDA, stops, retrace and return moves),
    /// when the tick asked for it. Inside the `Motion` lock: the controller pushes straight
    /// into the DDA.
    pub fn feed_wire(&mut self, motion: &mut impl Mutex<T = Motion>) {
        motion.lock(|m| {
            if link_wire::wants_feed(m) {
                link_wire::feed(m);
            }
        });
    }

    /// The status task's teach work: taught events into stream blocks for `ReadTeach`.
    pub fn drain_teach(&mut self, motion: &mut impl Mutex<T = Motion>) {
        link_copy::drain_teach(&mut self.feed.teach, motion);
    }

    /// Milliseconds of DDA time since boot (division: never call from the tick).
    fn now_ms(&self, motion: &mut impl Mutex<T = Motion>) -> u64 {
        let (now, tick_hz) =
            motion.lock(|m| (m.dda.now(), m.machine.config().wire.machine.tick_hz));
        self.feed.clock_base_ms + now * 1_000 / tick_hz.max(1) as u64
    }
}

fn lowest(bits: u32) -> FaultCode {
    FaultCode::ALL.iter().copied().find(|f| bits & f.bit() != 0).unwrap_or(FaultCode::SensorFault)
}

/// [`LinkTarget`] for one request: the link plus the `Motion` resource. `LinkTarget` reads
/// through `&self`, and an RTIC lock needs `&mut`, hence the `RefCell` (never borrowed twice: no
/// method calls another while it holds the lock).
pub struct Target<'a, M: Mutex<T = Motion>> {
    link: &'a mut Feed,
    motion: RefCell<&'a mut M>,
    /// The feeder has work.
    pub wake_feeder: bool,
}

impl<'a, M: Mutex<T = Motion>> Target<'a, M> {
    fn new(link: &'a mut Feed, motion: &'a mut M) -> Self {
        Target { link, motion: RefCell::new(motion), wake_feeder: false }
    }

    fn with<R>(&self, f: impl FnOnce(&mut Motion) -> R) -> R {
        self.motion.borrow_mut().lock(f)
    }

    /// One machine command; a refusal changes nothing and becomes the NAK code.
    fn command(&mut self, cmd: MachineCommand<'_>) -> Result<MachineState, ErrorCode> {
        let r = self.motion.get_mut().lock(|m| m.machine.command(cmd, &mut m.dda));
        r.map_err(|e: Refusal| e.error_code())
    }

    /// After a command that stops and drops the job: the queue goes too, and the feeder runs the
    /// machine's background (the abort of the frozen DDA).
    fn drop_job(&mut self) {
        self.motion.get_mut().lock(|m| {
            link_wire::drop_job(m);
            link_copy::drop_job(m);
            link_force::drop_job(m);
            m.z.drop_run();
        });
        self.link.queue.clear();
        self.link.events.clear();
        EVENTS_WAITING.store(false, Relaxed);
        self.wake_feeder = true;
    }

    /// Installs `cfg` (a validated board config): the machine first (it refuses out of state),
    /// then a DDA and preparer for a changed machine config, retimed in one critical section.
    fn install(&mut self, cfg: &BoardConfig) -> Result<(), ErrorCode> {
        let preparer = Preparer::new(&cfg.wire.machine).map_err(|_| ErrorCode::InvalidConfig)?;
        let old = self.with(|m| m.machine.config().wire.machine);
        let tick_hz = cfg.wire.machine.tick_hz;
        let fresh = if cfg.wire.machine == old {
            None
        } else {
            if !self.link.tick_rate.supports(tick_hz) {
                return Err(ErrorCode::InvalidConfig);
            }
            Some(Dda::new(&cfg.wire.machine).map_err(|_| ErrorCode::InvalidConfig)?)
        };
        self.command(MachineCommand::SetConfig(cfg))?;
        self.drop_job();
        if board::ConfigStorage::PERSISTS {
            self.link.save_pending = Some(*cfg);
        }
        let Some(mut fresh) = fresh else { return Ok(()) };
        let tick_rate = &mut self.link.tick_rate;
        // The swap and the retiming in one critical section: no tick sees a half-done change.
        // The machine froze the DDA (SetConfig stops at once); the background aborts the new one.
        self.motion.get_mut().lock(|m| {
            core::mem::swap(&mut m.dda, &mut fresh);
            tick_rate.set(tick_hz)
        });
        // `fresh` now holds the old DDA.
        self.link.clock_base_ms += fresh.now() * 1_000 / old.tick_hz.max(1) as u64;
        self.link.preparer = preparer;
        WAKE_TICKS.store(wake_ticks(tick_hz), Relaxed);
        Ok(())
    }
}

impl<M: Mutex<T = Motion>> LinkTarget for Target<'_, M> {
    fn state(&self) -> WireState {
        self.with(|m| m.wire_state())
    }

    fn machine_state(&self) -> MachineState {
        self.with(|m| m.machine.state())
    }

    fn credits(&self) -> u16 {
        self.with(|m| link_wire::credits(m))
            .unwrap_or((SEGMENT_QUEUE - self.link.queue.len()) as u16)
    }

    fn queue_capacity(&self) -> u16 {
        SEGMENT_QUEUE as u16
    }

    fn config(&self) -> WireConfig {
        self.with(|m| m.machine.config().wire)
    }

    fn planned_position(&self) -> [i64; MAX_AXES] {
        self.with(|m| m.machine.planned_end())
    }

    fn status(&self) -> Status {
        // One lock: positions, tick, state and counters are one consistent snapshot.
        self.with(|m| {
            let (d, mc) = (&m.dda, &m.machine);
            let mut s = Status {
                tick: d.now(),
                positions: mc.positions(),
                state: m.wire_state(),
                override_bits: d.feed_override().to_bits(),
                queue_depth: mc.in_flight(d).min(u16::MAX as u32) as u16,
                segments_done: d.segments_done(),
                last_done_id: d.last_done_id(),
                done_hash: d.done_hash(),
                faults: mc.faults().mask(),
                sensors: [0; SENSOR_CHANNELS],
                machine: mc.state(),
                causes: mc.active_causes(),
                homed: mc.is_homed(),
                events_fired: m.playback.fired(),
                event_blocks: self.link.events.blocks() as u16,
                ..Status::default()
            };
            link_wire::status(m, &mut s);
            link_zslide::status(m, &mut s);
            link_copy::status(m, &self.link.teach, &mut s);
            link_force::status(m, &mut s);
            s
        })
    }

    fn set_config(&mut self, cfg: &WireConfig) -> Result<(), ErrorCode> {
        let homing = self.with(|m| m.machine.config().homing());
        self.install(&BoardConfig::with_homing(*cfg, &homing))
    }

    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode> {
        let wire = self.with(|m| m.machine.config().wire);
        self.install(&BoardConfig::with_homing(wire, homing))
    }

    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode> {
        if self.with(|m| link_wire::live(m)) {
            let state = self.motion.get_mut().lock(|m| link_wire::queue(m, seg))?;
            self.wake_feeder |= state != MachineState::Ready;
            return Ok(());
        }
        if self.link.queue.is_full() {
            return Err(ErrorCode::QueueFull);
        }
        let state = self.command(MachineCommand::Queue(seg))?;
        // Cannot fail: checked for room above.
        let _ = self.link.queue.push_back(*seg);
        self.wake_feeder |= state != MachineState::Ready;
        Ok(())
    }

    fn start(&mut self) -> Result<(), ErrorCode> {
        if self.with(|m| link_wire::live(m)) {
            self.motion.get_mut().lock(link_wire::start)?;
            self.wake_feeder = true;
            return Ok(());
        }
        if self.with(|m| link_force::armed(m)) {
            // The machine's start and the force loop's in one critical section.
            let r = self.motion.get_mut().lock(|m| {
                m.machine.command(MachineCommand::Start, &mut m.dda)?;
                link_force::start(m);
                Ok(())
            });
            r.map_err(|e: Refusal| e.error_code())?;
            self.wake_feeder = true;
            return Ok(());
        }
        self.command(MachineCommand::Start)?;
        self.wake_feeder = true;
        Ok(())
    }

    fn hold(&mut self) -> Result<(), ErrorCode> {
        // A hold must not outlive the job it was meant for: nothing moving and nothing to feed
        // means there is nothing to hold.
        let idle = self.with(|m| m.dda.is_idle() && !m.machine.event_job());
        if idle && self.link.queue.is_empty() {
            return Err(ErrorCode::OutOfState);
        }
        self.command(MachineCommand::Hold).map(|_| ())
    }

    fn resume(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::Resume)?;
        self.wake_feeder = true;
        Ok(())
    }

    fn abort(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::Abort)?;
        self.drop_job();
        Ok(())
    }

    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode> {
        self.with(|m| m.dda.apply(Command::SetOverride(rate)));
        Ok(())
    }

    fn clear_fault(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::ClearFault)?;
        self.link.announced = 0;
        self.drop_job();
        Ok(())
    }

    fn home(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::Home)?;
        self.drop_job();
        Ok(())
    }

    fn jog_off_limit(&mut self) -> Result<(), ErrorCode> {
        self.command(MachineCommand::JogOff)?;
        // The feeder plans the jog move (the machine's background).
        self.wake_feeder = true;
        Ok(())
    }

    fn event_credits(&self) -> u16 {
        if self.with(|m| m.machine.events_queued()) {
            self.link.events.credits()
        } else {
            // A new stream starts with an empty feed (see `queue_events`).
            self.link.events.capacity()
        }
    }

    fn next_event_block(&self) -> Option<u16> {
        if self.with(|m| m.machine.events_queued()) {
            self.link.events.expected()
        } else {
            Some(0)
        }
    }

    fn events_pending(&self) -> bool {
        // A wire job is a source job too, but its segments come through QueueSegments.
        self.with(|m| (m.machine.events_queued() || m.machine.event_job()) && !link_wire::live(m))
    }

    fn queue_events(&mut self, block: &[u8], last: bool) -> Result<(), ErrorCode> {
        if self.with(|m| link_wire::live(m) || link_copy::live(m)) {
            return Err(ErrorCode::OutOfState);
        }
        let fresh = !self.with(|m| m.machine.events_queued());
        let state = self.command(MachineCommand::QueueEvents)?;
        if fresh {
            // The machine had no events: whatever the feed holds is a finished job's.
            self.link.events.clear();
        }
        // Checked by BoardLink against `next_event_block` and `event_credits`: a refusal here
        // is a link bug. (The machine's flag stays set: the job has nothing new to play.)
        self.link.events.push(block, last).map_err(|_| ErrorCode::Internal)?;
        EVENTS_WAITING.store(true, Relaxed);
        self.wake_feeder |= state != MachineState::Ready;
        Ok(())
    }

    fn start_playback(&mut self, scale: SizeScale) -> Result<(), ErrorCode> {
        if self.with(|m| link_wire::live(m)) {
            return Err(ErrorCode::OutOfState);
        }
        // Decode the first events outside the lock, from a copy (a refused start changes
        // nothing), then start the job and fill its playback in one critical section: the
        // first tick of the job already has events.
        let mut feed = self.link.events.clone();
        let mut first = [StepEvent::default(); QUEUE_DEPTH];
        let (n, finished) = feed.take(&mut first);
        let (head, _) = first.split_at(n);
        let r = self.motion.get_mut().lock(|m| {
            m.machine.command(MachineCommand::StartEvents, &mut m.dda)?;
            m.playback = Playback::new(scale);
            for &ev in head {
                // Cannot fail: a fresh playback holds QUEUE_DEPTH events.
                let _ = m.playback.push(ev);
            }
            if finished {
                m.playback.finish();
            }
            Ok(())
        });
        r.map_err(|e: Refusal| e.error_code())?;
        self.link.events = feed;
        self.wake_feeder = true;
        Ok(())
    }

    fn arm_wire(&mut self, params: &WireJobParams) -> Result<(), ErrorCode> {
        let empty = self.link.queue.is_empty() && self.link.events.blocks() == 0;
        // An armed force job owns the next segment job (issue 4).
        let empty = empty && !self.with(|m| link_force::live(m));
        self.motion.get_mut().lock(|m| link_wire::arm(m, empty, params))
    }

    fn z_table_begin(&mut self, h: &ZTableHeader) -> Result<(), ZNak> {
        let active = self.with(|m| m.machine.z_job());
        self.link.z.begin(h, active)
    }

    fn z_table_chunk(&mut self, index: u16, bytes: &[u8]) -> Result<(), ZNak> {
        let active = self.with(|m| m.machine.z_job());
        self.link.z.chunk(index, bytes, active)
    }

    fn z_table_end(&mut self, crc: u32) -> Result<(), ZNak> {
        // Checked outside the lock; the install (a copy) inside it.
        let active = self.with(|m| m.machine.z_job());
        let table = self.link.z.end(crc, active)?;
        let copy = table.clone();
        self.motion.get_mut().lock(|m| link_zslide::install(m, table))?;
        self.link.z.installed(copy);
        Ok(())
    }

    fn start_z(&mut self, spec: &ZJobSpec) -> Result<(), ZNak> {
        let empty = self.link.queue.is_empty() && self.link.events.blocks() == 0;
        let (tick_hz, speed, active) = self.with(|m| {
            let tick_hz = m.machine.config().wire.machine.tick_hz;
            (tick_hz, m.z.sensed_speed_turn_q32_per_tick(), m.machine.z_job())
        });
        // The generator is built here, outside the lock (see link_zslide).
        let prepared = self.link.z.prepare(spec, tick_hz, speed, active)?;
        self.motion.get_mut().lock(|m| link_zslide::start(m, empty, prepared))
    }

    fn sim_spindle(&mut self, rpm_milli: u32, index: bool) -> Result<(), ErrorCode> {
        let tick_hz = self.with(|m| m.machine.config().wire.machine.tick_hz);
        link_zslide::sim_spindle(tick_hz, rpm_milli, index)
    }

    fn arm_force(&mut self, params: &ForceJobParams) -> Result<(), ErrorCode> {
        let empty = self.link.queue.is_empty() && self.link.events.blocks() == 0;
        self.motion.get_mut().lock(|m| {
            let wire_live = link_wire::live(m);
            link_force::arm(m, empty, wire_live, params)
        })
    }

    fn sim_milling(&mut self, params: &SimMillingParams) -> Result<(), ErrorCode> {
        self.motion.get_mut().lock(|m| link_force::set_sim(m, params))
    }

    fn sim_inject(&mut self, wire_stall: bool) -> Result<(), ErrorCode> {
        if board::MachineIo::inject_wire_stall(wire_stall) {
            Ok(())
        } else {
            Err(ErrorCode::Unsupported)
        }
    }

    fn start_copy(&mut self, scale: SizeScale, teach: bool) -> Result<(), ErrorCode> {
        if !board::CopyEncoders::ROUTED {
            return Err(ErrorCode::Unsupported);
        }
        if !self.link.queue.is_empty() || self.link.events.blocks() != 0 {
            return Err(ErrorCode::OutOfState);
        }
        self.motion.get_mut().lock(|m| link_copy::start(m, scale, teach))?;
        // A new recording (the last one's unread blocks go).
        self.link.teach.reset(teach);
        Ok(())
    }

    fn read_teach(&mut self, block: u16) -> Result<TeachChunk, ErrorCode> {
        let rec = &mut self.link.teach;
        Ok(self.motion.get_mut().lock(|m| link_copy::read(rec, m, block)))
    }

    fn teach_resend(&self) -> Option<TeachChunk> {
        Some(self.with(|m| link_copy::resend(&self.link.teach, m)))
    }

    fn sim_encoders(&mut self, counts: [i32; 2]) -> Result<(), ErrorCode> {
        if board::CopyEncoders::set_sim_target(counts) {
            Ok(())
        } else {
            Err(ErrorCode::Unsupported)
        }
    }
}

/// The serial port and its transmit queue.
pub struct HostPort {
    pub serial: board::HostSerial,
    tx: Deque<u8, TX_BUFFER>,
    /// Responses dropped because the queue could not hold them whole.
    pub dropped: u32,
}

impl HostPort {
    pub fn new(mut serial: board::HostSerial) -> Self {
        serial.listen_rx();
        HostPort { serial, tx: Deque::new(), dropped: 0 }
    }

    /// Encodes and queues one response; false if it was dropped.
    pub fn send(&mut self, resp: &Response) -> bool {
        let mut buf = [0u8; MAX_FRAME_WIRE];
        match encode_frame(resp, &mut buf) {
            Ok(frame) => self.queue_frame(frame),
            Err(_) => {
                self.dropped = self.dropped.wrapping_add(1);
                false
            }
        }
    }

    /// Queues one encoded frame whole, or drops it; starts the transmitter.
    pub fn queue_frame(&mut self, frame: &[u8]) -> bool {
        if TX_BUFFER - self.tx.len() < frame.len() {
            self.dropped = self.dropped.wrapping_add(1);
            return false;
        }
        for &b in frame {
            // Cannot fail: checked for room above.
            let _ = self.tx.push_back(b);
        }
        self.pump();
        true
    }

    /// Moves queued bytes into the USART while it takes them; the TXE interrupt is on exactly
    /// while bytes wait.
    pub fn pump(&mut self) {
        while let Some(&b) = self.tx.front() {
            if !self.serial.write_byte(b) {
                self.serial.listen_tx(true);
                return;
            }
            self.tx.pop_front();
        }
        self.serial.listen_tx(false);
    }
}

/// Encodes `resp` into `buf` for [`HostPort::queue_frame`]; outside any lock.
pub fn encode<'b>(resp: &Response, buf: &'b mut [u8; MAX_FRAME_WIRE]) -> Option<&'b [u8]> {
    encode_frame(resp, buf).ok()
}
