//! The machine as the interpreter sees it from outside: what it reads back after a tool change,
//! a probe move or a units change (rs274ngc's GET_EXTERNAL_* calls).
//!
//! [`World`] models it the way LinuxCNC's stand-alone `rs274` does (saicanon.cc): it follows the
//! canonical calls, a probe move never trips and ends 0.254 mm (0.01 in) back from its target
//! toward where it started, and the tool table is the one given. Running on a machine, the
//! position and the probe result come from the board instead ([`World::set_probe_result`]).

use crate::canon::{Canon, MotionControl, Plane, Pos, ToolEntry, Units};

/// A tool table: entry 0 is the spindle, entries 1.. the tools in table order (LinuxCNC's
/// non-random tool changer).
#[derive(Clone, Debug, PartialEq)]
pub struct ToolTable {
    pub entries: Vec<ToolEntry>,
}

impl ToolTable {
    /// Tools `1..=n` in pockets `1..=n`, no offsets, diameter 0: the table LinuxCNC's rs274 is
    /// run with as the reference here.
    pub fn numbered(n: i32) -> Self {
        let mut entries = vec![ToolEntry::EMPTY];
        for t in 1..=n {
            entries.push(ToolEntry { toolno: t, pocketno: t, ..ToolEntry::EMPTY });
        }
        ToolTable { entries }
    }

    /// `tooldata_find_index_for_tool`: tool 0 is the empty spindle.
    pub fn index_of(&self, toolno: i32) -> Option<usize> {
        if toolno == 0 {
            return Some(0);
        }
        self.entries.iter().skip(1).position(|e| e.toolno == toolno).map(|i| i + 1)
    }

    /// The table as a LinuxCNC `.tbl` file (offsets and diameter in user units).
    pub fn to_tbl(&self) -> String {
        let mut s = String::new();
        for e in self.entries.iter().skip(1) {
            s.push_str(&format!(
                "T{} P{} D{} Z{} ;\n",
                e.toolno, e.pocketno, e.diameter, e.offset[2]
            ));
        }
        s
    }
}

impl Default for ToolTable {
    fn default() -> Self {
        ToolTable::numbered(20)
    }
}

/// Where a probe move ended and whether the probe tripped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeResult {
    /// Position (program units, active system) where the probe tripped, or the target.
    pub probe_position: Pos,
    pub tripped: bool,
    /// Where the machine stands after the move.
    pub end_position: Pos,
}

/// The outside world (LinuxCNC's stand-alone canon model).
#[derive(Clone, Debug)]
pub struct World {
    position: Pos,
    g5x: Pos,
    g92: Pos,
    units: Units,
    pub feed_rate: f64,
    pub control: MotionControl,
    pub tolerance: f64,
    pub naivecam_tolerance: f64,
    pub plane: Plane,
    pub tool_offset: [f64; 9],
    pub tools: ToolTable,
    pub active_slot: i32,
    pub feed_override: bool,
    pub speed_override: bool,
    pub probe_position: Pos,
    pending_probe: Option<ProbeResult>,
}

impl World {
    pub fn new(tools: ToolTable) -> Self {
        World {
            position: [0.0; 6],
            g5x: [0.0; 6],
            g92: [0.0; 6],
            units: Units::Mm,
            feed_rate: 0.0,
            control: MotionControl::Continuous,
            tolerance: 0.0,
            naivecam_tolerance: 0.0,
            plane: Plane::XY,
            tool_offset: [0.0; 9],
            tools,
            active_slot: 1,
            feed_override: true,
            speed_override: true,
            probe_position: [0.0; 6],
            pending_probe: None,
        }
    }

    /// The position the machine reports, in program units of the active system.
    pub fn position(&self) -> Pos {
        self.position
    }

    /// Replaces the simulated outcome of the last probe move (a board's report).
    pub fn set_probe_result(&mut self, r: ProbeResult) {
        self.probe_position = r.probe_position;
        self.position = r.end_position;
        self.pending_probe = Some(r);
    }

    /// Whether the last probe tripped (the simulation never trips, as rs274's does not).
    pub fn probe_tripped(&self) -> bool {
        self.pending_probe.is_some_and(|r| r.tripped)
    }

    /// Follows one call, as saicanon.cc does.
    pub fn observe(&mut self, c: &Canon) {
        match c {
            Canon::StraightTraverse(p) | Canon::StraightFeed(p) => self.position = *p,
            Canon::ArcFeed { first_end, second_end, axis_end_point, a, b, c, .. } => {
                let (f, s, n) = (*first_end, *second_end, *axis_end_point);
                let p = &mut self.position;
                match self.plane {
                    Plane::YZ => (p[0], p[1], p[2]) = (n, f, s),
                    Plane::XZ => (p[0], p[1], p[2]) = (s, n, f),
                    _ => (p[0], p[1], p[2]) = (f, s, n),
                }
                (p[3], p[4], p[5]) = (*a, *b, *c);
            }
            Canon::StraightProbe { end, .. } => self.probe(end),
            Canon::NurbsFeed { points, .. } => {
                // rs274's model reads one past the last control point; the last point is what
                // a machine would report.
                if let Some(last) = points.last() {
                    self.position[0] = last.x;
                    self.position[1] = last.y;
                }
            }
            Canon::SetG5xOffset { offset, .. } => {
                for i in 0..6 {
                    self.position[i] += self.g5x[i] - offset[i];
                }
                self.g5x = *offset;
            }
            Canon::SetG92Offset(offset) => {
                for i in 0..6 {
                    self.position[i] += self.g92[i] - offset[i];
                }
                self.g92 = *offset;
            }
            Canon::UseLengthUnits(u) if *u != self.units => {
                let k = if *u == Units::Inches { 1.0 / 25.4 } else { 25.4 };
                for i in 0..3 {
                    self.position[i] *= k;
                    self.g5x[i] *= k;
                    self.g92[i] *= k;
                }
                self.units = *u;
            }
            Canon::SetFeedRate(f) => self.feed_rate = *f,
            Canon::SetMotionControlMode { mode, tolerance } => {
                self.control = *mode;
                self.tolerance = if *mode == MotionControl::Continuous { *tolerance } else { 0.0 };
            }
            Canon::SetNaivecamTolerance(t) => self.naivecam_tolerance = *t,
            Canon::SelectPlane(p) => self.plane = *p,
            Canon::UseToolLengthOffset(o) => self.tool_offset = *o,
            Canon::SetToolTableEntry { index, entry } => {
                if let Some(e) = self.tools.entries.get_mut(*index as usize) {
                    *e = *entry;
                }
            }
            Canon::ChangeTool(slot) => {
                self.active_slot = *slot;
                if let Some(e) = self.tools.entries.get(*slot as usize).copied() {
                    self.tools.entries[0] = e;
                }
            }
            Canon::ChangeToolNumber(t) => self.active_slot = *t,
            Canon::EnableFeedOverride => self.feed_override = true,
            Canon::DisableFeedOverride => self.feed_override = false,
            Canon::EnableSpeedOverride(_) => self.speed_override = true,
            Canon::DisableSpeedOverride(_) => self.speed_override = false,
            _ => {}
        }
    }

    fn probe(&mut self, end: &Pos) {
        self.pending_probe = None;
        let d: Vec<f64> = (0..3).map(|i| self.position[i] - end[i]).collect();
        let distance = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        self.probe_position = *end;
        if distance != 0.0 {
            let backoff = if self.units == Units::Mm { 0.254 } else { 0.01 };
            for i in 0..3 {
                self.position[i] = end[i] + backoff * (d[i] / distance);
            }
        }
        self.position[3..].copy_from_slice(&end[3..]);
    }
}
