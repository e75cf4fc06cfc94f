//! One Z run's state inside the job: the generator for the table's form, the pin stage of its
//! two axes, and how a checked spec becomes a run ([`prepare_run`]).

use super::spec::{ZJobSpec, ZStartError};
use super::upload::LinkTable;
use crate::turning::command::{ZCommandConfig, ZGen, ZState, ZUpdate};
use crate::turning::output::{DacScale, StepScale};
use crate::turning::table::MAX_WIDTH;

#[derive(Clone, Debug)]
pub(super) enum Gen {
    Power(ZGen<4>),
    Harmonic(ZGen<MAX_WIDTH>),
}

/// Pin stage for the job's two axes: at most one rise per axis every other tick, DIR written a
/// tick after the last rise and a tick before the next (the DDA's and the playback's rules).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Pins {
    pub(super) dir: u8,
    pub(super) rose_last: u8,
}

impl Pins {
    /// One axis toward `target - position`; returns (rise, dir_write) bits and moves `position`.
    #[inline]
    pub(super) fn axis(
        &mut self,
        bit: u8,
        negative_is_up: bool,
        delta: i64,
        position: &mut i64,
    ) -> (u8, u8) {
        if delta == 0 || self.rose_last & bit != 0 {
            return (0, 0);
        }
        let up = delta > 0;
        let neg = if up != negative_is_up { 0 } else { bit };
        if neg != self.dir & bit {
            self.dir = (self.dir & !bit) | neg;
            return (0, bit);
        }
        *position += if up { 1 } else { -1 };
        (bit, 0)
    }
}

#[derive(Clone, Debug)]
pub(super) struct ZRun {
    pub(super) spec: ZJobSpec,
    pub(super) gen: Gen,
    pub(super) x_in_q24: i32,
    /// X axis steps emitted (relative to the start), Z steps emitted.
    pub(super) x_steps: i64,
    pub(super) z_steps: i64,
    pub(super) x_bit: u8,
    pub(super) z_bit: u8,
    pub(super) steps: Option<StepScale>,
    pub(super) dac: Option<DacScale>,
    pub(super) dac_code: u16,
    /// A command outside the DAC's range (latched: `ZSlideLimit`).
    pub(super) dac_fault: bool,
    pub(super) pins: Pins,
    /// The generator's last update (in its own time unit: [`ZRun::update_shift`] ticks).
    pub(super) last: ZUpdate,
    /// This tick's command (the last update taken forward to now).
    pub(super) command: ZUpdate,
    /// The generator updates every `2^update_shift` ticks; the ticks between take its command
    /// forward by its own derivatives ([`ZUpdate::shifted`]).
    pub(super) update_shift: u8,
    /// Ticks since the last update, `0..2^update_shift`.
    pub(super) update_phase: u8,
    /// Largest |command - output| while following, inches Q32.
    pub(super) max_following_in_q32: i64,
    /// The table's coefficients at the X the next update is expected at, interpolated on the
    /// tick before it: half of an update's work.
    pub(super) ahead: Ahead,
}

/// Coefficients interpolated a tick ahead of the update that uses them.
#[derive(Clone, Copy, Debug)]
pub(super) struct Ahead {
    /// Set by [`ZRun::interpolate_ahead`], cleared by the update that comes next.
    pub(super) valid: bool,
    /// The X they were interpolated at: used only if the update's X is the same.
    pub(super) x_in_q24: i32,
    /// The first `form.width()` are the row (a power-form row uses 4).
    pub(super) coeffs_in_q32: [i32; MAX_WIDTH],
}

impl ZRun {
    pub(super) fn state(&self) -> ZState {
        match &self.gen {
            Gen::Power(g) => g.state(),
            Gen::Harmonic(g) => g.state(),
        }
    }

    /// The tick `n` ticks after the next one updates the generator or interpolates ahead for
    /// it: the run's heavy ticks.
    #[inline]
    pub(super) fn heavy_in(&self, n: u8) -> bool {
        let mask = (1u8 << self.update_shift) - 1;
        let phase = self.update_phase.wrapping_add(n) & mask;
        phase == 0 || (self.update_shift > 0 && phase == mask)
    }

    /// X after one more tick: it feeds while the command follows the table, not in a hold.
    #[inline]
    pub(super) fn fed_x_in_q24(&self, hold: bool) -> i32 {
        let end = self.spec.x_end_in_q24;
        if !hold && self.state() == ZState::Running && self.x_in_q24 < end {
            self.x_in_q24.saturating_add(self.spec.x_feed_in_q24_per_tick).min(end)
        } else {
            self.x_in_q24
        }
    }

    /// The coefficients at `x_in_q24` into [`ZRun::ahead`], for the next update.
    #[inline]
    pub(super) fn interpolate_ahead(&mut self, table: &LinkTable, x_in_q24: i32) {
        let a = &mut self.ahead;
        match (&self.gen, table) {
            (Gen::Power(g), LinkTable::Power(t)) => {
                let row = t.coefficients(x_in_q24, g.interp());
                for (to, c) in a.coeffs_in_q32.iter_mut().zip(row) {
                    *to = c;
                }
            }
            (Gen::Harmonic(g), LinkTable::Harmonic(t)) => {
                a.coeffs_in_q32 = t.coefficients(x_in_q24, g.interp());
            }
            // Not reachable: a run exists only with the table it was made for.
            _ => return,
        }
        a.x_in_q24 = x_in_q24;
        a.valid = true;
    }
}

/// A run prepared by [`ZJob::prepare`], for [`ZJob::begin`].
#[derive(Clone, Debug)]
pub struct ZPrepared(pub(super) ZRun);

pub(super) fn prepare_run(
    table: &LinkTable,
    speed: i32,
    spec: &ZJobSpec,
    (cfg, update_shift): (ZCommandConfig, u8),
    steps: Option<StepScale>,
    dac: Option<DacScale>,
    z_axis: Option<u8>,
) -> Result<ZRun, ZStartError> {
    let x = spec.x_start_in_q24;
    // The slide is at rest at the job's start: Z = 0 relative to where it stands.
    let gen = match table {
        LinkTable::None => return Err(ZStartError::NoTable),
        LinkTable::Power(t) => {
            let mut g = ZGen::new(t, cfg, 0).map_err(|_| ZStartError::Config)?;
            g.start(t, x, speed, 0).map_err(ZStartError::Fault)?;
            Gen::Power(g)
        }
        LinkTable::Harmonic(t) => {
            let mut g = ZGen::new(t, cfg, 0).map_err(|_| ZStartError::Config)?;
            g.start(t, x, speed, 0).map_err(ZStartError::Fault)?;
            Gen::Harmonic(g)
        }
    };
    let dac_code = dac.and_then(|d| d.code(0).ok()).unwrap_or(crate::machine::Z_DAC_MID_SCALE);
    let mut run = ZRun {
        spec: *spec,
        gen,
        x_in_q24: x,
        x_steps: 0,
        z_steps: 0,
        x_bit: 1 << spec.x_axis,
        z_bit: z_axis.map(|a| 1u8 << a).unwrap_or(0),
        steps,
        dac,
        dac_code,
        dac_fault: false,
        pins: Pins::default(),
        last: ZUpdate::default(),
        command: ZUpdate::default(),
        update_shift,
        update_phase: 0,
        max_following_in_q32: 0,
        ahead: Ahead { valid: false, x_in_q24: 0, coeffs_in_q32: [0; MAX_WIDTH] },
    };
    // The first update, on the first tick, finds its coefficients ready.
    let x = run.fed_x_in_q24(false);
    run.interpolate_ahead(table, x);
    Ok(run)
}
