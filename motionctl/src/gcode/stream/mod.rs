//! G-code planned as a stream, in memory bounded whatever the file's length: the interpreter
//! reads the file line by line, each call becomes job items ([`Converter`]) and planner items
//! ([`Stepper`]) as the planner's window asks for them, and nothing is kept but counts and the
//! first [`KEEP`] errors and warnings.
//!
//! `plan` and `run` read a file twice. The first pass checks all of it, plans it and runs the
//! plan through the host model ([`check_and_plan`]): a file with any error is refused here,
//! before anything moves, with the same messages as the whole-program path ([`super::load`]);
//! otherwise the pass yields the totals a run needs (segments, planned time, where the job must
//! end). The second pass ([`items`]) reads the file again and streams it to the board
//! ([`outputs`], in `second_pass`).

mod second_pass;
use super::{machine_diag, Converter, GcodeError};
use crate::convert::{ConvertError, Program, ProgramItem, Stepper};
use crate::job::{Item, Machine, Source};
use crate::plan::{self, PlanFailure, SimulateError, Stream, Totals};
use motion::report::Report;
use motion::MAX_AXES;
use motion_gcode::source::{LineSource, SeekSource};
use motion_gcode::{Diagnostic, Event, Interpreter};
pub use second_pass::outputs;
use std::fmt;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// Most errors, and most warnings, a stream keeps; beyond that they are only counted.
pub const KEEP: usize = 1000;

/// The stream ended early: see [`Items::verdict`] for why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The file has an error (the stream then reads on to the end to list every one).
    Refused,
    Plan(PlanFailure),
}

impl From<PlanFailure> for Stop {
    fn from(p: PlanFailure) -> Self {
        Stop::Plan(p)
    }
}

/// Why a G-code file is refused, as the whole-program path says it.
#[derive(Clone, Debug, PartialEq)]
pub enum Refusal {
    /// Errors of the G-code or of what the board cannot do (listed, file:line:column).
    Gcode(GcodeError),
    /// The first move the machine cannot take (a soft limit, a move too long).
    Convert(ConvertError),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Gcode(e) => e.fmt(f),
            Refusal::Convert(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for Refusal {}

/// A G-code file's planner items, read as they are asked for.
pub struct Items<'m, S> {
    interp: Interpreter<S>,
    conv: Converter<'m>,
    stepper: Result<Stepper, ConvertError>,
    file: String,
    /// Items of the last call, handed out from `next_pending` on.
    pending: Vec<Item>,
    next_pending: usize,
    errors: Vec<Diagnostic>,
    errors_total: usize,
    warnings: Vec<String>,
    warnings_total: usize,
    convert_error: Option<ConvertError>,
    failed: bool,
    moves: usize,
    /// Running from a line: the filter, and what it gave that is not handed out yet.
    resume: Option<super::resume::Resume>,
    resumed: std::collections::VecDeque<ProgramItem>,
}

/// The items of the G-code file `path` for `machine`.
pub fn items<'m>(
    path: &Path,
    machine: &'m Machine,
) -> Result<Items<'m, SeekSource<BufReader<File>>>, GcodeError> {
    let (interp, name) = super::open(path)?;
    Ok(Items::new(interp, &name, machine))
}

impl<'m, S: LineSource> Items<'m, S> {
    /// `file` names the program in messages.
    pub fn new(interp: Interpreter<S>, file: &str, machine: &'m Machine) -> Self {
        let mut conv = Converter::new(machine);
        conv.note_limit = KEEP;
        let stepper = Stepper::new(machine);
        Items {
            interp: interp.keep_going(true),
            conv,
            failed: stepper.is_err(),
            stepper,
            file: file.to_string(),
            pending: Vec::new(),
            next_pending: 0,
            errors: Vec::new(),
            errors_total: 0,
            warnings: Vec::new(),
            warnings_total: 0,
            convert_error: None,
            moves: 0,
            resume: None,
            resumed: std::collections::VecDeque::new(),
        }
    }

    /// The job from `at`'s line on, with the approach to it ([`super::resume`]).
    pub fn resume_from(mut self, at: super::resume::ResumeAt) -> Self {
        self.resume = Some(super::resume::Resume::new(at));
        self
    }

    /// With [`Items::resume_from`]: whether the resume line was reached (check once drained).
    pub fn resume_reached(&self) -> bool {
        self.resume.as_ref().is_none_or(|r| r.started())
    }

    fn error(&mut self, d: Diagnostic) {
        self.errors_total += 1;
        if self.errors.len() < KEEP {
            self.errors.push(d);
        }
    }

    /// Planner items handed out so far that move.
    pub fn moves(&self) -> usize {
        self.moves
    }

    /// Moves dropped so far because they round to no steps.
    pub fn skipped_moves(&self) -> usize {
        self.stepper.as_ref().map_or(0, |s| s.skipped_moves())
    }

    /// Where the items so far leave each axis, steps from the start.
    pub fn final_steps(&self) -> [i64; MAX_AXES] {
        // Resuming past the last move: nothing was handed out, the machine stays at the origin.
        if !self.resume_reached() {
            return [0; MAX_AXES];
        }
        self.stepper.as_ref().map_or([0; MAX_AXES], |s| s.final_steps())
    }

    /// Reads the rest of the file, items dropped, so that every error is found.
    pub fn drain(&mut self) {
        for _ in self.by_ref() {}
    }

    /// After the stream has ended: the file's errors (every one, when it was read to the end),
    /// else the first move the machine cannot take.
    pub fn verdict(&self) -> Result<(), Refusal> {
        if self.errors_total > 0 {
            return Err(Refusal::Gcode(GcodeError {
                file: self.file.clone(),
                errors: self.errors.clone(),
                omitted: self.errors_total - self.errors.len(),
            }));
        }
        match (&self.stepper, &self.convert_error) {
            (Err(e), _) | (Ok(_), Some(e)) => Err(Refusal::Convert(e.clone())),
            _ => Ok(()),
        }
    }

    /// Warnings, one line each (`FILE:LINE:COL: warning: ...`), the first [`KEEP`] of each kind,
    /// and how many more there were.
    pub fn warnings(&self) -> (Vec<String>, usize) {
        let mut w = self.warnings.clone();
        for (line, m) in &self.conv.notes {
            w.push(format!("{}:{line}: warning: {m}", self.file));
        }
        let shown = w.len();
        let total = self.warnings_total + self.conv.notes.len() + self.conv.notes_omitted;
        (w, total - shown)
    }

    /// The G-code line an item came from (0 when it has none).
    fn line_of(&self, p: &ProgramItem) -> u32 {
        match p {
            ProgramItem::Move { source: Source::Gcode { line }, .. }
            | ProgramItem::Probe { source: Source::Gcode { line }, .. } => *line as u32,
            _ => 0,
        }
    }

    /// A probe move ended on the board (`trip_steps` and `rest_steps`: steps from the job's
    /// start): the interpreter is told the result, as LinuxCNC's is (#5061..#5066 where it
    /// tripped, or the move's end when it did not, #5070 whether it did, in the program's
    /// coordinates and units), and what follows is planned from where the axes came to rest.
    /// Call it before the next item is asked for.
    pub fn probed(
        &mut self,
        tripped: bool,
        trip_steps: &[i64; MAX_AXES],
        rest_steps: &[i64; MAX_AXES],
    ) {
        let Ok(stepper) = self.stepper.as_mut() else { return };
        stepper.set_position_steps(rest_steps);
        let mm = |steps: &[i64; MAX_AXES]| -> Vec<f64> {
            stepper.steps_per_mm().iter().zip(steps).map(|(spm, s)| *s as f64 / spm).collect()
        };
        let (trip_mm, rest_mm) = (mm(trip_steps), mm(rest_steps));
        let result = self.conv.probe_result(tripped, &trip_mm, &rest_mm);
        self.interp.world_mut().set_probe_result(result);
    }

    fn fail(&mut self) -> Option<Result<ProgramItem, Stop>> {
        self.pending.clear();
        self.next_pending = 0;
        if self.failed {
            return None;
        }
        self.failed = true;
        Some(Err(Stop::Refused))
    }
}

impl<S: LineSource> Iterator for Items<'_, S> {
    type Item = Result<ProgramItem, Stop>;

    /// The next planner item; `Err(Stop::Refused)` once, at the first error, and after that
    /// `None` once the rest of the file has been read for its errors.
    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(p) = self.resumed.pop_front() {
                self.moves += is_move(&p) as usize;
                return Some(Ok(p));
            }
            if self.next_pending < self.pending.len() {
                let i = self.next_pending;
                self.next_pending += 1;
                let Ok(stepper) = self.stepper.as_mut() else { continue };
                match stepper.item(&self.pending[i]) {
                    Ok(Some(p)) if self.resume.is_some() => {
                        let (pos, cfg) = (stepper.final_steps(), *stepper.config());
                        let refused = match self.resume.as_mut() {
                            Some(r) => r.filter(p, pos, &cfg, &mut self.resumed).err(),
                            None => None,
                        };
                        if let Some(m) = refused {
                            self.error(machine_diag(self.line_of(&p), m));
                            if let Some(r) = self.fail() {
                                return Some(r);
                            }
                        }
                        continue;
                    }
                    Ok(Some(p)) => {
                        self.moves += is_move(&p) as usize;
                        return Some(Ok(p));
                    }
                    Ok(None) => continue,
                    Err(e) => {
                        self.convert_error = Some(e);
                        if let Some(r) = self.fail() {
                            return Some(r);
                        }
                        continue;
                    }
                }
            }
            self.pending.clear();
            self.next_pending = 0;
            match self.interp.next_event()? {
                Event::Diagnostic(d) if d.is_error() => {
                    self.error(d);
                    if let Some(r) = self.fail() {
                        return Some(r);
                    }
                }
                Event::Diagnostic(d) => {
                    self.warnings_total += 1;
                    if self.warnings.len() < KEEP {
                        self.warnings.push(d.display_with_file(&self.file).to_string());
                    }
                }
                Event::Call(c) => {
                    if let Err(m) = self.conv.call_into(c.line, &c.canon, &mut self.pending) {
                        self.error(machine_diag(c.line, m));
                        if let Some(r) = self.fail() {
                            return Some(r);
                        }
                    }
                    if self.failed {
                        self.pending.clear();
                    }
                }
            }
        }
    }
}

fn is_move(p: &ProgramItem) -> bool {
    matches!(p, ProgramItem::Move { .. } | ProgramItem::Probe { .. })
}

/// What the checking pass learnt about a file it accepted.
#[derive(Clone, Debug, PartialEq)]
pub struct Checked {
    /// The job in the planner's terms, without its items (they are streamed): config, scale,
    /// where it ends.
    pub program: Program,
    pub totals: Totals,
    /// The host model's run of every segment.
    pub report: Report,
    pub warnings: Vec<String>,
    pub warnings_omitted: usize,
}

/// Why the checking pass refused a file.
#[derive(Debug)]
pub enum CheckError {
    Refused(Refusal),
    Plan(PlanFailure),
    Model(SimulateError),
    /// The model did not end where the job does (a planner or model bug if it happens).
    Mismatch(String),
}

impl fmt::Display for CheckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CheckError::Refused(r) => r.fmt(f),
            CheckError::Plan(p) => p.fmt(f),
            CheckError::Model(m) => m.fmt(f),
            CheckError::Mismatch(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for CheckError {}

/// The first pass: checks the whole of `items`, plans it and runs the plan through the host
/// model, keeping only counts. Errors come in the whole-program path's order: the G-code's
/// (every one), else the first move the machine cannot take, else the planner's refusal.
pub fn check_and_plan<S: LineSource>(
    items: Items<'_, S>,
    progress: impl FnMut(u32),
) -> Result<Checked, CheckError> {
    let (planned, report) = check(items, Some(progress))?;
    let Some(report) = report else {
        return Err(CheckError::Mismatch("the host model did not run".into()));
    };
    let (totals, n) = (planned.totals, planned.program.config.axis_count as usize);
    if report.segments as usize != totals.segments {
        return Err(CheckError::Mismatch(format!(
            "the model ran {} of {} segments",
            report.segments, totals.segments
        )));
    }
    if report.positions[..n] != planned.program.final_steps[..n] {
        return Err(CheckError::Mismatch(format!(
            "the model ended at {:?} steps but the job ends at {:?}",
            &report.positions[..n],
            &planned.program.final_steps[..n]
        )));
    }
    Ok(Checked {
        program: planned.program,
        totals,
        report,
        warnings: planned.warnings,
        warnings_omitted: planned.warnings_omitted,
    })
}

/// What a pass that plans without the host model learnt ([`check_and_plan_only`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    pub program: Program,
    pub totals: Totals,
    pub warnings: Vec<String>,
    pub warnings_omitted: usize,
}

/// [`check_and_plan`] without the host model's tick-by-tick run: check and plan only.
pub fn check_and_plan_only<S: LineSource>(items: Items<'_, S>) -> Result<Planned, CheckError> {
    check(items, None::<fn(u32)>).map(|(p, _)| p)
}

fn check<S: LineSource>(
    mut items: Items<'_, S>,
    model: Option<impl FnMut(u32)>,
) -> Result<(Planned, Option<Report>), CheckError> {
    let config = match &items.stepper {
        Ok(s) => Some(*s.config()),
        Err(_) => None,
    };
    let mut run = None;
    if let Some(config) = config {
        let mut stream: Stream<_, Stop> = Stream::over(&config, items.by_ref());
        run = Some(match model {
            Some(progress) => plan::simulate_stream(&config, &mut stream, progress)
                .map(|(t, r, stopped)| (t, Some(r), stopped)),
            None => {
                let (mut t, mut stopped) = (Totals::default(), None);
                for out in stream.by_ref() {
                    match out {
                        Ok(crate::plan::Output::Segment(s)) => {
                            t.segments += 1;
                            t.nominal_ticks += s.duration_ticks as u64;
                        }
                        Ok(crate::plan::Output::Outputs(_)) => t.spindle_events += 1,
                        Ok(crate::plan::Output::Pause) => t.pauses += 1,
                        Ok(crate::plan::Output::Dwell(s)) => {
                            t.dwells += 1;
                            t.dwell_ms += crate::plan::dwell_ms(s);
                        }
                        Ok(crate::plan::Output::Probe(_)) => t.probes += 1,
                        Ok(crate::plan::Output::ProbeEnd) => {}
                        Err(e) => stopped = Some(e),
                    }
                }
                Ok((t, None, stopped))
            }
        });
    }
    items.drain();
    items.verdict().map_err(CheckError::Refused)?;
    let (Some(config), Some(run)) = (config, run) else {
        // verdict() refuses a machine the stepper refused.
        return Err(CheckError::Mismatch("no machine configuration".into()));
    };
    let (mut totals, report, stopped) = run.map_err(CheckError::Model)?;
    match stopped {
        Some(Stop::Plan(p)) => return Err(CheckError::Plan(p)),
        // verdict() found the error that stopped the stream.
        Some(Stop::Refused) => return Err(CheckError::Mismatch("stopped without an error".into())),
        None => {}
    }
    totals.moves = items.moves();
    totals.skipped_moves = items.skipped_moves();
    let final_steps = items.final_steps();
    let (warnings, warnings_omitted) = items.warnings();
    let steps_per_mm =
        items.stepper.as_ref().map(|s| s.steps_per_mm().to_vec()).unwrap_or_default();
    let program = Program {
        config,
        steps_per_mm,
        items: Vec::new(),
        commands: Vec::new(),
        final_steps,
        skipped_moves: totals.skipped_moves,
    };
    Ok((Planned { program, totals, warnings, warnings_omitted }, report))
}
