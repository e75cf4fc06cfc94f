//! Fixed-point biquad (direct form I, Q30 coefficients, 64-bit accumulator): the anti-alias
//! filter in front of the force chain's decimator.

/// Coefficients in Q30: y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2 (a0 = 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BiquadCoeffs {
    pub b0: i32,
    pub b1: i32,
    pub b2: i32,
    pub a1: i32,
    pub a2: i32,
}

impl BiquadCoeffs {
    /// Second-order Butterworth low-pass at fs/20 (bilinear, prewarped): the anti-alias filter
    /// for decimation by 5 (the passband ends at half the decimated Nyquist frequency). a2 is
    /// rounded 2 LSB off so that b0 + b1 + b2 = 2^30 + a1 + a2 exactly: unity DC gain, so a
    /// steady force reads exactly.
    pub const BUTTERWORTH_FS_OVER_20: BiquadCoeffs = BiquadCoeffs {
        b0: 21_564_350,
        b1: 43_128_700,
        b2: 21_564_350,
        a1: -1_676_130_396,
        a2: 688_645_972,
    };
}

/// One filter channel's state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Biquad {
    x1: i32,
    x2: i32,
    y1: i32,
    y2: i32,
    /// What the last output's rounding left out, Q30: fed back so a steady input reads
    /// exactly instead of sitting in a rounding dead band.
    residue: i64,
}

impl Biquad {
    /// Starts settled at `value` (a DC input gives `value` out from the first sample).
    pub const fn settled(value: i32) -> Self {
        Biquad { x1: value, x2: value, y1: value, y2: value, residue: 0 }
    }

    /// One sample in, one out. Inputs within +/-2^28 (268 kN in mN) cannot overflow: the sum of
    /// five Q30 products stays below 2^62.
    #[inline]
    pub fn step(&mut self, c: &BiquadCoeffs, x: i32) -> i32 {
        let acc =
            c.b0 as i64 * x as i64 + c.b1 as i64 * self.x1 as i64 + c.b2 as i64 * self.x2 as i64
                - c.a1 as i64 * self.y1 as i64
                - c.a2 as i64 * self.y2 as i64
                + self.residue;
        // The clamp only matters for inputs beyond the documented range.
        let y = (acc >> 30).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
        self.residue = acc - ((y as i64) << 30);
        self.x2 = self.x1;
        self.x1 = x;
        self.y2 = self.y1;
        self.y1 = y;
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The constants are the bilinear Butterworth design at fs/20, recomputed in f64.
    #[test]
    fn coefficients_match_the_design() {
        let k = (core::f64::consts::PI / 20.0).tan();
        let n = 1.0 / (1.0 + 2f64.sqrt() * k + k * k);
        let q = (1u64 << 30) as f64;
        let c = BiquadCoeffs::BUTTERWORTH_FS_OVER_20;
        assert!((c.b0 as f64 - k * k * n * q).abs() < 1.0);
        assert_eq!(c.b1, 2 * c.b0);
        assert_eq!(c.b2, c.b0);
        assert!((c.a1 as f64 - 2.0 * (k * k - 1.0) * n * q).abs() < 1.0);
        assert!((c.a2 as f64 - (1.0 - 2f64.sqrt() * k + k * k) * n * q).abs() < 3.0);
        assert_eq!(4 * c.b0 as i64, (1i64 << 30) + c.a1 as i64 + c.a2 as i64);
    }

    #[test]
    fn step_response_settles_exactly_without_much_overshoot() {
        let c = BiquadCoeffs::BUTTERWORTH_FS_OVER_20;
        let mut f = Biquad::default();
        let mut peak = 0;
        let mut y = 0;
        for _ in 0..400 {
            y = f.step(&c, 15_600_000);
            peak = peak.max(y);
        }
        assert_eq!(y, 15_600_000);
        // Butterworth: 4.3 % overshoot.
        assert!(peak > 16_200_000 && peak < 16_400_000, "{peak}");
    }

    #[test]
    fn attenuates_above_the_decimated_nyquist() {
        // fs/10 (the Nyquist frequency after decimating by 5): about -12.5 dB for this design.
        let c = BiquadCoeffs::BUTTERWORTH_FS_OVER_20;
        let mut f = Biquad::default();
        let mut amp = 0;
        for n in 0..2000 {
            let x = (1e6 * (2.0 * core::f64::consts::PI * n as f64 / 10.0).sin()) as i32;
            let y = f.step(&c, x);
            if n > 1000 {
                amp = amp.max(y.abs());
            }
        }
        assert!(amp < 250_000 && amp > 200_000, "{amp}");
    }
}
