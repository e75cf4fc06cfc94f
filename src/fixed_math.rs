//! Integer helpers for planning-rate code (never called from the tick path).

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

/// Largest `r` with `r * r <= n`.
pub fn isqrt_u64(n: u64) -> u64 {
    isqrt_u128(n as u128) as u64
}

/// `ceil(a / b)` for `b > 0`.
pub const fn div_ceil_u64(a: u64, b: u64) -> u64 {
    a.div_ceil(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isqrt_is_floor_sqrt() {
        for n in 0u128..5000 {
            let r = isqrt_u128(n);
            assert!(r * r <= n && (r + 1) * (r + 1) > n, "n={n} r={r}");
        }
        for &n in &[u64::MAX as u128, u128::MAX, (1u128 << 100) + 12345, 999_999_999_999] {
            let r = isqrt_u128(n);
            assert!(r.checked_mul(r).is_some_and(|sq| sq <= n));
            assert!((r + 1).checked_mul(r + 1).is_none_or(|sq| sq > n));
        }
        assert_eq!(isqrt_u64(u64::MAX), 4_294_967_295);
    }
}
