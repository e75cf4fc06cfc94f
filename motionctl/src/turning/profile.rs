//! Non-round profiles for the same command generator: a part whose cross-section is `r(phi)`
//! (an oval piston, a plate cam) turned with the fast slide moving radially while the feed axis
//! traverses the length. The table form is the one of the paraboloid: at each feed position `X`
//! the radius over a revolution, as a Fourier series in the spindle angle, less the gross radius
//! (the largest, so `Z <= 0` as in the thesis) that the cross slide holds.
//!
//! Two families, read by `--profile FILE`:
//! * an ellipse, `.toml`: semi-axes along `phi = 0` and `phi = 90 deg`, the centre's offset from
//!   the spindle axis, and optionally the semi-axes at the end of the feed (a linear taper);
//! * a cam, `.csv`: points `theta_deg, r` through which a periodic cubic spline passes.
//!
//! Lengths are in the file's unit (`units = "mm"` in the TOML, an `r_mm` / `r_in` header in the
//! CSV), else in `--units`.

use super::units::Units;
use anyhow::{anyhow, bail, Result};
use std::f64::consts::PI;
use std::path::Path;

/// Most points of a cam profile (a spline of this size solves in well under a millisecond).
pub const MAX_CAM_POINTS: usize = 100_000;

/// An ellipse `((x - cx)/a)^2 + ((y - cy)/b)^2 = 1` about the spindle axis, its semi-axes
/// changing linearly from `start` at `X = 0` to `end` at `X = x_max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    /// Semi-axes `(a, b)` at the start, inches.
    pub start_in: (f64, f64),
    /// Semi-axes at `X = x_max`, inches (the start's for a cylinder).
    pub end_in: (f64, f64),
    /// Centre offset `(cx, cy)` from the spindle axis, inches.
    pub centre_in: (f64, f64),
}

impl Ellipse {
    /// Checks the shape: semi-axes finite and > 0, the spindle axis inside the ellipse at both
    /// ends (else a ray from the axis does not meet the outline once).
    pub fn new(start_in: (f64, f64), end_in: (f64, f64), centre_in: (f64, f64)) -> Result<Self> {
        for (name, v) in [
            ("semi_axis_x", start_in.0),
            ("semi_axis_y", start_in.1),
            ("semi_axis_x_end", end_in.0),
            ("semi_axis_y_end", end_in.1),
        ] {
            if !(v.is_finite() && v > 0.0) {
                bail!("{name} must be a finite length > 0 (got {v})");
            }
        }
        for (name, v) in [("centre_x", centre_in.0), ("centre_y", centre_in.1)] {
            if !v.is_finite() {
                bail!("{name} must be finite (got {v})");
            }
        }
        for (a, b) in [start_in, end_in] {
            let inside = (centre_in.0 / a).powi(2) + (centre_in.1 / b).powi(2);
            if inside >= 1.0 {
                bail!(
                    "the centre offset ({}, {}) puts the spindle axis outside the ellipse with \
                     semi-axes {a} x {b} in: every ray from the axis must meet the outline once",
                    centre_in.0,
                    centre_in.1
                );
            }
        }
        Ok(Ellipse { start_in, end_in, centre_in })
    }

    /// Semi-axes at feed fraction `t` in `0..=1`.
    fn axes(&self, t: f64) -> (f64, f64) {
        let (a0, b0) = self.start_in;
        let (a1, b1) = self.end_in;
        (a0 + (a1 - a0) * t, b0 + (b1 - b0) * t)
    }

    /// Distance from the spindle axis to the outline along the ray at `phi_rad`, at feed
    /// fraction `t`: the positive root of `A s^2 - 2 B s + C = 0` (`C < 0`: the axis is inside).
    pub fn radius_in(&self, t: f64, phi_rad: f64) -> f64 {
        let (a, b) = self.axes(t);
        let (s, c) = phi_rad.sin_cos();
        let (cx, cy) = self.centre_in;
        let qa = (c / a).powi(2) + (s / b).powi(2);
        let qb = cx * c / (a * a) + cy * s / (b * b);
        let qc = (cx / a).powi(2) + (cy / b).powi(2) - 1.0;
        // s = (B + sqrt(B^2 - A C)) / A = -C / (sqrt(B^2 - A C) - B), whichever cancels less.
        let root = (qb * qb - qa * qc).sqrt();
        if qb >= 0.0 {
            (qb + root) / qa
        } else {
            -qc / (root - qb)
        }
    }
}

/// A periodic cubic spline `r(theta)` through the points of a cam profile.
#[derive(Clone, Debug, PartialEq)]
pub struct Cam {
    /// Knot angles, radians, strictly increasing in `[0, 2 pi)`.
    theta_rad: Vec<f64>,
    r_in: Vec<f64>,
    /// Second derivatives at the knots.
    m: Vec<f64>,
}

impl Cam {
    /// The spline through `(theta_rad, r_in)` (at least 4 points, angles strictly increasing in
    /// `[0, 2 pi)`, radii > 0).
    pub fn new(theta_rad: Vec<f64>, r_in: Vec<f64>) -> Result<Self> {
        let n = theta_rad.len();
        if n < 4 || r_in.len() != n {
            bail!("a cam profile needs at least 4 points (got {n})");
        }
        if n > MAX_CAM_POINTS {
            bail!("a cam profile holds at most {MAX_CAM_POINTS} points (got {n})");
        }
        let h = |i: usize| {
            if i + 1 < n {
                theta_rad[i + 1] - theta_rad[i]
            } else {
                theta_rad[0] + 2.0 * PI - theta_rad[n - 1]
            }
        };
        // Cyclic tridiagonal system for the second derivatives:
        // h[i-1] M[i-1] + 2 (h[i-1] + h[i]) M[i] + h[i] M[i+1] = 6 (slope[i] - slope[i-1]).
        let slope = |i: usize| (r_in[(i + 1) % n] - r_in[i]) / h(i);
        let prev = |i: usize| (i + n - 1) % n;
        let sub: Vec<f64> = (0..n).map(|i| h(prev(i))).collect();
        let diag: Vec<f64> = (0..n).map(|i| 2.0 * (h(prev(i)) + h(i))).collect();
        let sup: Vec<f64> = (0..n).map(h).collect();
        let rhs: Vec<f64> = (0..n).map(|i| 6.0 * (slope(i) - slope(prev(i)))).collect();
        let m = solve_cyclic(&sub, &diag, &sup, &rhs);
        if m.iter().any(|v| !v.is_finite()) {
            bail!("the cam profile's spline is singular (repeated angles?)");
        }
        Ok(Cam { theta_rad, r_in, m })
    }

    /// `r(phi)`, inches.
    pub fn radius_in(&self, phi_rad: f64) -> f64 {
        let n = self.theta_rad.len();
        let t = phi_rad.rem_euclid(2.0 * PI);
        // The interval [theta_i, theta_i+1) holding t; before the first knot: the wrap interval.
        let i = match self.theta_rad.partition_point(|&k| k <= t) {
            0 => n - 1,
            p => p - 1,
        };
        let j = (i + 1) % n;
        let (t0, mut t1) = (self.theta_rad[i], self.theta_rad[j]);
        if j == 0 {
            t1 += 2.0 * PI;
        }
        let t = if t < t0 { t + 2.0 * PI } else { t };
        let h = t1 - t0;
        let (a, b) = ((t1 - t) / h, (t - t0) / h);
        a * self.r_in[i]
            + b * self.r_in[j]
            + ((a * a * a - a) * self.m[i] + (b * b * b - b) * self.m[j]) * h * h / 6.0
    }
}

/// Solves the cyclic tridiagonal system `sub[i] x[i-1] + diag[i] x[i] + sup[i] x[i+1] = rhs[i]`
/// (indices mod n, n >= 3) by Sherman-Morrison around the Thomas algorithm.
fn solve_cyclic(sub: &[f64], diag: &[f64], sup: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let (alpha, beta) = (sup[n - 1], sub[0]);
    let gamma = -diag[0];
    let mut bb = diag.to_vec();
    bb[0] = diag[0] - gamma;
    bb[n - 1] = diag[n - 1] - alpha * beta / gamma;
    let x = thomas(sub, &bb, sup, rhs);
    let mut u = vec![0.0; n];
    u[0] = gamma;
    u[n - 1] = alpha;
    let z = thomas(sub, &bb, sup, &u);
    let fact = (x[0] + beta * x[n - 1] / gamma) / (1.0 + z[0] + beta * z[n - 1] / gamma);
    x.iter().zip(&z).map(|(xi, zi)| xi - fact * zi).collect()
}

/// Tridiagonal solve (no pivoting: the spline's system is diagonally dominant).
fn thomas(sub: &[f64], diag: &[f64], sup: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let mut c = vec![0.0; n];
    let mut d = vec![0.0; n];
    c[0] = sup[0] / diag[0];
    d[0] = rhs[0] / diag[0];
    for i in 1..n {
        let den = diag[i] - sub[i] * c[i - 1];
        c[i] = sup[i] / den;
        d[i] = (rhs[i] - sub[i] * d[i - 1]) / den;
    }
    let mut x = vec![0.0; n];
    x[n - 1] = d[n - 1];
    for i in (0..n - 1).rev() {
        x[i] = d[i] - c[i] * x[i + 1];
    }
    x
}

/// A profile read from a file.
#[derive(Clone, Debug, PartialEq)]
pub enum Profile {
    Ellipse(Ellipse),
    Cam(Cam),
}

impl Profile {
    /// `r(X, phi)`, inches, at feed fraction `t = X / x_max`.
    pub fn radius_in(&self, t: f64, phi_rad: f64) -> f64 {
        match self {
            Profile::Ellipse(e) => e.radius_in(t, phi_rad),
            Profile::Cam(c) => c.radius_in(phi_rad),
        }
    }

    pub fn describe(&self, units: Units) -> String {
        let u = |v: f64| format!("{:.4} {}", units.from_in(v), units.name());
        match self {
            Profile::Ellipse(e) => {
                let taper = if e.end_in != e.start_in {
                    format!(" -> {} x {} at the end", u(e.end_in.0), u(e.end_in.1))
                } else {
                    String::new()
                };
                format!(
                    "ellipse, semi-axes {} x {}{taper}, centre offset ({}, {})",
                    u(e.start_in.0),
                    u(e.start_in.1),
                    u(e.centre_in.0),
                    u(e.centre_in.1)
                )
            }
            Profile::Cam(c) => format!("cam profile, {} points r(theta)", c.theta_rad.len()),
        }
    }
}

/// Reads `--profile FILE`: `.toml` an ellipse, `.csv` (or `.txt`) cam points.
pub fn read(path: &Path, units: Units) -> Result<Profile> {
    let name = path.display().to_string();
    let src = std::fs::read_to_string(path).map_err(|e| anyhow!("reading {name}: {e}"))?;
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("toml") => parse_ellipse(&name, &src, units).map(Profile::Ellipse),
        Some("csv" | "txt") => parse_cam(&name, &src, units).map(Profile::Cam),
        _ => bail!("{name}: a profile is an ellipse (.toml) or cam points r(theta) (.csv)"),
    }
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct EllipseFile {
    ellipse: EllipseSection,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct EllipseSection {
    units: Option<String>,
    semi_axis_x: f64,
    semi_axis_y: f64,
    #[serde(default)]
    centre_x: f64,
    #[serde(default)]
    centre_y: f64,
    semi_axis_x_end: Option<f64>,
    semi_axis_y_end: Option<f64>,
}

fn file_units(name: &str, u: Option<&str>, default: Units) -> Result<Units> {
    match u {
        None => Ok(default),
        Some("in") => Ok(Units::In),
        Some("mm") => Ok(Units::Mm),
        Some(other) => bail!("{name}: units = {other:?}: must be \"in\" or \"mm\""),
    }
}

/// An ellipse profile: `[ellipse]` with `semi_axis_x`, `semi_axis_y` (along phi = 0 and 90
/// deg), optional `centre_x`, `centre_y` (offset from the spindle axis), `semi_axis_x_end`,
/// `semi_axis_y_end` (at the end of the feed) and `units`.
pub fn parse_ellipse(name: &str, src: &str, default: Units) -> Result<Ellipse> {
    let f: EllipseFile = toml::from_str(src).map_err(|e| anyhow!("{name}: {e}"))?;
    let e = f.ellipse;
    let u = file_units(name, e.units.as_deref(), default)?;
    let start = (u.to_in(e.semi_axis_x), u.to_in(e.semi_axis_y));
    let end = (
        e.semi_axis_x_end.map_or(start.0, |v| u.to_in(v)),
        e.semi_axis_y_end.map_or(start.1, |v| u.to_in(v)),
    );
    Ellipse::new(start, end, (u.to_in(e.centre_x), u.to_in(e.centre_y)))
        .map_err(|e| anyhow!("{name}: [ellipse] {e}"))
}

/// Cam points: one `theta_deg, r` per line (commas or blanks), `#` comments, an optional header
/// (`theta_deg,r_mm` names the unit). Angles strictly increasing in `[0, 360)`, radii > 0.
pub fn parse_cam(name: &str, src: &str, default: Units) -> Result<Cam> {
    let mut units = default;
    let mut header_seen = false;
    let (mut theta, mut r) = (Vec::new(), Vec::new());
    for (i, raw) in src.lines().enumerate() {
        let line = i + 1;
        let text = raw.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let f = fields(raw);
        if !header_seen
            && theta.is_empty()
            && f.first().is_some_and(|c| c.1.parse::<f64>().is_err())
        {
            header_seen = true;
            if let Some(&(col, unit_name)) = f.get(1) {
                units = match unit_name.to_ascii_lowercase().rsplit_once('_') {
                    Some((_, "mm")) => Units::Mm,
                    Some((_, "in")) => Units::In,
                    _ => bail!(
                        "{name}:{line}:{col}: header `{unit_name}`: name the radius column r_mm \
                         or r_in"
                    ),
                };
            }
            continue;
        }
        if f.len() != 2 {
            let col = f.get(2).map_or(1, |c| c.0);
            bail!("{name}:{line}:{col}: {} values, a cam point is `theta_deg, r`", f.len());
        }
        let num = |k: usize| -> Result<f64> {
            let (col, t) = f[k];
            match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => bail!("{name}:{line}:{col}: `{t}` is not a finite number"),
            }
        };
        let (deg, radius) = (num(0)?, num(1)?);
        if !(0.0..360.0).contains(&deg) || theta.last().is_some_and(|&p| deg.to_radians() <= p) {
            bail!(
                "{name}:{line}:{}: theta = {deg} deg: angles must increase strictly within \
                 [0, 360)",
                f[0].0
            );
        }
        if radius <= 0.0 {
            bail!("{name}:{line}:{}: r = {radius}: radii must be > 0", f[1].0);
        }
        if theta.len() == MAX_CAM_POINTS {
            bail!("{name}:{line}: more than {MAX_CAM_POINTS} points");
        }
        theta.push(deg.to_radians());
        r.push(radius);
    }
    let r_in = r.into_iter().map(|v| units.to_in(v)).collect();
    Cam::new(theta, r_in).map_err(|e| anyhow!("{name}: {e}"))
}

/// Fields of a line split at blanks and commas, with 1-based columns.
fn fields(line: &str) -> Vec<(usize, &str)> {
    super::table_file::fields_by(line, |c| c.is_whitespace() || c == ',')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ellipse_radius_on_the_axes_and_off_centre() {
        let e = Ellipse::new((2.0, 1.0), (2.0, 1.0), (0.0, 0.0)).unwrap();
        assert!((e.radius_in(0.0, 0.0) - 2.0).abs() < 1e-15);
        assert!((e.radius_in(0.0, PI / 2.0) - 1.0).abs() < 1e-15);
        // A circle of radius 1 centred at (0.5, 0): r(0) = 1.5, r(pi) = 0.5.
        let c = Ellipse::new((1.0, 1.0), (1.0, 1.0), (0.5, 0.0)).unwrap();
        assert!((c.radius_in(0.0, 0.0) - 1.5).abs() < 1e-15);
        assert!((c.radius_in(0.0, PI) - 0.5).abs() < 1e-15);
        assert!(Ellipse::new((1.0, 1.0), (1.0, 1.0), (1.0, 0.0)).is_err());
    }

    #[test]
    fn spline_reproduces_a_trigonometric_cam_and_passes_its_points() {
        let f = |t: f64| 1.0 + 0.01 * (2.0 * t).cos() + 0.003 * t.sin();
        let n = 180;
        let th: Vec<f64> = (0..n).map(|i| 2.0 * PI * i as f64 / n as f64).collect();
        let cam = Cam::new(th.clone(), th.iter().map(|&t| f(t)).collect()).unwrap();
        for &t in &th {
            assert!((cam.radius_in(t) - f(t)).abs() < 1e-14);
        }
        for k in 0..1000 {
            let t = 2.0 * PI * k as f64 / 1000.0 + 0.0123;
            assert!((cam.radius_in(t) - f(t)).abs() < 2e-8, "{t}");
        }
    }
}
