//! Canonical machining calls (LinuxCNC's canon.hh), the interpreter's output.
//!
//! Coordinates are in the program's units at the time of the call (see [`Canon::UseLengthUnits`])
//! and in the active coordinate system: the G5x/G92 offsets, the XY rotation and the tool
//! length offset arrive as calls of their own, so a consumer that needs machine coordinates
//! applies them ([`crate::frame::Frame`] does).

/// X, Y, Z, A, B, C.
pub type Pos = [f64; 6];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Units {
    Inches,
    Mm,
}

impl Units {
    /// Millimetres per program unit.
    pub fn mm(self) -> f64 {
        match self {
            Units::Inches => 25.4,
            Units::Mm => 1.0,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    XY,
    YZ,
    XZ,
    UV,
    UW,
    VW,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionControl {
    /// G61.1
    ExactStop,
    /// G61
    ExactPath,
    /// G64 (with its P tolerance, program units; 0: as fast as possible)
    Continuous,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeKind {
    /// G38.2: toward the target until the probe trips; not tripping is an error.
    TowardError,
    /// G38.3: toward, no error.
    Toward,
    /// G38.4: away until the probe clears; not clearing is an error.
    AwayError,
    /// G38.5: away, no error.
    Away,
}

impl ProbeKind {
    /// rs274's probe_type bits: 1 = no error, 2 = away.
    pub fn bits(self) -> u8 {
        match self {
            ProbeKind::TowardError => 0,
            ProbeKind::Toward => 1,
            ProbeKind::AwayError => 2,
            ProbeKind::Away => 3,
        }
    }
}

/// A NURBS control point (X, Y, weight).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlPoint {
    pub x: f64,
    pub y: f64,
    pub w: f64,
}

/// One tool table entry as SET_TOOL_TABLE_ENTRY reports it (offsets in user units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolEntry {
    pub toolno: i32,
    pub pocketno: i32,
    /// X Y Z A B C U V W.
    pub offset: [f64; 9],
    pub diameter: f64,
    pub frontangle: f64,
    pub backangle: f64,
    pub orientation: i32,
}

impl ToolEntry {
    pub const EMPTY: ToolEntry = ToolEntry {
        toolno: -1,
        pocketno: 0,
        offset: [0.0; 9],
        diameter: 0.0,
        frontangle: 0.0,
        backangle: 0.0,
        orientation: 0,
    };
}

/// One canonical machining call.
#[derive(Clone, Debug, PartialEq)]
pub enum Canon {
    UseLengthUnits(Units),
    SetG5xOffset {
        index: i32,
        offset: Pos,
    },
    SetG92Offset(Pos),
    SetXyRotation(f64),
    /// Always CANON_XYZ in rs274ngc.
    SetFeedReferenceXyz,
    OnReset,
    SelectPlane(Plane),
    StraightTraverse(Pos),
    StraightFeed(Pos),
    /// rs274's argument order: the end in the plane's first and second axis, the centre in the
    /// same axes, the turn (+n counterclockwise, -n clockwise: n-1 extra full circles), the end
    /// on the axis normal to the plane, then A, B, C.
    ArcFeed {
        first_end: f64,
        second_end: f64,
        first_axis: f64,
        second_axis: f64,
        rotation: i32,
        axis_end_point: f64,
        a: f64,
        b: f64,
        c: f64,
    },
    StraightProbe {
        end: Pos,
        kind: ProbeKind,
    },
    TurnProbeOn,
    TurnProbeOff,
    /// G33.1: feed to (x, y, z) synchronised with the spindle, reverse, come back.
    RigidTap {
        x: f64,
        y: f64,
        z: f64,
        scale: f64,
    },
    /// G5, G5.1, G5.2/G5.3: a NURBS in the XY plane of the given order.
    NurbsFeed {
        order: u32,
        points: Vec<ControlPoint>,
    },
    Dwell(f64),
    SetFeedRate(f64),
    /// mode 0: units per minute (G93 inverse time also reports 0), 1: units per revolution.
    SetFeedMode {
        spindle: i32,
        mode: i32,
    },
    SetMotionControlMode {
        mode: MotionControl,
        tolerance: f64,
    },
    SetNaivecamTolerance(f64),
    SetSpindleSpeed {
        spindle: i32,
        rpm: f64,
    },
    StartSpindleClockwise(i32),
    StartSpindleCounterclockwise(i32),
    StopSpindleTurning(i32),
    /// 0: constant RPM (G97); otherwise G96's maximum RPM (1e30 without D).
    SetSpindleMode {
        spindle: i32,
        mode: f64,
    },
    OrientSpindle {
        spindle: i32,
        orientation: f64,
        mode: i32,
    },
    WaitSpindleOrientComplete {
        spindle: i32,
        timeout: f64,
    },
    StartSpeedFeedSynch {
        spindle: i32,
        feed_per_revolution: f64,
        velocity_mode: bool,
    },
    StopSpeedFeedSynch,
    MistOn,
    MistOff,
    FloodOn,
    FloodOff,
    SelectTool(i32),
    StartChange,
    ChangeTool(i32),
    ChangeToolNumber(i32),
    /// X Y Z A B C U V W, program units.
    UseToolLengthOffset([f64; 9]),
    SetToolTableEntry {
        index: i32,
        entry: ToolEntry,
    },
    ReloadTooldata,
    EnableFeedOverride,
    DisableFeedOverride,
    EnableSpeedOverride(i32),
    DisableSpeedOverride(i32),
    EnableAdaptiveFeed,
    DisableAdaptiveFeed,
    EnableFeedHold,
    DisableFeedHold,
    SetMotionOutputBit(i32),
    ClearMotionOutputBit(i32),
    SetAuxOutputBit(i32),
    ClearAuxOutputBit(i32),
    SetMotionOutputValue(i32, f64),
    SetAuxOutputValue(i32, f64),
    Comment(String),
    Message(String),
    Log(String),
    LogOpen(String),
    LogAppend(String),
    LogClose,
    ProgramStop,
    OptionalProgramStop,
    PalletShuttle,
    ProgramEnd,
    /// The closing `%` of a program.
    Finish,
}

impl Canon {
    /// True for the calls that move the machine.
    pub fn is_motion(&self) -> bool {
        matches!(
            self,
            Canon::StraightTraverse(_)
                | Canon::StraightFeed(_)
                | Canon::ArcFeed { .. }
                | Canon::StraightProbe { .. }
                | Canon::RigidTap { .. }
                | Canon::NurbsFeed { .. }
        )
    }
}

/// A canonical call and the source line that made it (0: before the first line).
#[derive(Clone, Debug, PartialEq)]
pub struct Call {
    pub line: u32,
    pub canon: Canon,
}
