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
    /// Who vouches that a machine without switches stands at machine zero when it is homed.
    pub zero_here: ZeroHere,
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
            zero_here: ZeroHere::Simulated,
            journal: None,
            sim_probe: None,
        }
    }
}

/// Homing a machine without switches takes the axes where they stand as machine zero: who
/// vouches that they stand there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZeroHere {
    /// A simulated machine (the simulator, QEMU) starts at its zero: nothing to ask.
    Simulated,
    /// The operator said so on the command line (`--yes`).
    Confirmed,
    /// Ask the operator on the terminal.
    Ask,
    /// No terminal to ask on and no `--yes`: refuse.
    Refuse,
}

impl ZeroHere {
    /// The choice for a run: a simulated board needs no one, else `--yes`, else the terminal.
    pub fn for_run(simulated: bool, yes: bool, terminal: bool) -> ZeroHere {
        match (simulated, yes, terminal) {
            (true, _, _) => ZeroHere::Simulated,
            (false, true, _) => ZeroHere::Confirmed,
            (false, false, true) => ZeroHere::Ask,
            (false, false, false) => ZeroHere::Refuse,
        }
    }

    /// Whether the axes stand at machine zero; `why` says what homing will do. Asks on the
    /// terminal (stderr, one line from stdin: `yes` or `y`) for `Ask`.
    pub fn confirm(self, why: &str) -> bool {
        match self {
            ZeroHere::Simulated | ZeroHere::Confirmed => true,
            ZeroHere::Refuse => false,
            ZeroHere::Ask => {
                eprint!("motionctl: {why}. Are the axes at machine zero? Type yes to home here: ");
                let mut answer = String::new();
                std::io::stdin().read_line(&mut answer).is_ok() && is_yes(&answer)
            }
        }
    }
}

fn is_yes(answer: &str) -> bool {
    matches!(answer.trim().to_ascii_lowercase().as_str(), "yes" | "y")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_simulated_board_or_the_operator_vouches_for_the_zero() {
        assert_eq!(ZeroHere::for_run(true, false, false), ZeroHere::Simulated);
        assert_eq!(ZeroHere::for_run(false, true, false), ZeroHere::Confirmed);
        assert_eq!(ZeroHere::for_run(false, false, true), ZeroHere::Ask);
        assert_eq!(ZeroHere::for_run(false, false, false), ZeroHere::Refuse);
        assert!(!ZeroHere::Refuse.confirm("x"));
        assert!(ZeroHere::Confirmed.confirm("x"));
        assert!(is_yes(" Yes\n") && is_yes("y") && !is_yes("") && !is_yes("no"));
    }
}
