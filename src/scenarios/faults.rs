//! The fault suite: one scenario per fault cause, with a sim board that injects it. Each drives
//! [`Machine`] around the real DDA exactly as the firmware's tick and control tasks do (tick:
//! `Machine::tick`; planning, preparing and aborting: `Scenario::background`), ends in the
//! documented state with its fault code, and reports the machine's position counters next to the
//! DDA's positions and the `StepRecorder`'s net steps, so their equality is visible in QEMU's
//! report as well as the host's.

use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::dda::{Dda, Preparer};
use crate::machine::persist::{ConfigStore, LoadError};
use crate::machine::ram_flash::RamFlash;
use crate::machine::{
    BoardConfig, FollowingConfig, HomeAxis, Inputs, Machine, MachineCommand, MachineState, Outputs,
    OverrunDetector, Refusal,
};
use crate::planner::{Move, Planner};
use crate::protocol::{AxisScale, FaultCode, WireConfig};
use crate::scenario::{Scenario, ScenarioReport, TraceHash};
use crate::segment::Segment;
use crate::trace::StepRecorder;

const TICK_HZ: u32 = 50_000;
const AXIS: AxisLimits =
    AxisLimits { max_rate_hz: 20_000, accel_steps_per_s2: 200_000, junction_jerk_hz: 1_000 };
/// Where the sim's switches close (sim steps from the start point): min at or below, max at or
/// above.
const SWITCH_MIN: i64 = -3_000;
const SWITCH_MAX: i64 = 3_000;
/// Tick at which the cause appears.
const INJECT_TICK: u64 = 3_000;
/// Ticks the scenario keeps running once everything has settled.
const SETTLE_TICKS: u32 = 100;
/// Safety net: no scenario comes near it (the longest, the polar homing, takes about 60 000).
const MAX_TICKS: u64 = 100_000;
/// Soft limits of the soft-limit cases (steps, both axes).
const SOFT_LIMIT: i64 = 2_000;

/// The injected cause.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Case {
    EStop,
    LimitMin(u8),
    LimitMax(u8),
    /// A limit trips, ClearFault is refused while the axis sits on the switch, JogOff moves it
    /// off, then ClearFault returns to Ready with the position kept.
    LimitJogOff,
    HomingOk,
    HomingNotFound,
    SoftLimitQueue,
    SoftLimitRun,
    /// The host stops feeding after two segments of a stream at speed: the machine holds on
    /// the path (no fault), and resumes by itself when the host feeds again.
    QueueStarved,
    /// While X moves, its max switch input chatters (noise on the cable, a bouncing contact)
    /// in bursts shorter than the debounce: no fault, the move ends where it was planned.
    LimitNoise,
    LinkLoss,
    TickOverrun,
    ConfigMissing,
    Sensor(FaultCode),
    /// The sim plant follows the steps (a few ticks behind) until X jams: the machine's
    /// following-error monitor trips after its debounce.
    FollowingError,
    /// The polar machine (`polar::job::board_config`) homes: the arm against its end-stop, the
    /// carriage onto its minimum-radius switch; both origins land on the switch points.
    HomingPolar,
}

/// Every case, in the order the scenario list runs them.
pub const CASES: [Case; 23] = [
    Case::EStop,
    Case::LimitMin(0),
    Case::LimitMax(0),
    Case::LimitMin(1),
    Case::LimitMax(1),
    Case::LimitJogOff,
    Case::HomingOk,
    Case::HomingNotFound,
    Case::SoftLimitQueue,
    Case::SoftLimitRun,
    Case::QueueStarved,
    Case::LimitNoise,
    Case::LinkLoss,
    Case::TickOverrun,
    Case::ConfigMissing,
    Case::Sensor(FaultCode::ForceSaturated),
    Case::Sensor(FaultCode::ForceStuck),
    Case::Sensor(FaultCode::SpindleStopped),
    Case::Sensor(FaultCode::EncoderIndex),
    Case::Sensor(FaultCode::ResolverLoss),
    Case::Sensor(FaultCode::SensorFault),
    Case::FollowingError,
    Case::HomingPolar,
];

impl Case {
    pub const fn name(self) -> &'static str {
        match self {
            Case::EStop => "fault_estop",
            Case::LimitMin(0) => "fault_limit_x_min",
            Case::LimitMax(0) => "fault_limit_x_max",
            Case::LimitMin(_) => "fault_limit_y_min",
            Case::LimitMax(_) => "fault_limit_y_max",
            Case::LimitJogOff => "fault_limit_jog_off",
            Case::HomingOk => "fault_homing_ok",
            Case::HomingNotFound => "fault_homing_not_found",
            Case::SoftLimitQueue => "fault_soft_limit_queue",
            Case::SoftLimitRun => "fault_soft_limit_run",
            Case::QueueStarved => "queue_starved",
            Case::LimitNoise => "limit_noise",
            Case::LinkLoss => "fault_link_loss",
            Case::TickOverrun => "fault_tick_overrun",
            Case::ConfigMissing => "fault_config_missing",
            Case::Sensor(FaultCode::ForceSaturated) => "fault_force_saturated",
            Case::Sensor(FaultCode::ForceStuck) => "fault_force_stuck",
            Case::Sensor(FaultCode::SpindleStopped) => "fault_spindle_stopped",
            Case::Sensor(FaultCode::EncoderIndex) => "fault_encoder_index",
            Case::Sensor(FaultCode::ResolverLoss) => "fault_resolver_loss",
            Case::Sensor(_) => "fault_sensor",
            Case::FollowingError => "fault_following_error",
            Case::HomingPolar => "fault_homing_polar",
        }
    }

    /// The state the case ends in and the fault code it reports (`None`: no fault).
    pub const fn expected(self) -> (MachineState, Option<FaultCode>) {
        use MachineState::{Fault, Ready};
        let (state, code) = match self {
            Case::EStop => (Fault, FaultCode::EStop),
            Case::LimitMin(_) | Case::LimitMax(_) => (Fault, FaultCode::LimitSwitch),
            // Jogged off and cleared: the fault it recovered from.
            Case::LimitJogOff => (Ready, FaultCode::LimitSwitch),
            Case::HomingOk | Case::HomingPolar | Case::QueueStarved | Case::LimitNoise => {
                return (Ready, None)
            }
            Case::HomingNotFound => (Fault, FaultCode::HomingFailed),
            // Refused at the queue: nothing changes, the refusal names the soft limit.
            Case::SoftLimitQueue => (Ready, FaultCode::SoftLimit),
            Case::SoftLimitRun => (Fault, FaultCode::SoftLimit),
            Case::LinkLoss => (Fault, FaultCode::LinkLost),
            Case::TickOverrun => (Fault, FaultCode::TickOverrun),
            Case::ConfigMissing => (Fault, FaultCode::ConfigMissing),
            Case::Sensor(code) => (Fault, code),
            Case::FollowingError => (Fault, FaultCode::FollowingError),
        };
        (state, Some(code))
    }
}

fn home_axis(toward_max: bool, max_travel_steps: u32, home_pos_steps: i64) -> HomeAxis {
    HomeAxis {
        toward_max,
        search_hz: 10_000,
        latch_hz: 2_000,
        backoff_steps: 200,
        max_travel_steps,
        home_pos_steps,
    }
}

/// The scenarios' board: two axes, switches at +-3000 steps, wide soft limits and no homing
/// switches (homing sets the origin where the machine stands), except where a case says.
pub fn config(case: Case) -> BoardConfig {
    if case == Case::HomingPolar {
        return crate::polar::job::board_config();
    }
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    axes[0] = AXIS;
    axes[1] = AXIS;
    let soft = match case {
        Case::SoftLimitQueue | Case::SoftLimitRun => SOFT_LIMIT,
        _ => 100_000,
    };
    let scale = AxisScale { steps_per_unit_milli: 80_000, soft_min: -soft, soft_max: soft };
    let mut cfg = BoardConfig {
        wire: WireConfig {
            machine: MachineConfig {
                tick_hz: TICK_HZ,
                timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
                axis_count: 2,
                axes,
            },
            scale: [
                scale,
                scale,
                AxisScale::UNUSED,
                AxisScale::UNUSED,
                AxisScale::UNUSED,
                AxisScale::UNUSED,
            ],
            inputs: crate::config::InputFilterConfig::DEFAULT,
        },
        home_order: [0, 1, 0, 0, 0, 0],
        home_count: 0,
        home: [HomeAxis::UNUSED; MAX_AXES],
        following: FollowingConfig::OFF,
    };
    match case {
        Case::HomingOk => {
            cfg.home_count = 2;
            // x on its min switch, y on its max switch; the switch points become +-3000.
            cfg.home[0] = home_axis(false, 4_000, SWITCH_MIN);
            cfg.home[1] = home_axis(true, 4_000, SWITCH_MAX);
        }
        Case::HomingNotFound => {
            cfg.home_count = 1;
            cfg.home[0] = home_axis(false, 500, SWITCH_MIN);
        }
        Case::FollowingError => {
            cfg.following.limit_steps[0] = FOLLOWING_LIMIT_STEPS;
            cfg.following.limit_steps[1] = FOLLOWING_LIMIT_STEPS;
            cfg.following.debounce_ticks = FOLLOWING_DEBOUNCE_TICKS;
        }
        _ => {}
    }
    cfg
}

const fn mv(x: i32, y: i32, feed_hz: u32) -> Move {
    Move { steps: [x, y, 0, 0, 0, 0], feed_hz }
}

const LONG_X: [Move; 1] = [mv(2_500, 1_000, 10_000)];
const TO_X_MIN: [Move; 1] = [mv(-5_000, 0, 12_000)];
const TO_X_MAX: [Move; 1] = [mv(5_000, 0, 12_000)];
const TO_Y_MIN: [Move; 1] = [mv(0, -5_000, 12_000)];
const TO_Y_MAX: [Move; 1] = [mv(0, 5_000, 12_000)];
const INSIDE: [Move; 1] = [mv(1_500, 500, 10_000)];
/// Eight short collinear moves: the planner emits the first ones at speed (exit rate > 0); the
/// stream ends (2400 steps) short of the X limit switch.
const STREAM: [Move; 8] = [mv(300, 0, 10_000); 8];
/// The noise case's chatter on the X max switch input: bursts of `NOISE_ON_TICKS` closed (under
/// the 100-tick debounce) and `NOISE_OFF_TICKS` open, `NOISE_BURSTS` times from `INJECT_TICK`.
const NOISE_ON_TICKS: u64 = 90;
const NOISE_OFF_TICKS: u64 = 5;
const NOISE_BURSTS: u64 = 6;
/// How long the starved case's host stays away once the machine stands still, ticks.
const STARVED_TICKS: u32 = 2_000;
/// The move the soft-limit-at-queue case tries after `INSIDE`: it would end at x = 2500.
const BEYOND: Move = mv(1_000, 0, 10_000);
/// The segment the run-time case pushes past the admission check (a stand-in for any path
/// that bypasses it): x from 1500 to 4000 through the 2000 limit.
const ROGUE_X_STEPS: i32 = 2_500;

/// The following-error case: limit and debounce, and how far behind the steps the sim's plant
/// (the measured position) follows. The plant's lag is far inside the limit.
const FOLLOWING_LIMIT_STEPS: u32 = 40;
const FOLLOWING_DEBOUNCE_TICKS: u16 = 8;
const PLANT_LAG_TICKS: usize = 16;

/// Where the polar homing case starts: the arm 1000 steps (22.5 degrees) off its end-stop,
/// the carriage 1500 steps (1.5 in) out from minimum radius.
const POLAR_START_THETA_STEPS: i64 = 1_000;
const POLAR_START_R_STEPS: i64 = 1_500;

/// The flash the config-missing case boots from: erased, as QEMU's read-only flash reads.
type SimFlash = RamFlash<2048, 1024>;

pub struct FaultScenario {
    case: Case,
    machine: Machine,
    dda: Dda,
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
        let cfg = machine.config().wire.machine;
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
                let mut p = Planner::new(&self.machine.config().wire.machine);
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
        self.machine.config().wire.machine.tick_hz
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

/// Runs `case` to its end on the host (the same code the firmware's tick and control tasks run).
pub fn run_case(case: Case) -> Option<ScenarioReport> {
    let mut s = FaultScenario::new(case)?;
    Some(crate::scenario::run_to_end(&mut s, MAX_TICKS + 1))
}

/// What the report `r` of `case` breaks of the documented end, `None` when nothing: the state and
/// fault code of [`Case::expected`], settled before the safety net; the machine's counters equal
/// to the DDA's positions and to the steps the pins made (nothing lost, nothing twice); after a
/// fault that stops at once no step more; after one that kills, the outputs off.
pub fn broken_promise(case: Case, r: &ScenarioReport) -> Option<&'static str> {
    use crate::machine::{reaction, Reaction};
    let f = |n: &str| r.figure(n);
    let (state, code) = case.expected();
    if f("state") != Some(state as i64) {
        return Some("ended in another state than documented");
    }
    if r.fault != code.map_or(0, |c| c.code()) {
        return Some("reported another fault code than documented");
    }
    if r.ticks >= MAX_TICKS {
        return Some("did not settle");
    }
    for a in 0..2 {
        let raw = f(["raw0_steps", "raw1_steps"][a]);
        if raw.is_none()
            || raw != f(["dda0_steps", "dda1_steps"][a])
            || raw != f(["net0_steps", "net1_steps"][a])
        {
            return Some("machine counters, DDA positions and pin steps disagree");
        }
    }
    if let Some(code) = code.filter(|_| state == MachineState::Fault) {
        match reaction(code) {
            Reaction::Hold => {}
            Reaction::Kill if f("spindle") != Some(0) || f("wire_power") != Some(0) => {
                return Some("outputs left on after a kill")
            }
            _ if f("steps_after_fault") != Some(0) => {
                return Some("stepped after an immediate stop")
            }
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::reaction;
    use crate::scenario::run_to_end;

    #[test]
    fn every_case_ends_documented_with_exact_counters() {
        for c in CASES {
            let r = run(c);
            assert_eq!(broken_promise(c, &r), None, "{}: {:?}", r.name, r.figures);
        }
    }

    fn run(c: Case) -> ScenarioReport {
        run_case(c).unwrap()
    }

    #[test]
    fn estop_switches_outputs_off_and_refuses_clear_while_pressed() {
        let r = run(Case::EStop);
        assert_eq!(r.figure("fault_tick"), Some(INJECT_TICK as i64));
        assert_eq!(r.figure("spindle"), Some(0));
        assert_eq!(r.figure("wire_power"), Some(0));
        assert_eq!(r.figure("z_dac"), Some(crate::machine::Z_DAC_MID_SCALE as i64));
        assert_eq!(r.figure("homed"), Some(0));
        assert_eq!(
            r.figure("clear_refused_nak"),
            Some(crate::protocol::ErrorCode::OutOfState.code() as i64)
        );
        assert!(r.figure("net0_steps").unwrap() > 0, "moving when the e-stop came");
        // The report says the counters are exact, and the documented reaction says so too.
        assert_eq!(r.figure("counters_exact"), Some(1));
        assert!(reaction(FaultCode::EStop).name().contains("the counters are exact"));
    }

    /// The switch debounce of the cases, ticks.
    fn debounce_ticks() -> u64 {
        config(Case::LimitMin(0)).wire.inputs.debounce_ticks(TICK_HZ) as u64
    }

    #[test]
    fn limits_stop_one_debounce_past_the_switch() {
        // The switch closes on the step onto it; the machine believes it `debounce` ticks later
        // and stops at once: the axis, cruising at 12 kHz, goes on for debounce - 1 ticks.
        let d = debounce_ticks();
        assert_eq!(d, 100, "2 ms at 50 kHz");
        let feed_hz = TO_X_MIN[0].feed_hz as u64;
        let least = (d - 1) * feed_hz / TICK_HZ as u64;
        let most = ((d - 1) * feed_hz).div_ceil(TICK_HZ as u64);
        for (c, axis, at) in [
            (Case::LimitMin(0), 0, SWITCH_MIN),
            (Case::LimitMax(0), 0, SWITCH_MAX),
            (Case::LimitMin(1), 1, SWITCH_MIN),
            (Case::LimitMax(1), 1, SWITCH_MAX),
        ] {
            let r = run(c);
            let phys = r.figure(["phys0_steps", "phys1_steps"][axis]).unwrap();
            let over = (phys - at).unsigned_abs();
            assert!((least..=most).contains(&over), "{}: {over} steps past the switch", r.name);
            assert_eq!(r.figure(["pos0_steps", "pos1_steps"][axis]), Some(phys), "{}", r.name);
            assert_eq!(r.figure("clear_refused_nak"), Some(10), "{}", r.name);
        }
    }

    #[test]
    fn without_a_debounce_limits_stop_on_the_switch() {
        for (c, axis, at) in
            [(Case::LimitMin(0), 0, SWITCH_MIN), (Case::LimitMax(1), 1, SWITCH_MAX)]
        {
            let mut s = FaultScenario::new(c).unwrap();
            let mut cfg = *s.machine.config();
            cfg.wire.inputs.switch_debounce_us = 0;
            s.machine = Machine::new();
            s.machine.boot(Ok(cfg));
            let r = run_to_end(&mut s, MAX_TICKS + 1);
            assert_eq!(r.figure(["phys0_steps", "phys1_steps"][axis]), Some(at), "{}", r.name);
        }
    }

    #[test]
    fn jog_off_a_limit_then_clear_keeps_the_position() {
        let r = run(Case::LimitJogOff);
        // ClearFault was refused while the switch was closed ...
        assert_eq!(r.figure("clear_refused_nak"), Some(10));
        assert_eq!(r.figure("jog_sent"), Some(1));
        assert_eq!(r.figure("refusal_nak"), Some(0), "JogOff and the second ClearFault accepted");
        // ... the jog stopped once the switch had stayed open for the debounce: after the
        // first step off it (min switch closed at <= -3000), at most debounce ticks at the jog
        // rate (an eighth of the max rate, still accelerating),
        let jog_hz = AXIS.max_rate_hz as u64 / crate::machine::jog_off::JOG_RATE_DIVISOR as u64;
        let past = r.figure("phys0_steps").unwrap() - (SWITCH_MIN + 1);
        let most = (debounce_ticks() * jog_hz).div_ceil(TICK_HZ as u64) as i64;
        assert!((0..=most).contains(&past), "{past} steps past the first step off the switch");
        assert_eq!(r.figure("pos0_steps"), r.figure("phys0_steps"), "position kept exactly");
        // ... and the machine is back in Ready with nothing latched, homing still trusted.
        assert_eq!(r.figure("fault_mask"), Some(0));
        assert_eq!(r.figure("cleared"), Some(FaultCode::LimitSwitch.code() as i64));
        assert_eq!(r.figure("homed"), Some(1));
    }

    #[test]
    fn jog_off_is_refused_without_a_limit_fault() {
        // An e-stop fault: not a limit, nothing to jog off; the refusal changes nothing.
        let mut s = FaultScenario::new(Case::EStop).unwrap();
        let _ = run_to_end(&mut s, MAX_TICKS + 1);
        let before = (s.machine.state(), s.machine.faults().mask(), s.machine.positions());
        let r = s.machine.command(MachineCommand::JogOff, &mut s.dda);
        assert_eq!(r, Err(Refusal::NotOnLimit));
        assert_eq!((s.machine.state(), s.machine.faults().mask(), s.machine.positions()), before);
        assert!(!s.machine.is_jogging());
    }

    #[test]
    fn homing_puts_the_origin_on_the_switches() {
        let r = run(Case::HomingOk);
        assert_eq!(r.figure("homed"), Some(1));
        // Machine position equals the sim's physical position: the origin is exact.
        assert_eq!(r.figure("pos0_steps"), r.figure("phys0_steps"));
        assert_eq!(r.figure("pos1_steps"), r.figure("phys1_steps"));
        // Pulled off by the backoff: 200 steps inside each switch.
        assert_eq!(r.figure("pos0_steps"), Some(SWITCH_MIN + 200));
        assert_eq!(r.figure("pos1_steps"), Some(SWITCH_MAX - 200));
        let r = run(Case::HomingNotFound);
        assert_eq!(r.figure("net0_steps"), Some(-500), "stopped after max_travel");
        assert_eq!(r.figure("homed"), Some(0));
    }

    #[test]
    fn polar_homing_puts_both_origins_on_their_switches() {
        let r = run(Case::HomingPolar);
        let f = |n: &str| r.figure(n).unwrap();
        assert_eq!(f("homed"), 1);
        assert_eq!(f("fault_mask"), 0);
        let h = crate::polar::job::homing_config();
        for (a, start) in [(0usize, POLAR_START_THETA_STEPS), (1, POLAR_START_R_STEPS)] {
            let (pos, phys) = (["pos0_steps", "pos1_steps"][a], ["phys0_steps", "phys1_steps"][a]);
            // The origin is the switch point (theta: the end-stop, r: minimum radius), where
            // the documented home position says: machine position = sim position from there.
            assert_eq!(f(pos), f(phys) + h.axes[a].home_pos_steps, "axis {a}");
            // Pulled off the switch by the back-off.
            assert_eq!(f(pos), h.axes[a].home_pos_steps + h.axes[a].backoff_steps as i64);
            // Net travel: from the start down to the switch, then the back-off out again.
            let net = f(["net0_steps", "net1_steps"][a]);
            assert_eq!(net, -start + h.axes[a].backoff_steps as i64, "axis {a}");
        }
        assert!(r.ticks < MAX_TICKS);
    }

    #[test]
    fn soft_limits_at_queue_and_at_run_time() {
        let r = run(Case::SoftLimitQueue);
        assert_eq!(
            r.figure("refusal_nak"),
            Some(crate::protocol::ErrorCode::InvalidSegment.code() as i64)
        );
        assert_eq!(r.figure("fault_mask"), Some(0), "a refused segment latches nothing");
        assert_eq!(r.figure("pos0_steps"), Some(INSIDE[0].steps[0] as i64));
        let r = run(Case::SoftLimitRun);
        assert_eq!(
            r.figure("pos0_steps"),
            Some(SOFT_LIMIT + 1),
            "stopped on the first step outside"
        );
    }

    #[test]
    fn switch_chatter_shorter_than_the_debounce_is_not_a_limit() {
        let r = run(Case::LimitNoise);
        assert_eq!(r.fault, 0);
        assert_eq!(r.figure("state"), Some(MachineState::Ready as i64));
        assert_eq!(r.figure("phys0_steps"), Some(LONG_X[0].steps[0] as i64), "the whole move");
        // Raw, the same chatter trips the limit.
        let mut s = FaultScenario::new(Case::LimitNoise).unwrap();
        let mut cfg = *s.machine.config();
        cfg.wire.inputs.switch_debounce_us = 0;
        s.machine = Machine::new();
        s.machine.boot(Ok(cfg));
        let r = run_to_end(&mut s, MAX_TICKS + 1);
        assert_eq!(r.fault, FaultCode::LimitSwitch.code());
    }

    #[test]
    fn a_late_host_pauses_the_job_on_the_path_and_it_resumes() {
        let r = run(Case::QueueStarved);
        let f = |n: &str| r.figure(n).unwrap();
        // Two 300-step segments fed at speed, then nothing: the hold ramps down inside the
        // second (no abrupt stop at its end, no fault), stands still for the host's absence,
        // and the rest of the stream runs to its end once the host feeds again.
        assert_eq!(f("dda_underruns"), 0);
        assert_eq!(f("starve_holds"), 1);
        let held = f("held_at0_steps");
        assert!(held > 300 && held <= 600, "held at {held} steps, inside the second segment");
        assert_eq!(f("held_ticks"), STARVED_TICKS as i64);
        assert_eq!(r.fault, 0);
        assert_eq!(f("state"), MachineState::Ready as i64);
        let total: i64 = STREAM.iter().map(|m| m.steps[0] as i64).sum();
        assert_eq!(f("net0_steps"), total, "every step of the stream, none twice");
    }

    #[test]
    fn following_error_trips_after_the_jam_plus_limit_plus_debounce() {
        let r = run(Case::FollowingError);
        let f = |n: &str| r.figure(n).unwrap();
        // X jammed at INJECT_TICK: the plant stands where the steps put it PLANT_LAG_TICKS
        // earlier. The error passes the limit on the step that makes it limit + 1, and the
        // monitor trips FOLLOWING_DEBOUNCE_TICKS checks later (the last of them included).
        let jam = f("measured0_steps");
        assert!(jam > 0, "moving when the jam came");
        let stop = f("raw0_steps");
        // The trip is the debounce-th check over the limit, counting the first one.
        let over = f("over_tick");
        assert!(over > INJECT_TICK as i64);
        assert_eq!(f("fault_tick"), over + FOLLOWING_DEBOUNCE_TICKS as i64 - 1);
        // X steps at most once per 5 ticks (10 kHz feed, 50 kHz tick), so the debounce adds at
        // most ceil(8 / 5) = 2 steps past the first one over the limit.
        let past = stop - jam - (FOLLOWING_LIMIT_STEPS as i64 + 1);
        assert!((0..=2).contains(&past), "{past} steps past the first over the limit");
        assert_eq!(f("following_worst0_steps"), stop - jam);
        // Y's plant followed (lagging PLANT_LAG_TICKS) and is caught up at rest.
        assert_eq!(f("measured1_steps"), f("raw1_steps"));
        // Before the jam the lagging plant never came near the limit: nothing tripped early.
        assert_eq!(r.fault, FaultCode::FollowingError.code());
        assert_eq!(f("fault_mask"), FaultCode::FollowingError.bit() as i64);
        assert_eq!(f("steps_after_fault"), 0, "immediate stop");
    }

    /// Without a jam the same plant (lagging 16 ticks, limit 40) never trips, and ClearFault
    /// after a trip loses the homing (Idle) and re-zeroes the monitor.
    #[test]
    fn following_plant_without_jam_never_trips_and_clear_loses_homing() {
        let cfg = config(Case::FollowingError);
        let mut m = Machine::new();
        m.boot(Ok(cfg));
        let mc = cfg.wire.machine;
        let (mut dda, mut prep) = (Dda::new(&mc).unwrap(), Preparer::new(&mc).unwrap());
        m.command(MachineCommand::Home, &mut dda).unwrap();
        let mut net = [0i64; MAX_AXES];
        let mut ring = [[0i64; MAX_AXES]; PLANT_LAG_TICKS];
        let mut tick =
            |m: &mut Machine, dda: &mut Dda, prep: &mut Preparer, t: usize, jam: bool| {
                let out = m.tick(dda, &Inputs::QUIET);
                for a in 0..2 {
                    if out.step.rise() & (1 << a) != 0 {
                        net[a] += if out.step.dir() & (1 << a) != 0 { -1 } else { 1 };
                    }
                }
                let lagged = ring[t % PLANT_LAG_TICKS];
                ring[t % PLANT_LAG_TICKS] = net;
                let mut meas = lagged;
                if jam {
                    meas[0] = 0;
                }
                m.feedback(&meas);
                while m.wants_background() {
                    m.background(dda, prep);
                }
            };
        for t in 0..10 {
            tick(&mut m, &mut dda, &mut prep, t, false);
        }
        assert_eq!(m.state(), MachineState::Ready);
        let mut p = Planner::new(&mc);
        let mut segs = std::collections::VecDeque::new();
        for mv in STREAM.iter().chain(LONG_X.iter()) {
            while p.push(mv).is_err() {
                segs.push_back(p.pop().unwrap());
            }
        }
        p.finish();
        while let Some(seg) = p.pop() {
            segs.push_back(seg);
        }
        for seg in &segs {
            m.command(MachineCommand::Queue(seg), &mut dda).unwrap();
        }
        m.command(MachineCommand::Start, &mut dda).unwrap();
        let mut t = 10;
        while m.state() == MachineState::Running && t < 200_000 {
            while dda.ready_free() > 0 {
                let Some(seg) = segs.pop_front() else { break };
                dda.push(&prep.prepare(&seg).unwrap()).unwrap();
            }
            tick(&mut m, &mut dda, &mut prep, t, false);
            t += 1;
        }
        assert_eq!(m.faults().mask(), 0, "a plant within the limit never trips");
        let worst = m.following_worst_steps();
        assert!(worst[0] > 0 && worst[0] <= FOLLOWING_LIMIT_STEPS, "worst {worst:?}");
        // Now jam X at 0 while the counters say it moved: trips at once (error >> limit),
        // after the debounce.
        for k in 0..FOLLOWING_DEBOUNCE_TICKS as usize {
            assert_eq!(m.faults().mask(), 0, "tripped before the debounce, check {k}");
            tick(&mut m, &mut dda, &mut prep, t + k, true);
        }
        assert_eq!(m.faults().first(), Some(FaultCode::FollowingError));
        assert!(m.is_homed(), "homing kept while latched (position kept)");
        assert_eq!(m.command(MachineCommand::ClearFault, &mut dda), Ok(MachineState::Idle));
        assert!(!m.is_homed());
        // Re-zeroed: the same standing error no longer counts.
        for k in 0..50 {
            tick(&mut m, &mut dda, &mut prep, t + 100 + k, true);
        }
        assert!(m.faults().is_clear());
    }

    #[test]
    fn config_missing_refuses_motion() {
        let r = run(Case::ConfigMissing);
        assert_eq!(r.figure("home_refused"), Some(1));
        assert_eq!(r.figure("net0_steps"), Some(0));
        assert_eq!(r.figure("clear_refused_nak"), Some(10));
    }
}
