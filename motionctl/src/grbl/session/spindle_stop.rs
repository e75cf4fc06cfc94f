//! The real-time spindle stop (0x9E), as grbl 1.1's spindle stop override: only in a feed hold,
//! it toggles the spindle off once the hold is complete, and on again at the next 0x9E or at
//! cycle start; the machine resumes only after the spindle had its spin-up time. The board's
//! spindle is switched through the same outputs path as the coolant toggles, so the report's
//! `A:` field (what the board drives) shows no `S`/`C` while it is stopped; the parser's
//! spindle (`$G`, `M3`/`M4`) is the program's and does not change.

use super::Bridge;
use crate::grbl::report::State;
use anyhow::Result;
use motion::protocol::{LinkState, ProgramOutputs, SpindleDir};
use std::time::{Duration, Instant};

/// Spin-up time after the stopped spindle is switched on again before motion resumes (the
/// bridge's resume dwell, as grbl waits its spindle delay).
const SPIN_UP: Duration = Duration::from_millis((crate::gcode::resume::SPIN_UP_S * 1e3) as u64);

/// The spindle stop's state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct SpindleStop {
    /// The sender asked for the spindle stopped (0x9E in a hold; a second one or cycle start
    /// lets go).
    pub wanted: bool,
    /// The spindle the board drove when the stop switched it off: what comes back.
    pub stopped: Option<SpindleDir>,
}

/// What the spindle stop does now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Action {
    None,
    /// Switch the board's spindle off; `SpindleDir` is what to restore later.
    Stop(SpindleDir),
    /// Switch it back on in this direction and wait for the spin-up.
    Restore(SpindleDir),
}

impl SpindleStop {
    /// What to do, given whether the hold is complete (the board held, at rest) and the
    /// spindle the board drives now.
    pub fn action(&self, hold_complete: bool, board: SpindleDir) -> Action {
        match (self.wanted, self.stopped) {
            (true, None) if hold_complete && board != SpindleDir::Off => Action::Stop(board),
            (false, Some(dir)) => Action::Restore(dir),
            _ => Action::None,
        }
    }
}

impl Bridge<'_> {
    /// 0x9E: toggles the stop, only in a feed hold (not a door, not a jog), as grbl.
    pub(super) fn spindle_stop_byte(&mut self) {
        if matches!(self.state(), State::Hold { .. }) && !self.door && !self.jog {
            self.spindle_stop.wanted = !self.spindle_stop.wanted;
        }
    }

    /// Puts the stop on the board: off once the hold is complete, on again when it is let go
    /// (then the resume waits for the spin-up).
    pub(super) fn spindle_stop_step(&mut self) -> Result<()> {
        let now = ProgramOutputs::from_bits(self.latest.outputs);
        let complete = self.hold && (self.latest.state == LinkState::Held || !self.moving());
        match self.spindle_stop.action(complete, now.spindle) {
            Action::None => {}
            Action::Stop(dir) => {
                self.spindle_stop.stopped = Some(dir);
                self.switch_outputs(ProgramOutputs { spindle: SpindleDir::Off, ..now })?;
            }
            Action::Restore(dir) => {
                self.spindle_stop.stopped = None;
                self.spin_up_until = Some(Instant::now() + SPIN_UP);
                self.switch_outputs(ProgramOutputs { spindle: dir, ..now })?;
            }
        }
        if self.spin_up_until.is_some_and(|t| Instant::now() >= t) {
            self.spin_up_until = None;
        }
        Ok(())
    }

    /// The spindle stop keeps the machine held: stopped and let go (not yet back on), or
    /// spinning up.
    pub(super) fn spindle_holds(&self) -> bool {
        (self.spindle_stop.stopped.is_some() && !self.spindle_stop.wanted)
            || self.spin_up_until.is_some()
    }

    /// A reset or an abort ends the stop (the outputs go off with it).
    pub(super) fn spindle_stop_clear(&mut self) {
        self.spindle_stop = SpindleStop::default();
        self.spin_up_until = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stop_waits_for_a_complete_hold_and_restores_the_direction_it_took() {
        let idle = SpindleStop::default();
        assert_eq!(idle.action(true, SpindleDir::Cw), Action::None);
        let wanted = SpindleStop { wanted: true, stopped: None };
        assert_eq!(wanted.action(false, SpindleDir::Cw), Action::None, "still decelerating");
        assert_eq!(wanted.action(true, SpindleDir::Off), Action::None, "nothing turns");
        assert_eq!(wanted.action(true, SpindleDir::Ccw), Action::Stop(SpindleDir::Ccw));
        let stopped = SpindleStop { wanted: true, stopped: Some(SpindleDir::Ccw) };
        assert_eq!(stopped.action(true, SpindleDir::Off), Action::None, "stays off");
        let let_go = SpindleStop { wanted: false, stopped: Some(SpindleDir::Ccw) };
        assert_eq!(let_go.action(true, SpindleDir::Off), Action::Restore(SpindleDir::Ccw));
        assert_eq!(let_go.action(false, SpindleDir::Off), Action::Restore(SpindleDir::Ccw));
    }
}
