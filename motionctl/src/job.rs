//! The job model both front ends produce (TOML job files and G-code), and the TOML format itself
//! (`format = "motion-job"`, `version = 1`; see `JOB_FORMAT.md`).
//!
//! Lengths are millimetres (or the axis's own unit for rotary axes), feeds mm/min, rates mm/s.
//! [`crate::convert`] turns a [`Job`] into planner moves in steps.

use motion::machine::ProbeKind;
use motion::protocol::{ProgramOutputs, SpindleDir};
use motion::StepTiming;
use serde::{Deserialize, Deserializer};
use std::collections::BTreeMap;
use std::fmt;

/// The `format` every job file declares.
pub const FORMAT: &str = "motion-job";
/// The only `version` this tool reads.
pub const VERSION: i64 = 1;

/// Largest |coordinate| accepted, mm.
pub const MAX_COORD_MM: f64 = 1.0e6;
/// Largest feed accepted, mm/min.
pub const MAX_FEED_MM_MIN: f64 = 1.0e7;
/// Largest steps per mm accepted.
pub const MAX_STEPS_PER_MM: f64 = 1.0e6;
/// Largest rate, acceleration or jerk accepted (mm/s, mm/s^2).
pub const MAX_KINEMATIC: f64 = 1.0e9;
/// Largest feed override factor (the DDA clamps above 2.0).
pub const MAX_OVERRIDE: f64 = 2.0;

/// A whole job: the machine and what it should do, in machine units.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    pub machine: Machine,
    pub items: Vec<Item>,
    /// Time-stamped feed commands (override, hold, resume), in the order given.
    pub feed_commands: Vec<FeedCommand>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    pub tick_hz: u32,
    /// STEP/DIR timing in nanoseconds.
    pub timing: StepTiming,
    /// Axes in DDA order (axis 0 first); 1..=6.
    pub axes: Vec<Axis>,
    /// How long a limit switch must hold a new level (and the e-stop stay released) before the
    /// board believes it, ms (`switch_debounce_ms`, default 2; 0 = raw inputs).
    pub switch_debounce_ms: f64,
    /// Largest distance between an arc (or spline) and the chords it is cut into, mm
    /// (`arc_tolerance_mm`, default 0.002 as grbl's `$12`).
    pub arc_tolerance_mm: f64,
    /// Axes homed on their switches, in turn (`home_order`, else the axes with a `home` entry
    /// in file order); empty: no switches, homing takes the axes where they stand.
    pub home_order: Vec<usize>,
}

/// Default chord tolerance of arcs and splines, mm (grbl's default `$12`).
pub const DEFAULT_ARC_TOLERANCE_MM: f64 = motion_gcode::curves::DEFAULT_CHORD_TOLERANCE_MM;

/// The board's default switch debounce, ms.
pub const DEFAULT_SWITCH_DEBOUNCE_MS: f64 = motion::config::DEFAULT_SWITCH_DEBOUNCE_US as f64 / 1e3;

impl Machine {
    /// The switch debounce as the board's config carries it.
    pub fn input_filter(&self) -> motion::InputFilterConfig {
        motion::InputFilterConfig {
            switch_debounce_us: (self.switch_debounce_ms * 1e3).round() as u32,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub name: String,
    pub steps_per_mm: f64,
    pub max_rate_mm_s: f64,
    pub accel_mm_s2: f64,
    pub junction_jerk_mm_s: f64,
    /// Soft limits, mm.
    pub min_mm: f64,
    pub max_mm: f64,
    /// Its homing switch (`home = { ... }`), if it has one.
    pub home: Option<crate::homing::AxisHome>,
}

impl Machine {
    /// Index of the axis called `name` (case-insensitive).
    pub fn axis_index(&self, name: &str) -> Option<usize> {
        self.axes.iter().position(|a| a.name.eq_ignore_ascii_case(name))
    }

    /// "X, Y, Z": for error messages.
    pub fn axis_names(&self) -> String {
        let names: Vec<&str> = self.axes.iter().map(|a| a.name.as_str()).collect();
        names.join(", ")
    }

    /// The board's homing config (`HomingConfig::NONE` for a machine without switches).
    pub fn homing(&self) -> motion::protocol::HomingConfig {
        let homes: Vec<_> = self.axes.iter().map(|a| a.home).collect();
        let steps: Vec<f64> = self.axes.iter().map(|a| a.steps_per_mm).collect();
        crate::homing::config(&self.home_order, &homes, &steps)
    }
}

/// One step of the program, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    Move(MoveCmd),
    /// The spindle (M3, M4, M5) and coolant (M7, M8, M9) as they are from here on, all of them:
    /// one switch of the board's outputs. Motion before it completes first.
    Outputs(ProgramOutputs),
    /// Program pause (M0): motion before it completes, then the runner holds until resumed.
    Pause,
    /// Dwell (G4): motion before it completes, then the machine stands still this many seconds.
    Dwell(f64),
    /// A probe move (G38.2..G38.5): motion before it completes, then the board runs `mv` alone
    /// as a probe move (`ArmProbe`), stopping where the probe trips; what follows is planned
    /// from where the axes came to rest.
    Probe {
        kind: ProbeKind,
        mv: MoveCmd,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct MoveCmd {
    pub target: Target,
    pub feed: Feed,
    /// Where the move was written, for error messages.
    pub source: Source,
}

/// Per-axis coordinates, indexed like [`Machine::axes`], mm.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// Absolute coordinates; `None` keeps the axis where it is.
    Absolute(Vec<Option<f64>>),
    /// Distances from the current position (0 for axes that stay).
    Relative(Vec<f64>),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Feed {
    /// As fast as the axes' max rates allow (G0).
    Rapid,
    /// Cartesian path feed, mm/min.
    MmPerMin(f64),
}

/// Where a move came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Entry `index` (0-based) of a TOML job's `[[moves]]`.
    Toml { index: usize },
    /// A G-code block (1-based line).
    Gcode { line: usize },
}

impl Source {
    /// The run journal's cursor for a move from here: the G-code line, or for a TOML job the
    /// entry's number counted from 1 (`moves[0]` is 1), so 0 never names a move.
    pub fn cursor(self) -> usize {
        match self {
            Source::Toml { index } => index.saturating_add(1),
            Source::Gcode { line } => line,
        }
    }
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Source::Toml { index } => write!(f, "moves[{index}]"),
            Source::Gcode { line } => write!(f, "line {line}"),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedCommand {
    /// Machine time from the start of the job, seconds.
    pub at_s: f64,
    pub action: FeedAction,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FeedAction {
    /// Feed override factor, 0..=2.
    Override(f64),
    Hold,
    Resume,
}

/// 1-based line and column in a source file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineCol {
    pub line: usize,
    pub column: usize,
}

impl LineCol {
    /// Line and column of byte offset `at` in `src`.
    pub fn of_offset(src: &str, at: usize) -> LineCol {
        let before = &src[..floor_char_boundary(src, at)];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        LineCol { line, column: before[line_start..].chars().count() + 1 }
    }
}

fn floor_char_boundary(s: &str, mut at: usize) -> usize {
    at = at.min(s.len());
    while !s.is_char_boundary(at) {
        at -= 1;
    }
    at
}

/// A rejected job file: the field (as a path like `machine.axes[1].steps_per_mm`), what is wrong,
/// and where, when known.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JobError {
    pub field: String,
    pub message: String,
    pub at: Option<LineCol>,
}

impl JobError {
    fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        JobError { field: field.into(), message: message.into(), at: None }
    }
}

impl fmt::Display for JobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.field.is_empty() {
            write!(f, "{}", self.message)?;
        } else {
            write!(f, "{}: {}", self.field, self.message)?;
        }
        if let Some(at) = self.at {
            write!(f, " (line {}, column {})", at.line, at.column)?;
        }
        Ok(())
    }
}

impl std::error::Error for JobError {}

/// Parses a TOML job file. Checks `format` and `version` first, then every field.
pub fn parse_toml(src: &str) -> Result<Job, JobError> {
    let raw = parse_raw(src)?;
    let machine = raw.machine.into_machine()?;
    let items = moves_to_items(&raw.moves, &machine)?;
    let feed_commands = raw
        .feed_commands
        .iter()
        .enumerate()
        .map(|(i, c)| c.to_command(i))
        .collect::<Result<_, _>>()?;
    Ok(Job { machine, items, feed_commands })
}

/// Parses only the `[machine]` section of a TOML job file (its moves are checked for syntax but
/// not used): the machine a G-code program runs on.
pub fn parse_machine_toml(src: &str) -> Result<Machine, JobError> {
    parse_raw(src)?.machine.into_machine()
}

fn parse_raw(src: &str) -> Result<RawJob, JobError> {
    check_header(src)?;
    let de = toml::de::Deserializer::parse(src).map_err(|e| toml_error(src, "", &e))?;
    serde_path_to_error::deserialize::<_, RawJob>(de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        toml_error(src, &path, e.inner())
    })
}

fn toml_error(src: &str, field: &str, e: &toml::de::Error) -> JobError {
    JobError {
        field: field.to_string(),
        // toml's messages are one line; keep ours that way.
        message: e.message().trim().replace('\n', "; "),
        at: e.span().map(|s| LineCol::of_offset(src, s.start)),
    }
}

/// `format` and `version`, read leniently so a file of another format or version is named as
/// such rather than failing on its first unknown field.
fn check_header(src: &str) -> Result<(), JobError> {
    #[derive(Deserialize)]
    struct Header {
        format: Option<toml::Value>,
        version: Option<toml::Value>,
    }
    let h: Header = toml::from_str(src).map_err(|e| toml_error(src, "", &e))?;
    match h.format {
        None => {
            return Err(JobError::new(
                "format",
                format!("missing; a job file starts with format = \"{FORMAT}\""),
            ))
        }
        Some(toml::Value::String(s)) if s == FORMAT => {}
        Some(other) => {
            return Err(JobError::new("format", format!("expected \"{FORMAT}\", found {other}")))
        }
    }
    match h.version {
        None => Err(JobError::new("version", format!("missing; expected version = {VERSION}"))),
        Some(toml::Value::Integer(v)) if v == VERSION => Ok(()),
        Some(other) => Err(JobError::new(
            "version",
            format!("unsupported version {other}; this motionctl reads version {VERSION}"),
        )),
    }
}

// ---- the TOML file as written ----

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawJob {
    #[allow(dead_code)]
    format: String,
    #[allow(dead_code)]
    version: i64,
    machine: RawMachine,
    #[serde(default)]
    moves: Vec<RawMove>,
    #[serde(default)]
    feed_commands: Vec<RawFeedCommand>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMachine {
    tick_hz: u32,
    timing: RawTiming,
    axes: Vec<RawAxis>,
    /// At most `motion::config::MAX_SWITCH_DEBOUNCE_US` (50 ms).
    #[serde(default)]
    switch_debounce_ms: Option<NonNegative<50>>,
    /// At most 1 mm: a coarser chord is not an arc.
    #[serde(default)]
    arc_tolerance_mm: Option<Positive<1>>,
    #[serde(default)]
    home_order: Option<Vec<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTiming {
    pulse_ns: u32,
    dir_setup_ns: u32,
    dir_hold_ns: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAxis {
    name: String,
    steps_per_mm: Positive<{ MAX_STEPS_PER_MM as u64 }>,
    max_rate_mm_s: Positive<{ MAX_KINEMATIC as u64 }>,
    accel_mm_s2: Positive<{ MAX_KINEMATIC as u64 }>,
    #[serde(default)]
    junction_jerk_mm_s: NonNegative<{ MAX_KINEMATIC as u64 }>,
    min_mm: Coord,
    max_mm: Coord,
    #[serde(default)]
    home: Option<crate::homing::RawHome>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMove {
    to: Option<BTreeMap<String, Coord>>,
    by: Option<BTreeMap<String, Coord>>,
    feed_mm_min: Option<Positive<{ MAX_FEED_MM_MIN as u64 }>>,
    rapid: Option<bool>,
    spindle: Option<SpindleState>,
    pause: Option<bool>,
    /// Seconds at rest (G4), at most an hour.
    dwell_s: Option<NonNegative<3600>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum SpindleState {
    On,
    Off,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFeedCommand {
    at_s: NonNegative<{ u64::MAX }>,
    action: RawAction,
    factor: Option<NonNegative<{ MAX_OVERRIDE as u64 }>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RawAction {
    Override,
    Hold,
    Resume,
}

/// A finite f64 in `(0, MAX]`.
#[derive(Clone, Copy)]
struct Positive<const MAX: u64>(f64);
/// A finite f64 in `[0, MAX]`.
#[derive(Clone, Copy, Default)]
struct NonNegative<const MAX: u64>(f64);
/// A finite coordinate within `±MAX_COORD_MM`.
#[derive(Clone, Copy)]
struct Coord(f64);

fn finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if !v.is_finite() {
        return Err(serde::de::Error::custom(format!("must be a finite number, got {v}")));
    }
    Ok(v)
}

impl<'de, const MAX: u64> Deserialize<'de> for Positive<MAX> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = finite(d)?;
        if v <= 0.0 || v > MAX as f64 {
            return Err(serde::de::Error::custom(format!("must be > 0 and <= {MAX}, got {v}")));
        }
        Ok(Positive(v))
    }
}

impl<'de, const MAX: u64> Deserialize<'de> for NonNegative<MAX> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = finite(d)?;
        if v < 0.0 || v > MAX as f64 {
            return Err(serde::de::Error::custom(format!("must be >= 0 and <= {MAX}, got {v}")));
        }
        Ok(NonNegative(v))
    }
}

impl<'de> Deserialize<'de> for Coord {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = finite(d)?;
        if v.abs() > MAX_COORD_MM {
            return Err(serde::de::Error::custom(format!(
                "must be within ±{MAX_COORD_MM} mm, got {v}"
            )));
        }
        Ok(Coord(v))
    }
}

impl RawMachine {
    fn into_machine(self) -> Result<Machine, JobError> {
        if self.axes.is_empty() || self.axes.len() > motion::MAX_AXES {
            return Err(JobError::new(
                "machine.axes",
                format!("needs 1..={} axes, found {}", motion::MAX_AXES, self.axes.len()),
            ));
        }
        let mut axes: Vec<Axis> = Vec::with_capacity(self.axes.len());
        for (i, a) in self.axes.into_iter().enumerate() {
            let field = |f: &str| format!("machine.axes[{i}].{f}");
            let name = a.name.trim().to_string();
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(JobError::new(
                    field("name"),
                    format!("must be letters, digits or '_', got {:?}", a.name),
                ));
            }
            if axes.iter().any(|b| b.name.eq_ignore_ascii_case(&name)) {
                return Err(JobError::new(
                    field("name"),
                    format!("axis name {name:?} is used twice"),
                ));
            }
            if a.min_mm.0 >= a.max_mm.0 {
                return Err(JobError::new(
                    field("min_mm"),
                    format!("must be below max_mm ({} >= {})", a.min_mm.0, a.max_mm.0),
                ));
            }
            let limits = crate::homing::AxisLimits {
                steps_per_mm: a.steps_per_mm.0,
                max_rate_mm_s: a.max_rate_mm_s.0,
                min_mm: a.min_mm.0,
                max_mm: a.max_mm.0,
            };
            let home = a
                .home
                .as_ref()
                .map(|h| crate::homing::check_axis(h, &limits))
                .transpose()
                .map_err(|(f, why)| JobError::new(field(&format!("home.{f}")), why))?;
            axes.push(Axis {
                name,
                steps_per_mm: a.steps_per_mm.0,
                max_rate_mm_s: a.max_rate_mm_s.0,
                accel_mm_s2: a.accel_mm_s2.0,
                junction_jerk_mm_s: a.junction_jerk_mm_s.0,
                min_mm: a.min_mm.0,
                max_mm: a.max_mm.0,
                home,
            });
        }
        let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
        let homed: Vec<bool> = axes.iter().map(|a| a.home.is_some()).collect();
        let home_order = crate::homing::order(self.home_order.as_deref(), &names, &homed)
            .map_err(|why| JobError::new("machine.home_order", why))?;
        Ok(Machine {
            tick_hz: self.tick_hz,
            timing: StepTiming {
                pulse_ns: self.timing.pulse_ns,
                dir_setup_ns: self.timing.dir_setup_ns,
                dir_hold_ns: self.timing.dir_hold_ns,
            },
            axes,
            switch_debounce_ms: self.switch_debounce_ms.map_or(DEFAULT_SWITCH_DEBOUNCE_MS, |d| d.0),
            arc_tolerance_mm: self.arc_tolerance_mm.map_or(DEFAULT_ARC_TOLERANCE_MM, |t| t.0),
            home_order,
        })
    }
}

/// `[[moves]]` entries to items. The feed is modal: a move without `feed_mm_min` uses the last
/// one given; `rapid = true` applies to its own entry only.
fn moves_to_items(moves: &[RawMove], machine: &Machine) -> Result<Vec<Item>, JobError> {
    let mut feed_mm_min: Option<f64> = None;
    let mut outputs = ProgramOutputs::OFF;
    let mut items = Vec::with_capacity(moves.len());
    for (index, m) in moves.iter().enumerate() {
        let field = |f: &str| format!("moves[{index}]{f}");
        let kinds = [
            m.to.is_some(),
            m.by.is_some(),
            m.spindle.is_some(),
            m.pause.is_some(),
            m.dwell_s.is_some(),
        ];
        if kinds.iter().filter(|&&k| k).count() != 1 {
            return Err(JobError::new(
                field(""),
                "needs exactly one of `to`, `by`, `spindle`, `pause` or `dwell_s`",
            ));
        }
        if let Some(d) = m.dwell_s {
            no_motion_fields(m, &field)?;
            items.push(Item::Dwell(d.0));
            continue;
        }
        if let Some(s) = m.spindle {
            no_motion_fields(m, &field)?;
            // A job file switches the spindle only; the coolant stays as it is (off).
            let spindle = match s {
                SpindleState::On => SpindleDir::Cw,
                SpindleState::Off => SpindleDir::Off,
            };
            outputs.spindle = spindle;
            items.push(Item::Outputs(outputs));
            continue;
        }
        if let Some(p) = m.pause {
            no_motion_fields(m, &field)?;
            if !p {
                return Err(JobError::new(field(".pause"), "only `pause = true` is meaningful"));
            }
            items.push(Item::Pause);
            continue;
        }
        let coords = |map: &BTreeMap<String, Coord>, key: &str| {
            let mut out = vec![None; machine.axes.len()];
            for (name, v) in map {
                let Some(i) = machine.axis_index(name) else {
                    return Err(JobError::new(
                        field(&format!(".{key}.{name}")),
                        format!("no such axis (axes: {})", machine.axis_names()),
                    ));
                };
                if out[i].is_some() {
                    return Err(JobError::new(
                        field(&format!(".{key}.{name}")),
                        "axis given twice",
                    ));
                }
                out[i] = Some(v.0);
            }
            Ok(out)
        };
        let target = match (&m.to, &m.by) {
            (Some(to), _) => Target::Absolute(coords(to, "to")?),
            (_, Some(by)) => {
                Target::Relative(coords(by, "by")?.into_iter().map(|v| v.unwrap_or(0.0)).collect())
            }
            _ => unreachable!("exactly one kind was checked above"),
        };
        if let Some(f) = m.feed_mm_min {
            feed_mm_min = Some(f.0);
        }
        let feed = match (m.rapid, m.feed_mm_min) {
            (Some(true), Some(_)) => {
                return Err(JobError::new(field(".rapid"), "a rapid move takes no feed_mm_min"))
            }
            (Some(true), None) => Feed::Rapid,
            _ => match feed_mm_min {
                Some(f) => Feed::MmPerMin(f),
                None => {
                    return Err(JobError::new(
                        field(".feed_mm_min"),
                        "missing, and no earlier move set a feed (or use rapid = true)",
                    ))
                }
            },
        };
        items.push(Item::Move(MoveCmd { target, feed, source: Source::Toml { index } }));
    }
    Ok(items)
}

fn no_motion_fields(m: &RawMove, field: &dyn Fn(&str) -> String) -> Result<(), JobError> {
    if m.feed_mm_min.is_some() || m.rapid.is_some() {
        return Err(JobError::new(
            field(""),
            "`spindle`, `pause` and `dwell_s` entries take no feed_mm_min or rapid",
        ));
    }
    Ok(())
}

impl RawFeedCommand {
    fn to_command(&self, i: usize) -> Result<FeedCommand, JobError> {
        let field = |f: &str| format!("feed_commands[{i}].{f}");
        let action = match (self.action, self.factor) {
            (RawAction::Override, Some(f)) => FeedAction::Override(f.0),
            (RawAction::Override, None) => {
                return Err(JobError::new(
                    field("factor"),
                    "missing; action = \"override\" needs a factor in 0..=2",
                ))
            }
            (_, Some(_)) => {
                return Err(JobError::new(
                    field("factor"),
                    "only action = \"override\" takes a factor",
                ))
            }
            (RawAction::Hold, None) => FeedAction::Hold,
            (RawAction::Resume, None) => FeedAction::Resume,
        };
        Ok(FeedCommand { at_s: self.at_s.0, action })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_lines_and_chars() {
        let src = "a = 1\nbé = 2\n";
        assert_eq!(LineCol::of_offset(src, 0), LineCol { line: 1, column: 1 });
        assert_eq!(LineCol::of_offset(src, 6), LineCol { line: 2, column: 1 });
        // 'é' is two bytes but one column.
        assert_eq!(LineCol::of_offset(src, 9), LineCol { line: 2, column: 3 });
        assert_eq!(LineCol::of_offset(src, 999), LineCol { line: 3, column: 1 });
    }

    #[test]
    fn error_display_is_one_line_with_position() {
        let e = JobError {
            field: "machine.tick_hz".into(),
            message: "bad".into(),
            at: Some(LineCol { line: 3, column: 7 }),
        };
        assert_eq!(e.to_string(), "machine.tick_hz: bad (line 3, column 7)");
    }
}
