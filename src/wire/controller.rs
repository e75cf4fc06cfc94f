//! Runs a wire job on the DDA with wire-stall recovery and the wire power output.
//!
//! On a debounced stall the controller cuts the wire power, holds the feed, and once the DDA
//! reports `Held` aborts it (positions stay exactly what was stepped). It then retraces the
//! executed path backwards, one recorded piece at a time (each as a rest-to-rest segment over
//! the piece's own duration and ramp), until the stall clears or the retraced distance would
//! pass the limit (fault [`FaultCode::WireStall`]). A stall that clears in the middle of a
//! retrace piece holds and aborts again there. Then the power comes back on and the controller
//! replays the retraced pieces forward to the stall point, finishes the interrupted segment and
//! continues the job at a reduced feed override. Every target is an absolute step position, so
//! no step is lost however often it stops. E-stop aborts at once and cuts the power.
//!
//! Split by rate: [`WireController::tick`] is the timer-interrupt part (debounce, e-stop, hold,
//! the DDA tick, completions: integer adds and compares, no division); [`WireController::feed`]
//! is the feeder-task part (segment preparation, abort bookkeeping and retrace planning, which
//! divide in [`Preparer::prepare`] and [`Dda::positions`]), called whenever the DDA has room or
//! the controller changed phase.

use super::history::{l1_steps, sub, History, Piece, Replay};
use super::job::JobSegment;
use crate::config::{ConfigError, MachineConfig, MAX_AXES};
use crate::dda::{Command, Dda, MotionState, Preparer, StepOutput, READY_DEPTH};
use crate::machine::debounce::Debouncer;
use crate::protocol::errors::FaultCode;
use crate::segment::{Rate, Segment, SegmentError};
use heapless::Deque;

/// Stall handling parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StallParams {
    /// Consecutive ticks the switch must agree before a change counts.
    pub debounce_ticks: u16,
    /// Largest retraced distance, sum of absolute steps over the four axes.
    pub retrace_limit_steps: u64,
    /// Feed override while retracing (the thesis retraced at the cutting feed).
    pub retrace_override: Rate,
    /// Feed override from the return until `resume_segments` job segments have completed.
    pub resume_override: Rate,
    pub resume_segments: u32,
}

/// Where the controller is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Feeding job segments.
    Running,
    /// Stall seen: holding, waiting for `Held` to abort.
    Stopping,
    /// Running backwards along the history.
    Retracing,
    /// The stall cleared in the middle of a retrace piece: holding there.
    RetraceStopping,
    /// Replaying the retraced pieces and the interrupted segment's rest.
    Returning,
    /// The job is complete.
    Done,
    /// Stopped for good with this fault; wire power off.
    Faulted(FaultCode),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Job segment with its table index.
    Job(u32),
    Retrace,
    Return,
}

/// A segment handed to the DDA and not completed yet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Flight {
    kind: Kind,
    piece: Piece,
}

/// Tag bit of recovery segments (job segments carry their table index).
pub const RECOVERY_ID: u32 = 1 << 31;

/// Counters for reports and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StallStats {
    pub stalls: u32,
    pub retrace_segments: u32,
    pub return_segments: u32,
    /// Retrace pieces left in the middle because the stall cleared.
    pub retrace_interrupts: u32,
    /// Largest retraced distance of one stall, L1 steps.
    pub max_retrace_steps: u64,
    /// Tick of the first stall detection and of the first return to `Running` after it.
    pub first_stall_tick: u64,
    pub first_resume_tick: u64,
}

/// Where the controller reads the job's segments: a constant table ([`JobSegment`] slices, the
/// scenarios) or the link's streamed window ([`super::link_job::WireQueue`]). Segment `k` is the
/// `k`th of the job; the controller asks again for a segment it fed but did not start (after a
/// stall), so a stream must keep every segment from the oldest one not yet completed
/// ([`WireCore::oldest_needed`]). Cheap and division-free: asked from the tick.
pub trait JobTable {
    /// Segment `k`, if it is here (a stream may not have received it yet).
    fn segment(&self, k: usize) -> Option<JobSegment>;
    /// The job has no segment `k` and never will: it has `k` or fewer segments.
    fn ended(&self, k: usize) -> bool;
}

impl JobTable for [JobSegment] {
    #[inline]
    fn segment(&self, k: usize) -> Option<JobSegment> {
        self.get(k).copied()
    }

    #[inline]
    fn ended(&self, k: usize) -> bool {
        k >= self.len()
    }
}

/// The retrace controller without its DDA and job: the DDA is the caller's (the link
/// firmware's `Motion` resource, or [`WireController`]'s own), the job any [`JobTable`].
#[derive(Clone, Debug)]
pub struct WireCore {
    prep: Preparer,
    next_job: usize,
    in_flight: Deque<Flight, { READY_DEPTH + 2 }>,
    /// End of the last segment handed to the DDA (the position once it is idle).
    pos: [i32; 4],
    history: History,
    replay: Replay,
    stall_in: Debouncer,
    stalled: bool,
    phase: Phase,
    wire_on: bool,
    params: StallParams,
    done_seen: u32,
    retraced_steps: u64,
    resume_left: u32,
    recovery_ids: u32,
    stats: StallStats,
}

/// [`WireCore`] with a DDA and a constant job of its own (the scenarios and their tests).
pub struct WireController<'a> {
    dda: Dda,
    core: WireCore,
    job: &'a [JobSegment],
}

fn pos4(p: [i64; MAX_AXES]) -> [i32; 4] {
    // Wire positions stay within +-2^31 steps (a few metres of travel); saturate otherwise.
    p[..4].iter().enumerate().fold([0; 4], |mut a, (i, &v)| {
        a[i] = v.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        a
    })
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
        super::job::total_steps(self.job)
    }
}

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

    /// Timer interrupt: samples the inputs, reacts to e-stop and stall, ticks the DDA and books
    /// completed segments. Bounded, integer only, no division.
    #[inline]
    pub fn tick<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
        stall_raw: bool,
        estop_raw: bool,
    ) -> StepOutput {
        if estop_raw && !matches!(self.phase, Phase::Faulted(_)) {
            self.fault(dda, FaultCode::EStop);
        }
        self.stalled = self.stall_in.update(stall_raw);
        match self.phase {
            Phase::Running | Phase::Returning if self.stalled => {
                self.wire_on = false;
                dda.apply(Command::Hold);
                self.phase = Phase::Stopping;
                if self.stats.stalls == 0 {
                    self.stats.first_stall_tick = dda.now();
                }
                self.stats.stalls += 1;
            }
            Phase::Retracing if !self.stalled && dda.state() == MotionState::Moving => {
                dda.apply(Command::Hold);
                self.phase = Phase::RetraceStopping;
                self.stats.retrace_interrupts += 1;
            }
            _ => {}
        }
        let out = dda.tick();
        while self.done_seen != dda.segments_done() {
            self.done_seen = dda.segments_done();
            self.complete_front(dda);
            let job_done = job.ended(self.next_job) && self.in_flight.is_empty();
            if self.phase == Phase::Running && job_done && dda.is_idle() {
                self.phase = Phase::Done;
            }
        }
        out
    }

    #[cold]
    fn complete_front(&mut self, dda: &mut Dda) {
        let Some(f) = self.in_flight.pop_front() else {
            return;
        };
        match f.kind {
            Kind::Job(_) => {
                self.history.push(f.piece);
                if self.resume_left > 0 {
                    self.resume_left -= 1;
                    if self.resume_left == 0 {
                        dda.apply(Command::CapabilityOverride(Rate::ONE));
                    }
                }
            }
            Kind::Return => self.history.push(f.piece),
            Kind::Retrace => {}
        }
    }

    fn fault(&mut self, dda: &mut Dda, code: FaultCode) {
        dda.abort();
        self.in_flight.clear();
        self.done_seen = dda.segments_done();
        self.wire_on = false;
        self.phase = Phase::Faulted(code);
    }

    /// True when [`WireCore::feed`] has work: a free DDA slot and a job segment to fill it, or a
    /// stop, retrace or return step due. Cheap and division-free: the timer interrupt asks it
    /// every tick and hands `feed` to the feeder task only when it is true.
    pub fn wants_feed<J: JobTable + ?Sized>(&self, dda: &Dda, job: &J) -> bool {
        let settled = self.in_flight.is_empty() && dda.is_idle();
        match self.phase {
            Phase::Running => {
                (dda.ready_free() > 0
                    && !self.in_flight.is_full()
                    && job.segment(self.next_job).is_some())
                    || (job.ended(self.next_job) && settled)
            }
            Phase::Stopping | Phase::RetraceStopping => {
                matches!(dda.state(), MotionState::Held | MotionState::Idle)
            }
            Phase::Retracing | Phase::Returning => settled,
            Phase::Done | Phase::Faulted(_) => false,
        }
    }

    /// Feeder task: hands segments to the DDA and plans the recovery moves (divides).
    pub fn feed<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
    ) -> Result<(), SegmentError> {
        match self.phase {
            Phase::Running => self.feed_job(dda, job)?,
            Phase::Stopping | Phase::RetraceStopping => {
                let s = dda.state();
                if (s == MotionState::Held || s == MotionState::Idle) && self.stop_here(dda) {
                    self.phase = if self.phase == Phase::Stopping && self.stalled {
                        dda.apply(Command::CapabilityOverride(self.params.retrace_override));
                        self.retraced_steps = 0;
                        Phase::Retracing
                    } else {
                        self.start_return(dda);
                        Phase::Returning
                    };
                }
            }
            Phase::Retracing => {
                if self.in_flight.is_empty() && dda.is_idle() {
                    if !self.stalled {
                        self.start_return(dda);
                        self.phase = Phase::Returning;
                    } else {
                        self.retrace_next(dda)?;
                    }
                }
            }
            Phase::Returning => {
                if self.in_flight.is_empty() && dda.is_idle() {
                    self.return_next(dda, job)?;
                }
            }
            Phase::Done | Phase::Faulted(_) => {}
        }
        Ok(())
    }

    fn feed_job<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
    ) -> Result<(), SegmentError> {
        while dda.ready_free() > 0 && !self.in_flight.is_full() {
            let Some(js) = job.segment(self.next_job) else {
                if job.ended(self.next_job) && self.in_flight.is_empty() && dda.is_idle() {
                    self.phase = Phase::Done;
                }
                return Ok(());
            };
            let mut seg = js.segment(self.next_job as u32);
            if job.ended(self.next_job + 1) {
                // A job (or a slice of one) always ends at rest.
                seg.exit_rate = Rate::ZERO;
            }
            let end = add(self.pos, js.steps);
            let piece = Piece {
                start: self.pos,
                end,
                duration_ticks: js.duration_ticks,
                accel_q30: js.accel_q30,
            };
            self.push(dda, seg, Kind::Job(self.next_job as u32), piece)?;
            self.next_job += 1;
        }
        Ok(())
    }

    fn push(
        &mut self,
        dda: &mut Dda,
        seg: Segment,
        kind: Kind,
        piece: Piece,
    ) -> Result<(), SegmentError> {
        let p = self.prep.prepare(&seg)?;
        if dda.push(&p).is_err() || self.in_flight.push_back(Flight { kind, piece }).is_err() {
            // Callers check room first.
            return Err(SegmentError::Duration);
        }
        self.pos = piece.end;
        Ok(())
    }

    /// A rest-to-rest recovery segment from the current position to `piece.end` over the
    /// piece's duration and ramp; nothing when already there.
    fn push_recovery(
        &mut self,
        dda: &mut Dda,
        kind: Kind,
        piece: Piece,
    ) -> Result<bool, SegmentError> {
        // Mid-piece after an interrupted retrace: only the part left, in its share of time.
        let piece = if self.pos == piece.start { piece } else { piece.part(self.pos, piece.end) };
        let d = piece.steps_to_end(self.pos);
        if d == [0; 4] {
            return Ok(false);
        }
        let mut steps = [0i32; MAX_AXES];
        steps[..4].copy_from_slice(&d);
        self.recovery_ids = self.recovery_ids.wrapping_add(1);
        let seg = Segment {
            steps,
            duration_ticks: piece.duration_ticks,
            entry_rate: Rate::ZERO,
            exit_rate: Rate::ZERO,
            accel_per_tick: Rate::from_bits(piece.accel_q30.max(1)),
            id: RECOVERY_ID | (self.recovery_ids & !RECOVERY_ID),
        };
        self.push(dda, seg, kind, piece)?;
        Ok(true)
    }

    /// After a hold: abort where the DDA stands and book the interrupted segment: its executed
    /// part joins the history, its rest goes on the replay stack; unstarted job segments are
    /// fed again later from the table.
    fn stop_here(&mut self, dda: &mut Dda) -> bool {
        let p = pos4(dda.positions());
        dda.abort();
        self.prep.reset_junction();
        self.done_seen = dda.segments_done();
        let mut ok = true;
        if let Some(f) = self.in_flight.pop_front() {
            if let Kind::Job(k) = f.kind {
                self.next_job = k as usize + 1;
            }
            match f.kind {
                Kind::Job(_) | Kind::Return => {
                    // Executed part (all of it when stopped exactly at its end) and the rest.
                    self.history.push(f.piece.part(f.piece.start, p));
                    ok = self.replay.push(f.piece.part(p, f.piece.end));
                }
                // Its piece is on the replay stack already.
                Kind::Retrace => {}
            }
        }
        self.in_flight.clear();
        self.pos = p;
        if !ok {
            self.fault(dda, FaultCode::WireStall);
        }
        ok
    }

    fn retrace_next(&mut self, dda: &mut Dda) -> Result<(), SegmentError> {
        let Some(h) = self.history.pop() else {
            self.fault(dda, FaultCode::WireStall);
            return Ok(());
        };
        let d = l1_steps(sub(h.start, self.pos));
        if self.retraced_steps + d > self.params.retrace_limit_steps || !self.replay.push(h) {
            self.fault(dda, FaultCode::WireStall);
            return Ok(());
        }
        self.retraced_steps += d;
        self.stats.max_retrace_steps = self.stats.max_retrace_steps.max(self.retraced_steps);
        // Backwards: to the piece's start.
        let back = Piece { start: h.end, end: h.start, ..h };
        if self.push_recovery(dda, Kind::Retrace, back)? {
            self.stats.retrace_segments += 1;
        }
        Ok(())
    }

    fn start_return(&mut self, dda: &mut Dda) {
        self.wire_on = true;
        dda.apply(Command::CapabilityOverride(self.params.resume_override));
    }

    fn return_next<J: JobTable + ?Sized>(
        &mut self,
        dda: &mut Dda,
        job: &J,
    ) -> Result<(), SegmentError> {
        while let Some(r) = self.replay.pop() {
            if self.push_recovery(dda, Kind::Return, r)? {
                self.stats.return_segments += 1;
                return Ok(());
            }
        }
        self.phase = Phase::Running;
        self.resume_left = self.params.resume_segments;
        if self.stats.first_resume_tick == 0 {
            self.stats.first_resume_tick = dda.now();
        }
        if self.resume_left == 0 {
            dda.apply(Command::CapabilityOverride(Rate::ONE));
        }
        self.feed_job(dda, job)
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

fn add(a: [i32; 4], b: [i32; 4]) -> [i32; 4] {
    [
        a[0].wrapping_add(b[0]),
        a[1].wrapping_add(b[1]),
        a[2].wrapping_add(b[2]),
        a[3].wrapping_add(b[3]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::StepRecorder;
    use crate::wire::job::seg;
    use crate::wire::machine;

    const ONE: u32 = 1 << 30;

    /// Six 4-axis segments, 2000 ticks each, meeting at full speed.
    fn job() -> [JobSegment; 6] {
        // Full speed to rest in 400 ticks.
        let a = ONE / 400;
        [
            seg(400, 100, 20, -50, 2000, 0, ONE, a),
            seg(400, 200, 10, -50, 2000, ONE, ONE, a),
            seg(300, 300, 0, -50, 2000, ONE, ONE, a),
            seg(200, 400, -10, -50, 2000, ONE, ONE, a),
            seg(100, 400, -20, -50, 2000, ONE, ONE, a),
            seg(0, 400, -30, -50, 2000, ONE, 0, a),
        ]
    }

    fn params() -> StallParams {
        StallParams {
            debounce_ticks: 5,
            retrace_limit_steps: 100_000,
            retrace_override: Rate::ONE,
            resume_override: Rate::lit("0.5"),
            resume_segments: 2,
        }
    }

    struct Outcome {
        phase: Phase,
        positions: [i64; 4],
        net: [i64; 4],
        stats: StallStats,
        /// Wire power seen while the debounced stall was asserted / while retracing.
        power_while_retracing: bool,
        min_x_after_stall: i64,
        ticks: u64,
    }

    fn run(
        job: &[JobSegment],
        p: StallParams,
        stall: impl Fn(u64) -> bool,
        estop: impl Fn(u64) -> bool,
    ) -> Outcome {
        let mut c = WireController::new(&machine::config(), job, p).unwrap();
        let mut rec = StepRecorder::new();
        let mut power_while_retracing = false;
        let mut min_x_after_stall = i64::MAX;
        let mut n = 0u64;
        while !c.is_finished() && n < 1_000_000 {
            c.feed().unwrap();
            let out = c.tick(stall(n), estop(n));
            n += 1;
            rec.record(c.dda().now(), &out);
            if matches!(c.phase(), Phase::Retracing | Phase::RetraceStopping) {
                power_while_retracing |= c.wire_power();
            }
            if c.stats().stalls > 0 && out.rise() & 1 != 0 {
                min_x_after_stall = min_x_after_stall.min(c.dda().positions()[0]);
            }
        }
        let p = c.dda().positions();
        Outcome {
            phase: c.phase(),
            positions: [p[0], p[1], p[2], p[3]],
            net: [rec.net[0], rec.net[1], rec.net[2], rec.net[3]],
            stats: c.stats(),
            power_while_retracing,
            min_x_after_stall,
            ticks: n,
        }
    }

    fn end(job: &[JobSegment]) -> [i64; 4] {
        crate::wire::job::total_steps(job)
    }

    #[test]
    fn runs_the_job_without_stall() {
        let j = job();
        let o = run(&j, params(), |_| false, |_| false);
        assert_eq!(o.phase, Phase::Done);
        assert_eq!(o.positions, end(&j));
        assert_eq!(o.net, o.positions);
        assert_eq!(o.stats.stalls, 0);
    }

    #[test]
    fn stall_retraces_backwards_then_finishes_exactly() {
        let j = job();
        // Stalled for 3000 ticks from the middle of segment 2.
        let o = run(&j, params(), |t| (5000..8000).contains(&t), |_| false);
        assert_eq!(o.phase, Phase::Done);
        assert_eq!(o.positions, end(&j));
        assert_eq!(o.net, o.positions, "steps on the pins == DDA positions");
        assert_eq!(o.stats.stalls, 1);
        assert!(o.stats.retrace_segments >= 2, "{:?}", o.stats);
        assert!(o.stats.return_segments >= 2, "{:?}", o.stats);
        assert!(!o.power_while_retracing);
        // X went back below where it was at the stall (~1000 steps into the job).
        assert!(o.min_x_after_stall < 800, "{}", o.min_x_after_stall);
        // The whole job at nominal speed is 12 000 ticks; the stall costs time.
        assert!(o.ticks > 12_000 + 3_000);
    }

    #[test]
    fn debouncer_ignores_short_glitches() {
        let j = job();
        let o = run(&j, params(), |t| t % 1000 < 3, |_| false);
        assert_eq!(o.phase, Phase::Done);
        assert_eq!(o.stats.stalls, 0);
    }

    #[test]
    fn stall_clearing_mid_retrace_returns_from_there() {
        let j = job();
        // Stall late in segment 4; it clears 1500 ticks later, in the middle of retracing.
        let o = run(&j, params(), |t| (9000..10_500).contains(&t), |_| false);
        assert_eq!(o.phase, Phase::Done);
        assert_eq!(o.stats.retrace_interrupts, 1, "{:?}", o.stats);
        assert_eq!(o.positions, end(&j));
        assert_eq!(o.net, o.positions);
        assert_eq!(o.stats.stalls, 1);
    }

    #[test]
    fn repeated_stalls_lose_no_steps() {
        let j = job();
        let o = run(
            &j,
            params(),
            |t| {
                (2500..3500).contains(&t)
                    || (9000..9500).contains(&t)
                    || (14_000..16_000).contains(&t)
            },
            |_| false,
        );
        assert_eq!(o.phase, Phase::Done);
        assert_eq!(o.positions, end(&j));
        assert_eq!(o.net, o.positions);
        assert!(o.stats.stalls >= 2, "{:?}", o.stats);
    }

    #[test]
    fn permanent_stall_faults_at_the_limit() {
        let j = job();
        let p = StallParams { retrace_limit_steps: 1_000, ..params() };
        let o = run(&j, p, |t| t >= 7000, |_| false);
        assert_eq!(o.phase, Phase::Faulted(FaultCode::WireStall));
        assert!(o.stats.max_retrace_steps <= 1_000);
        assert_eq!(o.net, o.positions);
        // Without a limit it runs out of history (back at the start) and faults the same way.
        let p = StallParams { retrace_limit_steps: u64::MAX, ..params() };
        let o = run(&j, p, |t| t >= 7000, |_| false);
        assert_eq!(o.phase, Phase::Faulted(FaultCode::WireStall));
        assert_eq!(o.positions, [0; 4]);
    }

    /// After a stall the job resumes at the scenarios' `resume_override` (0.5) for
    /// `resume_segments` (2) job segments, then at 1.0: the DDA's override is 0.5 through the
    /// return and the first two job segments after it, 1.0 from the completion of the second
    /// on; the first of them takes about twice its nominal 2000 ticks, the third its nominal.
    #[test]
    fn resumes_at_reduced_feed_for_two_segments() {
        use crate::wire::scenario::STALL_PARAMS;
        let j = job();
        // Retrace distinct from the resume override, so the three phases can be told apart.
        let p = StallParams { retrace_override: Rate::lit("0.75"), ..STALL_PARAMS };
        let mut c = WireController::new(&machine::config(), &j, p).unwrap();
        let half = STALL_PARAMS.resume_override;
        assert_eq!(half, Rate::lit("0.5"));
        assert_eq!(STALL_PARAMS.resume_segments, 2);
        // (job segment index, completion tick) after the return, and the override seen while
        // each job segment after the return was running.
        let mut done_after: Vec<(u32, u64)> = Vec::new();
        let mut seen = [None::<Rate>; 6];
        let (mut last_done, mut returned, mut n) = (0u32, false, 0u64);
        let (mut saw_retrace, mut saw_return) = (false, false);
        while !c.is_finished() && n < 1_000_000 {
            c.feed().unwrap();
            c.tick((5000..6000).contains(&n), false);
            n += 1;
            let ovr = c.dda().feed_override();
            match c.phase() {
                Phase::Retracing => {
                    saw_retrace = true;
                    assert_eq!(ovr, p.retrace_override, "retracing, tick {n}");
                }
                Phase::Returning => {
                    saw_return = true;
                    returned = true;
                    assert_eq!(ovr, half, "returning, tick {n}");
                }
                _ => {}
            }
            if c.dda().segments_done() != last_done {
                last_done = c.dda().segments_done();
                let id = c.dda().last_done_id().unwrap();
                if returned && id & RECOVERY_ID == 0 {
                    done_after.push((id, n));
                }
            }
            // The job segment in progress after the return: the override it runs at (the
            // change lands at a completion, so sample mid-way through the segment).
            if returned && c.phase() == Phase::Running && c.dda().state() == MotionState::Moving {
                let k = done_after.len();
                let since = done_after.last().map_or(c.stats().first_resume_tick, |d| d.1);
                if n == since + 500 && k < seen.len() {
                    seen[k] = Some(ovr);
                }
            }
        }
        assert_eq!(c.phase(), Phase::Done);
        assert!(saw_retrace && saw_return);
        assert_eq!(c.stats().stalls, 1);
        assert_eq!(c.dda().feed_override(), Rate::ONE, "back to 1.0 at the end");
        // Stalled in segment 2: segments 3, 4, 5 run after the return.
        let ids: Vec<u32> = done_after.iter().map(|d| d.0).collect();
        assert_eq!(ids, [3, 4, 5], "{done_after:?}");
        assert_eq!(seen[..3], [Some(half), Some(half), Some(Rate::ONE)], "{seen:?}");
        // Durations: segment 4 (between two reduced-feed completions) runs at half speed, segment
        // 5 at full speed to rest (2000 ticks plus its ramp down).
        let d4 = done_after[1].1 - done_after[0].1;
        let d5 = done_after[2].1 - done_after[1].1;
        std::eprintln!("after the return: {done_after:?}; segment 4 {d4} ticks, 5 {d5} ticks");
        assert!((3_800..=4_200).contains(&d4), "segment 4 took {d4} ticks at 0.5");
        assert!((2_000..=2_600).contains(&d5), "segment 5 took {d5} ticks at 1.0");
    }

    #[test]
    fn estop_cuts_wire_power_at_once() {
        let j = job();
        let mut c = WireController::new(&machine::config(), &j, params()).unwrap();
        for n in 0..4000 {
            c.feed().unwrap();
            c.tick(false, false);
            assert!(c.wire_power(), "tick {n}");
        }
        c.tick(false, true);
        assert!(!c.wire_power());
        assert_eq!(c.fault_code(), Some(FaultCode::EStop));
        assert!(c.dda().is_idle());
    }
}
