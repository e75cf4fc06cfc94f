//! The host link (feature `link`): the machine side of [`BoardLink`] on top of the RTIC
//! resources, and the USART1 transmit queue.
//!
//! * [`Link`] (shared by the USART1 task, the feeder and the status task, ceiling priority 2):
//!   the protocol state machine plus [`Machine`], the segment queue between the host and the
//!   feeder, the preparer, the configuration and the fault latch.
//! * [`Target`] implements [`LinkTarget`] for one request over a `&mut Machine` and the DDA
//!   resource (locked per access, so the tick is only ever held off for a few loads or one
//!   command).
//! * [`HostPort`] (shared by the USART1 task and the status task): the serial driver and the
//!   transmit byte queue.
//!
//! Job life cycle: segments queued while Idle wait in the queue (state Idle, `queue_depth` > 0)
//! until `Start`; then the feeder moves them into the DDA as it has room, and segments queued
//! while the job runs follow without another Start. Once every segment fed since the Start has
//! finished and the queue is empty, the job is over: the state is Idle again and the next
//! segments wait for the next Start. `Abort` stops at once, drops the queue and ends the job.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering::Relaxed};

use heapless::Deque;
use motion::config::MAX_AXES;
use motion::dda::{Command, MotionState, Prepared, Preparer};
use motion::protocol::{
    encode_frame, AxisScale, BoardLink, ErrorCode, FaultCode, FrameError, LinkTarget, Response,
    Status, WireConfig, WireState, CAP_DDA, CAP_HOLD_RESUME, CAP_OVERRIDE, CAP_SOFT_LIMITS,
    CAP_STATUS_STREAM, MAX_FRAME_WIRE, SENSOR_CHANNELS,
};
use motion::segment::{Rate, Segment, SegmentError};
use motion::{demo_job, Dda};
use rtic::Mutex;

use crate::board;

/// Segments the host may have queued beyond the DDA's own ready queue (`credits` when empty).
pub const SEGMENT_QUEUE: usize = 64;
/// Transmit queue; a response that does not fit whole is dropped (the host retransmits).
pub const TX_BUFFER: usize = 1024;
/// How often the status task runs, as a fraction of a second: 1 ms, so a status period of P ms
/// is met to the millisecond.
const POLLS_PER_SECOND: u32 = 1_000;

/// DDA ticks between two runs of the status task; the tick counts down from it (no division in
/// the tick). Rewritten when SetConfig changes the tick rate.
pub static WAKE_TICKS: AtomicU32 = AtomicU32::new(demo_job::TICK_HZ / POLLS_PER_SECOND);

/// What the board announces in `HelloInfo::capabilities`.
pub const CAPABILITIES: u32 =
    CAP_DDA | CAP_STATUS_STREAM | CAP_OVERRIDE | CAP_HOLD_RESUME | CAP_SOFT_LIMITS;

/// The configuration before any SetConfig: the demo machine, 1 step per user unit, no soft limits.
pub fn initial_config() -> WireConfig {
    let scale = AxisScale { steps_per_unit_milli: 1_000, soft_min: i64::MIN, soft_max: i64::MAX };
    WireConfig { machine: demo_job::config(), scale: [scale; MAX_AXES] }
}

/// The protocol state machine and the machine it drives.
pub struct Link {
    pub board: BoardLink,
    pub machine: Machine,
}

/// Everything the link owns besides the DDA.
pub struct Machine {
    queue: Deque<Segment, SEGMENT_QUEUE>,
    preparer: Preparer,
    config: WireConfig,
    tick_rate: board::TickRate,
    /// Position after every accepted segment: DDA position at the last abort (or zero with a
    /// new DDA) plus the steps of every segment queued since.
    planned: [i64; MAX_AXES],
    /// Start was given and the job has not ended (see the module docs).
    started: bool,
    /// The feeder took a segment since the last Start.
    fed: bool,
    /// Segments queued since the DDA was created, less those dropped by an abort: with the
    /// DDA's `segments_done`, the segments queued and not yet finished.
    accepted: u32,
    /// Latched faults, bit n = `FaultCode` n. The only source so far: a DDA queue underrun.
    faults: u32,
    underruns_seen: u32,
    /// Milliseconds of DDA time before the current DDA was created (SetConfig restarts its
    /// clock), so the status clock never goes back.
    clock_base_ms: u64,
}

impl Link {
    /// `firmware` is reported in `HelloInfo`; `cfg` must be valid.
    pub fn new(firmware: &str, cfg: WireConfig, tick_rate: board::TickRate) -> Option<Self> {
        let preparer = Preparer::new(&cfg.machine).ok()?;
        cfg.validate().ok()?;
        WAKE_TICKS.store(wake_ticks(cfg.machine.tick_hz), Relaxed);
        Some(Link {
            board: BoardLink::new(firmware, CAPABILITIES),
            machine: Machine {
                queue: Deque::new(),
                preparer,
                config: cfg,
                tick_rate,
                planned: [0; MAX_AXES],
                started: false,
                fed: false,
                accepted: 0,
                faults: 0,
                underruns_seen: 0,
                clock_base_ms: 0,
            },
        })
    }

    /// Handles one frame from the decoder; the response must be sent. The flag is true when the
    /// feeder has new work (Start, or segments queued into a started job).
    pub fn on_frame(
        &mut self,
        frame: Result<&[u8], FrameError>,
        dda: &mut impl Mutex<T = Dda>,
    ) -> (Response, bool) {
        let mut t = Target::new(&mut self.machine, dda);
        let resp = self.board.on_frame(frame, &mut t);
        (resp, t.wake_feeder)
    }

    /// The status task's periodic work: latch faults, and the periodic Status when one is due.
    /// Returns the frames to send (a `Fault` first).
    pub fn poll(&mut self, dda: &mut impl Mutex<T = Dda>) -> [Option<Response>; 2] {
        let fault = self.machine.check_faults(dda);
        let now_ms = self.machine.now_ms(dda);
        let t = Target::new(&mut self.machine, dda);
        [fault, self.board.poll(now_ms, &t)]
    }

    /// The next segment for the DDA, prepared; `None` when the queue is empty or the job has not
    /// been started. Called by the feeder only, which pushes it into the DDA before anything
    /// else can run at its priority.
    pub fn next_prepared(&mut self) -> Option<Result<Prepared, (u32, SegmentError)>> {
        let m = &mut self.machine;
        if !m.started {
            return None;
        }
        let seg = m.queue.pop_front()?;
        m.fed = true;
        Some(m.preparer.prepare(&seg).map_err(|e| (seg.id, e)))
    }

    pub fn is_empty(&self) -> bool {
        self.machine.queue.is_empty()
    }
}

/// Ticks between status-task runs at `tick_hz` (>= MIN_TICK_HZ after validation, so >= 10).
fn wake_ticks(tick_hz: u32) -> u32 {
    (tick_hz / POLLS_PER_SECOND).max(1)
}

impl Machine {
    fn wire_state(&self, dda: MotionState) -> WireState {
        if self.faults != 0 {
            return WireState::Faulted;
        }
        match dda {
            // Started with segments still to feed: moving as soon as the feeder runs.
            MotionState::Idle if self.started && !self.queue.is_empty() => WireState::Moving,
            s => s.into(),
        }
    }

    /// Milliseconds of DDA time since boot (division: never call from the tick).
    fn now_ms(&self, dda: &mut impl Mutex<T = Dda>) -> u64 {
        let now = dda.lock(|d| d.now());
        self.clock_base_ms + now * 1_000 / self.config.machine.tick_hz as u64
    }

    /// Stops at once and drops every queued segment; the job is over.
    fn stop_all(&mut self, dda: &mut impl Mutex<T = Dda>) {
        let (positions, done) = dda.lock(|d| {
            d.abort();
            (d.positions(), d.segments_done())
        });
        self.planned = positions;
        self.accepted = done;
        self.queue.clear();
        self.preparer.reset_junction();
        self.started = false;
        self.fed = false;
    }

    /// Latches a queue underrun the DDA reported since the last check: motion stops, the queue
    /// is dropped, and the host gets a `Fault` frame.
    fn check_faults(&mut self, dda: &mut impl Mutex<T = Dda>) -> Option<Response> {
        let (underruns, tick) = dda.lock(|d| (d.underruns(), d.now()));
        if underruns == self.underruns_seen {
            return None;
        }
        self.underruns_seen = underruns;
        self.faults |= FaultCode::QueueUnderrun.bit();
        self.stop_all(dda);
        Some(Response::Fault { code: FaultCode::QueueUnderrun, tick })
    }
}

/// [`LinkTarget`] for one request: the machine plus the DDA resource. `LinkTarget` reads through
/// `&self`, and an RTIC lock needs `&mut`, hence the `RefCell` (never borrowed twice: no method
/// calls another while it holds the DDA).
pub struct Target<'a, D: Mutex<T = Dda>> {
    m: &'a mut Machine,
    dda: RefCell<&'a mut D>,
    /// The feeder has new work.
    pub wake_feeder: bool,
}

impl<'a, D: Mutex<T = Dda>> Target<'a, D> {
    pub fn new(m: &'a mut Machine, dda: &'a mut D) -> Self {
        Target { m, dda: RefCell::new(dda), wake_feeder: false }
    }

    fn with_dda<R>(&self, f: impl FnOnce(&mut Dda) -> R) -> R {
        self.dda.borrow_mut().lock(f)
    }
}

impl<D: Mutex<T = Dda>> LinkTarget for Target<'_, D> {
    fn state(&self) -> WireState {
        self.m.wire_state(self.with_dda(|d| d.state()))
    }

    fn credits(&self) -> u16 {
        (SEGMENT_QUEUE - self.m.queue.len()) as u16
    }

    fn queue_capacity(&self) -> u16 {
        SEGMENT_QUEUE as u16
    }

    fn config(&self) -> WireConfig {
        self.m.config
    }

    fn planned_position(&self) -> [i64; MAX_AXES] {
        self.m.planned
    }

    fn status(&self) -> Status {
        // One lock: positions, tick and counters are one consistent snapshot.
        let (mut s, dda_state) = self.with_dda(|d| {
            let s = Status {
                tick: d.now(),
                positions: d.positions(),
                override_bits: d.feed_override().to_bits(),
                segments_done: d.segments_done(),
                last_done_id: d.last_done_id(),
                done_hash: d.done_hash(),
                ..Status::default()
            };
            (s, d.state())
        });
        s.state = self.m.wire_state(dda_state);
        s.queue_depth = self.m.accepted.wrapping_sub(s.segments_done).min(u16::MAX as u32) as u16;
        s.faults = self.m.faults;
        s.sensors = [0; SENSOR_CHANNELS];
        s
    }

    fn set_config(&mut self, cfg: &WireConfig) -> Result<(), ErrorCode> {
        let preparer = Preparer::new(&cfg.machine).map_err(|_| ErrorCode::InvalidConfig)?;
        if cfg.machine == self.m.config.machine {
            // Same machine, new scale or soft limits: the DDA, its clock and positions stay.
            self.m.config = *cfg;
            return Ok(());
        }
        let tick_hz = cfg.machine.tick_hz;
        if !self.m.tick_rate.supports(tick_hz) {
            return Err(ErrorCode::InvalidConfig);
        }
        let mut fresh = Dda::new(&cfg.machine).map_err(|_| ErrorCode::InvalidConfig)?;
        let (dda, tick_rate) = (self.dda.get_mut(), &mut self.m.tick_rate);
        // The swap and the retiming in one critical section: no tick sees a half-done change.
        let swapped = dda.lock(|d| {
            if !d.is_idle() {
                return false;
            }
            core::mem::swap(d, &mut fresh);
            tick_rate.set(tick_hz)
        });
        if !swapped {
            return Err(ErrorCode::OutOfState);
        }
        // `fresh` now holds the old DDA.
        let old_ms = fresh.now() * 1_000 / self.m.config.machine.tick_hz as u64;
        let m = &mut *self.m;
        m.clock_base_ms += old_ms;
        m.preparer = preparer;
        m.config = *cfg;
        m.planned = [0; MAX_AXES];
        m.accepted = 0;
        m.underruns_seen = 0;
        m.started = false;
        m.fed = false;
        WAKE_TICKS.store(wake_ticks(tick_hz), Relaxed);
        Ok(())
    }

    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode> {
        if self.m.queue.is_full() {
            return Err(ErrorCode::QueueFull);
        }
        if self.m.started && self.m.fed && self.m.queue.is_empty() && self.with_dda(|d| d.is_idle())
        {
            // Everything fed since the Start has finished: that job is over, this segment
            // belongs to the next one and waits for its Start.
            self.m.started = false;
            self.m.fed = false;
        }
        // Cannot fail: checked for room above.
        let _ = self.m.queue.push_back(*seg);
        for (p, &s) in self.m.planned.iter_mut().zip(seg.steps.iter()) {
            *p += s as i64;
        }
        self.m.accepted = self.m.accepted.wrapping_add(1);
        self.wake_feeder |= self.m.started;
        Ok(())
    }

    fn start(&mut self) -> Result<(), ErrorCode> {
        self.m.started = true;
        self.m.fed = false;
        self.wake_feeder = true;
        Ok(())
    }

    fn hold(&mut self) -> Result<(), ErrorCode> {
        let pending = self.m.started && !self.m.queue.is_empty();
        // Checked in the same lock as the command: a hold must not outlive the job it was meant
        // for (an idle DDA would keep it and start the next job held).
        self.with_dda(|d| {
            if d.is_idle() && !pending {
                return Err(ErrorCode::OutOfState);
            }
            d.apply(Command::Hold);
            Ok(())
        })
    }

    fn resume(&mut self) -> Result<(), ErrorCode> {
        self.with_dda(|d| d.apply(Command::Resume));
        Ok(())
    }

    fn abort(&mut self) -> Result<(), ErrorCode> {
        self.m.stop_all(&mut **self.dda.get_mut());
        Ok(())
    }

    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode> {
        self.with_dda(|d| d.apply(Command::SetOverride(rate)));
        Ok(())
    }

    fn clear_fault(&mut self) -> Result<(), ErrorCode> {
        self.m.faults = 0;
        Ok(())
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
