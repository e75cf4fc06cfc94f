//! The link firmware's entry points around the machine's tick (full, deferred, step-only) and
//! the sample they pend, with the spindle-speed conversion the sample needs.

use super::ForceJob;
use crate::dda::{Command, Dda, StepOutput};
use crate::machine::{Inputs, Machine, MachineState, TickOut};
use crate::milling::link_params::ForcePhase;

use crate::milling::control::Mode;

/// Milli-revolutions per second (the force job's spindle unit) from a spindle speed in turns
/// (Q32) per tick at `tick_hz` (the spindle sources' unit), rounded; the direction is dropped.
/// Multiply and shift only (u64, saturating): it runs at sample rate.
#[inline]
pub fn mrev_s_from_turn_q32_per_tick(speed_turn_q32_per_tick: i32, tick_hz: u32) -> u32 {
    let per_s_q32 = (speed_turn_q32_per_tick.unsigned_abs() as u64)
        .saturating_mul(tick_hz as u64 * MILLI_PER_UNIT);
    (per_s_q32.saturating_add(HALF_Q32) >> 32).min(u32::MAX as u64) as u32
}

const MILLI_PER_UNIT: u64 = 1000;
const HALF_Q32: u64 = 1 << 31;

/// One link-firmware tick with a force job on a tick-sampled (simulator) board: the machine's
/// tick with the job's latched force faults among the sensor inputs, then the job's sample at
/// the feed axis's new position, whose override goes to the DDA the way `SetOverride` does
/// (the machine's holds and fault freeze stay in charge: a held or frozen DDA does not move
/// whatever the override). A force fault reaches the machine on the next tick (one tick of
/// latency). The job runs while the machine runs or holds the job, and ends with it.
/// Division-free, bounded: the machine's tick plus [`ForceJob::sample_sim`].
#[inline]
pub fn link_tick(
    machine: &mut Machine,
    dda: &mut Dda,
    inputs: &Inputs,
    job: &mut ForceJob,
) -> TickOut {
    let (out, due) = link_tick_deferred(machine, dda, inputs, job);
    if due {
        link_sample(machine, dda, job);
    }
    out
}

/// [`link_tick`] without the plant sample: the machine's tick and the sample countdown; true
/// when a sample is due, for [`link_sample`] to take right after this tick and before the next
/// (the simulator board's stand-in for the real board's ADC interrupt, so the tick interrupt
/// stays short and the sample sees the same positions as in [`link_tick`]).
#[inline]
pub fn link_tick_deferred(
    machine: &mut Machine,
    dda: &mut Dda,
    inputs: &Inputs,
    job: &mut ForceJob,
) -> (TickOut, bool) {
    let mut inp = *inputs;
    if job.is_running() {
        inp.sensor_faults |= job.fault_bits;
    }
    let out = machine.tick(dda, &inp);
    let mut due = false;
    if job.is_running() {
        if matches!(machine.state(), MachineState::Running | MachineState::Holding) {
            due = job.sample_due();
        } else {
            job.end();
        }
    }
    (out, due)
}

/// A step-only tick of a force job ([`Machine::fast_tick`]), if the machine grants one: the
/// DDA, the counters, the soft limits and the sample countdown (true: a sample is due, as from
/// [`link_tick_deferred`]). `None`: run [`link_tick_deferred`]. The machine grants none while
/// the job has a force fault latched (its bits are sensor inputs of the full tick), so a fault
/// found by a sample reaches the machine on the next full tick, at most
/// `SUPERVISE_TICKS - 1` ticks later; the job's end is seen there too.
#[inline(always)]
pub fn link_step_only_deferred(
    machine: &mut Machine,
    dda: &mut Dda,
    job: &mut ForceJob,
) -> Option<(StepOutput, bool)> {
    if !job.is_running() {
        return None;
    }
    let step = machine.fast_tick(dda)?;
    // A soft limit crossed on this tick faulted the machine: the next full tick ends the job.
    let due = matches!(machine.state(), MachineState::Running | MachineState::Holding)
        && job.sample_due();
    Some((step, due))
}

/// The plant sample [`link_tick_deferred`] said is due: the chain, the control law at its rate,
/// the override into the DDA.
pub fn link_sample(machine: &Machine, dda: &mut Dda, job: &mut ForceJob) {
    let pos = machine.positions().get(job.axis).copied().unwrap_or(0);
    let t = job.sample_sim(pos);
    if let Some(rate) = t.set_override {
        dda.apply(Command::CapabilityOverride(rate));
    }
}

/// The status phase of a controller mode.
pub fn phase_of(m: Mode) -> ForcePhase {
    match m {
        Mode::Tare(_) => ForcePhase::Tare,
        Mode::Air => ForcePhase::Air,
        Mode::ContactSlow(_) => ForcePhase::ContactSlow,
        Mode::ContactStop(_) => ForcePhase::ContactStop,
        Mode::Reduced(_) => ForcePhase::Reduced,
        Mode::Cutting => ForcePhase::Cutting,
        Mode::Faulted(_) => ForcePhase::Faulted,
    }
}
