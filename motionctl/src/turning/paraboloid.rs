//! The off-axis paraboloid of Douglass (1983), Chapter 2, and tool-nose compensation.
//!
//! Geometry (eqs 2-1..2-3): the paraboloid `z1 = (x1^2 + y1^2) / c`, `c = 4 p` (`p` = focal
//! length); the sector is centred at `y1 = S_y` (the offset) and the machine frame (subscript 3)
//! is rotated by `theta`, `tan(theta) = 2 S_y / c`, so that its axis is the surface normal there.
//! In cylindrical machine coordinates (`X` = radius, `phi` = spindle angle) eq 2-9 gives
//!
//! ```text
//! Y_t(X, phi) = A (1 - P) + X cot(theta) sin(phi),   A = S_y / sin^3(theta)
//! P^2 = 1 + u,   u = a1 X sin(phi) - a2 X^2 cos^2(phi),
//! a1 = 2 sin^2(theta) cos(theta) / S_y,   a2 = sin^4(theta) / S_y^2
//! ```
//!
//! and the gross axial path (eq 2-14, with the `1 -` the OCR dropped) is the circular arc
//! `Y(X) = R0 - sqrt(R0^2 - X^2)`, `R0 = S_y / sin(theta)`, the highest point per radius while
//! the two maxima of eq 2-11 exist (beyond the radius where they meet at phi = 270 deg, the
//! height there: [`OffAxisParaboloid::gross_y_in`]). The Z slide supplies `Z = Y_t - Y <= 0`
//! (eq 2-15).
//!
//! Eq 2-9 as printed subtracts two numbers near `A = 5304 in` to get a few mils; [`Self::z_in`]
//! uses `1 - P = -u / (1 + P)` instead (`A a1 = 2 cot(theta)`, `A a2 = 1 / R0`):
//!
//! ```text
//! Y_t = X cot(theta) s u / (1 + P)^2 + X^2 cos^2(phi) / (R0 (1 + P))
//! Y   = X^2 / (R0 (1 + sqrt(1 - X^2 / R0^2)))
//! ```
//!
//! Tool nose (Appendix B-1, not in the chapter): a round-nosed tool of radius `RT` whose centre is
//! at radius `X` touches the part at a larger radius. FOREX4 finds the contact radius on the gross
//! arc by three fixed-point iterations; on the arc the contact is exactly
//! `X1 = X R0 / (R0 - RT)` ([`Self::contact_radius_gross_arc_in`]). The exact envelope of the
//! nose circle along each meridian (`phi` fixed) is [`Self::z_tool_centre_envelope_in`].

use super::{non_negative, positive, Result, TurningError};
use std::f64::consts::PI;

/// The off-axis paraboloid sector and the tool that cuts it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffAxisParaboloid {
    /// `c = 4 p` of eq 2-1, in.
    c_in: f64,
    /// `S_y`: distance from the parabola axis to the sector centre, in.
    offset_in: f64,
    /// Sector diameter, in (the table covers `0 <= X <= sector_diameter_in / 2`).
    sector_diameter_in: f64,
    /// Tool-nose radius, in (0 = sharp tool, no compensation).
    tool_nose_radius_in: f64,
    // Derived.
    sin_theta: f64,
    cos_theta: f64,
    cot_theta: f64,
    r0_in: f64,
    a_in: f64,
    a1_per_in: f64,
    a2_per_in2: f64,
}

impl OffAxisParaboloid {
    /// A paraboloid of focal length `focal_length_in` (`c = 4 p`), sector centre `offset_in` off
    /// the axis, sector diameter `sector_diameter_in`, cut by a tool of nose radius
    /// `tool_nose_radius_in` (0 for no compensation). Errors if a number is non-finite or out of
    /// range, or if the sector (and the tool-nose contact beyond it) leaves the part of the
    /// paraboloid the machine frame can describe.
    pub fn new(
        focal_length_in: f64,
        offset_in: f64,
        sector_diameter_in: f64,
        tool_nose_radius_in: f64,
    ) -> Result<Self> {
        let p = positive("focal length (in)", focal_length_in)?;
        Self::from_c(4.0 * p, offset_in, sector_diameter_in, tool_nose_radius_in)
    }

    /// Like [`Self::new`] but with the constant `c = 4 p` of eq 2-1 given directly (Appendix B-1
    /// uses `c = 316.7`, not `4 x 79.15 = 316.6`).
    pub fn from_c(
        c_in: f64,
        offset_in: f64,
        sector_diameter_in: f64,
        tool_nose_radius_in: f64,
    ) -> Result<Self> {
        let c = positive("c = 4 x focal length (in)", c_in)?;
        let sy = positive("sector offset S_y (in)", offset_in)?;
        let d = positive("sector diameter (in)", sector_diameter_in)?;
        let rt = non_negative("tool-nose radius (in)", tool_nose_radius_in)?;
        let hyp = (c * c + 4.0 * sy * sy).sqrt();
        let sin_theta = 2.0 * sy / hyp;
        let cos_theta = c / hyp;
        let r0_in = sy / sin_theta;
        let s = Self {
            c_in: c,
            offset_in: sy,
            sector_diameter_in: d,
            tool_nose_radius_in: rt,
            sin_theta,
            cos_theta,
            cot_theta: c / (2.0 * sy),
            r0_in,
            a_in: sy / (sin_theta * sin_theta * sin_theta),
            a1_per_in: 2.0 * sin_theta * sin_theta * cos_theta / sy,
            a2_per_in2: (sin_theta * sin_theta / sy) * (sin_theta * sin_theta / sy),
        };
        if !s.a_in.is_finite() || !s.r0_in.is_finite() {
            return Err(TurningError::NotPositive { name: "sin(theta)", value: sin_theta });
        }
        if rt >= r0_in {
            return Err(TurningError::ToolNose {
                tool_nose_radius_in: rt,
                reason: "it is not smaller than the radius of the gross X-Y arc",
            });
        }
        // The tool at the sector edge touches the part at the contact radius, beyond the edge.
        let edge = s.sector_radius_in();
        let contact = edge * r0_in / (r0_in - rt);
        if contact >= s.domain_limit_in() {
            return Err(TurningError::OutsideSurface {
                x_in: contact,
                limit_in: s.domain_limit_in(),
            });
        }
        Ok(s)
    }

    /// The problem statement of Chapter 1 (l.251-253: p = 79.15 in, S_y = 28 in, ~16 in
    /// sector) with the 0.125 in tool nose of Appendix B-1.
    pub fn douglass_problem() -> Self {
        // Constants known to be valid; the constructor cannot fail on them.
        Self::new(79.15, 28.0, 16.0, 0.125).unwrap_or_else(|_| unreachable!())
    }

    /// The constants of the FOREX4 listing (Appendix B-1): c = 316.7, S_y = 28, RT = 0.125,
    /// X up to 8 in.
    pub fn douglass_listing() -> Self {
        Self::from_c(316.7, 28.0, 16.0, 0.125).unwrap_or_else(|_| unreachable!())
    }

    /// The same surface with another tool-nose radius (0 = no compensation).
    pub fn with_tool_nose_radius(self, tool_nose_radius_in: f64) -> Result<Self> {
        Self::from_c(self.c_in, self.offset_in, self.sector_diameter_in, tool_nose_radius_in)
    }

    pub fn c_in(&self) -> f64 {
        self.c_in
    }
    pub fn focal_length_in(&self) -> f64 {
        self.c_in / 4.0
    }
    pub fn offset_in(&self) -> f64 {
        self.offset_in
    }
    pub fn sector_diameter_in(&self) -> f64 {
        self.sector_diameter_in
    }
    pub fn sector_radius_in(&self) -> f64 {
        0.5 * self.sector_diameter_in
    }
    pub fn tool_nose_radius_in(&self) -> f64 {
        self.tool_nose_radius_in
    }
    /// Tilt of the machine frame, `tan(theta) = 2 S_y / c`.
    pub fn theta_rad(&self) -> f64 {
        self.sin_theta.atan2(self.cos_theta)
    }
    /// `R0 = S_y / sin(theta)`: radius of the gross X-Y arc (160.806 in for c = 316.7).
    pub fn r0_in(&self) -> f64 {
        self.r0_in
    }
    /// `A = S_y / sin^3(theta)` of eq 2-9 (5303.89 in for c = 316.7).
    pub fn a_in(&self) -> f64 {
        self.a_in
    }

    /// Largest radius at which the machine-frame formulas hold: `X < R0` (eq 2-14) and
    /// `P^2 > 0` for every `phi` (eq 2-9).
    pub fn domain_limit_in(&self) -> f64 {
        let (a1, a2) = (self.a1_per_in, self.a2_per_in2);
        // min over s in [-1, 1] of 1 + a1 X s - a2 X^2 (1 - s^2): at s = -1 unless the vertex
        // s* = -a1 / (2 a2 X) lies inside.
        let at_minus_one = 1.0 / a1;
        let p_limit = if a2 * at_minus_one > 0.5 * a1 {
            // vertex inside [-1, 1] before 1 - a1 X reaches 0
            let q = (1.0 - a1 * a1 / (4.0 * a2)) / a2;
            if q > 0.0 {
                q.sqrt()
            } else {
                0.0
            }
        } else {
            at_minus_one
        };
        p_limit.min(self.r0_in)
    }

    fn check_radius(&self, x_in: f64) -> Result<f64> {
        let limit_in = self.domain_limit_in();
        if x_in.is_finite() && (0.0..limit_in).contains(&x_in) {
            Ok(x_in)
        } else {
            Err(TurningError::OutsideSurface { x_in, limit_in })
        }
    }

    /// `u` and `P = sqrt(1 + u)` of eq 2-9.
    fn u_p(&self, x_in: f64, s: f64, cos2: f64) -> (f64, f64) {
        let u = self.a1_per_in * x_in * s - self.a2_per_in2 * x_in * x_in * cos2;
        (u, (1.0 + u).sqrt())
    }

    /// `Y_t(X, phi)` (eq 2-9), cancellation-free.
    pub fn yt_in(&self, x_in: f64, phi_rad: f64) -> Result<f64> {
        let x = self.check_radius(x_in)?;
        let (s, co) = phi_rad.sin_cos();
        let cos2 = co * co;
        let (u, p) = self.u_p(x, s, cos2);
        let onep = 1.0 + p;
        Ok(x * self.cot_theta * s * u / (onep * onep) + x * x * cos2 / (self.r0_in * onep))
    }

    /// `Y_t(X, phi)` exactly as eq 2-9 is printed, `A (1 - P) + X cot(theta) sin(phi)`: loses
    /// about `A eps = 6e-13 in` to cancellation in f64 (and 500 uin in f32).
    pub fn yt_naive_in(&self, x_in: f64, phi_rad: f64) -> Result<f64> {
        let x = self.check_radius(x_in)?;
        let (s, co) = phi_rad.sin_cos();
        let (_, p) = self.u_p(x, s, co * co);
        Ok(self.a_in * (1.0 - p) + x * self.cot_theta * s)
    }

    /// `dY_t/dX` at fixed `phi`, cancellation-free.
    pub fn dyt_dx(&self, x_in: f64, phi_rad: f64) -> Result<f64> {
        let x = self.check_radius(x_in)?;
        let (s, co) = phi_rad.sin_cos();
        let cos2 = co * co;
        let (u, p) = self.u_p(x, s, cos2);
        Ok(self.cot_theta * s * u / (p * (1.0 + p)) + x * cos2 / (self.r0_in * p))
    }

    /// The gross arc `R0 - sqrt(R0^2 - X^2)` (eq 2-14 corrected), cancellation-free: the highest
    /// point per radius while the two maxima of eq 2-11 exist ([`Self::gross_y_in`]).
    pub fn gross_arc_y_in(&self, x_in: f64) -> Result<f64> {
        let x = self.check_radius(x_in)?;
        let q = (1.0 - (x / self.r0_in) * (x / self.r0_in)).sqrt();
        Ok(x * x / (self.r0_in * (1.0 + q)))
    }

    /// `sin(phi*)` of the maxima of `Y_t` at radius `x > 0` (eq 2-11), unclamped: below -1
    /// the two maxima have met at phi = 270 deg.
    fn maxima_sin(&self, x: f64) -> f64 {
        let t = x / self.offset_in * self.sin_theta;
        // 1 - sqrt(1 - t^2) = t^2 / (1 + sqrt(1 - t^2))
        let one_minus = t * t / (1.0 + (1.0 - t * t).sqrt());
        -(self.c_in / (2.0 * x * self.sin_theta)) * one_minus
    }

    /// The gross axial path `Y(X) = max over phi of Y_t(X, phi)`, the highest point of the
    /// surface per radius, which the Z slide's command is measured from (`Z <= 0`): the arc of
    /// eq 2-14 while the two maxima of eq 2-11 exist; beyond the radius where they meet at
    /// phi = 270 deg (about `4 S_y^2 / (c sin(theta))`: 57 in for the thesis's part, inside the
    /// sector of a part with a large offset for its focal length) the surface's height there,
    /// below the arc.
    pub fn gross_y_in(&self, x_in: f64) -> Result<f64> {
        let x = self.check_radius(x_in)?;
        if x == 0.0 || self.maxima_sin(x) >= -1.0 {
            self.gross_arc_y_in(x)
        } else {
            self.yt_in(x, -0.5 * PI)
        }
    }

    /// `Z(X, phi) = Y_t(X, phi) - Y(X)` (eq 2-15) for a sharp tool, cancellation-free.
    pub fn z_in(&self, x_in: f64, phi_rad: f64) -> Result<f64> {
        Ok(self.yt_in(x_in, phi_rad)? - self.gross_y_in(x_in)?)
    }

    /// Eq 2-15 evaluated as printed (naive; for comparison only).
    pub fn z_naive_in(&self, x_in: f64, phi_rad: f64) -> Result<f64> {
        let x = self.check_radius(x_in)?;
        let q = (1.0 - (x / self.r0_in) * (x / self.r0_in)).sqrt();
        Ok(self.yt_naive_in(x, phi_rad)? - self.r0_in * (1.0 - q))
    }

    /// The two spindle angles of the maxima of `Y_t` at radius `X` (eq 2-11), where `Z = 0`:
    /// `phi*` and `pi - phi*` (about -8.09 and 188.09 deg at X = 8 in).
    pub fn maxima_phi_rad(&self, x_in: f64) -> Result<(f64, f64)> {
        let x = self.check_radius(x_in)?;
        if x == 0.0 {
            return Ok((0.0, PI));
        }
        let t = x / self.offset_in * self.sin_theta;
        // 1 - sqrt(1 - t^2) = t^2 / (1 + sqrt(1 - t^2))
        let one_minus = t * t / (1.0 + (1.0 - t * t).sqrt());
        let s = -(self.c_in / (2.0 * x * self.sin_theta)) * one_minus;
        let phi = s.clamp(-1.0, 1.0).asin();
        Ok((phi, PI - phi))
    }

    /// The surface point on the axis line `(x3, y3)` of the machine frame, found by transforming
    /// eq 2-1 directly (eqs 2-2, 2-3) and solving the quadratic for `z3`: an independent check of
    /// eq 2-9. Returns the root nearest the sector (`z3 = 0` at the origin).
    pub fn direct_z3_in(&self, x3_in: f64, y3_in: f64) -> Result<f64> {
        let (sn, co, c, sy) = (self.sin_theta, self.cos_theta, self.c_in, self.offset_in);
        let sz = sy * sy / c;
        // c (y3 sn + z co + sz) = x3^2 + (y3 co - z sn + sy)^2, quadratic a z^2 + b z + k = 0
        let w = y3_in * co + sy;
        let a = sn * sn;
        let b = -2.0 * w * sn - c * co;
        let k = x3_in * x3_in + w * w - c * (y3_in * sn + sz);
        let disc = b * b - 4.0 * a * k;
        if !disc.is_finite() || disc < 0.0 {
            return Err(TurningError::OutsideSurface {
                x_in: x3_in.hypot(y3_in),
                limit_in: self.domain_limit_in(),
            });
        }
        // Smaller root, in the cancellation-free form 2k / (-b + sqrt(disc)) (b < 0).
        Ok(2.0 * k / (-b + disc.sqrt()))
    }

    /// Contact radius of the tool nose on the gross arc when the tool centre is at `x_tool_in`:
    /// FOREX4's fixed point `X1 <- X + RT sin(alpha(X1))`, `alpha = atan(X1 / (R0 - Y(X1)))`.
    /// On the arc `sin(alpha) = X1 / R0`, so the converged contact is `X R0 / (R0 - RT)`.
    pub fn contact_radius_gross_arc_in(&self, x_tool_in: f64) -> Result<f64> {
        let x = non_negative("tool-centre radius X (in)", x_tool_in)?;
        let x1 = x * self.r0_in / (self.r0_in - self.tool_nose_radius_in);
        self.check_radius(x1)
    }

    /// Tool-centre path on the gross arc, `Y_c(X) = Y(X1) + RT cos(alpha)`: the arc of radius
    /// `R0 - RT` (FOREX4's model).
    pub fn gross_y_tool_centre_arc_in(&self, x_tool_in: f64) -> Result<f64> {
        let x = non_negative("tool-centre radius X (in)", x_tool_in)?;
        let r = self.r0_in - self.tool_nose_radius_in;
        if x >= r {
            return Err(TurningError::OutsideSurface { x_in: x, limit_in: r });
        }
        let q = (1.0 - (x / r) * (x / r)).sqrt();
        // R0 - sqrt(r^2 - x^2) = RT + r (1 - q)
        Ok(self.tool_nose_radius_in + x * x / (r * (1.0 + q)))
    }

    /// Tool-centre gross path: the nose circle's centre riding on [`Self::gross_y_in`] (the
    /// highest centre over the contact points `u`, `Y(u) + sqrt(RT^2 - (u - X)^2)`). While the
    /// contact lies on the arc this is [`Self::gross_y_tool_centre_arc_in`]; beyond, the
    /// maximum is found by golden-section search.
    pub fn gross_y_tool_centre_in(&self, x_tool_in: f64) -> Result<f64> {
        let x = non_negative("tool-centre radius X (in)", x_tool_in)?;
        let rt = self.tool_nose_radius_in;
        if rt == 0.0 {
            return self.gross_y_in(x);
        }
        let contact = x * self.r0_in / (self.r0_in - rt);
        if contact == 0.0 || self.maxima_sin(contact) >= -1.0 {
            return self.gross_y_tool_centre_arc_in(x);
        }
        let height = |u: f64| -> Result<f64> {
            let d = u - x;
            Ok(self.gross_y_in(u.abs())? + (rt * rt - d * d).max(0.0).sqrt())
        };
        golden_max(height, x - rt, x + rt)
    }

    /// Z command for the tool centre at radius `x_tool_in`, with the nose compensated on the
    /// gross arc (FOREX4's model, converged): the surface `Z` at the contact radius `X1`.
    pub fn z_tool_centre_gross_arc_in(&self, x_tool_in: f64, phi_rad: f64) -> Result<f64> {
        self.z_in(self.contact_radius_gross_arc_in(x_tool_in)?, phi_rad)
    }

    /// Z command for the tool centre at radius `x_tool_in`, with the nose circle (in the
    /// meridian plane `phi` = const, where a turning tool's nose lies) touching the true meridian
    /// section `Y_t(., phi)`: the contact radius `X` solves `X - RT sin(beta) = x_tool`,
    /// `tan(beta) = dY_t/dX`, and the command is `Y_t + RT cos(beta)` minus the tool-centre
    /// gross path. FOREX4 uses the gross arc's slope instead of `dY_t/dX`; the first-order
    /// terms of the two cancel and they differ by at most 0.3 uin, at X = 8 in (second order,
    /// `~ RT (dZ/dX)^2 / 2`). Returns `(z_in, contact_radius_in)`.
    pub fn z_tool_centre_envelope_in(&self, x_tool_in: f64, phi_rad: f64) -> Result<(f64, f64)> {
        let xc = non_negative("tool-centre radius X (in)", x_tool_in)?;
        let rt = self.tool_nose_radius_in;
        let mut x = self.contact_radius_gross_arc_in(xc)?;
        let mut converged = false;
        for _ in 0..60 {
            let m = self.dyt_dx(x, phi_rad)?;
            let sin_beta = m / (1.0 + m * m).sqrt();
            let next = xc + rt * sin_beta;
            let step = next - x;
            x = self.check_radius(next)?;
            if step.abs() <= 1e-15 * (1.0 + x) {
                converged = true;
                break;
            }
        }
        if !converged {
            return Err(TurningError::NoConvergence { x_in: xc });
        }
        let m = self.dyt_dx(x, phi_rad)?;
        let cos_beta = 1.0 / (1.0 + m * m).sqrt();
        // Y_t + RT cos(beta) - [RT + r (1 - q)], regrouped so the RT terms cancel exactly:
        // RT (cos(beta) - 1) = -RT m^2 / (sqrt(1 + m^2) (1 + sqrt(1 + m^2)))
        let root = (1.0 + m * m).sqrt();
        let nose = -rt * m * m * cos_beta / (1.0 + root);
        let gross = self.gross_y_tool_centre_in(xc)? - rt;
        Ok((self.yt_in(x, phi_rad)? + nose - gross, x))
    }
}

/// Largest value of `f` on `[a, b]` (unimodal there) by golden-section search to 1e-14 of the
/// interval.
fn golden_max(f: impl Fn(f64) -> Result<f64>, mut a: f64, mut b: f64) -> Result<f64> {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let tol = 1e-14 * (b - a).abs().max(1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c)?, f(d)?);
    while b - a > tol {
        if fc > fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - g * (b - a);
            fc = f(c)?;
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + g * (b - a);
            fd = f(d)?;
        }
    }
    f(0.5 * (a + b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domain_is_bounded_by_the_gross_arc() {
        let p = OffAxisParaboloid::douglass_listing();
        assert_eq!(p.domain_limit_in(), p.r0_in());
        assert!(p.z_in(p.r0_in() * 0.999, 1.0).is_ok());
    }

    #[test]
    fn gross_paths() {
        let p = OffAxisParaboloid::douglass_listing();
        let x = 6.0;
        let naive = p.r0_in() - (p.r0_in() * p.r0_in() - x * x).sqrt();
        assert!((p.gross_y_in(x).unwrap() - naive).abs() < 1e-13);
        let r = p.r0_in() - 0.125;
        let naive_c = p.r0_in() - (r * r - x * x).sqrt();
        assert!((p.gross_y_tool_centre_in(x).unwrap() - naive_c).abs() < 1e-13);
    }
}
