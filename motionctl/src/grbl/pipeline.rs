//! Moves as they come, one block at a time, into an incremental [`Planner`], and its segments
//! (with the spindle and coolant, pause and dwell events between them) into a queue the link drains.
//!
//! Targets are rounded to steps from the commanded position in mm, as [`crate::convert`] does
//! for a whole job, so rounding never accumulates. The planner keeps its lookahead window until
//! [`Pipeline::flush`] (the bridge flushes when the sender goes quiet or the board runs low):
//! then the last move ends at rest.

use crate::convert::{feed_hz, rapid_feed_hz};
use crate::job::{Feed, Machine};
use motion::machine::ProbeKind;
use motion::planner::{Move, PlanError, Planner};
use motion::protocol::ProgramOutputs;
use motion::{MachineConfig, Segment, MAX_AXES};
use std::collections::VecDeque;
use std::time::Instant;

/// What the link sends next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Out {
    Segment(Segment),
    /// The spindle and coolant from here on (M3, M4, M5, M7, M8, M9).
    Outputs(ProgramOutputs),
    /// M0/M1: hold until cycle start.
    Pause,
    /// G4: wait this long once the motion before it is done.
    Dwell(f64),
    /// G38.x: once the motion before it is done, arm the board for a probe move of this kind;
    /// the probe move's segments follow, then [`Out::ProbeEnd`].
    Probe(ProbeKind),
    /// The probe move's segments are all given: start them alone and wait for its result.
    ProbeEnd,
}

/// A move the pipeline refused.
#[derive(Clone, Debug, PartialEq)]
pub enum MoveError {
    /// Outside the machine's travel (soft limits on).
    SoftLimit(String),
    /// Anything else wrong with the target or feed.
    Invalid(String),
}

pub struct Pipeline {
    machine: Machine,
    cfg: MachineConfig,
    spm: Vec<f64>,
    planner: Planner,
    /// Moves in the planner not yet emitted.
    pub dirty: bool,
    pub pending_moves: usize,
    /// Where the queued motion ends: mm, and steps.
    pub pos_mm: Vec<f64>,
    pub pos_steps: [i64; MAX_AXES],
    pub out: VecDeque<Out>,
    pub last_push: Instant,
    pub soft_limits: bool,
}

impl Pipeline {
    pub fn new(machine: &Machine, cfg: MachineConfig) -> Self {
        Pipeline {
            machine: machine.clone(),
            cfg,
            spm: machine.axes.iter().map(|a| a.steps_per_mm).collect(),
            planner: Planner::new(&cfg),
            dirty: false,
            pending_moves: 0,
            pos_mm: vec![0.0; machine.axes.len()],
            pos_steps: [0; MAX_AXES],
            out: VecDeque::new(),
            last_push: Instant::now(),
            soft_limits: true,
        }
    }

    /// Drops everything queued; the machine stands at `steps`.
    pub fn reset(&mut self, steps: &[i64; MAX_AXES]) {
        self.planner = Planner::new(&self.cfg);
        self.dirty = false;
        self.pending_moves = 0;
        self.out.clear();
        self.moved_to(steps);
    }

    /// Segments waiting for the link.
    pub fn queued_segments(&self) -> usize {
        self.out.iter().filter(|o| matches!(o, Out::Segment(_))).count()
    }

    /// Ticks of motion waiting for the link.
    pub fn queued_ticks(&self) -> u64 {
        self.out
            .iter()
            .map(|o| match o {
                Out::Segment(s) => s.duration_ticks as u64,
                _ => 0,
            })
            .sum()
    }

    /// Nothing queued or planned.
    pub fn is_empty(&self) -> bool {
        !self.dirty && self.out.is_empty()
    }

    /// The soft-limit check of a move from `from` to `target`, mm (an axis that does not move
    /// is not checked).
    pub fn check(&self, from: &[f64], target: &[f64]) -> Result<(), MoveError> {
        for ((a, &t), &p) in self.machine.axes.iter().zip(target).zip(from) {
            if !t.is_finite() || t.abs() > crate::job::MAX_COORD_MM {
                return Err(MoveError::Invalid(format!("axis {} target is out of range", a.name)));
            }
            if self.soft_limits && t != p && (t < a.min_mm || t > a.max_mm) {
                return Err(MoveError::SoftLimit(format!(
                    "axis {} target {t:.3} mm is outside its travel {}..{} mm",
                    a.name, a.min_mm, a.max_mm
                )));
            }
        }
        Ok(())
    }

    /// A move to `target` (mm per machine axis; `None` stays). With `dry`, only checked and
    /// followed (check mode).
    pub fn push_move(
        &mut self,
        target: &[Option<f64>],
        feed: Feed,
        dry: bool,
    ) -> Result<(), MoveError> {
        let target: Vec<f64> =
            target.iter().zip(&self.pos_mm).map(|(t, p)| t.unwrap_or(*p)).collect();
        if target.len() != self.pos_mm.len() {
            return Err(MoveError::Invalid("target does not match the machine's axes".into()));
        }
        self.check(&self.pos_mm, &target)?;
        let mut steps = [0i32; MAX_AXES];
        let mut new_steps = self.pos_steps;
        for (i, (&t, &spm)) in target.iter().zip(&self.spm).enumerate() {
            let s = (t * spm).round() as i64;
            let d = s - self.pos_steps[i];
            steps[i] = i32::try_from(d)
                .map_err(|_| MoveError::Invalid(format!("a move of {d} steps is too long")))?;
            new_steps[i] = s;
        }
        let hz = match feed {
            Feed::Rapid => rapid_feed_hz(&steps, &self.cfg),
            Feed::MmPerMin(f) if f.is_finite() && f > 0.0 => feed_hz(&steps, &self.spm, f),
            Feed::MmPerMin(_) => return Err(MoveError::Invalid("feed must be above 0".into())),
        };
        if !dry && steps.iter().any(|&s| s != 0) {
            self.plan(Move { steps, feed_hz: hz })?;
            self.dirty = true;
            self.pending_moves += 1;
            self.last_push = Instant::now();
        }
        self.pos_mm = target;
        self.pos_steps = new_steps;
        Ok(())
    }

    fn plan(&mut self, mv: Move) -> Result<(), MoveError> {
        loop {
            match self.planner.push(&mv) {
                Ok(()) => {
                    self.drain();
                    return Ok(());
                }
                Err(PlanError::Full) if !self.planner.is_full() => {
                    self.planner.finish();
                    self.drain();
                }
                Err(PlanError::Full) => self.drain(),
                Err(PlanError::TooLong) => {
                    // Halves, each planned on its own.
                    let mut a = mv;
                    let mut b = mv;
                    for i in 0..MAX_AXES {
                        a.steps[i] = mv.steps[i] / 2;
                        b.steps[i] = mv.steps[i] - a.steps[i];
                    }
                    if a.steps.iter().all(|&s| s == 0) {
                        return Err(MoveError::Invalid("move too long for the planner".into()));
                    }
                    self.plan(a)?;
                    return self.plan(b);
                }
                Err(PlanError::Empty) => return Ok(()),
                Err(e) => return Err(MoveError::Invalid(format!("planner refused: {e:?}"))),
            }
        }
    }

    fn drain(&mut self) {
        while let Some(s) = self.planner.pop() {
            self.out.push_back(Out::Segment(s));
            self.pending_moves = self.pending_moves.saturating_sub(1);
        }
    }

    /// Ends the planned motion at rest and queues all of it.
    pub fn flush(&mut self) {
        if self.dirty {
            self.planner.finish();
            self.drain();
            self.dirty = false;
            self.pending_moves = 0;
        }
    }

    /// A probe move to `target`: the motion before it ends at rest, then [`Out::Probe`], the
    /// move planned alone from rest to rest, and [`Out::ProbeEnd`]. A move of no steps is
    /// refused, as grbl refuses a probe target where the machine is: nothing to probe along.
    pub fn push_probe(
        &mut self,
        target: &[Option<f64>],
        feed: Feed,
        kind: ProbeKind,
    ) -> Result<(), MoveError> {
        self.push_event(Out::Probe(kind));
        let refused = match self.push_move(target, feed, false) {
            Ok(()) if !self.dirty => Some(MoveError::Invalid(
                "a probe move to where the machine is: nothing to probe along".into(),
            )),
            Ok(()) => None,
            Err(e) => Some(e),
        };
        if let Some(e) = refused {
            self.out.pop_back();
            return Err(e);
        }
        self.flush();
        self.out.push_back(Out::ProbeEnd);
        Ok(())
    }

    /// The machine came to rest at `steps`, short of where the queued motion ends (a probe move
    /// stopped at its trip); nothing may be planned past it yet.
    pub fn moved_to(&mut self, steps: &[i64; MAX_AXES]) {
        self.pos_steps = *steps;
        self.pos_mm = self.spm.iter().zip(steps).map(|(s, p)| *p as f64 / s).collect();
    }

    /// An event after the motion so far (which ends at rest first).
    pub fn push_event(&mut self, e: Out) {
        self.flush();
        self.out.push_back(e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pipeline() -> Pipeline {
        let src = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/corpus-machine.toml"
        ))
        .unwrap();
        let m = crate::job::parse_machine_toml(&src).unwrap();
        let cfg = crate::convert::machine_config(&m).unwrap();
        Pipeline::new(&m, cfg)
    }

    #[test]
    fn moves_become_segments_that_end_at_rest_after_flush() {
        let mut p = pipeline();
        for i in 1..=40 {
            p.push_move(
                &[Some(i as f64), Some(0.5 * i as f64), None],
                Feed::MmPerMin(1200.0),
                false,
            )
            .unwrap();
        }
        assert!(p.dirty);
        assert!(p.queued_segments() > 0, "a full window emits");
        p.flush();
        let segs: Vec<Segment> = p
            .out
            .iter()
            .filter_map(|o| match o {
                Out::Segment(s) => Some(*s),
                _ => None,
            })
            .collect();
        assert_eq!(segs.last().unwrap().exit_rate.to_bits(), 0);
        let net = crate::plan::net_steps(&segs);
        assert_eq!(&net[..3], &[3200, 1600, 0]);
        assert_eq!(p.pos_steps[..3], [3200, 1600, 0]);
    }

    #[test]
    fn a_probe_move_is_planned_alone_between_its_events() {
        let mut p = pipeline();
        p.push_move(&[Some(5.0), None, None], Feed::Rapid, false).unwrap();
        let kind = ProbeKind::Toward;
        p.push_probe(&[None, None, Some(-10.0)], Feed::MmPerMin(100.0), kind).unwrap();
        assert!(!p.dirty, "nothing waits in the planner");
        let at = |o: Out| p.out.iter().position(|x| *x == o).unwrap();
        let (arm, end) = (at(Out::Probe(kind)), at(Out::ProbeEnd));
        assert_eq!(end, p.out.len() - 1);
        let z_steps: i64 = p.out.range(arm..end).map(|o| seg_steps(o)[2]).sum();
        let x_steps: i64 = p.out.range(arm..end).map(|o| seg_steps(o)[0]).sum();
        assert_eq!((x_steps, z_steps), (0, -4000), "the probe move's segments, Z only");
        assert!(p.out.range(..arm).all(|o| seg_steps(o)[2] == 0), "the rapid before it");
        assert_eq!(p.pos_steps[..3], [400, 0, -4000]);
        // Stopped at its trip: the next move is planned from there.
        p.moved_to(&[400, 0, -1200, 0, 0, 0]);
        assert_eq!(p.pos_mm, vec![5.0, 0.0, -3.0]);
        // Nowhere to go is refused, and leaves nothing queued.
        let n = p.out.len();
        let e = p.push_probe(&[None, None, Some(-3.0)], Feed::MmPerMin(100.0), kind).unwrap_err();
        assert!(matches!(e, MoveError::Invalid(_)), "{e:?}");
        assert_eq!(p.out.len(), n);
    }

    fn seg_steps(o: &Out) -> [i64; MAX_AXES] {
        match o {
            Out::Segment(s) => s.steps.map(i64::from),
            _ => [0; MAX_AXES],
        }
    }

    #[test]
    fn soft_limits_refuse_without_moving() {
        let mut p = pipeline();
        let e = p.push_move(&[Some(600.0), None, None], Feed::Rapid, false).unwrap_err();
        assert!(matches!(e, MoveError::SoftLimit(_)), "{e:?}");
        assert!(p.is_empty());
        p.soft_limits = false;
        p.push_move(&[Some(600.0), None, None], Feed::Rapid, true).unwrap();
        assert!(p.is_empty(), "dry runs queue nothing");
        assert_eq!(p.pos_mm[0], 600.0);
    }
}
