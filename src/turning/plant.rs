//! Z-slide plants for simulation (no_std, fixed point): the voice-coil slide of Douglass Ch. 4,
//! eq 4-11 (`M s^2 Z + B s Z = Kf Im`, `Im = (Em - Kb s Z) / (R + L s)`, B = 0) with the measured
//! constants of motor 1 (Kf = 4.0 lbf/A, Kb = 5.52 V s/ft, M = 0.194 slug, R = 3.2 ohm,
//! tau_e = L/R = 0.26 ms), integrated once per tick (semi-implicit Euler), and a servo for it:
//! acceleration and velocity feedforward from the Z command plus PD position feedback (from a
//! gage quantised to 2^-30 in, about 1 nin) through a proportional current loop. The ideal
//! stepper axis is [`super::output::StepFollower`].
//!
//! States: `z` inches Q48, `v` inches Q48 per tick, `i` nanoamps, voltage in microvolts. The
//! multipliers are computed once from the physical constants (setup-time f64, IEEE-exact on host
//! and target); the per-tick path is integer only.

/// Physical constants of a voice-coil slide (eq 4-11), in the thesis's units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoiceCoilMotor {
    pub kf_lbf_per_a: f64,
    pub kb_v_s_per_ft: f64,
    pub mass_slug: f64,
    pub resistance_ohm: f64,
    pub tau_e_s: f64,
}

impl VoiceCoilMotor {
    /// Motor 1 (digest section 1, seed l.956-960).
    pub const MOTOR_1: Self = Self {
        kf_lbf_per_a: 4.0,
        kb_v_s_per_ft: 5.52,
        mass_slug: 0.194,
        resistance_ohm: 3.2,
        tau_e_s: 0.26e-3,
    };
    /// Inductance, H.
    pub fn inductance_h(&self) -> f64 {
        self.tau_e_s * self.resistance_ohm
    }
    /// Coefficients of eq 4-13, `s^2 + a1 s + a0` (the denominator of `Z s / Em` divided by
    /// `M L`): `a1 = R/L`, `a0 = Kf Kb / (M L)`.
    pub fn eq_4_13(&self) -> (f64, f64) {
        let l = self.inductance_h();
        (self.resistance_ohm / l, self.kf_lbf_per_a * self.kb_v_s_per_ft / (self.mass_slug * l))
    }
}

/// Servo gains and amplifier limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoiceCoilServo {
    /// Position loop natural frequency, Hz, and damping.
    pub position_hz: f64,
    pub damping: f64,
    /// Current loop proportional gain, ohm (V per A of current error).
    pub current_gain_ohm: f64,
    /// Amplifier output limit, V.
    pub max_voltage_v: f64,
}

impl VoiceCoilServo {
    /// The position loop's closed loop without feedforward, `1 / (1 + b1 s + b2 s^2)` with
    /// `b1 = 2 zeta / wn` (s), `b2 = 1 / wn^2` (s^2): what a position-only command (the DAC
    /// output) must lead by ([`super::output::CommandLead::for_loop`]).
    pub fn closed_loop_b1_b2(&self) -> (f64, f64) {
        let wn = 2.0 * core::f64::consts::PI * self.position_hz;
        (2.0 * self.damping / wn, 1.0 / (wn * wn))
    }
}

impl Default for VoiceCoilServo {
    fn default() -> Self {
        Self { position_hz: 250.0, damping: 0.8, current_gain_ohm: 20.0, max_voltage_v: 60.0 }
    }
}

/// The slide and its servo, stepped once per tick.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VoiceCoilSlide {
    // Plant multipliers (x * m >> 32 unless named otherwise).
    r_uv_per_na_q32: i64,
    kb_uv_per_q48_tick_q32: i64,
    di_na_per_uv_q24: i64,
    dv_q48_per_na_q32: i64,
    // Servo multipliers.
    kp_per_tick2_q32: i64,
    kd_per_tick_q32: i64,
    na_per_q48_tick2_q24: i64,
    kc_uv_per_na_q32: i64,
    max_uv: i64,
    // State.
    z_in_q48: i64,
    v_in_q48_per_tick: i64,
    i_na: i64,
    gage_prev_in_q30: i64,
    voltage_uv: i64,
}

fn q(v: f64, bits: u32) -> i64 {
    let s = v * (1u64 << bits) as f64;
    // Round half away from zero without libm.
    if s >= 0.0 {
        (s + 0.5) as i64
    } else {
        (s - 0.5) as i64
    }
}

impl VoiceCoilSlide {
    /// A slide at rest at `z_in_q32` for a `tick_hz` update rate (setup: f64 and division).
    pub fn new(motor: VoiceCoilMotor, servo: VoiceCoilServo, tick_hz: u32, z_in_q32: i32) -> Self {
        let dt = 1.0 / tick_hz as f64;
        let q48 = (1u64 << 48) as f64;
        let l = motor.inductance_h();
        let mass_lbf_s2_per_in = motor.mass_slug / 12.0;
        let kb_v_s_per_in = motor.kb_v_s_per_ft / 12.0;
        // Back EMF: Kb [V s/in] * v [in/s]; v_q48/tick -> in/s: * tick_hz / 2^48; V -> uV.
        let kb = kb_v_s_per_in * tick_hz as f64 / q48 * 1e6;
        // Current: di [A] = dt/L * u [V]; nA per uV = dt/L * 1e3.
        let di = dt / l * 1e3;
        // Velocity: dv [in/s] = dt Kf/M i [A]; in Q48 per tick: * dt * 2^48; per nA: * 1e-9.
        let dv = dt * dt * motor.kf_lbf_per_a / mass_lbf_s2_per_in * q48 * 1e-9;
        let wn = 2.0 * core::f64::consts::PI * servo.position_hz;
        Self {
            r_uv_per_na_q32: q(motor.resistance_ohm * 1e-3, 32),
            kb_uv_per_q48_tick_q32: q(kb, 32),
            di_na_per_uv_q24: q(di, 24),
            dv_q48_per_na_q32: q(dv, 32),
            kp_per_tick2_q32: q(wn * wn * dt * dt, 32),
            kd_per_tick_q32: q(2.0 * servo.damping * wn * dt, 32),
            na_per_q48_tick2_q24: q(1.0 / dv, 24),
            kc_uv_per_na_q32: q(servo.current_gain_ohm * 1e-3, 32),
            max_uv: q(servo.max_voltage_v.clamp(0.0, 1000.0) * 1e6, 0),
            z_in_q48: (z_in_q32 as i64) << 16,
            v_in_q48_per_tick: 0,
            i_na: 0,
            gage_prev_in_q30: (z_in_q32 as i64) >> 2,
            voltage_uv: 0,
        }
    }

    /// One tick: the servo reads the gage and the coil current, drives the amplifier toward the
    /// command (`z`, with the generator's velocity and acceleration as feedforward), and the
    /// plant integrates eq 4-11 over the tick. Bounded, no division; clamped operands so a wild
    /// command cannot overflow (the amplifier clamps at its voltage limit, as a real one).
    #[inline]
    pub fn tick(
        &mut self,
        z_cmd_in_q32: i32,
        v_ff_in_q48_per_tick: i64,
        a_ff_in_q48_per_tick2: i64,
    ) {
        // Plain 64-bit products (no i128: a libcall on the M4); the clamps below bound every
        // operand so no product can overflow (bounds in the comments, from the motor-1 scale).
        let m = |x: i64, k: i64, s: u32| -> i64 { (x * k) >> s };
        const ERR_MAX: i64 = 1 << 40; // 1/256 in of tracking error: the servo saturates there
        const V_MAX: i64 = 1 << 36; // about 12 in/s at 50 kHz
        const A_MAX: i64 = 1 << 26; // about 6000 in/s^2 at 50 kHz, 3x what 8 A gives
        const I_MAX: i64 = 1 << 35; // 34 A, beyond the amplifier's V/R
                                    // Servo: gage in Q30 inches (about 1 nin), velocity from its difference.
        let gage = self.z_in_q48 >> 18;
        let v_meas = ((gage - self.gage_prev_in_q30) << 18).clamp(-V_MAX, V_MAX);
        self.gage_prev_in_q30 = gage;
        let v_ff = v_ff_in_q48_per_tick.clamp(-V_MAX, V_MAX);
        let err = (((z_cmd_in_q32 as i64) << 16) - (gage << 18)).clamp(-ERR_MAX, ERR_MAX);
        let a_cmd = (a_ff_in_q48_per_tick2.clamp(-A_MAX, A_MAX)
            + m(err, self.kp_per_tick2_q32, 32)
            + m(v_ff - v_meas, self.kd_per_tick_q32, 32))
        .clamp(-A_MAX, A_MAX);
        let i_ref = m(a_cmd, self.na_per_q48_tick2_q24, 24).clamp(-I_MAX, I_MAX);
        let e = m(i_ref, self.r_uv_per_na_q32, 32)
            + m(v_ff, self.kb_uv_per_q48_tick_q32, 32)
            + m(i_ref - self.i_na, self.kc_uv_per_na_q32, 32);
        self.voltage_uv = e.clamp(-self.max_uv, self.max_uv);
        // Plant, semi-implicit Euler: current, then velocity, then position.
        let u = self.voltage_uv
            - m(self.i_na, self.r_uv_per_na_q32, 32)
            - m(self.v_in_q48_per_tick, self.kb_uv_per_q48_tick_q32, 32);
        self.i_na = (self.i_na + m(u, self.di_na_per_uv_q24, 24)).clamp(-I_MAX, I_MAX);
        self.v_in_q48_per_tick = (self.v_in_q48_per_tick
            + m(self.i_na, self.dv_q48_per_na_q32, 32))
        .clamp(-(V_MAX << 2), V_MAX << 2);
        self.z_in_q48 = self.z_in_q48.saturating_add(self.v_in_q48_per_tick);
    }

    /// Slide position, inches Q32.
    pub fn z_in_q32(&self) -> i64 {
        self.z_in_q48 >> 16
    }
    /// Coil current, nA.
    pub fn current_na(&self) -> i64 {
        self.i_na
    }
    /// Amplifier voltage, uV.
    pub fn voltage_uv(&self) -> i64 {
        self.voltage_uv
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motor_1_gives_eq_4_13() {
        // Thesis eq 4-13: s^2 + 3846 s + 136791 (roots -35.9, -3810).
        let (a1, a0) = VoiceCoilMotor::MOTOR_1.eq_4_13();
        eprintln!("eq 4-13 from motor 1: s^2 + {a1:.1} s + {a0:.1}");
        assert!((a1 - 3846.0).abs() < 1.0, "{a1}");
        assert!((a0 - 136_791.0).abs() / 136_791.0 < 1e-4, "{a0}");
        let disc = (a1 * a1 - 4.0 * a0).sqrt();
        let (r1, r2) = ((-a1 + disc) / 2.0, (-a1 - disc) / 2.0);
        assert!((r1 + 35.9).abs() < 0.1 && (r2 + 3810.0).abs() < 1.0, "{r1} {r2}");
    }

    #[test]
    fn open_loop_steady_speed_matches_back_emf() {
        // Fixed voltage, no servo: steady speed E/Kb (B = 0). Drive through the plant only by
        // forcing the servo's output: a huge constant command saturates the amplifier.
        let mut s = VoiceCoilSlide::new(
            VoiceCoilMotor::MOTOR_1,
            VoiceCoilServo { max_voltage_v: 0.5, ..VoiceCoilServo::default() },
            50_000,
            0,
        );
        // 0.24 s = 8.5 mechanical time constants (M R / (Kf Kb) = 28 ms); travel 0.26 in.
        for _ in 0..12_000 {
            s.tick(i32::MAX, 0, 0);
        }
        let v_in_s = s.v_in_q48_per_tick as f64 * 50_000.0 / (1u64 << 48) as f64;
        let expect = 1.0 / (5.52 / 12.0);
        let expect = expect * 0.5;
        eprintln!("0.5 V open loop: {v_in_s:.4} in/s (E/Kb = {expect:.4})");
        assert!((v_in_s - expect).abs() / expect < 1e-3);
    }

    #[test]
    fn tracks_a_sine_with_small_error() {
        // 4 mil half-amplitude at 6 Hz (360 rpm, X = 8 in is about this): feedforward from the
        // exact derivatives, the target for the gage sample of this tick (the servo's zero
        // latency), compared with the slide at the end of the tick against the sine there. The
        // thesis's loop (no feedforward, Kv ~ 4800/s) predicts +-390 uin here (digest section
        // 3 I). Comparing with the sine at the start of the tick instead would add v dt = 3.0
        // uin: the one-tick offset that a 1-tick command advance puts on this servo.
        let hz = 50_000.0;
        let mut s =
            VoiceCoilSlide::new(VoiceCoilMotor::MOTOR_1, VoiceCoilServo::default(), 50_000, 0);
        let w = 2.0 * std::f64::consts::PI * 6.0;
        let z_at = |k: u32| 0.004 * (w * k as f64 / hz).sin();
        let mut worst = 0.0f64;
        for k in 0..100_000 {
            let t = k as f64 / hz;
            let v = 0.004 * w * (w * t).cos() / hz * (1u64 << 48) as f64;
            let a = -0.004 * w * w * (w * t).sin() / (hz * hz) * (1u64 << 48) as f64;
            s.tick((z_at(k) * 4_294_967_296.0).round() as i32, v as i64, a as i64);
            if k > 5000 {
                let slide = s.z_in_q32() as f64 / 4_294_967_296.0;
                worst = worst.max((slide - z_at(k + 1)).abs());
            }
        }
        eprintln!("voice coil sine tracking: max error {:.3} uin", worst * 1e6);
        assert!(worst < 0.1e-6, "{worst}");
    }
}
