//! Coefficient tables over `X` on a uniform grid, in the power form the command generator uses,
//! their interpolation (linear, cubic, and the 8080 program's stepped updates) with error
//! figures, and the export for the firmware.
//!
//! Power form (eqs 2-18..2-23): with `cos 2phi = 1 - 2 s^2` and `sin 3phi = 3 s - 4 s^3`,
//! `C0 + S1 sin(phi) + C2 cos(2 phi) + S3 sin(3 phi) = C00 + C01 s + C02 s^2 + C03 s^3` with
//! `C00 = C0 + C2`, `C01 = S1 + 3 S3`, `C02 = -2 C2`, `C03 = -4 S3`.

use super::{finite, positive, Result, TurningError};
use std::f64::consts::PI;

/// One row of the table: the coefficients of eq 2-19 at one `X`, in inches.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PowerRow {
    pub c00_in: f64,
    pub c01_in: f64,
    pub c02_in: f64,
    pub c03_in: f64,
}

impl PowerRow {
    /// Eqs 2-20..2-23 from the four significant harmonics.
    pub fn from_harmonics(c0_in: f64, s1_in: f64, c2_in: f64, s3_in: f64) -> Self {
        Self {
            c00_in: c0_in + c2_in,
            c01_in: s1_in + 3.0 * s3_in,
            c02_in: -2.0 * c2_in,
            c03_in: -4.0 * s3_in,
        }
    }

    /// Back to `(C0, S1, C2, S3)`.
    pub fn to_harmonics(&self) -> (f64, f64, f64, f64) {
        let c2 = -0.5 * self.c02_in;
        let s3 = -0.25 * self.c03_in;
        (self.c00_in - c2, self.c01_in - 3.0 * s3, c2, s3)
    }

    /// `C00 + C01 s + C02 s^2 + C03 s^3` (eq 2-19).
    pub fn eval_in(&self, sin_phi: f64) -> f64 {
        let s = sin_phi;
        self.c00_in + s * (self.c01_in + s * (self.c02_in + s * self.c03_in))
    }

    pub fn as_array(&self) -> [f64; 4] {
        [self.c00_in, self.c01_in, self.c02_in, self.c03_in]
    }

    pub fn from_array(c: [f64; 4]) -> Self {
        Self { c00_in: c[0], c01_in: c[1], c02_in: c[2], c03_in: c[3] }
    }
}

/// How coefficients are found between table rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Straight line between the two neighbouring rows (the thesis's scheme, Chapter 2).
    Linear,
    /// Cubic through the four nearest rows (Lagrange; shifted inwards at the ends).
    Cubic,
    /// The 8080 program of Appendix A: linear, but each coefficient is re-evaluated only at its
    /// update points (X quantised down to 0.010, 0.001, 0.0005, 0.010 in for C00, C01, C02, C03,
    /// i.e. 10, 100, 200, 10 updates per 0.1 in grid cell).
    ThesisUpdates,
}

/// Update interval of each coefficient in the 8080 program, in (C00, C01, C02, C03).
pub const THESIS_UPDATE_INTERVALS_IN: [f64; 4] = [0.010, 0.001, 0.0005, 0.010];

/// A coefficient table on the uniform grid `x_i = x0 + i dx`.
#[derive(Clone, Debug, PartialEq)]
pub struct CoefficientTable {
    x0_in: f64,
    dx_in: f64,
    rows: Vec<PowerRow>,
}

/// Worst-case interpolation errors against a reference `Z(X, phi)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InterpolationError {
    /// Largest `|Z_table - Z_true|` at the grid nodes (series truncation and rounding only), in.
    pub max_at_nodes_in: f64,
    /// Largest error at the middles of the grid cells, in.
    pub max_mid_interval_in: f64,
    /// Largest error over all sampled points, in.
    pub max_in: f64,
    /// Where `max_in` occurred.
    pub worst_x_in: f64,
    pub worst_phi_rad: f64,
}

impl CoefficientTable {
    /// A table from `x0_in` in steps of `dx_in`. Needs at least one row and finite values.
    pub fn new(x0_in: f64, dx_in: f64, rows: Vec<PowerRow>) -> Result<Self> {
        finite("table start X (in)", x0_in)?;
        positive("table step (in)", dx_in)?;
        if rows.is_empty() {
            return Err(TurningError::Table("a table needs at least one row"));
        }
        if rows.iter().any(|r| r.as_array().iter().any(|v| !v.is_finite())) {
            return Err(TurningError::Table("a coefficient is not finite"));
        }
        Ok(Self { x0_in, dx_in, rows })
    }

    /// Builds a table by calling `row(x_in)` at `x0 + i dx`, `i = 0..n`.
    pub fn from_fn(
        x0_in: f64,
        dx_in: f64,
        n: usize,
        mut row: impl FnMut(f64) -> Result<PowerRow>,
    ) -> Result<Self> {
        finite("table start X (in)", x0_in)?;
        positive("table step (in)", dx_in)?;
        let rows = (0..n).map(|i| row(x0_in + i as f64 * dx_in)).collect::<Result<Vec<_>>>()?;
        Self::new(x0_in, dx_in, rows)
    }

    pub fn x0_in(&self) -> f64 {
        self.x0_in
    }
    pub fn dx_in(&self) -> f64 {
        self.dx_in
    }
    pub fn rows(&self) -> &[PowerRow] {
        &self.rows
    }
    pub fn len(&self) -> usize {
        self.rows.len()
    }
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }
    /// `X` of row `i`, in.
    pub fn x_at(&self, i: usize) -> f64 {
        self.x0_in + i as f64 * self.dx_in
    }
    pub fn last_x_in(&self) -> f64 {
        self.x_at(self.rows.len() - 1)
    }

    /// The same table with every coefficient rounded to a multiple of `quantum_in` (1e-7 in for
    /// the 7 decimals of Table 2-2, 1/3.2768 uin for the thesis's DACs).
    pub fn rounded(&self, quantum_in: f64) -> Result<Self> {
        let q = positive("rounding quantum (in)", quantum_in)?;
        let rows = self
            .rows
            .iter()
            .map(|r| PowerRow::from_array(r.as_array().map(|v| (v / q).round() * q)))
            .collect();
        Self::new(self.x0_in, self.dx_in, rows)
    }

    /// Every `k`-th row (a coarser grid over the same range, e.g. 0.2 in from a 0.1 in table).
    pub fn decimated(&self, k: usize) -> Result<Self> {
        if k == 0 {
            return Err(TurningError::Table("decimation factor must be >= 1"));
        }
        let rows = self.rows.iter().step_by(k).copied().collect();
        Self::new(self.x0_in, self.dx_in * k as f64, rows)
    }

    fn check_x(&self, x_in: f64) -> Result<f64> {
        let last = self.last_x_in();
        let tol = 1e-9 * self.dx_in;
        if x_in.is_finite() && x_in >= self.x0_in - tol && x_in <= last + tol {
            Ok(x_in.clamp(self.x0_in, last))
        } else {
            Err(TurningError::OutsideTable { x_in, first_in: self.x0_in, last_in: last })
        }
    }

    /// Index of the cell holding `x` and the fraction across it.
    fn cell(&self, x: f64) -> (usize, f64) {
        let n = self.rows.len();
        if n == 1 {
            return (0, 0.0);
        }
        let u = (x - self.x0_in) / self.dx_in;
        let i = (u.floor().max(0.0) as usize).min(n - 2);
        (i, u - i as f64)
    }

    fn linear(&self, k: usize, x: f64) -> f64 {
        let (i, t) = self.cell(x);
        let a = self.rows[i].as_array()[k];
        if self.rows.len() == 1 {
            return a;
        }
        let b = self.rows[i + 1].as_array()[k];
        a + (b - a) * t
    }

    /// The coefficients at `x_in`. Errors outside the table's range.
    pub fn coefficients_at(&self, x_in: f64, interp: Interpolation) -> Result<PowerRow> {
        let x = self.check_x(x_in)?;
        let n = self.rows.len();
        Ok(match interp {
            Interpolation::Linear => {
                PowerRow::from_array(std::array::from_fn(|k| self.linear(k, x)))
            }
            Interpolation::ThesisUpdates => PowerRow::from_array(std::array::from_fn(|k| {
                let q = THESIS_UPDATE_INTERVALS_IN[k];
                // Quantise the position within the cell, as the 8080 counts update steps from
                // the node: value = T[i] + slope * k.
                let (i, t) = self.cell(x);
                let steps = (t * self.dx_in / q + 1e-9).floor();
                let xq = self.x_at(i) + steps * q;
                self.linear(k, xq.min(self.last_x_in()))
            })),
            Interpolation::Cubic => {
                if n < 4 {
                    PowerRow::from_array(std::array::from_fn(|k| self.linear(k, x)))
                } else {
                    let (i, _) = self.cell(x);
                    let start = i.saturating_sub(1).min(n - 4);
                    let u = (x - self.x_at(start)) / self.dx_in;
                    // Lagrange weights for nodes 0, 1, 2, 3 at u.
                    let w = [
                        -(u - 1.0) * (u - 2.0) * (u - 3.0) / 6.0,
                        u * (u - 2.0) * (u - 3.0) / 2.0,
                        -u * (u - 1.0) * (u - 3.0) / 2.0,
                        u * (u - 1.0) * (u - 2.0) / 6.0,
                    ];
                    PowerRow::from_array(std::array::from_fn(|k| {
                        (0..4).map(|j| w[j] * self.rows[start + j].as_array()[k]).sum()
                    }))
                }
            }
        })
    }

    /// The command `Z(X, phi)` the table gives (eq 2-19 with interpolated coefficients), in.
    pub fn z_in(&self, x_in: f64, phi_rad: f64, interp: Interpolation) -> Result<f64> {
        finite("spindle angle (rad)", phi_rad)?;
        Ok(self.coefficients_at(x_in, interp)?.eval_in(phi_rad.sin()))
    }

    /// Interpolation error against `truth(X, phi)` over the whole table: at every node, at every
    /// cell middle and at `points_per_cell` evenly spaced points inside each cell, each at
    /// `phi_samples` spindle angles evenly spaced over a revolution.
    pub fn interpolation_error(
        &self,
        mut truth: impl FnMut(f64, f64) -> Result<f64>,
        interp: Interpolation,
        phi_samples: usize,
        points_per_cell: usize,
    ) -> Result<InterpolationError> {
        if phi_samples == 0 {
            return Err(TurningError::Table("need at least one spindle angle"));
        }
        let mut e = InterpolationError::default();
        let n = self.rows.len();
        let sub = points_per_cell.max(2);
        let mut visit = |x: f64, kind: u8, e: &mut InterpolationError| -> Result<()> {
            let row = self.coefficients_at(x, interp)?;
            for j in 0..phi_samples {
                let phi = 2.0 * PI * j as f64 / phi_samples as f64;
                let err = (row.eval_in(phi.sin()) - truth(x, phi)?).abs();
                match kind {
                    0 => e.max_at_nodes_in = e.max_at_nodes_in.max(err),
                    1 => e.max_mid_interval_in = e.max_mid_interval_in.max(err),
                    _ => {}
                }
                if err > e.max_in {
                    e.max_in = err;
                    e.worst_x_in = x;
                    e.worst_phi_rad = phi;
                }
            }
            Ok(())
        };
        for i in 0..n {
            visit(self.x_at(i), 0, &mut e)?;
            if i + 1 < n {
                visit(self.x_at(i) + 0.5 * self.dx_in, 1, &mut e)?;
                for k in 1..sub {
                    visit(self.x_at(i) + self.dx_in * k as f64 / sub as f64, 2, &mut e)?;
                }
            }
        }
        Ok(e)
    }

    /// The table in the plain form the firmware will take.
    pub fn export(&self) -> ExportTable {
        ExportTable {
            x0_in: self.x0_in,
            dx_in: self.dx_in,
            rows: self
                .rows
                .iter()
                .enumerate()
                .map(|(i, r)| ExportRow {
                    x_in: self.x_at(i),
                    c00_in: r.c00_in,
                    c01_in: r.c01_in,
                    c02_in: r.c02_in,
                    c03_in: r.c03_in,
                })
                .collect(),
        }
    }
}

/// A coefficient table as plain data for the firmware: rows at `x0_in + i dx_in`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportTable {
    pub x0_in: f64,
    pub dx_in: f64,
    pub rows: Vec<ExportRow>,
}

/// One exported row: `Z = c00 + c01 s + c02 s^2 + c03 s^3`, `s = sin(phi)`, at radius `x_in`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExportRow {
    pub x_in: f64,
    pub c00_in: f64,
    pub c01_in: f64,
    pub c02_in: f64,
    pub c03_in: f64,
}

impl ExportTable {
    /// Back to a [`CoefficientTable`] (checks the grid is uniform and the values finite).
    pub fn to_table(&self) -> Result<CoefficientTable> {
        for (i, r) in self.rows.iter().enumerate() {
            let expect = self.x0_in + i as f64 * self.dx_in;
            if (r.x_in - expect).abs() > 1e-9 * self.dx_in.abs().max(1.0) {
                return Err(TurningError::Table("exported rows are not on a uniform grid"));
            }
        }
        CoefficientTable::new(
            self.x0_in,
            self.dx_in,
            self.rows
                .iter()
                .map(|r| PowerRow {
                    c00_in: r.c00_in,
                    c01_in: r.c01_in,
                    c02_in: r.c02_in,
                    c03_in: r.c03_in,
                })
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_is_exact_for_cubics_and_linear_for_lines() {
        let f = |x: f64| 1e-3 * x * x * x - 2e-3 * x + 5e-4;
        let t = CoefficientTable::from_fn(0.0, 0.5, 9, |x| {
            Ok(PowerRow { c00_in: f(x), c01_in: 2.0 * x, ..Default::default() })
        })
        .unwrap();
        for x in [0.0, 0.1, 0.26, 1.9, 3.77, 4.0] {
            let c = t.coefficients_at(x, Interpolation::Cubic).unwrap();
            assert!((c.c00_in - f(x)).abs() < 1e-15, "{x}");
            let l = t.coefficients_at(x, Interpolation::Linear).unwrap();
            assert!((l.c01_in - 2.0 * x).abs() < 1e-14, "{x}");
        }
    }

    #[test]
    fn single_row_table() {
        let t = CoefficientTable::new(1.0, 0.1, vec![PowerRow::from_array([1.0, 2.0, 3.0, 4.0])])
            .unwrap();
        assert_eq!(t.coefficients_at(1.0, Interpolation::Cubic).unwrap().c03_in, 4.0);
        assert!(t.coefficients_at(1.05, Interpolation::Linear).is_err());
    }
}
