//! Z-slide jobs on the link firmware (`motion::turning::link_job`): the table upload goes through
//! the link's [`ZRequests`] (staging buffer, never touched by the tick) into the [`ZJob`] in
//! [`Motion`] at `ZTableEnd`; `StartZ` engages the job and starts the machine's Z job
//! (`MachineCommand::StartSource(TURNING_JOB)`, the Start column) in one critical section;
//! every tick the board's spindle is read ([`sense`]: the sim spindle under QEMU, TIM4's
//! encoder on the F405) and, while the machine's Z job runs, the tick runs the job through
//! `Machine::tick_with` ([`tick`]) with the job's latched faults as sensor inputs, and drives
//! the DAC with the job's code.
//!
//! Interrupt rate ([`sense`], [`tick`]): integer only, no division, bounded (see
//! `motion::turning::link_job`). `StartZ` builds its generator (`ZGen::new`: divides and scans
//! the table, milliseconds on the F405) in the USART task on the link's copy of the active
//! table, outside the `Motion` lock; the lock only begins the prepared run.

mod requests;

use motion::dda::StepOutput;
use motion::machine::{Inputs, MachineCommand, TickOut};
use motion::protocol::{ErrorCode, NakDetail, Status};
use motion::spindle::encoder::EncoderConfig;
use motion::turning::link_job::{ZJob, ZPrepared};
use motion::turning::link_requests::{self as zr, ZNak};
use motion::turning::TURNING_JOB;

use motion::polar::copy_link::{TeachRecorder, TEACH_BLOCKS};

use super::link_job::{LinkJob, Readings, StepReadings};
use super::Motion;
use crate::board;
use board_contract::SpindleEncoder as _;

/// The spindle encoder both boards read (40 000 counts per revolution, the scenario's: the
/// board's fitted encoder), a 256-tick speed window, no index tolerance.
pub const ENCODER: EncoderConfig = motion::turning::scenario::encoder_config();

/// Configures the board's spindle encoder logic (init).
pub fn init(spindle: &mut board::Spindle) -> bool {
    spindle.configure(ENCODER).is_ok()
}

/// Once per tick, before the machine ticks: the spindle's counter into its decoder, its reading
/// into the job (angle and speed only on the ticks that use them: `ZJob::sense_from`).
/// Interrupt rate.
#[inline]
pub fn sense(spindle: &mut board::Spindle, job: &mut ZJob) {
    spindle.update();
    job.sense_from(spindle);
}

/// One tick with the machine's Z job (`None`: no Z job, the caller ticks as usual). The job's
/// fresh faults join the sensor inputs; a DAC job's code goes to `Outputs::z_dac`.
#[inline]
pub fn tick(m: &mut Motion, inputs: &Inputs) -> Option<TickOut> {
    if !m.machine.runs(TURNING_JOB) {
        return None;
    }
    let Motion { dda, machine, z, .. } = m;
    let inputs = Inputs { sensor_faults: inputs.sensor_faults | z.take_sensor_faults(), ..*inputs };
    let mut out = machine.tick_with(dda, &inputs, z);
    if let Some(code) = z.dac_code() {
        out.outputs.z_dac = code;
    }
    Some(out)
}

/// A step-only tick of a Z job (`Machine::fast_tick_with`), if the machine grants one: the
/// spindle read as on every tick, then the job's tick, counters and soft limits; `None`: run a
/// full tick (the spindle not read yet). Interrupt rate.
#[inline(always)]
pub fn step_only_tick(m: &mut Motion, spindle: &mut board::Spindle) -> Option<StepOutput> {
    if !m.machine.step_only_due() {
        return None;
    }
    sense(spindle, &mut m.z);
    m.machine.fast_tick_with(&mut m.dda, &mut m.z)
}

/// `ZTableEnd`'s install (inside the `Motion` lock).
pub fn install(m: &mut Motion, table: motion::turning::link_job::LinkTable) -> Result<(), ZNak> {
    let active = m.machine.runs(TURNING_JOB);
    zr::install(&mut m.z, table, active)
}

/// `StartZ`'s lock half: nothing else queued or armed, the prepared run begun (a few stores),
/// then the machine's job; a machine refusal drops the run again.
pub fn start(m: &mut Motion, plain_queue_empty: bool, p: ZPrepared) -> Result<(), ZNak> {
    if !plain_queue_empty || super::wire::live(m) {
        return Err((ErrorCode::OutOfState, NakDetail::None));
    }
    zr::begin(&mut m.z, p, m.machine.runs(TURNING_JOB))?;
    let Motion { dda, machine, z, .. } = m;
    if let Err(e) = machine.command(MachineCommand::StartSource(TURNING_JOB), dda) {
        z.drop_run();
        return Err((e.error_code(), NakDetail::None));
    }
    Ok(())
}

/// The Z fields of `Status`.
pub fn status(m: &Motion, s: &mut Status) {
    zr::status(&m.z, m.machine.config().link.machine.tick_hz, s);
}

/// The turning capability's link hooks.
pub struct Turning;

impl LinkJob for Turning {
    fn live(m: &Motion) -> bool {
        m.machine.runs(TURNING_JOB)
    }

    fn drop_job(m: &mut Motion) {
        m.z.drop_run();
    }

    fn status(m: &Motion, _teach: &TeachRecorder<TEACH_BLOCKS>, s: &mut Status) {
        status(m, s)
    }

    /// The spindle's decoder sees every tick, job or not.
    #[inline(always)]
    fn sense(m: &mut Motion, r: &mut Readings<'_>) {
        sense(r.spindle, &mut m.z)
    }

    #[inline(always)]
    fn tick(m: &mut Motion, r: &Readings<'_>) -> Option<TickOut> {
        tick(m, r.inputs)
    }

    #[inline(always)]
    fn step_only_tick(m: &mut Motion, b: &mut StepReadings<'_>) -> Option<StepOutput> {
        step_only_tick(m, b.spindle)
    }
}
