//! Z command outputs: an integer step target for a step/dir axis with a follower that moves at
//! most one step per tick toward it, or a 12-bit DAC code (the F405 DAC) for an analog slide.
//! A DAC code outside 0..=4095 is a `ZSlideLimit` fault, never a clipped output.

use super::command::ZUpdate;
use crate::protocol::errors::FaultCode;

/// Z (inches Q32) to steps: `steps_per_in` integer, <= 2^24 (0.06 uin steps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepScale {
    steps_per_in: u32,
    /// `2^32 / steps_per_in`: one step in inches Q32 (rounded), for reports and plants.
    step_in_q32: i64,
}

impl StepScale {
    /// `None` unless `1 <= steps_per_in <= 2^24` (setup: divides).
    pub const fn new(steps_per_in: u32) -> Option<Self> {
        if steps_per_in == 0 || steps_per_in > 1 << 24 {
            return None;
        }
        let step = ((1i64 << 32) + steps_per_in as i64 / 2) / steps_per_in as i64;
        Some(Self { steps_per_in, step_in_q32: step })
    }
    /// Nearest step to `z_in_q32` (rounded half up). `|z| * steps_per_in < 2^56`: no overflow.
    #[inline]
    pub fn target_steps(&self, z_in_q32: i32) -> i32 {
        ((z_in_q32 as i64 * self.steps_per_in as i64 + (1 << 31)) >> 32) as i32
    }
    /// Position of `steps` in inches Q32.
    #[inline]
    pub fn z_in_q32(&self, steps: i32) -> i64 {
        steps as i64 * self.step_in_q32
    }
    pub const fn steps_per_in(&self) -> u32 {
        self.steps_per_in
    }
}

/// A step/dir axis position that follows a target at one step per tick at most (the ideal
/// stepper Z axis of the scenarios: it is where its steps put it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepFollower {
    position_steps: i32,
}

impl StepFollower {
    pub const fn new(position_steps: i32) -> Self {
        Self { position_steps }
    }
    /// One tick: the step to take (-1, 0, +1) toward `target_steps`.
    #[inline]
    pub fn tick(&mut self, target_steps: i32) -> i8 {
        let d = target_steps.cmp(&self.position_steps) as i8;
        self.position_steps = self.position_steps.wrapping_add(d as i32);
        d
    }
    pub const fn position_steps(&self) -> i32 {
        self.position_steps
    }
}

/// Z (inches Q32) to a 12-bit DAC code: `code = mid + z * codes_per_in`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DacScale {
    /// DAC codes per inch (e.g. 2048 codes over 0.010 in: 204_800).
    codes_per_in: i64,
    mid_code: u16,
    /// One code in inches Q32 (rounded): the analog position a code stands for.
    lsb_in_q32: i64,
}

impl DacScale {
    /// `None` unless `mid_code <= 4095` and `0 < codes_per_in <= 2^24`.
    pub const fn new(codes_per_in: u32, mid_code: u16) -> Option<Self> {
        if mid_code > 4095 || codes_per_in == 0 || codes_per_in > 1 << 24 {
            return None;
        }
        let lsb = ((1i64 << 32) + codes_per_in as i64 / 2) / codes_per_in as i64;
        Some(Self { codes_per_in: codes_per_in as i64, mid_code, lsb_in_q32: lsb })
    }
    /// The position `code` commands, inches Q32 (simulated analog slides).
    #[inline]
    pub fn z_in_q32(&self, code: u16) -> i64 {
        (code as i64 - self.mid_code as i64) * self.lsb_in_q32
    }
    /// The code for `z_in_q32`, or `ZSlideLimit` if it is outside the DAC's range.
    #[inline]
    pub fn code(&self, z_in_q32: i32) -> Result<u16, FaultCode> {
        let c = self.mid_code as i64 + ((z_in_q32 as i64 * self.codes_per_in + (1 << 31)) >> 32);
        if (0..=4095).contains(&c) {
            Ok(c as u16)
        } else {
            Err(FaultCode::ZSlideLimit)
        }
    }
}

/// Command-side lead for a slide driven by its position command alone (the DAC output into
/// an analog servo: no velocity or acceleration input): the output is `z + b1 v + b2 a`, which
/// cancels a closed loop `1 / (1 + b1 s + b2 s^2)` (a pure latency `tau` is `b1 = tau`,
/// `b2 = tau^2 / 2`). Selected per job with the output, like the step/DAC choice.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CommandLead {
    /// `b1` in ticks Q16 (<= 2^26: 1024 ticks) and `b2` in ticks^2 Q16 (<= 2^32: 65536
    /// ticks^2, a 256-tick time constant squared).
    b1_ticks_q16: i64,
    b2_ticks2_q16: i64,
}

impl CommandLead {
    /// No lead: the output is the command.
    pub const NONE: Self = Self { b1_ticks_q16: 0, b2_ticks2_q16: 0 };

    /// The lead for a loop `1 / (1 + b1 s + b2 s^2)` (`b1` seconds, `b2` seconds^2) at
    /// `tick_hz` (setup: f64). `None` for negative, non-finite or out-of-range coefficients.
    pub fn for_loop(b1_s: f64, b2_s2: f64, tick_hz: u32) -> Option<Self> {
        let hz = tick_hz as f64;
        let b1 = b1_s * hz * 65_536.0;
        let b2 = b2_s2 * hz * hz * 65_536.0;
        if !(0.0..=(1u64 << 26) as f64).contains(&b1) || !(0.0..=(1u64 << 32) as f64).contains(&b2)
        {
            return None;
        }
        Some(Self { b1_ticks_q16: (b1 + 0.5) as i64, b2_ticks2_q16: (b2 + 0.5) as i64 })
    }

    /// The position command with the lead, inches Q32 (saturating at the `i32` range).
    /// Division-free, 2 multiplies.
    #[inline]
    pub fn apply(&self, u: &ZUpdate) -> i32 {
        // v clamped to 2^36 Q48 (12 in/s at 50 kHz), a to 2^30 (9500 in/s^2): products < 2^62.
        let v = u.v_in_q48_per_tick.clamp(-(1 << 36), 1 << 36);
        let a = u.a_in_q48_per_tick2.clamp(-(1 << 30), 1 << 30);
        let lead_q48 = ((v * self.b1_ticks_q16) >> 16) + ((a * self.b2_ticks2_q16) >> 16);
        let z = u.z_in_q32 as i64 + (lead_q48 >> 16);
        z.clamp(i32::MIN as i64, i32::MAX as i64) as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn steps_and_dac() {
        let s = StepScale::new(100_000).unwrap(); // 10 uin steps
        let z = (25e-6 * 4_294_967_296.0) as i32; // 25 uin -> 2.5 steps -> 3 (half up)
        assert_eq!(s.target_steps(z), 2);
        assert_eq!(s.target_steps(z + 300), 3);
        assert_eq!(s.target_steps(-z - 300), -3);
        let mut f = StepFollower::new(0);
        assert_eq!(f.tick(3), 1);
        assert_eq!(f.tick(3), 1);
        assert_eq!(f.tick(1), -1);
        assert_eq!(f.tick(1), 0);
        let d = DacScale::new(204_800, 2048).unwrap();
        assert_eq!(d.code(0), Ok(2048));
        // A code's position is within half a Q32 unit per code of 5 mil and maps back to it.
        let half = d.z_in_q32(2048 + 1024) - (0.005 * 4_294_967_296.0) as i64;
        assert!(half.abs() <= 1024 / 2 + 1, "{half}");
        for c in [0u16, 1, 2047, 2048, 3000, 4095] {
            assert_eq!(d.code(d.z_in_q32(c) as i32), Ok(c));
        }
        assert_eq!(d.code((0.005 * 4_294_967_296.0) as i32), Ok(2048 + 1024));
        assert_eq!(d.code((0.011 * 4_294_967_296.0) as i32), Err(FaultCode::ZSlideLimit));
        assert_eq!(d.code((-0.0101 * 4_294_967_296.0) as i32), Err(FaultCode::ZSlideLimit));
    }

    #[test]
    fn lead_adds_b1_v_plus_b2_a() {
        // b1 = 2 ticks, b2 = 3 ticks^2 at 50 kHz; v = 1 uin/tick, a = 0.01 uin/tick^2.
        let l = CommandLead::for_loop(2.0 / 50e3, 3.0 / 2.5e9, 50_000).unwrap();
        let q48 = (1u64 << 48) as f64;
        let u = ZUpdate {
            z_in_q32: (100e-6 * 4_294_967_296.0) as i32,
            v_in_q48_per_tick: (1e-6 * q48) as i64,
            a_in_q48_per_tick2: (0.01e-6 * q48) as i64,
        };
        let got = l.apply(&u) as f64 / 4_294_967_296.0;
        let want = 100e-6 + 2.0 * 1e-6 + 3.0 * 0.01e-6;
        assert!((got - want).abs() < 1e-9, "{got} {want}");
        assert_eq!(CommandLead::NONE.apply(&u), u.z_in_q32);
        assert_eq!(CommandLead::for_loop(-1.0, 0.0, 50_000), None);
        assert_eq!(CommandLead::for_loop(f64::NAN, 0.0, 50_000), None);
    }

    proptest! {
        #[test]
        fn lead_never_panics(z in any::<i32>(), v in any::<i64>(), a in any::<i64>(), b1 in 0.0f64..0.02, b2 in 0.0f64..2.5e-5) {
            let l = CommandLead::for_loop(b1, b2, 50_000).unwrap();
            let _ = l.apply(&ZUpdate { z_in_q32: z, v_in_q48_per_tick: v, a_in_q48_per_tick2: a });
        }

        #[test]
        fn no_panic(z in any::<i32>(), spi in any::<u32>(), cpi in any::<u32>(), mid in any::<u16>(), t in any::<i32>(), p in any::<i32>()) {
            if let Some(s) = StepScale::new(spi) { let _ = s.target_steps(z); let _ = s.z_in_q32(t); }
            if let Some(d) = DacScale::new(cpi, mid) { let _ = d.code(z); }
            let mut f = StepFollower::new(p);
            let before = f.position_steps();
            let step = f.tick(t);
            prop_assert!(step.abs() <= 1);
            prop_assert_eq!(f.position_steps(), before.wrapping_add(step as i32));
        }
    }
}
