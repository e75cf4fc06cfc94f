//! The Z job ([`ZJob`]): its table, the spindle reading, starting a run (checks, setup outside
//! the tick, engage inside it) and what Status and the machine read from it.

use super::run::{prepare_run, Gen, ZPrepared, ZRun};
use super::spec::{ZJobSpec, ZOutputSpec, ZStartError};
use super::update_rate::{per_update, update_shift};
use super::upload::LinkTable;
use crate::protocol::errors::FaultCode;
use crate::spindle::SpindleSource;
use crate::turning::command::{ZCommandConfig, ZState, ZUpdate};
use crate::turning::output::{DacScale, StepScale};
use crate::turning::table::Interp;

/// The Z job: the active table and the run, if any (inside the tick's resource).
#[derive(Clone, Debug, Default)]
pub struct ZJob {
    pub(super) table: LinkTable,
    pub(super) run: Option<ZRun>,
    pub(super) angle_turn_q32: u32,
    pub(super) speed_turn_q32_per_tick: i32,
    pub(super) source_fault: Option<FaultCode>,
    /// Ticks until the next full reading outside the generator's update ticks.
    refresh_in: u8,
    /// Fault bits already handed to the machine.
    reported: u32,
}

/// Outside the generator's update ticks the spindle's angle and speed are read every this many
/// ticks (0.32 ms at 100 kHz): for Status, the force job's stopped-spindle hold and the start
/// check. Its fault is read every tick.
pub const SENSE_REFRESH_TICKS: u8 = 32;

/// Inches Q32 to nanoinches (reports).
#[inline]
fn nin(z_in_q32: i64) -> i64 {
    (z_in_q32.clamp(-(1 << 40), 1 << 40) * 1_000_000_000) >> 32
}

impl ZJob {
    pub const fn new() -> Self {
        Self {
            table: LinkTable::None,
            run: None,
            angle_turn_q32: 0,
            speed_turn_q32_per_tick: 0,
            source_fault: None,
            refresh_in: 0,
            reported: 0,
        }
    }

    /// Replaces the table; refused (`Running`) while a job runs.
    pub fn install(&mut self, table: LinkTable) -> Result<(), ZStartError> {
        if self.is_running() {
            return Err(ZStartError::Running);
        }
        self.table = table;
        Ok(())
    }

    pub fn table(&self) -> &LinkTable {
        &self.table
    }

    /// A run exists (started, not dropped): its table must stay.
    pub fn is_running(&self) -> bool {
        self.run.is_some()
    }

    /// The spindle reading for this tick (call every tick, job or not: the start check uses
    /// the speed). Interrupt rate: three stores.
    #[inline]
    pub fn sense(
        &mut self,
        angle_turn_q32: u32,
        speed_turn_q32_per_tick: i32,
        fault: Option<FaultCode>,
    ) {
        self.angle_turn_q32 = angle_turn_q32;
        self.speed_turn_q32_per_tick = speed_turn_q32_per_tick;
        self.source_fault = fault;
    }

    /// The spindle reading for this tick from `spindle`, reading its angle and speed (a few
    /// dozen instructions) only when they are used: on the generator's update ticks during a
    /// run, and every [`SENSE_REFRESH_TICKS`] ticks; its fault every tick of a run. Interrupt
    /// rate; a decrement on the ticks between without a run.
    #[inline]
    pub fn sense_from<S: SpindleSource>(&mut self, spindle: &S) {
        if self.refresh_in > 1 {
            match &self.run {
                // Nothing reads the spindle between refreshes without a run.
                None => {
                    self.refresh_in -= 1;
                    return;
                }
                // The generator reacts to a spindle fault on any tick of a run.
                Some(r) if r.update_phase != 0 => {
                    self.refresh_in -= 1;
                    self.source_fault = spindle.fault();
                    return;
                }
                Some(_) => {}
            }
        }
        self.refresh_in = SENSE_REFRESH_TICKS;
        self.sense(spindle.angle_turn_q32(), spindle.speed_turn_q32_per_tick(), spindle.fault());
    }

    /// Checks `spec` against the table and the last sensed spindle speed, and engages (setup
    /// time: divides). The caller then starts the machine's job (`MachineCommand::StartSource(TURNING_JOB)`); a
    /// refusal there is undone with [`ZJob::drop_run`].
    pub fn start(&mut self, spec: &ZJobSpec, tick_hz: u32) -> Result<(), ZStartError> {
        if self.run.is_some() {
            return Err(ZStartError::Running);
        }
        let p = Self::prepare(&self.table, spec, tick_hz, self.speed_turn_q32_per_tick)?;
        self.begin(p)
    }

    /// The setup half of [`ZJob::start`], outside the job: checks `spec` against `table` (the
    /// table the job holds, or an identical copy) and the spindle speed, builds the generator
    /// (setup time: divides, scans the table: milliseconds on the F405, so the link firmware runs
    /// it outside the tick's lock) and engages it.
    pub fn prepare(
        table: &LinkTable,
        spec: &ZJobSpec,
        tick_hz: u32,
        speed_turn_q32_per_tick: i32,
    ) -> Result<ZPrepared, ZStartError> {
        let axes = crate::config::MAX_AXES as u8;
        let (steps, dac, z_axis) = match spec.output {
            ZOutputSpec::Steps { axis, steps_per_in } => {
                (Some(StepScale::new(steps_per_in).ok_or(ZStartError::Spec)?), None, Some(axis))
            }
            ZOutputSpec::Dac { codes_per_in, mid_code } => {
                (None, Some(DacScale::new(codes_per_in, mid_code).ok_or(ZStartError::Spec)?), None)
            }
        };
        let bad_axis = spec.x_axis >= axes || z_axis.is_some_and(|z| z >= axes || z == spec.x_axis);
        let bad_feed = spec.x_feed_in_q24_per_tick <= 0
            || spec.x_feed_in_q24_per_tick > 1 << 14
            || spec.x_end_in_q24 < spec.x_start_in_q24
            || spec.x_steps_per_in == 0
            || spec.x_steps_per_in > 1 << 24;
        if bad_axis || bad_feed {
            return Err(ZStartError::Spec);
        }
        // The generator's time unit is its update period: everything per tick scales with it.
        let shift = update_shift(tick_hz, speed_turn_q32_per_tick);
        let cfg = ZCommandConfig {
            tick_hz: tick_hz >> shift,
            interp: if spec.cubic { Interp::Cubic } else { Interp::Linear },
            advance_ticks_q16: spec.advance_ticks_q16 >> shift,
            engage_ticks: (spec.engage_ticks >> shift).max(1),
            blend_start_x_in_q24: spec.blend_start_x_in_q24,
            blend_end_x_in_q24: spec.blend_end_x_in_q24,
            max_velocity_uin_per_s: spec.max_velocity_uin_per_s,
            max_accel_uin_per_s2: spec.max_accel_uin_per_s2,
            min_speed_turn_q32_per_tick: spec
                .min_speed_turn_q32_per_tick
                .saturating_mul(1 << shift),
        };
        let speed = per_update(speed_turn_q32_per_tick, shift);
        prepare_run(table, speed, spec, (cfg, shift), steps, dac, z_axis).map(ZPrepared)
    }

    /// Starts a prepared run (a few stores: inside the tick's lock). Refused while a run exists.
    pub fn begin(&mut self, p: ZPrepared) -> Result<(), ZStartError> {
        if self.run.is_some() {
            return Err(ZStartError::Running);
        }
        if matches!(self.table, LinkTable::None) {
            return Err(ZStartError::NoTable);
        }
        self.reported = 0;
        self.run = Some(p.0);
        Ok(())
    }

    /// [`ZJob::begin`] after the last run ended: that run is replaced, or kept if refused.
    pub fn rebegin(&mut self, p: ZPrepared) -> Result<(), ZStartError> {
        let old = self.run.take();
        let reported = self.reported;
        let r = self.begin(p);
        if r.is_err() {
            self.run = old;
            self.reported = reported;
        }
        r
    }
}

impl ZJob {
    /// [`ZJob::start`] after the last run ended (the machine's job is over): that run is
    /// replaced, or kept (with its figures) if the start is refused.
    pub fn restart(&mut self, spec: &ZJobSpec, tick_hz: u32) -> Result<(), ZStartError> {
        let old = self.run.take();
        let reported = self.reported;
        let r = self.start(spec, tick_hz);
        if r.is_err() {
            self.run = old;
            self.reported = reported;
        }
        r
    }

    /// Forgets the run (after Abort, ClearFault, SetConfig, Home, or a refused machine start).
    pub fn drop_run(&mut self) {
        self.run = None;
        self.reported = 0;
    }

    /// Fault bits the machine has not been given yet (`Inputs::sensor_faults`); each once.
    #[inline]
    pub fn take_sensor_faults(&mut self) -> u32 {
        let Some(run) = &self.run else { return 0 };
        let state = match &run.gen {
            Gen::Power(g) => g.state(),
            Gen::Harmonic(g) => g.state(),
        };
        let mut bits = match state {
            ZState::Faulted(f) => f.bit(),
            _ => 0,
        };
        if run.dac_fault {
            bits |= FaultCode::ZSlideLimit.bit();
        }
        let fresh = bits & !self.reported;
        self.reported |= bits;
        fresh
    }

    /// The generator's state, if a run exists.
    pub fn state(&self) -> Option<ZState> {
        self.run.as_ref().map(|r| match &r.gen {
            Gen::Power(g) => g.state(),
            Gen::Harmonic(g) => g.state(),
        })
    }

    /// The last Z command.
    pub fn last(&self) -> Option<ZUpdate> {
        self.run.as_ref().map(|r| r.command)
    }

    /// Commanded X, inches Q24.
    pub fn x_in_q24(&self) -> Option<i32> {
        self.run.as_ref().map(|r| r.x_in_q24)
    }

    /// The DAC code to write this tick (DAC output only).
    pub fn dac_code(&self) -> Option<u16> {
        self.run.as_ref().filter(|r| r.dac.is_some()).map(|r| r.dac_code)
    }

    /// Steps emitted on the (X, Z) axes since the start.
    pub fn steps(&self) -> Option<(i64, i64)> {
        self.run.as_ref().map(|r| (r.x_steps, r.z_steps))
    }

    /// Largest |Z command - Z output| while following, nanoinches (Status figure).
    pub fn max_following_nin(&self) -> i64 {
        self.run.as_ref().map_or(0, |r| nin(r.max_following_in_q32))
    }

    /// The last sensed spindle speed, 2^-32 turn per tick.
    pub fn sensed_speed_turn_q32_per_tick(&self) -> i32 {
        self.speed_turn_q32_per_tick
    }

    /// [`ZJob::state`] as a number for `Status::z_state`: 0 no run, 1 idle (before the engage),
    /// 2 running, 3 finished, 4 faulted.
    pub fn state_code(&self) -> u8 {
        match self.state() {
            None => 0,
            Some(ZState::Idle) => 1,
            Some(ZState::Running) => 2,
            Some(ZState::Finished) => 3,
            Some(ZState::Faulted(_)) => 4,
        }
    }
}
