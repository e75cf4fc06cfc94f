//! G-code jobs through `motion-gcode` (an rs274ngc-grade front end checked against LinuxCNC's
//! `rs274`): its canonical calls become job [`Item`]s in machine millimetres, with arcs and
//! splines cut into segments within the machine's `arc_tolerance_mm` (default
//! [`CHORD_TOLERANCE_MM`], grbl's `$12`).
//!
//! A program with any error is refused as a whole, before anything moves; every error is listed.
//! What the board cannot do (spindle-synchronised motion) is refused with a message saying so;
//! what it cannot switch (M62..M68 outputs) is reported as a warning and not executed. A probe
//! move (G38.2..G38.5) becomes one [`Item::Probe`]: `run` drives it alone and replans the rest
//! of the program from where the board stopped ([`stream::Items::probed`]). The spindle (M3,
//! M4, M5) and the coolant (M7, M8, M9) become one [`Item::Outputs`] each time one of them
//! switches, carrying all of them; a dwell (G4) is a stop at rest the runner times.

pub mod cli;
pub mod resume;
pub mod stream;

use crate::job::{Feed, Item, Machine, MoveCmd, Source, Target};
use motion::machine::ProbeKind;
use motion::protocol::{ProgramOutputs, SpindleDir};
use motion_gcode::canon::{Canon, Pos};
use motion_gcode::frame::{Frame, Motion};
use motion_gcode::source::{LineSource, SeekSource};
use motion_gcode::{curves, Diagnostic, Event, Interpreter, Options, ProbeResult};
use std::fmt;
use std::io::Cursor;
use std::path::Path;

/// Default chord tolerance for arcs and splines, mm (grbl's default arc tolerance).
pub const CHORD_TOLERANCE_MM: f64 = crate::job::DEFAULT_ARC_TOLERANCE_MM;

/// The G-code axis letters, in canonical order.
const AXES: [&str; 6] = ["X", "Y", "Z", "A", "B", "C"];

/// A refused G-code program: every error, with file, line, column and word.
#[derive(Clone, Debug, PartialEq)]
pub struct GcodeError {
    pub file: String,
    pub errors: Vec<Diagnostic>,
    /// Errors beyond those listed (a stream keeps the first [`stream::KEEP`]).
    pub omitted: usize,
}

impl fmt::Display for GcodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.errors.len() + self.omitted;
        write!(f, "{n} error{} in the G-code: ", if n == 1 { "" } else { "s" })?;
        for (i, d) in self.errors.iter().enumerate() {
            if i > 0 {
                write!(f, "; ")?;
            }
            write!(f, "{}", d.display_with_file(&self.file))?;
        }
        if self.omitted > 0 {
            write!(f, "; and {} more", self.omitted)?;
        }
        Ok(())
    }
}

impl std::error::Error for GcodeError {}

/// A G-code program as job items, with what was accepted but not executed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Loaded {
    pub items: Vec<Item>,
    /// Warnings, one line each (`FILE:LINE:COL: warning: ...`).
    pub warnings: Vec<String>,
}

/// The interpreter reading a file.
pub(crate) type FileInterpreter = Interpreter<SeekSource<std::io::BufReader<std::fs::File>>>;

/// Reads a G-code file for `machine`.
pub fn load(path: &Path, machine: &Machine) -> Result<Loaded, GcodeError> {
    let (interp, name) = open(path)?;
    to_items(interp, &name, machine)
}

/// The interpreter over the file `path`, and its name for messages; a file that cannot be read
/// is a [`GcodeError`] naming it.
pub(crate) fn open(path: &Path) -> Result<(FileInterpreter, String), GcodeError> {
    let name = path.display().to_string();
    let interp = Interpreter::open(path, Options::default()).map_err(|e| GcodeError {
        file: name.clone(),
        errors: vec![io_diag(&e.to_string())],
        omitted: 0,
    })?;
    Ok((interp, name))
}

/// Parses G-code held in memory (`source` names it in messages).
pub fn parse(src: &str, machine: &Machine) -> Result<Vec<Item>, GcodeError> {
    let interp =
        Interpreter::new(SeekSource::new(Cursor::new(src.as_bytes())), "gcode", Options::default());
    to_items(interp, "gcode", machine).map(|l| l.items)
}

fn io_diag(m: &str) -> Diagnostic {
    Diagnostic {
        severity: motion_gcode::Severity::Error,
        kind: motion_gcode::Kind::Limit,
        line: 0,
        column: 0,
        span: None,
        word: None,
        message: m.to_string(),
        text: String::new(),
    }
}

/// Which G-code axis (0..6) drives each machine axis.
fn axis_map(machine: &Machine) -> Vec<Option<usize>> {
    machine.axes.iter().map(|a| AXES.iter().position(|n| a.name.eq_ignore_ascii_case(n))).collect()
}

/// Turns the interpreter's calls into items; collects every error.
fn to_items<S: LineSource>(
    interp: Interpreter<S>,
    file: &str,
    machine: &Machine,
) -> Result<Loaded, GcodeError> {
    let mut conv = Converter::new(machine);
    let mut errors = Vec::new();
    let mut loaded = Loaded::default();
    for e in interp.keep_going(true) {
        match e {
            Event::Diagnostic(d) if d.is_error() => errors.push(d),
            Event::Diagnostic(d) => loaded.warnings.push(d.display_with_file(file).to_string()),
            Event::Call(c) => {
                if let Err(m) = conv.call(c.line, &c.canon, &mut loaded) {
                    errors.push(machine_diag(c.line, m));
                }
            }
        }
    }
    for (line, m) in conv.notes {
        loaded.warnings.push(format!("{file}:{line}: warning: {m}"));
    }
    if errors.is_empty() {
        Ok(loaded)
    } else {
        Err(GcodeError { file: file.to_string(), errors, omitted: 0 })
    }
}

pub(crate) fn machine_diag(line: u32, message: String) -> Diagnostic {
    Diagnostic { line, ..io_diag(&message) }
}

/// Canonical calls to job items for one machine.
pub(crate) struct Converter<'a> {
    machine: &'a Machine,
    map: Vec<Option<usize>>,
    pub frame: Frame,
    /// (line, message) of what runs without being executed.
    pub notes: Vec<(u32, String)>,
    /// Most notes kept; the rest are only counted in `notes_omitted`.
    pub note_limit: usize,
    pub notes_omitted: usize,
    ended: bool,
    /// The last `F` and its line: rs274 sets the feed before the block's G20/G21, but a feed is
    /// in the units of its own block (as grbl reads it: `G20 G1 X1 F10` is 10 in/min).
    last_feed: Option<(u32, f64)>,
    /// The spindle and coolant as the program has switched them so far.
    outputs: ProgramOutputs,
}

impl<'a> Converter<'a> {
    pub fn new(machine: &'a Machine) -> Self {
        Converter {
            machine,
            map: axis_map(machine),
            frame: Frame::default(),
            notes: Vec::new(),
            note_limit: usize::MAX,
            notes_omitted: 0,
            ended: false,
            last_feed: None,
            outputs: ProgramOutputs::OFF,
        }
    }

    /// Which G-code axis (0..6) drives each machine axis.
    pub fn axis_map(&self) -> &[Option<usize>] {
        &self.map
    }

    /// A probe move ended on the board, where its machine axes latched (`trip_mm`) and came to
    /// rest (`rest_mm`), machine mm per machine axis: the frame moves to the rest position, and
    /// the result is what the interpreter is told, as LinuxCNC's is (#5061..#5066 where it
    /// tripped, or the move's end when it did not, #5070 whether it did, in the program's
    /// coordinates and units). Shared by `run` and the grbl bridge.
    pub fn probe_result(&mut self, tripped: bool, trip_mm: &[f64], rest_mm: &[f64]) -> ProbeResult {
        let machine_pos = |mm: &[f64], frame_pos: &Pos| {
            let mut p = *frame_pos;
            for (g, v) in self.map.iter().zip(mm) {
                if let Some(g) = g {
                    p[*g] = *v;
                }
            }
            p
        };
        let rest = machine_pos(rest_mm, &self.frame.position);
        let probe = if tripped {
            machine_pos(trip_mm, &self.frame.position)
        } else {
            // rs274's rule: no trip leaves the probe position at the programmed end.
            self.frame.position
        };
        let result = ProbeResult {
            probe_position: self.frame.to_program(&probe),
            tripped,
            end_position: self.frame.to_program(&rest),
        };
        self.frame.position = rest;
        result
    }

    fn note(&mut self, line: u32, m: impl Into<String>) {
        if self.notes.len() < self.note_limit {
            self.notes.push((line, m.into()));
        } else {
            self.notes_omitted += 1;
        }
    }

    /// One call; an error names what the board cannot do.
    pub fn call(&mut self, line: u32, c: &Canon, out: &mut Loaded) -> Result<(), String> {
        self.call_into(line, c, &mut out.items)
    }

    /// [`Converter::call`], the items appended to `out`.
    pub fn call_into(&mut self, line: u32, c: &Canon, out: &mut Vec<Item>) -> Result<(), String> {
        if self.ended {
            return Ok(());
        }
        if let Some(o) = switched(self.outputs, c) {
            self.outputs = o;
            out.push(Item::Outputs(o));
        }
        match c {
            Canon::ProgramStop | Canon::OptionalProgramStop => out.push(Item::Pause),
            Canon::ChangeTool(t) => {
                self.note(line, format!("tool change (pocket {t}): the job pauses for the operator"));
                out.push(Item::Pause);
            }
            Canon::ProgramEnd => self.ended = true,
            Canon::Dwell(s) => out.push(Item::Dwell(*s)),
            Canon::SetFeedMode { mode: 1, .. } => {
                return Err("G95 (feed per revolution) needs spindle feedback the board does not have".into())
            }
            Canon::SetSpindleMode { mode, .. } if *mode != 0.0 => {
                return Err("G96 (constant surface speed) needs spindle control the board does not have".into())
            }
            Canon::StartSpeedFeedSynch { .. } => {
                return Err("G33/G33.1 (spindle-synchronised motion) needs spindle feedback the board does not have".into())
            }
            Canon::SetMotionOutputBit(_)
            | Canon::ClearMotionOutputBit(_)
            | Canon::SetAuxOutputBit(_)
            | Canon::ClearAuxOutputBit(_)
            | Canon::SetMotionOutputValue(..)
            | Canon::SetAuxOutputValue(..) => self.note(line, "M62..M68 output: the board has no such output; not switched"),
            Canon::Message(m) => self.note(line, format!("message: {m}")),
            _ => {}
        }
        if let Some(m) = self.frame.apply(c) {
            self.motion(line, &m, out)?;
        }
        match c {
            Canon::SetFeedRate(f) => self.last_feed = Some((line, *f)),
            Canon::UseLengthUnits(_) => {
                if let Some((at, f)) = self.last_feed.filter(|(at, _)| *at == line) {
                    self.frame.apply(&Canon::SetFeedRate(f));
                    self.last_feed = Some((at, f));
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn motion(&mut self, line: u32, m: &Motion, out: &mut Vec<Item>) -> Result<(), String> {
        let source = Source::Gcode { line: line as usize };
        if let Motion::Probe { to, kind, feed_mm_min, .. } = m {
            let target = Target::Absolute(self.target(to)?);
            let mv = MoveCmd { target, feed: Feed::MmPerMin(*feed_mm_min), source };
            out.push(Item::Probe { kind: board_probe_kind(*kind), mv });
            return Ok(());
        }
        let mut point = |p: &Pos, feed: Feed| -> Result<(), String> {
            let target = self.target(p)?;
            out.push(Item::Move(MoveCmd { target: Target::Absolute(target), feed, source }));
            Ok(())
        };
        let (points, feed) = match m {
            // One point: no list of them (the common case, once per line of a CAM file).
            Motion::Rapid { to, .. } => return point(to, Feed::Rapid),
            Motion::Feed { to, feed_mm_min, .. } => return point(to, Feed::MmPerMin(*feed_mm_min)),
            Motion::Arc { feed_mm_min, .. } | Motion::Nurbs { feed_mm_min, .. } => {
                (curves::flatten(m, self.machine.arc_tolerance_mm), Feed::MmPerMin(*feed_mm_min))
            }
            // Taken above, before the closure borrows `out`.
            Motion::Probe { .. } => return Ok(()),
            Motion::RigidTap { .. } => {
                return Err("G33.1 rigid tapping needs spindle synchronisation".into())
            }
        };
        for p in &points {
            point(p, feed)?;
        }
        Ok(())
    }

    /// Machine-axis targets for a G-code position; an axis the machine lacks must stay at 0.
    fn target(&self, p: &Pos) -> Result<Vec<Option<f64>>, String> {
        for (i, v) in p.iter().enumerate() {
            if !self.map.contains(&Some(i)) && v.abs() > 1e-9 {
                return Err(format!(
                    "moves {} to {v:.4} but the machine has no {} axis (it has {})",
                    AXES[i],
                    AXES[i],
                    self.machine.axis_names()
                ));
            }
        }
        Ok(self.map.iter().map(|g| g.map(|i| p[i])).collect())
    }
}

/// The board's probe move for a G38.x word.
fn board_probe_kind(k: motion_gcode::canon::ProbeKind) -> ProbeKind {
    use motion_gcode::canon::ProbeKind as G;
    match k {
        G::TowardError => ProbeKind::TowardError,
        G::Toward => ProbeKind::Toward,
        G::AwayError => ProbeKind::AwayError,
        G::Away => ProbeKind::Away,
    }
}

/// The outputs after `c`, if it is a spindle or coolant call (M9 is two calls, mist then flood
/// off; each gives the whole state).
fn switched(now: ProgramOutputs, c: &Canon) -> Option<ProgramOutputs> {
    Some(match c {
        Canon::StartSpindleClockwise(_) => ProgramOutputs { spindle: SpindleDir::Cw, ..now },
        Canon::StartSpindleCounterclockwise(_) => {
            ProgramOutputs { spindle: SpindleDir::Ccw, ..now }
        }
        Canon::StopSpindleTurning(_) => ProgramOutputs { spindle: SpindleDir::Off, ..now },
        Canon::MistOn => ProgramOutputs { mist: true, ..now },
        Canon::MistOff => ProgramOutputs { mist: false, ..now },
        Canon::FloodOn => ProgramOutputs { flood: true, ..now },
        Canon::FloodOff => ProgramOutputs { flood: false, ..now },
        _ => return None,
    })
}
