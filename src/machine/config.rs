//! The board configuration the machine runs with and persists: the link's [`LinkConfig`] (step
//! timing, axis limits, scale and soft limits) plus the homing parameters of each axis.

use super::following::FollowingConfig;
use crate::config::{AxisLimits, ConfigError, MachineConfig, StepTiming, MAX_AXES};
use crate::protocol::{AxisScale, LinkConfig};

/// How one axis homes: seek its switch at `search_hz`, back off `backoff_steps`, approach again
/// at `latch_hz` and call the point where the switch closes `home_pos_steps`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct HomeAxis {
    /// Home on the max switch (else the min switch).
    pub toward_max: bool,
    pub search_hz: u32,
    pub latch_hz: u32,
    pub backoff_steps: u32,
    /// Longest seek before "switch not found".
    pub max_travel_steps: u32,
    /// Machine position of the switch's latch point.
    pub home_pos_steps: i64,
}

impl HomeAxis {
    pub const UNUSED: HomeAxis = HomeAxis {
        toward_max: false,
        search_hz: 0,
        latch_hz: 0,
        backoff_steps: 0,
        max_travel_steps: 0,
        home_pos_steps: 0,
    };
}

/// Everything the machine needs to run, persisted as one record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BoardConfig {
    pub link: LinkConfig,
    /// Axes homed, in order (the polar machine: arm against its stop, then the carriage at
    /// minimum radius). The first `home_count` entries count; 0 = no switches, home where it is.
    pub home_order: [u8; MAX_AXES],
    pub home_count: u8,
    pub home: [HomeAxis; MAX_AXES],
    /// Following-error limits of the axes with feedback ([`FollowingConfig::OFF`]: none).
    pub following: FollowingConfig,
}

/// Longest homing travel: a seek must fit one planned move.
pub const MAX_HOME_TRAVEL_STEPS: u32 = 1 << 30;
/// Largest |home_pos_steps|: 2^46 steps is over 8 000 km at 10 steps/um, and keeps every
/// position sum (raw steps + offset) far from i64's range.
pub const MAX_HOME_POS_STEPS: i64 = 1 << 46;

impl BoardConfig {
    /// The config used when none is stored (or it is corrupt): slow, no travel allowed (soft
    /// limits 0..=0), no homing. It exists so the DDA can be built; the `ConfigMissing` fault
    /// keeps the machine still until a real config is set.
    pub const fn safe_default() -> BoardConfig {
        const AXIS: AxisLimits =
            AxisLimits { max_rate_hz: 1_000, accel_steps_per_s2: 10_000, junction_jerk_hz: 100 };
        const SCALE: AxisScale =
            AxisScale { steps_per_unit_milli: 1_000, soft_min: 0, soft_max: 0 };
        BoardConfig {
            link: LinkConfig {
                machine: MachineConfig {
                    tick_hz: 50_000,
                    timing: StepTiming {
                        pulse_ns: 5_000,
                        dir_setup_ns: 10_000,
                        dir_hold_ns: 10_000,
                    },
                    axis_count: MAX_AXES as u8,
                    axes: [AXIS; MAX_AXES],
                },
                scale: [SCALE; MAX_AXES],
                inputs: crate::config::InputFilterConfig::DEFAULT,
            },
            home_order: [0; MAX_AXES],
            home_count: 0,
            home: [HomeAxis::UNUSED; MAX_AXES],
            following: FollowingConfig::OFF,
        }
    }

    /// `link` with the homing parameters of `h` and no following-error check (validate before
    /// use).
    pub fn with_homing(link: LinkConfig, h: &crate::protocol::HomingConfig) -> BoardConfig {
        BoardConfig {
            link,
            home_order: h.order,
            home_count: h.count,
            home: h.axes,
            following: FollowingConfig::OFF,
        }
    }

    /// This config with the following-error limits `f` (validate before use).
    pub const fn with_following(self, f: FollowingConfig) -> BoardConfig {
        BoardConfig { following: f, ..self }
    }

    /// The homing parameters, as the link carries them.
    pub fn homing(&self) -> crate::protocol::HomingConfig {
        crate::protocol::HomingConfig {
            order: self.home_order,
            count: self.home_count,
            axes: self.home,
        }
    }

    /// Every check of [`LinkConfig::validate`] plus the homing parameters; the error names the
    /// field (and axis).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.link.validate()?;
        let axes = self.link.machine.axis_count;
        let err = |field, axis, reason| Err(ConfigError { field, axis, reason });
        if self.home_count > axes {
            return err("home_count", None, "more than axis_count");
        }
        let mut seen = 0u8;
        for k in 0..self.home_count as usize {
            let a = self.home_order[k];
            if a >= axes {
                return err("home_order", Some(a), "axis not in use");
            }
            if seen & (1 << a) != 0 {
                return err("home_order", Some(a), "axis listed twice");
            }
            seen |= 1 << a;
            let h = &self.home[a as usize];
            let max_rate = self.link.machine.axes[a as usize].max_rate_hz;
            if h.search_hz == 0 || h.search_hz > max_rate {
                return err("search_hz", Some(a), "must be within 1..=max_rate_hz");
            }
            if h.latch_hz == 0 || h.latch_hz > h.search_hz {
                return err("latch_hz", Some(a), "must be within 1..=search_hz");
            }
            if h.backoff_steps == 0 || h.backoff_steps > MAX_HOME_TRAVEL_STEPS / 2 {
                return err("backoff_steps", Some(a), "must be within 1..=2^29");
            }
            if h.max_travel_steps <= h.backoff_steps || h.max_travel_steps > MAX_HOME_TRAVEL_STEPS {
                return err("max_travel_steps", Some(a), "must be within backoff_steps+1..=2^30");
            }
            if h.home_pos_steps.unsigned_abs() > MAX_HOME_POS_STEPS as u64 {
                return err("home_pos_steps", Some(a), "must be within -2^46..=2^46");
            }
        }
        self.following.validate(axes)
    }
}
