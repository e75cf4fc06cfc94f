//! Thesis-exact mode: the FORTRAN program FOREX4 and the SSP subroutine FORIF of Douglass (1983),
//! Appendix B-1 (seed l.2252-2365), transcribed statement by statement in f64.
//!
//! The listing's constants are kept: `C = 316.7` (not `4 x 79.15 = 316.6`), `SY = 28`,
//! `RT = .125`, `N = 360` (721 samples per revolution), `M = 4`, `pi = 3.141593`, three passes of
//! the tool-nose fixed point, `X = (I - 1) * .1`. The evaluation order of every expression follows
//! the FORTRAN (left to right, `x**2` as `x*x`). With these, [`forex4`] reproduces all 324 values
//! of Table 2-2 when printed with `F10.7` ([`format_for30`]).
//!
//! One deliberate difference: the FORTRAN literals (`.1`, `316.7`, `3.141593`) are REAL*4
//! constants to a strict compiler; here they are the f64 nearest the decimal.
//! [`Forex4Params::single_precision_literals`] gives the other reading; both print Table 2-2.

use super::table::{CoefficientTable, PowerRow};
use super::{non_negative, positive, Result, TurningError};

/// FORIF's value of pi (`CONST=3.141593*COEF`), kept on purpose: it is part of the listing.
#[allow(clippy::approx_constant)]
pub const FORIF_PI: f64 = 3.141593;

/// The constants of FOREX4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Forex4Params {
    /// `C` (= 4 x focal length), in. Listing: 316.7.
    pub c_in: f64,
    /// `SY`, in. Listing: 28.0.
    pub offset_in: f64,
    /// `RT`, in. Listing: .125 (0 turns compensation off; Chapter 3's maxima are uncompensated).
    pub tool_nose_radius_in: f64,
    /// FORIF's `N`: `2N + 1` samples per revolution. Listing: 360.
    pub n: usize,
    /// FORIF's `M`: highest harmonic. Listing: 4.
    pub m: usize,
    /// The value of pi in FORIF's `CONST = 3.141593 * COEF`.
    pub pi: f64,
    /// Passes through statement 1000 (the listing exits on `ITER1 .EQ. 3`). At least 1.
    pub iterations: usize,
    /// X step, in. Listing: .1
    pub x_step_in: f64,
    /// Number of table rows. Listing: 81.
    pub rows: usize,
}

impl Default for Forex4Params {
    fn default() -> Self {
        Self::listing()
    }
}

impl Forex4Params {
    /// Appendix B-1 exactly.
    pub fn listing() -> Self {
        Self {
            c_in: 316.7,
            offset_in: 28.0,
            tool_nose_radius_in: 0.125,
            n: 360,
            m: 4,
            pi: FORIF_PI,
            iterations: 3,
            x_step_in: 0.1,
            rows: 81,
        }
    }

    /// The listing with its REAL*4 literals (`316.7`, `.1`, `3.141593`) widened from f32, as a
    /// strict FORTRAN 77 compiler would store them.
    pub fn single_precision_literals() -> Self {
        Self {
            c_in: f64::from(316.7f32),
            pi: f64::from(FORIF_PI as f32),
            x_step_in: f64::from(0.1f32),
            ..Self::listing()
        }
    }

    fn validate(&self) -> Result<()> {
        positive("C (in)", self.c_in)?;
        positive("SY (in)", self.offset_in)?;
        non_negative("RT (in)", self.tool_nose_radius_in)?;
        positive("pi", self.pi)?;
        positive("X step (in)", self.x_step_in)?;
        if self.iterations == 0 {
            return Err(TurningError::Table(
                "FOREX4 needs at least one pass through statement 1000",
            ));
        }
        if self.rows == 0 {
            return Err(TurningError::Table("FOREX4 needs at least one row"));
        }
        if self.m > self.n {
            return Err(TurningError::Forif { n: self.n, m: self.m, ier: 1 });
        }
        if self.m < 3 {
            return Err(TurningError::Table("FOREX4 needs M >= 3 (it reads C0, S1, C2, S3)"));
        }
        Ok(())
    }
}

/// One pass of FOREX4's DO 2 loop: what it writes to unit 5 (`I11, X1, Y, XTC, YTC`) and 30.
#[derive(Clone, Debug, PartialEq)]
pub struct Forex4Row {
    /// `X12(I11)`: tabulated tool-centre radius, in.
    pub x_in: f64,
    /// `X1`: contact radius at which `FUN` was evaluated, in.
    pub x1_in: f64,
    /// `Y`: gross path at `X1`, in.
    pub y_in: f64,
    /// `XTC`, `YTC`: tool centre from the last pass, in.
    pub xtc_in: f64,
    pub ytc_in: f64,
    /// FORIF's `A(1..M+1)` = `C0, C1, ..., CM` (with `A(1)` halved), in.
    pub cos_in: Vec<f64>,
    /// FORIF's `B(1..M+1)` = `S0 (= 0), S1, ..., SM`, in.
    pub sin_in: Vec<f64>,
    /// `C00..C03` (eqs 2-20..2-23).
    pub power: PowerRow,
}

/// The SSP subroutine FORIF: Fourier coefficients `A(j) = C_{j-1}`, `B(j) = S_{j-1}`,
/// `j = 1..M+1`, of `fun` on `[0, 2 pi]` from the `2N + 1` samples `fun(k 2 pi / (2N + 1))`,
/// with Goertzel's recurrence over `k = 2N .. 1` and the angle rotated by recurrence.
/// `pi` is the value FORIF uses (the listing: 3.141593). `fun` is called `(M+1)(2N) + 1` times.
/// IER = 1 (`M > N`) becomes an error (`M < 0`, IER = 2, cannot occur with `usize`).
pub fn forif(
    mut fun: impl FnMut(f64) -> f64,
    n: usize,
    m: usize,
    pi: f64,
) -> Result<(Vec<f64>, Vec<f64>)> {
    if m > n {
        return Err(TurningError::Forif { n, m, ier: 1 });
    }
    let mut a = vec![0.0; m + 1];
    let mut b = vec![0.0; m + 1];
    let an = n as f64;
    let coef = 2.0 / (2.0 * an + 1.0);
    let konst = pi * coef;
    let s1 = konst.sin();
    let c1 = konst.cos();
    let mut c = 1.0;
    let mut s = 0.0;
    let funz = fun(0.0);
    for j in 0..=m {
        // 70
        let mut u2 = 0.0;
        let mut u1 = 0.0;
        let mut ai = (2 * n) as f64;
        // 75 .. IF(AI) 80,80,75
        while ai > 0.0 {
            let x = ai * konst;
            let u0 = fun(x) + 2.0 * c * u1 - u2;
            u2 = u1;
            u1 = u0;
            ai -= 1.0;
        }
        // 80
        a[j] = coef * (funz + c * u1 - u2);
        b[j] = coef * s * u1;
        // 90
        let q = c1 * c - s1 * s;
        s = c1 * s + s1 * c;
        c = q;
    }
    // 100
    a[0] *= 0.5;
    Ok((a, b))
}

/// FOREX4: the coefficient table of Table 2-2 (with [`Forex4Params::listing`]).
pub fn forex4(params: &Forex4Params) -> Result<Vec<Forex4Row>> {
    params.validate()?;
    let (c, sy, rt) = (params.c_in, params.offset_in, params.tool_nose_radius_in);
    let sth = 2.0 * sy / (c * c + 4.0 * sy * sy).sqrt();
    let cth = c / (c * c + 4.0 * sy * sy).sqrt();
    let a = c / (2.0 * cth * (sth * sth));
    let a1 = 2.0 * cth / (a * sth);
    let a2 = 2.0 * cth / (a * c);
    let a3 = c / (2.0 * sy);
    let mut rows = Vec::with_capacity(params.rows);
    for i11 in 1..=params.rows {
        let x = (i11 - 1) as f64 * params.x_step_in;
        let mut iter1 = 0;
        let mut x1 = x;
        // 1000
        let (a1x, a2x2, a3x, y, xtc, alpha) = loop {
            iter1 += 1;
            let a1x = a1 * x1;
            let a2x2 = a2 * x1 * x1;
            let a3x = a3 * x1;
            let t = x1 * sth / sy;
            let y = (c / (2.0 * cth)) * (1.0 - (1.0 - t * t).sqrt());
            let dy = x1;
            let dx = (sy / sth) - y;
            let alpha = (dy / dx).atan();
            let xtc = x1 - rt * alpha.sin();
            if iter1 >= params.iterations {
                break (a1x, a2x2, a3x, y, xtc, alpha);
            }
            x1 = x + x1 - xtc;
        };
        // 1001
        let ytc = y + rt * alpha.cos();
        let mut bad = None;
        let fun = |phi: f64| {
            let sph = phi.sin();
            let v =
                a * (1.0 - (1.0 + a1x * sph + a2x2 * (sph * sph) - a2x2).sqrt()) + a3x * sph - y;
            if !v.is_finite() && bad.is_none() {
                bad = Some(phi);
            }
            v
        };
        let (co, si) = forif(fun, params.n, params.m, params.pi)?;
        if let Some(phi_rad) = bad {
            return Err(TurningError::SurfaceNotFinite { x_in: x1, phi_rad });
        }
        let (c0, s1, c2, s3) = (co[0], si[1], co[2], si[3]);
        let power = PowerRow {
            c00_in: c0 + c2,
            c01_in: s1 + 3.0 * s3,
            c02_in: -2. * c2,
            c03_in: -4.0 * s3,
        };
        rows.push(Forex4Row {
            x_in: x,
            x1_in: x1,
            y_in: y,
            xtc_in: xtc,
            ytc_in: ytc,
            cos_in: co,
            sin_in: si,
            power,
        });
    }
    Ok(rows)
}

/// FOREX4's rows as a [`CoefficientTable`] (uniform grid from 0 with the listing's step).
pub fn forex4_table(params: &Forex4Params) -> Result<CoefficientTable> {
    let rows = forex4(params)?;
    CoefficientTable::new(0.0, params.x_step_in, rows.into_iter().map(|r| r.power).collect())
}

/// FORTRAN `Fw.d` output of one value as the thesis's computer printed it: correctly rounded to
/// `d` decimals, right-justified in `w` columns, a leading `-` on every negative value, even one
/// that rounds to zero (`-0.0000000`, as Table 2-2 prints at X = 0.1). A zero prints unsigned:
/// the DEC floating formats of the time had no negative zero, so the `-2.*C2` of a zero `C2` at
/// X = 0 is `0.0000000` in the thesis while IEEE arithmetic gives `-0.0`. A field too narrow is
/// filled with `*` as FORTRAN does.
pub fn fortran_f(value: f64, width: usize, decimals: usize) -> String {
    let v = if value == 0.0 { 0.0 } else { value };
    let s = format!("{v:.decimals$}");
    if s.len() > width {
        "*".repeat(width)
    } else {
        format!("{s:>width$}")
    }
}

/// The lines of FOR30.DAT: FORMAT `(F4.1,'|',F10.7,'|',F10.7,'|',F10.7,'|',F10.7)`.
pub fn format_for30(table: &CoefficientTable) -> Vec<String> {
    table
        .rows()
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let x = table.x_at(i);
            format!(
                "{}|{}|{}|{}|{}",
                fortran_f(x, 4, 1),
                fortran_f(r.c00_in, 10, 7),
                fortran_f(r.c01_in, 10, 7),
                fortran_f(r.c02_in, 10, 7),
                fortran_f(r.c03_in, 10, 7)
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forif_rejects_m_above_n() {
        assert!(matches!(forif(|_| 0.0, 2, 3, FORIF_PI), Err(TurningError::Forif { ier: 1, .. })));
    }

    #[test]
    fn forif_calls_fun_as_the_listing_does() {
        let mut calls = 0;
        forif(
            |_| {
                calls += 1;
                1.0
            },
            360,
            4,
            FORIF_PI,
        )
        .unwrap();
        assert_eq!(calls, 5 * 720 + 1);
    }

    #[test]
    fn negative_zero_prints_unsigned() {
        assert_eq!(fortran_f(-2.0 * 0.0, 10, 7), " 0.0000000");
    }
}
