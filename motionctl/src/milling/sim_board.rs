//! A simulated board that runs force jobs, inside motionctl, for tests of `milling run` (and its
//! resume) without QEMU: the firmware's link state machine ([`BoardLink`]) over a
//! [`MillingSimTarget`], behind the [`Transport`] trait.
//!
//! The plain [`SimTarget`] finishes a segment at once and runs a force job as plain segments;
//! here every segment runs tick by tick through the library's [`Dda`], and an armed force job
//! (`ArmForce`, `Sim(Milling)`) runs the firmware's own [`ForceJob`] on it: the simulated plant
//! sampled every `tick_hz / sample_hz` ticks at the feed axis's position, the chain and the
//! control law, whose override goes to the DDA as the link firmware's tick does. Machine time
//! runs at `speed` times the wall clock, and the status stream on board time.
//!
//! For resume tests it can lose power once the feed axis reaches a position
//! ([`MillingSimBoard::power_cut_at_steps`]): the board restarts blank (no config, queue and job
//! gone) and the machine's path so far is kept.

use crate::sim_link::SimLink;
use crate::transport::Transport;
use motion::dda::{Command, Dda, Preparer};
use motion::machine::{MachineState, ProbeKind};
use motion::milling::link_job::ForceJob;
use motion::milling::link_params::ForceJobParams;
use motion::protocol::{
    BoardLink, ErrorCode, FaultCode, HomingConfig, LinkConfig, LinkState, LinkTarget,
    ProgramOutputs, SimRequest, SimTarget, Status, CAP_DDA, CAP_HOLD_RESUME, CAP_MILLING_JOB,
    CAP_OVERRIDE, CAP_SIM_INPUTS, CAP_SOFT_LIMITS, CAP_STATUS_STREAM,
};
use motion::segment::Segment;
use motion::{Rate, MAX_AXES};
use std::collections::VecDeque;
use std::io;
use std::time::{Duration, Instant};

/// Queue capacity of the simulated board.
pub const CAPACITY: u16 = 8;
/// Most machine time run per call (a stalled test thread does not owe minutes of ticks).
const MAX_ADVANCE_S: f64 = 0.05;

/// The segment running on the DDA: where the axes were at its start.
#[derive(Clone, Copy, Debug)]
struct Running {
    start: [i64; MAX_AXES],
    dda_base: [i64; MAX_AXES],
    dda_done: u32,
}

/// [`SimTarget`] (the command table, queue, counters) with its segments run on a DDA and its
/// force job on the firmware's force code.
pub struct MillingSimTarget {
    pub inner: SimTarget,
    /// The queued segments, as the inner target holds them (it has no look at its front).
    queued: VecDeque<Segment>,
    dda: Option<(Dda, Preparer)>,
    running: Option<Running>,
    force: Option<ForceJob>,
    dda_held: bool,
}

impl MillingSimTarget {
    pub fn new(capacity: u16) -> Self {
        MillingSimTarget {
            inner: SimTarget::new(LinkConfig::UNSET, capacity),
            queued: VecDeque::new(),
            dda: None,
            running: None,
            force: None,
            dda_held: false,
        }
    }

    fn drop_motion(&mut self) {
        self.queued.clear();
        self.running = None;
        if let Some((dda, _)) = self.dda.as_mut() {
            dda.abort();
        }
        self.end_force();
    }

    fn end_force(&mut self) {
        if let Some(f) = self.force.as_mut() {
            f.end();
        }
        self.inner.force_armed = None;
    }

    /// Runs one machine tick: the running segment (or the next queued one), the force job's
    /// sample when due. Board time advances whether or not anything moves.
    pub fn tick(&mut self) {
        self.inner.tick += 1;
        let live = self.inner.running && self.inner.faults == 0;
        if self.running.is_none() && live && !self.inner.held {
            if let Some(seg) = self.queued.front().copied() {
                self.begin(&seg);
            }
        }
        let Some(run) = self.running else { return };
        let Some((dda, _)) = self.dda.as_mut() else { return };
        if self.inner.held != self.dda_held {
            self.dda_held = self.inner.held;
            dda.apply(if self.dda_held { Command::Hold } else { Command::Resume });
        }
        dda.tick();
        let now = dda.positions();
        for (i, p) in self.inner.positions.iter_mut().enumerate() {
            *p = run.start[i] + now[i] - run.dda_base[i];
        }
        if let Some(f) = self.force.as_mut().filter(|f| f.is_running()) {
            if f.sample_due() {
                let out = f.sample_sim(self.inner.positions[f.axis()]);
                if let Some(rate) = out.set_override {
                    dda.apply(Command::CapabilityOverride(rate));
                }
                if out.fault_bits != 0 {
                    let code = FaultCode::ALL
                        .iter()
                        .copied()
                        .find(|c| out.fault_bits & c.bit() != 0)
                        .unwrap_or(FaultCode::SensorFault);
                    self.inner.raise_fault(code);
                    self.drop_motion();
                    return;
                }
            }
        }
        if dda.segments_done() != run.dda_done {
            // Done: the inner target books it (positions, counters, the job's end).
            let (tick, end) = (self.inner.tick, self.inner.positions);
            self.inner.positions = run.start;
            self.inner.complete_one();
            debug_assert_eq!(self.inner.positions, end);
            self.inner.positions = end;
            self.inner.tick = tick;
            self.queued.pop_front();
            self.running = None;
            if self.inner.machine == MachineState::Ready {
                self.end_force();
            }
        }
    }

    fn begin(&mut self, seg: &Segment) {
        let machine = self.inner.config.machine;
        if self.dda.is_none() {
            match (Dda::new(&machine), Preparer::new(&machine)) {
                (Ok(d), Ok(p)) => self.dda = Some((d, p)),
                _ => {
                    self.inner.raise_fault(FaultCode::ConfigCorrupt);
                    self.drop_motion();
                    return;
                }
            }
        }
        let Some((dda, prep)) = self.dda.as_mut() else { return };
        let pushed = prep.prepare(seg).ok().is_some_and(|p| dda.push(&p).is_ok());
        if !pushed {
            self.inner.raise_fault(FaultCode::QueueUnderrun);
            self.drop_motion();
            return;
        }
        self.running = Some(Running {
            start: self.inner.positions,
            dda_base: dda.positions(),
            dda_done: dda.segments_done(),
        });
    }
}

impl LinkTarget for MillingSimTarget {
    fn state(&self) -> LinkState {
        self.inner.state()
    }
    fn machine_state(&self) -> MachineState {
        self.inner.machine_state()
    }
    fn credits(&self) -> u16 {
        self.inner.credits()
    }
    fn queue_capacity(&self) -> u16 {
        self.inner.queue_capacity()
    }
    fn config(&self) -> LinkConfig {
        self.inner.config()
    }
    fn planned_position(&self) -> [i64; MAX_AXES] {
        self.inner.planned_position()
    }

    /// The inner status with the force job's figures; while it runs, the override is its.
    fn status(&self) -> Status {
        let mut st = self.inner.status();
        if let Some(f) = &self.force {
            let t = f.telemetry();
            t.write_status(&mut st);
            if f.is_running() && t.updates != 0 {
                st.override_bits = t.override_bits;
            }
        }
        st
    }

    fn set_config(&mut self, cfg: &LinkConfig) -> Result<(), ErrorCode> {
        self.inner.set_config(cfg)?;
        self.dda = None;
        Ok(())
    }
    fn queue_segment(&mut self, seg: &Segment) -> Result<(), ErrorCode> {
        self.inner.queue_segment(seg)?;
        self.queued.push_back(*seg);
        Ok(())
    }
    fn start(&mut self) -> Result<(), ErrorCode> {
        // The force job is made first: a refusal must change nothing.
        let job = match self.inner.force_armed {
            Some(p) => {
                let tick_hz = self.inner.config.machine.tick_hz;
                let sim = self.inner.sim_milling.as_ref();
                Some(ForceJob::new(&p, tick_hz, true, sim).map_err(|_| ErrorCode::OutOfRange)?)
            }
            None => None,
        };
        self.inner.start()?;
        if let Some(mut job) = job {
            job.start(self.inner.positions[job.axis()]);
            self.force = Some(job);
        }
        Ok(())
    }
    fn hold(&mut self) -> Result<(), ErrorCode> {
        self.inner.hold()
    }
    fn resume(&mut self) -> Result<(), ErrorCode> {
        self.inner.resume()
    }
    fn abort(&mut self) -> Result<(), ErrorCode> {
        self.inner.abort()?;
        self.drop_motion();
        Ok(())
    }
    fn set_override(&mut self, rate: Rate) -> Result<(), ErrorCode> {
        self.inner.set_override(rate)?;
        if let Some((dda, _)) = self.dda.as_mut() {
            dda.apply(Command::SetOverride(rate));
        }
        Ok(())
    }
    fn clear_fault(&mut self) -> Result<(), ErrorCode> {
        self.inner.clear_fault()?;
        self.drop_motion();
        Ok(())
    }
    fn home(&mut self) -> Result<(), ErrorCode> {
        self.inner.home()
    }
    fn set_homing(&mut self, homing: &HomingConfig) -> Result<(), ErrorCode> {
        self.inner.set_homing(homing)
    }
    fn jog_off_limit(&mut self) -> Result<(), ErrorCode> {
        self.inner.jog_off_limit()
    }
    fn sim(&mut self, req: &SimRequest) -> Result<(), ErrorCode> {
        self.inner.sim(req)
    }
    fn set_program_outputs(&mut self, o: ProgramOutputs) -> Result<(), ErrorCode> {
        self.inner.set_program_outputs(o)
    }
    fn arm_probe(&mut self, _kind: ProbeKind) -> Result<(), ErrorCode> {
        Err(ErrorCode::Unsupported)
    }
}

impl motion::polar::link_messages::PolarTarget for MillingSimTarget {}

impl motion::turning::link_messages::TurningTarget for MillingSimTarget {}

impl motion::milling::link_messages::MillingTarget for MillingSimTarget {
    fn arm_force(&mut self, params: &ForceJobParams) -> Result<(), ErrorCode> {
        self.inner.arm_force(params)
    }
}

impl motion::wire::link_messages::WireTarget for MillingSimTarget {}

/// The board: link, target, the wall clock it runs on, and an optional power cut.
pub struct MillingSimBoard {
    pub board: BoardLink,
    pub target: MillingSimTarget,
    link: SimLink,
    last: Instant,
    budget_ticks: f64,
    /// Machine time per wall time.
    pub speed: f64,
    /// Lose power once the feed axis (X) reaches this many steps.
    pub power_cut_at_steps: Option<i64>,
    /// Power cuts so far.
    pub power_cuts: u32,
    /// When `Some`, X after every tick it changed: the path the machine took, kept through a
    /// power cut (a power cut does not undo motion).
    pub path: Option<Vec<i64>>,
}

impl MillingSimBoard {
    pub fn new(speed: f64) -> Self {
        let caps = CAP_DDA
            | CAP_STATUS_STREAM
            | CAP_OVERRIDE
            | CAP_HOLD_RESUME
            | CAP_SOFT_LIMITS
            | CAP_SIM_INPUTS
            | CAP_MILLING_JOB;
        MillingSimBoard {
            board: BoardLink::new("motionctl-force-sim", caps),
            target: MillingSimTarget::new(CAPACITY),
            link: SimLink::new(),
            last: Instant::now(),
            budget_ticks: 0.0,
            speed,
            power_cut_at_steps: None,
            power_cuts: 0,
            path: None,
        }
    }

    /// Board time, ms (the status stream runs on it).
    fn now_ms(&self) -> u64 {
        let hz = self.target.inner.config.machine.tick_hz.max(1) as u64;
        self.target.inner.tick * 1000 / hz
    }

    /// Runs the machine up to now (at most [`MAX_ADVANCE_S`] of machine time) and emits the
    /// statuses due.
    fn advance(&mut self) {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        let tick_hz = self.target.inner.config.machine.tick_hz as f64;
        self.budget_ticks =
            (self.budget_ticks + dt * tick_hz * self.speed).min(MAX_ADVANCE_S * tick_hz);
        let period_ticks = (tick_hz / 1000.0).max(1.0) as u64;
        while self.budget_ticks >= 1.0 {
            self.budget_ticks -= 1.0;
            let x = self.target.inner.positions[0];
            self.target.tick();
            let x_now = self.target.inner.positions[0];
            if x_now != x {
                if let Some(p) = self.path.as_mut() {
                    p.push(x_now);
                }
                if self.power_cut_at_steps.is_some_and(|at| x_now >= at) {
                    self.power_cut();
                    return;
                }
            }
            // The status stream at board time, a millisecond at a time.
            if self.target.inner.tick.is_multiple_of(period_ticks) {
                let ms = self.now_ms();
                if let Some(resp) = self.board.poll(ms, &self.target) {
                    self.link.emit(&resp);
                }
            }
        }
    }

    /// Power lost and back: a blank board; the machine stays where it stopped, which the new
    /// board does not know (it counts from zero, as after a reset).
    fn power_cut(&mut self) {
        let fresh = MillingSimBoard::new(self.speed);
        let (path, cuts) = (self.path.take(), self.power_cuts + 1);
        *self = fresh;
        self.path = path;
        self.power_cuts = cuts;
    }
}

impl Transport for MillingSimBoard {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.advance();
        self.link.receive(bytes, &mut self.board, &mut self.target);
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        self.advance();
        if self.link.is_empty() {
            SimLink::idle_wait(timeout);
            self.advance();
        }
        Ok(self.link.take())
    }

    fn reconnect(&mut self) -> io::Result<()> {
        self.link.reset();
        Ok(())
    }

    fn describe(&self) -> String {
        "the simulated force board".into()
    }
}
