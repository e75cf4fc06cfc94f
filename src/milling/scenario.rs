//! Closed-loop Case A (thesis §4.5) as a [`Scenario`]: a DDA feeds the X axis at the rapid
//! traverse (override 1.0 = 12.7 mm/s, 1 um per step, 500 mm/s^2), the milling plant turns the
//! stepped position into force, the simulated ADC into counts, the chain into a force reading
//! and the control law into the override, at 2 kHz. The tool starts 2 mm before the wall, cuts
//! b = 2.5 mm for 10 mm, then b = 10 mm; Fnom = 4100 N, tau = 30 ms. Fault variants inject a
//! saturated channel, a stuck channel, a spindle stop (5 mm into the cut) or lower the trip level
//! below the force at the step; each must end in a feed hold with the position exact.
//!
//! [`MillingScenario::custom`] runs the same loop on a milling job's [`MillingSetup`] (its nominal
//! force and thresholds, spindle speed, teeth, cutting constant, feed and move); every figure of
//! the report is then the job's.

use crate::config::{AxisLimits, MachineConfig, StepTiming, MAX_AXES};
use crate::dda::{Command, Dda, MotionState, Preparer};
use crate::protocol::errors::FaultCode;
use crate::scenario::{Scenario, ScenarioReport, TraceHash};
use crate::segment::{Rate, Segment};

use super::biquad::BiquadCoeffs;
use super::chain::{ChainConfig, ChainOutput, ChannelCal, ForceChain, MAX_CHANNELS};
use super::control::{ContactStrategy, ControlInput, ControlParams, ForceController};
use super::plant::{AdcFault, MillingPlant, PlantParams, SimAdc};

/// DDA tick rate.
pub const TICK_HZ: u32 = 50_000;
/// DDA ticks per ADC sample (10 kHz) and ADC samples per control update (2 kHz).
pub const TICKS_PER_SAMPLE: u32 = 5;
pub const CONTROL_HZ: u32 = 2_000;
const SAMPLE_HZ: u32 = TICK_HZ / TICKS_PER_SAMPLE;
/// Rapid traverse: override 1.0, steps/s (1 um per step).
pub const RAPID_STEPS_PER_S: u32 = 12_700;
/// Axis acceleration, steps/s^2 (500 mm/s^2, near the thesis's 478 mm/s^2).
pub const ACCEL_STEPS_PER_S2: u32 = 500_000;
/// Start before the wall and end of the move, steps from the start.
pub const WALL_STEPS: i64 = 2_000;
pub const MOVE_STEPS: i32 = 15_000;
/// Nominal force, mN.
pub const FNOM_MN: u32 = 4_100_000;
/// Spindle: 4 teeth at 500 rpm, mrev/s.
pub const SPINDLE_MREV_S: u32 = 8_333;
/// Penetration at which a fault variant injects its fault, steps.
const FAULT_AT_PEN: i64 = 5_000;
/// The run stops this long after the depth step (figures window), ticks: 400 ms.
const WINDOW_TICKS: u64 = TICK_HZ as u64 * 2 / 5;
/// Safety stop: 5 s of machine time.
const MAX_TICKS: u64 = TICK_HZ as u64 * 5;
/// Ticks run after the DDA reports Held.
const AFTER_HOLD_TICKS: u32 = 500;

/// Which run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    CaseA,
    SaturatedChannel,
    StuckChannel,
    SpindleStop,
    /// Trip level 12 kN, below the 15.6 kN at the step.
    AboveTrip,
    /// Entering a full-depth cut (b = 10 mm from the wall on) straight into the PI: the
    /// baseline the impact strategies improve on.
    ImpactDirect,
    /// The same entry with Algorithm A (slow feed, hold, then PI).
    ImpactA,
    /// The same entry with Algorithm B (stop, reduced gain, then full).
    ImpactB,
}

impl Variant {
    pub const ALL: [Variant; 8] = [
        Variant::CaseA,
        Variant::SaturatedChannel,
        Variant::StuckChannel,
        Variant::SpindleStop,
        Variant::AboveTrip,
        Variant::ImpactDirect,
        Variant::ImpactA,
        Variant::ImpactB,
    ];

    /// Runs the whole Case A (no fault injected).
    const fn is_case_a(self) -> bool {
        matches!(self, Variant::CaseA) || self.is_impact()
    }

    /// Enters a full-depth cut.
    const fn is_impact(self) -> bool {
        matches!(self, Variant::ImpactDirect | Variant::ImpactA | Variant::ImpactB)
    }

    pub const fn name(self) -> &'static str {
        match self {
            Variant::CaseA => "milling_case_a",
            Variant::SaturatedChannel => "milling_saturated",
            Variant::StuckChannel => "milling_stuck",
            Variant::SpindleStop => "milling_spindle_stop",
            Variant::AboveTrip => "milling_trip",
            Variant::ImpactDirect => "milling_impact_direct",
            Variant::ImpactA => "milling_impact_a",
            Variant::ImpactB => "milling_impact_b",
        }
    }
}

/// The machine: one X axis, 1 um per step.
pub fn machine() -> MachineConfig {
    let x = AxisLimits {
        max_rate_hz: 20_000,
        accel_steps_per_s2: ACCEL_STEPS_PER_S2,
        junction_jerk_hz: 0,
    };
    let mut axes = [AxisLimits::UNUSED; MAX_AXES];
    axes[0] = x;
    MachineConfig {
        tick_hz: TICK_HZ,
        timing: StepTiming { pulse_ns: 2_500, dir_setup_ns: 5_000, dir_hold_ns: 5_000 },
        axis_count: 1,
        axes,
    }
}

/// The single move of Case A: rapid feed, ramp at the axis acceleration.
pub fn segment() -> Segment {
    segment_for(MOVE_STEPS, RAPID_STEPS_PER_S)
}

/// The single move of a job: `move_steps` (> 0) along X at `steps_per_s` (override 1.0), ramp
/// at the axis acceleration.
pub fn segment_for(move_steps: i32, steps_per_s: u32) -> Segment {
    let d = move_steps.max(1) as u64;
    let duration = (d * TICK_HZ as u64).div_ceil(steps_per_s.max(1) as u64);
    // Rate change per tick = a / v_nominal / tick_hz, v_nominal = d tick_hz / duration.
    let accel_bits = ((ACCEL_STEPS_PER_S2 as u128 * duration as u128) << 30)
        / (d as u128 * TICK_HZ as u128 * TICK_HZ as u128);
    let mut steps = [0; MAX_AXES];
    steps[0] = d as i32;
    Segment {
        steps,
        duration_ticks: duration as u32,
        entry_rate: Rate::ZERO,
        exit_rate: Rate::ZERO,
        accel_per_tick: Rate::from_bits(accel_bits as u32),
        id: 1,
    }
}

/// The control-law setup of the Case A run.
pub fn control_params(trip_mn: u32) -> ControlParams {
    ControlParams {
        fnom_mn: FNOM_MN,
        contact_mn: 45_000,
        trip_mn,
        air_after_ms: 50,
        tare_ms: 50,
        control_hz: CONTROL_HZ,
        steps_per_s_at_one: RAPID_STEPS_PER_S,
        kp_dec_q16: 1 << 15,
        kp_inc_q16: 1 << 15,
        ki_dec_per_s_q16: 40 << 16,
        ki_inc_per_s_q16: 20 << 16,
        normalise: true,
        fixed_scale_q16: 6_554,
        feed_min: Rate::lit("0.01"),
        feed_max: Rate::ONE,
        feed_air: Rate::ONE,
        contact: ContactStrategy::Direct,
        min_spindle_mrev_s: 2_000,
    }
}

/// The chain setup: 3 channels, 12-bit ADC, 9.77 N per count, zero guessed at mid-scale.
pub fn chain_config() -> ChainConfig {
    let cal = ChannelCal { zero_counts: 2048, mn_per_count_q16: 9_770 << 16 };
    ChainConfig {
        channels: 3,
        cal: [cal; MAX_CHANNELS],
        adc_max_counts: 4095,
        rail_margin_counts: 2,
        saturated_samples: 3,
        stuck_samples: 200,
        tare_shift: 6,
        coeffs: BiquadCoeffs::BUTTERWORTH_FS_OVER_20,
        teeth: 4,
        control_hz: CONTROL_HZ,
        nominal_spindle_mrev_s: SPINDLE_MREV_S,
    }
}

/// The plant setup of Case A (eq 4.17, a = 20 mm, b 2.5 -> 10 mm at 10 mm, tau = 30 ms).
pub fn plant_params() -> PlantParams {
    PlantParams {
        // K a of eq 4.17: 205 N/mm^3 x 20 mm.
        kc_mn_per_mm2: 4_100_000,
        b_before_um: 2_500,
        b_after_um: 10_000,
        step_at_um: 10_000,
        wall_steps: WALL_STEPS,
        nm_per_step: 1000,
        sample_hz: SAMPLE_HZ,
        teeth: 4,
        spindle_mrev_s: SPINDLE_MREV_S,
        periodic: false,
    }
}

/// A milling job's setup for the closed loop: the control law (nominal force, thresholds,
/// gains, the feed at override 1.0), the force chain (teeth, nominal spindle speed), the cut
/// (cutting constant, depths, spindle speed) and the move (from the start, [`WALL_STEPS`] before
/// the wall, to its end).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MillingSetup {
    pub control: ControlParams,
    pub chain: ChainConfig,
    pub plant: PlantParams,
    /// Length of the move, steps (> 0).
    pub move_steps: i32,
    /// The run stops after this many ticks of machine time whatever happens.
    pub max_ticks: u64,
}

impl MillingSetup {
    /// Case A (trip 18 kN).
    pub fn case_a() -> Self {
        MillingSetup {
            control: control_params(18_000_000),
            chain: chain_config(),
            plant: plant_params(),
            move_steps: MOVE_STEPS,
            max_ticks: MAX_TICKS,
        }
    }

    /// The job's move.
    pub fn segment(&self) -> Segment {
        segment_for(self.move_steps, self.control.steps_per_s_at_one)
    }
}

/// Figures gathered while running.
#[derive(Clone, Copy, Debug, Default)]
struct Stats {
    peak_mn: u32,
    /// Highest force before the depth step: the impact of entering the cut.
    contact_peak_mn: u32,
    step_tick: Option<u64>,
    force_before_step_mn: u32,
    x_100ms_before_step: i64,
    x_at_step: i64,
    x_at_300ms: i64,
    x_at_400ms: i64,
    last_outside_tick: u64,
    min_after_step_mn: u32,
    late_max_mn: u32,
    late_min_mn: u32,
    fault_tick: u64,
    fault_x: i64,
    held_tick: u64,
    after_hold: u32,
    control_updates: u64,
}

/// See the module docs.
pub struct MillingScenario {
    variant: Variant,
    dda: Dda,
    plant: MillingPlant,
    adc: SimAdc,
    chain: ForceChain,
    ctl: ForceController,
    x_steps: i64,
    sub: u32,
    spindle_mrev_s: u32,
    air: bool,
    ovr_bits: u32,
    fault: Option<FaultCode>,
    hash: TraceHash,
    ticks: u64,
    done: bool,
    /// x at each control update of the last 100 ms (for the feed before the step).
    x_hist: [i64; 256],
    hist_at: u8,
    s: Stats,
    /// (tick, force, override, X) at the latest control update.
    last: (u64, u32, u32, i64),
    /// The job's nominal force (the settling band is +-10 % of it), mN.
    fnom_mn: u32,
    max_ticks: u64,
}

/// A scenario setup failed (a bug in the constants above; tests build every variant).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SetupError;

impl MillingScenario {
    pub fn new(variant: Variant) -> Result<Self, SetupError> {
        let trip = if variant == Variant::AboveTrip { 12_000_000 } else { 18_000_000 };
        let mut params = control_params(trip);
        params.contact = match variant {
            // The thesis's settings (digest section 2): A creeps at 1 % of the 30 ipm rapid
            // (0.3 ipm) for 100 ms; B stops 40 ms, then runs 100 ms at a third of the gain.
            Variant::ImpactA => ContactStrategy::SlowHold { slow: Rate::lit("0.01"), hold_ms: 100 },
            Variant::ImpactB => ContactStrategy::StopReduced {
                stop_ms: 40,
                reduced_ms: 100,
                reduced_gain_q16: (1 << 16) / 3,
            },
            _ => params.contact,
        };
        let plant = if variant.is_impact() {
            PlantParams { b_before_um: 10_000, ..plant_params() }
        } else {
            plant_params()
        };
        let setup = MillingSetup { control: params, plant, ..MillingSetup::case_a() };
        Self::with_setup(variant, &setup)
    }

    /// The Case A run on a milling job's setup.
    pub fn custom(setup: &MillingSetup) -> Result<Self, SetupError> {
        Self::with_setup(Variant::CaseA, setup)
    }

    fn with_setup(variant: Variant, setup: &MillingSetup) -> Result<Self, SetupError> {
        let cfg = machine();
        let mut dda = Dda::new(&cfg).map_err(|_| SetupError)?;
        let mut prep = Preparer::new(&cfg).map_err(|_| SetupError)?;
        let p = prep.prepare(&setup.segment()).map_err(|_| SetupError)?;
        dda.push(&p).map_err(|_| SetupError)?;
        Ok(MillingScenario {
            variant,
            dda,
            plant: MillingPlant::new(setup.plant).map_err(|_| SetupError)?,
            // True zeros off the calibration's guess; force along (0.48, 0.64, 0.60).
            adc: SimAdc::new([2085, 2036, 2053], [31_457, 41_943, 39_322], 9_770),
            chain: ForceChain::new(setup.chain).map_err(|_| SetupError)?,
            ctl: ForceController::new(setup.control).map_err(|_| SetupError)?,
            x_steps: 0,
            sub: 0,
            spindle_mrev_s: setup.plant.spindle_mrev_s,
            air: true,
            ovr_bits: u32::MAX,
            fault: None,
            hash: TraceHash::new(),
            ticks: 0,
            done: false,
            x_hist: [0; 256],
            hist_at: 0,
            s: Stats { late_min_mn: u32::MAX, min_after_step_mn: u32::MAX, ..Stats::default() },
            last: (0, 0, 0, 0),
            fnom_mn: setup.control.fnom_mn,
            max_ticks: setup.max_ticks,
        })
    }

    /// The latest control update: (tick, force mN, override Q30, X steps), and how many updates
    /// there were. A host loop polls it after every tick to record a trace.
    pub fn last_update(&self) -> (u64, (u64, u32, u32, i64)) {
        (self.s.control_updates, self.last)
    }

    /// The DDA (for the tests' position checks).
    pub fn dda(&self) -> &Dda {
        &self.dda
    }

    /// Steps that reached the X pins, signed.
    pub fn steps_emitted(&self) -> i64 {
        self.x_steps
    }

    fn inject(&mut self) {
        match self.variant {
            Variant::SaturatedChannel => self.adc.fault = AdcFault::Saturated(1),
            Variant::StuckChannel => self.adc.fault = AdcFault::Stuck(0),
            Variant::SpindleStop => self.spindle_mrev_s = 0,
            _ => {}
        }
    }

    fn stats(&mut self, force_mn: u32) {
        let t = self.ticks;
        let s = &mut self.s;
        s.peak_mn = s.peak_mn.max(force_mn);
        let pen = self.x_steps - WALL_STEPS;
        let Some(step) = s.step_tick else {
            if pen >= self.plant.step_at_steps() {
                s.step_tick = Some(t);
                s.x_at_step = self.x_steps;
                let back = self.hist_at.wrapping_sub(200);
                s.x_100ms_before_step = self.x_hist[back as usize];
            } else {
                s.force_before_step_mn = force_mn;
                s.contact_peak_mn = s.contact_peak_mn.max(force_mn);
            }
            return;
        };
        let since = t - step;
        if since > WINDOW_TICKS {
            return;
        }
        let band = self.fnom_mn / 10;
        let outside = force_mn.abs_diff(self.fnom_mn) > band;
        if outside {
            s.last_outside_tick = t;
        }
        s.min_after_step_mn = s.min_after_step_mn.min(force_mn);
        if since >= WINDOW_TICKS / 2 {
            s.late_max_mn = s.late_max_mn.max(force_mn);
            s.late_min_mn = s.late_min_mn.min(force_mn);
        }
        if since == WINDOW_TICKS * 3 / 4 {
            s.x_at_300ms = self.x_steps;
        }
        if since == WINDOW_TICKS {
            s.x_at_400ms = self.x_steps;
        }
    }

    fn control(&mut self, out: ChainOutput) {
        let (force_mn, tooth_updates, chain_fault) = match out {
            ChainOutput::Pending => return,
            ChainOutput::Reading(r) => (r.magnitude_mn, r.tooth_updates, None),
            ChainOutput::Fault(code) => (0, 0, Some(code)),
        };
        self.s.control_updates += 1;
        self.hist_at = self.hist_at.wrapping_add(1);
        self.x_hist[self.hist_at as usize] = self.x_steps;
        let o = self.ctl.update(&ControlInput {
            force_mn,
            tooth_updates,
            position_steps: self.x_steps,
            spindle_mrev_s: self.spindle_mrev_s,
            chain_fault,
        });
        self.air = o.air;
        if o.hold && self.fault.is_none() {
            self.fault = o.fault;
            self.hash.u32(o.fault.map_or(0, |f| f.code() as u32));
            self.s.fault_tick = self.ticks;
            self.s.fault_x = self.x_steps;
            self.dda.apply(Command::Hold);
        } else if !o.hold && o.feed.to_bits() != self.ovr_bits {
            self.dda.apply(Command::CapabilityOverride(o.feed));
        }
        self.ovr_bits = o.feed.to_bits();
        self.last = (self.ticks, force_mn, self.ovr_bits, self.x_steps);
    }
}

impl Scenario for MillingScenario {
    fn name(&self) -> &'static str {
        self.variant.name()
    }

    fn tick_hz(&self) -> u32 {
        TICK_HZ
    }

    fn tick(&mut self) -> bool {
        if self.done {
            return false;
        }
        self.ticks += 1;
        let out = self.dda.tick();
        if out.rise() & 1 != 0 {
            self.x_steps += if out.dir() & 1 != 0 { -1 } else { 1 };
        }
        self.sub += 1;
        if self.sub == TICKS_PER_SAMPLE {
            self.sub = 0;
            if !self.variant.is_case_a() && self.x_steps - WALL_STEPS >= FAULT_AT_PEN {
                self.inject();
            }
            let force_mn = self.plant.sample(self.x_steps);
            self.stats(force_mn);
            let counts = self.adc.convert(force_mn);
            let out = self.chain.sample(&counts, self.spindle_mrev_s, self.air);
            self.control(out);
            self.hash.u64(self.ticks);
            self.hash.u32(force_mn);
            self.hash.u32(self.ovr_bits);
        }
        let held = self.dda.state() == MotionState::Held;
        if held {
            if self.s.held_tick == 0 {
                self.s.held_tick = self.ticks;
            }
            self.s.after_hold += 1;
        }
        let window_over = self.s.step_tick.is_some_and(|t| self.ticks > t + WINDOW_TICKS);
        self.done = self.dda.is_idle()
            || self.ticks >= self.max_ticks
            || self.s.after_hold >= AFTER_HOLD_TICKS
            || (self.variant.is_case_a() && window_over);
        true
    }

    fn report(&self) -> ScenarioReport {
        let fault = self.fault.map_or(0, FaultCode::code);
        let mut r = ScenarioReport::new(self.name(), self.ticks, self.hash.value(), fault);
        let s = &self.s;
        let us_per_tick = 1_000_000 / TICK_HZ as i64;
        let pos = self.dda.positions()[0];
        r.push("fnom_mn", self.fnom_mn as i64);
        r.push("peak_force_mn", s.peak_mn as i64);
        r.push("force_before_step_mn", s.force_before_step_mn as i64);
        r.push("contact_peak_mn", s.contact_peak_mn as i64);
        if s.step_tick.is_some() {
            r.push("feed_before_step_um_s", (s.x_at_step - s.x_100ms_before_step) * 10);
        }
        if s.x_at_400ms != 0 {
            r.push("feed_after_step_um_s", (s.x_at_400ms - s.x_at_300ms) * 10);
        }
        if let Some(step) = s.step_tick {
            let settle = s.last_outside_tick.saturating_sub(step) as i64 * us_per_tick;
            r.push("settle_us", settle);
        }
        if s.step_tick.is_some() {
            // The force comes down from 4x Fnom: its overshoot is how far it dips below Fnom.
            r.push("overshoot_below_fnom_mn", self.fnom_mn as i64 - s.min_after_step_mn as i64);
        }
        if s.late_max_mn >= s.late_min_mn {
            r.push("late_ripple_mn", (s.late_max_mn - s.late_min_mn) as i64);
        }
        r.push("steps_emitted", self.x_steps);
        r.push("dda_position_steps", pos);
        r.push("lost_steps", (pos - self.x_steps).abs());
        r.push("deferred_steps", self.dda.deferred_steps() as i64);
        r.push("control_updates", s.control_updates as i64);
        r.push("final_override_q30", self.ovr_bits as i64);
        if self.fault.is_some() {
            r.push("fault_position_steps", s.fault_x);
            r.push("stop_distance_um", self.x_steps - s.fault_x);
            r.push("stop_time_us", s.held_tick.saturating_sub(s.fault_tick) as i64 * us_per_tick);
            r.push("held", (self.dda.state() == MotionState::Held) as i64);
        }
        r
    }
}

#[cfg(test)]
mod impact_tests {
    use super::*;
    use crate::scenario::run_to_end;

    fn contact_peak(v: Variant) -> (i64, u8) {
        let mut s = MillingScenario::new(v).unwrap();
        let r = run_to_end(&mut s, MAX_TICKS + 1);
        (r.figure("contact_peak_mn").unwrap(), r.fault)
    }

    /// Entering a full-depth cut: both impact strategies keep the peak at or below the direct
    /// entry's, with no fault. The stepper cannot stop faster than its acceleration allows
    /// (161 um from 12.7 mm/s), and that sets most of the peak: the strategies trim it by a few
    /// per cent, they cannot remove it.
    #[test]
    fn impact_strategies_do_not_raise_the_entry_peak() {
        let (direct, f0) = contact_peak(Variant::ImpactDirect);
        let (a, fa) = contact_peak(Variant::ImpactA);
        let (b, fb) = contact_peak(Variant::ImpactB);
        assert_eq!((f0, fa, fb), (0, 0, 0));
        assert!(a <= direct && b <= direct, "direct {direct}, A {a}, B {b}");
        assert!(direct < 18_000_000, "below the trip level");
    }
}
