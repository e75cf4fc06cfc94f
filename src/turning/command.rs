//! The interrupt-rate Z command: `Z(X, phi + omega tau)` from a coefficient table, with soft
//! engage from the slide's current Z, a blended disengage at the table edge (smoothstep weights,
//! so neither engage nor disengage steps the command), and velocity/acceleration limits checked
//! against the spindle speed before start and at every update (`FaultCode::ZSlideLimit`; the
//! command is never clipped silently). Faults latch and freeze the command.
//!
//! Per update ([`ZCommand::update`]): one table evaluation (interpolation in X, sin/cos, the
//! series and its two angle derivatives), a few multiplies for the limits and the blend. No
//! division, no loops beyond the table width, no panics.

use super::table::{
    eval_row_with_delta, rad_per_tick_q32, CoefficientTable, Interp, TableForm, ZPoint,
};
use crate::protocol::errors::FaultCode;

/// Fastest spindle the generator accepts: 2^22 turn Q32 per tick (1/1024 turn per tick, 2930
/// rpm at 50 kHz). Keeps every product in range; faster is a `ZSlideLimit` fault.
pub const MAX_SPEED_TURN_Q32_PER_TICK: i32 = 1 << 22;
/// Angles sampled per table row by the pre-start check.
pub const CHECK_ANGLES: u32 = 256;

/// Generator setup (config time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ZCommandConfig {
    pub tick_hz: u32,
    pub interp: Interp,
    /// Latency the command is advanced by (`phi + omega tau`), ticks Q16.
    pub advance_ticks_q16: u32,
    /// Soft-engage duration, ticks (>= 1).
    pub engage_ticks: u32,
    /// Disengage blend: weight 1 at `blend_start`, 0 at `blend_end` (<= the table's last X).
    pub blend_start_x_in_q24: i32,
    pub blend_end_x_in_q24: i32,
    /// Slide limits, micro-inches per second and per second^2.
    pub max_velocity_uin_per_s: u32,
    pub max_accel_uin_per_s2: u32,
    /// While engaged, a spindle slower than this (turn Q32 per tick) is `SpindleStopped`.
    pub min_speed_turn_q32_per_tick: u32,
}

/// Why a config was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZConfigError {
    TickRate,
    Engage,
    Blend,
    Limits,
}

/// Where the generator is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZState {
    /// Holding the rest Z, not following the table.
    Idle,
    /// Following the table with weight `< 1` (engaging) or 1.
    Running,
    /// Past the blend end: back at the rest Z.
    Finished,
    /// A fault latched: the command is frozen.
    Faulted(FaultCode),
}

/// One update's output.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ZUpdate {
    /// Z command, inches Q32.
    pub z_in_q32: i32,
    /// Its time derivatives (feedforward for a servo), inches Q48 per tick and per tick^2: the
    /// spindle-angle terms scaled by the blend weight plus the blend's own terms (the weight
    /// changes in time during the engage and with X during the disengage). Not included: the
    /// X-feed term `dZ/dX * dX/dt` and the spindle-acceleration term `dZ/dphi * alpha`.
    pub v_in_q48_per_tick: i64,
    pub a_in_q48_per_tick2: i64,
}

impl ZUpdate {
    /// The command `ticks_q16` ticks later (earlier if negative), by its Taylor series
    /// `z + v d + a d^2 / 2`, `v + a d`: an output whose latency differs from the generator's
    /// `advance_ticks_q16` takes the command shifted by the difference (error `jerk d^3 / 6`:
    /// below 1e-6 uin for one tick at 360 rpm). `|ticks_q16| <= 2^20` (16 ticks) keeps every
    /// product in range; larger values are clamped. Division-free.
    #[inline]
    pub fn shifted(&self, ticks_q16: i32) -> ZUpdate {
        let d = (ticks_q16 as i64).clamp(-(1 << 20), 1 << 20);
        // v, a are bounded by the generator's limit check (<< 2^40 Q48 per tick) or are zero.
        let v = self.v_in_q48_per_tick.clamp(-(1 << 42), 1 << 42);
        let a = self.a_in_q48_per_tick2.clamp(-(1 << 42), 1 << 42);
        let ad = (a * d) >> 16; // Q48 per tick
        let dz_q48 = ((v * d) >> 16) + ((ad * d) >> 17);
        let z = self.z_in_q32 as i64 + (dz_q48 >> 16);
        ZUpdate {
            z_in_q32: z.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
            v_in_q48_per_tick: v + ad,
            a_in_q48_per_tick2: a,
        }
    }
}

/// The generator's state without its table: every method that reads the table takes it as an
/// argument, so an owner may keep the table beside the state (the link firmware's Z job, whose
/// table is replaced by uploads between jobs). [`ZCommand`] pairs it with a borrowed table.
/// The table passed must be the one given to [`ZGen::new`] (its derivative scan is cached).
#[derive(Clone, Debug)]
pub struct ZGen<const WIDTH: usize> {
    cfg: ZCommandConfig,
    v_max_in_q48_per_tick: i64,
    a_max_in_q48_per_tick2: i64,
    engage_step_q16: u32,
    blend_per_x_q32: i64,
    /// Largest |dZ/dphi|, |d2Z/dphi2| over the table (inches Q32 per rad, per rad^2).
    max_dz_dphi_in_q32: i64,
    max_d2z_dphi2_in_q32: i64,
    state: ZState,
    z_rest_in_q32: i32,
    engage_weight_q16: u32,
    /// X at the previous update (the disengage blend's rate comes from its change).
    last_x_in_q24: i32,
    /// Coefficients at the previous update's X: their change is the X-feed term of the
    /// feedforward (`dZ/dX dX/dt`, the series being linear in its coefficients).
    last_coeffs_in_q32: [i32; WIDTH],
    last: ZUpdate,
    updates: u64,
}

/// `3 w^2 - 2 w^3` in Q16 for `0 <= w <= 1` (Q16): zero slope at both ends.
#[inline]
fn smoothstep_q16(w_q16: u32) -> i64 {
    let w = w_q16.min(1 << 16) as i64;
    let w2 = (w * w) >> 16;
    (w2 * ((3 << 16) - 2 * w)) >> 16
}

/// Largest X change per update the blend-rate estimate takes (2^14 Q24 = 0.001 in per tick, 50
/// in/s at 50 kHz): bounds the products below; a faster X only clips the blend feedforward.
const MAX_DX_IN_Q24_PER_TICK: i64 = 1 << 14;

/// First and second time derivatives of the blend weight `smoothstep(m)` for a ramp variable
/// `m` (Q16, 0..=1) moving at `dm_q32` per tick (Q32), as `(w' Q32 per tick, w'' Q32 per
/// tick^2)`: `w' = 6 m (1 - m) m'`, `w'' = (6 - 12 m) m'^2` (`m'' = 0`: both ramps are linear
/// in their variable). `|dm_q32| <= 2^32` keeps every product below 2^63.
#[inline]
fn smoothstep_rates_q32(m_q16: u32, dm_q32: i64) -> (i64, i64) {
    let m = m_q16.min(1 << 16) as i64;
    let dm = dm_q32.clamp(-(1 << 32), 1 << 32);
    let slope_q16 = (6 * m * ((1 << 16) - m)) >> 16; // <= 1.5 * 2^16
    let curve_q16 = (6 << 16) - 12 * m; // |.| <= 6 * 2^16
    let dm2_q32 = ((dm >> 8) * (dm >> 8)) >> 16; // <= 2^32
    ((slope_q16 * dm) >> 16, (curve_q16 * dm2_q32) >> 16)
}

impl<const WIDTH: usize> ZGen<WIDTH> {
    /// Checks the config and scans the table once for its largest angle derivatives (config
    /// time: divides, loops over rows x [`CHECK_ANGLES`]).
    pub fn new<const ROWS: usize>(
        table: &CoefficientTable<ROWS, WIDTH>,
        cfg: ZCommandConfig,
        z_rest_in_q32: i32,
    ) -> Result<Self, ZConfigError> {
        if cfg.tick_hz < 1000 {
            return Err(ZConfigError::TickRate);
        }
        if cfg.engage_ticks == 0 {
            return Err(ZConfigError::Engage);
        }
        if cfg.blend_end_x_in_q24 <= cfg.blend_start_x_in_q24
            || cfg.blend_end_x_in_q24 > table.x_last_in_q24()
        {
            return Err(ZConfigError::Blend);
        }
        if cfg.max_velocity_uin_per_s == 0 || cfg.max_accel_uin_per_s2 == 0 {
            return Err(ZConfigError::Limits);
        }
        let hz = cfg.tick_hz as i64;
        // uin/s -> in Q48 per tick: v * 2^48 / 1e6 / hz.
        let v_max = ((cfg.max_velocity_uin_per_s as i128) << 48) / (1_000_000 * hz as i128);
        let a_max = ((cfg.max_accel_uin_per_s2 as i128) << 48) / (1_000_000 * (hz * hz) as i128);
        let span = (cfg.blend_end_x_in_q24 as i64 - cfg.blend_start_x_in_q24 as i64).max(1);
        let mut max_d1 = 0i64;
        let mut max_d2 = 0i64;
        for i in 0..table.len() {
            if let Some(row) = table.row(i) {
                for j in 0..CHECK_ANGLES {
                    let phi = j.wrapping_mul(u32::MAX / CHECK_ANGLES + 1);
                    let p = super::table::eval_row(table.form(), row, phi);
                    max_d1 = max_d1.max(p.dz_dphi_in_q32.abs());
                    max_d2 = max_d2.max(p.d2z_dphi2_in_q32.abs());
                }
            }
        }
        Ok(Self {
            cfg,
            v_max_in_q48_per_tick: v_max as i64,
            a_max_in_q48_per_tick2: (a_max as i64).max(1),
            engage_step_q16: ((1u32 << 16) / cfg.engage_ticks).max(1),
            blend_per_x_q32: (1i64 << 48) / span,
            max_dz_dphi_in_q32: max_d1,
            max_d2z_dphi2_in_q32: max_d2,
            state: ZState::Idle,
            z_rest_in_q32,
            engage_weight_q16: 0,
            last_x_in_q24: 0,
            last_coeffs_in_q32: [0; WIDTH],
            last: ZUpdate { z_in_q32: z_rest_in_q32, ..ZUpdate::default() },
            updates: 0,
        })
    }

    /// Velocity and acceleration the table needs at this spindle speed, worst case over the
    /// table (inches Q48 per tick, per tick^2).
    pub fn required_at(&self, speed_turn_q32_per_tick: i32) -> (i64, i64) {
        let w = rad_per_tick_q32(
            speed_turn_q32_per_tick
                .clamp(-MAX_SPEED_TURN_Q32_PER_TICK, MAX_SPEED_TURN_Q32_PER_TICK),
        )
        .abs();
        (vel_q48(self.max_dz_dphi_in_q32, w), acc_q48(self.max_d2z_dphi2_in_q32, w))
    }

    /// The slide limits in the same units.
    pub fn limits(&self) -> (i64, i64) {
        (self.v_max_in_q48_per_tick, self.a_max_in_q48_per_tick2)
    }

    /// Pre-start check and soft engage, at `x_in_q24`, from `z_now_in_q32` (the slide's current Z, which
    /// becomes the rest Z the disengage returns to). Errs with `ZSlideLimit` if the table at
    /// this spindle speed (or the engage ramp) needs more than the slide has, `SpindleStopped`
    /// if the spindle is stopped.
    pub fn start<const ROWS: usize>(
        &mut self,
        table: &CoefficientTable<ROWS, WIDTH>,
        x_in_q24: i32,
        speed_turn_q32_per_tick: i32,
        z_now_in_q32: i32,
    ) -> Result<(), FaultCode> {
        if speed_turn_q32_per_tick.unsigned_abs() < self.cfg.min_speed_turn_q32_per_tick {
            return Err(FaultCode::SpindleStopped);
        }
        if speed_turn_q32_per_tick.unsigned_abs() > MAX_SPEED_TURN_Q32_PER_TICK as u32 {
            return Err(FaultCode::ZSlideLimit);
        }
        let (v, a) = self.required_at(speed_turn_q32_per_tick);
        // Engage ramp: smoothstep's peak slope is 1.5 / engage_ticks times the distance from
        // the current Z to the table's Z at the engage X.
        let c = table.coefficients(x_in_q24, self.cfg.interp);
        let mut far = 0i64;
        for j in 0..CHECK_ANGLES {
            let phi = j.wrapping_mul(u32::MAX / CHECK_ANGLES + 1);
            let z = super::table::eval_row(table.form(), &c, phi).z_in_q32;
            far = far.max((z as i64 - z_now_in_q32 as i64).abs());
        }
        let ramp_v = (far << 16) * 3 / 2 / self.cfg.engage_ticks as i64;
        if v + ramp_v > self.v_max_in_q48_per_tick || a > self.a_max_in_q48_per_tick2 {
            return Err(FaultCode::ZSlideLimit);
        }
        self.z_rest_in_q32 = z_now_in_q32;
        self.engage_weight_q16 = 0;
        self.last_x_in_q24 = x_in_q24;
        self.last_coeffs_in_q32 = c;
        // The first update's step check compares with this: the slide is at `z_now` (not at
        // the rest Z given to `new`, which may differ).
        self.last = ZUpdate { z_in_q32: z_now_in_q32, ..ZUpdate::default() };
        self.state = ZState::Running;
        Ok(())
    }

    /// One update (call once per tick, >= 20 kHz): spindle angle and speed from the source,
    /// its fault if any, the X position. Returns the command (frozen once faulted).
    #[inline(never)]
    pub fn update<const ROWS: usize>(
        &mut self,
        table: &CoefficientTable<ROWS, WIDTH>,
        x_in_q24: i32,
        angle_turn_q32: u32,
        speed_turn_q32_per_tick: i32,
        sensor_fault: Option<FaultCode>,
    ) -> ZUpdate {
        let interp = self.cfg.interp;
        self.update_from(
            table.form(),
            || table.coefficients(x_in_q24, interp),
            x_in_q24,
            angle_turn_q32,
            speed_turn_q32_per_tick,
            sensor_fault,
        )
    }

    /// The interpolation [`ZGen::update`] uses (an owner that computes the coefficients ahead
    /// of the update, [`ZGen::update_from`], must use the same).
    pub const fn interp(&self) -> Interp {
        self.cfg.interp
    }

    /// [`ZGen::update`] with the table's coefficients at `x_in_q24` already interpolated, by
    /// `table.coefficients(x_in_q24, self.interp())` (an owner that does that a tick ahead
    /// spreads the work of one update over two ticks). The result is the same.
    #[inline(never)]
    pub fn update_with(
        &mut self,
        form: TableForm,
        coefficients_in_q32: [i32; WIDTH],
        x_in_q24: i32,
        angle_turn_q32: u32,
        speed_turn_q32_per_tick: i32,
        sensor_fault: Option<FaultCode>,
    ) -> ZUpdate {
        self.update_from(
            form,
            || coefficients_in_q32,
            x_in_q24,
            angle_turn_q32,
            speed_turn_q32_per_tick,
            sensor_fault,
        )
    }

    /// The update, with the coefficients from `coefficients` (called at most once, after the
    /// state and speed checks). Inlined into its two entries, [`ZGen::update`] and
    /// [`ZGen::update_with`], so each is one function as the update was before it had two.
    #[inline(always)]
    fn update_from(
        &mut self,
        form: TableForm,
        coefficients: impl FnOnce() -> [i32; WIDTH],
        x_in_q24: i32,
        angle_turn_q32: u32,
        speed_turn_q32_per_tick: i32,
        sensor_fault: Option<FaultCode>,
    ) -> ZUpdate {
        self.updates = self.updates.wrapping_add(1);
        match self.state {
            ZState::Running => {}
            ZState::Faulted(_) => return self.last,
            ZState::Idle | ZState::Finished => {
                self.last = ZUpdate { z_in_q32: self.z_rest_in_q32, ..ZUpdate::default() };
                return self.last;
            }
        }
        if let Some(f) = sensor_fault {
            return self.fault(f);
        }
        let speed_abs = speed_turn_q32_per_tick.unsigned_abs();
        if speed_abs < self.cfg.min_speed_turn_q32_per_tick {
            return self.fault(FaultCode::SpindleStopped);
        }
        if speed_abs > MAX_SPEED_TURN_Q32_PER_TICK as u32 {
            return self.fault(FaultCode::ZSlideLimit);
        }
        // Phase advance for the known latency: phi + omega * tau (wraps as angles do).
        let advance =
            ((speed_turn_q32_per_tick as i64 * self.cfg.advance_ticks_q16 as i64) >> 16) as u32;
        let phi = angle_turn_q32.wrapping_add(advance);
        let c = coefficients();
        // X-feed term: the series at this angle over the coefficients' change since the last
        // update is dZ/dX * dX per tick (a backward difference: half a tick late, negligible).
        // Without it the servo lags by 2.7 uin at X 6.75 in the scenario's 3 in/s feed. It
        // shares the angle's sines and cosines with the command's own evaluation.
        let mut dc = [0i32; WIDTH];
        for ((d, now), before) in dc.iter_mut().zip(c.iter()).zip(self.last_coeffs_in_q32.iter()) {
            // Coefficients are within +-2^28 (table check): the difference cannot overflow.
            *d = now.wrapping_sub(*before);
        }
        self.last_coeffs_in_q32 = c;
        let (p, dz_x): (ZPoint, i32) = eval_row_with_delta(form, &c, &dc, phi);
        let v_x = (dz_x as i64) << 16;
        let w = rad_per_tick_q32(speed_turn_q32_per_tick);
        let v_phi = ((p.dz_dphi_in_q32 * w) >> 16) + v_x;
        let a_phi = acc_q48(p.d2z_dphi2_in_q32, w);
        // Blend weight: engage ramp in time, disengage ramp in X.
        self.engage_weight_q16 = (self.engage_weight_q16 + self.engage_step_q16).min(1 << 16);
        let to_end = (self.cfg.blend_end_x_in_q24 as i64 - x_in_q24 as i64).max(0);
        let edge_q16 = ((to_end * self.blend_per_x_q32) >> 32).min(1 << 16) as u32;
        let dx = (x_in_q24 as i64 - self.last_x_in_q24 as i64)
            .clamp(-MAX_DX_IN_Q24_PER_TICK, MAX_DX_IN_Q24_PER_TICK);
        self.last_x_in_q24 = x_in_q24;
        // The ramp variable in force and its rate per tick (Q32): the engage's is the constant
        // step while it ramps; the disengage's is -dX * (1/span) inside the blend zone.
        let (m_q16, dm_q32) = if self.engage_weight_q16 <= edge_q16 {
            let ramping = self.engage_weight_q16 < 1 << 16;
            (self.engage_weight_q16, if ramping { (self.engage_step_q16 as i64) << 16 } else { 0 })
        } else {
            let inside = edge_q16 > 0 && edge_q16 < 1 << 16;
            (edge_q16, if inside { -((dx * self.blend_per_x_q32) >> 16) } else { 0 })
        };
        let weight = smoothstep_q16(m_q16);
        let (dw_q32, d2w_q32) = smoothstep_rates_q32(m_q16, dm_q32);
        let rest = self.z_rest_in_q32 as i64;
        let lift = p.z_in_q32 as i64 - rest; // |.| < 2^32
        let z = rest + ((lift * weight) >> 16);
        // d/dt [rest + lift w] = lift' w + lift w'; d2/dt2 = lift'' w + 2 lift' w' + lift w''
        // (lift' = v, lift'' = a: the angle terms). Without the blend terms the servo lags the
        // blend: 42.7 uin in the disengage of the 360 rpm scenario (0.09 in/s unfed at X 7.4).
        // Operands pre-shifted so each product stays below 2^58.
        let v = ((v_phi * weight) >> 16) + (((lift >> 8) * dw_q32) >> 8);
        let a = ((a_phi * weight) >> 16)
            + ((((v_phi >> 16) * dw_q32) >> 16) << 1)
            + (((lift >> 8) * d2w_q32) >> 8);
        if v.abs() > self.v_max_in_q48_per_tick || a.abs() > self.a_max_in_q48_per_tick2 {
            return self.fault(FaultCode::ZSlideLimit);
        }
        // Command step check: the blends must not move faster than the slide either (the
        // per-update change, with 25 % allowance for the angle quantisation of the source).
        let dz_q48 = (z - self.last.z_in_q32 as i64) << 16;
        if dz_q48.abs() > self.v_max_in_q48_per_tick + (self.v_max_in_q48_per_tick >> 2) {
            return self.fault(FaultCode::ZSlideLimit);
        }
        if edge_q16 == 0 {
            self.state = ZState::Finished;
        }
        self.last = ZUpdate {
            z_in_q32: z.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
            v_in_q48_per_tick: v,
            a_in_q48_per_tick2: a,
        };
        self.last
    }

    fn fault(&mut self, f: FaultCode) -> ZUpdate {
        self.state = ZState::Faulted(f);
        self.last = ZUpdate { z_in_q32: self.last.z_in_q32, ..ZUpdate::default() };
        self.last
    }

    pub fn state(&self) -> ZState {
        self.state
    }
    /// The latched fault, if any.
    pub fn fault_code(&self) -> Option<FaultCode> {
        match self.state {
            ZState::Faulted(f) => Some(f),
            _ => None,
        }
    }
    pub fn last(&self) -> ZUpdate {
        self.last
    }
    /// Updates done (every call counts).
    pub fn updates(&self) -> u64 {
        self.updates
    }
}

/// The generator over one borrowed table: [`ZGen`] plus the table it was built for.
#[derive(Clone, Debug)]
pub struct ZCommand<'t, const ROWS: usize, const WIDTH: usize> {
    table: &'t CoefficientTable<ROWS, WIDTH>,
    gen: ZGen<WIDTH>,
}

impl<'t, const ROWS: usize, const WIDTH: usize> ZCommand<'t, ROWS, WIDTH> {
    /// [`ZGen::new`] over `table` (config time).
    pub fn new(
        table: &'t CoefficientTable<ROWS, WIDTH>,
        cfg: ZCommandConfig,
        z_rest_in_q32: i32,
    ) -> Result<Self, ZConfigError> {
        Ok(Self { table, gen: ZGen::new(table, cfg, z_rest_in_q32)? })
    }
    /// See [`ZGen::required_at`].
    pub fn required_at(&self, speed_turn_q32_per_tick: i32) -> (i64, i64) {
        self.gen.required_at(speed_turn_q32_per_tick)
    }
    /// See [`ZGen::limits`].
    pub fn limits(&self) -> (i64, i64) {
        self.gen.limits()
    }
    /// See [`ZGen::start`].
    pub fn start(
        &mut self,
        x_in_q24: i32,
        speed_turn_q32_per_tick: i32,
        z_now_in_q32: i32,
    ) -> Result<(), FaultCode> {
        self.gen.start(self.table, x_in_q24, speed_turn_q32_per_tick, z_now_in_q32)
    }
    /// See [`ZGen::update`] (interrupt rate).
    #[inline(always)]
    pub fn update(
        &mut self,
        x_in_q24: i32,
        angle_turn_q32: u32,
        speed_turn_q32_per_tick: i32,
        sensor_fault: Option<FaultCode>,
    ) -> ZUpdate {
        self.gen.update(self.table, x_in_q24, angle_turn_q32, speed_turn_q32_per_tick, sensor_fault)
    }
    pub fn state(&self) -> ZState {
        self.gen.state()
    }
    pub fn fault_code(&self) -> Option<FaultCode> {
        self.gen.fault_code()
    }
    pub fn last(&self) -> ZUpdate {
        self.gen.last()
    }
    pub fn updates(&self) -> u64 {
        self.gen.updates()
    }
    pub fn table(&self) -> &'t CoefficientTable<ROWS, WIDTH> {
        self.table
    }
    /// The generator state.
    pub fn gen(&self) -> &ZGen<WIDTH> {
        &self.gen
    }
}

/// `dZ/dphi * w` in inches Q48 per tick (w in rad per tick Q32).
#[inline]
fn vel_q48(dz_dphi_in_q32: i64, w_rad_q32: i64) -> i64 {
    (dz_dphi_in_q32 * w_rad_q32) >> 16
}

/// `d2Z/dphi2 * w^2` in inches Q48 per tick^2.
#[inline]
fn acc_q48(d2z_in_q32: i64, w_rad_q32: i64) -> i64 {
    (((d2z_in_q32 * w_rad_q32) >> 32) * w_rad_q32) >> 16
}
