//! Real-time bytes, acted on as they arrive: `?` (the status report), feed hold, safety door,
//! cycle start, reset, jog cancel, the overrides, the spindle stop and the coolant toggles.

use super::{link_err, Bridge, Pending};
use crate::grbl::pipeline::Out;
use crate::grbl::protocol::{self, realtime, Coolant, Realtime};
use crate::grbl::report::{Report, State};
use crate::grbl::settings;
use anyhow::Result;
use motion::machine::MachineState;
use motion::protocol::{LinkState, ProgramOutputs, RequestBody, MAX_OVERRIDE_BITS};
use motion_gcode::canon::Units;

impl Bridge<'_> {
    pub(super) fn byte(&mut self, b: u8) -> Result<()> {
        let Some(r) = realtime(b) else {
            self.rx.push(b);
            return Ok(());
        };
        match r {
            Realtime::Status => {
                let line = self.report();
                self.say(&line);
            }
            Realtime::FeedHold if self.jog && self.moving() => self.stop_motion()?,
            Realtime::FeedHold => {
                if self.alarm.is_none() && !self.check {
                    self.hold = true;
                }
            }
            Realtime::SafetyDoor => {
                if self.alarm.is_none() && !self.check {
                    if self.jog && self.moving() {
                        self.stop_motion()?;
                    }
                    self.door = true;
                    self.hold = true;
                }
            }
            Realtime::CycleStart => {
                self.door = false;
                self.hold = false;
                // The stopped spindle comes back first; the resume waits for its spin-up.
                self.spindle_stop.wanted = false;
                if self.paused {
                    self.paused = false;
                    if matches!(self.motion.out.front(), Some(Out::Pause)) {
                        self.motion.out.pop_front();
                    }
                }
            }
            Realtime::Reset => self.soft_reset()?,
            Realtime::JogCancel => {
                if self.jog {
                    self.stop_motion()?;
                }
            }
            Realtime::Feed(c) => {
                let v = c.apply(self.ovr[0]);
                if v != self.ovr[0] {
                    self.ovr[0] = v;
                    self.send_override()?;
                }
            }
            Realtime::Rapid(v) => self.ovr[1] = v,
            Realtime::Spindle(c) => self.ovr[2] = c.apply(self.ovr[2]),
            Realtime::Coolant(c) => self.toggle_coolant(c)?,
            Realtime::SpindleStop => self.spindle_stop_byte(),
            Realtime::Ignored => {}
        }
        Ok(())
    }

    /// 0xA0, 0xA1: the board's flood or mist toggled now, not behind the queued motion, and the
    /// parser's coolant (`$G`, `A:`) with it; as grbl, only in Idle, Run and Hold.
    fn toggle_coolant(&mut self, c: Coolant) -> Result<()> {
        if !matches!(self.state(), State::Idle | State::Run | State::Hold { .. }) {
            return Ok(());
        }
        let to = c.toggle(ProgramOutputs::from_bits(self.latest.outputs));
        if self.prog.ended() {
            self.new_program();
        }
        self.prog.set_coolant(to.mist, to.flood);
        self.switch_outputs(to)
    }

    pub(super) fn send_override(&mut self) -> Result<()> {
        let f = self.ovr[0] as f64 / 100.0;
        let rate_bits = ((f * (1u64 << 30) as f64).round() as u32).min(MAX_OVERRIDE_BITS);
        let seq = self.s.send(RequestBody::SetOverride { rate_bits }).map_err(link_err)?;
        self.pending.insert(seq, Pending::Ignore);
        Ok(())
    }

    pub(super) fn state(&self) -> State {
        if self.homing {
            State::Home
        } else if self.alarm.is_some() {
            State::Alarm
        } else if self.check {
            State::Check
        } else if self.door {
            State::Door
        } else if self.hold || self.paused || self.spindle_holds() {
            let stopping = self.latest.machine == MachineState::Running
                || (self.latest.machine == MachineState::Holding
                    && self.latest.state != LinkState::Held);
            State::Hold { stopping }
        } else if self.moving() {
            if self.jog {
                State::Jog
            } else {
                State::Run
            }
        } else {
            State::Idle
        }
    }

    /// Machine position, mm.
    pub(super) fn mpos(&self) -> Vec<f64> {
        self.spm.iter().enumerate().map(|(i, s)| self.latest.positions[i] as f64 / s).collect()
    }

    /// Work coordinate offset (G5x + G92 + tool length on Z), mm, per machine axis.
    pub(super) fn wco(&self) -> Vec<f64> {
        let m = self.prog.modal();
        let k = if m.units == Units::Inches { 25.4 } else { 1.0 };
        self.gaxis
            .iter()
            .map(|&g| {
                let tool = if g == 2 { m.tool_length_offset[2] } else { 0.0 };
                match (m.g5x_offset.get(g), m.g92_offset.get(g)) {
                    (Some(a), Some(b)) => (a + b + tool) * k,
                    _ => 0.0,
                }
            })
            .collect()
    }

    pub(super) fn report(&self) -> String {
        let state = self.state();
        let moving = matches!(state, State::Run | State::Jog | State::Hold { stopping: true });
        let m = self.prog.modal();
        let used = self.motion.pending_moves
            + self.motion.queued_segments()
            + self.latest.queue_depth as usize;
        let spindle_on = m.spindle != motion_gcode::Spindle::Stopped;
        Report {
            state,
            mpos: self.mpos(),
            wco: self.wco(),
            planner_free: protocol::PLANNER_BLOCKS.saturating_sub(used),
            rx_free: self.rx.free(),
            feed: if moving { self.feed_now * self.ovr[0] as f64 / 100.0 } else { 0.0 },
            speed: if spindle_on { m.speed } else { 0.0 },
            overrides: self.ovr,
            accessories: ProgramOutputs::from_bits(self.latest.outputs),
            mask: self.settings.get(settings::STATUS_MASK) as u16,
            inches: self.settings.flag(settings::REPORT_INCHES),
        }
        .line()
    }
}
