//! The Z job's tick ([`StepSource`] for [`ZJob`]): X feed, Z update, pins. Interrupt rate.

use super::job::ZJob;
use super::run::Gen;
use super::update_rate::per_update;
use super::upload::LinkTable;
use crate::dda::{Dda, StepOutput};
use crate::machine::StepSource;
use crate::zslide::command::ZState;

impl StepSource for ZJob {
    /// X feed, Z update, pins. Division-free: multiplies, shifts and compares.
    #[inline]
    fn tick(&mut self, dda: &mut Dda, hold: bool) -> StepOutput {
        // The idle DDA keeps the clock (Status ticks).
        let _ = dda.tick();
        let (angle, speed, source_fault) =
            (self.angle_turn_q32, self.speed_turn_q32_per_tick, self.source_fault);
        let Some(run) = &mut self.run else {
            return StepOutput::new(0, 0, 0, 0);
        };
        let state = match &run.gen {
            Gen::Power(g) => g.state(),
            Gen::Harmonic(g) => g.state(),
        };
        // X feeds while the command follows the table (as the scenario), not in a hold.
        if !hold && state == ZState::Running && run.x_in_q24 < run.spec.x_end_in_q24 {
            run.x_in_q24 = run
                .x_in_q24
                .saturating_add(run.spec.x_feed_in_q24_per_tick)
                .min(run.spec.x_end_in_q24);
        }
        // The generator every 2^shift ticks (at once on a sensor fault); between, its command
        // taken forward by its derivatives: a few multiplies instead of a table evaluation.
        let u = if run.update_phase == 0 || source_fault.is_some() {
            let speed = per_update(speed, run.update_shift);
            let u = match (&mut run.gen, &self.table) {
                (Gen::Power(g), LinkTable::Power(t)) => {
                    g.update(t, run.x_in_q24, angle, speed, source_fault)
                }
                (Gen::Harmonic(g), LinkTable::Harmonic(t)) => {
                    g.update(t, run.x_in_q24, angle, speed, source_fault)
                }
                // Not reachable: the table cannot change while a run exists.
                _ => run.last,
            };
            run.last = u;
            run.update_phase = 0;
            u
        } else {
            run.last.shifted(((run.update_phase as i32) << 16) >> run.update_shift)
        };
        run.update_phase = (run.update_phase + 1) & ((1u8 << run.update_shift) - 1);
        run.command = u;
        // X axis: toward the commanded X in steps.
        let x_rel = run.x_in_q24 as i64 - run.spec.x_start_in_q24 as i64;
        let x_target = (x_rel * run.spec.x_steps_per_in as i64 + (1 << 23)) >> 24;
        let fall = run.pins.rose_last;
        let (xr, xw) =
            run.pins.axis(run.x_bit, run.spec.x_negative, x_target - run.x_steps, &mut run.x_steps);
        let (mut zr, mut zw) = (0, 0);
        let z_out = if let Some(s) = run.steps {
            let target = s.target_steps(u.z_in_q32) as i64;
            (zr, zw) = run.pins.axis(run.z_bit, false, target - run.z_steps, &mut run.z_steps);
            s.z_in_q32(run.z_steps.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
        } else if let Some(d) = run.dac {
            match d.code(u.z_in_q32) {
                Ok(c) => run.dac_code = c,
                // Out of the DAC's range: the code stays, the fault goes to the machine.
                Err(_) => run.dac_fault = true,
            }
            d.z_in_q32(run.dac_code)
        } else {
            u.z_in_q32 as i64
        };
        if state == ZState::Running {
            // In Q32 here, nanoinches when read (the conversion is monotonic).
            let fe = (u.z_in_q32 as i64 - z_out).abs();
            run.max_following_in_q32 = run.max_following_in_q32.max(fe);
        }
        let rise = xr | zr;
        run.pins.rose_last = rise;
        StepOutput::new(fall, xw | zw, run.pins.dir, rise)
    }

    /// Done: the command finished (past the blend), X at its end, the axes at their targets.
    fn idle(&self, _dda: &Dda) -> bool {
        let Some(run) = &self.run else { return true };
        let finished = match &run.gen {
            Gen::Power(g) => g.state() == ZState::Finished,
            Gen::Harmonic(g) => g.state() == ZState::Finished,
        };
        let z_home =
            run.steps.is_none_or(|s| s.target_steps(run.command.z_in_q32) as i64 == run.z_steps);
        let x_rel = run.x_in_q24 as i64 - run.spec.x_start_in_q24 as i64;
        let x_target = (x_rel * run.spec.x_steps_per_in as i64 + (1 << 23)) >> 24;
        finished && z_home && x_target == run.x_steps
    }
}
