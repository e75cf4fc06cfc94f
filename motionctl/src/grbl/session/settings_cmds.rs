//! Commands that change stored settings: `$N=V`, `$RST=`, `$N0=`/`$N1=`, written to the overlay
//! file; a setting of the machine puts a new config on the board.

use super::Bridge;
use crate::grbl::pipeline::Pipeline;
use crate::grbl::program::Program;
use crate::grbl::protocol::{alarm, error};
use crate::grbl::settings::{self, SetError};
use crate::job::Machine;
use crate::runner;
use anyhow::Result;
use motion::protocol::{Reply, RequestBody};

impl Bridge<'_> {
    pub(super) fn setting(&mut self, cmd: &str) -> Result<()> {
        let Some((n, v)) = cmd[1..].split_once('=') else {
            self.error(error::INVALID_STATEMENT);
            return Ok(());
        };
        let Ok(num) = n.parse::<u16>() else {
            self.error(error::INVALID_STATEMENT);
            return Ok(());
        };
        if !n.chars().all(|c| c.is_ascii_digit()) {
            self.error(error::INVALID_STATEMENT);
            return Ok(());
        }
        if self.moving() {
            self.error(error::IDLE_ERROR);
            return Ok(());
        }
        let mut next = self.settings.clone();
        match next.set(n, v) {
            Ok(()) => {}
            Err(SetError::BadNumber) => {
                self.error(error::BAD_NUMBER_FORMAT);
                return Ok(());
            }
            Err(SetError::Unknown) => {
                self.error(error::INVALID_STATEMENT);
                return Ok(());
            }
            Err(SetError::Negative) => {
                self.error(error::NEGATIVE_VALUE);
                return Ok(());
            }
        }
        let axes = self.machine.axes.len();
        if settings::is_machine_field(num, axes) && next.get(num) != self.settings.get(num) {
            let machine = match settings::machine_with(&self.machine_src, &next) {
                Ok(m) => m,
                Err(why) => {
                    eprintln!("motionctl: ${num}={v}: {why}");
                    self.say(&format!("[MSG:${num}={v}: {why}]"));
                    self.error(settings::OUT_OF_RANGE);
                    return Ok(());
                }
            };
            if let Err(why) = self.install_machine(machine, settings::is_board_field(num, axes))? {
                self.say(&format!("[MSG:${num}={v}: {why}]"));
                self.error(error::SETTING_READ_FAIL);
                return Ok(());
            }
        }
        self.settings = next;
        self.motion.soft_limits = self.settings.flag(settings::SOFT_LIMITS);
        self.save();
        self.ok();
        Ok(())
    }

    /// Writes the overlay; a failure is told (the setting is in effect for this session).
    pub(super) fn save(&mut self) {
        let o = settings::Overlay {
            settings: self.settings.changed(),
            startup: self.startup_lines.clone(),
        };
        if let Err(e) = o.write(&self.overlay, &self.machine_path) {
            eprintln!("motionctl: {e:#}");
            self.say(&format!("[MSG:not saved, in effect until the bridge stops: {e:#}]"));
        }
    }

    /// The bridge runs `machine` from now on; with `board`, the board gets its config first
    /// (through [`runner::ready_board`], as at start: only when it differs from the board's).
    /// A new config loses the board's homing: the bridge is then in alarm until `$H`. The
    /// inner error says why the board refused (nothing changed then).
    pub(super) fn install_machine(
        &mut self,
        machine: Machine,
        board: bool,
    ) -> Result<Result<(), String>> {
        let (cfg, link_cfg) = match crate::grbl::board_config(&machine) {
            Ok(c) => c,
            Err(e) => return Ok(Err(format!("{e:#}"))),
        };
        if board {
            self.stop_motion()?;
            let r = self.configure(link_cfg, false, "machine with the grbl settings")?;
            if let Err(e) = r {
                let config_now = runner::ask(&mut self.s, RequestBody::GetConfig, "GetConfig")?;
                if config_now != Reply::Config(link_cfg) {
                    return Ok(Err(e));
                }
                // The config is in; the board lost its homing.
                eprintln!("motionctl: {e}");
                self.say("[MSG:the board has the new config and must be homed: '$H' to home]");
                self.alarm = Some(alarm::HOMING_REQUIRED);
            }
        }
        // Machines live as long as the bridge (the interpreter borrows them); one per change.
        let machine: &'static Machine = Box::leak(Box::new(machine));
        self.machine = machine;
        self.spm = machine.axes.iter().map(|a| a.steps_per_mm).collect();
        self.tick_hz = cfg.tick_hz.max(1) as f64;
        let soft = self.motion.soft_limits;
        self.motion = Pipeline::new(machine, cfg);
        self.motion.soft_limits = soft;
        self.rebase();
        let kept = self.kept.clone();
        self.prog = Program::with_parameters(machine, &self.motion.pos_mm, kept);
        Ok(Ok(()))
    }

    /// `$RST=$` (settings back to the machine file's), `$RST=#` (offsets cleared), `$RST=*`
    /// (both, and the startup lines).
    pub(super) fn restore(&mut self, cmd: &str, idle: bool) -> Result<()> {
        if !idle {
            self.error(error::IDLE_ERROR);
            return Ok(());
        }
        if cmd != "$RST=#" {
            let mut next = self.settings.clone();
            next.restore();
            // The machine file's own values, on the board too if they differ.
            match settings::machine_with(&self.machine_src, &next) {
                Ok(m) => {
                    if let Err(why) = self.install_machine(m, true)? {
                        self.say(&format!("[MSG:{cmd}: {why}]"));
                        self.error(error::SETTING_READ_FAIL);
                        return Ok(());
                    }
                }
                Err(why) => {
                    self.say(&format!("[MSG:{cmd}: {}: {why}]", self.machine_path.display()));
                    self.error(error::SETTING_READ_FAIL);
                    return Ok(());
                }
            }
            self.settings = next;
            self.motion.soft_limits = self.settings.flag(settings::SOFT_LIMITS);
            if cmd == "$RST=*" {
                self.startup_lines = [String::new(), String::new()];
            }
            self.save();
        }
        if cmd != "$RST=$" {
            for p in 1..=6 {
                let _ = self.prog.run(&format!("G10 L2 P{p} X0 Y0 Z0"));
            }
            let _ = self.prog.run("G92.1");
            self.kept = self.prog.persistent();
        }
        self.ok();
        Ok(())
    }

    /// `$N0=LINE`, `$N1=LINE`: a startup line, checked before it is kept.
    pub(super) fn set_startup_line(&mut self, cmd: &str, raw: &str, idle: bool) -> Result<()> {
        let i = if cmd.starts_with("$N0") { 0 } else { 1 };
        let text = raw.split_once('=').map_or("", |(_, t)| t).trim().to_string();
        if !idle {
            self.error(error::IDLE_ERROR);
            return Ok(());
        }
        if !text.is_empty() {
            // Checked as a program line on a scratch interpreter: nothing runs now.
            let mut scratch =
                Program::with_parameters(self.machine, &self.motion.pos_mm, self.kept.clone());
            if let Err(e) = scratch.run(&text) {
                eprintln!("motionctl: startup line `{text}`: {} (error:{})", e.message, e.code);
                self.say(&format!("[MSG:$N{i}: {}]", e.message));
                self.error(e.code);
                return Ok(());
            }
        }
        self.startup_lines[i] = text;
        self.save();
        self.ok();
        Ok(())
    }
}
