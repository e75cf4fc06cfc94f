//! A toy fifth capability, a rotary indexer: it turns axis 0 through `stations` equal steps of
//! `steps_per_station` steps, one step every `step_every_ticks` ticks, and dwells
//! `dwell_ticks` at each station. It lives in this folder only: its registry entry, its step
//! source and its scenario. The machine runs it by the rules every source job gets (faults,
//! e-stop freeze, hold, step counters, soft limits, job end) without naming it.

pub mod scenario;
pub mod source;

use motion::capability::Capability;
use motion::machine::SourceJob;

/// The indexer's source-job tag (no built-in capability uses it: `check` says so).
pub const INDEXER_JOB: SourceJob = SourceJob(100);

/// A `HelloInfo` bit no built-in capability uses.
pub const CAP_INDEXER_JOB: u32 = 1 << 24;

/// The indexer's registry entry.
pub const CAPABILITY: Capability = Capability {
    name: "indexer",
    title: "rotary indexer (toy): equal stations with a dwell at each",
    hello_bits: CAP_INDEXER_JOB,
    jobs: &[INDEXER_JOB],
    faults: &[],
};

/// The user's indexing job.
#[derive(Clone, Copy, Debug)]
pub struct IndexJob {
    pub stations: u32,
    pub steps_per_station: u32,
    pub step_every_ticks: u32,
    pub dwell_ticks: u32,
}

impl IndexJob {
    /// Steps the whole job makes.
    pub fn total_steps(&self) -> u64 {
        u64::from(self.stations) * u64::from(self.steps_per_station)
    }

    /// Ticks the whole job takes without a hold: each step waits its interval, each station
    /// its dwell (intervals of 0 run as 1).
    pub fn ticks_unheld(&self) -> u64 {
        self.total_steps() * u64::from(self.step_every_ticks.max(1))
            + u64::from(self.stations) * u64::from(self.dwell_ticks.max(1))
    }
}
