//! [`WireController`]: the retrace controller with a DDA and a constant job of its own.

use super::{Phase, StallParams, StallStats, WireCore};
use crate::config::{ConfigError, MachineConfig};
use crate::dda::{Dda, StepOutput};
use crate::protocol::errors::FaultCode;
use crate::segment::SegmentError;
use crate::wire::job::JobSegment;

/// [`WireCore`] with a DDA and a constant job of its own (the scenarios and their tests).
pub struct WireController<'a> {
    dda: Dda,
    core: WireCore,
    job: &'a [JobSegment],
}

impl<'a> WireController<'a> {
    pub fn new(
        cfg: &MachineConfig,
        job: &'a [JobSegment],
        params: StallParams,
    ) -> Result<Self, ConfigError> {
        Ok(WireController { dda: Dda::new(cfg)?, core: WireCore::new(cfg, params)?, job })
    }

    /// Timer interrupt: see [`WireCore::tick`].
    #[inline]
    pub fn tick(&mut self, stall_raw: bool, estop_raw: bool) -> StepOutput {
        self.core.tick(&mut self.dda, self.job, stall_raw, estop_raw)
    }

    /// See [`WireCore::wants_feed`].
    pub fn wants_feed(&self) -> bool {
        self.core.wants_feed(&self.dda, self.job)
    }

    /// Feeder task: see [`WireCore::feed`].
    pub fn feed(&mut self) -> Result<(), SegmentError> {
        self.core.feed(&mut self.dda, self.job)
    }

    pub fn phase(&self) -> Phase {
        self.core.phase()
    }

    /// See [`WireCore::wire_power`].
    pub fn wire_power(&self) -> bool {
        self.core.wire_power()
    }

    pub fn fault_code(&self) -> Option<FaultCode> {
        self.core.fault_code()
    }

    pub fn is_finished(&self) -> bool {
        self.core.is_finished()
    }

    pub fn dda(&self) -> &Dda {
        &self.dda
    }

    pub fn stats(&self) -> StallStats {
        self.core.stats()
    }

    /// Absolute position the job ends at, relative to where it started.
    pub fn job_end(&self) -> [i64; 4] {
        crate::wire::job::total_steps(self.job)
    }
}
