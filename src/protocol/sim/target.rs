//! A hardware-free [`LinkTarget`]: a segment queue and a motion state, enough to exercise the link
//! in tests, in the fuzzers and in `motionctl`'s loopback mode. No allocation.
//!
//! Its machine state follows the machine's command table ([`crate::machine::cell`]) with two
//! simplifications: homing completes at once, and a job ends when the queue runs dry after a
//! segment that ends at rest.
//!
//! Event jobs (`QueueEvents`, `StartPlayback`) run the firmware's own code: the blocks go through
//! an [`EventFeed`] into a [`Playback`] ticked by [`SimTarget::run_events`] at the feed override,
//! so the positions and event counts are exactly the board's.

use crate::milling::link_params::ForceJobParams;
use crate::wire::link_messages::WireJobParams;
use heapless::Deque;

#[cfg(feature = "sim-inputs")]
use super::messages::SimRequest;
use super::messages::{SimMillingParams, SimProbeSurface};
use crate::config::MAX_AXES;
use crate::machine::{
    cell, reaction, Cell, CommandKind, MachineState, Outputs, ProbeKind, ProbeRun, Reaction,
};
use crate::polar::feed::EventFeed;
use crate::polar::playback::{Playback, SizeScale, RATE_MAX, RATE_MIN};
use crate::protocol::errors::{ErrorCode, FaultCode};
use crate::protocol::messages::{BoardCounters, HomingConfig, LinkConfig, LinkState, Status};
use crate::protocol::program_outputs::ProgramOutputs;
use crate::protocol::session::LinkTarget;
use crate::segment::{Rate, Segment};

/// Largest queue a `SimTarget` can have.
pub const SIM_QUEUE_MAX: usize = 64;
/// Event blocks a `SimTarget` holds (as the link firmware).
pub const SIM_EVENT_BLOCKS: usize = crate::polar::feed::EVENT_QUEUE_BLOCKS;

/// Fake machine: queued segments complete when the test calls [`SimTarget::complete_one`].
#[derive(Clone, Debug)]
pub struct SimTarget {
    pub config: LinkConfig,
    pub homing: HomingConfig,
    pub machine: MachineState,
    pub homed: bool,
    queue: Deque<Segment, SIM_QUEUE_MAX>,
    capacity: u16,
    pub running: bool,
    pub held: bool,
    pub override_bits: u32,
    pub faults: u32,
    pub positions: [i64; MAX_AXES],
    planned: [i64; MAX_AXES],
    pub tick: u64,
    pub segments_done: u32,
    pub last_done_id: Option<u32>,
    pub done_hash: u32,
    /// Segments ever queued, and the deepest the queue got.
    pub queued_total: u64,
    pub max_depth: u16,
    /// Calls that changed something (every successful mutating call), for "nothing changed"
    /// assertions.
    pub mutations: u64,
    /// Event blocks waiting for the playback.
    pub events: EventFeed<SIM_EVENT_BLOCKS>,
    /// The event job's playback (ticked by [`SimTarget::run_events`]).
    pub playback: Playback,
    /// An event job was started and has not ended.
    pub event_job: bool,
    /// Machine positions when the event job started (the playback counts from there).
    event_base: [i64; MAX_AXES],
    /// An armed wire job's parameters (`ArmWire`); the sim runs its segments as plain ones.
    pub wire_armed: Option<WireJobParams>,
    /// The simulated wire-stall switch (`Sim(Inject)`).
    pub sim_wire_stall: bool,
    // -- force job --
    /// An armed force job's parameters (`ArmForce`); the sim runs its segments as plain ones.
    pub force_armed: Option<ForceJobParams>,
    /// The simulated milling plant (`Sim(Milling)`).
    pub sim_milling: Option<SimMillingParams>,
    /// Pauses for a late host (`BoardCounters::starve_holds`), counted by whoever runs the
    /// queue.
    pub starve_holds: u32,
    /// The machine's outputs (`SetProgramOutputs` switches the spindle and coolant in them; a
    /// fault whose reaction kills them forces [`Outputs::SAFE`], as the machine does).
    pub outputs: Outputs,
    /// The probe move (`ArmProbe`): the machine's own bookkeeping, tripped against
    /// `sim_probe` along each segment (no debounce, no deceleration: it stops at the trip).
    pub probe: ProbeRun,
    /// The simulated probe surface (`Sim(Probe)`); `None`: the probe never touches.
    pub sim_probe: Option<SimProbeSurface>,
}

impl PartialEq for SimTarget {
    fn eq(&self, o: &Self) -> bool {
        self.config == o.config
            && (self.homing, self.machine, self.homed) == (o.homing, o.machine, o.homed)
            && self.queue.iter().eq(o.queue.iter())
            && (self.capacity, self.running, self.held) == (o.capacity, o.running, o.held)
            && (self.override_bits, self.faults, self.tick) == (o.override_bits, o.faults, o.tick)
            && (self.positions, self.planned) == (o.positions, o.planned)
            && (self.segments_done, self.last_done_id) == (o.segments_done, o.last_done_id)
            && (self.queued_total, self.max_depth, self.mutations)
                == (o.queued_total, o.max_depth, o.mutations)
            && (self.events.events_admitted, self.events.blocks(), self.event_job)
                == (o.events.events_admitted, o.events.blocks(), o.event_job)
            && self.playback.fired() == o.playback.fired()
            && (self.wire_armed, self.sim_wire_stall) == (o.wire_armed, o.sim_wire_stall)
            && (self.force_armed, self.sim_milling) == (o.force_armed, o.sim_milling)
            && self.outputs == o.outputs
            && (self.probe, self.sim_probe) == (o.probe, o.sim_probe)
    }
}

impl SimTarget {
    /// Homed and `Ready` (the state after SetConfig and Home); `capacity` is clamped to
    /// [`SIM_QUEUE_MAX`].
    pub fn new(config: LinkConfig, capacity: u16) -> Self {
        SimTarget {
            config,
            homing: HomingConfig::NONE,
            machine: MachineState::Ready,
            homed: true,
            queue: Deque::new(),
            capacity: capacity.min(SIM_QUEUE_MAX as u16),
            running: false,
            held: false,
            override_bits: Rate::ONE.to_bits(),
            faults: 0,
            positions: [0; MAX_AXES],
            planned: [0; MAX_AXES],
            tick: 0,
            segments_done: 0,
            last_done_id: None,
            done_hash: crate::segment::ORDER_HASH_START,
            queued_total: 0,
            max_depth: 0,
            mutations: 0,
            events: EventFeed::new(),
            playback: Playback::new(SizeScale::ONE),
            event_job: false,
            event_base: [0; MAX_AXES],
            wire_armed: None,
            sim_wire_stall: false,
            force_armed: None,
            sim_milling: None,
            starve_holds: 0,
            outputs: Outputs::SAFE,
            probe: ProbeRun::new(),
            sim_probe: None,
        }
    }

    /// The simulated probe input at `positions`.
    fn probe_level(&self, positions: &[i64; MAX_AXES]) -> bool {
        self.sim_probe.is_some_and(|s| s.active(positions))
    }

    /// A probe move's segment against the surface: the positions at the first step along it
    /// where the probe reads the level that ends the move, if it does. The surface is a plane
    /// across one axis, so along a straight segment the level changes at most once: a binary
    /// search over the segment's steps (host code: it divides).
    fn probe_trip_along(&self, seg: &Segment) -> Option<[i64; MAX_AXES]> {
        let n = seg.steps.iter().map(|s| s.unsigned_abs()).max().unwrap_or(0) as i64;
        let start = self.positions;
        let at = |k: i64| {
            let mut p = start;
            for (p, &s) in p.iter_mut().zip(&seg.steps) {
                *p += (s as i64 * k).checked_div(n).unwrap_or(0);
            }
            p
        };
        let trip = self.probe.kind().trip_level();
        let hits = |k: i64| self.probe_level(&at(k)) == trip;
        if hits(0) {
            return Some(start);
        }
        if !hits(n) {
            return None;
        }
        let (mut lo, mut hi) = (0, n);
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if hits(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(at(hi))
    }

    /// Runs an event job for `ticks` ticks as the firmware would: refill the playback from the
    /// blocks, tick it at the feed override (stopped while held), count its steps. The job ends
    /// when the playback is done; a playback that starves before the last block is an underrun
    /// (`QueueUnderrun`, the job stops).
    pub fn run_events(&mut self, ticks: u64) {
        for _ in 0..ticks {
            if !self.event_job || self.faults != 0 {
                return;
            }
            self.events.fill(&mut self.playback);
            if self.playback.starved() {
                self.raise_fault(FaultCode::QueueUnderrun);
                return;
            }
            let rate = if self.held {
                0
            } else {
                Rate::from_bits(self.override_bits).clamp(RATE_MIN, RATE_MAX).to_bits()
            };
            self.playback.tick_at(rate);
            self.tick += 1;
            let p = self.playback.position();
            self.positions[0] = self.event_base[0] + p[0];
            self.positions[1] = self.event_base[1] + p[1];
            if self.playback.done() {
                self.event_job = false;
                self.running = false;
                self.events.clear();
                self.planned = self.positions;
                self.machine = MachineState::Ready;
                return;
            }
        }
    }

    pub fn queue_len(&self) -> usize {
        self.queue.len()
    }

    /// Finishes the oldest queued segment if the machine is running (not held, no fault).
    pub fn complete_one(&mut self) -> Option<Segment> {
        if !self.running || self.held || self.faults != 0 {
            return None;
        }
        let seg = self.queue.pop_front()?;
        if self.probe.watching() {
            if let Some(at) = self.probe_trip_along(&seg) {
                // As the machine: latch, stop there, drop the rest of the move; the cut
                // segment is not done. The job ends in Ready.
                self.probe.trip(at);
                self.probe.stopped();
                self.probe.take_discard();
                self.positions = at;
                self.tick += seg.duration_ticks as u64;
                self.queue.clear();
                self.planned = self.positions;
                self.running = false;
                self.machine = MachineState::Ready;
                return Some(seg);
            }
        }
        for (p, s) in self.positions.iter_mut().zip(seg.steps) {
            *p += s as i64;
        }
        self.segments_done += 1;
        self.last_done_id = Some(seg.id);
        self.done_hash = crate::segment::order_hash(self.done_hash, seg.id);
        self.tick += seg.duration_ticks as u64;
        if self.queue.is_empty() && seg.exit_rate.to_bits() == 0 {
            // The job ended at rest (an armed wire job with it, as on the board).
            self.running = false;
            self.machine = MachineState::Ready;
            self.wire_armed = None;
            if let Some(fault) = self.probe.job_end() {
                self.raise_fault(fault);
            }
        }
        Some(seg)
    }

    /// Latches a fault: motion stops, the queue is dropped.
    pub fn raise_fault(&mut self, code: FaultCode) {
        self.faults |= code.bit();
        self.probe.drop_move();
        if reaction(code) == Reaction::Kill {
            self.outputs = Outputs::SAFE;
        }
        self.queue.clear();
        self.drop_events();
        self.planned = self.positions;
        self.running = false;
        self.held = false;
        self.machine = MachineState::Fault;
    }

    fn drop_events(&mut self) {
        self.events.clear();
        self.event_job = false;
    }

    /// The table's transition for an accepted command (`BoardLink` checked it was allowed).
    fn take(&mut self, cmd: CommandKind) {
        self.machine = match cell(self.machine, cmd) {
            // Instant homing: there are no axes to move.
            Cell::To(MachineState::Homing) => {
                self.homed = true;
                MachineState::Ready
            }
            Cell::To(s) => s,
            Cell::Recover if self.homed => MachineState::Ready,
            Cell::Recover => MachineState::Idle,
            Cell::Stay | Cell::Refused => self.machine,
        };
        if cmd == CommandKind::SetConfig {
            self.homed = false;
        }
        if matches!(
            cmd,
            CommandKind::SetConfig
                | CommandKind::Home
                | CommandKind::Abort
                | CommandKind::ClearFault
        ) {
            self.probe.drop_move();
            self.wire_armed = None;
        }
        self.mutations += 1;
    }
}

impl LinkTarget for SimTarget {
    fn state(&self) -> LinkState {
        if self.faults != 0 {
            LinkState::Faulted
        } else if self.held {
            LinkState::Held
        } else if self.running && (!self.queue.is_empty() || self.event_job) {
            LinkState::Moving
        } else {
            LinkState::Idle
        }
    }

    fn machine_state(&self) -> MachineState {
        self.machine
    }

    fn credits(&self) -> u16 {
        self.capacity.saturating_sub(self.queue.len() as u16)
    }

    fn queue_capacity(&self) -> u16 {
        self.capacity
    }

    fn config(&self) -> LinkConfig {
        self.config
    }

    fn planned_position(&self) -> [i64; MAX_AXES] {
        self.planned
    }

    fn status(&self) -> Status {
        Status {
            tick: self.tick,
            positions: self.positions,
            state: self.state(),
            override_bits: self.override_bits,
            queue_depth: self.queue.len() as u16,
            credits: 0,
            segments_done: self.segments_done,
            last_done_id: self.last_done_id,
            done_hash: self.done_hash,
            faults: self.faults,
            sensors: [0; 4],
            next_seq: 0,
            machine: self.machine,
            causes: 0,
            homed: self.homed,
            event_credits: self.events.credits(),
            events_fired: self.playback.fired(),
            event_blocks: self.events.blocks() as u16,
            counters: BoardCounters { starve_holds: self.starve_holds, ..BoardCounters::default() },
            outputs: ProgramOutputs::of(&self.outputs).bits(),
            probe_phase: self.probe.phase() as u8,
            probe_steps: self.probe.latched_steps(),
            probe_input: self.probe_level(&self.positions),
            ..Status::default()
        }
    }

    fn set_config(&mut self, cfg: &LinkConfig) -> Result<(), ErrorCode> {
        self.config = *cfg;
        self.take(CommandKind::SetConfig);
        Ok(())
    }

    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode> {
        // The same switches again change nothing: the machine stays homed.
        if *homing == self.homing {
            return Ok(());
        }
        self.homing = *homing;
        self.take(CommandKind::SetConfig);
        Ok(())
    }

    fn home(&mut self) -> Result<(), ErrorCode> {
        self.take(CommandKind::Home);
        Ok(())
    }

    /// The fake machine has no switches: there is never anything to jog off.
    fn jog_off_limit(&mut self) -> Result<(), ErrorCode> {
        Err(ErrorCode::OutOfState)
    }

    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode> {
        if self.event_job || !self.events.is_unused() {
            return Err(ErrorCode::OutOfState);
        }
        if self.queue.len() >= self.capacity as usize {
            return Err(ErrorCode::QueueFull);
        }
        self.queue.push_back(*seg).map_err(|_| ErrorCode::QueueFull)?;
        for (p, s) in self.planned.iter_mut().zip(seg.steps) {
            *p += s as i64;
        }
        self.queued_total += 1;
        self.max_depth = self.max_depth.max(self.queue.len() as u16);
        self.mutations += 1;
        Ok(())
    }

    fn start(&mut self) -> Result<(), ErrorCode> {
        if self.event_job || !self.events.is_unused() {
            return Err(ErrorCode::OutOfState);
        }
        if let Err(fault) = self.probe.start(self.probe_level(&self.positions)) {
            // As the machine: nothing moves, the fault is the answer.
            self.raise_fault(fault);
            return Ok(());
        }
        self.running = true;
        self.take(CommandKind::Start);
        Ok(())
    }

    fn hold(&mut self) -> Result<(), ErrorCode> {
        self.held = true;
        self.take(CommandKind::Hold);
        Ok(())
    }

    fn resume(&mut self) -> Result<(), ErrorCode> {
        self.held = false;
        self.take(CommandKind::Resume);
        Ok(())
    }

    fn abort(&mut self) -> Result<(), ErrorCode> {
        self.queue.clear();
        self.drop_events();
        self.planned = self.positions;
        self.running = false;
        self.held = false;
        self.take(CommandKind::Abort);
        Ok(())
    }

    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode> {
        self.override_bits = rate.to_bits();
        self.mutations += 1;
        Ok(())
    }

    fn clear_fault(&mut self) -> Result<(), ErrorCode> {
        self.faults = 0;
        self.queue.clear();
        self.drop_events();
        self.planned = self.positions;
        self.take(CommandKind::ClearFault);
        Ok(())
    }

    fn event_credits(&self) -> u16 {
        self.events.credits()
    }

    fn events_pending(&self) -> bool {
        self.event_job || !self.events.is_unused()
    }

    /// The wire-stall switch and the milling plant; no spindle or encoders (`CopySim` has
    /// those).
    #[cfg(feature = "sim-inputs")]
    fn sim(&mut self, req: &SimRequest) -> Result<(), ErrorCode> {
        match *req {
            SimRequest::Inject { wire_stall } => self.sim_wire_stall = wire_stall,
            SimRequest::Milling(params) => self.sim_milling = Some(params),
            SimRequest::Probe { surface } => self.sim_probe = surface,
            SimRequest::Spindle { .. }
            | SimRequest::Encoders { .. }
            | SimRequest::CorruptConfig => return Err(ErrorCode::Unsupported),
        }
        self.mutations += 1;
        Ok(())
    }

    fn arm_probe(&mut self, kind: ProbeKind) -> Result<(), ErrorCode> {
        let busy = !self.queue.is_empty() || self.event_job || self.events.blocks() != 0;
        let armed = self.wire_armed.is_some() || self.force_armed.is_some();
        if self.machine != MachineState::Ready || busy || armed {
            return Err(ErrorCode::OutOfState);
        }
        self.probe.arm(kind);
        self.mutations += 1;
        Ok(())
    }

    fn set_program_outputs(&mut self, o: ProgramOutputs) -> Result<(), ErrorCode> {
        // As `Machine::set_outputs`: nothing switches on while the e-stop is latched.
        if self.faults & FaultCode::EStop.bit() != 0 {
            return Err(ErrorCode::OutOfState);
        }
        self.outputs = o.applied_to(self.outputs);
        self.mutations += 1;
        Ok(())
    }
}

impl crate::polar::link_messages::PolarTarget for SimTarget {
    fn next_event_block(&self) -> Option<u16> {
        self.events.expected()
    }
    fn queue_events(&mut self, block: &[u8], last: bool) -> Result<(), ErrorCode> {
        if !self.queue.is_empty() {
            return Err(ErrorCode::OutOfState);
        }
        self.events.push(block, last).map_err(|_| ErrorCode::Internal)?;
        self.take(CommandKind::Queue);
        Ok(())
    }
    fn start_playback(&mut self, scale: SizeScale) -> Result<(), ErrorCode> {
        if self.event_job || self.events.is_unused() || !self.queue.is_empty() {
            return Err(ErrorCode::OutOfState);
        }
        self.playback = Playback::new(scale);
        self.events.fill(&mut self.playback);
        self.event_base = self.positions;
        self.event_job = true;
        self.running = true;
        self.take(CommandKind::Start);
        Ok(())
    }
}

impl crate::turning::link_messages::TurningTarget for SimTarget {}

impl crate::milling::link_messages::MillingTarget for SimTarget {
    // -- force job --
    fn arm_force(&mut self, params: &ForceJobParams) -> Result<(), ErrorCode> {
        let busy = !self.queue.is_empty() || self.event_job || self.events.blocks() != 0;
        let armed = self.wire_armed.is_some() || self.force_armed.is_some();
        if self.machine != MachineState::Ready || busy || armed {
            return Err(ErrorCode::OutOfState);
        }
        self.force_armed = Some(*params);
        self.mutations += 1;
        Ok(())
    }
}

impl crate::wire::link_messages::WireTarget for SimTarget {
    fn arm_wire(&mut self, params: &WireJobParams) -> Result<(), ErrorCode> {
        let busy = !self.queue.is_empty() || self.event_job || self.events.blocks() != 0;
        if self.machine != MachineState::Ready || busy || self.wire_armed.is_some() {
            return Err(ErrorCode::OutOfState);
        }
        self.wire_armed = Some(*params);
        self.mutations += 1;
        Ok(())
    }
}
