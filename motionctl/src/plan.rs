//! Planning a [`Program`] into segments and events in order, and the offline run through the host
//! model of the firmware ([`motion::model::run`]).
//!
//! [`Stream`] is what a runner feeds a link from: segments as the planner finalises them, with
//! spindle and pause events in program order (motion before an event is planned to rest first).

use crate::convert::{Program, ProgramItem};
use crate::job::Source;
use motion::planner::{Move, PlanError, Planner};
use motion::report::Report;
use motion::{Segment, MAX_AXES};
use std::fmt;

/// What a runner does next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Output {
    Segment(Segment),
    /// Switch the spindle once every earlier segment has completed.
    Spindle(bool),
    /// Hold once every earlier segment has completed, until the operator resumes.
    Pause,
}

/// The planner refused a move.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlanFailure {
    pub source: Source,
    pub error: PlanError,
}

impl fmt::Display for PlanFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let why = match self.error {
            PlanError::Empty => "no axis moves".to_string(),
            PlanError::Feed => "feed is zero".to_string(),
            PlanError::UnusedAxis { axis } => format!("axis {axis} is not configured"),
            PlanError::Full => "planner window full".to_string(),
            PlanError::TooLong => "move lasts too long for the planner; split it".to_string(),
        };
        write!(f, "{}: planner refused the move: {why}", self.source)
    }
}

impl std::error::Error for PlanFailure {}

/// Segments and events of a program, in order.
pub struct Stream<'a> {
    planner: Planner,
    items: std::slice::Iter<'a, ProgramItem>,
    /// A move that did not fit the window; pushed again once the window has drained.
    retry: Option<(Move, Source)>,
    event: Option<Output>,
    finished: bool,
}

impl<'a> Stream<'a> {
    pub fn new(program: &'a Program) -> Self {
        Stream {
            planner: Planner::new(&program.config),
            items: program.items.iter(),
            retry: None,
            event: None,
            finished: false,
        }
    }
}

impl Iterator for Stream<'_> {
    type Item = Result<Output, PlanFailure>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(seg) = self.planner.pop() {
                return Some(Ok(Output::Segment(seg)));
            }
            // The planner has drained (it was finished before the event was taken).
            if let Some(ev) = self.event.take() {
                return Some(Ok(ev));
            }
            let (mv, source) = match self.retry.take() {
                Some(r) => r,
                None => match self.items.next() {
                    Some(&ProgramItem::Move { mv, source }) => (mv, source),
                    Some(ProgramItem::Spindle(on)) => {
                        self.planner.finish();
                        self.event = Some(Output::Spindle(*on));
                        continue;
                    }
                    Some(ProgramItem::Pause) => {
                        self.planner.finish();
                        self.event = Some(Output::Pause);
                        continue;
                    }
                    None if self.finished => return None,
                    None => {
                        self.planner.finish();
                        self.finished = true;
                        continue;
                    }
                },
            };
            match self.planner.push(&mv) {
                Ok(()) => {}
                // A long move split into more pieces than the window has free: end the motion so
                // far at rest, then push it into the drained window.
                Err(PlanError::Full) if !self.planner.is_full() => {
                    self.planner.finish();
                    self.retry = Some((mv, source));
                }
                Err(PlanError::Full) => self.retry = Some((mv, source)),
                Err(error) => return Some(Err(PlanFailure { source, error })),
            }
        }
    }
}

/// The planned job: every segment, and counts of what was between them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    pub segments: Vec<Segment>,
    pub spindle_events: usize,
    pub pauses: usize,
    /// Sum of the segments' nominal durations (at full speed, override 1.0).
    pub nominal_ticks: u64,
}

pub fn plan(program: &Program) -> Result<Plan, PlanFailure> {
    let mut p = Plan::default();
    for out in Stream::new(program) {
        match out? {
            Output::Segment(s) => {
                p.nominal_ticks += s.duration_ticks as u64;
                p.segments.push(s);
            }
            Output::Spindle(_) => p.spindle_events += 1,
            Output::Pause => p.pauses += 1,
        }
    }
    Ok(p)
}

/// What the offline run found.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub moves: usize,
    pub skipped_moves: usize,
    pub plan: Plan,
    pub report: Report,
    /// False when the model stopped at its tick limit before the job ended (e.g. a hold that is
    /// never resumed).
    pub finished: bool,
}

impl Summary {
    pub fn seconds(&self) -> f64 {
        self.report.ticks as f64 / self.report.tick_hz.max(1) as f64
    }
}

/// Why the offline run failed.
#[derive(Debug)]
pub enum SimulateError {
    Plan(PlanFailure),
    /// The firmware model refused a planned segment (a planner bug if it happens).
    Segment(motion::segment::SegmentError),
}

impl fmt::Display for SimulateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimulateError::Plan(p) => p.fmt(f),
            SimulateError::Segment(e) => write!(f, "the firmware model refused a segment: {e:?}"),
        }
    }
}

impl std::error::Error for SimulateError {}

/// Longest the model runs: generous for ramps, slow overrides and timed holds.
pub fn max_ticks(program: &Program, plan: &Plan) -> u64 {
    let last_command = program.commands.iter().map(|c| c.0).max().unwrap_or(0);
    plan.nominal_ticks
        .saturating_mul(16)
        .saturating_add(last_command)
        .saturating_add(60 * program.config.tick_hz as u64)
}

/// Plans `program` and runs it through the host model of the firmware. `progress` is called now
/// and then with the number of segments completed.
pub fn simulate(program: &Program, progress: impl FnMut(u32)) -> Result<Summary, SimulateError> {
    let plan = plan(program).map_err(SimulateError::Plan)?;
    simulate_plan(program, plan, progress)
}

/// Runs an already planned `program` through the host model.
pub fn simulate_plan(
    program: &Program,
    plan: Plan,
    mut progress: impl FnMut(u32),
) -> Result<Summary, SimulateError> {
    let mut next = plan.segments.iter().copied();
    let limit = max_ticks(program, &plan);
    let report = motion::model::run(
        &program.config,
        || next.next(),
        &program.commands,
        limit,
        |dda, _| {
            if dda.now() % 65_536 == 0 {
                progress(dda.segments_done());
            }
        },
    )
    .map_err(SimulateError::Segment)?;
    let finished = report.segments as usize == plan.segments.len() && report.ticks < limit;
    Ok(Summary {
        moves: program.moves().count(),
        skipped_moves: program.skipped_moves,
        plan,
        report,
        finished,
    })
}

/// Per-axis steps emitted by `segments` (net, signed).
pub fn net_steps(segments: &[Segment]) -> [i64; MAX_AXES] {
    let mut net = [0i64; MAX_AXES];
    for s in segments {
        for (n, &d) in net.iter_mut().zip(&s.steps) {
            *n += d as i64;
        }
    }
    net
}
