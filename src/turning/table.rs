//! Fixed-point coefficient tables over the radial position `X` (uniform grid), their
//! interpolation in `X` (linear or 4-point cubic) and the Z command `Z(X, phi)` they give, in
//! both forms the generator supports:
//!
//! * power form (Douglass eq 2-19): row `[C00, C01, C02, C03]`,
//!   `Z = C00 + C01 s + C02 s^2 + C03 s^3`, `s = sin(phi)`;
//! * harmonic form (eq 2-17 cut at order `K <= 8`): row `[a0, a1, b1, ..., aK, bK]`,
//!   `Z = a0 + sum_k a_k cos(k phi) + b_k sin(k phi)`.
//!
//! Units: coefficients and `Z` in inches Q32 (`_in_q32`, 2^-32 in = 0.00023 uin per LSB, range
//! +-0.5 in), `X` in inches Q24 (`_in_q24`), angles in `u32` turn fractions (`_turn_q32`).
//! Everything here is integer and division-free after [`CoefficientTable::try_new`]; every
//! product is bounded by the checks made there (|coefficient| <= [`MAX_COEFF_IN_Q32`]).

use crate::trig::{cos_q30, sin_q30, TWO_PI_Q29};

/// Highest harmonic order of the harmonic form.
pub const MAX_ORDER: usize = 8;
/// Widest row: `2 * MAX_ORDER + 1` coefficients.
pub const MAX_WIDTH: usize = 2 * MAX_ORDER + 1;
/// Largest coefficient magnitude a table may hold: 2^28 = 1/16 in, far beyond any Z slide, and
/// small enough that no intermediate product below can overflow `i64`.
pub const MAX_COEFF_IN_Q32: i32 = 1 << 28;

/// Which series the rows hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TableForm {
    /// `[C00, C01, C02, C03]` in powers of `s = sin(phi)`.
    Power,
    /// `[a0, a1, b1, ..., aK, bK]`, `K = order`, `1 <= K <= 8`.
    Harmonic { order: u8 },
}

impl TableForm {
    /// Coefficients per row.
    pub const fn width(self) -> usize {
        match self {
            TableForm::Power => 4,
            TableForm::Harmonic { order } => 2 * order as usize + 1,
        }
    }
}

/// How coefficients are found between rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interp {
    /// Straight line between the two neighbouring rows.
    Linear,
    /// Lagrange cubic through the four nearest rows (shifted inwards at the ends); tables with
    /// fewer than four rows fall back to linear.
    Cubic,
}

/// Why a table was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TableError {
    /// No rows, or more than the capacity.
    RowCount,
    /// The form needs another row width (or an order outside 1..=8).
    Width,
    /// Grid step not positive, or the grid leaves the `i32` X range.
    Grid,
    /// A coefficient above [`MAX_COEFF_IN_Q32`] in magnitude.
    Coefficient,
}

/// A table of `len <= ROWS` rows of `WIDTH` coefficients at `X = x0 + i dx`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CoefficientTable<const ROWS: usize, const WIDTH: usize> {
    form: TableForm,
    len: usize,
    x0_in_q24: i32,
    dx_in_q24: i32,
    x_last_in_q24: i32,
    /// `2^54 / dx_in_q24`: turns `X - x0` into grid cells in Q30 without a division.
    cells_per_x_q54: i64,
    rows: [[i32; WIDTH]; ROWS],
}

/// The Z command at one `(X, phi)` with its derivatives along the spindle angle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ZPoint {
    /// `Z`, inches Q32.
    pub z_in_q32: i32,
    /// `dZ/dphi`, inches Q32 per radian.
    pub dz_dphi_in_q32: i64,
    /// `d2Z/dphi2`, inches Q32 per radian^2.
    pub d2z_dphi2_in_q32: i64,
}

impl<const ROWS: usize, const WIDTH: usize> CoefficientTable<ROWS, WIDTH> {
    /// Checks and builds a table (config time: divides once). `rows[..len]` are used; a
    /// harmonic table needs `WIDTH == 2 K + 1`, a power table `WIDTH == 4`.
    pub const fn try_new(
        form: TableForm,
        x0_in_q24: i32,
        dx_in_q24: i32,
        len: usize,
        rows: [[i32; WIDTH]; ROWS],
    ) -> Result<Self, TableError> {
        if len == 0 || len > ROWS {
            return Err(TableError::RowCount);
        }
        if let TableForm::Harmonic { order } = form {
            if order == 0 || order as usize > MAX_ORDER {
                return Err(TableError::Width);
            }
        }
        if form.width() != WIDTH {
            return Err(TableError::Width);
        }
        if dx_in_q24 <= 0 {
            return Err(TableError::Grid);
        }
        let x_last = x0_in_q24 as i64 + (len as i64 - 1) * dx_in_q24 as i64;
        if x_last > i32::MAX as i64 {
            return Err(TableError::Grid);
        }
        let cells_per_x_q54 = (1i64 << 54) / dx_in_q24 as i64;
        // (X - x0) * cells_per_x must fit: span * 2^54 / dx = cells * 2^54 <= 2^62 -> <= 256
        // cells plus the clamp margin; checked exactly.
        let span = x_last - x0_in_q24 as i64;
        if span > 0 && cells_per_x_q54 > (1i64 << 62) / span {
            return Err(TableError::Grid);
        }
        let mut r = 0;
        while r < len {
            let mut k = 0;
            while k < WIDTH {
                let c = rows[r][k];
                if c > MAX_COEFF_IN_Q32 || c < -MAX_COEFF_IN_Q32 {
                    return Err(TableError::Coefficient);
                }
                k += 1;
            }
            r += 1;
        }
        Ok(Self {
            form,
            len,
            x0_in_q24,
            dx_in_q24,
            x_last_in_q24: x_last as i32,
            cells_per_x_q54,
            rows,
        })
    }

    pub const fn form(&self) -> TableForm {
        self.form
    }
    pub const fn len(&self) -> usize {
        self.len
    }
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }
    pub const fn x0_in_q24(&self) -> i32 {
        self.x0_in_q24
    }
    pub const fn dx_in_q24(&self) -> i32 {
        self.dx_in_q24
    }
    /// `X` of the last row.
    pub const fn x_last_in_q24(&self) -> i32 {
        self.x_last_in_q24
    }
    /// Row `i`, if present.
    pub fn row(&self, i: usize) -> Option<&[i32; WIDTH]> {
        if i < self.len {
            self.rows.get(i)
        } else {
            None
        }
    }

    fn row_or_zero(&self, i: usize) -> [i32; WIDTH] {
        self.rows.get(i).copied().unwrap_or([0; WIDTH])
    }

    /// The coefficients at `x_in_q24` (clamped to the table), interpolated.
    #[inline]
    pub fn coefficients(&self, x_in_q24: i32, interp: Interp) -> [i32; WIDTH] {
        let x = x_in_q24.clamp(self.x0_in_q24, self.x_last_in_q24);
        if self.len < 2 {
            return self.row_or_zero(0);
        }
        // Grid position in cells, Q30 (bounded by the check in try_new).
        let u_q30 = ((x as i64 - self.x0_in_q24 as i64) * self.cells_per_x_q54) >> 24;
        let cell = ((u_q30 >> 30) as usize).min(self.len - 2);
        let mut out = [0i32; WIDTH];
        if interp == Interp::Linear || self.len < 4 {
            let t_q30 = u_q30 - ((cell as i64) << 30);
            let a = self.row_or_zero(cell);
            let b = self.row_or_zero(cell + 1);
            for k in 0..WIDTH {
                out[k] = a[k] + (((b[k] - a[k]) as i64 * t_q30) >> 30) as i32;
            }
            return out;
        }
        let start = cell.saturating_sub(1).min(self.len - 4);
        let w = lagrange4_q30(u_q30 - ((start as i64) << 30));
        let r = [
            self.row_or_zero(start),
            self.row_or_zero(start + 1),
            self.row_or_zero(start + 2),
            self.row_or_zero(start + 3),
        ];
        for k in 0..WIDTH {
            let acc = w[0] * r[0][k] as i64
                + w[1] * r[1][k] as i64
                + w[2] * r[2][k] as i64
                + w[3] * r[3][k] as i64;
            out[k] = (acc >> 30) as i32;
        }
        out
    }

    /// `Z(X, phi)` and its angle derivatives from interpolated coefficients.
    #[inline]
    pub fn eval(&self, x_in_q24: i32, phi_turn_q32: u32, interp: Interp) -> ZPoint {
        let c = self.coefficients(x_in_q24, interp);
        eval_row(self.form, &c, phi_turn_q32)
    }
}

/// Lagrange weights for nodes 0, 1, 2, 3 at `tau` (Q30, 0 <= tau <= 3), in Q30.
#[inline]
fn lagrange4_q30(tau_q30: i64) -> [i64; 4] {
    const ONE: i64 = 1 << 30;
    let a = tau_q30;
    let b = a - ONE;
    let c = a - 2 * ONE;
    let d = a - 3 * ONE;
    // Each pair product is at most 6 * 2^60 in magnitude; shift back to Q30 before the third.
    let bc = (b * c) >> 30;
    let ad = (a * d) >> 30;
    let ab = (a * b) >> 30;
    [-sixth((bc * d) >> 30), ((ad * c) >> 30) / 2, -((ad * b) >> 30) / 2, sixth((ab * c) >> 30)]
}

/// `x / 6` (to within one Q30 unit) by a multiply: an `i64` division, even by a constant, is a
/// library call on the M4, and this runs every update.
#[inline(always)]
fn sixth(x: i64) -> i64 {
    // round(2^30 / 6); |x| <= 6 * 2^30 keeps the product below 2^62.
    const SIXTH_Q30: i64 = 178_956_971;
    (x * SIXTH_Q30) >> 30
}

/// `Z` and its derivatives for one row of coefficients (`c.len()` must be `form.width()`;
/// missing coefficients count as zero).
#[inline]
pub fn eval_row(form: TableForm, c: &[i32], phi_turn_q32: u32) -> ZPoint {
    let get = |k: usize| c.get(k).copied().unwrap_or(0) as i64;
    match form {
        TableForm::Power => {
            let s = sin_q30(phi_turn_q32) as i64;
            let co = cos_q30(phi_turn_q32) as i64;
            let (c0, c1, c2, c3) = (get(0), get(1), get(2), get(3));
            // Horner in Q32 inches; |terms| <= 4 * 2^28, products <= 2^61.
            let z = c0 + ((s * (c1 + ((s * (c2 + ((s * c3) >> 30))) >> 30))) >> 30);
            // P'(s) = c1 + 2 c2 s + 3 c3 s^2; P''(s) = 2 c2 + 6 c3 s.
            let p1 = c1 + ((s * (2 * c2 + ((3 * c3 * s) >> 30))) >> 30);
            let p2 = 2 * c2 + ((6 * c3 * s) >> 30);
            // dZ/dphi = P' cos; d2Z/dphi2 = P'' cos^2 - P' sin.
            let d1 = (p1 * co) >> 30;
            let cos2 = (co * co) >> 30;
            let d2 = ((p2 * cos2) >> 30) - ((p1 * s) >> 30);
            ZPoint { z_in_q32: z as i32, dz_dphi_in_q32: d1, d2z_dphi2_in_q32: d2 }
        }
        TableForm::Harmonic { order } => {
            let mut z = get(0);
            let mut d1 = 0i64;
            let mut d2 = 0i64;
            let mut angle = phi_turn_q32;
            let order = (order as usize).min(MAX_ORDER);
            for k in 1..=order {
                // k phi as a turn fraction wraps exactly in u32.
                let s = sin_q30(angle) as i64;
                let co = cos_q30(angle) as i64;
                let (a, b) = (get(2 * k - 1), get(2 * k));
                let ac = (a * co) >> 30;
                let bs = (b * s) >> 30;
                let kk = k as i64;
                z += ac + bs;
                d1 += kk * (((b * co) >> 30) - ((a * s) >> 30));
                d2 -= kk * kk * (ac + bs);
                angle = angle.wrapping_add(phi_turn_q32);
            }
            ZPoint {
                z_in_q32: z.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
                dz_dphi_in_q32: d1,
                d2z_dphi2_in_q32: d2,
            }
        }
    }
}

/// [`eval_row`] of `c` and, sharing its sines and cosines, the Z of the coefficient change `dc`
/// (the generator's X-feed term): bit for bit `eval_row(form, dc, phi).z_in_q32`, at the price
/// of a few multiplies instead of a second evaluation.
#[inline]
pub fn eval_row_with_delta(
    form: TableForm,
    c: &[i32],
    dc: &[i32],
    phi_turn_q32: u32,
) -> (ZPoint, i32) {
    let get = |k: usize| c.get(k).copied().unwrap_or(0) as i64;
    let getd = |k: usize| dc.get(k).copied().unwrap_or(0) as i64;
    match form {
        TableForm::Power => {
            let s = sin_q30(phi_turn_q32) as i64;
            let co = cos_q30(phi_turn_q32) as i64;
            let (c0, c1, c2, c3) = (get(0), get(1), get(2), get(3));
            let z = c0 + ((s * (c1 + ((s * (c2 + ((s * c3) >> 30))) >> 30))) >> 30);
            let p1 = c1 + ((s * (2 * c2 + ((3 * c3 * s) >> 30))) >> 30);
            let p2 = 2 * c2 + ((6 * c3 * s) >> 30);
            let d1 = (p1 * co) >> 30;
            let cos2 = (co * co) >> 30;
            let d2 = ((p2 * cos2) >> 30) - ((p1 * s) >> 30);
            let (e0, e1, e2, e3) = (getd(0), getd(1), getd(2), getd(3));
            let dz = e0 + ((s * (e1 + ((s * (e2 + ((s * e3) >> 30))) >> 30))) >> 30);
            (ZPoint { z_in_q32: z as i32, dz_dphi_in_q32: d1, d2z_dphi2_in_q32: d2 }, dz as i32)
        }
        TableForm::Harmonic { order } => {
            let mut z = get(0);
            let mut dz = getd(0);
            let mut d1 = 0i64;
            let mut d2 = 0i64;
            let mut angle = phi_turn_q32;
            let order = (order as usize).min(MAX_ORDER);
            for k in 1..=order {
                let s = sin_q30(angle) as i64;
                let co = cos_q30(angle) as i64;
                let (a, b) = (get(2 * k - 1), get(2 * k));
                let ac = (a * co) >> 30;
                let bs = (b * s) >> 30;
                let kk = k as i64;
                z += ac + bs;
                d1 += kk * (((b * co) >> 30) - ((a * s) >> 30));
                d2 -= kk * kk * (ac + bs);
                dz += ((getd(2 * k - 1) * co) >> 30) + ((getd(2 * k) * s) >> 30);
                angle = angle.wrapping_add(phi_turn_q32);
            }
            let clamp = |v: i64| v.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
            (ZPoint { z_in_q32: clamp(z), dz_dphi_in_q32: d1, d2z_dphi2_in_q32: d2 }, clamp(dz))
        }
    }
}

/// Angular speed in radians per tick, Q32, from turns per tick Q32 (`|speed|` must be at most
/// 2^24 for the products downstream; the generator checks that).
#[inline]
pub fn rad_per_tick_q32(speed_turn_q32_per_tick: i32) -> i64 {
    (speed_turn_q32_per_tick as i64 * TWO_PI_Q29) >> 29
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const IN_Q32: f64 = 4_294_967_296.0;

    fn q32(v: f64) -> i32 {
        (v * IN_Q32).round() as i32
    }

    proptest! {
        /// The shared evaluation equals two separate ones, bit for bit.
        #[test]
        fn with_delta_equals_two_evaluations(
            c in prop::array::uniform17(-(1i32 << 28)..(1 << 28)),
            dc in prop::array::uniform17(-(1i32 << 20)..(1 << 20)),
            phi in any::<u32>(),
            order in 0u8..=8,
        ) {
            for form in [TableForm::Power, TableForm::Harmonic { order }] {
                let (p, dz) = eval_row_with_delta(form, &c, &dc, phi);
                prop_assert_eq!(p, eval_row(form, &c, phi));
                prop_assert_eq!(dz, eval_row(form, &dc, phi).z_in_q32);
            }
        }
    }

    #[test]
    fn lagrange_weights_sum_to_one_and_hit_nodes() {
        for j in 0..=300 {
            let tau = ((j as i64) << 30) * 3 / 300;
            let w = lagrange4_q30(tau);
            let s: i64 = w.iter().sum();
            assert!((s - (1 << 30)).abs() <= 4, "tau {tau} sum {s}");
        }
        assert_eq!(lagrange4_q30(2 << 30), [0, 0, 1 << 30, 0]);
    }

    #[test]
    fn power_and_harmonic_forms_agree() {
        // C0 + S1 sin + C2 cos 2phi + S3 sin 3phi == power form (eqs 2-20..2-23).
        let (c0, s1, c2, s3) = (-3.1e-3, -1.66e-3, 3.0e-3, -1.28e-5);
        let p = [q32(c0 + c2), q32(s1 + 3.0 * s3), q32(-2.0 * c2), q32(-4.0 * s3)];
        let h = [q32(c0), 0, q32(s1), q32(c2), 0, 0, q32(s3)];
        for k in 0..360 {
            let phi = ((k as u64) << 32) / 360;
            let a = eval_row(TableForm::Power, &p, phi as u32);
            let b = eval_row(TableForm::Harmonic { order: 3 }, &h, phi as u32);
            // 16 LSB = 3.7e-9 in: two sin/cos interpolation errors apart.
            assert!((a.z_in_q32 - b.z_in_q32).abs() < 16, "{k}: {a:?} {b:?}");
            assert!((a.dz_dphi_in_q32 - b.dz_dphi_in_q32).abs() < 64, "{k}");
            assert!((a.d2z_dphi2_in_q32 - b.d2z_dphi2_in_q32).abs() < 256, "{k}");
            let phi_rad = k as f64 * std::f64::consts::PI / 180.0;
            let exact =
                c0 + s1 * phi_rad.sin() + c2 * (2.0 * phi_rad).cos() + s3 * (3.0 * phi_rad).sin();
            let d1 = s1 * phi_rad.cos() - 2.0 * c2 * (2.0 * phi_rad).sin()
                + 3.0 * s3 * (3.0 * phi_rad).cos();
            // sin/cos error 3e-7 times coefficients of a few 1e-3 in.
            // Bound: sin error times |dZ/ds| <= |C01| + 2 |C02| + 3 |C03|, plus rounding.
            let bound =
                2.96e-7 * (s1.abs() + 3.0 * s3.abs() + 4.0 * c2.abs() + 12.0 * s3.abs()) + 1e-9;
            assert!((a.z_in_q32 as f64 / IN_Q32 - exact).abs() < bound);
            let e1 = (a.dz_dphi_in_q32 as f64 / IN_Q32 - d1).abs();
            assert!(e1 < 1e-8, "{k}: {e1:e}");
        }
    }

    #[test]
    fn interpolation_reproduces_lines_and_cubics() {
        let dx = 1 << 22; // 0.25 in
        let f = |x: f64| 1e-3 * x * x * x - 2e-3 * x * x + 5e-4;
        let mut rows = [[0i32; 4]; 12];
        for (i, r) in rows.iter_mut().enumerate() {
            let x = i as f64 * 0.25;
            *r = [q32(f(x)), q32(1e-3 * x), 0, 0];
        }
        let t = CoefficientTable::<12, 4>::try_new(TableForm::Power, 0, dx, 10, rows).unwrap();
        for j in 0..=900 {
            let x = j as f64 * 0.0025;
            let xq = (x * (1 << 24) as f64).round() as i32;
            let xr = xq as f64 / (1 << 24) as f64;
            let c = t.coefficients(xq, Interp::Cubic);
            assert!((c[0] as f64 / IN_Q32 - f(xr)).abs() < 2e-9, "{x}");
            let l = t.coefficients(xq, Interp::Linear);
            assert!((l[1] as f64 / IN_Q32 - 1e-3 * xr).abs() < 2e-9, "{x}");
        }
        // Clamped outside the grid.
        assert_eq!(t.coefficients(-5, Interp::Cubic), *t.row(0).unwrap());
        assert_eq!(t.coefficients(i32::MAX, Interp::Linear), *t.row(9).unwrap());
    }

    #[test]
    fn bad_tables_are_refused() {
        let rows = [[0i32; 4]; 4];
        assert_eq!(
            CoefficientTable::<4, 4>::try_new(TableForm::Power, 0, 0, 4, rows),
            Err(TableError::Grid)
        );
        assert_eq!(
            CoefficientTable::<4, 4>::try_new(TableForm::Power, 0, 1, 5, rows),
            Err(TableError::RowCount)
        );
        assert_eq!(
            CoefficientTable::<4, 4>::try_new(TableForm::Harmonic { order: 2 }, 0, 1, 4, rows),
            Err(TableError::Width)
        );
        let mut big = rows;
        big[2][1] = MAX_COEFF_IN_Q32 + 1;
        assert_eq!(
            CoefficientTable::<4, 4>::try_new(TableForm::Power, 0, 1 << 20, 4, big),
            Err(TableError::Coefficient)
        );
        // More than 256 cells: (X - x0) * 2^54 / dx could overflow, refused at setup.
        let many = [[0i32; 4]; 300];
        assert_eq!(
            CoefficientTable::<300, 4>::try_new(TableForm::Power, 0, 1 << 10, 300, many),
            Err(TableError::Grid)
        );
        assert!(
            CoefficientTable::<300, 4>::try_new(TableForm::Power, 0, 1 << 10, 257, many).is_ok()
        );
    }

    proptest! {
        #[test]
        fn no_panic_on_any_table_and_input(
            coeffs in proptest::collection::vec(-MAX_COEFF_IN_Q32..=MAX_COEFF_IN_Q32, 6 * 17),
            dx in 1i32..i32::MAX, x0 in any::<i32>(), x in any::<i32>(), phi in any::<u32>(),
            order in 1u8..=8, len in 1usize..=6,
        ) {
            let mut rows = [[0i32; 17]; 6];
            for (i, v) in coeffs.iter().enumerate() { rows[i / 17][i % 17] = *v; }
            if let Ok(t) = CoefficientTable::<6, 17>::try_new(TableForm::Harmonic { order: 8 }, x0, dx, len, rows) {
                let _ = t.eval(x, phi, Interp::Cubic);
                let _ = t.eval(x, phi, Interp::Linear);
            }
            let w = TableForm::Harmonic { order }.width();
            let _ = eval_row(TableForm::Harmonic { order }, &rows[0][..w], phi);
            let _ = eval_row(TableForm::Power, &rows[1][..4], phi);
        }
    }
}
