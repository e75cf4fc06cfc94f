//! Integer helpers. `isqrt_u64` and `ratio_u64` never divide (shift, add, compare, multiply)
//! and are safe at interrupt rate; `isqrt_u128` and `div_ceil_u64` divide and belong to
//! planning-rate code.

/// Largest `r` with `r * r <= n`.
pub fn isqrt_u128(n: u128) -> u128 {
    if n < 2 {
        return n;
    }
    // Newton from an upper bound: 2^(ceil(bits/2)) >= sqrt(n).
    let bits = 128 - n.leading_zeros();
    let mut x: u128 = 1u128 << bits.div_ceil(2);
    loop {
        let y = (x + n / x) >> 1;
        if y >= x {
            return x;
        }
        x = y;
    }
}

/// Largest `r` with `r * r <= n`, digit by digit: 32 rounds of shift, add and compare.
pub const fn isqrt_u64(n: u64) -> u32 {
    let mut rem = n;
    let mut root: u64 = 0;
    let mut bit: u64 = 1 << 62;
    while bit > rem && bit != 0 {
        bit >>= 2;
    }
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root as u32
}

/// 1/D in Q30 for D = `d32` / 2^32 in [0.5, 1) (top bit of `d32` set): a linear first guess
/// (error <= 1/17) and three Newton steps X <- X (2 - D X), each squaring the error.
const fn recip_q30(d32: u32) -> u64 {
    const TWO_Q30: u64 = 2 << 30;
    // 48/17 - 32/17 D in Q30.
    let mut x: u64 = 3_031_741_621 - ((2_021_161_080u64 * d32 as u64) >> 32);
    let mut i = 0;
    while i < 3 {
        let dx = (d32 as u64 * x) >> 32;
        x = (x * (TWO_Q30 - dx)) >> 30;
        i += 1;
    }
    x
}

/// `num / den` without a divide instruction, saturating at `u64::MAX` (also for `den == 0`).
/// A reciprocal good to ~2^-29 relative and one correction step: exact (floor) for quotients
/// below 2^28, within `num/den * 4e-9` above.
pub const fn ratio_u64(num: u64, den: u64) -> u64 {
    if den == 0 {
        return u64::MAX;
    }
    let s = den.leading_zeros();
    let d = den << s;
    // Rounding the divisor up keeps the quotient from overshooting.
    let top = (d >> 32) as u32;
    let (d32, carry) = if d as u32 == 0 { (top, false) } else { top.overflowing_add(1) };
    // den = D 2^(64-s) with D = d32/2^32; num/den = num X 2^(s - 64 - 30). A carry means D = 1.
    let (x, shift) = if carry { (1u64 << 30, 94 - s) } else { (recip_q30(d32), 94 - s) };
    let mut q = (num as u128 * x as u128) >> shift;
    // The estimate is never above the quotient; one step up when the remainder allows it.
    if q < u64::MAX as u128 && (q + 1) * den as u128 <= num as u128 {
        q += 1;
    }
    if q > u64::MAX as u128 {
        u64::MAX
    } else {
        q as u64
    }
}

/// `ceil(a / b)` for `b > 0`.
pub const fn div_ceil_u64(a: u64, b: u64) -> u64 {
    a.div_ceil(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn isqrt_u128_is_floor_sqrt() {
        for n in 0u128..5000 {
            let r = isqrt_u128(n);
            assert!(r * r <= n && (r + 1) * (r + 1) > n, "n={n} r={r}");
        }
        for &n in &[u64::MAX as u128, u128::MAX, (1u128 << 100) + 12345, 999_999_999_999] {
            let r = isqrt_u128(n);
            assert!(r.checked_mul(r).is_some_and(|sq| sq <= n));
            assert!((r + 1).checked_mul(r + 1).is_none_or(|sq| sq > n));
        }
    }

    #[test]
    fn isqrt_is_floor_sqrt() {
        for n in 0u64..5000 {
            let r = isqrt_u64(n) as u64;
            assert!(r * r <= n && (r + 1) * (r + 1) > n, "{n}");
        }
        assert_eq!(isqrt_u64(u64::MAX), u32::MAX);
        assert_eq!(isqrt_u64(1 << 62), 1 << 31);
    }

    #[test]
    fn ratio_edges() {
        assert_eq!(ratio_u64(5, 0), u64::MAX);
        assert_eq!(ratio_u64(u64::MAX, 1), u64::MAX);
        assert_eq!(ratio_u64(0, 7), 0);
        assert_eq!(ratio_u64(1 << 40, 1 << 20), 1 << 20);
        assert_eq!(ratio_u64(4_100_000 << 16, 4_100_000), 1 << 16);
    }

    proptest! {
        #[test]
        fn isqrt_prop(n: u64) {
            let r = isqrt_u64(n) as u128;
            prop_assert!(r * r <= n as u128 && (r + 1) * (r + 1) > n as u128);
        }

        #[test]
        fn ratio_close_to_division(num in 0u64..(1 << 62), den in 1u64..u64::MAX) {
            let exact = num / den;
            let got = ratio_u64(num, den);
            prop_assert!(got <= exact, "never above: {got} > {exact}");
            let slack = if exact < 1 << 28 { 0 } else { (exact as f64 * 4e-9) as u64 + 1 };
            prop_assert!(exact - got <= slack, "{num}/{den}: {got} vs {exact}");
        }
    }
}
