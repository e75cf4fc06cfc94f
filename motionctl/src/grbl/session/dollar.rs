//! `$` commands: help, `$$`, `$#`, `$G`, `$I`, `$N`, `$C`, `$X`, `$H`, `$SLP`; settings, jogs and
//! capability jobs are dispatched to their own files.

use super::Bridge;
use crate::grbl::protocol::{self, alarm, error};
use crate::grbl::settings;
use crate::runner;
use anyhow::Result;
use motion::machine::MachineState;
use motion::protocol::RequestBody;
use motion_gcode::canon::Units;

/// grbl's build info (`$I`).
const VERSION: &str = "[VER:1.1h.20190825:";

impl Bridge<'_> {
    /// A `$` line: answered here, or handed to settings or jogging.
    pub(super) fn dollar(&mut self, raw: &str) -> Result<()> {
        let upper: String = raw.to_ascii_uppercase();
        let cmd: String = upper.chars().filter(|c| !c.is_whitespace()).collect();
        let idle = !self.moving();
        match cmd.as_str() {
            "$" => {
                self.say(
                    "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x \
                     $MILL=job $POLAR=stream $TURN=table $WIRE=job]",
                );
                self.ok();
            }
            "$$" => {
                if self.moving() && !self.jog {
                    self.error(error::IDLE_ERROR);
                    return Ok(());
                }
                for l in self.settings.listing() {
                    self.say(&l);
                }
                self.ok();
            }
            "$#" => {
                if !idle {
                    self.error(error::IDLE_ERROR);
                    return Ok(());
                }
                self.parameters();
                self.ok();
            }
            "$G" => {
                if self.prog.ended() {
                    self.new_program();
                }
                let codes = self.prog.modal().codes().join(" ");
                self.say(&format!("[GC:{codes}]"));
                self.ok();
            }
            "$I" => {
                let v = format!("{VERSION}{}]", self.build_info);
                self.say(&v);
                self.say(&format!(
                    "[OPT:V,{},{}]",
                    protocol::PLANNER_BLOCKS,
                    protocol::RX_BUFFER_SIZE
                ));
                self.ok();
            }
            "$N" => {
                for i in 0..2 {
                    let l = format!("$N{i}={}", self.startup_lines[i]);
                    self.say(&l);
                }
                self.ok();
            }
            "$C" => self.check_mode(idle)?,
            "$X" => self.unlock()?,
            "$H" => self.home()?,
            "$SLP" => {
                self.stop_motion()?;
                self.say("[MSG:Sleeping]");
                self.ok();
            }
            "$RST=$" | "$RST=#" | "$RST=*" => self.restore(&cmd, idle)?,
            _ if cmd.starts_with("$J=") => {
                self.jog_line(&upper[upper.find('=').unwrap_or(0) + 1..])
            }
            _ if cmd.starts_with("$N0=") || cmd.starts_with("$N1=") => {
                self.set_startup_line(&cmd, raw, idle)?
            }
            _ if self.capability_line(raw)? => {}
            _ if cmd.starts_with("$I=") => {
                let text = raw.split_once('=').map_or("", |(_, t)| t).trim();
                self.build_info = text.chars().take(80).collect();
                self.ok();
            }
            _ => self.setting(&cmd)?,
        }
        Ok(())
    }

    /// `$C`: check mode toggled; leaving it resets, as grbl does.
    fn check_mode(&mut self, idle: bool) -> Result<()> {
        if self.check {
            self.say("[MSG:Disabled]");
            self.ok();
            self.soft_reset()?;
        } else if self.alarm.is_some() || !idle {
            self.error(error::IDLE_ERROR);
        } else {
            self.check = true;
            self.say("[MSG:Enabled]");
            self.ok();
        }
        Ok(())
    }

    /// `$#`: coordinate systems, G28, G30, G92, tool length offset, probe.
    pub(super) fn parameters(&mut self) {
        if self.prog.ended() {
            self.new_program();
        }
        let gaxis = self.gaxis.clone();
        let mut block = |base: u32| -> Vec<f64> {
            let nums: Vec<u32> = gaxis.iter().map(|&g| base + g as u32).collect();
            self.prog.parameters(&nums)
        };
        let mut values = Vec::new();
        for (i, name) in ["G54", "G55", "G56", "G57", "G58", "G59"].iter().enumerate() {
            values.push((*name, block(5221 + 20 * i as u32)));
        }
        values.push(("G28", block(5161)));
        values.push(("G30", block(5181)));
        values.push(("G92", block(5211)));
        let m = self.prog.modal();
        let k = if m.units == Units::Inches { 25.4 } else { 1.0 };
        values.push(("TLO", vec![m.tool_length_offset[2] * k]));
        let mut lines: Vec<String> =
            values.iter().map(|(name, v)| format!("[{name}:{}]", self.axes_text(v))).collect();
        // The last probe result, last as grbl prints it.
        lines.push(self.prb_line());
        for l in lines {
            self.say(&l);
        }
    }

    pub(super) fn unlock(&mut self) -> Result<()> {
        if self.alarm.is_none() {
            self.ok();
            return Ok(());
        }
        self.refresh()?;
        if self.latest.faults != 0 {
            if let Err(e) = self.request(RequestBody::ClearFault, "ClearFault") {
                self.say(&format!("[MSG:{e}]"));
                self.error(error::SYSTEM_GC_LOCK);
                return Ok(());
            }
            self.refresh()?;
            self.faults_seen = self.latest.faults;
        }
        if self.latest.machine == MachineState::Idle {
            self.alarm = Some(alarm::HOMING_REQUIRED);
            self.say("[MSG:the board runs no motion until homed: '$H' to home]");
            self.ok();
            return Ok(());
        }
        self.alarm = None;
        self.rebase();
        self.say("[MSG:Caution: Unlocked]");
        self.ok();
        Ok(())
    }

    pub(super) fn home(&mut self) -> Result<()> {
        if !self.settings.flag(settings::HOMING) {
            self.error(error::SETTING_DISABLED);
            return Ok(());
        }
        if self.check || (self.moving() && self.alarm.is_none()) {
            self.error(error::IDLE_ERROR);
            return Ok(());
        }
        self.stop_motion()?;
        if self.latest.faults != 0 {
            let _ = self.request(RequestBody::ClearFault, "ClearFault");
            self.refresh()?;
            self.faults_seen = self.latest.faults;
        }
        self.homing = true;
        let tick_hz = self.tick_hz as u32;
        let result = runner::home(&mut self.s, tick_hz, &|m: &str| eprintln!("motionctl: {m}"));
        self.homing = false;
        self.refresh()?;
        self.faults_seen = self.latest.faults;
        match result {
            Ok(()) => {
                self.alarm = None;
                self.rebase();
                self.startup();
                self.ok();
            }
            Err(e) => {
                eprintln!("motionctl: {e}");
                self.alarm = Some(alarm::HOMING_FAIL_RESET);
                self.say(&format!("ALARM:{}", alarm::HOMING_FAIL_RESET));
                self.say(&format!("[MSG:{e}]"));
                self.error(error::SYSTEM_GC_LOCK);
            }
        }
        Ok(())
    }
}
