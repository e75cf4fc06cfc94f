//! Jogging off a tripped limit switch. A limit fault keeps the position but leaves the axis on
//! its switch, and `ClearFault` is refused while a switch is closed: without a way off, the
//! machine would be stuck. `JogOff` moves every tripped axis away from its switch (a min switch
//! toward +, a max switch toward -) at a slow rate, by at most a bounded distance, and the tick
//! stops it the moment every tripped switch has opened, or at once if any other switch closes.
//!
//! Rate and distance per axis: the axis's homing latch rate and back-off when it homes, else an
//! eighth of its max rate for at most a quarter of a second of travel at that rate.
//! The move is planned in the background like a homing move; the tick only compares bits.

use super::config::BoardConfig;
use crate::config::MAX_AXES;
use crate::planner::Move;

/// Without homing parameters: jog at `max_rate_hz / JOG_RATE_DIVISOR` ...
pub const JOG_RATE_DIVISOR: u32 = 8;
/// ... for at most `rate / JOG_TRAVEL_DIVISOR` steps (a quarter second at the jog rate).
pub const JOG_TRAVEL_DIVISOR: u32 = 4;

/// What the tick must do after [`JogOff::watch`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JogEvent {
    None,
    /// Every tripped switch opened: stop here, the fault can be cleared.
    Released,
    /// A switch that was open closed: stop at once.
    OtherSwitch,
    /// The move ended with a tripped switch still closed (jog again, or check the switch).
    Ended,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JogOff {
    /// Tripped switches (bit i = axis i) this jog moves off.
    min: u8,
    max: u8,
    need_move: bool,
}

impl JogOff {
    /// A jog off the closed switches `limit_min`/`limit_max` of `cfg`'s axes; `None` when no
    /// switch is closed, one is on an unused axis, or an axis has both closed (a wiring fault:
    /// no direction is away from both).
    pub fn start(limit_min: u8, limit_max: u8, cfg: &BoardConfig) -> Option<Self> {
        let used = (1u16 << cfg.link.machine.axis_count).wrapping_sub(1) as u8;
        let tripped = limit_min | limit_max;
        if tripped == 0 || tripped & !used != 0 || limit_min & limit_max != 0 {
            return None;
        }
        Some(JogOff { min: limit_min, max: limit_max, need_move: true })
    }

    /// The move is still to be planned (background work).
    pub fn needs_move(&self) -> bool {
        self.need_move
    }

    /// The jog move (taken once): every tripped axis away from its switch, all by the shortest
    /// of their distances at the slowest of their rates, so no axis goes further or faster than
    /// its own bound. Planning-rate code (divides).
    pub fn take_move(&mut self, cfg: &BoardConfig) -> Option<Move> {
        if !self.need_move {
            return None;
        }
        self.need_move = false;
        let (mut rate_hz, mut travel) = (u32::MAX, u32::MAX);
        for a in 0..MAX_AXES {
            if (self.min | self.max) & (1 << a) == 0 {
                continue;
            }
            let home = &cfg.home[a];
            let (r, d) = if home.latch_hz > 0 && home.backoff_steps > 0 {
                (home.latch_hz, home.backoff_steps)
            } else {
                let r = (cfg.link.machine.axes[a].max_rate_hz / JOG_RATE_DIVISOR).max(1);
                (r, (r / JOG_TRAVEL_DIVISOR).max(1))
            };
            rate_hz = rate_hz.min(r);
            travel = travel.min(d);
        }
        let len = i32::try_from(travel).ok()?;
        let mut steps = [0i32; MAX_AXES];
        for (a, s) in steps.iter_mut().enumerate() {
            if self.min & (1 << a) != 0 {
                *s = len;
            } else if self.max & (1 << a) != 0 {
                *s = -len;
            }
        }
        Some(Move { steps, feed_hz: rate_hz })
    }

    /// One tick's look at the switches and whether the DDA went idle. Compares only.
    #[inline]
    pub fn watch(&self, limit_min: u8, limit_max: u8, dda_idle: bool) -> JogEvent {
        if (limit_min & !self.min) | (limit_max & !self.max) != 0 {
            JogEvent::OtherSwitch
        } else if limit_min & self.min == 0 && limit_max & self.max == 0 {
            JogEvent::Released
        } else if dda_idle && !self.need_move {
            JogEvent::Ended
        } else {
            JogEvent::None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> BoardConfig {
        crate::scenarios::faults::config(crate::scenarios::faults::Case::LimitMin(0))
    }

    #[test]
    fn moves_away_from_each_switch_within_its_bounds() {
        let c = cfg();
        let mut j = JogOff::start(0b01, 0b10, &c).unwrap();
        let mv = j.take_move(&c).unwrap();
        let rate = c.link.machine.axes[0].max_rate_hz / JOG_RATE_DIVISOR;
        assert_eq!(mv.feed_hz, rate);
        let d = (rate / JOG_TRAVEL_DIVISOR) as i32;
        assert_eq!(&mv.steps[..2], &[d, -d], "x off its min (+), y off its max (-)");
        assert!(j.take_move(&c).is_none(), "taken once");
    }

    #[test]
    fn homing_parameters_set_rate_and_distance() {
        let mut c = cfg();
        c.home[0].latch_hz = 500;
        c.home[0].backoff_steps = 123;
        let mv = JogOff::start(0, 0b01, &c).unwrap().take_move(&c).unwrap();
        assert_eq!((mv.feed_hz, mv.steps[0]), (500, -123));
    }

    #[test]
    fn nothing_to_jog_or_both_switches_is_refused() {
        let c = cfg();
        assert!(JogOff::start(0, 0, &c).is_none());
        assert!(JogOff::start(0b1, 0b1, &c).is_none(), "both switches of one axis");
        assert!(JogOff::start(0b100, 0, &c).is_none(), "axis 2 is not in use");
    }

    #[test]
    fn watch_stops_on_release_or_another_switch() {
        let c = cfg();
        let mut j = JogOff::start(0b01, 0, &c).unwrap();
        let _ = j.take_move(&c);
        assert_eq!(j.watch(0b01, 0, false), JogEvent::None);
        assert_eq!(j.watch(0, 0, false), JogEvent::Released);
        assert_eq!(j.watch(0b11, 0, false), JogEvent::OtherSwitch);
        assert_eq!(j.watch(0b01, 0b01, false), JogEvent::OtherSwitch);
        assert_eq!(j.watch(0b01, 0, true), JogEvent::Ended);
    }
}
