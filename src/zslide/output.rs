//! Z command outputs: an integer step target for a step/dir axis with a follower that moves at
//! most one step per tick toward it, or a 12-bit DAC code (the F405 DAC) for an analog slide.
//! A DAC code outside 0..=4095 is a `ZSlideLimit` fault, never a clipped output.

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
}

impl DacScale {
    /// `None` unless `mid_code <= 4095` and `0 < codes_per_in <= 2^24`.
    pub const fn new(codes_per_in: u32, mid_code: u16) -> Option<Self> {
        if mid_code > 4095 || codes_per_in == 0 || codes_per_in > 1 << 24 {
            return None;
        }
        Some(Self { codes_per_in: codes_per_in as i64, mid_code })
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
        assert_eq!(d.code((0.005 * 4_294_967_296.0) as i32), Ok(2048 + 1024));
        assert_eq!(d.code((0.011 * 4_294_967_296.0) as i32), Err(FaultCode::ZSlideLimit));
        assert_eq!(d.code((-0.0101 * 4_294_967_296.0) as i32), Err(FaultCode::ZSlideLimit));
    }

    proptest! {
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
