//! Stopping: motion held and aborted on the board, the host's queue dropped, a soft reset (Ctrl-X,
//! a sender connecting) back to the power-on parser state and the startup lines.

use super::{link_err, Bridge, Pending};
use crate::grbl::program::Program;
use crate::grbl::protocol::WELCOME;
use crate::grbl::settings;
use anyhow::{bail, Result};
use motion::machine::MachineState;
use motion::protocol::{LinkState, ProgramOutputs, RequestBody};
use std::time::{Duration, Instant};

/// Longest wait for a hold to stop the machine before a reset drops its queue.
const STOP_WAIT: Duration = Duration::from_secs(5);

impl Bridge<'_> {
    /// Waits until every segment batch sent has been answered.
    pub(super) fn settle_batches(&mut self) -> Result<()> {
        let start = Instant::now();
        while self.pending.values().any(|p| matches!(p, Pending::Batch { .. })) {
            if start.elapsed() > STOP_WAIT {
                bail!("the board did not answer queued segments");
            }
            self.s.pump(Duration::from_millis(2)).map_err(link_err)?;
            self.answers();
        }
        Ok(())
    }

    /// Stops the machine on its path (hold, then abort the rest), drops everything queued, and
    /// starts counting again from where the board stands.
    pub(super) fn stop_motion(&mut self) -> Result<()> {
        self.settle_batches()?;
        self.refresh()?;
        if matches!(self.latest.machine, MachineState::Running | MachineState::Holding) {
            if self.latest.machine == MachineState::Running {
                let _ = self.request(RequestBody::Hold, "Hold");
            }
            let start = Instant::now();
            loop {
                self.refresh()?;
                let running =
                    matches!(self.latest.machine, MachineState::Running | MachineState::Holding);
                if !running || self.latest.state == LinkState::Held || start.elapsed() > STOP_WAIT {
                    break;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            self.request(RequestBody::Abort, "Abort")?;
        } else if self.latest.queue_depth > 0 {
            self.request(RequestBody::Abort, "Abort")?;
        }
        self.refresh()?;
        // The board drops its queue in its background work after the Abort: until then its
        // status still counts the dropped segments in flight, which would read as motion to
        // start again.
        let start = Instant::now();
        while self.latest.queue_depth > 0 && start.elapsed() < STOP_WAIT {
            std::thread::sleep(Duration::from_millis(2));
            self.refresh()?;
        }
        if self.latest.queue_depth > 0 {
            eprintln!(
                "motionctl: the board still counts {} segments after Abort",
                self.latest.queue_depth
            );
        }
        self.rebase();
        Ok(())
    }

    /// Nothing queued anywhere: counting starts again at the board's state.
    pub(super) fn rebase(&mut self) {
        self.pending.retain(|_, p| !matches!(p, Pending::Batch { .. } | Pending::Control));
        self.control_seq = None;
        self.base_done = self.latest.segments_done;
        self.sent = 0;
        self.acked = 0;
        self.popped = 0;
        self.inflight.clear();
        self.motion.reset(&self.latest.positions);
        self.hold = false;
        self.door = false;
        self.paused = false;
        self.jog = false;
        self.dwell_until = None;
        // A probe move stopped before its end: the block is answered (no result; the
        // interpreter takes it as no contact and is moved to where the machine stands).
        self.end_probe(false);
        if !self.prog.ended() {
            let at = self.motion.pos_mm.clone();
            self.prog.sync(&at);
        }
    }

    /// Ctrl-X, and a sender connecting: stop, forget the queue, power-on parser state,
    /// welcome.
    pub(super) fn soft_reset(&mut self) -> Result<()> {
        // As grbl's reset: a probe cycle under way is dropped unanswered, and the probe
        // position cleared.
        self.probe = None;
        self.last_probe = super::probe::LastProbe::none(self.spm.len());
        self.stop_motion()?;
        // As grbl's reset: the spindle and coolant stop with the motion.
        self.spindle_stop_clear();
        self.switch_outputs(ProgramOutputs::OFF)?;
        self.rx.clear();
        self.check = false;
        if self.ovr[0] != 100 {
            self.ovr[0] = 100;
            self.send_override()?;
        }
        self.ovr = [100; 3];
        self.feed_now = 0.0;
        self.new_program();
        self.motion.soft_limits = self.settings.flag(settings::SOFT_LIMITS);
        self.say("");
        self.say(WELCOME);
        if self.alarm.is_some() {
            self.say("[MSG:'$H'|'$X' to unlock]");
        } else {
            self.startup();
        }
        Ok(())
    }

    /// The `$N0`, `$N1` startup lines, each answered `>LINE:ok` or `>LINE:error:N` (grbl runs
    /// them after a reset, and after homing when it starts in alarm).
    pub(super) fn startup(&mut self) {
        for i in 0..2 {
            let line = self.startup_lines[i].clone();
            if line.is_empty() {
                continue;
            }
            match self.gcode(&line) {
                None => self.answer(format!(">{line}:ok")),
                Some(n) => self.say(&format!(">{line}:error:{n}")),
            }
            if self.alarm.is_some() {
                break;
            }
        }
    }

    /// A fresh interpreter at the commanded position, keeping the offsets grbl keeps in EEPROM.
    pub(super) fn new_program(&mut self) {
        let kept = if self.prog.ended() { Vec::new() } else { self.prog.persistent() };
        let kept = if kept.is_empty() { self.kept.clone() } else { kept };
        self.kept = kept.clone();
        self.prog = Program::with_parameters(self.machine, &self.motion.pos_mm, kept);
    }
}
