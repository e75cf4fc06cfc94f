//! [`Machine`]: the state machine, the fault latch and its reactions, soft limits, homing and the
//! step counters, wrapped around the DDA. The tick interrupt calls [`Machine::tick`] (which ticks
//! the DDA), the control task calls [`Machine::command`] and, whenever
//! [`Machine::wants_background`], [`Machine::background`].
//!
//! Why the immediate stops are split in two: `Dda::abort` reads `Dda::positions`, which divides
//! (a 64-bit software divide on the M4), so it must not run in the tick. The tick therefore
//! *freezes* the DDA (stops ticking it: no further edge reaches the pins, the same tick the cause
//! is seen) and the background aborts it before the next DDA tick. Nothing is stepped in between,
//! so the positions are exactly what was stepped.

use super::config::BoardConfig;
use super::debounce::SwitchFilter;
use super::faults::{reaction, FaultLatch, Reaction};
use super::following::FollowingMonitor;
use super::homing::{HomeEvent, Homing};
use super::jog_off::{JogEvent, JogOff};
use super::limits::SoftLimits;
use super::outputs::Outputs;
use super::probe::{ProbeKind, ProbeRun};
use super::reset_cause::ResetCause;
use super::state::{cell, event_allowed, Cell, CommandKind, MachineState};
use crate::config::{ConfigError, MAX_AXES};
use crate::dda::{Command, Dda, MotionState, Preparer, StepOutput, READY_DEPTH};
use crate::planner::Planner;
use crate::protocol::{ErrorCode, FaultCode, LinkState};
use crate::segment::{Segment, SegmentError};

mod command;
mod fast;
mod pending;
mod source;
mod watch;
pub use command::{MachineCommand, Refusal};
pub use fast::{
    supervise_ticks, MAX_SUPERVISE_TICKS, STREAM_SAMPLE_STRIDE, SUPERVISE_HZ, SUPERVISE_TICKS,
};
pub use source::{DdaSource, SourceJob, StepSource};

/// Slack, in virtual ticks, between the point where a starved job is held and the last point
/// from which the hold still stops within the running segment (the hold acts from the next tick).
pub const STARVE_MARGIN_VTICKS: u32 = 64;

/// The job bookkeeping (end of job, underrun, a late host) runs every this many ticks of a
/// running job: far inside [`STARVE_MARGIN_VTICKS`] (at most two virtual ticks pass per tick).
pub const JOB_WATCH_TICKS: u8 = 8;

/// What the board reads every tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Inputs {
    /// E-stop chain open.
    pub estop: bool,
    /// Limit switches closed: bit i = axis i.
    pub limit_min: u8,
    pub limit_max: u8,
    /// Faults the sensor monitors raise now: `FaultCode::bit()`s (force, spindle, encoder,
    /// resolver, following error, ...). Bits of other codes are ignored.
    pub sensor_faults: u32,
    /// The host link is alive (a valid frame within the link timeout).
    pub link_ok: bool,
    /// The previous tick overran (from [`super::OverrunDetector`]).
    pub tick_overrun: bool,
    /// The touch probe is triggered (in contact), raw: the machine debounces it.
    pub probe: bool,
}

impl Inputs {
    /// Nothing wrong.
    pub const QUIET: Inputs = Inputs {
        estop: false,
        limit_min: 0,
        limit_max: 0,
        sensor_faults: 0,
        link_ok: true,
        tick_overrun: false,
        probe: false,
    };
}

/// The fault codes a sensor monitor may raise through [`Inputs::sensor_faults`].
pub const SENSOR_FAULTS: u32 = FaultCode::SensorFault.bit()
    | FaultCode::ForceSaturated.bit()
    | FaultCode::ForceStuck.bit()
    | FaultCode::ForceTrip.bit()
    | FaultCode::SpindleStopped.bit()
    | FaultCode::EncoderIndex.bit()
    | FaultCode::ResolverLoss.bit()
    | FaultCode::ZSlideLimit.bit()
    | FaultCode::WireStall.bit()
    | FaultCode::FollowingError.bit();

/// What the board applies after a tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TickOut {
    pub step: StepOutput,
    pub outputs: Outputs,
}

/// Why a stored config could not be used at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BootConfig {
    /// Never saved (QEMU's read-only flash always reads this way): `ConfigMissing`.
    Missing,
    /// Something is stored but no complete record of this version (or the flash refused the
    /// read): `ConfigCorrupt`.
    Corrupt,
    /// A complete record whose values fail validation: `ConfigCorrupt`.
    Invalid(ConfigError),
    /// A valid record whose tick rate this board's timer cannot make: `TickRate`.
    UnsupportedTickRate { tick_hz: u32 },
}

impl BootConfig {
    /// The fault the machine latches for this reason.
    pub const fn fault(self) -> FaultCode {
        match self {
            BootConfig::Missing => FaultCode::ConfigMissing,
            BootConfig::Corrupt | BootConfig::Invalid(_) => FaultCode::ConfigCorrupt,
            BootConfig::UnsupportedTickRate { .. } => FaultCode::TickRate,
        }
    }
}

/// The config faults: levels until a valid `SetConfig`.
const CONFIG_FAULTS: u32 =
    FaultCode::ConfigMissing.bit() | FaultCode::ConfigCorrupt.bit() | FaultCode::TickRate.bit();

#[derive(Clone, Debug)]
pub struct Machine {
    state: MachineState,
    cfg: BoardConfig,
    config_set: bool,
    limits: SoftLimits,
    /// `limits` in the frame of `raw` (minus `offset`): what the per-step check compares.
    raw_limits: SoftLimits,
    latch: FaultLatch,
    /// Fault causes present now (levels: e-stop, switches, sensors, link, missing config).
    active: u32,
    outputs: Outputs,
    /// Steps that reached the pins since boot, per axis.
    raw: [i64; MAX_AXES],
    /// Machine position = raw + offset; set by homing.
    offset: [i64; MAX_AXES],
    homed: bool,
    /// Machine position after every admitted segment.
    planned_end: [i64; MAX_AXES],
    admitted: u32,
    done_base: u32,
    underruns_base: u32,
    last_exit_nonzero: bool,
    /// The DDA is not ticked (immediate stop) until the background aborts it.
    frozen: bool,
    abort_pending: bool,
    hold_pending: bool,
    homing: Homing,
    /// Moving off a tripped limit switch (in `Fault`).
    jog: Option<JogOff>,
    /// The limit switches (min, max) as the last tick read them.
    switches: (u8, u8),
    last_dir: u8,
    ticks: u64,
    /// Ticks until the job bookkeeping runs again (every [`JOB_WATCH_TICKS`]).
    job_watch_in: u8,
    /// Items (step events, a source's own segments) were admitted for a source job that has
    /// not ended.
    source_queued: bool,
    /// A source job runs (or holds): the tick's source is its owner's (the tag says whose), and
    /// the job ends when the source is idle.
    source: Option<SourceJob>,
    /// A hold is in force (feed hold, or a hold reaction): sources with a clock stop it.
    paused: bool,
    /// The host was late: the machine holds on the path until the next segment is admitted,
    /// then resumes by itself (a sender's pause is not a fault).
    starved: bool,
    /// The starved job's successor arrived: resume on this tick.
    resume_pending: bool,
    /// Times a late host made the machine hold (modular, compare with `wrapping_sub`).
    starve_holds: u32,
    /// Commanded (the step counters) against measured, for axes with feedback.
    following: FollowingMonitor,
    tick_overruns: u32,
    /// Debounces the limit switches and the e-stop for the fault checks and jog-off, and the
    /// probe for probe moves.
    switch_filter: SwitchFilter,
    /// Step-only ticks left before the next full tick ([`Machine::fast_tick`]); 0 after any
    /// command, fault or state change.
    fast_left: u8,
    /// Steps of the step-only ticks since the last full tick, not yet in `raw`.
    pending: pending::PendingSteps,
    /// Ticks from `room_since` in which every axis stays inside its soft limits at one step a
    /// tick (`pending::room`); 0 when the limits change or are not armed.
    limit_room: u64,
    room_since: u64,
    /// Ticks from one full tick to the next while quiet, at the config's tick rate.
    supervise_ticks: u8,
    /// The board runs full ticks on every this many ticks at most ([`Machine::held_tick`]
    /// between them): the input filter counts its samples at that rate.
    sample_stride: u8,
    /// The probe move (G38.x): armed, watched, its result.
    probe: ProbeRun,
}

impl Default for Machine {
    fn default() -> Self {
        Self::new()
    }
}

impl Machine {
    /// In `Boot`, with the safe default config until [`Machine::boot`].
    pub fn new() -> Self {
        let cfg = BoardConfig::safe_default();
        Machine {
            state: MachineState::Boot,
            limits: SoftLimits::from_scale(&cfg.link.scale, cfg.link.machine.axis_count),
            raw_limits: SoftLimits::from_scale(&cfg.link.scale, cfg.link.machine.axis_count),
            cfg,
            config_set: false,
            latch: FaultLatch::new(),
            active: 0,
            outputs: Outputs::SAFE,
            raw: [0; MAX_AXES],
            offset: [0; MAX_AXES],
            homed: false,
            planned_end: [0; MAX_AXES],
            admitted: 0,
            done_base: 0,
            underruns_base: 0,
            last_exit_nonzero: false,
            frozen: false,
            abort_pending: false,
            hold_pending: false,
            homing: Homing::idle(),
            jog: None,
            switches: (0, 0),
            last_dir: 0,
            ticks: 0,
            job_watch_in: 1,
            source_queued: false,
            source: None,
            paused: false,
            starved: false,
            resume_pending: false,
            starve_holds: 0,
            following: FollowingMonitor::new(),
            tick_overruns: 0,
            switch_filter: SwitchFilter::new(
                cfg.link.inputs.debounce_ticks(cfg.link.machine.tick_hz),
            ),
            fast_left: 0,
            pending: pending::PendingSteps::new(),
            limit_room: 0,
            room_since: 0,
            supervise_ticks: fast::supervise_ticks(cfg.link.machine.tick_hz),
            sample_stride: 1,
            probe: ProbeRun::new(),
        }
    }

    /// Leaves `Boot` with the config loaded from flash: a valid one -> `Idle`; missing -> safe
    /// defaults and `ConfigMissing`, corrupt or invalid -> safe defaults and `ConfigCorrupt`
    /// (`Fault` either way). Build the DDA and preparer from
    /// [`Machine::config`] afterwards. Outside `Boot` it changes nothing.
    pub fn boot(&mut self, loaded: Result<BoardConfig, BootConfig>) -> MachineState {
        self.boot_after_reset(loaded, ResetCause::Unknown)
    }

    /// [`Machine::boot`] after a reset of cause `reset` (the board decodes RCC_CSR with
    /// [`ResetCause::from_rcc_csr`]): after a watchdog reset the machine latches
    /// `WatchdogReset` first (so it is the first fault), then loads the config as `boot` does,
    /// and stays in `Fault` until `ClearFault` (then `Idle`: never homed after a reset).
    pub fn boot_after_reset(
        &mut self,
        loaded: Result<BoardConfig, BootConfig>,
        reset: ResetCause,
    ) -> MachineState {
        if self.state != MachineState::Boot {
            return self.state;
        }
        if reset.is_watchdog() {
            // Boot -> Fault; the `Idle` below is then not an allowed event and is skipped.
            self.raise(FaultCode::WatchdogReset);
        }
        match loaded.and_then(|c| c.validate().map(|_| c).map_err(BootConfig::Invalid)) {
            Ok(cfg) => {
                self.install(cfg);
                self.enter(MachineState::Idle);
            }
            Err(why) => {
                self.install(BoardConfig::safe_default());
                self.config_set = false;
                let code = why.fault();
                self.active |= code.bit();
                self.raise(code);
            }
        }
        self.state
    }

    /// The input filter's debounce in samples: one per full tick, which comes at most every
    /// `sample_stride` ticks while inputs change.
    fn set_filter_ticks(&mut self, cfg: &BoardConfig) {
        let sample_hz = cfg.link.machine.tick_hz / self.sample_stride as u32;
        self.switch_filter.set_ticks(cfg.link.inputs.debounce_ticks(sample_hz));
    }

    fn install(&mut self, cfg: BoardConfig) {
        self.limits = SoftLimits::from_scale(&cfg.link.scale, cfg.link.machine.axis_count);
        self.raw_limits = self.limits.minus(&self.offset);
        self.limit_room = 0;
        self.set_filter_ticks(&cfg);
        self.supervise_ticks = fast::supervise_ticks(cfg.link.machine.tick_hz);
        self.cfg = cfg;
        self.config_set = true;
        self.active &= !CONFIG_FAULTS;
    }

    pub fn state(&self) -> MachineState {
        self.state
    }

    /// The state as the link reports it.
    pub fn link_state(&self, dda: &Dda) -> LinkState {
        match self.state {
            MachineState::Fault => LinkState::Faulted,
            MachineState::Boot | MachineState::Idle | MachineState::Ready => LinkState::Idle,
            _ => dda.state().into(),
        }
    }

    pub fn config(&self) -> &BoardConfig {
        &self.cfg
    }

    pub fn faults(&self) -> &FaultLatch {
        &self.latch
    }

    /// Fault causes present now (`FaultCode::bit()`s).
    pub fn active_causes(&self) -> u32 {
        self.active
    }

    /// Machine positions (steps on the pins since boot plus the homing offset).
    pub fn positions(&self) -> [i64; MAX_AXES] {
        let mut p = self.raw_positions();
        for i in 0..MAX_AXES {
            p[i] = p[i].saturating_add(self.offset[i]);
        }
        p
    }

    /// Steps that reached the pins since boot, per axis (no offset), the step-only ticks' too.
    pub fn raw_positions(&self) -> [i64; MAX_AXES] {
        let mut p = self.raw;
        for (p, n) in p.iter_mut().zip(self.pending.net()) {
            *p += n;
        }
        p
    }

    /// Machine position after every admitted segment (what `Queue` checks against).
    pub fn planned_end(&self) -> [i64; MAX_AXES] {
        self.planned_end
    }

    pub fn is_homed(&self) -> bool {
        self.homed
    }

    pub fn homing(&self) -> &Homing {
        &self.homing
    }

    /// The probe move: armed, running, or the last one's result and latched position.
    pub fn probe(&self) -> &ProbeRun {
        &self.probe
    }

    /// True once after a tripped probe move stopped: the caller drops the segments of the move
    /// it still holds (its link queue) before it feeds again.
    pub fn take_probe_discard(&mut self) -> bool {
        self.probe.take_discard()
    }

    /// The probe input, debounced.
    pub fn probe_input(&self) -> bool {
        self.switch_filter.probe_level()
    }

    /// Marks the next `Start` as a probe move of `kind`: `Ready`, nothing admitted, no source
    /// job. The queued segments then run as the probe move (see [`super::probe`]).
    pub fn arm_probe(&mut self, kind: ProbeKind, dda: &Dda) -> Result<(), Refusal> {
        let busy = self.in_flight(dda) != 0 || self.source_queued || self.source.is_some();
        if self.state != MachineState::Ready || busy || !dda.is_idle() {
            return Err(Refusal::OutOfState(self.state));
        }
        self.probe.arm(kind);
        Ok(())
    }

    /// A `JogOff` move is under way.
    pub fn is_jogging(&self) -> bool {
        self.jog.is_some()
    }

    pub fn outputs(&self) -> Outputs {
        self.outputs
    }

    /// Sets the spindle, wire and Z outputs; refused (false, nothing changes) while an e-stop is
    /// latched or pressed.
    pub fn set_outputs(&mut self, o: Outputs) -> bool {
        if self.latch.has(FaultCode::EStop) || self.active & FaultCode::EStop.bit() != 0 {
            return false;
        }
        self.outputs = o;
        // The board writes outputs on full ticks only.
        self.fast_left = 0;
        true
    }

    /// The feeder may move admitted segments into the DDA (a job runs or holds).
    pub fn may_feed(&self) -> bool {
        matches!(self.state, MachineState::Running | MachineState::Holding) && !self.frozen
    }

    /// The source job that was started and has not ended, if any: tick with its owner's source.
    #[inline(always)]
    pub fn source_job(&self) -> Option<SourceJob> {
        self.source
    }

    /// Source job `job` was started and has not ended.
    #[inline(always)]
    pub fn runs(&self, job: SourceJob) -> bool {
        self.source == Some(job)
    }

    /// Items were admitted for a source job (queued or playing) and the job has not ended.
    pub fn source_queued(&self) -> bool {
        self.source_queued
    }

    /// Ticks seen.
    /// Ticks that overran their period since boot (modular u32).
    pub fn tick_overruns(&self) -> u32 {
        self.tick_overruns
    }

    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// Times a late host made a segment job hold on the path until its next segment came
    /// (modular).
    pub fn starve_holds(&self) -> u32 {
        self.starve_holds
    }

    /// A segment job holds because the host has not sent the next segment yet.
    pub fn is_starved(&self) -> bool {
        self.starved
    }

    /// One tick (interrupt rate): fault inputs, then the DDA tick unless an immediate stop froze
    /// it, then the step counters, the run-time soft-limit check, homing and job bookkeeping.
    /// Integer compares and adds only; no division, bounded (a few loops over the 6 axes or the
    /// 17 fault codes, the latter only while a sensor fault bit is set).
    #[inline]
    pub fn tick(&mut self, dda: &mut Dda, inp: &Inputs) -> TickOut {
        self.tick_with(dda, inp, &mut DdaSource)
    }

    /// [`Machine::tick`] with the steps from `source` (a source job's): the same
    /// inputs, freeze, counters, soft limits and job bookkeeping; a source job ends when the
    /// source is idle and raises `QueueUnderrun` when it starves.
    #[inline]
    pub fn tick_with(
        &mut self,
        dda: &mut Dda,
        inp: &Inputs,
        source: &mut impl StepSource,
    ) -> TickOut {
        self.ticks += 1;
        self.pending.fold_into(&mut self.raw);
        // Faults and jog-off see debounced switches; homing latches on the raw edge.
        let raw = inp;
        let inp = &self.switch_filter.filter(raw);
        self.watch_inputs(dda, inp);
        self.apply_hold(dda);
        if self.frozen {
            // No edge this tick; DIR stays; a STEP high from the last tick stays high a little
            // longer (longer pulses are harmless).
            return TickOut {
                step: StepOutput::new(0, 0, self.last_dir, 0),
                outputs: self.outputs,
            };
        }
        let step = source.tick(dda, self.paused);
        self.last_dir = step.dir();
        if step.rise() != 0 {
            self.count(step);
        }
        if self.probe.watching() {
            self.watch_probe(dda, inp.probe);
        }
        match self.state {
            MachineState::Homing => self.watch_homing(dda, raw),
            MachineState::Running if self.source.is_some() => self.watch_source(dda, source),
            MachineState::Running => {
                // The bookkeeping looks ahead by more than these ticks (the starve margin), so
                // a divided rate loses nothing but a few ticks of latency at the job's end. A
                // starved job resumes on the tick its successor arrives.
                self.job_watch_in = self.job_watch_in.wrapping_sub(1);
                if self.job_watch_in == 0 || self.starved {
                    self.job_watch_in = JOB_WATCH_TICKS;
                    self.watch_job(dda);
                }
            }
            MachineState::Fault if self.jog.is_some() => self.watch_jog(dda, inp),
            _ => {}
        }
        self.apply_hold(dda);
        self.arm_fast(raw, source);
        TickOut { step, outputs: self.outputs }
    }

    /// The following-error check (interrupt rate, after [`Machine::tick`] / `tick_with`, once
    /// per tick on boards with feedback): `measured_steps` is each axis's measured position in
    /// the frame of [`Machine::raw_positions`] (the board converts encoder counts to steps with
    /// a factor precomputed at setup), compared with the raw step counters. Axes whose
    /// `BoardConfig::following` limit is 0 are not checked. An error over the limit for the
    /// configured debounce latches `FollowingError` (immediate stop, position kept; homing is
    /// lost when it is cleared). True when it tripped now. Six subtracts and compares, no
    /// division.
    #[inline]
    pub fn feedback(&mut self, measured_steps: &[i64; MAX_AXES]) -> bool {
        if self.state == MachineState::Boot {
            return false;
        }
        let raw = self.raw_positions();
        let cfg = &self.cfg.following;
        match self.following.check(cfg, &raw, measured_steps) {
            Some(_) => {
                self.raise(FaultCode::FollowingError);
                true
            }
            None => false,
        }
    }

    /// Largest following error per axis since boot, the last `SetConfig` or the last clear of a
    /// following error, steps.
    pub fn following_worst_steps(&self) -> [u32; MAX_AXES] {
        self.following.worst_steps()
    }

    /// A fault the board found outside the tick (a peripheral that refused its setup, a
    /// segment the DDA refused, a panic before the last reset): latched with its class's
    /// reaction, as if the machine had found it.
    pub fn board_fault(&mut self, code: FaultCode) {
        self.raise(code);
    }

    /// Latches `code`; a new fault gets its class's reaction and the machine goes to `Fault`.
    fn raise(&mut self, code: FaultCode) {
        self.fast_left = 0;
        if !self.latch.raise(code) {
            return;
        }
        match reaction(code) {
            Reaction::Kill => {
                self.freeze();
                self.outputs = Outputs::SAFE;
                self.homed = false;
            }
            Reaction::Stop => self.freeze(),
            Reaction::Hold => self.hold_pending = true,
        }
        self.starved = false;
        self.homing.cancel();
        self.probe.drop_move();
        self.enter(MachineState::Fault);
    }

    #[inline]
    fn apply_hold(&mut self, dda: &mut Dda) {
        if self.hold_pending {
            // A hold (a fault's reaction) wins over a starved job's resume.
            self.hold_pending = false;
            self.resume_pending = false;
            self.paused = true;
            dda.apply(Command::Hold);
        } else if self.resume_pending {
            self.resume_pending = false;
            self.paused = false;
            dda.apply(Command::Resume);
        }
    }

    /// Immediate stop: the DDA is not ticked again until the background has aborted it.
    fn freeze(&mut self) {
        self.frozen = true;
        self.abort_pending = true;
    }

    /// Event transitions, only along the documented edges.
    fn enter(&mut self, to: MachineState) {
        if event_allowed(self.state, to) {
            self.state = to;
        }
    }

    /// Planning-rate work is due: an abort after an immediate stop, or a homing move to plan.
    pub fn wants_background(&self) -> bool {
        self.abort_pending
            || (self.state == MachineState::Homing && self.homing.needs_move())
            || self.jog.is_some_and(|j| j.needs_move())
    }

    /// The feeder has nothing to do until the DDA takes a segment: its ready queue is full and
    /// no background work is due. An abort is due with the queue full (a stop drops a queue
    /// the frozen DDA no longer runs): the feeder must still run [`Machine::background`], or
    /// the machine would wait for ever with its queue counted in flight.
    pub fn feeder_blocked(&self, dda: &Dda) -> bool {
        dda.ready_free() == 0 && !self.wants_background()
    }

    /// The planning-rate work (control task; divides): aborts a frozen DDA, then plans and
    /// queues the next homing move. A homing move the planner or DDA refuses raises
    /// `HomingFailed` (the config was validated, so it does not happen with a valid one).
    pub fn background(&mut self, dda: &mut Dda, prep: &mut Preparer) {
        if self.abort_pending {
            self.fast_left = 0;
            dda.abort();
            prep.reset_junction();
            self.abort_pending = false;
            self.frozen = false;
            self.hold_pending = false;
            self.planned_end = self.positions();
            self.admitted = 0;
            self.done_base = dda.segments_done();
            self.underruns_base = dda.underruns();
            self.last_exit_nonzero = false;
            // The caller dropped the items it held (Abort, ClearFault, SetConfig, Home).
            self.source_queued = false;
            self.source = None;
            self.paused = false;
            self.starved = false;
            self.resume_pending = false;
        }
        let mv = match (self.state, &mut self.jog) {
            (MachineState::Homing, _) => self.homing.take_move(),
            (MachineState::Fault, Some(jog)) => jog.take_move(&self.cfg),
            _ => None,
        };
        let Some(mv) = mv else { return };
        self.fast_left = 0;
        let mut planner = Planner::new(&self.cfg.link.machine);
        let mut ok = planner.push(&mv).is_ok();
        planner.finish();
        while ok {
            let Some(seg) = planner.pop() else { break };
            ok = match prep.prepare(&seg) {
                Ok(p) => dda.push(&p).is_ok(),
                Err(_) => false,
            };
        }
        if !ok && self.state == MachineState::Homing {
            self.raise(FaultCode::HomingFailed);
        } else if !ok {
            // A jog move the planner refuses: nothing moves; the operator sees the jog end.
            self.jog = None;
            self.freeze();
        }
    }
}
