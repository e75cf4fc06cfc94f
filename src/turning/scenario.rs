//! Closed-loop Z-slide scenario: a simulated spindle at 360 rpm (a 20 % step to 432 rpm half way,
//! as a 10 ms ramp) drives the encoder or the resolver source; X feeds 0 -> 7.5 in in 2.5 s of
//! machine time (compressed: the thesis fed 0.03 in/min); the Z command from the checked-in
//! Douglass table is updated every tick at 50 kHz and tracked by the ideal stepper axis (10 uin
//! steps, one step per tick at most) and by the voice-coil slide of Ch. 4 (motor 1) three ways:
//! its digital servo with the command's velocity/acceleration feedforward, and driven by
//! position alone through the 12-bit DAC (an analog servo: no feedforward input), with and
//! without the command-side lead ([`CommandLead`]). The disengage blends from X = 7.2 in to the
//! end of the feed at 7.5 in.
//!
//! Latency: the command is advanced by one tick (the stepper reaches its target at the end of
//! the tick); the voice-coil servo tracks its target at the gage sample itself (zero latency,
//! the feedforward covers its dynamics), so it takes the command shifted back by a tick
//! ([`ZUpdate::shifted`]). Every following error is the surface error: the command for the end
//! of the tick against the slide there.
//!
//! Figures (units in the names; `_nin` = nanoinches): updates, max following error of each plant
//! while following the table, the feedforward voice coil's split by phase (engage, steady,
//! speed step, disengage blend) and where its max is (tick, X, spindle angle), Z command
//! peak-to-peak, final spindle speed. The trace hash covers the per-tick Z command. Variant
//! `IndexLoss`: the encoder's index pulse stops after 5 revolutions; the encoder latches
//! `EncoderIndex` one revolution later and the generator freezes the command (fault 13 in the
//! report).

use super::command::{ZCommand, ZCommandConfig, ZState, ZUpdate};
use super::douglass_table::{DOUGLASS_POWER, DOUGLASS_ROWS};
use super::output::{CommandLead, DacScale, StepFollower, StepScale};
use super::plant::{VoiceCoilMotor, VoiceCoilServo, VoiceCoilSlide};
use super::table::Interp;
use crate::scenario::{Scenario, ScenarioReport, TraceHash};
use crate::spindle::{
    speed_turn_q32_per_tick, EncoderConfig, QuadratureEncoder, Resolver, ResolverConfig,
    SimSpindle, SpindleSource,
};

/// Tick rate of the scenario (and Z update rate), Hz.
pub const TICK_HZ: u32 = 50_000;
pub const CPR: u32 = 40_000;
pub const RUN_TICKS: u32 = 3 * TICK_HZ;
pub const ENGAGE_TICK: u32 = TICK_HZ / 5;
const STEP_TICK: u32 = TICK_HZ * 3 / 2;
const RAMP_TICKS: u32 = TICK_HZ / 100;
pub const FEED_TICKS: u32 = TICK_HZ * 5 / 2;
pub const X_END_IN_Q24: i32 = 15 << 23; // 7.5 in
const X_BLEND_IN_Q24: i32 = (72 << 24) / 10; // 7.2 in
/// The stepper reaches its target at the end of the tick: the command's advance.
pub const STEPPER_LATENCY_TICKS_Q16: u32 = 1 << 16;
/// The feedforward voice-coil servo tracks its target at the gage sample: no latency.
pub const VOICE_COIL_LATENCY_TICKS_Q16: u32 = 0;
/// Ticks after the engage ramp, and after the speed ramp, counted as transient (the encoder's
/// speed window is 256 ticks; the servo settles in a few ms).
const SETTLE_TICKS: u32 = TICK_HZ / 50;
/// DAC scale of the position-only paths: +-0.010 in over the 12 bits (the thesis's gage range).
const DAC_CODES_PER_IN: u32 = 204_800;

/// Parts of the run the voice coil's following error is split into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Engage = 0,
    Steady = 1,
    SpeedStep = 2,
    Blend = 3,
}
/// Which spindle source drives the command, and whether the index fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TurningVariant {
    Encoder,
    Resolver,
    IndexLoss,
}

/// The scenario state.
pub struct TurningScenario {
    variant: TurningVariant,
    sim: SimSpindle,
    encoder: QuadratureEncoder,
    resolver: Resolver,
    seed: u32,
    command: ZCommand<'static, DOUGLASS_ROWS, 4>,
    steps: StepScale,
    stepper: StepFollower,
    voice_coil: VoiceCoilSlide,
    dac: DacScale,
    lead: CommandLead,
    voice_coil_dac: VoiceCoilSlide,
    voice_coil_dac_lead: VoiceCoilSlide,
    tick: u32,
    x_in_q24: i32,
    x_step_in_q24: i32,
    hash: TraceHash,
    fault: u8,
    max_fe_stepper_nin: i64,
    max_fe_voice_coil_nin: i64,
    /// Per [`Phase`].
    max_fe_phase_nin: [i64; 4],
    /// Where the max is: tick, X (inches Q24), spindle angle (true, turn Q32).
    max_fe_at: (u32, i32, u32),
    max_fe_dac_nin: i64,
    max_fe_dac_lead_nin: i64,
    z_min: i32,
    z_max: i32,
    speed_turn_q32_per_tick: i32,
    /// The engage (`ZCommand::start`) has run.
    engaged: bool,
}

const fn speed(rpm: u64) -> i32 {
    speed_turn_q32_per_tick(rpm * 1000, TICK_HZ)
}

/// The scenario's spindle encoder (also used by the benchmarks).
pub const fn encoder_config() -> EncoderConfig {
    EncoderConfig {
        counts_per_rev: CPR,
        index_tolerance_counts: 0,
        window_log2: 8,
        stop_counts_per_window: 16,
    }
}

/// The scenario's resolver (also used by the benchmarks).
pub const fn resolver_config() -> ResolverConfig {
    ResolverConfig {
        tick_hz: TICK_HZ,
        amplitude_lsb: 1800,
        amplitude_min_lsb: 1200,
        amplitude_max_lsb: 2300,
        loss_ticks: 4,
        bandwidth_hz: 100,
        stop_speed_turn_q32_per_tick: 1000,
    }
}

/// The scenario's Z command setup (also used by the benchmarks).
pub const fn command_config() -> ZCommandConfig {
    ZCommandConfig {
        tick_hz: TICK_HZ,
        interp: Interp::Cubic,
        advance_ticks_q16: STEPPER_LATENCY_TICKS_Q16,
        engage_ticks: TICK_HZ / 20,
        blend_start_x_in_q24: X_BLEND_IN_Q24,
        blend_end_x_in_q24: X_END_IN_Q24,
        max_velocity_uin_per_s: 500_000,
        max_accel_uin_per_s2: 100_000_000,
        min_speed_turn_q32_per_tick: speed(60) as u32,
    }
}

/// Spindle speed at `rpm`, in the source's unit at the scenario's tick rate.
pub const fn speed_at_rpm(rpm: u64) -> i32 {
    speed(rpm)
}

impl TurningScenario {
    pub fn new(variant: TurningVariant) -> Self {
        let sim = SimSpindle::new(0x4000_0000);
        let (enc_cfg, res_cfg, cfg) = (encoder_config(), resolver_config(), command_config());
        // Constants known valid: the fallbacks are never taken (checked by the tests).
        let encoder = match QuadratureEncoder::new(enc_cfg, sim.encoder(CPR).0) {
            Ok(e) => e,
            Err(_) => unreachable!(),
        };
        let resolver = match Resolver::new(res_cfg) {
            Ok(r) => r,
            Err(_) => unreachable!(),
        };
        let command = match ZCommand::new(&DOUGLASS_POWER, cfg, 0) {
            Ok(c) => c,
            Err(_) => unreachable!(),
        };
        let steps = match StepScale::new(100_000) {
            Some(s) => s,
            None => unreachable!(),
        };
        let dac = match DacScale::new(DAC_CODES_PER_IN, 2048) {
            Some(d) => d,
            None => unreachable!(),
        };
        let (servo, motor) = (VoiceCoilServo::default(), VoiceCoilMotor::MOTOR_1);
        let (b1_s, b2_s2) = servo.closed_loop_b1_b2();
        let lead = CommandLead::for_loop(b1_s, b2_s2, TICK_HZ).unwrap_or(CommandLead::NONE);
        Self {
            variant,
            sim,
            encoder,
            resolver,
            seed: 12345,
            command,
            steps,
            stepper: StepFollower::new(0),
            voice_coil: VoiceCoilSlide::new(motor, servo, TICK_HZ, 0),
            dac,
            lead,
            voice_coil_dac: VoiceCoilSlide::new(motor, servo, TICK_HZ, 0),
            voice_coil_dac_lead: VoiceCoilSlide::new(motor, servo, TICK_HZ, 0),
            tick: 0,
            x_in_q24: 0,
            x_step_in_q24: X_END_IN_Q24 / FEED_TICKS as i32,
            hash: TraceHash::new(),
            fault: 0,
            max_fe_stepper_nin: 0,
            max_fe_voice_coil_nin: 0,
            max_fe_phase_nin: [0; 4],
            max_fe_at: (0, 0, 0),
            max_fe_dac_nin: 0,
            max_fe_dac_lead_nin: 0,
            z_min: 0,
            z_max: 0,
            speed_turn_q32_per_tick: 0,
            engaged: false,
        }
    }

    fn spindle_speed(&self) -> u32 {
        spindle_speed_at(self.tick)
    }

    /// The Z command of the last tick (inches Q32): the trace the hash covers.
    pub fn command_z_in_q32(&self) -> i32 {
        self.command.last().z_in_q32
    }
}

/// The scenario's spindle speed profile at `tick`: 360 rpm, a 10 ms ramp to 432 rpm at
/// `STEP_TICK` (turn Q32 per tick; also drives the link-job test's sim spindle).
pub fn spindle_speed_at(tick: u32) -> u32 {
    {
        let (v0, v1) = (speed(360) as i64, speed(432) as i64);
        let t = tick;
        let v = if t < STEP_TICK {
            v0
        } else if t < STEP_TICK + RAMP_TICKS {
            // Scenario-profile interpolation, by a reciprocal: no division in the tick.
            const INV_RAMP_Q32: i64 = (1 << 32) / RAMP_TICKS as i64;
            v0 + (((v1 - v0) * (t - STEP_TICK) as i64 * INV_RAMP_Q32) >> 32)
        } else {
            v1
        };
        v as u32
    }
}

impl TurningScenario {
    fn phase(&self) -> Phase {
        let t = self.tick;
        if self.x_in_q24 >= X_BLEND_IN_Q24 {
            Phase::Blend
        } else if t < ENGAGE_TICK + command_config().engage_ticks + SETTLE_TICKS {
            Phase::Engage
        } else if (STEP_TICK..STEP_TICK + RAMP_TICKS + SETTLE_TICKS).contains(&t) {
            Phase::SpeedStep
        } else {
            Phase::Steady
        }
    }

    /// A position-only slide: the (led) command through the DAC; a code out of range latches
    /// `ZSlideLimit` and holds the slide.
    fn dac_tick(&mut self, u: &ZUpdate, led: bool) -> i64 {
        let z = if led { self.lead.apply(u) } else { u.z_in_q32 };
        let slide = if led { &mut self.voice_coil_dac_lead } else { &mut self.voice_coil_dac };
        match self.dac.code(z) {
            Ok(code) => slide.tick(self.dac.z_in_q32(code) as i32, 0, 0),
            Err(f) => {
                self.fault = f.code();
                let hold = slide.z_in_q32() as i32;
                slide.tick(hold, 0, 0);
            }
        }
        slide.z_in_q32()
    }
}

/// Inches Q32 to nanoinches (reports).
fn nin(z_in_q32: i64) -> i64 {
    (z_in_q32 * 1_000_000_000) >> 32
}

impl Scenario for TurningScenario {
    fn name(&self) -> &'static str {
        match self.variant {
            TurningVariant::Encoder => "turning_encoder",
            TurningVariant::Resolver => "turning_resolver",
            TurningVariant::IndexLoss => "turning_index_loss",
        }
    }

    fn tick_hz(&self) -> u32 {
        TICK_HZ
    }

    /// The engage check divides (limits at this speed, ramp slope): planning-rate work, run
    /// before the engage tick from the last tick's sensor readings.
    fn wants_background(&self) -> bool {
        self.tick == ENGAGE_TICK && !self.engaged
    }

    fn background(&mut self) {
        self.engaged = true;
        let z_now = self.voice_coil.z_in_q32() as i32;
        if let Err(f) = self.command.start(self.x_in_q24, self.speed_turn_q32_per_tick, z_now) {
            self.fault = f.code();
        }
    }

    fn tick(&mut self) -> bool {
        if self.tick >= RUN_TICKS {
            return false;
        }
        // Sensors.
        self.sim.advance(self.spindle_speed());
        let src: &dyn SpindleSource = match self.variant {
            TurningVariant::Resolver => {
                let (s, c) = self.sim.resolver(1800, 2, &mut self.seed);
                self.resolver.update(s, c);
                &self.resolver
            }
            TurningVariant::Encoder | TurningVariant::IndexLoss => {
                let (c, i) = self.sim.encoder(CPR);
                let lost = self.variant == TurningVariant::IndexLoss && self.sim.turns() > 5;
                self.encoder.update(c, if lost { None } else { i });
                &self.encoder
            }
        };
        let (angle, speed_now, fault) =
            (src.angle_turn_q32(), src.speed_turn_q32_per_tick(), src.fault());
        self.speed_turn_q32_per_tick = speed_now;
        // Control (the engage itself ran in `background`).
        if self.command.state() == ZState::Running && self.x_in_q24 < X_END_IN_Q24 {
            self.x_in_q24 = (self.x_in_q24 + self.x_step_in_q24).min(X_END_IN_Q24);
        }
        let u = self.command.update(self.x_in_q24, angle, speed_now, fault);
        if let Some(f) = self.command.fault_code() {
            self.fault = f.code();
        }
        // Plants.
        self.stepper.tick(self.steps.target_steps(u.z_in_q32));
        // The command is for the end of this tick (the stepper's latency); the voice coil's
        // servo wants it for now.
        const SHIFT: i32 = VOICE_COIL_LATENCY_TICKS_Q16 as i32 - STEPPER_LATENCY_TICKS_Q16 as i32;
        let uv = u.shifted(SHIFT);
        self.voice_coil.tick(uv.z_in_q32, uv.v_in_q48_per_tick, uv.a_in_q48_per_tick2);
        let z_dac = self.dac_tick(&uv, false);
        let z_dac_lead = self.dac_tick(&uv, true);
        if self.command.state() == ZState::Running {
            let z = u.z_in_q32 as i64;
            let fe_s = (z - self.steps.z_in_q32(self.stepper.position_steps())).abs();
            let fe_v = nin((z - self.voice_coil.z_in_q32()).abs());
            self.max_fe_stepper_nin = self.max_fe_stepper_nin.max(nin(fe_s));
            if fe_v > self.max_fe_voice_coil_nin {
                self.max_fe_voice_coil_nin = fe_v;
                self.max_fe_at = (self.tick, self.x_in_q24, self.sim.angle_turn_q32());
            }
            let ph = self.phase() as usize;
            if let Some(m) = self.max_fe_phase_nin.get_mut(ph) {
                *m = (*m).max(fe_v);
            }
            self.max_fe_dac_nin = self.max_fe_dac_nin.max(nin((z - z_dac).abs()));
            self.max_fe_dac_lead_nin = self.max_fe_dac_lead_nin.max(nin((z - z_dac_lead).abs()));
        }
        self.z_min = self.z_min.min(u.z_in_q32);
        self.z_max = self.z_max.max(u.z_in_q32);
        self.hash.i32(u.z_in_q32);
        self.tick += 1;
        true
    }

    fn report(&self) -> ScenarioReport {
        let mut r =
            ScenarioReport::new(self.name(), self.tick as u64, self.hash.value(), self.fault);
        r.push("updates", self.command.updates() as i64);
        r.push("max_fe_stepper_nin", self.max_fe_stepper_nin);
        r.push("max_fe_voice_coil_nin", self.max_fe_voice_coil_nin);
        let [engage, steady, speed_step, blend] = self.max_fe_phase_nin;
        r.push("max_fe_voice_coil_engage_nin", engage);
        r.push("max_fe_voice_coil_steady_nin", steady);
        r.push("max_fe_voice_coil_speed_step_nin", speed_step);
        r.push("max_fe_voice_coil_blend_nin", blend);
        let (tick, x, phi) = self.max_fe_at;
        r.push("max_fe_voice_coil_tick", tick as i64);
        r.push("max_fe_voice_coil_x_uin", (x as i64 * 1_000_000) >> 24);
        r.push("max_fe_voice_coil_phi_mdeg", (phi as i64 * 360_000) >> 32);
        r.push("max_fe_dac_nin", self.max_fe_dac_nin);
        r.push("max_fe_dac_lead_nin", self.max_fe_dac_lead_nin);
        r.push("z_pp_nin", nin(self.z_max as i64 - self.z_min as i64));
        r.push("x_final_uin", (self.x_in_q24 as i64 * 1_000_000) >> 24);
        r.push("voice_coil_z_final_nin", nin(self.voice_coil.z_in_q32()));
        r.push("stepper_steps_final", self.stepper.position_steps() as i64);
        r.push(
            "spindle_rpm_milli",
            crate::spindle::rpm_milli(self.speed_turn_q32_per_tick, TICK_HZ),
        );
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::run_to_end;

    fn run(v: TurningVariant) -> ScenarioReport {
        let mut s = TurningScenario::new(v);
        let r = run_to_end(&mut s, u64::MAX);
        let mut out = String::new();
        r.write_lines(|l| {
            out.push_str(l);
            out.push('\n')
        });
        eprint!("{out}");
        r
    }

    #[test]
    fn encoder_and_resolver_runs_track() {
        for v in [TurningVariant::Encoder, TurningVariant::Resolver] {
            let r = run(v);
            assert_eq!(r.fault, 0, "{v:?}");
            assert_eq!(r.ticks, RUN_TICKS as u64);
            assert_eq!(r.figure("updates"), Some(RUN_TICKS as i64));
            // X fed to 7.5 in and the disengage blend brought Z back to rest (0) smoothly.
            assert_eq!(r.figure("x_final_uin"), Some(7_500_000));
            assert!(r.figure("voice_coil_z_final_nin").unwrap().abs() < 100);
            assert_eq!(r.figure("stepper_steps_final"), Some(0));
            // The source measured the 20 % step: 432 rpm at the end.
            assert!((r.figure("spindle_rpm_milli").unwrap() - 432_000).abs() < 1_000);
            // Stepper: 10 uin steps -> at most half a step of rounding plus one tick of lag at
            // up to 0.33 in/s (6.6 uin): under 12 uin.
            let fe_s = r.figure("max_fe_stepper_nin").unwrap();
            assert!(fe_s < 12_000, "{v:?} stepper {fe_s}");
            // Voice coil with the full feedforward (angle, X feed, blend) at its own latency:
            // the max is the 20 % speed step (no spindle-acceleration term, the speed estimate
            // lags), under 4 uin; steady state and the blends under 2 uin (angle quantisation
            // of the source). Before the blend terms it was 42.7 uin in the disengage.
            let fe_v = r.figure("max_fe_voice_coil_nin").unwrap();
            assert!(fe_v < 4_000, "{v:?} voice coil {fe_v}");
            for name in [
                "max_fe_voice_coil_engage_nin",
                "max_fe_voice_coil_steady_nin",
                "max_fe_voice_coil_blend_nin",
            ] {
                let f = r.figure(name).unwrap();
                assert!(f < 2_000, "{v:?} {name} {f}");
            }
            // Position only through the DAC: without the lead the servo's closed loop lags by
            // b1 v = 1.02 ms x 0.27 in/s (the thesis's loop, b1 = 1.91 ms, predicts +-390 uin
            // at X = 7 in, digest I); with it, within the DAC's half code (2.44 uin) plus the
            // feedforward servo's residual.
            let dac = r.figure("max_fe_dac_nin").unwrap();
            assert!(dac > 150_000 && dac < 400_000, "{v:?} dac {dac}");
            let dac_lead = r.figure("max_fe_dac_lead_nin").unwrap();
            assert!(dac_lead < 2_440 + fe_v, "{v:?} dac lead {dac_lead}");
            // The command spans most of the 7.8 mil of X = 7.2..7.5 in.
            let pp = r.figure("z_pp_nin").unwrap();
            assert!(pp > 6_000_000 && pp < 7_800_000, "{pp}");
        }
    }

    #[test]
    fn index_loss_faults_and_freezes() {
        let r = run(TurningVariant::IndexLoss);
        assert_eq!(r.fault, crate::protocol::errors::FaultCode::EncoderIndex.code());
    }

    #[test]
    fn every_figure_fits() {
        let r = TurningScenario::new(TurningVariant::Encoder).report();
        assert_eq!(r.figures.len(), 17);
    }
}
