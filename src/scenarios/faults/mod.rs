//! The fault suite: one scenario per fault cause, with a sim board that injects it. Each drives
//! [`Machine`](crate::machine::Machine) around the real DDA exactly as the firmware's tick and control tasks do (tick:
//! `Machine::tick`; planning, preparing and aborting: `Scenario::background`), ends in the
//! documented state with its fault code, and reports the machine's position counters next to the
//! DDA's positions and the `StepRecorder`'s net steps, so their equality is visible in QEMU's
//! report as well as the host's.
//!
//! The parts: `case` names the causes and their documented ends, `board` the board each case
//! boots, `scenario` the sim board and host that inject the cause, `check` what a report must
//! show. The figures they share are here.

mod board;
mod case;
mod check;
mod scenario;
#[cfg(test)]
mod tests;

pub use board::config;
pub use case::{Case, CASES};
pub use check::{broken_promise, run_case};
pub use scenario::FaultScenario;

use crate::config::AxisLimits;
use crate::planner::Move;

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
