//! The built-in job the firmware runs without a host: six axes, mixed directions and feeds,
//! override changes and a feed hold with resume. The QEMU golden scenario runs it and the host
//! model runs the same, through the same planner and DDA.

use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::dda::Command;
use crate::planner::{Move, Planner};
use crate::segment::{Rate, Segment};

pub const TICK_HZ: u32 = 100_000;
/// The firmware prints a position snapshot about this often.
pub const SNAPSHOT_PERIOD_TICKS: u64 = 10_000;

const AXIS: AxisLimits =
    AxisLimits { max_rate_hz: 40_000, accel_steps_per_s2: 400_000, junction_jerk_hz: 2_000 };

pub fn config() -> MachineConfig {
    MachineConfig {
        tick_hz: TICK_HZ,
        // Typical of TB6600/DM542-class drivers: 2.5 us pulses, 5 us DIR setup and hold.
        timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
        axis_count: MAX_AXES as u8,
        axes: [AXIS; MAX_AXES],
    }
}

const fn mv(steps: [i32; MAX_AXES], feed_hz: u32) -> Move {
    Move { steps, feed_hz }
}

/// X Y Z A B C. A square with a diagonal, a Z plunge and retract, rotary moves, reversals on
/// every axis, short moves that meet at speed and one long fast traverse.
pub const MOVES: [Move; 16] = [
    mv([4_000, 0, 0, 0, 0, 0], 20_000),
    mv([0, 3_000, 0, 0, 0, 0], 20_000),
    mv([-4_000, 0, 0, 0, 0, 0], 20_000),
    mv([0, -3_000, 0, 0, 0, 0], 20_000),
    mv([4_000, 3_000, 0, 0, 0, 0], 30_000),
    mv([0, 0, -1_200, 0, 0, 0], 8_000),
    mv([1_000, 500, 0, 250, 0, 0], 12_000),
    mv([1_000, 700, 0, 250, 0, 0], 12_000),
    mv([1_000, 900, 0, 250, 0, 0], 12_000),
    mv([1_000, 1_100, 0, 250, 0, 0], 12_000),
    mv([0, 0, 1_200, -2_000, 0, 0], 15_000),
    mv([-7_000, -6_200, 0, 0, 1_500, -800], 36_000),
    mv([300, -200, 100, -50, -1_500, 800], 5_000),
    mv([-300, 200, -100, 50, 0, 0], 5_000),
    mv([2_500, 0, 0, 0, 0, 0], 40_000),
    mv([-2_500, 0, 0, 1_000, 0, 0], 40_000),
];

/// Tick-stamped feed commands, as a host would schedule them.
pub fn commands() -> &'static [(u64, Command)] {
    const C: [(u64, Command); 7] = [
        (30_000, Command::SetOverride(Rate::lit("1.5"))),
        (60_000, Command::SetOverride(Rate::lit("0.5"))),
        (90_000, Command::SetOverride(Rate::lit("2.0"))),
        (120_000, Command::Hold),
        (150_000, Command::Resume),
        (160_000, Command::SetOverride(Rate::lit("0.25"))),
        (175_000, Command::SetOverride(Rate::ONE)),
    ];
    &C
}

/// Streams the planned segments of [`MOVES`].
pub struct DemoJob {
    planner: Planner,
    next_move: usize,
}

impl Default for DemoJob {
    fn default() -> Self {
        Self::new()
    }
}

impl DemoJob {
    pub fn new() -> Self {
        DemoJob { planner: Planner::new(&config()), next_move: 0 }
    }

    /// The next planned segment; `None` once the job is done. The moves are constants checked by
    /// the host tests, so planning them cannot fail at run time.
    pub fn next_segment(&mut self) -> Option<Segment> {
        loop {
            if let Some(seg) = self.planner.pop() {
                return Some(seg);
            }
            let mv = MOVES.get(self.next_move)?;
            if self.planner.push(mv).is_err() {
                return None;
            }
            self.next_move += 1;
            if self.next_move == MOVES.len() {
                self.planner.finish();
            }
        }
    }
}
