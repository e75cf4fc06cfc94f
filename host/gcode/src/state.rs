//! The interpreter's model of the machine and program (rs274ngc's `setup_struct`), in program
//! units and the active coordinate system.

use crate::canon::{MotionControl, Plane, Pos, Units};
use crate::modal::g;
use crate::params::{Lookup, Lookups, SUB_PARAMS};
use crate::source::SourcePos;
use crate::world::ToolTable;
use std::collections::HashMap;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeedMode {
    UnitsPerMinute,
    InverseTime,
    UnitsPerRevolution,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spindle {
    Stopped,
    Clockwise,
    CounterClockwise,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Off,
    Left,
    Right,
}

/// Canned-cycle values kept between blocks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Cycle {
    pub cc: f64,
    pub i: f64,
    pub j: f64,
    pub k: f64,
    pub l: i32,
    pub p: f64,
    pub q: f64,
    pub r: f64,
    /// Initial level (for G98), kept while cycles follow one another.
    pub il: f64,
    pub il_flag: bool,
}

/// What an O-word label marks (rs274ngc's `o_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OKind {
    None,
    Sub,
    Endsub,
    Call,
    Do,
    While,
    If,
    Elseif,
    Else,
    Endif,
    Break,
    Continue,
    Endwhile,
    Return,
    Repeat,
    Endrepeat,
    M98,
    /// A bare `O1234` line (Fanuc-style program or subprogram number).
    Bare,
}

/// A remembered O-word label: where it is and what it is.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Label {
    pub kind: OKind,
    /// Position of the label's line.
    pub at: SourcePos,
    pub repeat_count: i64,
    /// Times the loop has jumped back since it last started (the loop limit).
    pub iterations: u64,
}

/// A subroutine call level (rs274ngc's `context`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Frame {
    pub sub_name: Option<String>,
    /// Where to go back to on return.
    pub position: SourcePos,
    pub saved_params: [f64; SUB_PARAMS],
    pub is_call: bool,
}

impl Default for Frame {
    fn default() -> Self {
        Frame {
            sub_name: None,
            position: SourcePos::default(),
            saved_params: [0.0; SUB_PARAMS],
            is_call: false,
        }
    }
}

/// The interpreter's settings.
#[derive(Clone, Debug)]
pub(crate) struct Settings {
    /// Current position, active system, program units: X Y Z A B C.
    pub cur: Pos,
    pub origin_index: i32,
    /// G54..G59.3 offset of the active system.
    pub origin: Pos,
    /// G92/G52 offset.
    pub axis: Pos,
    pub rotation_xy: f64,
    /// X Y Z A B C U V W.
    pub tool_offset: [f64; 9],
    pub units: Units,
    pub plane: Plane,
    pub absolute: bool,
    pub ijk_absolute: bool,
    pub feed_mode: FeedMode,
    pub feed_rate: f64,
    pub speed: f64,
    pub spindle: Spindle,
    pub css: bool,
    pub motion_mode: i32,
    pub retract_old_z: bool,
    pub control: MotionControl,
    pub tolerance: f64,
    pub naivecam_tolerance: f64,
    pub comp_side: Side,
    pub comp_radius: f64,
    pub arc_not_allowed: bool,
    pub cycle: Cycle,
    pub mist: bool,
    pub flood: bool,
    pub feed_override: bool,
    pub speed_override: bool,
    pub adaptive_feed: bool,
    pub feed_hold: bool,
    pub current_pocket: i32,
    pub selected_pocket: i32,
    pub selected_tool: i32,
    pub tools: ToolTable,
    pub lathe_diameter: bool,
    pub probe_flag: bool,
    pub toolchange_flag: bool,
    pub input_flag: bool,
    pub input_index: i32,
    pub input_digital: bool,
    /// The line being executed (rs274's sequence_number).
    pub line: u32,
    pub percent_flag: bool,
    // O-words.
    pub call_level: usize,
    pub defining_sub: bool,
    pub skipping_o: Option<String>,
    pub skipping_to_sub: Option<String>,
    pub skipping_start: u32,
    pub sub_name: Option<String>,
    pub labels: HashMap<String, Label>,
    pub frames: Vec<Frame>,
    pub executed_if: bool,
    pub doing_break: bool,
    pub doing_continue: bool,
    pub return_value: f64,
    pub value_returned: bool,
    pub test_value: f64,
}

impl Settings {
    pub fn new(tools: ToolTable) -> Self {
        Settings {
            cur: [0.0; 6],
            origin_index: 1,
            origin: [0.0; 6],
            axis: [0.0; 6],
            rotation_xy: 0.0,
            tool_offset: [0.0; 9],
            units: Units::Mm,
            plane: Plane::XY,
            absolute: true,
            ijk_absolute: false,
            feed_mode: FeedMode::UnitsPerMinute,
            feed_rate: 0.0,
            speed: 0.0,
            spindle: Spindle::Stopped,
            css: false,
            motion_mode: g::G80,
            retract_old_z: false,
            control: MotionControl::Continuous,
            tolerance: 0.0,
            naivecam_tolerance: 0.0,
            comp_side: Side::Off,
            comp_radius: 0.0,
            arc_not_allowed: false,
            cycle: Cycle::default(),
            mist: false,
            flood: false,
            feed_override: true,
            speed_override: true,
            adaptive_feed: false,
            feed_hold: true,
            current_pocket: 1,
            selected_pocket: 0,
            selected_tool: 0,
            tools,
            lathe_diameter: false,
            probe_flag: false,
            toolchange_flag: false,
            input_flag: false,
            input_index: -1,
            input_digital: false,
            line: 0,
            percent_flag: false,
            call_level: 0,
            defining_sub: false,
            skipping_o: None,
            skipping_to_sub: None,
            skipping_start: 0,
            sub_name: None,
            labels: HashMap::new(),
            frames: vec![Frame::default(); crate::params::CALL_LEVELS],
            executed_if: false,
            doing_break: false,
            doing_continue: false,
            return_value: 0.0,
            value_returned: false,
            test_value: 0.0,
        }
    }

    /// Program units per user unit of the parameters and tool table (LinuxCNC's user units are
    /// inches in the stand-alone interpreter: GET_EXTERNAL_LENGTH_UNITS() = 0.03937007874016).
    pub fn user_to_program(&self, u: f64) -> f64 {
        let mm = u / USER_UNITS_PER_MM;
        match self.units {
            Units::Inches => mm / 25.4,
            Units::Mm => mm,
        }
    }

    pub fn program_to_user(&self, p: f64) -> f64 {
        let mm = match self.units {
            Units::Inches => p * 25.4,
            Units::Mm => p,
        };
        mm * USER_UNITS_PER_MM
    }

    pub fn comp_on(&self) -> bool {
        self.comp_side != Side::Off
    }

    /// The subroutine whose labels are local here (rs274's `subName` in read_o).
    pub fn local_prefix(&self) -> &str {
        if self.call_level > 0 {
            self.frames[self.call_level].sub_name.as_deref().unwrap_or("")
        } else if self.defining_sub {
            self.sub_name.as_deref().unwrap_or("")
        } else {
            ""
        }
    }
}

/// User (parameter file) units per millimetre.
pub const USER_UNITS_PER_MM: f64 = 0.03937007874016;

/// rs274ngc's `rotate` (angle in degrees).
pub fn rotate(x: &mut f64, y: &mut f64, theta: f64) {
    let t = theta * (std::f64::consts::PI / 180.0);
    let (s, c) = t.sin_cos();
    let xx = *x * c - *y * s;
    let yy = *x * s + *y * c;
    *x = xx;
    *y = yy;
}

/// Rotates the X and Y of a position in place.
pub fn rotate_xy(p: &mut [f64], theta: f64) {
    let (mut x, mut y) = (p[0], p[1]);
    rotate(&mut x, &mut y, theta);
    p[0] = x;
    p[1] = y;
}

fn b(v: bool) -> f64 {
    if v {
        1.0
    } else {
        0.0
    }
}

impl Lookups for Settings {
    fn lookup(&self, what: Lookup) -> f64 {
        match what {
            Lookup::Line => self.line as f64,
            Lookup::MotionMode => self.motion_mode as f64,
            Lookup::Plane => match self.plane {
                Plane::XY => 170.0,
                Plane::XZ => 180.0,
                Plane::YZ => 190.0,
                Plane::UV => 171.0,
                Plane::UW => 181.0,
                Plane::VW => 191.0,
            },
            Lookup::CComp => match self.comp_side {
                Side::Right => 420.0,
                Side::Left => 410.0,
                Side::Off => 400.0,
            },
            Lookup::Metric => b(self.units == Units::Mm),
            Lookup::Imperial => b(self.units == Units::Inches),
            Lookup::Absolute => b(self.absolute),
            Lookup::Incremental => b(!self.absolute),
            Lookup::InverseTime => b(self.feed_mode == FeedMode::InverseTime),
            Lookup::UnitsPerMinute => b(self.feed_mode == FeedMode::UnitsPerMinute),
            Lookup::UnitsPerRev => b(self.feed_mode == FeedMode::UnitsPerRevolution),
            Lookup::CoordSystem => {
                if self.origin_index < 7 {
                    (530 + 10 * self.origin_index) as f64
                } else {
                    (584 + self.origin_index) as f64
                }
            }
            Lookup::ToolOffset => b(self.tool_offset.iter().any(|v| *v != 0.0)),
            Lookup::RetractRPlane => b(!self.retract_old_z),
            Lookup::RetractOldZ => b(self.retract_old_z),
            Lookup::SpindleRpmMode => b(!self.css),
            Lookup::SpindleCssMode => b(self.css),
            Lookup::IjkAbsoluteMode => b(self.ijk_absolute),
            Lookup::LatheDiameterMode => b(self.lathe_diameter),
            Lookup::LatheRadiusMode => b(!self.lathe_diameter),
            Lookup::SpindleOn => b(self.spindle != Spindle::Stopped),
            Lookup::SpindleCw => b(self.spindle == Spindle::Clockwise),
            Lookup::Mist => b(self.mist),
            Lookup::Flood => b(self.flood),
            Lookup::SpeedOverride => b(self.speed_override),
            Lookup::FeedOverride => b(self.feed_override),
            Lookup::AdaptiveFeed => b(self.adaptive_feed),
            Lookup::FeedHold => b(self.feed_hold),
            Lookup::Feed => self.feed_rate,
            Lookup::Rpm => self.speed.abs(),
            Lookup::CurrentTool => {
                self.tools.entries.first().map_or(0.0, |e| e.toolno.max(0) as f64)
            }
            Lookup::CurrentPocket => {
                if self.current_pocket == -1 {
                    -1.0
                } else {
                    self.tool_pocket(self.current_pocket)
                }
            }
            Lookup::SelectedPocket => match self.tool_pocket(self.selected_pocket) {
                0.0 => -1.0,
                p => p,
            },
            Lookup::SelectedTool => self.selected_tool as f64,
            Lookup::Axis(i) => self.cur.get(i as usize).copied().unwrap_or(0.0),
            Lookup::AbsAxis(i) => self.abs_axis(i as usize),
            Lookup::Value => self.return_value,
            Lookup::ValueReturned => b(self.value_returned),
            Lookup::Task | Lookup::RemapLevel => 0.0,
            Lookup::CallLevel => self.call_level as f64,
        }
    }
}

impl Settings {
    fn tool_pocket(&self, index: i32) -> f64 {
        usize::try_from(index)
            .ok()
            .and_then(|i| self.tools.entries.get(i))
            .map_or(0.0, |e| e.pocketno as f64)
    }

    fn abs_axis(&self, i: usize) -> f64 {
        if i < 2 {
            let mut x = self.cur[0] + self.axis[0];
            let mut y = self.cur[1] + self.axis[1];
            rotate(&mut x, &mut y, self.rotation_xy);
            let v = if i == 0 { x } else { y };
            v + self.origin[i] + self.tool_offset[i]
        } else if i < 6 {
            self.cur[i] + self.axis[i] + self.origin[i] + self.tool_offset[i]
        } else {
            0.0
        }
    }
}
