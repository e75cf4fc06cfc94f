//! [`Job`] (machine units) -> [`MachineConfig`] and planner [`Move`]s (steps).
//!
//! Positions: the commanded absolute position is kept in mm and every target is rounded to steps
//! from it, so each move's steps are `round(target) - round(previous target)` and rounding never
//! accumulates, however many small relative moves there are.
//!
//! Feeds: a move's `feed_hz` is its path speed in step space. A move of `L` mm at `F` mm/min takes
//! `t = L / (F / 60)` s, so `feed_hz = |steps| / t`. Rapids run at the largest speed no axis's
//! max rate forbids.

use crate::job::{Axis, Feed, FeedAction, Item, Job, Machine, Source, Target};
use motion::dda::{Command, MAX_SCHEDULED};
use motion::machine::ProbeKind;
use motion::planner::Move;
use motion::protocol::ProgramOutputs;
use motion::{AxisLimits, MachineConfig, Rate, MAX_AXES};
use std::fmt;

/// A job in the planner's terms.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub config: MachineConfig,
    pub steps_per_mm: Vec<f64>,
    pub items: Vec<ProgramItem>,
    /// Tick-stamped feed commands for the DDA's schedule.
    pub commands: Vec<(u64, Command)>,
    /// Where the job leaves each axis, steps from the start.
    pub final_steps: [i64; MAX_AXES],
    /// Moves that round to no steps at all; they are dropped.
    pub skipped_moves: usize,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProgramItem {
    Move {
        mv: Move,
        source: Source,
    },
    /// The spindle and coolant from here on ([`Item::Outputs`]).
    Outputs(ProgramOutputs),
    Pause,
    /// Seconds at rest.
    Dwell(f64),
    /// A probe move ([`Item::Probe`]): planned alone, from rest to rest.
    Probe {
        kind: ProbeKind,
        mv: Move,
        source: Source,
    },
}

impl Program {
    pub fn moves(&self) -> impl Iterator<Item = &Move> {
        self.items.iter().filter_map(|i| match i {
            ProgramItem::Move { mv, .. } | ProgramItem::Probe { mv, .. } => Some(mv),
            _ => None,
        })
    }
}

/// A job the planner cannot take: which part (a field path or a move) and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConvertError {
    pub what: String,
    pub message: String,
}

impl fmt::Display for ConvertError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.what, self.message)
    }
}

impl std::error::Error for ConvertError {}

fn error(what: impl Into<String>, message: impl Into<String>) -> ConvertError {
    ConvertError { what: what.into(), message: message.into() }
}

/// The machine in steps, validated. Rates are rounded down so no limit is exceeded.
pub fn machine_config(m: &Machine) -> Result<MachineConfig, ConvertError> {
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    if m.axes.is_empty() || m.axes.len() > MAX_AXES {
        return Err(error(
            "machine.axes",
            format!("needs 1..={MAX_AXES} axes, found {}", m.axes.len()),
        ));
    }
    for (i, (a, lim)) in m.axes.iter().zip(axes.iter_mut()).enumerate() {
        let steps = |field: &str, per_mm: f64, min: u32| {
            let v = (per_mm * a.steps_per_mm).floor();
            if !(v >= min as f64 && v <= u32::MAX as f64) {
                return Err(error(
                    format!("machine.axes[{i}].{field}"),
                    format!(
                        "{per_mm} x steps_per_mm {} = {v} steps, outside {min}..={}",
                        a.steps_per_mm,
                        u32::MAX
                    ),
                ));
            }
            Ok(v as u32)
        };
        *lim = AxisLimits {
            max_rate_hz: steps("max_rate_mm_s", a.max_rate_mm_s, 1)?,
            accel_steps_per_s2: steps("accel_mm_s2", a.accel_mm_s2, 1)?,
            junction_jerk_hz: steps("junction_jerk_mm_s", a.junction_jerk_mm_s, 0)?,
        };
    }
    let cfg = MachineConfig {
        tick_hz: m.tick_hz,
        timing: m.timing,
        axis_count: m.axes.len() as u8,
        axes,
    };
    cfg.validate().map_err(|e| {
        let (field, value) = match e.field {
            "tick_hz" => ("machine.tick_hz".to_string(), m.tick_hz.to_string()),
            "pulse_ns" | "dir_setup_ns" | "dir_hold_ns" => {
                let v = match e.field {
                    "pulse_ns" => m.timing.pulse_ns,
                    "dir_setup_ns" => m.timing.dir_setup_ns,
                    _ => m.timing.dir_hold_ns,
                };
                (format!("machine.timing.{}", e.field), v.to_string())
            }
            "max_rate_hz" | "accel_steps_per_s2" => {
                let i = e.axis.unwrap_or(0) as usize;
                let (name, v, unit) = if e.field == "max_rate_hz" {
                    ("max_rate_mm_s", cfg.axes[i].max_rate_hz, "steps/s")
                } else {
                    ("accel_mm_s2", cfg.axes[i].accel_steps_per_s2, "steps/s^2")
                };
                (format!("machine.axes[{i}].{name}"), format!("{v} {unit}"))
            }
            other => (format!("machine.{other}"), String::new()),
        };
        error(field, format!("{} (is {value})", e.reason))
    })?;
    Ok(cfg)
}

/// Job items to planner items one at a time, in machine steps: what [`convert`] does for a whole
/// job, for a caller that streams (a G-code file of any length) and never holds the items.
#[derive(Clone, Debug)]
pub struct Stepper {
    config: MachineConfig,
    axes: Vec<Axis>,
    steps_per_mm: Vec<f64>,
    pos_mm: [f64; MAX_AXES],
    pos_steps: [i64; MAX_AXES],
    skipped_moves: usize,
}

impl Stepper {
    /// Validates `machine` (as [`machine_config`]); every axis starts at 0.
    pub fn new(machine: &Machine) -> Result<Self, ConvertError> {
        let config = machine_config(machine)?;
        Ok(Stepper {
            config,
            axes: machine.axes.clone(),
            steps_per_mm: machine.axes.iter().map(|a| a.steps_per_mm).collect(),
            pos_mm: [0.0; MAX_AXES],
            pos_steps: [0; MAX_AXES],
            skipped_moves: 0,
        })
    }

    pub fn config(&self) -> &MachineConfig {
        &self.config
    }

    pub fn steps_per_mm(&self) -> &[f64] {
        &self.steps_per_mm
    }

    /// Where the items so far leave each axis, steps from the start.
    pub fn final_steps(&self) -> [i64; MAX_AXES] {
        self.pos_steps
    }

    /// The machine stands at `steps` (steps from the start; a probe move stopped short): the
    /// next move goes from there.
    pub fn set_position_steps(&mut self, steps: &[i64; MAX_AXES]) {
        for (i, spm) in self.steps_per_mm.iter().enumerate() {
            self.pos_steps[i] = steps[i];
            self.pos_mm[i] = steps[i] as f64 / spm;
        }
    }

    /// Moves so far that rounded to no steps (dropped).
    pub fn skipped_moves(&self) -> usize {
        self.skipped_moves
    }

    /// One item in steps; `None` for a move that rounds to no steps. Checks soft limits. After an
    /// error the position is unchanged.
    pub fn item(&mut self, item: &Item) -> Result<Option<ProgramItem>, ConvertError> {
        let m = match item {
            Item::Outputs(o) => return Ok(Some(ProgramItem::Outputs(*o))),
            Item::Pause => return Ok(Some(ProgramItem::Pause)),
            Item::Dwell(s) => return Ok(Some(ProgramItem::Dwell(*s))),
            Item::Move(m) => m,
            Item::Probe { kind, mv } => {
                return match self.item(&Item::Move(mv.clone()))? {
                    Some(ProgramItem::Move { mv, source }) => {
                        Ok(Some(ProgramItem::Probe { kind: *kind, mv, source }))
                    }
                    _ => Err(error(
                        mv.source.to_string(),
                        format!("{} probe move rounds to no steps: nothing to probe", kind.gcode()),
                    )),
                }
            }
        };
        let n = self.axes.len();
        let what = || m.source.to_string();
        let given = match &m.target {
            Target::Absolute(t) => t.len(),
            Target::Relative(d) => d.len(),
        };
        if given < n {
            return Err(error(what(), "target does not match the machine's axes"));
        }
        let mut target_mm = [0.0f64; MAX_AXES];
        for i in 0..n {
            target_mm[i] = match &m.target {
                Target::Absolute(t) => t[i].unwrap_or(self.pos_mm[i]),
                Target::Relative(d) => self.pos_mm[i] + d[i],
            };
        }
        let mut steps = [0i32; MAX_AXES];
        let mut target_steps = [0i64; MAX_AXES];
        for (i, a) in self.axes.iter().enumerate() {
            let t = target_mm[i];
            if t != self.pos_mm[i] {
                check_soft_limit(a, t).map_err(|msg| error(what(), msg))?;
            }
            target_steps[i] = (t * a.steps_per_mm).round() as i64;
            let delta = target_steps[i] - self.pos_steps[i];
            steps[i] = i32::try_from(delta).map_err(|_| {
                error(
                    what(),
                    format!(
                        "axis {} moves {delta} steps, more than one move can hold ({}); split it",
                        a.name,
                        i32::MAX
                    ),
                )
            })?;
        }
        let feed_hz = match m.feed {
            _ if steps.iter().all(|&s| s == 0) => None,
            Feed::Rapid => Some(rapid_feed_hz(&steps, &self.config)),
            Feed::MmPerMin(f) => {
                if !(f.is_finite() && f > 0.0) {
                    return Err(error(what(), format!("feed must be > 0 mm/min, got {f}")));
                }
                Some(feed_hz(&steps, &self.steps_per_mm, f))
            }
        };
        self.pos_mm[..n].copy_from_slice(&target_mm[..n]);
        self.pos_steps[..n].copy_from_slice(&target_steps[..n]);
        let Some(feed_hz) = feed_hz else {
            self.skipped_moves += 1;
            return Ok(None);
        };
        Ok(Some(ProgramItem::Move { mv: Move { steps, feed_hz }, source: m.source }))
    }
}

/// The whole job in steps: config, moves, events and feed commands. Checks soft limits per move.
pub fn convert(job: &Job) -> Result<Program, ConvertError> {
    let mut stepper = Stepper::new(&job.machine)?;
    let mut items = Vec::with_capacity(job.items.len());
    for item in &job.items {
        if let Some(p) = stepper.item(item)? {
            items.push(p);
        }
    }
    let commands = feed_commands(job, stepper.config.tick_hz)?;
    Ok(Program {
        config: stepper.config,
        steps_per_mm: stepper.steps_per_mm,
        items,
        commands,
        final_steps: stepper.pos_steps,
        skipped_moves: stepper.skipped_moves,
    })
}

fn check_soft_limit(a: &Axis, t: f64) -> Result<(), String> {
    if !t.is_finite() {
        return Err(format!("axis {} target is not a finite number", a.name));
    }
    if t < a.min_mm {
        return Err(format!(
            "axis {} target {t:.4} mm is below its soft limit min_mm = {}",
            a.name, a.min_mm
        ));
    }
    if t > a.max_mm {
        return Err(format!(
            "axis {} target {t:.4} mm is above its soft limit max_mm = {}",
            a.name, a.max_mm
        ));
    }
    Ok(())
}

/// Step-space path speed for a Cartesian feed: `|steps| / t` with `t = L_mm / (feed / 60)`, where
/// `L_mm` is the length of the move as rounded to steps. Rounded to the nearest step/s, >= 1.
pub fn feed_hz(steps: &[i32; MAX_AXES], steps_per_mm: &[f64], feed_mm_min: f64) -> u32 {
    let mut len_steps_sq = 0.0;
    let mut len_mm_sq = 0.0;
    for (&s, &spm) in steps.iter().zip(steps_per_mm) {
        let s = s as f64;
        len_steps_sq += s * s;
        len_mm_sq += (s / spm) * (s / spm);
    }
    let (len_steps, len_mm) = (len_steps_sq.sqrt(), len_mm_sq.sqrt());
    if len_mm == 0.0 {
        return 1;
    }
    let hz = len_steps * (feed_mm_min / 60.0) / len_mm;
    hz.round().clamp(1.0, u32::MAX as f64) as u32
}

/// The fastest path speed no axis's `max_rate_hz` forbids: min over moving axes of
/// `max_rate_hz * |steps| / |steps_i|`.
pub fn rapid_feed_hz(steps: &[i32; MAX_AXES], cfg: &MachineConfig) -> u32 {
    let len: f64 = steps.iter().map(|&s| s as f64 * s as f64).sum::<f64>().sqrt();
    let hz = steps
        .iter()
        .zip(&cfg.axes)
        .filter(|(&s, _)| s != 0)
        .map(|(&s, a)| a.max_rate_hz as f64 * len / s.unsigned_abs() as f64)
        .fold(f64::INFINITY, f64::min);
    hz.floor().clamp(1.0, u32::MAX as f64) as u32
}

fn feed_commands(job: &Job, tick_hz: u32) -> Result<Vec<(u64, Command)>, ConvertError> {
    if job.feed_commands.len() > MAX_SCHEDULED {
        return Err(error(
            "feed_commands",
            format!("{} given; the DDA schedules at most {MAX_SCHEDULED}", job.feed_commands.len()),
        ));
    }
    let mut out = Vec::with_capacity(job.feed_commands.len());
    for (i, c) in job.feed_commands.iter().enumerate() {
        let at_ticks = c.at_s * tick_hz as f64;
        if !(c.at_s.is_finite() && (0.0..=u64::MAX as f64 / 2.0).contains(&at_ticks)) {
            return Err(error(
                format!("feed_commands[{i}].at_s"),
                format!("out of range: {}", c.at_s),
            ));
        }
        let cmd = match c.action {
            FeedAction::Override(f) => {
                if !(f.is_finite() && (0.0..=crate::job::MAX_OVERRIDE).contains(&f)) {
                    return Err(error(
                        format!("feed_commands[{i}].factor"),
                        format!("must be within 0..=2, got {f}"),
                    ));
                }
                Command::SetOverride(Rate::from_num(f))
            }
            FeedAction::Hold => Command::Hold,
            FeedAction::Resume => Command::Resume,
        };
        out.push((at_ticks.round() as u64, cmd));
    }
    Ok(out)
}
