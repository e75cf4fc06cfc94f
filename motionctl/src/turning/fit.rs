//! Harmonic fit of any surface, in the spirit of FORIF but accurate: the surface `z(x, y)` (the
//! axial height of the part in the machine frame, `x = X cos(phi)`, `y = X sin(phi)`, eq 2-5) is
//! sampled around the circle of radius `X` and expanded as
//! `z = C0 + sum_i [Ci cos(i phi) + Si sin(i phi)]` (eq 2-17).
//!
//! The transform is a direct DFT with exactly reduced angles (`cos(2 pi (i k mod N) / N)`) and
//! compensated summation, so its rounding error stays near one ulp of the largest sample instead
//! of growing with `N` as Goertzel's recurrence in FORIF does.
//!
//! The surface may be a function ([`fit_ring`], [`table_from_surface`]) or samples on a
//! rectangular grid ([`CartesianGrid`], bicubic interpolation).

use super::table::{CoefficientTable, PowerRow};
use super::{finite, positive, Result, TurningError};
use std::f64::consts::PI;

/// Fourier coefficients of one revolution: `cos_in[i] = Ci`, `sin_in[i] = Si` (`S0 = 0`), in.
#[derive(Clone, Debug, PartialEq)]
pub struct Harmonics {
    pub cos_in: Vec<f64>,
    pub sin_in: Vec<f64>,
}

impl Harmonics {
    /// Highest order held.
    pub fn max_order(&self) -> usize {
        self.cos_in.len().saturating_sub(1)
    }

    fn c(&self, i: usize) -> f64 {
        self.cos_in.get(i).copied().unwrap_or(0.0)
    }
    fn s(&self, i: usize) -> f64 {
        self.sin_in.get(i).copied().unwrap_or(0.0)
    }

    /// The series at `phi_rad`.
    pub fn eval_in(&self, phi_rad: f64) -> f64 {
        let mut z = self.c(0);
        for i in 1..=self.max_order() {
            let (s, c) = (i as f64 * phi_rad).sin_cos();
            z += self.c(i) * c + self.s(i) * s;
        }
        z
    }

    /// `dz/dphi` of the series.
    pub fn derivative_in_per_rad(&self, phi_rad: f64) -> f64 {
        (1..=self.max_order())
            .map(|i| {
                let (s, c) = (i as f64 * phi_rad).sin_cos();
                i as f64 * (self.s(i) * c - self.c(i) * s)
            })
            .sum()
    }

    /// Eq 2-18 in power form: `C0, S1, C2, S3` only.
    pub fn power_row(&self) -> PowerRow {
        PowerRow::from_harmonics(self.c(0), self.s(1), self.c(2), self.s(3))
    }

    /// Sum of `|coefficient|` over the terms the power form drops (`C1`, `S2`, `C3`, and every
    /// order >= 4): a bound on the error of eq 2-18 for this revolution.
    pub fn neglected_in(&self) -> f64 {
        let mut sum = self.c(1).abs() + self.s(2).abs() + self.c(3).abs();
        for i in 4..=self.max_order() {
            sum += self.c(i).abs() + self.s(i).abs();
        }
        sum
    }
}

/// Neumaier's compensated sum.
#[derive(Default)]
struct Sum {
    s: f64,
    c: f64,
}

impl Sum {
    fn add(&mut self, v: f64) {
        let t = self.s + v;
        if self.s.abs() >= v.abs() {
            self.c += (self.s - t) + v;
        } else {
            self.c += (v - t) + self.s;
        }
        self.s = t;
    }
    fn get(&self) -> f64 {
        self.s + self.c
    }
}

/// Fourier coefficients up to `max_order` of `samples[k] = z(2 pi k / N)`, `k = 0..N`.
/// Needs `N >= 2 max_order + 1`.
pub fn dft(samples: &[f64], max_order: usize) -> Result<Harmonics> {
    let n = samples.len();
    let needed = 2 * max_order + 1;
    if n < needed {
        return Err(TurningError::TooFewSamples { order: max_order, needed, got: n });
    }
    if let Some(k) = samples.iter().position(|v| !v.is_finite()) {
        return Err(TurningError::SurfaceNotFinite {
            x_in: f64::NAN,
            phi_rad: 2.0 * PI * k as f64 / n as f64,
        });
    }
    let table: Vec<(f64, f64)> =
        (0..n).map(|k| (2.0 * PI * k as f64 / n as f64).sin_cos()).collect();
    let mut cos_in = vec![0.0; max_order + 1];
    let mut sin_in = vec![0.0; max_order + 1];
    let scale = 2.0 / n as f64;
    for i in 0..=max_order {
        let (mut a, mut b) = (Sum::default(), Sum::default());
        for (k, v) in samples.iter().enumerate() {
            let (s, c) = table[(i * k) % n];
            a.add(v * c);
            b.add(v * s);
        }
        cos_in[i] = scale * a.get();
        sin_in[i] = scale * b.get();
    }
    cos_in[0] *= 0.5;
    sin_in[0] = 0.0;
    Ok(Harmonics { cos_in, sin_in })
}

/// Harmonics of `f(phi)` from `samples` evenly spaced angles.
pub fn fit_function(
    mut f: impl FnMut(f64) -> Result<f64>,
    samples: usize,
    max_order: usize,
) -> Result<Harmonics> {
    let v = (0..samples)
        .map(|k| f(2.0 * PI * k as f64 / samples as f64))
        .collect::<Result<Vec<_>>>()?;
    dft(&v, max_order)
}

/// Harmonics of the surface `z(x, y)` around the circle of radius `radius_in`
/// (`x = X cos(phi)`, `y = X sin(phi)`).
pub fn fit_ring(
    mut z: impl FnMut(f64, f64) -> Result<f64>,
    radius_in: f64,
    samples: usize,
    max_order: usize,
) -> Result<Harmonics> {
    let r = finite("ring radius (in)", radius_in)?;
    if r < 0.0 {
        return Err(TurningError::Negative { name: "ring radius (in)", value: r });
    }
    fit_function(
        |phi| {
            let (s, c) = phi.sin_cos();
            let v = z(r * c, r * s)?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(TurningError::SurfaceNotFinite { x_in: r, phi_rad: phi })
            }
        },
        samples,
        max_order,
    )
}

/// What the Y slide (the gross axial path) takes out of the surface before the Z slide gets the
/// rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GrossPath {
    /// Nothing: the Z slide gets the whole height.
    None,
    /// The mean over a revolution (`C0`): Z swings both ways.
    Mean,
    /// The highest point of the revolution, as the thesis does (eq 2-14): `Z <= 0`, touching 0.
    MaxOverPhi,
}

/// A table fitted to a general surface.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceTable {
    /// The Z-slide table (power form, eq 2-19).
    pub table: CoefficientTable,
    /// The gross axial path removed at each row, in.
    pub gross_y_in: Vec<f64>,
    /// The full harmonics of each row (before the gross path is removed).
    pub harmonics: Vec<Harmonics>,
    /// Largest [`Harmonics::neglected_in`] over the rows: how far the surface is from the
    /// four-term form the command generator can produce.
    pub max_neglected_in: f64,
}

/// Options of [`table_from_surface`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceFitOptions {
    pub x0_in: f64,
    pub dx_in: f64,
    pub rows: usize,
    pub samples_per_rev: usize,
    pub max_order: usize,
    pub gross: GrossPath,
}

impl Default for SurfaceFitOptions {
    fn default() -> Self {
        Self {
            x0_in: 0.0,
            dx_in: 0.1,
            rows: 81,
            samples_per_rev: 1440,
            max_order: 19,
            gross: GrossPath::MaxOverPhi,
        }
    }
}

/// Largest value of the series over a revolution: the best of a dense scan, polished by Newton.
fn series_max(h: &Harmonics, scan: usize) -> f64 {
    let scan = scan.max(8);
    let mut best = (f64::NEG_INFINITY, 0.0);
    for k in 0..scan {
        let phi = 2.0 * PI * k as f64 / scan as f64;
        let v = h.eval_in(phi);
        if v > best.0 {
            best = (v, phi);
        }
    }
    let mut phi = best.1;
    let step = 2.0 * PI / scan as f64;
    for _ in 0..30 {
        let d1 = h.derivative_in_per_rad(phi);
        let eps = 1e-4;
        let d2 =
            (h.derivative_in_per_rad(phi + eps) - h.derivative_in_per_rad(phi - eps)) / (2.0 * eps);
        if d2 >= 0.0 || !d2.is_finite() {
            break;
        }
        let dphi = (-d1 / d2).clamp(-step, step);
        phi += dphi;
        if dphi.abs() < 1e-14 {
            break;
        }
    }
    h.eval_in(phi).max(best.0)
}

/// The Z-slide table of a general surface `z(x, y)`: at each `X` the ring is fitted, the gross
/// path removed, and `C0, S1, C2, S3` turned into the power form. No tool-nose compensation.
pub fn table_from_surface(
    mut z: impl FnMut(f64, f64) -> Result<f64>,
    opts: &SurfaceFitOptions,
) -> Result<SurfaceTable> {
    finite("table start X (in)", opts.x0_in)?;
    positive("table step (in)", opts.dx_in)?;
    if opts.x0_in < 0.0 {
        return Err(TurningError::Negative { name: "table start X (in)", value: opts.x0_in });
    }
    let mut rows = Vec::with_capacity(opts.rows);
    let mut gross_y_in = Vec::with_capacity(opts.rows);
    let mut harmonics = Vec::with_capacity(opts.rows);
    let mut max_neglected_in: f64 = 0.0;
    for i in 0..opts.rows {
        let x = opts.x0_in + i as f64 * opts.dx_in;
        let h = fit_ring(&mut z, x, opts.samples_per_rev, opts.max_order.max(3))?;
        let gross = match opts.gross {
            GrossPath::None => 0.0,
            GrossPath::Mean => h.cos_in[0],
            GrossPath::MaxOverPhi => series_max(&h, 4 * opts.samples_per_rev),
        };
        let mut r = h.power_row();
        r.c00_in -= gross;
        max_neglected_in = max_neglected_in.max(h.neglected_in());
        rows.push(r);
        gross_y_in.push(gross);
        harmonics.push(h);
    }
    Ok(SurfaceTable {
        table: CoefficientTable::new(opts.x0_in, opts.dx_in, rows)?,
        gross_y_in,
        harmonics,
        max_neglected_in,
    })
}

/// A surface sampled on a rectangular grid: `z_in[j * nx + i]` at
/// `(x0_in + i dx_in, y0_in + j dy_in)`. Evaluated by bicubic convolution (Keys, a = -1/2;
/// third order, with Keys' cubic extrapolation at the border), so the grid needs at least
/// 3 x 3 points.
#[derive(Clone, Debug, PartialEq)]
pub struct CartesianGrid {
    x0_in: f64,
    y0_in: f64,
    dx_in: f64,
    dy_in: f64,
    nx: usize,
    ny: usize,
    z_in: Vec<f64>,
}

impl CartesianGrid {
    pub fn new(
        x0_in: f64,
        y0_in: f64,
        dx_in: f64,
        dy_in: f64,
        nx: usize,
        ny: usize,
        z_in: Vec<f64>,
    ) -> Result<Self> {
        finite("grid x0 (in)", x0_in)?;
        finite("grid y0 (in)", y0_in)?;
        positive("grid dx (in)", dx_in)?;
        positive("grid dy (in)", dy_in)?;
        if nx < 3 || ny < 3 {
            return Err(TurningError::Grid("bicubic interpolation needs at least 3 x 3 points"));
        }
        if nx.checked_mul(ny) != Some(z_in.len()) {
            return Err(TurningError::Grid("z_in.len() must be nx * ny"));
        }
        if z_in.iter().any(|v| !v.is_finite()) {
            return Err(TurningError::Grid("a grid value is not finite"));
        }
        Ok(Self { x0_in, y0_in, dx_in, dy_in, nx, ny, z_in })
    }

    /// Samples `z(x, y)` on the grid.
    pub fn sample(
        x0_in: f64,
        y0_in: f64,
        dx_in: f64,
        dy_in: f64,
        nx: usize,
        ny: usize,
        mut z: impl FnMut(f64, f64) -> Result<f64>,
    ) -> Result<Self> {
        let mut v = Vec::with_capacity(nx.saturating_mul(ny));
        for j in 0..ny {
            for i in 0..nx {
                v.push(z(x0_in + i as f64 * dx_in, y0_in + j as f64 * dy_in)?);
            }
        }
        Self::new(x0_in, y0_in, dx_in, dy_in, nx, ny, v)
    }

    fn at(&self, i: usize, j: usize) -> f64 {
        self.z_in[j * self.nx + i]
    }

    /// Value at node (i, j) with i, j in -1..=n (Keys' extrapolation beyond the border).
    fn node(&self, i: isize, j: isize) -> f64 {
        let column = |i: isize| -> f64 {
            let ny = self.ny as isize;
            let iu = i as usize;
            match j {
                -1 => 3.0 * self.at(iu, 0) - 3.0 * self.at(iu, 1) + self.at(iu, 2),
                j if j == ny => {
                    let n = self.ny;
                    3.0 * self.at(iu, n - 1) - 3.0 * self.at(iu, n - 2) + self.at(iu, n - 3)
                }
                j => self.at(iu, j as usize),
            }
        };
        let nx = self.nx as isize;
        match i {
            -1 => 3.0 * column(0) - 3.0 * column(1) + column(2),
            i if i == nx => 3.0 * column(nx - 1) - 3.0 * column(nx - 2) + column(nx - 3),
            i => column(i),
        }
    }

    fn keys_weights(t: f64) -> [f64; 4] {
        // a = -1/2 (Catmull-Rom)
        [
            ((-0.5 * t + 1.0) * t - 0.5) * t,
            (1.5 * t - 2.5) * t * t + 1.0,
            ((-1.5 * t + 2.0) * t + 0.5) * t,
            (0.5 * t - 0.5) * t * t,
        ]
    }

    /// `z(x, y)`; errors outside the grid.
    pub fn eval_in(&self, x_in: f64, y_in: f64) -> Result<f64> {
        let u = (x_in - self.x0_in) / self.dx_in;
        let v = (y_in - self.y0_in) / self.dy_in;
        let tol = 1e-9;
        let (ux, vy) = ((self.nx - 1) as f64, (self.ny - 1) as f64);
        if !(u.is_finite()
            && v.is_finite()
            && u >= -tol
            && v >= -tol
            && u <= ux + tol
            && v <= vy + tol)
        {
            return Err(TurningError::OutsideGrid { x_in, y_in });
        }
        let u = u.clamp(0.0, ux);
        let v = v.clamp(0.0, vy);
        let i = (u.floor() as usize).min(self.nx - 2);
        let j = (v.floor() as usize).min(self.ny - 2);
        let wx = Self::keys_weights(u - i as f64);
        let wy = Self::keys_weights(v - j as f64);
        let mut z = 0.0;
        for (b, wyb) in wy.iter().enumerate() {
            let jj = j as isize - 1 + b as isize;
            let mut row = 0.0;
            for (a, wxa) in wx.iter().enumerate() {
                row += wxa * self.node(i as isize - 1 + a as isize, jj);
            }
            z += wyb * row;
        }
        Ok(z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compensated_sum_keeps_small_terms() {
        let mut s = Sum::default();
        for v in [1.0, 1e-16, 1e-16, -1.0] {
            s.add(v);
        }
        assert_eq!(s.get(), 2e-16);
    }

    #[test]
    fn dft_and_series_max() {
        let h =
            fit_function(|phi| Ok(2.0 - 3.0 * (2.0 * phi).cos() + 0.5 * phi.sin()), 16, 3).unwrap();
        assert!((h.cos_in[0] - 2.0).abs() < 1e-15);
        assert!((h.cos_in[2] + 3.0).abs() < 1e-15);
        assert!((h.sin_in[1] - 0.5).abs() < 1e-15);
        // max of 2 - 3 (1 - 2 s^2) + 0.5 s on [-1, 1] is at s = 1: 2 + 3 + 0.5
        assert!((series_max(&h, 64) - 5.5).abs() < 1e-12);
    }
}
