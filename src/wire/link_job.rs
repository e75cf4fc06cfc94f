//! A wire job streamed over the host link: the host's segments wait in a [`WireQueue`] and run
//! through the retrace controller ([`WireCore`]) on the link's own DDA, under the one
//! [`Machine`] (fault inputs, e-stop freeze, counters, soft limits, job end) through
//! [`Machine::tick_with`], like an event job.
//!
//! Life cycle (the machine's table): `Machine::command(QueueSourceSegment)` admits each segment (Queue
//! column: segment and soft-limit checks), [`WireJob::queue`] keeps it; `StartQueued(WIRE_JOB)` (Start
//! column) starts the job and [`WireJob::start`] takes over the DDA and pre-feeds it in the same
//! critical section. The tick calls [`tick`]; the feeder calls [`WireJob::feed`] whenever
//! [`WireJob::wants_feed`]. The job ends (Running -> Ready) when the controller is `Done`.
//!
//! Faults: a stall that persists through the retrace distance makes the controller fault
//! `WireStall`; [`tick`] hands that to the machine once as a sensor fault (its Hold reaction;
//! the controller already stopped), so `ClearFault` is not blocked by a cause that stays
//! active. Every machine fault (e-stop's Kill included) ends the job: the machine freezes and
//! aborts the DDA, and [`tick`] switches the wire power off while the machine is not `Running`.
//! A late host (the next segment not queued when the controller needs it) is the source's
//! `starved`: `QueueUnderrun`.

use super::controller::{JobTable, Phase, StallParams, StallStats, WireCore};
use super::job::JobSegment;
use crate::config::{ConfigError, MachineConfig, MAX_AXES};
use crate::dda::{Dda, StepOutput};
use crate::machine::{Inputs, Machine, MachineState, Outputs, StepSource, TickOut};
use crate::protocol::FaultCode;
use crate::segment::{Segment, SegmentError};

/// Segments a wire job may hold: those the host queued ahead plus those fed but not yet
/// completed (a stall re-feeds them). A power of two (the ring index is masked, no `%`).
pub const WIRE_QUEUE: usize = 64;
const MASK: usize = WIRE_QUEUE - 1;

/// The job's segments from the oldest one the controller may still need to the newest the host
/// sent, as a ring indexed by job segment number.
#[derive(Clone, Debug)]
pub struct WireQueue {
    buf: [JobSegment; WIRE_QUEUE],
    /// Job index of the oldest held segment and the ring slot it is in.
    base: usize,
    head: usize,
    len: usize,
    /// Segments the job has in all.
    total: usize,
}

impl WireQueue {
    /// An empty queue for a job of `total` segments.
    pub const fn new(total: u32) -> Self {
        const Z: JobSegment = super::job::seg(0, 0, 0, 0, 1, 0, 0, 1);
        WireQueue { buf: [Z; WIRE_QUEUE], base: 0, head: 0, len: 0, total: total as usize }
    }

    /// Appends the job's next segment; false (nothing changes) when full or when the job has
    /// all its segments.
    pub fn push(&mut self, s: JobSegment) -> bool {
        if self.len >= WIRE_QUEUE || self.base + self.len >= self.total {
            return false;
        }
        let slot = (self.head + self.len) & MASK;
        if let Some(b) = self.buf.get_mut(slot) {
            *b = s;
        }
        self.len += 1;
        true
    }

    /// Forgets the segments before job index `k`.
    pub fn trim(&mut self, k: usize) {
        while self.base < k && self.len > 0 {
            self.base += 1;
            self.head = (self.head + 1) & MASK;
            self.len -= 1;
        }
    }

    /// Free slots (the link's credits for a wire job).
    pub fn free(&self) -> usize {
        WIRE_QUEUE - self.len
    }

    /// Segments received so far.
    pub fn received(&self) -> usize {
        self.base + self.len
    }

    pub fn total(&self) -> usize {
        self.total
    }
}

impl JobTable for WireQueue {
    #[inline]
    fn segment(&self, k: usize) -> Option<JobSegment> {
        let i = k.checked_sub(self.base).filter(|&i| i < self.len)?;
        self.buf.get((self.head + i) & MASK).copied()
    }

    #[inline]
    fn ended(&self, k: usize) -> bool {
        k >= self.total
    }
}

/// A host segment as a wire job segment: the four wire axes only.
pub fn job_segment(seg: &Segment) -> Result<JobSegment, SegmentError> {
    if let Some(a) = seg.steps.iter().skip(4).position(|&s| s != 0) {
        return Err(SegmentError::UnusedAxis { axis: (a + 4).min(MAX_AXES) as u8 });
    }
    let s = &seg.steps;
    Ok(super::job::seg(
        s[0],
        s[1],
        s[2],
        s[3],
        seg.duration_ticks,
        seg.entry_rate.to_bits(),
        seg.exit_rate.to_bits(),
        seg.accel_per_tick.to_bits(),
    ))
}

/// The wire job of the link firmware: the controller and the job's segments.
#[derive(Clone, Debug)]
pub struct WireJob {
    core: WireCore,
    queue: WireQueue,
    /// The job was started and has not been seen ending yet.
    live: bool,
    started: bool,
    /// The machine holds (feed hold or a hold reaction): no recovery move may start.
    paused: bool,
    /// The controller needs a segment the host has not sent (set by the tick).
    starved: bool,
    /// The controller's fault was handed to the machine.
    fault_reported: bool,
}

impl WireJob {
    /// A job of `total` segments with stall handling `params`, for machine config `cfg`.
    /// Setup time (the preparer divides).
    pub fn new(cfg: &MachineConfig, params: StallParams, total: u32) -> Result<Self, ConfigError> {
        Ok(WireJob {
            core: WireCore::new(cfg, params)?,
            queue: WireQueue::new(total),
            live: true,
            started: false,
            paused: false,
            starved: false,
            fault_reported: false,
        })
    }

    /// Keeps an admitted segment (the caller ran `MachineCommand::QueueSourceSegment` first).
    pub fn queue(&mut self, seg: &Segment) -> Result<(), SegmentError> {
        let js = job_segment(seg)?;
        if self.queue.push(js) {
            Ok(())
        } else {
            // The link counts credits first: only a job with all its segments gets here.
            Err(SegmentError::Duration)
        }
    }

    /// Free segment slots.
    pub fn credits(&self) -> usize {
        self.queue.free()
    }

    /// The job started (the caller ran `MachineCommand::StartQueued(crate::wire::WIRE_JOB)`): takes over the idle DDA
    /// and feeds it, so the first tick already moves. Control-task code (divides).
    pub fn start(&mut self, dda: &mut Dda) -> Result<(), SegmentError> {
        self.core.attach(dda);
        self.started = true;
        self.feed(dda)
    }

    /// Feeder work is due (cheap, division-free: asked by the tick).
    pub fn wants_feed(&self, dda: &Dda) -> bool {
        self.live && self.started && !self.paused && self.core.wants_feed(dda, &self.queue)
    }

    /// The feeder's work: forget completed segments, then feed or plan the next recovery move.
    pub fn feed(&mut self, dda: &mut Dda) -> Result<(), SegmentError> {
        if !self.live || self.paused {
            return Ok(());
        }
        self.queue.trim(self.core.oldest_needed());
        self.core.feed(dda, &self.queue)
    }

    /// The job runs or waits to run (armed, started and not yet ended).
    pub fn is_live(&self) -> bool {
        self.live
    }

    pub fn phase(&self) -> Phase {
        self.core.phase()
    }

    pub fn stats(&self) -> StallStats {
        self.core.stats()
    }

    pub fn queue_len(&self) -> usize {
        WIRE_QUEUE - self.queue.free()
    }

    /// Segments completed or running (the controller's next job index) and the job's total.
    pub fn progress(&self) -> (usize, usize) {
        (self.core.next_job(), self.queue.total())
    }

    /// The controller wants the wire power on.
    pub fn wire_power(&self) -> bool {
        self.live && self.started && self.core.wire_power()
    }

    /// Ends the job (the link dropped it: Abort, ClearFault, SetConfig, Home).
    pub fn drop_job(&mut self) {
        self.live = false;
    }
}

/// The wire job as the machine's step source for one tick.
struct Source<'a> {
    job: &'a mut WireJob,
    stall_raw: bool,
}

impl StepSource for Source<'_> {
    #[inline]
    fn tick(&mut self, dda: &mut Dda, hold: bool) -> StepOutput {
        let j = &mut *self.job;
        j.paused = hold;
        let out = j.core.tick(dda, &j.queue, self.stall_raw, false);
        let next = j.core.next_job();
        j.starved = j.core.phase() == Phase::Running
            && j.core.settled(dda)
            && j.queue.segment(next).is_none()
            && !j.queue.ended(next);
        out
    }

    #[inline]
    fn idle(&self, _dda: &Dda) -> bool {
        self.job.core.phase() == Phase::Done
    }

    fn starved(&self) -> bool {
        self.job.starved
    }

    /// Pins only (the stall switch is read on every tick). The machine latches a stall fault
    /// the controller reports, and the wire power follows it, on the next full tick.
    fn step_only_ticks(&self) -> bool {
        true
    }
}

/// A step-only tick of a running wire job ([`Machine::fast_tick_with`]: the controller with the
/// stall switch `stall_raw`, the counters, the soft limits), if the machine grants one; `None`:
/// run [`tick`]. Interrupt rate.
#[inline(always)]
pub fn step_only_tick(
    machine: &mut Machine,
    dda: &mut Dda,
    job: &mut WireJob,
    stall_raw: bool,
) -> Option<StepOutput> {
    if !(job.live && job.started && machine.runs(super::WIRE_JOB)) {
        return None;
    }
    machine.fast_tick_with(dda, &mut Source { job, stall_raw })
}

/// One link-firmware tick with a wire job (interrupt rate: integer work, bounded, no
/// division). While the job is live and the machine runs it, the controller is the step source
/// (`stall_raw`: the wire-stall switch, closed = true); otherwise a plain [`Machine::tick`].
/// Then the wire power output: on only while the machine runs the job (not holding, no fault)
/// and the controller cuts; off otherwise (a Kill already forced every output off).
#[inline]
pub fn tick(
    machine: &mut Machine,
    dda: &mut Dda,
    inp: &Inputs,
    job: &mut WireJob,
    stall_raw: bool,
) -> TickOut {
    let mut out = if job.live && job.started && machine.runs(super::WIRE_JOB) {
        let mut inp = *inp;
        if job.core.fault_code() == Some(FaultCode::WireStall) && !job.fault_reported {
            // Once: the controller stopped already; the machine latches and holds.
            job.fault_reported = true;
            inp.sensor_faults |= FaultCode::WireStall.bit();
        }
        machine.tick_with(dda, &inp, &mut Source { job: &mut *job, stall_raw })
    } else {
        machine.tick(dda, inp)
    };
    if job.live && job.started && !machine.runs(super::WIRE_JOB) {
        // The machine ended the job (done, or dropped after a fault or an abort).
        job.live = false;
    }
    let on = job.wire_power() && machine.state() == MachineState::Running && !job.paused;
    let o = machine.outputs();
    if o.wire_power != on {
        // Refused (stays off) while an e-stop is latched or pressed.
        machine.set_outputs(Outputs { wire_power: on, ..o });
        out.outputs = machine.outputs();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::{BoardConfig, MachineCommand, Refusal};
    use crate::protocol::{AxisScale, HomingConfig, LinkConfig};
    use crate::trace::StepRecorder;
    use crate::wire::circle_complex_job as table;
    use crate::wire::controller::WireController;
    use crate::wire::job::total_steps;
    use crate::wire::machine;
    use crate::wire::scenario::{STALL_JOB, STALL_PARAMS};

    fn board() -> BoardConfig {
        let scale =
            AxisScale { steps_per_unit_milli: 1_000, soft_min: i64::MIN, soft_max: i64::MAX };
        let link = LinkConfig {
            machine: machine::config(),
            scale: [scale; MAX_AXES],
            inputs: crate::config::InputFilterConfig::DEFAULT,
        };
        BoardConfig::with_homing(link, &HomingConfig::NONE)
    }

    fn ready() -> (Machine, Dda, crate::dda::Preparer) {
        crate::machine::homed(board())
    }

    fn job() -> &'static [JobSegment] {
        table::SEGMENTS.get(STALL_JOB).unwrap()
    }

    struct Outcome {
        state: MachineState,
        faults: u32,
        positions: [i64; 4],
        net: [i64; 4],
        stats: StallStats,
        ticks: u64,
        power_while_stalled: bool,
        power_on_ticks: u64,
        hash: u64,
        /// DDA clock at the job start (homing ticked it).
        t0: u64,
        /// The machine's plain segments in flight after the run (a plain job may follow).
        in_flight: u32,
    }

    /// The link firmware's loop on the host: the host streams segments as credits allow
    /// (`lead` segments ahead at most), the feeder runs whenever the tick says so, the tick
    /// is [`tick`]. `stall(t)` is the switch level at tick `t` of the job.
    fn run(lead: usize, stall: impl Fn(u64) -> bool, estop: impl Fn(u64) -> bool) -> Outcome {
        run_with(lead, stall, estop, false).0
    }

    /// [`run`], with step-only ticks where the machine grants them (`step_only`); also how
    /// many ticks were step-only.
    fn run_with(
        lead: usize,
        stall: impl Fn(u64) -> bool,
        estop: impl Fn(u64) -> bool,
        step_only: bool,
    ) -> (Outcome, u64) {
        let (mut m, mut dda, mut prep) = ready();
        let js = job();
        let mut w = WireJob::new(&machine::config(), STALL_PARAMS, js.len() as u32).unwrap();
        let mut sent = 0;
        let mut send = |m: &mut Machine, dda: &mut Dda, w: &mut WireJob, upto: usize| {
            while sent < upto.min(js.len()) && w.credits() > 0 {
                let seg = js[sent].segment(sent as u32);
                m.command(MachineCommand::QueueSourceSegment(&seg), dda).unwrap();
                w.queue(&seg).unwrap();
                sent += 1;
            }
        };
        send(&mut m, &mut dda, &mut w, lead);
        let t0 = dda.now();
        m.command(MachineCommand::StartQueued(crate::wire::WIRE_JOB), &mut dda).unwrap();
        w.start(&mut dda).unwrap();
        let mut rec = StepRecorder::new();
        let (mut t, mut power_while_stalled, mut power_on_ticks) = (0u64, false, 0u64);
        let mut step_only_ticks = 0u64;
        while m.state() == MachineState::Running && t < 20_000_000 {
            let (done, _) = w.progress();
            send(&mut m, &mut dda, &mut w, done + lead);
            if w.wants_feed(&dda) {
                w.feed(&mut dda).unwrap();
            }
            let inp = Inputs { estop: estop(t), ..Inputs::QUIET };
            let fast = if step_only && !inp.estop {
                step_only_tick(&mut m, &mut dda, &mut w, stall(t))
            } else {
                None
            };
            step_only_ticks += u64::from(fast.is_some());
            let out = match fast {
                Some(step) => TickOut { step, outputs: m.outputs() },
                None => tick(&mut m, &mut dda, &inp, &mut w, stall(t)),
            };
            if m.wants_background() {
                m.background(&mut dda, &mut prep);
            }
            t += 1;
            rec.record(t, &out.step);
            power_on_ticks += out.outputs.wire_power as u64;
            if matches!(w.phase(), Phase::Stopping | Phase::Retracing | Phase::RetraceStopping) {
                power_while_stalled |= out.outputs.wire_power;
            }
        }
        let p = m.positions();
        let outcome = Outcome {
            state: m.state(),
            faults: m.faults().mask(),
            positions: [p[0], p[1], p[2], p[3]],
            net: [rec.net[0], rec.net[1], rec.net[2], rec.net[3]],
            stats: w.stats(),
            ticks: t,
            power_while_stalled,
            power_on_ticks,
            hash: rec.hash(),
            t0,
            in_flight: m.in_flight(&dda),
        };
        (outcome, step_only_ticks)
    }

    /// The same stall through the scenario's own controller (own DDA, whole table): the oracle.
    fn reference(stall: impl Fn(u64) -> bool) -> (u64, u64, [i64; 4], StallStats) {
        let mut c = WireController::new(&machine::config(), job(), STALL_PARAMS).unwrap();
        let mut rec = StepRecorder::new();
        let mut t = 0u64;
        while !c.is_finished() {
            if c.wants_feed() {
                c.feed().unwrap();
            }
            let out = c.tick(stall(t), false);
            t += 1;
            rec.record(t, &out);
        }
        (t, rec.hash(), [rec.net[0], rec.net[1], rec.net[2], rec.net[3]], c.stats())
    }

    const STALL: core::ops::Range<u64> = 150_000..190_000;

    #[test]
    fn stall_mid_job_retraces_recovers_and_ends_exactly_through_the_machine() {
        let o = run(8, |t| STALL.contains(&t), |_| false);
        assert_eq!((o.state, o.faults), (MachineState::Ready, 0));
        // The wire job's segments went through the DDA, not the plain queue: nothing is left
        // in flight for the next job to wait on.
        assert_eq!(o.in_flight, 0);
        let end = total_steps(job());
        assert_eq!(o.positions, end, "exact final position");
        assert_eq!(o.net, o.positions, "net steps on the pins == machine counters");
        assert_eq!(o.stats.stalls, 1);
        assert!(o.stats.retrace_segments >= 1 && o.stats.return_segments >= 1, "{:?}", o.stats);
        assert!(o.stats.max_retrace_steps > 0);
        assert!(!o.power_while_stalled, "wire power off from the stall until the return");
        // Same pins, tick for tick, as the scenario's controller on its own DDA with the whole
        // table (the machine's tick adds nothing and the stream never starves).
        let (ticks, hash, net, mut stats) = reference(|t| STALL.contains(&t));
        // Its ticks count from its own DDA's 0; the machine's DDA was ticked while homing.
        stats.first_stall_tick += o.t0;
        stats.first_resume_tick += o.t0;
        assert_eq!((o.ticks, o.hash, o.net, o.stats), (ticks, hash, net, stats));
        // Wire power off at least while the switch was closed (less the debounce), at most from
        // the detection to the end of the return, and on for the rest of the job.
        let off = o.ticks - o.power_on_ticks;
        let closed = STALL.end - STALL.start - STALL_PARAMS.debounce_ticks as u64;
        let max_off = stats.first_resume_tick - stats.first_stall_tick;
        assert!(off >= closed && off <= max_off, "off {off} closed {closed} max {max_off}");
    }

    #[test]
    fn without_stall_it_matches_the_plain_run() {
        let o = run(4, |_| false, |_| false);
        assert_eq!((o.state, o.faults), (MachineState::Ready, 0));
        assert_eq!(o.positions, total_steps(job()));
        let (ticks, hash, _, _) = reference(|_| false);
        assert_eq!((o.ticks, o.hash), (ticks, hash));
        assert_eq!(o.stats.stalls, 0);
    }

    #[test]
    fn step_only_ticks_cut_the_stalled_job_as_full_ticks_do() {
        let stall = |t: u64| STALL.contains(&t);
        let (full, _) = run_with(8, stall, |_| false, false);
        let (fast, step_only) = run_with(8, stall, |_| false, true);
        assert_eq!((fast.state, fast.faults), (MachineState::Ready, 0));
        // The same steps at the same ticks, the same stall and retrace; the end is seen on the
        // next full tick.
        assert_eq!(
            (fast.positions, fast.net, fast.hash, fast.stats),
            (full.positions, full.net, full.hash, full.stats)
        );
        let late = fast.ticks - full.ticks;
        assert!(late < u64::from(crate::machine::machine::SUPERVISE_TICKS), "{late}");
        // Every full tick grants the next 7, but for those the host's segments make full.
        let segments = job().len() as u64;
        assert!(step_only * 8 >= fast.ticks * 7 - 8 * (segments + 1), "{step_only}/{}", fast.ticks);
        // A persistent stall still ends in the fault, with the pins intact.
        let (o, _) = run_with(8, |t| t >= STALL.start, |_| false, true);
        assert_eq!((o.state, o.faults), (MachineState::Fault, FaultCode::WireStall.bit()));
        assert_eq!(o.net, o.positions);
    }

    #[test]
    fn persistent_stall_raises_wire_stall_and_cuts_the_power() {
        let o = run(8, |t| t >= STALL.start, |_| false);
        assert_eq!(o.state, MachineState::Fault);
        assert_eq!(o.faults, FaultCode::WireStall.bit());
        assert!(o.stats.max_retrace_steps <= STALL_PARAMS.retrace_limit_steps);
        assert_eq!(o.net, o.positions);
    }

    #[test]
    fn estop_ends_the_job_and_cuts_the_power() {
        let (mut m, mut dda, _) = ready();
        let js = job();
        let mut w = WireJob::new(&machine::config(), STALL_PARAMS, js.len() as u32).unwrap();
        for (k, s) in js.iter().enumerate().take(4) {
            let seg = s.segment(k as u32);
            m.command(MachineCommand::QueueSourceSegment(&seg), &mut dda).unwrap();
            w.queue(&seg).unwrap();
        }
        m.command(MachineCommand::StartQueued(crate::wire::WIRE_JOB), &mut dda).unwrap();
        w.start(&mut dda).unwrap();
        let out = tick(&mut m, &mut dda, &Inputs::QUIET, &mut w, false);
        assert!(out.outputs.wire_power);
        let out = tick(&mut m, &mut dda, &Inputs { estop: true, ..Inputs::QUIET }, &mut w, false);
        assert!(!out.outputs.wire_power);
        assert_eq!(m.state(), MachineState::Fault);
        assert!(m.faults().has(FaultCode::EStop));
        assert_eq!(out.step.rise(), 0);
    }

    #[test]
    fn late_host_is_an_underrun_and_wire_jobs_do_not_mix() {
        // Only 3 of 12 segments ever sent: the controller runs dry.
        let (mut m, mut dda, _) = ready();
        let js = job();
        let mut w = WireJob::new(&machine::config(), STALL_PARAMS, js.len() as u32).unwrap();
        for (k, s) in js.iter().enumerate().take(3) {
            let seg = s.segment(k as u32);
            m.command(MachineCommand::QueueSourceSegment(&seg), &mut dda).unwrap();
            w.queue(&seg).unwrap();
        }
        // A plain segment or a plain Start does not join a wire job.
        let seg = js[3].segment(3);
        assert!(matches!(
            m.command(MachineCommand::Queue(&seg), &mut dda),
            Err(Refusal::OutOfState(MachineState::Ready))
        ));
        assert!(m.command(MachineCommand::Start, &mut dda).is_err());
        m.command(MachineCommand::StartQueued(crate::wire::WIRE_JOB), &mut dda).unwrap();
        w.start(&mut dda).unwrap();
        let mut t = 0;
        while m.state() == MachineState::Running && t < 2_000_000 {
            if w.wants_feed(&dda) {
                w.feed(&mut dda).unwrap();
            }
            tick(&mut m, &mut dda, &Inputs::QUIET, &mut w, false);
            t += 1;
        }
        assert!(m.faults().has(FaultCode::QueueUnderrun), "{:#x}", m.faults().mask());
    }

    #[test]
    fn queue_is_a_window_by_job_index() {
        let mut q = WireQueue::new(100);
        let s = |k: i32| crate::wire::job::seg(k, 0, 0, 0, 10, 0, 0, 1);
        for k in 0..WIRE_QUEUE as i32 {
            assert!(q.push(s(k)));
        }
        assert!(!q.push(s(99)));
        assert_eq!(q.segment(5).map(|j| j.steps[0]), Some(5));
        q.trim(10);
        assert_eq!((q.segment(9), q.free()), (None, 10));
        assert!(q.push(s(64)));
        assert_eq!(q.segment(64).map(|j| j.steps[0]), Some(64));
        assert!(!q.ended(99) && q.ended(100));
        // A job's last segment: no more after `total`.
        let mut q = WireQueue::new(1);
        assert!(q.push(s(1)));
        assert!(!q.push(s(2)));
        // Axes beyond the four wire axes are refused.
        let mut seg = job()[0].segment(0);
        seg.steps[4] = 1;
        assert_eq!(job_segment(&seg), Err(SegmentError::UnusedAxis { axis: 4 }));
    }
}
