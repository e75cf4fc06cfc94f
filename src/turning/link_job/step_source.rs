//! The Z job's tick ([`StepSource`] for [`ZJob`]): X feed, Z update, pins. Interrupt rate.

use super::job::ZJob;
use super::run::Gen;
use super::update_rate::per_update;
use super::upload::LinkTable;
use crate::dda::{Dda, StepOutput};
use crate::machine::StepSource;
use crate::turning::command::ZState;
use crate::turning::table::MAX_WIDTH;

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
        let state = run.state();
        // X feeds while the command follows the table (as the scenario), not in a hold.
        run.x_in_q24 = run.fed_x_in_q24(hold);
        // The generator every 2^shift ticks (at once on a sensor fault); between, its command
        // taken forward by its derivatives: a few multiplies instead of a table evaluation.
        let u = if run.update_phase == 0 || source_fault.is_some() {
            let speed = per_update(speed, run.update_shift);
            let x = run.x_in_q24;
            // Interpolated on the tick before, at the X this update turned out to have.
            let ahead = run.ahead.valid && run.ahead.x_in_q24 == x;
            run.ahead.valid = false;
            let row = &run.ahead.coeffs_in_q32;
            let u = match (&mut run.gen, &self.table) {
                (Gen::Power(g), LinkTable::Power(t)) if ahead => {
                    g.update_with(t.form(), narrow(row), x, angle, speed, source_fault)
                }
                (Gen::Power(g), LinkTable::Power(t)) => g.update(t, x, angle, speed, source_fault),
                (Gen::Harmonic(g), LinkTable::Harmonic(t)) if ahead => {
                    g.update_with(t.form(), *row, x, angle, speed, source_fault)
                }
                (Gen::Harmonic(g), LinkTable::Harmonic(t)) => {
                    g.update(t, x, angle, speed, source_fault)
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
        if run.update_phase == 0 && run.update_shift > 0 {
            // The next tick updates: half its work now, the coefficients at the X it will have
            // if it feeds as this one did (a hold beginning then leaves them unused).
            let x = run.fed_x_in_q24(hold);
            run.interpolate_ahead(&self.table, x);
        }
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

    /// Step outputs only: a DAC job writes its code on every tick, which step-only ticks do
    /// not. The generator freezes its command on a spindle fault at once; the machine latches
    /// the fault on its next full tick.
    fn step_only_ticks(&self) -> bool {
        self.run.as_ref().is_some_and(|r| r.dac.is_none())
    }

    /// The full tick that ends the run lands on a tick between the generator's heavy ones (the
    /// update, and the coefficients interpolated on the tick before it): at most `max` ticks,
    /// fewer by up to `2^shift - 1`. With updates every tick or every other one every tick is
    /// heavy, and the run is `max`.
    #[inline]
    fn step_only_run(&self, max: u8) -> u8 {
        let Some(run) = &self.run else { return max };
        let mut n = max;
        // At most one period back; a light phase exists once the period is 4 or more.
        if run.update_shift >= 2 {
            while n > 0 && run.heavy_in(n) {
                n -= 1;
            }
        }
        n
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

/// A power-form row out of the ahead buffer.
#[inline]
fn narrow(c: &[i32; MAX_WIDTH]) -> [i32; 4] {
    core::array::from_fn(|k| c.get(k).copied().unwrap_or(0))
}
