//! How a run goes: the operator's choices and the link's settings.

use crate::csv_log::CsvLog;
use motion::protocol::{HostConfig, MAX_SEGMENTS_PER_FRAME};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// The simulated probe surface a run sets up (`run --sim-probe`): the probe touches while
/// machine axis `axis` is at or below (`below`), or at or above, `at_mm` from the job's origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimProbe {
    pub axis: usize,
    pub at_mm: f64,
    pub below: bool,
}

/// Default status period: 25 Hz, so the stream stays at or above 20 Hz however it is counted.
pub const DEFAULT_STATUS_PERIOD_MS: u16 = 40;

pub struct RunOptions {
    /// Wait for Enter at a program pause; otherwise continue at once (and say so).
    pub interactive: bool,
    pub status_period_ms: u16,
    pub host: HostConfig,
    /// Most segments per `QueueSegments` (1..=4); fewer while the link is noisy.
    pub max_batch: usize,
    pub csv: Option<CsvLog>,
    pub progress: bool,
    /// Set by Ctrl-C: abort the board and stop.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// Home the board first if it is not homed (else such a board refuses the job).
    pub home: bool,
    /// Keep the run journal (the line executing, for `run --resume`).
    pub journal: Option<crate::journal::Writer>,
    /// A simulated board's probe surface, set before the job (`run --sim-probe`).
    pub sim_probe: Option<SimProbe>,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            interactive: false,
            status_period_ms: DEFAULT_STATUS_PERIOD_MS,
            host: HostConfig { rto_ms: 100, window: 8 },
            max_batch: MAX_SEGMENTS_PER_FRAME,
            csv: None,
            progress: false,
            interrupt: None,
            home: false,
            journal: None,
            sim_probe: None,
        }
    }
}
