//! The M-codes of a block (rs274ngc's `convert_m`): I/O, spindle, tool change and overrides.

use crate::block::Block;
use crate::canon::Canon;
use crate::core::Core;
use crate::diag::{check, At, Fault, Res};
use crate::messages as msg;
use crate::modal::mgroup;
use crate::state::Spindle;

impl Core {
    pub(super) fn convert_m(&mut self, b: &mut Block) -> Res<()> {
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
}
