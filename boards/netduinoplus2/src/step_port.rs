//! The step/dir "pins". QEMU does not model GPIO, so the port writes nothing; the firmware
//! records every output into a `StepRecorder` (step counts, net direction, peak rates, a hash
//! of every rising edge), as the host model does, so one hash compares whole runs.

use motion::StepOutput;

pub struct StepPort;

impl board_contract::StepPort for StepPort {
    /// Nothing to drive without pins.
    #[inline(always)]
    fn write(&mut self, _out: &StepOutput) {}

    /// Drivers on (nothing to do without pins).
    fn enable(&mut self) {}

    /// Puts the outputs in their safe state (nothing to do without pins).
    fn disable(&mut self) {}
}
