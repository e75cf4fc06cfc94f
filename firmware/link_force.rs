//! Constant-force milling jobs on the link firmware (`motion::force::link_job`, issue 4):
//! `ArmForce` makes a [`ForceJob`] in [`Motion`] for the next plain segment job; `Start` starts
//! the machine's job and the force loop in the same critical section; the tick runs the
//! machine through `motion::force::link_job::link_tick` (the job's latched force faults among
//! the sensor inputs, the controller's override into the DDA like `SetOverride`).
//!
//! Sample source: the simulator board (netduinoplus2 under QEMU, whose ADC values are fake)
//! samples the milling plant of the last `SimMilling` from the feed axis's position every
//! `tick_hz / sample_hz` ticks inside the tick. The real board's force ADC (TIM3-triggered
//! ADC1 scan, DMA2 stream 0) is not wired to the link yet, so it does not announce
//! `CAP_FORCE_JOB`: a force job without samples would feed at override 1.0 unguarded.

use motion::force::link_job::{self, ForceJob};
use motion::machine::{Inputs, MachineState, TickOut};
use motion::protocol::{ErrorCode, ForceJobParams, SimMillingParams, Status};

use super::Motion;

/// The board has a force sample source the link can run a force job from.
pub const HAS_FORCE_SOURCE: bool = cfg!(feature = "board-netduinoplus2");

/// The force job (the last one, for its telemetry, until the next `ArmForce`) and the
/// simulated plant the next one samples.
#[derive(Default)]
pub struct ForceSlot {
    pub job: Option<ForceJob>,
    pub sim: Option<SimMillingParams>,
}

/// The force job is armed or running.
pub fn live(m: &Motion) -> bool {
    m.force.job.as_ref().is_some_and(|j| j.is_live())
}

/// One tick with a running force job (`None`: none, the caller ticks as usual). Interrupt
/// rate: the machine's tick plus one plant sample, ADC conversion and chain sample every
/// `tick_hz / sample_hz` ticks and one control update every fifth of those; division-free.
#[inline]
pub fn tick(m: &mut Motion, inputs: &Inputs) -> Option<TickOut> {
    let Motion { dda, machine, force, .. } = m;
    let job = force.job.as_mut().filter(|j| j.is_running())?;
    Some(link_job::link_tick(machine, dda, inputs, job))
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
        || m.machine.events_queued()
        || m.machine.event_job()
        || wire_live
        || live(m)
        || !m.dda.is_idle();
    if m.machine.state() != MachineState::Ready || busy {
        return Err(ErrorCode::OutOfState);
    }
    let tick_hz = m.machine.config().wire.machine.tick_hz;
    let job =
        ForceJob::new(p, tick_hz, true, m.force.sim.as_ref()).map_err(|_| ErrorCode::OutOfRange)?;
    m.force.job = Some(job);
    Ok(())
}

/// `SimMilling`: the plant the next armed job samples (checked by the session).
pub fn set_sim(m: &mut Motion, p: &SimMillingParams) -> Result<(), ErrorCode> {
    if !HAS_FORCE_SOURCE {
        return Err(ErrorCode::Unsupported);
    }
    m.force.sim = Some(*p);
    Ok(())
}

/// An armed (not yet started) force job waits for this `Start`.
pub fn armed(m: &Motion) -> bool {
    m.force.job.as_ref().is_some_and(|j| j.is_armed())
}

/// After the machine accepted `Start`: the loop runs from the next tick, positions counted
/// from the feed axis's position now (same critical section as the start).
pub fn start(m: &mut Motion) {
    let Motion { machine, force, .. } = m;
    if let Some(j) = force.job.as_mut() {
        let pos = machine.positions().get(j.axis()).copied().unwrap_or(0);
        j.start(pos);
    }
}

/// The link dropped the job (Abort, ClearFault, SetConfig, Home).
pub fn drop_job(m: &mut Motion) {
    if let Some(j) = m.force.job.as_mut() {
        j.end();
    }
}

/// The force job's telemetry, into `s`.
pub fn status(m: &Motion, s: &mut Status) {
    if let Some(j) = m.force.job.as_ref() {
        let t = j.telemetry();
        s.force_mn = t.force_mn;
        s.force_peak_mn = t.peak_mn;
        s.force_override_bits = t.override_bits;
        s.force_phase = t.phase as u8;
        s.force_updates = t.updates;
    }
}
