//! The fault suite's scenario: the sim board that injects the case's cause and the host that
//! feeds, homes, jogs and clears around it, driving the machine as the firmware's tasks do.

use super::board::config;
use super::case::Case;
use super::{
    BEYOND, FOLLOWING_LIMIT_STEPS, INJECT_TICK, INSIDE, LONG_X, MAX_TICKS, NOISE_BURSTS,
    NOISE_OFF_TICKS, NOISE_ON_TICKS, PLANT_LAG_TICKS, POLAR_START_R_STEPS, POLAR_START_THETA_STEPS,
    ROGUE_X_STEPS, SETTLE_TICKS, STARVED_TICKS, STREAM, SWITCH_MAX, SWITCH_MIN, TO_X_MAX, TO_X_MIN,
    TO_Y_MAX, TO_Y_MIN,
};
use crate::config::MAX_AXES;
use crate::dda::{Dda, Preparer};
use crate::machine::persist::{ConfigStore, LoadError};
use crate::machine::ram_flash::RamFlash;
use crate::machine::{
    Inputs, Machine, MachineCommand, MachineState, Outputs, OverrunDetector, Refusal,
};
use crate::planner::{Move, Planner};
use crate::protocol::FaultCode;
use crate::scenario::{Scenario, ScenarioReport, TraceHash};
use crate::segment::Segment;
use crate::trace::StepRecorder;

/// The flash the config-missing case boots from: erased, as QEMU's read-only flash reads.
type SimFlash = RamFlash<2048, 1024>;

pub struct FaultScenario {
    case: Case,
    // The tests reach into the machine and the DDA (a changed config, a refused command).
    pub(super) machine: Machine,
    pub(super) dda: Dda,
    prep: Preparer,
    planner: Planner,
    moves: &'static [Move],
    next_move: usize,
    planning_done: bool,
    /// Segments the feeder hands over before it stalls (the starved case).
    feed_limit: u32,
    /// Ticks the starved case has stood held; the feeder carries on after `STARVED_TICKS`.
    held_ticks: u32,
    /// Net X steps when the starved case first stood still.
    held_at0_steps: i64,
    fed: u32,
    home_sent: bool,
    started: bool,
    rogue_pushed: bool,
    beyond_tried: bool,
    refusal: Option<Refusal>,
    clear_refused: Option<Refusal>,
    jog_sent: bool,
    /// The fault a successful ClearFault unlatched.
    cleared: Option<FaultCode>,
    home_refused: bool,
    overrun: OverrunDetector,
    overrun_flag: bool,
    /// Sim plant: where the axes are, in sim steps from the start point.
    start_phys: [i64; MAX_AXES],
    rec: StepRecorder,
    /// Net steps of the last `PLANT_LAG_TICKS` ticks (the plant's lagging position).
    plant_ring: [[i64; 2]; PLANT_LAG_TICKS],
    /// The sim plant's measured position (following-error case), steps from the start point.
    measured: [i64; MAX_AXES],
    /// The tick the X error first exceeded the limit.
    over_tick: u64,
    hash: TraceHash,
    t: u64,
    fault_tick: u64,
    steps_after_fault: u64,
    settled: u32,
    done: bool,
}

impl FaultScenario {
    pub fn new(case: Case) -> Option<Self> {
        let mut machine = Machine::new();
        let loaded = if case == Case::ConfigMissing {
            let mut store = ConfigStore::new(SimFlash::new(), 0, 1024).ok()?;
            store.load().map_err(LoadError::boot)
        } else {
            Ok(config(case))
        };
        machine.boot(loaded);
        let cfg = machine.config().link.machine;
        let moves: &'static [Move] = match case {
            Case::EStop
            | Case::LinkLoss
            | Case::TickOverrun
            | Case::Sensor(_)
            | Case::FollowingError
            | Case::LimitNoise => &LONG_X,
            Case::LimitMin(0) | Case::LimitJogOff => &TO_X_MIN,
            Case::LimitMax(0) => &TO_X_MAX,
            Case::LimitMin(_) => &TO_Y_MIN,
            Case::LimitMax(_) => &TO_Y_MAX,
            Case::SoftLimitQueue | Case::SoftLimitRun => &INSIDE,
            Case::QueueStarved => &STREAM,
            Case::HomingOk | Case::HomingNotFound | Case::ConfigMissing | Case::HomingPolar => &[],
        };
        let start_phys = match case {
            Case::HomingOk => [-2_000, 2_200, 0, 0, 0, 0],
            // The arm part-way round, the carriage part-way out (steps from the homes).
            Case::HomingPolar => [POLAR_START_THETA_STEPS, POLAR_START_R_STEPS, 0, 0, 0, 0],
            _ => [0; MAX_AXES],
        };
        let mut s = FaultScenario {
            case,
            dda: Dda::new(&cfg).ok()?,
            prep: Preparer::new(&cfg).ok()?,
            planner: Planner::new(&cfg),
            machine,
            moves,
            next_move: 0,
            planning_done: moves.is_empty(),
            feed_limit: if case == Case::QueueStarved { 2 } else { u32::MAX },
            fed: 0,
            held_ticks: 0,
            held_at0_steps: 0,
            home_sent: false,
            started: false,
            rogue_pushed: false,
            beyond_tried: false,
            refusal: None,
            clear_refused: None,
            jog_sent: false,
            cleared: None,
            home_refused: false,
            overrun: OverrunDetector::new(),
            overrun_flag: false,
            start_phys,
            rec: StepRecorder::new(),
            plant_ring: [[0; 2]; PLANT_LAG_TICKS],
            measured: [0; MAX_AXES],
            over_tick: 0,
            hash: TraceHash::new(),
            t: 0,
            fault_tick: 0,
            steps_after_fault: 0,
            settled: 0,
            done: false,
        };
        if case == Case::ConfigMissing {
            // Motion before a config: refused, nothing changes.
            let home = s.machine.command(MachineCommand::Home, &mut s.dda);
            s.home_refused = home.is_err();
        }
        // Outputs a running cut would have on, so the e-stop's switch-off shows.
        s.machine.set_outputs(Outputs {
            spindle_enable: true,
            spindle_ccw: true,
            mist: true,
            flood: true,
            wire_power: true,
            z_dac: 3_000,
        });
        Some(s)
    }

    fn phys(&self, axis: usize) -> i64 {
        self.start_phys[axis] + self.rec.net[axis]
    }

    /// Where axis `a`'s (min, max) switches close, sim steps. The polar machine: the arm's
    /// right end-stop and the carriage's minimum-radius switch at its home (0), the far ends
    /// of the work area beyond.
    fn switch_at(&self, a: usize) -> (i64, i64) {
        match self.case {
            Case::HomingPolar => {
                (0, [crate::polar::job::THETA_SPAN_STEPS, crate::polar::job::R_SPAN_STEPS][a & 1])
            }
            _ => (SWITCH_MIN, SWITCH_MAX),
        }
    }

    /// The sim board's inputs this tick.
    fn inputs(&mut self) -> Inputs {
        let mut inp = Inputs::QUIET;
        for a in 0..2 {
            let (min_at, max_at) = self.switch_at(a);
            if self.phys(a) <= min_at {
                inp.limit_min |= 1 << a;
            }
            if self.phys(a) >= max_at {
                inp.limit_max |= 1 << a;
            }
        }
        let injected = self.t >= INJECT_TICK;
        if self.case == Case::LimitNoise && injected {
            let since = self.t - INJECT_TICK;
            let period = NOISE_ON_TICKS + NOISE_OFF_TICKS;
            if since < NOISE_BURSTS * period && since % period < NOISE_ON_TICKS {
                inp.limit_max |= 1;
            }
        }
        match self.case {
            Case::EStop => inp.estop = injected,
            Case::LinkLoss => inp.link_ok = !injected,
            Case::Sensor(code) if injected => inp.sensor_faults = code.bit(),
            _ => {}
        }
        inp.tick_overrun = self.overrun_flag;
        inp
    }

    fn has_more_to_feed(&self) -> bool {
        self.fed < self.feed_limit && !self.planning_done
    }

    fn wants_feed(&self) -> bool {
        if self.done {
            return false;
        }
        match self.machine.state() {
            MachineState::Idle => !self.home_sent,
            MachineState::Ready => {
                (!self.started && self.has_more_to_feed())
                    || (self.case == Case::SoftLimitQueue && self.started && !self.beyond_tried)
            }
            MachineState::Running | MachineState::Holding => {
                self.dda.ready_free() > 0
                    && (self.has_more_to_feed()
                        || (self.case == Case::SoftLimitRun && !self.rogue_pushed))
            }
            MachineState::Fault if self.case == Case::LimitJogOff => {
                let at_rest = self.dda.is_idle() && !self.machine.wants_background();
                at_rest
                    && !self.machine.is_jogging()
                    && (!self.jog_sent || self.machine.active_causes() == 0)
            }
            _ => false,
        }
    }

    /// The operator after a limit trip: ClearFault first (refused: the switch is closed), then
    /// JogOff, then ClearFault once the switch has opened.
    fn recover_from_limit(&mut self) {
        if !self.jog_sent {
            self.clear_refused =
                self.machine.command(MachineCommand::ClearFault, &mut self.dda).err();
            self.jog_sent = true;
            if let Err(r) = self.machine.command(MachineCommand::JogOff, &mut self.dda) {
                self.refusal = Some(r);
                self.done = true;
            }
            return;
        }
        let first = self.machine.faults().first();
        match self.machine.command(MachineCommand::ClearFault, &mut self.dda) {
            Ok(_) => self.cleared = first,
            Err(r) => {
                self.refusal = Some(r);
                self.done = true;
            }
        }
    }

    /// The next planned segment of the job, if the planner has one final.
    fn next_segment(&mut self) -> Option<Segment> {
        loop {
            if let Some(seg) = self.planner.pop() {
                return Some(seg);
            }
            let Some(m) = self.moves.get(self.next_move) else {
                self.planning_done = true;
                return None;
            };
            if self.planner.push(m).is_err() {
                self.planning_done = true;
                return None;
            }
            self.next_move += 1;
            if self.next_move == self.moves.len() {
                self.planner.finish();
            }
        }
    }

    /// The control task's work: homing command, admitting and feeding segments, starting.
    fn feed(&mut self) {
        match self.machine.state() {
            MachineState::Fault if self.case == Case::LimitJogOff => self.recover_from_limit(),
            MachineState::Idle => {
                self.home_sent = true;
                let _ = self.machine.command(MachineCommand::Home, &mut self.dda);
            }
            MachineState::Ready if self.started => {
                self.beyond_tried = true;
                let mut p = Planner::new(&self.machine.config().link.machine);
                let seg = p.push(&BEYOND).ok().and_then(|_| {
                    p.finish();
                    p.pop()
                });
                if let Some(seg) = seg {
                    let r = self.machine.command(MachineCommand::Queue(&seg), &mut self.dda);
                    self.refusal = r.err();
                }
            }
            _ => {
                while self.dda.ready_free() > 0 && self.has_more_to_feed() {
                    let Some(seg) = self.next_segment() else { break };
                    if let Err(r) = self.machine.command(MachineCommand::Queue(&seg), &mut self.dda)
                    {
                        self.refusal = Some(r);
                        self.planning_done = true;
                        break;
                    }
                    match self.prep.prepare(&seg) {
                        Ok(p) => {
                            let _ = self.dda.push(&p);
                        }
                        Err(_) => self.planning_done = true,
                    }
                    self.fed += 1;
                }
                if self.case == Case::SoftLimitRun
                    && self.started
                    && !self.has_more_to_feed()
                    && !self.rogue_pushed
                    && self.dda.ready_free() > 0
                {
                    self.rogue_pushed = true;
                    let rogue = Segment {
                        steps: [ROGUE_X_STEPS, 0, 0, 0, 0, 0],
                        duration_ticks: 25_000,
                        entry_rate: crate::segment::Rate::ZERO,
                        exit_rate: crate::segment::Rate::ZERO,
                        accel_per_tick: crate::segment::Rate::from_bits(1 << 18),
                        id: 0xbad,
                    };
                    if let Ok(p) = self.prep.prepare(&rogue) {
                        let _ = self.dda.push(&p);
                    }
                }
                if self.machine.state() == MachineState::Ready && !self.started {
                    self.started = true;
                    let _ = self.machine.command(MachineCommand::Start, &mut self.dda);
                }
            }
        }
    }

    /// Everything has come to rest in the case's final state.
    fn settled_now(&self) -> bool {
        let state = self.machine.state();
        let at_rest = self.dda.is_idle()
            || self.dda.state() == crate::dda::MotionState::Held
            || state == MachineState::Fault && self.dda.rate().to_bits() == 0;
        let final_state = match self.case {
            Case::HomingOk | Case::HomingPolar => {
                state == MachineState::Ready && self.machine.is_homed()
            }
            Case::LimitJogOff => state == MachineState::Ready && self.cleared.is_some(),
            Case::SoftLimitQueue => self.beyond_tried,
            Case::QueueStarved => state == MachineState::Ready && self.fed > 2,
            Case::LimitNoise => state == MachineState::Ready && self.started,
            _ => state == MachineState::Fault,
        };
        final_state && at_rest && !self.machine.wants_background() && !self.wants_feed()
    }

    /// The following-error case's plant after this tick's steps: it stands where the steps put
    /// it `PLANT_LAG_TICKS` ago (a drive that lags), except that X jams at `INJECT_TICK`.
    fn plant(&mut self) {
        let slot = (self.t as usize) % PLANT_LAG_TICKS;
        let lagged = self.plant_ring[slot];
        self.plant_ring[slot] = [self.rec.net[0], self.rec.net[1]];
        if self.t < INJECT_TICK {
            self.measured[0] = lagged[0];
        }
        self.measured[1] = lagged[1];
    }

    /// Attempts a `ClearFault` while a level cause is still present: the table says refused.
    fn try_clear_while_active(&mut self) {
        let level = matches!(
            self.case,
            Case::EStop
                | Case::LimitMin(_)
                | Case::LimitMax(_)
                | Case::LinkLoss
                | Case::ConfigMissing
                | Case::Sensor(_)
        );
        if level && self.machine.active_causes() != 0 {
            self.clear_refused =
                self.machine.command(MachineCommand::ClearFault, &mut self.dda).err();
        }
    }
}

impl Scenario for FaultScenario {
    fn name(&self) -> &'static str {
        self.case.name()
    }

    /// The case's machine's rate: `TICK_HZ`, except the polar machine's.
    fn tick_hz(&self) -> u32 {
        self.machine.config().link.machine.tick_hz
    }

    fn wants_background(&self) -> bool {
        self.machine.wants_background() || self.wants_feed()
    }

    /// Aborts, homing moves, planning, preparing and admitting: all divide, none in the tick.
    fn background(&mut self) {
        if self.machine.wants_background() {
            self.machine.background(&mut self.dda, &mut self.prep);
            return;
        }
        self.feed();
    }

    fn tick(&mut self) -> bool {
        if self.done {
            return false;
        }
        if self.t >= MAX_TICKS || self.settled >= SETTLE_TICKS {
            self.try_clear_while_active();
            self.done = true;
            return false;
        }
        self.t += 1;
        let inp = self.inputs();
        let was_fault = self.machine.state() == MachineState::Fault;
        let out = self.machine.tick(&mut self.dda, &inp);
        // The sim timer: the tick after INJECT_TICK finds its update flag pending.
        self.overrun_flag =
            self.overrun.after_tick(self.case == Case::TickOverrun && self.t == INJECT_TICK);
        if self.case == Case::FollowingError {
            self.plant();
            self.machine.feedback(&self.measured);
            let err = self.machine.raw_positions()[0] - self.measured[0];
            if self.over_tick == 0 && err > FOLLOWING_LIMIT_STEPS as i64 {
                self.over_tick = self.t;
            }
        }
        if !was_fault && self.machine.state() == MachineState::Fault {
            self.fault_tick = self.t;
        }
        if self.case == Case::QueueStarved
            && self.machine.state() == MachineState::Running
            && self.dda.state() == crate::dda::MotionState::Held
        {
            if self.held_ticks == 0 {
                self.held_at0_steps = self.rec.net[0];
            }
            self.held_ticks += 1;
            if self.held_ticks >= STARVED_TICKS {
                self.feed_limit = u32::MAX;
            }
        }
        if self.fault_tick != 0 && self.fault_tick != self.t {
            self.steps_after_fault += out.step.rise().count_ones() as u64;
        }
        self.rec.record(self.t, &out.step);
        self.hash.u32(out.step.rise() as u32 | (out.step.dir() as u32) << 8);
        self.hash.u32(self.machine.state() as u32 | self.machine.faults().mask() << 8);
        if self.settled_now() {
            self.settled += 1;
        } else {
            self.settled = 0;
        }
        true
    }

    fn report(&self) -> ScenarioReport {
        let fault = match (self.machine.faults().first().or(self.cleared), self.refusal) {
            (Some(f), _) => f.code(),
            (None, Some(Refusal::SoftLimit { .. })) => FaultCode::SoftLimit.code(),
            _ => 0,
        };
        let mut r = ScenarioReport::new(self.name(), self.t, self.hash.value(), fault);
        let pos = self.machine.positions();
        let raw = self.machine.raw_positions();
        let dda = self.dda.positions();
        r.push("state", self.machine.state() as i64);
        r.push("fault_mask", self.machine.faults().mask() as i64);
        r.push("pos0_steps", pos[0]);
        r.push("pos1_steps", pos[1]);
        r.push("raw0_steps", raw[0]);
        r.push("raw1_steps", raw[1]);
        r.push("dda0_steps", dda[0]);
        r.push("dda1_steps", dda[1]);
        r.push("net0_steps", self.rec.net[0]);
        r.push("net1_steps", self.rec.net[1]);
        r.push("phys0_steps", self.phys(0));
        r.push("phys1_steps", self.phys(1));
        r.push("fault_tick", self.fault_tick as i64);
        r.push("steps_after_fault", self.steps_after_fault as i64);
        r.push("segments", self.dda.segments_done() as i64);
        r.push("dda_underruns", self.dda.underruns() as i64);
        let o = self.machine.outputs();
        r.push("spindle", o.spindle_enable as i64);
        r.push("wire_power", o.wire_power as i64);
        r.push("z_dac", o.z_dac as i64);
        r.push("refusal_nak", self.refusal.map_or(0, |x| x.error_code().code() as i64));
        r.push("clear_refused_nak", self.clear_refused.map_or(0, |x| x.error_code().code() as i64));
        r.push("home_refused", self.home_refused as i64);
        r.push("jog_sent", self.jog_sent as i64);
        r.push("cleared", self.cleared.map_or(0, |f| f.code() as i64));
        r.push("homed", self.machine.is_homed() as i64);
        if self.case == Case::EStop {
            let exact = (0..MAX_AXES).all(|a| raw[a] == dda[a] && raw[a] == self.rec.net[a]);
            r.push("counters_exact", exact as i64);
        }
        if self.case == Case::QueueStarved {
            r.push("starve_holds", self.machine.starve_holds() as i64);
            r.push("held_at0_steps", self.held_at0_steps);
            r.push("held_ticks", self.held_ticks as i64);
        }
        if self.case == Case::FollowingError {
            r.push("measured0_steps", self.measured[0]);
            r.push("measured1_steps", self.measured[1]);
            r.push("following_worst0_steps", self.machine.following_worst_steps()[0] as i64);
            r.push("over_tick", self.over_tick as i64);
        }
        r
    }
}
