//! The link's side of the Z requests (`ZTableBegin`/`ZTableChunk`/`ZTableEnd`, `StartZ`), shared
//! by the link firmware and the host-side test targets: the upload's staging buffer
//! ([`ZRequests`], never touched by the tick), the NAKs for refused steps, and the Z fields of
//! `Status`. Setup-time code (divides where it reports rpm); nothing here runs in the tick.

use super::link_job::{
    LinkTable, ZJob, ZJobSpec, ZPrepared, ZStartError, ZTableError, ZTableHeader, ZTableUpload,
};
use crate::protocol::{ErrorCode, NakDetail, Status};

/// A refusal as the link sends it.
pub type ZNak = (ErrorCode, NakDetail);

/// The NAK for a refused upload step: `InvalidTable` with the reason and expected chunk.
pub fn table_nak(e: ZTableError) -> ZNak {
    let expected = match e {
        ZTableError::Sequence { expected } => Some(expected),
        _ => None,
    };
    (ErrorCode::InvalidTable, NakDetail::Turning { reason: e.code(), expected, fault: None })
}

/// The NAK for a refused start. `OutOfState` comes with `NakDetail::None`: the session fills
/// in the machine state.
pub fn start_nak(e: ZStartError) -> ZNak {
    match e {
        ZStartError::NoTable | ZStartError::Running => (ErrorCode::OutOfState, NakDetail::None),
        ZStartError::Spec | ZStartError::Config => (ErrorCode::OutOfRange, NakDetail::None),
        ZStartError::Fault(f) => (
            ErrorCode::OutOfRange,
            NakDetail::Turning { reason: 0, expected: None, fault: Some(f) },
        ),
    }
}

/// The upload staging buffer, a copy of the active table (so `StartZ` builds its generator
/// outside the tick's lock: [`ZRequests::prepare`]) and the request handlers. `job_active`: a Z
/// job runs or holds (the machine `runs(TURNING_JOB)`): every upload step is then refused with
/// `OutOfState`.
#[derive(Clone, Debug, Default)]
pub struct ZRequests {
    upload: ZTableUpload,
    active: LinkTable,
}

impl ZRequests {
    pub const fn new() -> Self {
        Self { upload: ZTableUpload::new(), active: LinkTable::None }
    }

    /// Records the table just installed in the job (after [`install`] succeeded).
    pub fn installed(&mut self, table: LinkTable) {
        self.active = table;
    }

    /// `StartZ`'s setup half, on the link's copy of the active table (divides, scans the table:
    /// outside the tick's lock). `speed`: the spindle speed the job last sensed.
    pub fn prepare(
        &self,
        spec: &ZJobSpec,
        tick_hz: u32,
        speed_turn_q32_per_tick: i32,
        job_active: bool,
    ) -> Result<ZPrepared, ZNak> {
        if job_active {
            return Err((ErrorCode::OutOfState, NakDetail::None));
        }
        ZJob::prepare(&self.active, spec, tick_hz, speed_turn_q32_per_tick).map_err(start_nak)
    }

    pub fn begin(&mut self, h: &ZTableHeader, job_active: bool) -> Result<(), ZNak> {
        if job_active {
            return Err((ErrorCode::OutOfState, NakDetail::None));
        }
        self.upload.begin(*h).map_err(table_nak)
    }

    pub fn chunk(&mut self, index: u16, bytes: &[u8], job_active: bool) -> Result<(), ZNak> {
        if job_active {
            return Err((ErrorCode::OutOfState, NakDetail::None));
        }
        self.upload.chunk(index, bytes).map_err(table_nak)
    }

    /// The checked table, for [`install`]. The upload is over either way.
    pub fn end(&mut self, crc: u32, job_active: bool) -> Result<LinkTable, ZNak> {
        if job_active {
            return Err((ErrorCode::OutOfState, NakDetail::None));
        }
        self.upload.end(crc).map_err(table_nak)
    }

    /// The chunk the open upload expects next.
    pub fn expected(&self) -> Option<u16> {
        self.upload.expected()
    }
}

/// Installs a checked table into the job (the last run, ended, is forgotten first).
pub fn install(job: &mut ZJob, table: LinkTable, job_active: bool) -> Result<(), ZNak> {
    if job_active {
        return Err((ErrorCode::OutOfState, NakDetail::None));
    }
    job.drop_run();
    job.install(table).map_err(start_nak)
}

/// Engages the job for `StartZ` (the caller then starts the machine's job with
/// `MachineCommand::StartSource(TURNING_JOB)`, and calls `ZJob::drop_run` if the machine refuses).
pub fn start(job: &mut ZJob, spec: &ZJobSpec, tick_hz: u32, job_active: bool) -> Result<(), ZNak> {
    if job_active {
        return Err((ErrorCode::OutOfState, NakDetail::None));
    }
    // The last run (ended) only kept its figures for Status.
    job.restart(spec, tick_hz).map_err(start_nak)
}

/// Begins a prepared run (inside the tick's lock: a few stores; the last run, ended, is
/// replaced). The caller then starts the machine's job, and drops the run if it refuses.
pub fn begin(job: &mut ZJob, p: ZPrepared, job_active: bool) -> Result<(), ZNak> {
    if job_active {
        return Err((ErrorCode::OutOfState, NakDetail::None));
    }
    job.rebegin(p).map_err(start_nak)
}

/// The Z fields of `Status` from the job (`tick_hz` for the rpm).
pub fn status(job: &ZJob, tick_hz: u32, s: &mut Status) {
    s.z_state = job.state_code();
    s.z_x_in_q24 = job.x_in_q24().unwrap_or(0);
    s.z_cmd_in_q32 = job.last().map_or(0, |u| u.z_in_q32);
    s.z_max_following_nin = job.max_following_nin();
    s.z_steps = job.steps().map_or(0, |(_, z)| z);
    s.z_dac_code = job.dac_code().unwrap_or(0);
    s.z_spindle_rpm_milli =
        crate::spindle::rpm_milli(job.sensed_speed_turn_q32_per_tick(), tick_hz);
}
