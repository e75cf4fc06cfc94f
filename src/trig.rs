//! Fixed-point sine and cosine of an angle given as a `u32` fraction of a turn.
//!
//! A quarter-wave table of 1025 Q30 values, built at compile time, with linear interpolation:
//! the worst error is `(pi/2/1024)^2 / 8 = 2.9e-7` (about 316 LSB of Q30). In the Z command
//! `C01 s + C02 s^2` that is below 0.005 uin for the Douglass table, far under its 0.1 uin budget.
//! Cost: a handful of shifts and masks, two loads and one 32x32 multiply; no division.

/// `1.0` in Q30.
pub const ONE_Q30: i32 = 1 << 30;
/// A quarter turn in `u32` turn units.
pub const QUARTER_TURN: u32 = 1 << 30;
/// `2 pi` in Q29 (rounded).
pub const TWO_PI_Q29: i64 = 3_373_259_426;

const SEGMENT_BITS: u32 = 10;
const SEGMENTS: usize = 1 << SEGMENT_BITS;

/// `sin(x)` for `0 <= x <= pi/2` by its Taylor series in f64 (compile time only: converges to an
/// ulp with 30 terms on this range).
const fn taylor_sin(x: f64) -> f64 {
    let mut term = x;
    let mut sum = x;
    let mut n = 1u32;
    while n < 30 {
        let k = (2 * n) as f64;
        term = -term * x * x / (k * (k + 1.0));
        sum += term;
        n += 1;
    }
    sum
}

const fn build_quarter() -> [i32; SEGMENTS + 1] {
    let mut t = [0i32; SEGMENTS + 1];
    let mut i = 0;
    while i <= SEGMENTS {
        let x = core::f64::consts::FRAC_PI_2 * i as f64 / SEGMENTS as f64;
        let v = taylor_sin(x) * ONE_Q30 as f64;
        // Round half up; v >= 0 here.
        let r = (v + 0.5) as i64;
        t[i] = if r > ONE_Q30 as i64 { ONE_Q30 } else { r as i32 };
        i += 1;
    }
    t
}

/// `sin` on `[0, pi/2]` at `SEGMENTS + 1` evenly spaced points, Q30.
static SIN_QUARTER_Q30: [i32; SEGMENTS + 1] = build_quarter();

/// `sin(2 pi a / 2^32)` in Q30.
#[inline]
pub fn sin_q30(a_turn_q32: u32) -> i32 {
    let quadrant = a_turn_q32 >> 30;
    let mut p = a_turn_q32 & (QUARTER_TURN - 1);
    if quadrant & 1 == 1 {
        // Mirror: sin(pi/2 + x) = sin(pi/2 - x); p may become exactly a quarter turn.
        p = QUARTER_TURN - p;
    }
    let idx = (p >> (30 - SEGMENT_BITS)) as usize;
    let frac_q16 = ((p >> (30 - SEGMENT_BITS - 16)) & 0xFFFF) as i64;
    let y0 = SIN_QUARTER_Q30.get(idx).copied().unwrap_or(ONE_Q30);
    let y1 = SIN_QUARTER_Q30.get(idx + 1).copied().unwrap_or(ONE_Q30);
    let y = y0 + (((y1 - y0) as i64 * frac_q16) >> 16) as i32;
    if quadrant >= 2 {
        -y
    } else {
        y
    }
}

/// `cos(2 pi a / 2^32)` in Q30.
#[inline]
pub fn cos_q30(a_turn_q32: u32) -> i32 {
    sin_q30(a_turn_q32.wrapping_add(QUARTER_TURN))
}

/// A `u32` turn fraction from radians (host and tests only: f64).
#[cfg(test)]
pub fn turn_q32_from_rad(phi_rad: f64) -> u32 {
    let t = phi_rad / (2.0 * core::f64::consts::PI);
    let t = t - t.floor();
    ((t * 4_294_967_296.0) as u64 & 0xFFFF_FFFF) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn two_pi_constant() {
        let v = TWO_PI_Q29 as f64 / (1u64 << 29) as f64;
        assert!((v - 2.0 * core::f64::consts::PI).abs() < 2e-9);
    }

    #[test]
    fn sin_cos_error_bound() {
        // The bound of linear interpolation, (h^2/8) with h = pi/2/1024, plus rounding.
        let bound = (core::f64::consts::FRAC_PI_2 / 1024.0).powi(2) / 8.0 + 2e-9;
        let mut worst = 0.0f64;
        for k in 0..200_003u64 {
            let a = (k * 214_747_u64 + k * k) as u32;
            let phi = a as f64 / 4_294_967_296.0 * 2.0 * core::f64::consts::PI;
            let es = (sin_q30(a) as f64 / ONE_Q30 as f64 - phi.sin()).abs();
            let ec = (cos_q30(a) as f64 / ONE_Q30 as f64 - phi.cos()).abs();
            worst = worst.max(es).max(ec);
        }
        eprintln!("sin/cos worst error {worst:.3e} (bound {bound:.3e})");
        assert!(worst <= bound, "{worst}");
        assert_eq!(sin_q30(0), 0);
        assert_eq!(sin_q30(QUARTER_TURN), ONE_Q30);
        assert_eq!(sin_q30(3 * QUARTER_TURN), -ONE_Q30);
    }

    proptest! {
        #[test]
        fn bounded_and_odd(a in any::<u32>()) {
            let s = sin_q30(a);
            prop_assert!(s.abs() <= ONE_Q30);
            // sin(-a) = -sin(a) up to one interpolation LSB.
            prop_assert!((sin_q30(a.wrapping_neg()) + s).abs() <= 1);
        }
    }
}
