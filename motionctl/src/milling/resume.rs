//! Resuming a milling job after a board reset, a brown-out or a power loss (`milling run
//! --resume`): the journal holds how far along the job's one move the cut had got (the board's
//! last status, so never ahead of the cut).
//!
//! The machine is homed again (the job's origin), the spindle switched on with a spin-up wait,
//! then the approach: the Case A machine has only the feed axis X, so there is no height to
//! retract to; the tool stands clear of the work at the origin (before the wall) and travels
//! back along the slot it already cut, which is clear of material. It goes at the rapid feed
//! as a plain move to [`APPROACH_CLEARANCE_MM`] before the resume point, and from there the
//! force job runs again, armed with the job's own nominal force, thresholds, gains and
//! strategy: the controller finds the cut again by its contact threshold, as on the first
//! entry, and continues the rest of the move to the job's end.
//!
//! On a simulator board the plant is told what is left of the work: the wall moves to the
//! resume point (the slot before it is cut) and the depth step stays where it was on the part.

use super::job::MillingJob;
use crate::link::Session;
use crate::runner::{ask, ask_status, fault_names};
use anyhow::{bail, Result};
use motion::machine::MachineState;
use motion::milling::scenario::{segment_for, RAPID_STEPS_PER_S};
use motion::protocol::{
    ProgramOutputs, RequestBody, SegmentBatch, SimForceFault, SimMillingParams, SpindleDir,
};
use motion::segment::Segment;
use std::time::{Duration, Instant};

/// The force job restarts this far before the resume point (in the slot already cut), mm.
pub const APPROACH_CLEARANCE_MM: f64 = 1.0;
/// The spindle's spin-up wait before the approach, s of board time.
pub const SPIN_UP_S: f64 = 2.0;
/// Steps per mm of the Case A machine's X axis.
const STEPS_PER_MM: f64 = 1000.0;

/// Where and how a milling job resumes; positions are X steps from the job's start.
#[derive(Clone, Debug, PartialEq)]
pub struct MillingResume {
    /// The resume point: the cut is done up to here.
    pub from_steps: i64,
    /// Where the force job restarts (the approach's end).
    pub approach_to_steps: i64,
    /// The plain move from the origin to `approach_to_steps` (`None`: it starts at the origin).
    pub approach: Option<Segment>,
    /// The rest of the job's move, from `approach_to_steps` to its end, at the programmed feed.
    pub rest: Segment,
}

impl MillingResume {
    /// Resuming `job` at `from_steps` (the journal's position); refused outside the move.
    pub fn new(job: &MillingJob, from_steps: i64) -> Result<MillingResume> {
        let len = job.setup.move_steps as i64;
        if from_steps < 0 || from_steps >= len {
            bail!(
                "the resume point X {:.3} mm is not inside the job's move (0 .. {:.3} mm){}",
                from_steps as f64 / STEPS_PER_MM,
                len as f64 / STEPS_PER_MM,
                if from_steps >= len { ": the move had ended, nothing to resume" } else { "" }
            );
        }
        let clearance = (APPROACH_CLEARANCE_MM * STEPS_PER_MM).round() as i64;
        let to = (from_steps - clearance).max(0);
        let approach = (to > 0).then(|| segment_for(to as i32, RAPID_STEPS_PER_S));
        let rest = segment_for((len - to) as i32, job.setup.control.steps_per_s_at_one);
        Ok(MillingResume { from_steps, approach_to_steps: to, approach, rest })
    }

    /// The resume point, mm from the job's start.
    pub fn from_mm(&self) -> f64 {
        self.from_steps as f64 / STEPS_PER_MM
    }

    pub fn approach_to_mm(&self) -> f64 {
        self.approach_to_steps as f64 / STEPS_PER_MM
    }

    /// The simulated plant for the resumed force job, whose positions count from
    /// `approach_to_steps`: the work is cut up to the resume point (the wall moves there when
    /// the cut had passed it), and the depth step stays where it is on the part (already
    /// passed: the whole rest is at the depth after it).
    pub fn sim_params(&self, job: &MillingJob) -> SimMillingParams {
        let p = &job.setup.plant;
        let per_um = |steps: i64| (steps * p.nm_per_step as i64 / 1000).max(0) as u32;
        let wall = p.wall_steps.max(self.from_steps);
        let step_at = job.step_at_steps();
        let (b_before_um, step_at_um) = if wall >= step_at {
            (p.b_after_um, 0)
        } else {
            (p.b_before_um, per_um(step_at - wall))
        };
        SimMillingParams {
            kc_mn_per_mm2: p.kc_mn_per_mm2,
            b_before_um,
            b_after_um: p.b_after_um,
            step_at_um,
            wall_steps: wall - self.approach_to_steps,
            nm_per_step: p.nm_per_step,
            spindle_mrev_s: p.spindle_mrev_s,
            periodic: p.periodic,
            fault: SimForceFault::None,
            fault_at_um: 0,
        }
    }

    /// The cut had not reached the wall: the resumed run meets the work as the first did.
    pub fn before_the_wall(&self, job: &MillingJob) -> bool {
        self.from_steps <= job.setup.plant.wall_steps
    }
}

/// Status poll interval (wall clock) while the spindle spins up and the approach runs.
const POLL_EVERY: Duration = Duration::from_millis(5);
/// The approach may take this many times its planned time, plus [`APPROACH_SLACK_S`] ...
const APPROACH_TIME_FACTOR: u64 = 2;
const APPROACH_SLACK_S: u64 = 5;
/// ... and may go this long (wall clock) without the board's clock moving.
const STUCK_WALL: Duration = Duration::from_secs(15);

/// The spindle on, its spin-up, and the approach on a homed, `Ready` board whose feed axis
/// stands at `origin_steps` (the job's start): returns when the axis is at the approach's end,
/// at rest, `Ready` for the force job. `tick_hz` = the board's tick rate.
pub fn restore(
    s: &mut Session,
    plan: &MillingResume,
    origin_steps: i64,
    tick_hz: u32,
    say: &dyn Fn(&str),
) -> Result<()> {
    let on = ProgramOutputs { spindle: SpindleDir::Cw, ..ProgramOutputs::OFF };
    ask(s, RequestBody::SetProgramOutputs(on), "SetProgramOutputs (spindle on)")?;
    say(&format!("spindle on (clockwise), waiting {SPIN_UP_S:.1} s for it to spin up"));
    let t0 = ask_status(s)?.tick;
    let spun_up = t0 + (SPIN_UP_S * tick_hz as f64) as u64;
    wait(s, spun_up, "the spindle's spin-up", |st| Ok(st.tick >= spun_up))?;
    let Some(seg) = plan.approach else {
        say("approach: none (the resume point is within the clearance of the job's start)");
        return Ok(());
    };
    let batch = SegmentBatch::from_slice(&[seg])
        .ok_or_else(|| anyhow::anyhow!("the approach move does not fit a segment batch"))?;
    ask(s, RequestBody::QueueSegments(batch), "QueueSegments (approach)")?;
    let t1 = ask_status(s)?.tick;
    ask(s, RequestBody::Start, "Start (approach)")?;
    say(&format!(
        "approach: X {:.3} -> {:.3} mm at the rapid feed along the slot already cut (the machine \
         has no Z: no height to retract to), {APPROACH_CLEARANCE_MM} mm before the resume point",
        0.0,
        plan.approach_to_mm()
    ));
    let target = origin_steps + plan.approach_to_steps;
    let limit =
        t1 + (seg.duration_ticks as u64 * APPROACH_TIME_FACTOR) + APPROACH_SLACK_S * tick_hz as u64;
    let arrived = wait(s, limit, "the approach", |st| {
        if st.faults != 0 || st.machine == MachineState::Fault {
            bail!("the approach stopped on a fault: {}", fault_names(st.faults));
        }
        Ok(st.machine == MachineState::Ready && st.queue_depth == 0 && st.positions[0] == target)
    })?;
    if !arrived {
        let st = ask_status(s)?;
        let _ = s.request(RequestBody::Abort);
        bail!(
            "the approach did not reach X {:.3} mm in time (at {:.3} mm, {:?}): aborted",
            plan.approach_to_mm(),
            (st.positions[0] - origin_steps) as f64 / STEPS_PER_MM,
            st.machine
        );
    }
    Ok(())
}

/// Polls the board's status until `done` holds for it (true) or the board's clock reaches
/// `until_tick` (false). A board clock that does not move for [`STUCK_WALL`] is an error.
fn wait(
    s: &mut Session,
    until_tick: u64,
    what: &str,
    done: impl Fn(&motion::protocol::Status) -> Result<bool>,
) -> Result<bool> {
    let mut last = (ask_status(s)?.tick, Instant::now());
    loop {
        let st = ask_status(s)?;
        if done(&st)? {
            return Ok(true);
        }
        if st.tick >= until_tick {
            return Ok(false);
        }
        if st.tick != last.0 {
            last = (st.tick, Instant::now());
        } else if last.1.elapsed() > STUCK_WALL {
            bail!("{what}: the board's clock stopped");
        }
        std::thread::sleep(POLL_EVERY);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const JOB: &str = include_str!("../../examples/case_a_milling.toml");

    /// The approach ends the clearance before the resume point, the rest ends where the job
    /// does; the plant's wall and depth step stay where they are on the part.
    #[test]
    fn the_resume_splits_the_move_and_keeps_the_part_where_it_is() {
        let job = super::super::job::parse(JOB).unwrap();
        let len = job.setup.move_steps as i64;
        let step = job.step_at_steps();
        let r = MillingResume::new(&job, 5_000).unwrap();
        assert_eq!(r.approach_to_steps, 4_000);
        assert_eq!(r.approach.unwrap().steps[0], 4_000);
        assert_eq!(r.approach_to_steps + r.rest.steps[0] as i64, len);
        let s = r.sim_params(&job);
        // Wall at the resume point (1 mm into the resumed move), the step where it was.
        assert_eq!(s.wall_steps, 1_000);
        assert_eq!(s.b_before_um, job.setup.plant.b_before_um);
        assert_eq!(4_000 + s.wall_steps + s.step_at_um as i64, step);
        // Past the depth step: the whole rest at the depth after it.
        let r = MillingResume::new(&job, step + 500).unwrap();
        let s = r.sim_params(&job);
        assert_eq!((s.b_before_um, s.step_at_um), (job.setup.plant.b_after_um, 0));
        // Before the wall: no approach move, the plant as the first run's.
        let r = MillingResume::new(&job, 300).unwrap();
        assert_eq!((r.approach, r.approach_to_steps), (None, 0));
        assert_eq!(r.sim_params(&job).wall_steps, job.setup.plant.wall_steps);
        assert!(r.before_the_wall(&job));
        // Outside the move: refused, naming the point in mm.
        for bad in [-1, len] {
            let e = MillingResume::new(&job, bad).unwrap_err().to_string();
            assert!(e.contains("not inside the job's move"), "{e}");
        }
    }
}
