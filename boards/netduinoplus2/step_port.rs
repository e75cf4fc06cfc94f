//! The step/dir "pins". QEMU does not model GPIO, so the port records every output into a
//! [`StepRecorder`]: step counts, net direction, peak rates and a hash of every rising edge. The
//! host model records the same DDA outputs the same way, so one hash compares whole runs.

use motion::trace::StepRecorder;
use motion::StepOutput;

pub struct StepPort {
    recorder: StepRecorder,
}

impl StepPort {
    pub const fn new() -> Self {
        StepPort { recorder: StepRecorder::new() }
    }

    /// Drivers on (nothing to do without pins).
    pub fn enable(&mut self) {}

    /// Puts the outputs in their safe state (nothing to do without pins).
    pub fn disable(&mut self) {}

    /// Applies one tick's output: falling edges, DIR writes, rising edges.
    #[inline(always)]
    pub fn apply(&mut self, now: u64, out: &StepOutput) {
        self.recorder.record(now, out);
    }

    // The link firmware reports positions from the machine's counters, not the recorder.
    #[cfg_attr(feature = "link", allow(dead_code))]
    pub fn recorder(&self) -> &StepRecorder {
        &self.recorder
    }
}
