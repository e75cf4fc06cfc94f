//! The wire manipulator as the DDA sees it: four axes X, Y, beta, alpha (axes 0..3), their step
//! limits (the steps per unit live in motionctl's `wire::ik`), and the tick rate.

use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};

/// DDA tick of the wire jobs. The axes step at most a few kHz (the job's fastest axis needs
/// about 1.4 kHz), so a 10 kHz tick is enough and keeps a 564 s job cheap in QEMU.
pub const TICK_HZ: u32 = 10_000;
/// Axis order of every wire segment.
pub const AXIS_X: usize = 0;
pub const AXIS_Y: usize = 1;
pub const AXIS_BETA: usize = 2;
pub const AXIS_ALPHA: usize = 3;
/// Axes in use.
pub const AXES: usize = 4;

/// Highest step rate of every axis: half the tick (one pulse high, one low).
pub const MAX_RATE_HZ: u32 = TICK_HZ / 2;
/// Acceleration limit, steps/s^2: 20 000 steps/s^2 is 6 mm/s^2 on X/Y, 80 deg/s^2 on beta and
/// 14 deg/s^2 on alpha; the job's axes reach their cutting speed in well under 0.1 s.
pub const ACCEL_STEPS_PER_S2: u32 = 20_000;
/// Largest axis speed change at a junction, steps/s: 0.06 mm/s on X/Y.
pub const JUNCTION_JERK_HZ: u32 = 200;

const AXIS: AxisLimits = AxisLimits {
    max_rate_hz: MAX_RATE_HZ,
    accel_steps_per_s2: ACCEL_STEPS_PER_S2,
    junction_jerk_hz: JUNCTION_JERK_HZ,
};

/// The machine configuration of the wire jobs (validated by the host tests).
pub const fn config() -> MachineConfig {
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    axes[AXIS_X] = AXIS;
    axes[AXIS_Y] = AXIS;
    axes[AXIS_BETA] = AXIS;
    axes[AXIS_ALPHA] = AXIS;
    MachineConfig {
        tick_hz: TICK_HZ,
        // KS-series servo drives take step/direction like the stepper drivers: 2.5 us pulses,
        // 5 us DIR setup and hold (one 100 us tick each).
        timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
        axis_count: AXES as u8,
        axes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_is_valid_and_rates_fit_the_tick() {
        let t = config().validate().unwrap();
        assert_eq!(t.min_spacing_ticks, 2);
        assert_eq!(MAX_RATE_HZ * t.min_spacing_ticks, TICK_HZ);
    }
}
