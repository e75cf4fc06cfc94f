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
use motion::planner::Move;
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
    Move { mv: Move, source: Source },
    Spindle(bool),
    Pause,
}

impl Program {
    pub fn moves(&self) -> impl Iterator<Item = &Move> {
        self.items.iter().filter_map(|i| match i {
            ProgramItem::Move { mv, .. } => Some(mv),
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

/// The whole job in steps: config, moves, events and feed commands. Checks soft limits per move.
pub fn convert(job: &Job) -> Result<Program, ConvertError> {
    let config = machine_config(&job.machine)?;
    let axes = &job.machine.axes;
    let steps_per_mm: Vec<f64> = axes.iter().map(|a| a.steps_per_mm).collect();
    let mut pos_mm = vec![0.0f64; axes.len()];
    let mut pos_steps = [0i64; MAX_AXES];
    let mut items = Vec::with_capacity(job.items.len());
    let mut skipped_moves = 0;
    for item in &job.items {
        let m = match item {
            Item::Spindle(on) => {
                items.push(ProgramItem::Spindle(*on));
                continue;
            }
            Item::Pause => {
                items.push(ProgramItem::Pause);
                continue;
            }
            Item::Move(m) => m,
        };
        let what = m.source.to_string();
        let target_mm: Vec<f64> = match &m.target {
            Target::Absolute(t) => t.iter().zip(&pos_mm).map(|(t, p)| t.unwrap_or(*p)).collect(),
            Target::Relative(d) => d.iter().zip(&pos_mm).map(|(d, p)| p + d).collect(),
        };
        if target_mm.len() != axes.len() {
            return Err(error(what, "target does not match the machine's axes"));
        }
        let mut steps = [0i32; MAX_AXES];
        for (i, a) in axes.iter().enumerate() {
            let t = target_mm[i];
            if t != pos_mm[i] {
                check_soft_limit(a, t).map_err(|msg| error(&what, msg))?;
            }
            let target_steps = (t * a.steps_per_mm).round() as i64;
            let delta = target_steps - pos_steps[i];
            steps[i] = i32::try_from(delta).map_err(|_| {
                error(
                    &what,
                    format!(
                        "axis {} moves {delta} steps, more than one move can hold ({}); split it",
                        a.name,
                        i32::MAX
                    ),
                )
            })?;
            pos_steps[i] = target_steps;
        }
        pos_mm = target_mm;
        if steps.iter().all(|&s| s == 0) {
            skipped_moves += 1;
            continue;
        }
        let feed_hz = match m.feed {
            Feed::Rapid => rapid_feed_hz(&steps, &config),
            Feed::MmPerMin(f) => {
                if !(f.is_finite() && f > 0.0) {
                    return Err(error(what, format!("feed must be > 0 mm/min, got {f}")));
                }
                feed_hz(&steps, &steps_per_mm, f)
            }
        };
        items.push(ProgramItem::Move { mv: Move { steps, feed_hz }, source: m.source });
    }
    let commands = feed_commands(job, config.tick_hz)?;
    Ok(Program { config, steps_per_mm, items, commands, final_steps: pos_steps, skipped_moves })
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
