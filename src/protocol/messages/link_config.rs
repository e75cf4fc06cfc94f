//! The configuration as set and read over the link: per-axis scale and soft limits next to the
//! step-space machine config, and the homing parameters.

use serde::{Deserialize, Serialize};

use crate::config::{
    AxisLimits, ConfigError, InputFilterConfig, MachineConfig, StepTiming, TickTiming, MAX_AXES,
};
use crate::machine::HomeAxis;

/// How the machine homes: `order[..count]` are the axes homed in turn (0 = home where it
/// stands), each with its `axes[axis]` parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct HomingConfig {
    pub order: [u8; MAX_AXES],
    pub count: u8,
    pub axes: [HomeAxis; MAX_AXES],
}

impl HomingConfig {
    /// No switches: `Home` takes the current position as it is.
    pub const NONE: HomingConfig =
        HomingConfig { order: [0; MAX_AXES], count: 0, axes: [HomeAxis::UNUSED; MAX_AXES] };
}

/// Per-axis scale and soft limits, alongside the step-space `MachineConfig`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct AxisScale {
    /// Steps per user unit (mm or degree) times 1000, e.g. 80 steps/mm = 80_000.
    pub steps_per_unit_milli: u32,
    /// Soft limits in steps (inclusive); `i64::MIN` / `i64::MAX` = none.
    pub soft_min: i64,
    pub soft_max: i64,
}

impl AxisScale {
    pub const UNUSED: AxisScale =
        AxisScale { steps_per_unit_milli: 0, soft_min: i64::MIN, soft_max: i64::MAX };
}

/// The configuration as set and read over the link.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkConfig {
    pub machine: MachineConfig,
    pub scale: [AxisScale; MAX_AXES],
    /// How long a limit switch must hold a new level, and the e-stop stay released, before the
    /// machine believes it.
    pub inputs: InputFilterConfig,
}

impl LinkConfig {
    /// A placeholder that fails validation (tick_hz 0): the board's state before any SetConfig.
    pub const UNSET: LinkConfig = LinkConfig {
        machine: MachineConfig {
            tick_hz: 0,
            timing: StepTiming { pulse_ns: 0, dir_setup_ns: 0, dir_hold_ns: 0 },
            axis_count: 0,
            axes: [AxisLimits::UNUSED; MAX_AXES],
        },
        scale: [AxisScale::UNUSED; MAX_AXES],
        inputs: InputFilterConfig::DEFAULT,
    };

    /// `MachineConfig::validate` plus the scale and input-filter checks; the same code runs on both ends, so the
    /// host can call it for the full reason behind an `InvalidConfig` NAK.
    pub fn validate(&self) -> Result<TickTiming, ConfigError> {
        let timing = self.machine.validate()?;
        let used = (self.machine.axis_count as usize).min(MAX_AXES);
        for (i, s) in self.scale.iter().enumerate().take(used) {
            let bad = |field, reason| Err(ConfigError { field, axis: Some(i as u8), reason });
            if s.steps_per_unit_milli == 0 {
                return bad("steps_per_unit_milli", "must be > 0");
            }
            if s.soft_min > s.soft_max {
                return bad("soft_min", "must be <= soft_max");
            }
        }
        self.inputs.validate()?;
        Ok(timing)
    }
}
