//! Machine configuration: tick rate, step/dir timing and per-axis limits, validated once so the
//! tick path can trust every derived number.

/// Axes the DDA drives.
pub const MAX_AXES: usize = 6;
/// Depth of the rise history the DDA keeps: it must cover two pulse lengths (high + low time)
/// and the DIR hold time.
pub const TIMING_RING_TICKS: u32 = 16;
/// Longest pulse, DIR setup or DIR hold time in ticks.
pub const MAX_TIMING_TICKS: u32 = TIMING_RING_TICKS / 2 - 1;

/// Step/direction interface timing required by the stepper drivers, in nanoseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(serde::Serialize, serde::Deserialize)]
pub struct StepTiming {
    /// Minimum STEP high time (and low time between pulses).
    pub pulse_ns: u32,
    /// Minimum time from a DIR change to the next STEP rising edge.
    pub dir_setup_ns: u32,
    /// Minimum time from a STEP rising edge to a DIR change.
    pub dir_hold_ns: u32,
}

/// Per-axis kinematic limits in steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(serde::Serialize, serde::Deserialize)]
pub struct AxisLimits {
    /// Highest step rate the axis may run at, steps/s.
    pub max_rate_hz: u32,
    /// Acceleration limit, steps/s^2.
    pub accel_steps_per_s2: u32,
    /// Largest instantaneous speed change allowed at a segment junction, steps/s.
    pub junction_jerk_hz: u32,
}

impl AxisLimits {
    pub const UNUSED: AxisLimits =
        AxisLimits { max_rate_hz: 0, accel_steps_per_s2: 0, junction_jerk_hz: 0 };
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(serde::Serialize, serde::Deserialize)]
pub struct MachineConfig {
    /// DDA tick frequency.
    pub tick_hz: u32,
    pub timing: StepTiming,
    /// Axes in use: 1..=MAX_AXES; the others must not move.
    pub axis_count: u8,
    pub axes: [AxisLimits; MAX_AXES],
}

/// A rejected configuration: which field, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError {
    pub field: &'static str,
    pub axis: Option<u8>,
    pub reason: &'static str,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.axis {
            Some(a) => write!(f, "axis {a} {}: {}", self.field, self.reason),
            None => write!(f, "{}: {}", self.field, self.reason),
        }
    }
}

/// Timing converted to whole ticks, rounded up so every requirement is met or exceeded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TickTiming {
    pub tick_ns: u32,
    /// STEP stays high for this many ticks (>= 1).
    pub pulse_ticks: u32,
    /// Ticks between a DIR write and the next rising edge on that axis.
    pub setup_ticks: u32,
    /// Ticks between a rising edge and a DIR write on that axis.
    pub hold_ticks: u32,
    /// Minimum ticks between two rising edges of one axis (high + low time).
    pub min_spacing_ticks: u32,
}

const NS_PER_S: u64 = 1_000_000_000;
/// Slowest tick the DDA supports (timing resolution 100 us).
pub const MIN_TICK_HZ: u32 = 10_000;
/// Fastest tick a tick interrupt is asked for (a 168 MHz core has ~670 cycles per tick here);
/// the boards' tick timers refuse faster ones.
pub const MAX_TICK_HZ: u32 = 250_000;
/// Fastest tick of all: a streamed step output's slot clock (`dda::edge_stream`), 250 kHz per
/// axis. Past [`MAX_TICK_HZ`] the DIR setup must be at least one tick, as a stream needs.
pub const MAX_STREAM_TICK_HZ: u32 = 500_000;

impl MachineConfig {
    pub fn tick_ns(&self) -> u32 {
        (NS_PER_S / self.tick_hz.max(1) as u64) as u32
    }

    /// Checks every field and derives the tick-quantised timing. Ticks up to
    /// [`MAX_STREAM_TICK_HZ`]; past [`MAX_TICK_HZ`], only a streamed output's, with a DIR setup
    /// of at least one tick. Whether the board's tick can run the rate is the board's to say.
    pub fn validate(&self) -> Result<TickTiming, ConfigError> {
        let t = self.validate_up_to(MAX_STREAM_TICK_HZ, "must be within 10 kHz..=500 kHz")?;
        if self.tick_hz > MAX_TICK_HZ && t.setup_ticks == 0 {
            return Err(ConfigError {
                field: "dir_setup_ns",
                axis: None,
                reason: "must be > 0 past a 250 kHz tick (a streamed step output's)",
            });
        }
        Ok(t)
    }

    /// [`MachineConfig::validate`] with ticks up to `max_tick_hz` (`range` says so in the
    /// error): a step output whose ticks are not interrupts runs them faster
    /// (`dda::edge_stream`).
    fn validate_up_to(
        &self,
        max_tick_hz: u32,
        range: &'static str,
    ) -> Result<TickTiming, ConfigError> {
        let err = |field, reason| Err(ConfigError { field, axis: None, reason });
        if self.tick_hz < MIN_TICK_HZ || self.tick_hz > max_tick_hz {
            return err("tick_hz", range);
        }
        if self.axis_count == 0 || self.axis_count as usize > MAX_AXES {
            return err("axis_count", "must be within 1..=6");
        }
        let tick_ns = self.tick_ns();
        let ticks_for = |ns: u32| (ns as u64).div_ceil(tick_ns as u64) as u32;
        let pulse_ticks = ticks_for(self.timing.pulse_ns).max(1);
        let setup_ticks = ticks_for(self.timing.dir_setup_ns);
        let hold_ticks = ticks_for(self.timing.dir_hold_ns);
        let limit = MAX_TIMING_TICKS;
        if pulse_ticks > limit {
            return err("pulse_ns", "longer than 7 ticks");
        }
        if setup_ticks > limit {
            return err("dir_setup_ns", "longer than 7 ticks");
        }
        if hold_ticks > limit {
            return err("dir_hold_ns", "longer than 7 ticks");
        }
        let min_spacing_ticks = 2 * pulse_ticks;
        let rate_ceiling_hz = self.tick_hz / min_spacing_ticks;
        for (i, a) in self.axes.iter().enumerate().take(self.axis_count as usize) {
            let axis = Some(i as u8);
            let bad = |field, reason| Err(ConfigError { field, axis, reason });
            if a.max_rate_hz == 0 {
                return bad("max_rate_hz", "must be > 0");
            }
            if a.max_rate_hz > rate_ceiling_hz {
                return bad("max_rate_hz", "exceeds tick_hz / (2 * pulse ticks)");
            }
            if a.accel_steps_per_s2 == 0 {
                return bad("accel_steps_per_s2", "must be > 0");
            }
        }
        Ok(TickTiming { tick_ns, pulse_ticks, setup_ticks, hold_ticks, min_spacing_ticks })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn cfg() -> MachineConfig {
        MachineConfig {
            tick_hz: 100_000,
            timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 12_000 },
            axis_count: 2,
            axes: [AxisLimits { max_rate_hz: 50_000, accel_steps_per_s2: 1, junction_jerk_hz: 0 };
                MAX_AXES],
        }
    }

    #[test]
    fn timing_rounds_up_to_ticks() {
        let t = cfg().validate().unwrap();
        assert_eq!(t.tick_ns, 10_000);
        assert_eq!((t.pulse_ticks, t.setup_ticks, t.hold_ticks), (1, 1, 2));
        assert_eq!(t.min_spacing_ticks, 2);
    }

    #[test]
    fn errors_name_the_field() {
        let mut c = cfg();
        c.axes[1].max_rate_hz = 50_001;
        let e = c.validate().unwrap_err();
        assert_eq!((e.field, e.axis), ("max_rate_hz", Some(1)));
        let mut c = cfg();
        c.timing.pulse_ns = 80_000;
        assert_eq!(c.validate().unwrap_err().field, "pulse_ns");
        let mut c = cfg();
        c.tick_hz = 1;
        assert_eq!(c.validate().unwrap_err().field, "tick_hz");
        c.tick_hz = MAX_STREAM_TICK_HZ + 1;
        assert_eq!(c.validate().unwrap_err().field, "tick_hz");
        // Past a tick interrupt's rate, a DIR write needs a tick of its own.
        c.tick_hz = MAX_TICK_HZ + 10_000;
        c.timing.dir_setup_ns = 0;
        assert_eq!(c.validate().unwrap_err().field, "dir_setup_ns");
        c.tick_hz = MAX_TICK_HZ;
        assert!(c.validate().is_ok());
        // Unused axes are not checked.
        let mut c = cfg();
        c.axes[3] = AxisLimits::UNUSED;
        assert!(c.validate().is_ok());
    }
}

// ---- switch inputs (machine::debounce filters them) ----

/// Default switch debounce, microseconds (grbl's `DEBOUNCE_PERIOD` is 32 ms of a watchdog;
/// grblHAL's default is 40 ms; 2 ms covers a microswitch's bounce without delaying a trip much).
pub const DEFAULT_SWITCH_DEBOUNCE_US: u32 = 2_000;
/// Longest debounce accepted, microseconds: a limit trip later than this is not a limit.
pub const MAX_SWITCH_DEBOUNCE_US: u32 = 50_000;

/// The switch inputs' filter settings (part of the stored board config).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InputFilterConfig {
    /// How long a limit switch must hold a new level, and the e-stop stay released, before the
    /// machine believes it, microseconds (0: raw inputs).
    pub switch_debounce_us: u32,
}

impl InputFilterConfig {
    pub const DEFAULT: InputFilterConfig =
        InputFilterConfig { switch_debounce_us: DEFAULT_SWITCH_DEBOUNCE_US };

    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.switch_debounce_us > MAX_SWITCH_DEBOUNCE_US {
            return Err(ConfigError {
                field: "switch_debounce_us",
                axis: None,
                reason: "must be within 0..=50000 (50 ms)",
            });
        }
        Ok(())
    }

    /// The debounce in ticks at `tick_hz`, rounded up (setup time: divides), at least 1 tick
    /// unless the debounce is off.
    pub fn debounce_ticks(&self, tick_hz: u32) -> u16 {
        let us = self.switch_debounce_us as u64;
        let ticks = (us * tick_hz as u64).div_ceil(1_000_000);
        ticks.min(u16::MAX as u64) as u16
    }
}

impl Default for InputFilterConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
