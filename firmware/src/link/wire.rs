//! Wire-manipulator jobs on the link firmware (`motion::wire::link_job`): `ArmWire` makes a
//! [`WireJob`] in [`Motion`]; while it is live the host's `QueueSegments` go into it (after the
//! machine's `QueueSourceSegment` checks) instead of the link's plain queue, `Start` starts it
//! (`StartQueued(WIRE_JOB)`) and pre-feeds the DDA in the same critical section, the tick runs
//! it through `motion::wire::link_job::tick` (the machine's `tick_with`, the wire-stall switch,
//! the wire power output), and the feeder calls [`feed`] when the tick asks for it.
//!
//! The controller's feeding (segment preparation, and after a stall the abort and the retrace
//! planning) divides, so it runs in the feeder task, never in the tick; it runs inside the
//! `Motion` lock because the controller pushes straight into the DDA (a few microseconds per
//! segment: one `Preparer::prepare`, or one `Dda::abort` after a stop).

mod requests;

use motion::dda::StepOutput;
use motion::machine::{Inputs, MachineCommand, MachineState, TickOut};
use motion::protocol::{ErrorCode, Status};
use motion::segment::{Rate, Segment};
use motion::wire::controller::StallParams;
use motion::wire::link_job::{self, WireJob};
use motion::wire::link_messages::WireJobParams;
use motion::wire::WIRE_JOB;

use super::link_job::{LinkJob, Readings, StepReadings};
use super::{LastJob, Motion};
use board_contract::MachineIo as _;

/// The wire job is live (armed, or started and not yet ended).
pub fn live(m: &Motion) -> bool {
    m.job.wire().is_some_and(|w| w.is_live())
}

/// One tick with a live wire job (`None`: no wire job, the caller ticks as usual). Interrupt
/// rate: see `motion::wire::link_job::tick`.
#[inline]
pub fn tick(m: &mut Motion, inputs: &Inputs, wire_stall: bool) -> Option<TickOut> {
    let Motion { dda, machine, job, .. } = m;
    let w = job.wire_mut().filter(|w| w.is_live())?;
    Some(link_job::tick(machine, dda, inputs, w, wire_stall))
}

/// A step-only tick of a live wire job (`link_job::step_only_tick`), if the machine grants one;
/// `None`: run [`tick`]. Interrupt rate.
#[inline(always)]
pub fn step_only_tick(m: &mut Motion, wire_stall: bool) -> Option<StepOutput> {
    let Motion { dda, machine, job, .. } = m;
    link_job::step_only_tick(machine, dda, job.wire_mut()?, wire_stall)
}

/// The feeder has wire work (division-free; asked by the tick).
#[inline]
pub fn wants_feed(m: &Motion) -> bool {
    m.job.wire().is_some_and(|w| w.wants_feed(&m.dda))
}

/// The feeder's wire work (divides; control task). A refused segment cannot happen (every one
/// was checked when queued); it stops the job like an abort would.
pub fn feed(m: &mut Motion) {
    let Motion { dda, machine, job, .. } = m;
    let Some(w) = job.wire_mut() else { return };
    if w.feed(dda).is_err() {
        w.drop_job();
        let _ = machine.command(MachineCommand::Abort, dda);
    }
}

/// `ArmWire`: in `Ready` with nothing queued, no event job and no live wire job.
pub fn arm(m: &mut Motion, plain_queue_empty: bool, p: &WireJobParams) -> Result<(), ErrorCode> {
    let busy = !plain_queue_empty
        || m.machine.source_queued()
        || m.machine.source_job().is_some()
        || live(m)
        || !m.dda.is_idle();
    if m.machine.state() != MachineState::Ready || busy {
        return Err(ErrorCode::OutOfState);
    }
    let params = StallParams {
        debounce_ticks: p.debounce_ticks,
        retrace_limit_steps: p.retrace_limit_steps,
        retrace_override: Rate::from_bits(p.retrace_override_bits),
        resume_override: Rate::from_bits(p.resume_override_bits),
        resume_segments: p.resume_segments,
    };
    let cfg = m.machine.config().link.machine;
    let job = WireJob::new(&cfg, params, p.segments).map_err(|_| ErrorCode::InvalidConfig)?;
    m.job = LastJob::Wire(job);
    Ok(())
}

/// Free segment slots of the live wire job.
pub fn credits(m: &Motion) -> Option<u16> {
    m.job.wire().filter(|w| w.is_live()).map(|w| w.credits().min(u16::MAX as usize) as u16)
}

/// Queues one segment into the live wire job: the machine's checks first (a refusal changes
/// nothing), then the job's queue.
pub fn queue(m: &mut Motion, seg: &Segment) -> Result<MachineState, ErrorCode> {
    let Motion { dda, machine, job, .. } = m;
    let Some(w) = job.wire_mut().filter(|w| w.is_live()) else {
        return Err(ErrorCode::Internal);
    };
    if w.credits() == 0 {
        return Err(ErrorCode::QueueFull);
    }
    // The job's own check (four axes) before the machine's, so a refusal changes nothing.
    link_job::job_segment(seg).map_err(|_| ErrorCode::InvalidSegment)?;
    let state = machine
        .command(MachineCommand::QueueSourceSegment(seg), dda)
        .map_err(|e| e.error_code())?;
    w.queue(seg).map_err(|_| ErrorCode::Internal)?;
    Ok(state)
}

/// `Start` with a live wire job: the machine's `StartQueued(WIRE_JOB)`, then the first segments
/// into the DDA in the same critical section (the first tick of the job already moves).
pub fn start(m: &mut Motion) -> Result<(), ErrorCode> {
    let Motion { dda, machine, job, .. } = m;
    let Some(w) = job.wire_mut().filter(|w| w.is_live()) else {
        return Err(ErrorCode::Internal);
    };
    machine.command(MachineCommand::StartQueued(WIRE_JOB), dda).map_err(|e| e.error_code())?;
    if w.start(dda).is_err() {
        w.drop_job();
        let _ = machine.command(MachineCommand::Abort, dda);
        return Err(ErrorCode::Internal);
    }
    Ok(())
}

/// The link dropped the job (Abort, ClearFault, SetConfig, Home).
pub fn drop_job(m: &mut Motion) {
    if let Some(w) = m.job.wire_mut() {
        w.drop_job();
    }
}

/// The wire job's counters and the wire power output, into `s`.
pub fn status(m: &Motion, s: &mut Status) {
    if let Some(w) = m.job.wire() {
        let st = w.stats();
        s.wire_stalls = st.stalls;
        s.wire_retraces = st.retrace_segments;
        s.wire_returns = st.return_segments;
        s.wire_max_retrace_steps = st.max_retrace_steps;
        if w.is_live() {
            // The machine's plain-job count means nothing during a source job.
            s.queue_depth = w.queue_len().min(u16::MAX as usize) as u16;
        }
    }
    s.wire_power = m.machine.outputs().wire_power;
}

/// The wire capability's link hooks.
pub struct Wire;

impl LinkJob for Wire {
    super::link_job::job_hooks_from_module_fns!();

    #[inline(always)]
    fn tick(m: &mut Motion, r: &Readings<'_>) -> Option<TickOut> {
        tick(m, r.inputs, r.wire_stall)
    }

    /// The stall switch read for the job's retrace.
    #[inline(always)]
    fn step_only_tick(m: &mut Motion, b: &mut StepReadings<'_>) -> Option<StepOutput> {
        let stall = b.io.read().wire_stall;
        step_only_tick(m, stall)
    }
}
