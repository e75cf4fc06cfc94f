//! Planning a [`Program`] into segments and events in order, and the offline run through the host
//! model of the firmware ([`motion::model::run`]).
//!
//! [`Stream`] is what a runner feeds a link from: segments as the planner finalises them, with
//! spindle and pause events in program order (motion before an event is planned to rest first).

use crate::convert::{Program, ProgramItem};
use crate::job::Source;
use motion::machine::ProbeKind;
use motion::planner::{Move, PlanError, Planner, LOOKAHEAD};
use motion::protocol::ProgramOutputs;
use motion::report::Report;
use motion::{MachineConfig, Segment, MAX_AXES};
use std::collections::VecDeque;
use std::fmt;
use std::marker::PhantomData;

/// What a runner does next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Output {
    Segment(Segment),
    /// Switch the spindle and coolant to this once every earlier segment has completed.
    Outputs(ProgramOutputs),
    /// Hold once every earlier segment has completed, until the operator resumes.
    Pause,
    /// Stand still this many seconds once every earlier segment has completed.
    Dwell(f64),
    /// Once every earlier segment has completed: arm the board for a probe move of this kind.
    /// The probe move's segments follow, then [`Output::ProbeEnd`].
    Probe(ProbeKind),
    /// The probe move's segments are all given: start them, wait for the move to end, and
    /// tell the source where the axes stopped before anything more is pulled from it (what
    /// follows is planned from there).
    ProbeEnd,
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
///
/// It pulls items from `I` only as the planner's window needs them, so a source that streams (a
/// G-code file read line by line) is planned in memory bounded by the window, whatever its
/// length. An item the source cannot give (`Err`) ends the stream at once with that error, with
/// nothing of the window emitted.
pub struct Stream<I, E = PlanFailure> {
    planner: Planner,
    items: I,
    /// A move that did not fit the window; pushed again once the window has drained.
    retry: Option<(Move, Source)>,
    event: Option<Output>,
    /// A probe move, pushed alone once [`Output::Probe`] has been given.
    probe: Option<(Move, Source)>,
    /// The move in `retry` is a probe move: the window is finished after it.
    probing: bool,
    finished: bool,
    /// An error ended the stream.
    failed: bool,
    /// Where the pieces in the window came from, oldest first: (source, pieces).
    sources: VecDeque<(Source, usize)>,
    last_source: Option<Source>,
    _error: PhantomData<E>,
}

type ProgramItems<'a> = std::iter::Map<
    std::slice::Iter<'a, ProgramItem>,
    fn(&ProgramItem) -> Result<ProgramItem, PlanFailure>,
>;

impl<'a> Stream<ProgramItems<'a>> {
    pub fn new(program: &'a Program) -> Self {
        let ok: fn(&ProgramItem) -> Result<ProgramItem, PlanFailure> = |i| Ok(*i);
        Stream::over(&program.config, program.items.iter().map(ok))
    }
}

impl<I, E> Stream<I, E>
where
    I: Iterator<Item = Result<ProgramItem, E>>,
    E: From<PlanFailure>,
{
    /// The items of `items`, planned for `config`.
    pub fn over(config: &MachineConfig, items: I) -> Self {
        Stream {
            planner: Planner::new(config),
            items,
            retry: None,
            event: None,
            probe: None,
            probing: false,
            finished: false,
            failed: false,
            sources: VecDeque::with_capacity(LOOKAHEAD),
            last_source: None,
            _error: PhantomData,
        }
    }

    /// Where the segment [`Iterator::next`] gave last was written (for [`Output::Probe`]: the
    /// probe move).
    pub fn source(&self) -> Option<Source> {
        self.last_source
    }

    /// The item source (to read what it found once the stream has ended).
    pub fn items(&self) -> &I {
        &self.items
    }

    pub fn items_mut(&mut self) -> &mut I {
        &mut self.items
    }

    fn pop(&mut self) -> Option<Segment> {
        let seg = self.planner.pop()?;
        if let Some((source, left)) = self.sources.front_mut() {
            self.last_source = Some(*source);
            *left -= 1;
            if *left == 0 {
                self.sources.pop_front();
            }
        }
        Some(seg)
    }
}

impl<I, E> Iterator for Stream<I, E>
where
    I: Iterator<Item = Result<ProgramItem, E>>,
    E: From<PlanFailure>,
{
    type Item = Result<Output, E>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        loop {
            if let Some(seg) = self.pop() {
                return Some(Ok(Output::Segment(seg)));
            }
            // The planner has drained (it was finished before the event was taken).
            if let Some(ev) = self.event.take() {
                if let Some(p) = self.probe.take() {
                    // The probe event is where its move was written.
                    self.last_source = Some(p.1);
                    self.retry = Some(p);
                    self.probing = true;
                }
                return Some(Ok(ev));
            }
            if self.finished {
                return None;
            }
            let (mv, source) = match self.retry.take() {
                Some(r) => r,
                None => match self.items.next() {
                    Some(Ok(ProgramItem::Move { mv, source })) => (mv, source),
                    Some(Ok(ProgramItem::Outputs(o))) => {
                        self.planner.finish();
                        self.event = Some(Output::Outputs(o));
                        continue;
                    }
                    Some(Ok(ProgramItem::Pause)) => {
                        self.planner.finish();
                        self.event = Some(Output::Pause);
                        continue;
                    }
                    Some(Ok(ProgramItem::Dwell(s))) => {
                        self.planner.finish();
                        self.event = Some(Output::Dwell(s));
                        continue;
                    }
                    Some(Ok(ProgramItem::Probe { kind, mv, source })) => {
                        self.planner.finish();
                        self.event = Some(Output::Probe(kind));
                        self.probe = Some((mv, source));
                        continue;
                    }
                    Some(Err(e)) => {
                        self.failed = true;
                        return Some(Err(e));
                    }
                    None => {
                        self.planner.finish();
                        self.finished = true;
                        continue;
                    }
                },
            };
            let before = self.planner.queued();
            match self.planner.push(&mv) {
                Ok(()) => {
                    let pieces = self.planner.queued().saturating_sub(before);
                    if pieces > 0 {
                        self.sources.push_back((source, pieces));
                    }
                    // A probe move ends at rest, and nothing after it is planned before the
                    // board has said where it stopped.
                    if std::mem::take(&mut self.probing) {
                        self.planner.finish();
                        self.event = Some(Output::ProbeEnd);
                    }
                }
                // A long move split into more pieces than the window has free: end the motion so
                // far at rest, then push it into the drained window.
                Err(PlanError::Full) if !self.planner.is_full() => {
                    self.planner.finish();
                    self.retry = Some((mv, source));
                }
                Err(PlanError::Full) => self.retry = Some((mv, source)),
                Err(error) => {
                    self.failed = true;
                    return Some(Err(PlanFailure { source, error }.into()));
                }
            }
        }
    }
}

/// The planned job: every segment, and counts of what was between them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    pub segments: Vec<Segment>,
    /// Spindle and coolant switches (M3, M4, M5, M7, M8, M9; one per switching call).
    pub spindle_events: usize,
    pub pauses: usize,
    /// Dwells, and their time at rest in milliseconds.
    pub dwells: usize,
    pub dwell_ms: u64,
    /// Probe moves (G38.x).
    pub probes: usize,
    /// Sum of the segments' nominal durations (at full speed, override 1.0).
    pub nominal_ticks: u64,
}

/// A dwell's time, ms (a dwell the interpreter passed is finite and >= 0).
pub fn dwell_ms(seconds: f64) -> u64 {
    (seconds.max(0.0) * 1000.0).round() as u64
}

pub fn plan(program: &Program) -> Result<Plan, PlanFailure> {
    let mut p = Plan::default();
    for out in Stream::new(program) {
        match out? {
            Output::Segment(s) => {
                p.nominal_ticks += s.duration_ticks as u64;
                p.segments.push(s);
            }
            Output::Outputs(_) => p.spindle_events += 1,
            Output::Pause => p.pauses += 1,
            Output::Dwell(s) => {
                p.dwells += 1;
                p.dwell_ms += dwell_ms(s);
            }
            Output::Probe(_) => p.probes += 1,
            Output::ProbeEnd => {}
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

/// What a planned job amounts to, without its segments.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    /// Moves planned (moves that round to no steps are not).
    pub moves: usize,
    pub skipped_moves: usize,
    pub segments: usize,
    /// Spindle and coolant switches (M3, M4, M5, M7, M8, M9; one per switching call).
    pub spindle_events: usize,
    pub pauses: usize,
    pub dwells: usize,
    pub dwell_ms: u64,
    /// Probe moves (G38.x).
    pub probes: usize,
    /// Sum of the segments' nominal durations (at full speed, override 1.0).
    pub nominal_ticks: u64,
}

impl Summary {
    pub fn totals(&self) -> Totals {
        Totals {
            moves: self.moves,
            skipped_moves: self.skipped_moves,
            segments: self.plan.segments.len(),
            spindle_events: self.plan.spindle_events,
            pauses: self.plan.pauses,
            dwells: self.plan.dwells,
            dwell_ms: self.plan.dwell_ms,
            probes: self.plan.probes,
            nominal_ticks: self.plan.nominal_ticks,
        }
    }
}

/// The `plan` summary as one JSON object (`plan --json`): what was planned and, when the host
/// model ran (`report`), what it did; per axis the final position in steps and mm and the peak
/// rate.
pub fn summary_json(
    path: &std::path::Path,
    machine: &crate::job::Machine,
    t: &Totals,
    report: Option<&Report>,
    final_steps: &[i64; motion::MAX_AXES],
) -> serde_json::Value {
    let mut axes = serde_json::Map::new();
    for (i, a) in machine.axes.iter().enumerate() {
        let steps = report.map_or(final_steps[i], |r| r.positions[i]);
        let mut v =
            serde_json::json!({ "final_steps": steps, "final_mm": steps as f64 / a.steps_per_mm });
        if let Some(r) = report {
            v["peak_mm_s"] = serde_json::json!(r.peak_rate_hz[i] as f64 / a.steps_per_mm);
        }
        axes.insert(a.name.clone(), v);
    }
    let hz = machine.tick_hz.max(1) as f64;
    serde_json::json!({
        "job": path.display().to_string(),
        "tick_hz": machine.tick_hz,
        "moves": t.moves,
        "skipped_moves": t.skipped_moves,
        "segments": t.segments,
        "spindle_events": t.spindle_events,
        "pauses": t.pauses,
        "dwells": t.dwells,
        "dwell_s": t.dwell_ms as f64 / 1000.0,
        "probes": t.probes,
        "nominal_s": t.nominal_ticks as f64 / hz,
        "model_s": report.map(|r| r.ticks as f64 / r.tick_hz.max(1) as f64),
        "model_underruns": report.map(|r| r.underruns),
        "axes": axes,
    })
}

/// The lines both `plan` summaries open with: the job, the machine, moves, events, dwells.
fn header(
    path: &std::path::Path,
    m: &crate::job::Machine,
    feed_commands: usize,
    t: &Totals,
) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "job        {}", path.display());
    let _ =
        writeln!(s, "machine    {} axes ({}), tick {} Hz", m.axes.len(), m.axis_names(), m.tick_hz);
    let _ = writeln!(
        s,
        "moves      {} ({} skipped: no steps after rounding)",
        t.moves, t.skipped_moves
    );
    let _ = writeln!(
        s,
        "events     {} spindle, {} pause, {feed_commands} feed commands",
        t.spindle_events, t.pauses,
    );
    dwell_line(&mut s, t);
    s
}

/// The summaries' dwell line, when the job has dwells.
fn dwell_line(s: &mut String, t: &Totals) {
    use std::fmt::Write;
    if t.dwells > 0 {
        let _ = writeln!(
            s,
            "dwells     {} (G4), {:.3} s at rest",
            t.dwells,
            t.dwell_ms as f64 / 1000.0
        );
    }
    if t.probes > 0 {
        let _ = writeln!(
            s,
            "probes     {} (G38.x): planned as if none trips; a run replans from where each \
             stops",
            t.probes
        );
    }
}

/// The `plan` summary as text: the job, what was planned and what the host model did.
pub fn summary_text(
    path: &std::path::Path,
    machine: &crate::job::Machine,
    feed_commands: usize,
    t: &Totals,
    r: &Report,
) -> String {
    use std::fmt::Write;
    let mut s = header(path, machine, feed_commands, t);
    let m = machine;
    let _ = writeln!(
        s,
        "segments   {} planned, {} run by the model, {} underruns",
        t.segments, r.segments, r.underruns
    );
    let _ = writeln!(
        s,
        "time       {:.4} s ({} ticks); nominal {:.4} s",
        r.ticks as f64 / r.tick_hz.max(1) as f64,
        r.ticks,
        t.nominal_ticks as f64 / m.tick_hz as f64
    );
    let _ = writeln!(
        s,
        "{:<6} {:>12} {:>12} {:>12} {:>10} {:>10}",
        "axis", "final_steps", "final_mm", "steps_run", "peak_hz", "peak_mm_s"
    );
    for (i, a) in m.axes.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:<6} {:>12} {:>12.4} {:>12} {:>10} {:>10.2}",
            a.name,
            r.positions[i],
            r.positions[i] as f64 / a.steps_per_mm,
            r.steps[i],
            r.peak_rate_hz[i],
            r.peak_rate_hz[i] as f64 / a.steps_per_mm
        );
    }
    s
}

/// The `plan --no-model` summary: what was planned and where the job ends, without a model run.
pub fn plan_text(
    path: &std::path::Path,
    machine: &crate::job::Machine,
    feed_commands: usize,
    t: &Totals,
    final_steps: &[i64; MAX_AXES],
) -> String {
    use std::fmt::Write;
    let mut s = header(path, machine, feed_commands, t);
    let m = machine;
    let _ = writeln!(s, "segments   {} planned (host model not run: --no-model)", t.segments);
    let _ = writeln!(
        s,
        "time       nominal {:.4} s ({} ticks)",
        t.nominal_ticks as f64 / m.tick_hz.max(1) as f64,
        t.nominal_ticks
    );
    let _ = writeln!(s, "{:<6} {:>12} {:>12}", "axis", "final_steps", "final_mm");
    for (i, a) in m.axes.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:<6} {:>12} {:>12.4}",
            a.name,
            final_steps[i],
            final_steps[i] as f64 / a.steps_per_mm
        );
    }
    s
}

/// A stream planned and run through the host model as the model takes its segments: nothing
/// is kept but the counts. For jobs without feed commands (a G-code file): the model then never
/// holds, so it runs until the last segment is done. `progress` is called now and then with the
/// number of segments completed.
///
/// Returns the totals, the model's report, and the error that ended the stream early, if any (the
/// report then covers the segments before it).
pub fn simulate_stream<I, E>(
    config: &MachineConfig,
    stream: &mut Stream<I, E>,
    mut progress: impl FnMut(u32),
) -> Result<(Totals, Report, Option<E>), SimulateError>
where
    I: Iterator<Item = Result<ProgramItem, E>>,
    E: From<PlanFailure>,
{
    let mut t = Totals::default();
    let mut stopped = None;
    let report = motion::model::run(
        config,
        || loop {
            match stream.next()? {
                Ok(Output::Segment(s)) => {
                    t.segments += 1;
                    t.nominal_ticks += s.duration_ticks as u64;
                    return Some(s);
                }
                Ok(Output::Outputs(_)) => t.spindle_events += 1,
                Ok(Output::Pause) => t.pauses += 1,
                Ok(Output::Dwell(s)) => {
                    t.dwells += 1;
                    t.dwell_ms += dwell_ms(s);
                }
                Ok(Output::Probe(_)) => t.probes += 1,
                Ok(Output::ProbeEnd) => {}
                Err(e) => {
                    stopped = Some(e);
                    return None;
                }
            }
        },
        &[],
        u64::MAX,
        |dda, _| {
            if dda.now() % 65_536 == 0 {
                progress(dda.segments_done());
            }
        },
    )
    .map_err(SimulateError::Segment)?;
    Ok((t, report, stopped))
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
