//! Setting a [`WireCore`] up (setup time) and what the link, Status and the tests read from it.

use super::{pos4, Kind, Phase, StallParams, StallStats, WireCore};
use crate::config::{ConfigError, MachineConfig};
use crate::dda::{Dda, Preparer};
use crate::machine::debounce::Debouncer;
use crate::protocol::errors::FaultCode;
use crate::wire::history::{History, Replay};
use heapless::Deque;

impl WireCore {
    /// A controller about to run a job from the DDA's position `[0; 4]` relative (positions it
    /// books are relative to where the job starts). Setup time (the preparer divides).
    pub fn new(cfg: &MachineConfig, params: StallParams) -> Result<Self, ConfigError> {
        Ok(WireCore {
            prep: Preparer::new(cfg)?,
            next_job: 0,
            in_flight: Deque::new(),
            pos: [0; 4],
            history: History::new(),
            replay: Replay::new(),
            // At least one sample: 0 behaves as 1 (follows the next sample).
            stall_in: Debouncer::new(params.debounce_ticks.max(1), false),
            stalled: false,
            phase: Phase::Running,
            wire_on: true,
            params,
            done_seen: 0,
            retraced_steps: 0,
            resume_left: 0,
            recovery_ids: 0,
            stats: StallStats::default(),
        })
    }

    /// Takes over `dda` as it stands (idle, its queue empty): the job's positions start at the
    /// DDA's current positions, and completions count from its current `segments_done`.
    pub fn attach(&mut self, dda: &Dda) {
        self.pos = pos4(dda.positions());
        self.done_seen = dda.segments_done();
    }

    /// The oldest job segment the controller may still ask its [`JobTable`] for: the first job
    /// segment in flight (a stall re-feeds the ones after it), else the next to feed. A stream
    /// may forget the segments before it.
    pub fn oldest_needed(&self) -> usize {
        self.in_flight
            .iter()
            .find_map(|f| match f.kind {
                Kind::Job(k) => Some(k as usize),
                _ => None,
            })
            .unwrap_or(self.next_job)
    }

    /// Job segments handed to the DDA so far (the index of the next one to feed).
    pub fn next_job(&self) -> usize {
        self.next_job
    }

    /// Nothing in flight and the DDA at rest (no segment of this controller is running).
    pub fn settled(&self, dda: &Dda) -> bool {
        self.in_flight.is_empty() && dda.is_idle()
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The wire power output: on while cutting, off from a stall until the return, and after
    /// a fault (e-stop included).
    pub fn wire_power(&self) -> bool {
        self.wire_on && !matches!(self.phase, Phase::Faulted(_) | Phase::Done)
    }

    pub fn fault_code(&self) -> Option<FaultCode> {
        match self.phase {
            Phase::Faulted(c) => Some(c),
            _ => None,
        }
    }

    pub fn is_finished(&self) -> bool {
        matches!(self.phase, Phase::Done | Phase::Faulted(_))
    }

    pub fn stats(&self) -> StallStats {
        self.stats
    }
}
