//! The DDA alone under a feed-override sweep (0 -> 2.0 in quarter steps, a hold and a resume):
//! the simplest closed loop, and the baseline every capability scenario extends. It proves in the
//! firmware what the host property tests prove on the host: override and hold never lose or add
//! a step.

use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::dda::{Command, Dda, Preparer};
use crate::planner::{Move, Planner};
use crate::scenario::{Scenario, ScenarioReport, TraceHash};
use crate::segment::Rate;
use crate::trace::StepRecorder;

const TICK_HZ: u32 = 50_000;
const AXIS: AxisLimits =
    AxisLimits { max_rate_hz: 20_000, accel_steps_per_s2: 200_000, junction_jerk_hz: 1_000 };
/// Ticks between override changes (20 ms).
const STEP_TICKS: u64 = 1_000;
/// Override sequence in quarters of 1.0; `HOLD` marks a hold, `RESUME` the resume.
const HOLD: u8 = 0xfe;
const RESUME: u8 = 0xff;
const SEQUENCE: [u8; 12] = [4, 6, 8, 2, 0, 1, 4, HOLD, RESUME, 7, 3, 4];
pub(crate) const MOVES: [Move; 3] = [
    Move { steps: [6_000, 2_500, 0, 0, 0, 0], feed_hz: 12_000 },
    Move { steps: [-1_500, 4_000, 0, 0, 0, 0], feed_hz: 9_000 },
    Move { steps: [-3_000, -6_000, 0, 0, 0, 0], feed_hz: 15_000 },
];
/// Ticks after which the run is cut off: far beyond the slowest schedule.
const MAX_TICKS: u64 = 40 * TICK_HZ as u64;

pub fn config() -> MachineConfig {
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    axes[0] = AXIS;
    axes[1] = AXIS;
    MachineConfig {
        tick_hz: TICK_HZ,
        timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
        axis_count: 2,
        axes,
    }
}

pub struct OverrideSweep {
    dda: Dda,
    prep: Preparer,
    planner: Planner,
    next_move: usize,
    next_change: usize,
    /// Ticks until the next override change (a countdown: no division on the tick path).
    change_in: u64,
    all_fed: bool,
    rec: StepRecorder,
    hash: TraceHash,
    fault: u8,
    done: bool,
}

impl OverrideSweep {
    /// `None` only if the built-in configuration were invalid (a host test proves it is not).
    pub fn new() -> Option<Self> {
        let cfg = config();
        Some(OverrideSweep {
            dda: Dda::new(&cfg).ok()?,
            prep: Preparer::new(&cfg).ok()?,
            planner: Planner::new(&cfg),
            next_move: 0,
            next_change: 0,
            change_in: STEP_TICKS,
            all_fed: false,
            rec: StepRecorder::new(),
            hash: TraceHash::new(),
            fault: 0,
            done: false,
        })
    }

    fn feed(&mut self) {
        while self.dda.ready_free() > 0 {
            if let Some(seg) = self.planner.pop() {
                match self.prep.prepare(&seg) {
                    Ok(p) => {
                        let _ = self.dda.push(&p);
                    }
                    Err(_) => {
                        self.fault = crate::protocol::FaultCode::ConfigMissing as u8;
                        self.done = true;
                        return;
                    }
                }
                continue;
            }
            let Some(mv) = MOVES.get(self.next_move) else {
                self.all_fed = true;
                return;
            };
            if self.planner.push(mv).is_err() {
                return;
            }
            self.next_move += 1;
            if self.next_move == MOVES.len() {
                self.planner.finish();
            }
        }
    }

    fn command_due(&mut self) {
        self.change_in -= 1;
        if self.change_in != 0 {
            return;
        }
        self.change_in = STEP_TICKS;
        let Some(&q) = SEQUENCE.get(self.next_change) else { return };
        self.next_change += 1;
        let cmd = match q {
            HOLD => Command::Hold,
            RESUME => Command::Resume,
            quarters => Command::SetOverride(Rate::from_bits((quarters as u32) << 28)),
        };
        self.dda.apply(cmd);
    }
}

impl Scenario for OverrideSweep {
    fn name(&self) -> &'static str {
        "override_sweep"
    }

    fn tick_hz(&self) -> u32 {
        TICK_HZ
    }

    fn wants_background(&self) -> bool {
        !self.done && !self.all_fed && self.dda.ready_free() > 0
    }

    /// Planning and preparing (both divide) run here, as the firmware's feeder task does.
    fn background(&mut self) {
        self.feed();
    }

    fn tick(&mut self) -> bool {
        if self.done {
            return false;
        }
        self.command_due();
        if (self.all_fed && self.dda.is_idle() && self.next_change >= SEQUENCE.len())
            || self.dda.now() >= MAX_TICKS
        {
            self.done = true;
            return false;
        }
        let out = self.dda.tick();
        self.rec.record(self.dda.now(), &out);
        self.hash.u32(out.rise() as u32 | (out.dir() as u32) << 8);
        true
    }

    fn report(&self) -> ScenarioReport {
        let mut r = ScenarioReport::new(self.name(), self.dda.now(), self.hash.value(), self.fault);
        let pos = self.dda.positions();
        r.push("pos0_steps", pos[0]);
        r.push("pos1_steps", pos[1]);
        r.push("net0_steps", self.rec.net[0]);
        r.push("net1_steps", self.rec.net[1]);
        r.push("segments", self.dda.segments_done() as i64);
        r.push("step_hash_low32", (self.rec.hash() & 0xffff_ffff) as i64);
        r
    }
}
