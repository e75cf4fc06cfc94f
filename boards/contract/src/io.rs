//! Machine inputs and outputs read and written every tick, and the e-stop interrupt line.

use motion::machine::Outputs;

/// Levels read in one tick, active levels resolved. Limits and e-stop raw: the machine debounces
/// them (`motion::machine::debounce`) with the configured time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RawInputs {
    /// The e-stop loop is open.
    pub estop: bool,
    /// Bit i = axis i's switch open (tripped).
    pub limit_min: u8,
    pub limit_max: u8,
    /// The wire-lag switch reports a stall (the wire controller debounces it itself).
    pub wire_stall: bool,
    /// The touch probe is triggered (in contact), raw: the machine debounces it and watches it
    /// during probe moves (G38.x).
    pub probe: bool,
}

pub trait MachineIo {
    /// The host may drive the inputs (`Sim(Inject)`; the simulated board).
    const SIM_INPUTS: bool;
    /// `write` drives the spindle direction and the mist and flood coolant outputs (a board
    /// whose pins for them are taken by another option does not: `SetProgramOutputs` is then
    /// refused as unsupported instead of reporting outputs nothing switches).
    const PROGRAM_OUTPUTS: bool;
    /// `write` drives a mist coolant output (M7); without one, `SetProgramOutputs` with mist on
    /// is refused as unsupported.
    const MIST: bool;
    /// Sets the simulated wire-stall switch; false where not honoured.
    fn inject_wire_stall(stalled: bool) -> bool;
    /// Every input, once per tick. Bounded, no division.
    fn read(&mut self) -> RawInputs;
    /// The machine's outputs (spindle enable and direction, mist, flood, wire power, Z DAC),
    /// once per tick.
    fn write(&mut self, outputs: &Outputs);
}

/// The e-stop's edge interrupt.
pub trait EStopLine {
    /// Acknowledges the interrupt; true if the e-stop line raised it.
    fn clear(&mut self) -> bool;
}
