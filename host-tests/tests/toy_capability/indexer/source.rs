//! The indexer's step source: a countdown per step and per dwell, integer only, bounded.

use motion::dda::{Dda, StepOutput};
use motion::machine::StepSource;

use super::IndexJob;

/// Axis 0 in the STEP and DIR-write masks (DIR low: the positive direction).
const AXIS0: u8 = 1;

/// Where the indexer is in its job.
#[derive(Clone, Copy, Debug)]
pub struct Indexer {
    job: IndexJob,
    station: u32,
    steps_left: u32,
    wait_ticks: u32,
    dwelling: bool,
    /// A STEP went high on the last tick: it falls on this one.
    high: bool,
    first: bool,
}

impl Indexer {
    /// Intervals of 0 ticks run as 1.
    pub fn new(mut job: IndexJob) -> Self {
        job.step_every_ticks = job.step_every_ticks.max(1);
        job.dwell_ticks = job.dwell_ticks.max(1);
        Indexer {
            job,
            station: 0,
            steps_left: job.steps_per_station,
            wait_ticks: job.step_every_ticks,
            dwelling: false,
            high: false,
            first: true,
        }
    }

    /// Stations finished.
    pub fn stations_done(&self) -> u32 {
        self.station
    }

    fn done(&self) -> bool {
        self.station >= self.job.stations
    }
}

impl StepSource for Indexer {
    fn tick(&mut self, dda: &mut Dda, hold: bool) -> StepOutput {
        // The idle DDA keeps the machine's clock.
        let _ = dda.tick();
        let fall = if self.high { AXIS0 } else { 0 };
        self.high = false;
        // DIR (low: positive) written once, before the first step.
        let dir_write = if self.first { AXIS0 } else { 0 };
        self.first = false;
        if hold || self.done() {
            return StepOutput::new(fall, dir_write, 0, 0);
        }
        self.wait_ticks = self.wait_ticks.saturating_sub(1);
        if self.wait_ticks > 0 {
            return StepOutput::new(fall, dir_write, 0, 0);
        }
        if self.dwelling {
            self.dwelling = false;
            self.station += 1;
            self.steps_left = self.job.steps_per_station;
            self.wait_ticks = self.job.step_every_ticks;
            return StepOutput::new(fall, dir_write, 0, 0);
        }
        self.steps_left -= 1;
        self.high = true;
        if self.steps_left == 0 {
            self.dwelling = true;
            self.wait_ticks = self.job.dwell_ticks;
        } else {
            self.wait_ticks = self.job.step_every_ticks;
        }
        StepOutput::new(fall, dir_write, 0, AXIS0)
    }

    fn idle(&self, _dda: &Dda) -> bool {
        self.done() && !self.high
    }
}
