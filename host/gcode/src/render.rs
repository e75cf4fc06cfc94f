//! Canonical calls in rs274's own text form (LinuxCNC's saicanon.cc), so this front end's
//! output and `rs274`'s compare line by line.

use crate::canon::{Canon, MotionControl, Plane, Units};
use std::fmt::Write;

/// The call as rs274 prints it, e.g. `STRAIGHT_FEED(1.0000, 2.0000, 0.0000, 0.0000, 0.0000, 0.0000)`.
pub fn render(c: &Canon) -> String {
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = write_call(&mut s, c);
    s
}

fn six(p: &[f64; 6]) -> String {
    format!("{:.4}, {:.4}, {:.4}, {:.4}, {:.4}, {:.4}", p[0], p[1], p[2], p[3], p[4], p[5])
}

fn plane_name(p: Plane) -> &'static str {
    match p {
        Plane::XY => "XY",
        Plane::YZ => "YZ",
        Plane::XZ => "XZ",
        _ => "UNKNOWN",
    }
}

fn write_call(s: &mut String, c: &Canon) -> std::fmt::Result {
    match c {
        Canon::UseLengthUnits(Units::Inches) => write!(s, "USE_LENGTH_UNITS(CANON_UNITS_INCHES)"),
        Canon::UseLengthUnits(Units::Mm) => write!(s, "USE_LENGTH_UNITS(CANON_UNITS_MM)"),
        Canon::SetG5xOffset { index, offset } => {
            write!(s, "SET_G5X_OFFSET({index}, {})", six(offset))
        }
        Canon::SetG92Offset(p) => write!(s, "SET_G92_OFFSET({})", six(p)),
        Canon::SetXyRotation(t) => write!(s, "SET_XY_ROTATION({t:.4})"),
        Canon::SetFeedReferenceXyz => write!(s, "SET_FEED_REFERENCE(CANON_XYZ)"),
        Canon::OnReset => write!(s, "ON_RESET()"),
        Canon::SelectPlane(p) => write!(s, "SELECT_PLANE(CANON_PLANE_{})", plane_name(*p)),
        Canon::StraightTraverse(p) => write!(s, "STRAIGHT_TRAVERSE({})", six(p)),
        Canon::StraightFeed(p) => write!(s, "STRAIGHT_FEED({})", six(p)),
        Canon::ArcFeed {
            first_end,
            second_end,
            first_axis,
            second_axis,
            rotation,
            axis_end_point,
            a,
            b,
            c,
        } => write!(
            s,
            "ARC_FEED({first_end:.4}, {second_end:.4}, {first_axis:.4}, {second_axis:.4}, \
             {rotation}, {axis_end_point:.4}, {a:.4}, {b:.4}, {c:.4})"
        ),
        Canon::StraightProbe { end, .. } => write!(s, "STRAIGHT_PROBE({})", six(end)),
        Canon::TurnProbeOn => write!(s, "TURN_PROBE_ON()"),
        Canon::TurnProbeOff => write!(s, "TURN_PROBE_OFF()"),
        Canon::RigidTap { x, y, z, .. } => write!(s, "RIGID_TAP({x:.4}, {y:.4}, {z:.4})"),
        Canon::NurbsFeed { points, .. } => write!(s, "NURBS_FEED({}, ...)", points.len()),
        Canon::Dwell(t) => write!(s, "DWELL({t:.4})"),
        Canon::SetFeedRate(f) => write!(s, "SET_FEED_RATE({f:.4})"),
        Canon::SetFeedMode { spindle, mode } => write!(s, "SET_FEED_MODE({spindle}, {mode})"),
        Canon::SetMotionControlMode { mode: MotionControl::ExactStop, .. } => {
            write!(s, "SET_MOTION_CONTROL_MODE(CANON_EXACT_STOP)")
        }
        Canon::SetMotionControlMode { mode: MotionControl::ExactPath, .. } => {
            write!(s, "SET_MOTION_CONTROL_MODE(CANON_EXACT_PATH)")
        }
        Canon::SetMotionControlMode { mode: MotionControl::Continuous, tolerance } => {
            write!(s, "SET_MOTION_CONTROL_MODE(CANON_CONTINUOUS, {tolerance:.6})")
        }
        Canon::SetNaivecamTolerance(t) => write!(s, "SET_NAIVECAM_TOLERANCE({t:.4})"),
        Canon::SetSpindleSpeed { spindle, rpm } => {
            write!(s, "SET_SPINDLE_SPEED({spindle}, {rpm:.4})")
        }
        Canon::StartSpindleClockwise(n) => write!(s, "START_SPINDLE_CLOCKWISE({n})"),
        Canon::StartSpindleCounterclockwise(n) => write!(s, "START_SPINDLE_COUNTERCLOCKWISE({n})"),
        Canon::StopSpindleTurning(n) => write!(s, "STOP_SPINDLE_TURNING({n})"),
        Canon::SetSpindleMode { spindle, mode } => {
            write!(s, "SET_SPINDLE_MODE({spindle} {mode:.4})")
        }
        Canon::OrientSpindle { spindle, orientation, mode } => {
            write!(s, "ORIENT_SPINDLE({spindle}, {orientation:.4}, {mode})")
        }
        Canon::WaitSpindleOrientComplete { spindle, timeout } => {
            write!(s, "SPINDLE.{spindle}.WAIT_ORIENT_COMPLETE({timeout:.4})")
        }
        Canon::StartSpeedFeedSynch { feed_per_revolution, velocity_mode, .. } => {
            write!(s, "START_SPEED_FEED_SYNC({feed_per_revolution:.6},{})", *velocity_mode as i32)
        }
        Canon::StopSpeedFeedSynch => write!(s, "STOP_SPEED_FEED_SYNCH()"),
        Canon::MistOn => write!(s, "MIST_ON()"),
        Canon::MistOff => write!(s, "MIST_OFF()"),
        Canon::FloodOn => write!(s, "FLOOD_ON()"),
        Canon::FloodOff => write!(s, "FLOOD_OFF()"),
        Canon::SelectTool(t) => write!(s, "SELECT_TOOL({t})"),
        Canon::StartChange => write!(s, "START_CHANGE()"),
        Canon::ChangeTool(t) => write!(s, "CHANGE_TOOL({t})"),
        Canon::ChangeToolNumber(t) => write!(s, "CHANGE_TOOL_NUMBER({t})"),
        Canon::UseToolLengthOffset(o) => write!(
            s,
            "USE_TOOL_LENGTH_OFFSET({:.4} {:.4} {:.4}, {:.4} {:.4} {:.4}, {:.4} {:.4} {:.4})",
            o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7], o[8]
        ),
        Canon::SetToolTableEntry { index, entry: e } => {
            let o = &e.offset;
            write!(
                s,
                "SET_TOOL_TABLE_ENTRY({index}, {}, {:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4}, \
                 {:.4}, {:.4}, {})",
                e.toolno, o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7], o[8], e.frontangle,
                e.backangle, e.orientation
            )
        }
        Canon::ReloadTooldata => write!(s, "RELOAD_TOOLDATA()"),
        Canon::EnableFeedOverride => write!(s, "ENABLE_FEED_OVERRIDE()"),
        Canon::DisableFeedOverride => write!(s, "DISABLE_FEED_OVERRIDE()"),
        Canon::EnableSpeedOverride(n) => write!(s, "ENABLE_SPEED_OVERRIDE({n})"),
        Canon::DisableSpeedOverride(n) => write!(s, "DISABLE_SPEED_OVERRIDE({n})"),
        Canon::EnableAdaptiveFeed => write!(s, "ENABLE_ADAPTIVE_FEED()"),
        Canon::DisableAdaptiveFeed => write!(s, "DISABLE_ADAPTIVE_FEED()"),
        Canon::EnableFeedHold => write!(s, "ENABLE_FEED_HOLD()"),
        Canon::DisableFeedHold => write!(s, "DISABLE_FEED_HOLD()"),
        Canon::SetMotionOutputBit(i) => write!(s, "SET_MOTION_OUTPUT_BIT({i})"),
        Canon::ClearMotionOutputBit(i) => write!(s, "CLEAR_MOTION_OUTPUT_BIT({i})"),
        Canon::SetAuxOutputBit(i) => write!(s, "SET_AUX_OUTPUT_BIT({i})"),
        Canon::ClearAuxOutputBit(i) => write!(s, "CLEAR_AUX_OUTPUT_BIT({i})"),
        Canon::SetMotionOutputValue(i, v) => write!(s, "SET_MOTION_OUTPUT_VALUE({i},{v:.6})"),
        Canon::SetAuxOutputValue(i, v) => write!(s, "SET_AUX_OUTPUT_VALUE({i},{v:.6})"),
        Canon::Comment(t) => write!(s, "COMMENT(\"{t}\")"),
        Canon::Message(t) => write!(s, "MESSAGE(\"{t}\")"),
        Canon::Log(t) => write!(s, "LOG(\"{t}\")"),
        Canon::LogOpen(t) => write!(s, "LOGOPEN(\"{t}\")"),
        Canon::LogAppend(t) => write!(s, "LOGAPPEND(\"{t}\")"),
        Canon::LogClose => write!(s, "LOGCLOSE()"),
        Canon::ProgramStop => write!(s, "PROGRAM_STOP()"),
        Canon::OptionalProgramStop => write!(s, "OPTIONAL_PROGRAM_STOP()"),
        Canon::PalletShuttle => write!(s, "PALLET_SHUTTLE()"),
        Canon::ProgramEnd => write!(s, "PROGRAM_END()"),
        Canon::Finish => write!(s, "FINISH()"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calls_print_as_rs274_prints_them() {
        assert_eq!(
            render(&Canon::StraightTraverse([1.5, 0.0, -0.0, 0.0, 0.0, 1.0 / 3.0])),
            "STRAIGHT_TRAVERSE(1.5000, 0.0000, -0.0000, 0.0000, 0.0000, 0.3333)"
        );
        assert_eq!(
            render(&Canon::SetMotionControlMode {
                mode: MotionControl::Continuous,
                tolerance: 0.0
            }),
            "SET_MOTION_CONTROL_MODE(CANON_CONTINUOUS, 0.000000)"
        );
        assert_eq!(
            render(&Canon::SetSpindleMode { spindle: 0, mode: 0.0 }),
            "SET_SPINDLE_MODE(0 0.0000)"
        );
        assert_eq!(render(&Canon::Comment("a b".into())), "COMMENT(\"a b\")");
    }
}
