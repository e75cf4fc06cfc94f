//! Running a block in rs274ngc's order (`execute_block` in interp_execute.cc, `convert_m`,
//! `convert_g` and `convert_stop` in interp_convert.cc): comment, spindle and feed modes, F, S,
//! T, the M-codes, the G-codes, then the stop codes.
//!
//! Parts: `comments`, `m_codes`, `g_codes` and `stop`, each an `impl Core` for its step of
//! the order; the block's order itself and the feed mode are here.

mod comments;
mod g_codes;
mod m_codes;
mod stop;

use crate::block::Block;
use crate::canon::Canon;
use crate::core::Core;
use crate::diag::{check, At, Res};
use crate::modal::{g, group, mgroup};
use crate::state::FeedMode;

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
}
