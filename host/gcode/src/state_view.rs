//! A read-only view of the modal state, for a sender's `$G` or a display.

use crate::canon::{MotionControl, Plane, Pos, Units};
use crate::core::Core;
use crate::modal::g_name;
use crate::state::{FeedMode, Side, Spindle};

#[derive(Clone, Debug, PartialEq)]
pub struct ModalState {
    /// The motion mode, ten times its G number (G1: 10; G80: 800; -1 after G5.3).
    pub motion: i32,
    pub plane: Plane,
    pub units: Units,
    pub absolute: bool,
    pub ijk_absolute: bool,
    pub feed_mode: FeedMode,
    /// 1..=9 for G54..G59.3.
    pub coord_system: i32,
    pub tool_length_offset: [f64; 9],
    pub cutter_comp: Side,
    pub retract_old_z: bool,
    pub control: MotionControl,
    pub spindle: Spindle,
    pub mist: bool,
    pub flood: bool,
    /// Tool in the spindle (0: none) and the prepared one.
    pub tool: i32,
    pub selected_tool: i32,
    /// Feed rate in program units per minute (or inverse time), spindle speed in rpm.
    pub feed_rate: f64,
    pub speed: f64,
    /// Position in the active coordinate system, program units.
    pub position: Pos,
    pub g5x_offset: Pos,
    pub g92_offset: Pos,
    pub rotation_xy: f64,
    /// The line last read.
    pub line: u32,
}

impl ModalState {
    pub(crate) fn of(c: &Core) -> Self {
        let s = &c.s;
        ModalState {
            motion: s.motion_mode,
            plane: s.plane,
            units: s.units,
            absolute: s.absolute,
            ijk_absolute: s.ijk_absolute,
            feed_mode: s.feed_mode,
            coord_system: s.origin_index,
            tool_length_offset: s.tool_offset,
            cutter_comp: s.comp_side,
            retract_old_z: s.retract_old_z,
            control: s.control,
            spindle: s.spindle,
            mist: s.mist,
            flood: s.flood,
            tool: s.tools.entries.first().map_or(0, |e| e.toolno.max(0)),
            selected_tool: s.selected_tool,
            feed_rate: s.feed_rate,
            speed: s.speed,
            position: s.cur,
            g5x_offset: s.origin,
            g92_offset: s.axis,
            rotation_xy: s.rotation_xy,
            line: s.line,
        }
    }

    /// The active codes as grbl's `$G` lists them: motion, coordinate system, plane, units,
    /// distance, feed mode, spindle, coolant, tool, feed, speed.
    pub fn codes(&self) -> Vec<String> {
        let mut v = Vec::new();
        if self.motion >= 0 {
            v.push(g_name(self.motion));
        }
        v.push(match self.coord_system {
            1..=6 => format!("G{}", 53 + self.coord_system),
            n => format!("G59.{}", n - 6),
        });
        v.push(
            match self.plane {
                Plane::XY => "G17",
                Plane::XZ => "G18",
                Plane::YZ => "G19",
                Plane::UV => "G17.1",
                Plane::UW => "G18.1",
                Plane::VW => "G19.1",
            }
            .into(),
        );
        v.push(if self.units == Units::Inches { "G20" } else { "G21" }.into());
        v.push(if self.absolute { "G90" } else { "G91" }.into());
        v.push(
            match self.feed_mode {
                FeedMode::InverseTime => "G93",
                FeedMode::UnitsPerMinute => "G94",
                FeedMode::UnitsPerRevolution => "G95",
            }
            .into(),
        );
        v.push(
            match self.spindle {
                Spindle::Clockwise => "M3",
                Spindle::CounterClockwise => "M4",
                Spindle::Stopped => "M5",
            }
            .into(),
        );
        match (self.mist, self.flood) {
            (false, false) => v.push("M9".into()),
            (m, f) => {
                if m {
                    v.push("M7".into());
                }
                if f {
                    v.push("M8".into());
                }
            }
        }
        v.push(format!("T{}", self.tool));
        v.push(format!("F{}", self.feed_rate));
        v.push(format!("S{}", self.speed));
        v
    }
}
