//! The board each fault case boots: two axes with wide soft limits, or what the case needs.

use super::case::Case;
use super::{
    AXIS, FOLLOWING_DEBOUNCE_TICKS, FOLLOWING_LIMIT_STEPS, SOFT_LIMIT, SWITCH_MAX, SWITCH_MIN,
    TICK_HZ,
};
use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::machine::{BoardConfig, FollowingConfig, HomeAxis};
use crate::protocol::{AxisScale, LinkConfig};

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
        link: LinkConfig {
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
