//! Constant-force milling jobs on the link firmware (`motion::milling::link_job`):
//! `ArmForce` makes a [`ForceJob`] in [`Motion`] for the next plain segment job; `Start` starts
//! the machine's job and the force loop in the same critical section; the tick runs the
//! machine through `motion::milling::link_job::link_tick_deferred` (the job's latched force
//! faults among the sensor inputs); the force interrupt puts the controller's override into the
//! DDA like `SetOverride`.
//!
//! Sample source: the simulator board (netduinoplus2 under QEMU, whose ADC values are fake)
//! samples the milling plant of the last `Sim(Milling)` (`super::sim`) from the feed axis's
//! position every `tick_hz / sample_hz` ticks: the tick counts down and pends the force
//! interrupt ([`on_sim_sample`]), which runs right after it. The real board (f405-motion)
//! samples its force sensors with the TIM3-triggered ADC1 scan into the DMA2 stream 0 double
//! buffer at [`ADC_SAMPLE_HZ`]; the `DMA2_STREAM0` interrupt (priority 3, the tick's: they
//! never preempt each other) hands each half buffer (`DECIMATION` frames = one control update)
//! to [`on_adc_frames`]: the chain per frame, the control law once, the override into the DDA.

mod requests;

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};
use motion::dda::{Command, StepOutput};
use motion::machine::{Inputs, MachineState, TickOut};
use motion::milling::link_job::{self, mrev_s_from_turn_q32_per_tick, ForceJob};
use motion::milling::link_params::ForceJobParams;
use motion::protocol::{ErrorCode, FaultCode, SimMillingParams, Status};

use super::link_job::{LinkJob, Readings, StepReadings};
use super::{LastJob, Motion};

/// The board has a force sample source the link can run a force job from: the simulator's
/// plant, or the real board's force ADC (a job is refused while [`ADC_SAMPLE_HZ`] is 0).
pub const HAS_FORCE_SOURCE: bool = true;
/// The simulator board samples its plant from the tick; the real board's ADC interrupt samples.
pub const TICK_SAMPLED: bool = crate::board::SIMULATED;
/// Rate the real board's force ADC was started at (0: not running); a job's `sample_hz` must be
/// this. Written once at init.
pub static ADC_SAMPLE_HZ: AtomicU32 = AtomicU32::new(0);
/// Rate the real board starts its force ADC at: the chain's 10 kHz (2 kHz control).
pub const ADC_START_HZ: u32 = 10_000;

/// The simulated plant the next force job samples (the job itself is in [`Motion::job`]).
#[derive(Default)]
pub struct ForceSlot {
    pub sim: Option<SimMillingParams>,
}

/// The force job is armed or running.
pub fn live(m: &Motion) -> bool {
    m.job.force().is_some_and(|j| j.is_live())
}

/// One tick with a running force job (`None`: none, the caller ticks as usual). Interrupt
/// rate: the machine's tick plus the sample countdown; on the ticks a sample is due it pends
/// the force interrupt. Division-free.
#[inline]
pub fn tick(m: &mut Motion, inputs: &Inputs) -> Option<TickOut> {
    let Motion { dda, machine, job, .. } = m;
    let job = job.force_mut().filter(|j| j.is_running())?;
    let (out, due) = link_job::link_tick_deferred(machine, dda, inputs, job);
    if due {
        pend_sample();
    }
    Some(out)
}

/// A step-only tick of a running force job (`link_job::link_step_only_deferred`: the DDA,
/// counters, soft limits and the sample countdown), if the machine grants one; `None`: run
/// [`tick`] (the spindle not read yet). The spindle is read as on every tick: the job's
/// spindle-stop check uses its speed. Interrupt rate.
#[inline(always)]
pub fn step_only_tick(m: &mut Motion, spindle: &mut crate::board::Spindle) -> Option<StepOutput> {
    if !m.machine.step_only_due() || !m.job.force().is_some_and(|j| j.is_running()) {
        return None;
    }
    super::turning::sense(spindle, &mut m.z);
    let Motion { dda, machine, job, .. } = m;
    let (step, due) = link_job::link_step_only_deferred(machine, dda, job.force_mut()?)?;
    if due {
        pend_sample();
    }
    Some(step)
}

/// The sample runs in the force interrupt, after this tick and before the next (the real
/// board's ADC DMA interrupt, at the tick's priority): the tick stays short.
#[inline(always)]
fn pend_sample() {
    SAMPLE_DUE.store(true, Relaxed);
    rtic::pend(crate::board::FORCE_IRQ);
}

/// A simulator board's plant sample is due ([`tick`] pended the force interrupt).
static SAMPLE_DUE: AtomicBool = AtomicBool::new(false);

/// The force interrupt on a simulator board: the plant sample the tick pended, the chain, the
/// control law at its rate, the override into the DDA. Division-free, bounded.
pub fn on_sim_sample(m: &mut Motion) {
    if !SAMPLE_DUE.swap(false, Relaxed) {
        return;
    }
    let Motion { dda, machine, job, .. } = m;
    if let Some(job) = job.force_mut().filter(|j| j.is_running()) {
        link_job::link_sample(machine, dda, job);
    }
}

/// `ArmForce`: in `Ready` with nothing queued, no event or wire job and no live force job.
/// A sample rate the tick cannot pace -> `OutOfRange` (the session names `sample_hz`).
pub fn arm(
    m: &mut Motion,
    plain_queue_empty: bool,
    wire_live: bool,
    p: &ForceJobParams,
) -> Result<(), ErrorCode> {
    if !HAS_FORCE_SOURCE {
        return Err(ErrorCode::Unsupported);
    }
    let busy = !plain_queue_empty
        || m.machine.source_queued()
        || m.machine.source_job().is_some()
        || wire_live
        || live(m)
        || !m.dda.is_idle();
    if m.machine.state() != MachineState::Ready || busy {
        return Err(ErrorCode::OutOfState);
    }
    if !TICK_SAMPLED {
        match ADC_SAMPLE_HZ.load(Relaxed) {
            0 => return Err(ErrorCode::Unsupported),
            hz if hz != p.sample_hz => return Err(ErrorCode::OutOfRange),
            _ => {}
        }
    }
    let tick_hz = m.machine.config().link.machine.tick_hz;
    let job = ForceJob::new(p, tick_hz, TICK_SAMPLED, m.milling.sim.as_ref())
        .map_err(|_| ErrorCode::OutOfRange)?;
    m.job = LastJob::Force(job);
    Ok(())
}

/// An armed (not yet started) force job waits for this `Start`.
pub fn armed(m: &Motion) -> bool {
    m.job.force().is_some_and(|j| j.is_armed())
}

/// After the machine accepted `Start`: the loop runs from the next tick, positions counted
/// from the feed axis's position now (same critical section as the start).
pub fn start(m: &mut Motion) {
    let Motion { machine, job, .. } = m;
    if let Some(j) = job.force_mut() {
        let pos = machine.positions().get(j.axis()).copied().unwrap_or(0);
        j.start(pos);
    }
}

/// The link dropped the job (Abort, ClearFault, SetConfig, Home).
pub fn drop_job(m: &mut Motion) {
    if let Some(j) = m.job.force_mut() {
        j.end();
    }
}

/// The force job's telemetry, into `s`.
pub fn status(m: &Motion, s: &mut Status) {
    if let Some(j) = m.job.force() {
        j.telemetry().write_status(s);
    }
}

/// The real board's `DMA2_STREAM0` interrupt: one half buffer of force frames (`None`: a
/// spurious interrupt, or the ADC/DMA overran: `overrun`), through the running job's chain per
/// frame and control law per `DECIMATION` frames; the override goes to the DDA like
/// `SetOverride`, an overrun latches `SensorFault`. Interrupt rate: `DECIMATION` chain samples
/// and one control update; division-free, bounded (the frames slice is one half buffer).
#[inline]
pub fn on_adc_frames<const N: usize>(m: &mut Motion, frames: Option<&[[u16; N]]>, overrun: bool) {
    let Motion { dda, machine, job, z, .. } = m;
    let Some(job) = job.force_mut().filter(|j| j.is_running()) else { return };
    if overrun {
        job.source_fault(FaultCode::SensorFault);
        return;
    }
    // The spindle encoder, read every tick (`turning::sense`), gives the speed: a stopped
    // spindle holds the feed with `SpindleStopped`.
    let tick_hz = machine.config().link.machine.tick_hz;
    job.set_spindle_mrev_s(mrev_s_from_turn_q32_per_tick(
        z.sensed_speed_turn_q32_per_tick(),
        tick_hz,
    ));
    let pos = machine.positions().get(job.axis()).copied().unwrap_or(0);
    for f in frames.unwrap_or(&[]) {
        // Fx, Fy, Fz: the first three force channels.
        let counts = [
            f.first().copied().unwrap_or(0),
            f.get(1).copied().unwrap_or(0),
            f.get(2).copied().unwrap_or(0),
        ];
        if let Some(rate) = job.sample(&counts, pos).set_override {
            dda.apply(Command::CapabilityOverride(rate));
        }
    }
}

/// The milling capability's link hooks.
pub struct Milling;

impl LinkJob for Milling {
    super::link_job::job_hooks_from_module_fns!();

    #[inline(always)]
    fn tick(m: &mut Motion, r: &Readings<'_>) -> Option<TickOut> {
        tick(m, r.inputs)
    }

    #[inline(always)]
    fn step_only_tick(m: &mut Motion, b: &mut StepReadings<'_>) -> Option<StepOutput> {
        step_only_tick(m, b.spindle)
    }
}
