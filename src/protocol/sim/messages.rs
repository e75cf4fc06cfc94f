//! The simulator board's test hooks on the link ([`SimRequest`], in `RequestBody::Sim`) and
//! the simulated milling plant's parameters. Link form as the other messages: postcard, variants
//! as varint indices in declaration order (new hooks go at the end).

use serde::{Deserialize, Serialize};

use crate::config::MAX_AXES;

/// A test hook of a simulator board (only with `CAP_SIM_INPUTS`, else `Unsupported`). Not a
/// machine command: accepted in every machine state.
#[cfg(feature = "sim-inputs")]
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SimRequest {
    /// The wire-stall switch level the board reads from its next tick on, until the next
    /// `Inject`.
    Inject { wire_stall: bool },
    /// The simulated spindle's speed from the next tick on (thousandths of rpm, >= 0) and
    /// whether its encoder gives index pulses.
    Spindle { rpm_milli: u32, index: bool },
    /// The simulated milling plant the force samples come from (also needs `CAP_MILLING_JOB`);
    /// used by the next `ArmForce` job's start. Out of range -> `OutOfRange` naming the field.
    Milling(SimMillingParams),
    /// The counts the simulated arm and carriage encoders slew to, one count per
    /// `polar::copy_link::SIM_TICKS_PER_COUNT` ticks each.
    Encoders { arm_counts: i32, carriage_counts: i32 },
    /// The simulated probe's surface from the next tick on (`None`: the probe never touches).
    /// The board evaluates it from its step counters every tick, then debounces it like a
    /// real probe input.
    Probe { surface: Option<SimProbeSurface> },
    /// The stored config records read corrupt from the next boot on, as disturbed flash would
    /// (a board whose config store can be corrupted, QEMU's; else `Unsupported`).
    CorruptConfig,
}

/// A simulated probe surface (`SimRequest::Probe`): the probe input reads active while axis
/// `axis`'s machine position is at or below `at_steps` (`below`), or at or above it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimProbeSurface {
    pub axis: u8,
    pub at_steps: i64,
    pub below: bool,
}

impl SimProbeSurface {
    /// The probe level at machine `positions` (an axis beyond the positions never touches).
    /// Interrupt rate: a load and a compare.
    #[inline]
    pub fn active(&self, positions: &[i64; MAX_AXES]) -> bool {
        match positions.get(self.axis as usize) {
            Some(&p) if self.below => p <= self.at_steps,
            Some(&p) => p >= self.at_steps,
            None => false,
        }
    }
}

/// A fault the simulated plant injects once the tool is `fault_at_um` into the work.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SimForceFault {
    None,
    /// A channel reads full scale.
    Saturated {
        channel: u8,
    },
    /// A channel repeats its last reading.
    Stuck {
        channel: u8,
    },
    /// The spindle stops.
    SpindleStop,
}

/// The simulated milling plant (`SimRequest::Milling`): eq 4.17 `F = Kc b [x(t) - x(t - tau)]`
/// (`Kc = K a`) with a depth step, seen through a simulated 12-bit ADC.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimMillingParams {
    /// Cutting constant Kc: force per mm^2 of chip section (axial depth times the feed per
    /// tooth), mN/mm^2 (eq 4.17's `K a`: 205 N/mm^3 x 20 mm = 4 100 000); axial depth b before
    /// and after its step at `step_at_um` of penetration, um.
    pub kc_mn_per_mm2: u32,
    pub b_before_um: u32,
    pub b_after_um: u32,
    pub step_at_um: u32,
    /// The wall: the feed axis's position (steps from where the job starts) where the cut begins.
    pub wall_steps: i64,
    /// Feed-axis resolution, nm per step.
    pub nm_per_step: u32,
    /// The plant's spindle speed, milli-revolutions per second (the tooth delay).
    pub spindle_mrev_s: u32,
    /// Two-tooth periodic force (eq 4.19).
    pub periodic: bool,
    pub fault: SimForceFault,
    /// Penetration where `fault` starts, um.
    pub fault_at_um: u32,
}
