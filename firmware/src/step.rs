//! The step port with the firmware's recorder: every output goes to the board's pins and into a
//! `StepRecorder` (counts, net direction, peak rates, a hash of every rising edge), so the
//! end-of-job report reads the same on hardware as under QEMU and in the host model.

use crate::board;
use board_contract::StepPort as _;
use motion::trace::StepRecorder;
use motion::StepOutput;

pub struct RecordedPort {
    port: board::StepPort,
    recorder: StepRecorder,
}

impl RecordedPort {
    pub const fn new(port: board::StepPort) -> Self {
        RecordedPort { port, recorder: StepRecorder::new() }
    }

    /// One tick's output to the pins, then into the recorder.
    #[inline(always)]
    pub fn apply(&mut self, now: u64, out: &StepOutput) {
        self.port.write(out);
        self.recorder.record(now, out);
    }

    pub fn enable(&mut self) {
        self.port.enable();
    }

    pub fn disable(&mut self) {
        self.port.disable();
    }

    pub fn recorder(&self) -> &StepRecorder {
        &self.recorder
    }
}
