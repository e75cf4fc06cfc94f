//! Running a block in rs274ngc's order (`execute_block` in interp_execute.cc, `convert_m`,
//! `convert_g` and `convert_stop` in interp_convert.cc): comment, spindle and feed modes, F, S,
//! T, the M-codes, the G-codes, then the stop codes.

use crate::block::{python_unavailable, Block};
use crate::canon::{Canon, MotionControl, Plane};
use crate::core::Core;
use crate::diag::{check, fail, At, Fault, Res};
use crate::messages as msg;
use crate::modal::{g, group, mgroup};
use crate::state::{rotate_xy, FeedMode, Spindle};

/// How a block ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outcome {
    Ok,
    /// M2/M30 (or M99 in the main program): the program ends.
    Exit,
}

impl Core {
    pub(crate) fn execute_block(&mut self, b: &mut Block) -> Res<Outcome> {
        // An empty comment "()" is no comment to rs274.
        if let Some(c) = b.comment.clone().filter(|c| !c.is_empty()) {
            self.convert_comment(&c)?;
        }
        if b.g_modes[group::SPINDLE_MODE] != -1 {
            if let Some(d) = b.dollar {
                check(
                    !(0.0..1.0).contains(&d),
                    "Invalid spindle ($) number in Spindle Mode command",
                    At::Letter(b'$'),
                )?;
            }
            if b.g_modes[group::SPINDLE_MODE] == g::G97 {
                self.s.css = false;
                self.emit(Canon::SetSpindleMode { spindle: 0, mode: 0.0 })?;
            } else {
                self.s.css = true;
                let mode = b.d.map_or(1e30, f64::abs);
                self.emit(Canon::SetSpindleMode { spindle: 0, mode })?;
            }
        }
        if b.g_modes[group::FEED_MODE] != -1 {
            if let Some(d) = b.dollar {
                check(
                    !(0.0..1.0).contains(&d),
                    "Invalid spindle ($) number in Spindle Feed command",
                    At::Letter(b'$'),
                )?;
            }
            self.convert_feed_mode(b.g_modes[group::FEED_MODE])?;
        }
        if let Some(f) = b.f {
            if self.s.feed_mode != FeedMode::InverseTime {
                self.s.feed_rate = f;
                self.emit(Canon::SetFeedRate(f))?;
            }
        }
        if let Some(sp) = b.s {
            if let Some(d) = b.dollar {
                check(
                    !(-1.0..1.0).contains(&d),
                    "Invalid spindle ($) number in Spindle speed command",
                    At::Letter(b'$'),
                )?;
            }
            if b.dollar.is_none_or(|d| d == -1.0 || d as i32 == 0) {
                self.emit(Canon::SetSpindleSpeed { spindle: 0, rpm: sp })?;
                self.s.speed = sp;
            }
        }
        if let Some(t) = b.t {
            self.convert_tool_select(t)?;
        }
        self.convert_m(b)?;
        self.convert_g(b)?;
        if b.m_modes[mgroup::STOP] != -1 {
            return self.convert_stop(b);
        }
        Ok(Outcome::Ok)
    }

    pub(crate) fn convert_comment(&mut self, comment: &str) -> Res<()> {
        let body = comment.trim_start_matches(|c: char| c.is_ascii_whitespace());
        let lc = body.to_ascii_lowercase();
        let after = |p: &str| body[p.len()..].to_string();
        if lc.starts_with("msg,") {
            self.emit(Canon::Message(after("msg,")))
        } else if lc.starts_with("debug,") {
            let text = self.expand_params(&after("debug,"))?;
            if self.params.num(5599) > 0.0 {
                self.emit(Canon::Message(text))?;
            }
            Ok(())
        } else if lc.starts_with("print,") {
            // rs274 writes these to its own stdout, not as a canonical call.
            Ok(())
        } else if lc.starts_with("log,") {
            let text = self.expand_params(&after("log,"))?;
            self.emit(Canon::Log(text))
        } else if lc.starts_with("logopen,") {
            self.emit(Canon::LogOpen(after("logopen,")))
        } else if lc.starts_with("logappend,") {
            self.emit(Canon::LogAppend(after("logappend,")))
        } else if lc.starts_with("py,") {
            fail(python_unavailable(&after("py,")))
        } else if lc.starts_with("pyrun,") {
            fail(python_unavailable(&after("pyrun,")))
        } else if lc.starts_with("pyreload") {
            fail("pyreload: Python plugin not initialized")
        } else if lc.starts_with("abort,") {
            let text = self.expand_params(&after("abort,"))?;
            fail(text)
        } else if lc == "logclose" {
            self.emit(Canon::LogClose)
        } else {
            self.emit(Canon::Comment(body.to_string()))
        }
    }

    /// `convert_param_comment`: `#n`, `#<name>` and `%d`/`%f`/`%.Nf` formats in (debug,...).
    fn expand_params(&self, text: &str) -> Res<String> {
        let t = text.as_bytes();
        let mut out = String::new();
        let mut fmt_prec: Option<usize> = None; // None: %lf (6 places)
        let mut i = 0;
        while i < t.len() {
            match t[i] {
                b'%' => {
                    i += 1;
                    match t.get(i) {
                        Some(b'd') => {
                            fmt_prec = Some(0);
                            i += 1;
                        }
                        Some(b'f') => {
                            fmt_prec = Some(4);
                            i += 1;
                        }
                        Some(b'.') => {
                            i += 1;
                            match (t.get(i), t.get(i + 1)) {
                                (Some(d), Some(b'f')) if d.is_ascii_digit() => {
                                    fmt_prec = Some((d - b'0') as usize);
                                    i += 2;
                                }
                                _ => out.push('.'),
                            }
                        }
                        _ => out.push('%'),
                    }
                }
                b'#' => {
                    i += 1;
                    if i >= t.len() {
                        return fail(msg::NAMED_PARAMETER_NOT_TERMINATED);
                    }
                    let value = if t[i].is_ascii_digit() {
                        let start = i;
                        while i < t.len() && t[i].is_ascii_digit() {
                            i += 1;
                        }
                        let n: usize = text[start..i].parse().unwrap_or(usize::MAX);
                        (n < crate::params::MAX_PARAMETERS).then(|| self.params.num(n))
                    } else if t[i] == b'<' {
                        i += 1;
                        let mut name = String::new();
                        while i < t.len() && t[i] != b')' && t[i] != b'>' {
                            if !t[i].is_ascii_whitespace() {
                                name.push(t[i].to_ascii_lowercase() as char);
                            }
                            i += 1;
                        }
                        if t.get(i) != Some(&b'>') {
                            return fail(msg::NAMED_PARAMETER_NOT_TERMINATED);
                        }
                        i += 1;
                        self.params.find_named(&name, self.s.call_level, &self.s)
                    } else {
                        out.push('#');
                        continue;
                    };
                    match value {
                        Some(v) => {
                            let v = if (v - 0.0).abs() < 0.0001 { 0.0 } else { v };
                            let s = format!("{:.*}", fmt_prec.unwrap_or(6), v);
                            out.push_str(if s.len() >= 30 { "######" } else { &s });
                        }
                        None => out.push_str("######"),
                    }
                }
                _ => {
                    let ch = text[i..].chars().next().unwrap_or(' ');
                    out.push(ch);
                    i += ch.len_utf8();
                }
            }
        }
        Ok(out)
    }

    fn convert_feed_mode(&mut self, code: i32) -> Res<()> {
        match code {
            g::G93 => {
                self.emit(Canon::Comment("interpreter: feed mode set to inverse time".into()))?;
                self.s.feed_mode = FeedMode::InverseTime;
                self.emit(Canon::SetFeedMode { spindle: 0, mode: 0 })?;
            }
            g::G94 => {
                self.emit(Canon::Comment("interpreter: feed mode set to units per minute".into()))?;
                self.s.feed_mode = FeedMode::UnitsPerMinute;
                self.emit(Canon::SetFeedMode { spindle: 0, mode: 0 })?;
                self.s.feed_rate = 0.0;
                self.emit(Canon::SetFeedRate(0.0))?;
            }
            _ => {
                self.emit(Canon::Comment(
                    "interpreter: feed mode set to units per revolution".into(),
                ))?;
                self.s.feed_mode = FeedMode::UnitsPerRevolution;
                self.emit(Canon::SetFeedMode { spindle: 0, mode: 1 })?;
                self.s.feed_rate = 0.0;
                self.emit(Canon::SetFeedRate(0.0))?;
            }
        }
        Ok(())
    }

    fn convert_m(&mut self, b: &mut Block) -> Res<()> {
        self.convert_m_io(b)?;
        match b.m_modes[mgroup::TOOL] {
            6 => self.convert_tool_change()?,
            61 => self.convert_m61(b)?,
            _ => {}
        }
        self.convert_m_spindle(b)?;
        match b.m_modes[mgroup::COOLANT] {
            7 => {
                self.emit(Canon::MistOn)?;
                self.s.mist = true;
            }
            8 => {
                self.emit(Canon::FloodOn)?;
                self.s.flood = true;
            }
            9 => {
                self.emit(Canon::MistOff)?;
                self.s.mist = false;
                self.emit(Canon::FloodOff)?;
                self.s.flood = false;
            }
            _ => {}
        }
        self.convert_m_overrides(b)?;
        let m = b.m_modes[mgroup::USER];
        if m != -1 {
            // No user M-code programs are defined.
            return Err(Fault::new(msg::unknown_m_code(m), At::MGroup(mgroup::USER)));
        }
        Ok(())
    }

    fn convert_m_io(&mut self, b: &Block) -> Res<()> {
        let m = b.m_modes[mgroup::IO];
        let at = At::MGroup(mgroup::IO);
        let comp = self.s.comp_on();
        let p = b.p_number.round_ties_even() as i32;
        match m {
            62..=65 => {
                let what = match m {
                    62 => "motion",
                    63 => "motion digital",
                    _ => "auxiliary digital",
                };
                check(
                    comp,
                    format!("Cannot set {what} output with cutter radius compensation on"),
                    at,
                )?;
                check(!b.p_flag, format!("No valid P word with M{m}"), at)?;
                self.emit(match m {
                    62 => Canon::SetMotionOutputBit(p),
                    63 => Canon::ClearMotionOutputBit(p),
                    64 => Canon::SetAuxOutputBit(p),
                    _ => Canon::ClearAuxOutputBit(p),
                })?;
            }
            66 => {
                check(b.p_flag && b.e.is_some(), msg::BOTH_DIGITAL_AND_ANALOG, at)?;
                check(
                    b.q_number <= 0.0 && b.l_flag && b.l_number > 0,
                    msg::ZERO_TIMEOUT_NOT_IMMEDIATE,
                    at,
                )?;
                check(
                    b.e.is_some() && b.l_flag && b.l_number != 0,
                    msg::ANALOG_WAIT_NOT_IMMEDIATE,
                    at,
                )?;
                let e = b.e.map(|e| e.round_ties_even() as i32);
                check(
                    (b.p_flag && p < 0) || e.is_some_and(|e| e < 0) || (!b.p_flag && e.is_none()),
                    msg::P_E_MISSING_M66,
                    at,
                )?;
                check(
                    comp,
                    "Cannot wait for digital input with cutter radius compensation on",
                    at,
                )?;
                self.s.input_flag = true;
                self.s.input_index = if b.p_flag { p } else { e.unwrap_or(0) };
                self.s.input_digital = b.p_flag;
            }
            67 | 68 => {
                let what = if m == 67 { "motion" } else { "auxiliary" };
                check(
                    comp,
                    format!("Cannot set {what} analog output with cutter radius compensation on"),
                    at,
                )?;
                let e = b.e.map(|e| e.round_ties_even() as i32);
                check(e.is_none_or(|e| e < 0), format!("Invalid analog index with M{m}"), at)?;
                let (i, v) = (e.unwrap_or(0), b.q_number);
                self.emit(if m == 67 {
                    Canon::SetMotionOutputValue(i, v)
                } else {
                    Canon::SetAuxOutputValue(i, v)
                })?;
            }
            _ => {}
        }
        Ok(())
    }

    fn convert_m_spindle(&mut self, b: &Block) -> Res<()> {
        let at = At::MGroup(mgroup::SPINDLE);
        let m = b.m_modes[mgroup::SPINDLE];
        if matches!(m, 3..=5) {
            if let Some(d) = b.dollar {
                check(
                    !(-1.0..1.0).contains(&d),
                    format!(
                        "Spindle ($) number out of range in M{m} Command\nnum_spindles =1. $={}\n",
                        d as i32
                    ),
                    at,
                )?;
            }
        }
        match m {
            3 => {
                self.emit(Canon::StartSpindleClockwise(0))?;
                self.s.spindle = Spindle::Clockwise;
            }
            4 => {
                self.emit(Canon::StartSpindleCounterclockwise(0))?;
                self.s.spindle = Spindle::CounterClockwise;
            }
            5 => {
                self.s.spindle = Spindle::Stopped;
                self.emit(Canon::StopSpindleTurning(0))?;
            }
            19 => {
                self.s.spindle = Spindle::Stopped;
                if let Some(d) = b.dollar {
                    check(
                        !(0.0..1.0).contains(&d),
                        "Spindle ($) number out of range in M19 Command",
                        at,
                    )?;
                }
                let spindle = b.dollar.map_or(0, |d| d as i32);
                if b.r.is_some() || b.p_flag {
                    let orientation = b.r.unwrap_or(0.0);
                    let mode = if b.p_flag { b.p_number as i32 } else { 0 };
                    self.emit(Canon::OrientSpindle { spindle, orientation, mode })?;
                }
                if b.q_flag {
                    check(b.q_number <= 0.0, "Q word with M19 requires a value > 0", at)?;
                    self.emit(Canon::WaitSpindleOrientComplete { spindle, timeout: b.q_number })?;
                }
            }
            70..=73 => {
                return Err(Fault::unsupported(
                    format!("M{m} (save/restore modal state) is not supported"),
                    at,
                ))
            }
            _ => {}
        }
        Ok(())
    }

    fn convert_m_overrides(&mut self, b: &Block) -> Res<()> {
        let at = At::MGroup(mgroup::OVERRIDE);
        let m = b.m_modes[mgroup::OVERRIDE];
        if m == -1 {
            return Ok(());
        }
        let on = m == 48 || (m != 49 && b.p_number != 0.0);
        let what = if on { "enable" } else { "disable" };
        check(
            self.s.comp_on(),
            format!("Cannot {what} overrides with cutter radius compensation on"),
            at,
        )?;
        match m {
            48 | 49 => {
                self.emit(if on { Canon::EnableFeedOverride } else { Canon::DisableFeedOverride })?;
                self.s.feed_override = on;
                self.emit(if on {
                    Canon::EnableSpeedOverride(0)
                } else {
                    Canon::DisableSpeedOverride(0)
                })?;
                self.s.speed_override = on;
            }
            50 => {
                self.emit(if on { Canon::EnableFeedOverride } else { Canon::DisableFeedOverride })?;
                self.s.feed_override = on;
            }
            51 => {
                if let Some(d) = b.dollar {
                    check(d <= 0.0 || d >= 1.0, "Invalid spindle ($) number in M51 command", at)?;
                }
                self.emit(if on {
                    Canon::EnableSpeedOverride(0)
                } else {
                    Canon::DisableSpeedOverride(0)
                })?;
                self.s.speed_override = on;
            }
            52 => {
                self.emit(if on { Canon::EnableAdaptiveFeed } else { Canon::DisableAdaptiveFeed })?;
                self.s.adaptive_feed = on;
            }
            _ => {
                self.emit(if on { Canon::EnableFeedHold } else { Canon::DisableFeedHold })?;
                self.s.feed_hold = on;
            }
        }
        Ok(())
    }

    fn convert_g(&mut self, b: &mut Block) -> Res<()> {
        if b.g_modes[group::MODAL_0] == g::G4 {
            self.emit(Canon::Dwell(b.p_number))?;
        }
        if b.g_modes[group::PLANE] != -1 {
            self.convert_set_plane(b.g_modes[group::PLANE])?;
        }
        if b.g_modes[group::UNITS] != -1 {
            self.convert_length_units(b.g_modes[group::UNITS])?;
        }
        if b.g_modes[group::LATHE_DIAMETER] != -1 {
            self.convert_lathe_diameter_mode(b)?;
        }
        if b.g_modes[group::CUTTER_COMP] != -1 {
            self.convert_cutter_compensation(b)?;
        }
        if b.g_modes[group::TOOL_LENGTH] != -1 {
            self.convert_tool_length_offset(b.g_modes[group::TOOL_LENGTH], b)?;
        }
        if b.g_modes[group::COORD_SYSTEM] != -1 {
            self.convert_coordinate_system(b.g_modes[group::COORD_SYSTEM])?;
        }
        if b.g_modes[group::CONTROL] != -1 {
            self.convert_control_mode(b.g_modes[group::CONTROL], b.p_number, b.q_number)?;
        }
        if b.g_modes[group::DISTANCE] != -1 {
            let abs = b.g_modes[group::DISTANCE] == g::G90;
            if self.s.absolute != abs {
                let t = if abs { "absolute" } else { "incremental" };
                self.emit(Canon::Comment(format!("interpreter: distance mode changed to {t}")))?;
                self.s.absolute = abs;
            }
        }
        if b.g_modes[group::IJK_DISTANCE] != -1 {
            let abs = b.g_modes[group::IJK_DISTANCE] == g::G90_1;
            if self.s.ijk_absolute != abs {
                let t = if abs { "absolute" } else { "incremental" };
                self.emit(Canon::Comment(format!(
                    "interpreter: IJK distance mode changed to {t}"
                )))?;
                self.s.ijk_absolute = abs;
            }
        }
        if b.g_modes[group::RETRACT] != -1 {
            check(
                self.s.comp_on(),
                "Cannot change retract mode with cutter radius compensation on",
                At::GGroup(group::RETRACT),
            )?;
            let old_z = b.g_modes[group::RETRACT] == g::G98;
            let t = if old_z { "old_z" } else { "r_plane" };
            self.emit(Canon::Comment(format!("interpreter: retract mode set to {t}")))?;
            self.s.retract_old_z = old_z;
        }
        if b.g_modes[group::MODAL_0] != -1 {
            self.convert_modal_0(b.g_modes[group::MODAL_0], b)?;
        }
        if b.g_modes[group::G92_APPLIED] != -1 {
            self.convert_axis_offsets(b.g_modes[group::G92_APPLIED], b)?;
        }
        if b.motion_to_be != -1 {
            self.convert_motion(b.motion_to_be, b)?;
        }
        Ok(())
    }

    fn convert_modal_0(&mut self, code: i32, b: &mut Block) -> Res<()> {
        match code {
            g::G10 => match b.l_number {
                1 | 10 | 11 => self.convert_setup_tool(b),
                0 => {
                    let tno = self.s.tools.entries[0].toolno;
                    if tno > 0 {
                        return fail(format!("G10 L0 not allowed with loaded tool <{tno}>\n"));
                    }
                    self.s.toolchange_flag = true;
                    self.emit(Canon::ReloadTooldata)
                }
                _ => self.convert_setup(b),
            },
            g::G28 | g::G30 => self.convert_home(code, b),
            g::G28_1 | g::G30_1 => self.convert_savehome(code),
            g::G52 | g::G92 => self.convert_axis_offsets(code, b),
            g::G5_3 => self.convert_nurbs(code, b),
            _ => Ok(()),
        }
    }

    fn convert_set_plane(&mut self, code: i32) -> Res<()> {
        let at = At::GGroup(group::PLANE);
        let comp = self.s.comp_on();
        let pl = self.s.plane;
        check(comp && code == g::G17 && pl != Plane::XY, msg::CANNOT_CHANGE_PLANES_WITH_COMP, at)?;
        check(comp && code == g::G18 && pl != Plane::XZ, msg::CANNOT_CHANGE_PLANES_WITH_COMP, at)?;
        check(comp && code == g::G19 && pl != Plane::YZ, msg::CANNOT_CHANGE_PLANES_WITH_COMP, at)?;
        check(comp && code == g::G19, msg::COMP_ONLY_XY_XZ, at)?;
        let plane = match code {
            g::G17 => Plane::XY,
            g::G18 => Plane::XZ,
            g::G19 => Plane::YZ,
            g::G17_1 => Plane::UV,
            g::G18_1 => Plane::UW,
            _ => Plane::VW,
        };
        self.emit(Canon::SelectPlane(plane))?;
        self.s.plane = plane;
        Ok(())
    }

    fn convert_control_mode(&mut self, code: i32, p: f64, q: f64) -> Res<()> {
        check(
            self.s.comp_on(),
            "Cannot change control mode with cutter radius compensation on",
            At::GGroup(group::CONTROL),
        )?;
        match code {
            g::G61 => {
                self.emit(Canon::SetMotionControlMode {
                    mode: MotionControl::ExactPath,
                    tolerance: 0.0,
                })?;
                self.s.control = MotionControl::ExactPath;
            }
            g::G61_1 => {
                self.emit(Canon::SetMotionControlMode {
                    mode: MotionControl::ExactStop,
                    tolerance: 0.0,
                })?;
                self.s.control = MotionControl::ExactStop;
            }
            _ => {
                let tolerance = if p >= 0.0 { p } else { 0.0 };
                self.s.control = MotionControl::Continuous;
                self.s.tolerance = tolerance;
                self.emit(Canon::SetMotionControlMode {
                    mode: MotionControl::Continuous,
                    tolerance,
                })?;
                let naive = if q >= 0.0 {
                    q
                } else if p >= 0.0 {
                    p
                } else {
                    0.0
                };
                self.s.naivecam_tolerance = naive;
                self.emit(Canon::SetNaivecamTolerance(naive))?;
            }
        }
        Ok(())
    }

    fn convert_lathe_diameter_mode(&mut self, b: &mut Block) -> Res<()> {
        let code = b.g_modes[group::LATHE_DIAMETER];
        if code == g::G7 && !self.s.lathe_diameter {
            if let Some(x) = b.x.as_mut() {
                *x /= 2.0;
            }
            self.emit(Canon::Comment(
                "interpreter: Lathe diameter mode changed to diameter".into(),
            ))?;
            self.s.lathe_diameter = true;
        } else if code == g::G8 && self.s.lathe_diameter {
            if let Some(x) = b.x.as_mut() {
                *x *= 2.0;
            }
            self.emit(Canon::Comment("interpreter: Lathe diameter mode changed to radius".into()))?;
            self.s.lathe_diameter = false;
        }
        Ok(())
    }

    /// M0, M1, M2, M30, M60, M99.
    fn convert_stop(&mut self, b: &Block) -> Res<Outcome> {
        let m = b.m_modes[mgroup::STOP];
        // rs274 reads the cutter compensation position here, which exists only in XY and XZ.
        if !matches!(self.s.plane, Plane::XY | Plane::XZ) {
            return Err(Fault::new(
                "BUG: Invalid plane in comp_get_current",
                At::MGroup(mgroup::STOP),
            ));
        }
        match m {
            0 => self.emit(Canon::ProgramStop)?,
            60 => {
                self.emit(Canon::PalletShuttle)?;
                self.emit(Canon::ProgramStop)?;
            }
            1 => self.emit(Canon::OptionalProgramStop)?,
            _ => {
                self.program_end(b.f.unwrap_or(0.0), m == 30)?;
                return Ok(Outcome::Exit);
            }
        }
        Ok(Outcome::Ok)
    }

    /// M2/M30's resets (convert_stop's steps 1 to 10).
    fn program_end(&mut self, f: f64, pallet: bool) -> Res<()> {
        let s = &mut self.s;
        rotate_xy(&mut s.cur, s.rotation_xy);
        for i in 0..6 {
            s.cur[i] += s.origin[i];
        }
        s.origin_index = 1;
        self.params.set_num(5220, 1.0);
        let mut origin = [0.0; 6];
        for (i, o) in origin.iter_mut().enumerate() {
            let v = self.params.num(5221 + i);
            *o = if i < 3 { self.s.user_to_program(v) } else { v };
        }
        let s = &mut self.s;
        s.origin = origin;
        s.rotation_xy = self.params.num(5230);
        for i in 0..6 {
            s.cur[i] -= s.origin[i];
        }
        rotate_xy(&mut s.cur, -s.rotation_xy);
        self.emit(Canon::SetG5xOffset { index: 1, offset: origin })?;
        self.emit(Canon::SetXyRotation(self.s.rotation_xy))?;
        if self.s.plane != Plane::XY {
            self.emit(Canon::SelectPlane(Plane::XY))?;
            self.s.plane = Plane::XY;
        }
        self.s.absolute = true;
        self.s.feed_mode = FeedMode::UnitsPerMinute;
        self.emit(Canon::SetFeedMode { spindle: 0, mode: 0 })?;
        self.s.feed_rate = f;
        self.emit(Canon::SetFeedRate(0.0))?;
        if !self.s.feed_override {
            self.emit(Canon::EnableFeedOverride)?;
            self.s.feed_override = true;
        }
        self.s.comp_side = crate::state::Side::Off;
        self.emit(Canon::StopSpindleTurning(0))?;
        self.s.spindle = Spindle::Stopped;
        self.s.speed_override = true;
        self.emit(Canon::SetSpindleMode { spindle: 0, mode: 0.0 })?;
        self.s.motion_mode = g::G1;
        if self.s.mist {
            self.emit(Canon::MistOff)?;
            self.s.mist = false;
        }
        if self.s.flood {
            self.emit(Canon::FloodOff)?;
            self.s.flood = false;
        }
        if pallet {
            self.emit(Canon::PalletShuttle)?;
        }
        self.emit(Canon::ProgramEnd)
    }
}
