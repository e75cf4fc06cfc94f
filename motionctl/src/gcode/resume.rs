//! Running a G-code job from a line: after a board reset, a power loss or an abort, the job goes
//! on from where it stopped instead of from the top.
//!
//! The program is read from the start as usual (so every modal state, offset and parameter is
//! what it was at that line), but nothing before the first move of the resume line is sent. In
//! its place the machine, standing at the job's origin (homed, as `run` expects), makes the
//! approach: Z up to the safe height (the Z axis's upper soft limit), a rapid across to where the
//! resume line's move starts, the spindle (in its direction) and the coolant as the program had
//! them there, with a spin-up dwell if the spindle turns, Z down in a rapid to 5 mm above that
//! point and the rest at the plunge feed. From there
//! the program runs as written.
//! Program pauses and dwells before the resume line are skipped; so is the part of that line's
//! move that was already cut (it is cut again: the same path).

use crate::convert::{rapid_feed_hz, ProgramItem};
use crate::job::{Machine, Source};
use anyhow::{bail, Result};
use motion::planner::Move;
use motion::protocol::{ProgramOutputs, SpindleDir};
use motion::{MachineConfig, MAX_AXES};
use std::collections::VecDeque;

/// Seconds the resumed job waits after switching the spindle on, before the plunge.
pub const SPIN_UP_S: f64 = 2.0;
/// The plunge to the resume point runs at this fraction of the Z axis's top speed ...
pub const PLUNGE_FRACTION_OF_Z_MAX: f64 = 0.1;
/// ... over this last stretch above it; the way down to there is a rapid.
pub const PLUNGE_CLEARANCE_MM: f64 = 5.0;

/// Where and how to resume.
#[derive(Clone, Debug, PartialEq)]
pub struct ResumeAt {
    /// The G-code line to resume from (1-based): its first move, or the first move after it.
    /// For a TOML job, the move entry's number from 1 ([`crate::job::Source::cursor`]).
    pub line: usize,
    z_axis: usize,
    /// Safe height and plunge speed, Z steps from the job's origin and steps per second.
    safe_z_steps: i64,
    plunge_hz: u32,
    clearance_steps: i64,
}

impl ResumeAt {
    /// Resuming `machine`'s job at `line`: the machine needs a Z axis (the approach travels
    /// above the work).
    pub fn new(machine: &Machine, line: usize) -> Result<ResumeAt> {
        let Some(z) = machine.axis_index("Z") else {
            bail!(
                "resuming needs a Z axis to travel above the work (the machine has {})",
                machine.axis_names()
            );
        };
        if line == 0 {
            bail!("the resume line must be 1 or more");
        }
        let a = &machine.axes[z];
        let plunge_hz = (a.max_rate_mm_s * a.steps_per_mm * PLUNGE_FRACTION_OF_Z_MAX).max(1.0);
        Ok(ResumeAt {
            line,
            z_axis: z,
            safe_z_steps: (a.max_mm * a.steps_per_mm).floor() as i64,
            plunge_hz: plunge_hz.min(u32::MAX as f64) as u32,
            clearance_steps: (PLUNGE_CLEARANCE_MM * a.steps_per_mm).round() as i64,
        })
    }
}

/// The filter over a program's items (steps), in [`super::stream::Items`].
#[derive(Clone, Debug)]
pub struct Resume {
    at: ResumeAt,
    /// Still before the resume point: the spindle and coolant so far.
    skipping: Option<ProgramOutputs>,
}

impl Resume {
    pub fn new(at: ResumeAt) -> Self {
        Resume { at, skipping: Some(ProgramOutputs::OFF) }
    }

    /// True once the resume point has been passed (the rest goes through as it is).
    pub fn started(&self) -> bool {
        self.skipping.is_none()
    }

    /// The resume line.
    pub fn line(&self) -> usize {
        self.at.line
    }

    /// One item of the program; `pos_after` = where the program stands after it (steps from
    /// the origin). Returns what to send in its place: nothing before the resume point, the
    /// approach and the item at it, the item itself after it.
    pub fn filter(
        &mut self,
        item: ProgramItem,
        pos_after: [i64; MAX_AXES],
        cfg: &MachineConfig,
        out: &mut VecDeque<ProgramItem>,
    ) -> Result<(), String> {
        let Some(outputs) = self.skipping.as_mut() else {
            out.push_back(item);
            return Ok(());
        };
        let (mv, source) = match item {
            ProgramItem::Outputs(o) => {
                *outputs = o;
                return Ok(());
            }
            ProgramItem::Pause | ProgramItem::Dwell(_) => return Ok(()),
            // What follows a probe move depends on where it tripped: one before the resume line
            // cannot be skipped. One at it is approached as a move is.
            ProgramItem::Probe { kind, source: Source::Gcode { line }, .. }
                if line < self.at.line =>
            {
                return Err(format!(
                    "{} probe move before the resume line {}: what follows it depends on where \
                     it trips; resume from this line or before it",
                    kind.gcode(),
                    self.at.line
                ));
            }
            ProgramItem::Move { mv, source } | ProgramItem::Probe { mv, source, .. } => {
                (mv, source)
            }
        };
        if source.cursor() < self.at.line {
            return Ok(());
        }
        let outputs = *outputs;
        self.skipping = None;
        // Where this move starts.
        let mut start = pos_after;
        for (p, &d) in start.iter_mut().zip(&mv.steps) {
            *p -= d as i64;
        }
        let z = self.at.z_axis;
        let safe = self.at.safe_z_steps.max(start[z]);
        let mut at = [0i64; MAX_AXES];
        let mut go = |to: [i64; MAX_AXES], feed: Option<u32>, out: &mut VecDeque<ProgramItem>| {
            let mut steps = [0i32; MAX_AXES];
            for i in 0..MAX_AXES {
                steps[i] = (to[i] - at[i]).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
            }
            at = to;
            if steps.iter().all(|&s| s == 0) {
                return;
            }
            let feed_hz = feed.unwrap_or_else(|| rapid_feed_hz(&steps, cfg));
            out.push_back(ProgramItem::Move { mv: Move { steps, feed_hz }, source });
        };
        // Z up, across at the safe height, spindle and coolant, Z down, the move.
        let mut up = [0i64; MAX_AXES];
        up[z] = safe;
        go(up, None, out);
        let mut above = start;
        above[z] = safe;
        go(above, None, out);
        if outputs != ProgramOutputs::OFF {
            out.push_back(ProgramItem::Outputs(outputs));
        }
        if outputs.spindle != SpindleDir::Off {
            out.push_back(ProgramItem::Dwell(SPIN_UP_S));
        }
        let mut clear = start;
        clear[z] = (start[z] + self.at.clearance_steps).min(safe);
        go(clear, None, out);
        go(start, Some(self.at.plunge_hz), out);
        out.push_back(item);
        Ok(())
    }
}
