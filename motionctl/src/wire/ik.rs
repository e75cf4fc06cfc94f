//! Inverse kinematics (seed L2856-2930, BASIC 5390-5490 and 5930-6060), steps and backlash.
//!
//! Chain: base -> X -> Y -> beta (about Y) -> alpha (about X) -> workpiece. The workpiece is
//! rotated first by `alpha` about X (pitch) and then by beta about Y; the table then moves the
//! rotated bottom point onto the wire. Sign convention (the thesis's): `alpha = atan(dy / ZT)`,
//! `beta = atan(dx / RSLT)` with `dx, dy` = top - bottom and `RSLT = sqrt(dy^2 + ZT^2)`; the
//! workpiece-to-machine rotation is `R_y(-beta) * R_x(alpha)`, see [`forward_mm`].
//! `x_mm`, `y_mm` are the thesis's XB1, YB1: the rotated bottom point's offset from the
//! rotation axes, which the X/Y table cancels.

use super::{Point2, Result, WireError};

/// Joint-space target: table X, Y in mm, pitch alpha and roll beta in rad.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Joints {
    pub x_mm: f64,
    pub y_mm: f64,
    pub alpha_rad: f64,
    pub beta_rad: f64,
}

fn check(index: usize, top: Point2, bottom: Point2, zt_mm: f64) -> Result<()> {
    for (field, v) in [("XT", top.x_mm), ("YT", top.y_mm), ("XB", bottom.x_mm), ("YB", bottom.y_mm)]
    {
        if !v.is_finite() {
            return Err(WireError::NotFinite { index, field, value: v });
        }
    }
    if !(zt_mm.is_finite() && zt_mm > 0.0) {
        return Err(WireError::BadParameter {
            name: "zt_mm",
            value: zt_mm,
            reason: "must be a finite number > 0",
        });
    }
    Ok(())
}

/// The thesis's IK exactly as printed (BASIC 5400-5490): `XB1 = XB cos(beta2 + beta3)` with
/// `beta2 = atan(ZB1 / XB)`. This XB1 is wrong whenever `ZB1 != 0`: it drops the factor
/// `1 / cos(beta2)` (the rotated point's radius in the X-Z plane is `sqrt(XB^2 + ZB1^2)`, not
/// `XB`), so it is off by up to 0.96 mm on the plate-4 path. At `XB = 0` GW-BASIC's division
/// by zero yields machine infinity, `ATN` gives +-pi/2 and XB1 = 0; reproduced here.
/// `index` only labels errors.
pub fn ik_thesis(index: usize, top: Point2, bottom: Point2, zt_mm: f64) -> Result<Joints> {
    check(index, top, bottom, zt_mm)?;
    let (dx, dy) = (top.x_mm - bottom.x_mm, top.y_mm - bottom.y_mm);
    let alpha1 = (dy / zt_mm).atan();
    let yb1 = bottom.y_mm * alpha1.abs().cos();
    let zb1 = bottom.y_mm * alpha1.sin();
    let rslt = (dy * dy + zt_mm * zt_mm).sqrt();
    let zt1 = zb1 + rslt;
    let beta2 = if bottom.x_mm == 0.0 {
        std::f64::consts::FRAC_PI_2.copysign(zb1)
    } else {
        (zb1 / bottom.x_mm).atan()
    };
    let beta3 = (dx / (zt1 - zb1)).atan();
    let xb1 = bottom.x_mm * (beta2 + beta3).abs().cos();
    Ok(Joints { x_mm: xb1, y_mm: yb1, alpha_rad: alpha1, beta_rad: beta3 })
}

/// Corrected IK: same angles (with atan2), exact offset `XB1 = XB cos(beta) - ZB1 sin(beta)`,
/// so that [`forward_mm`] puts both the bottom and the top point on the wire.
pub fn ik_exact(index: usize, top: Point2, bottom: Point2, zt_mm: f64) -> Result<Joints> {
    check(index, top, bottom, zt_mm)?;
    let (dx, dy) = (top.x_mm - bottom.x_mm, top.y_mm - bottom.y_mm);
    let alpha = dy.atan2(zt_mm);
    let rslt = dy.hypot(zt_mm);
    let beta = dx.atan2(rslt);
    let zb1 = bottom.y_mm * alpha.sin();
    Ok(Joints {
        x_mm: bottom.x_mm * beta.cos() - zb1 * beta.sin(),
        y_mm: bottom.y_mm * alpha.cos(),
        alpha_rad: alpha,
        beta_rad: beta,
    })
}

/// Which IK to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IkModel {
    /// [`ik_thesis`], reproduces the thesis's numbers including its XB1 error.
    Thesis,
    /// [`ik_exact`].
    Exact,
}

impl IkModel {
    pub fn solve(self, index: usize, top: Point2, bottom: Point2, zt_mm: f64) -> Result<Joints> {
        match self {
            IkModel::Thesis => ik_thesis(index, top, bottom, zt_mm),
            IkModel::Exact => ik_exact(index, top, bottom, zt_mm),
        }
    }
}

/// Machine-frame position (origin on the wire at the bottom plane) of workpiece point
/// `p = [x, y, z]` (mm) at joints `j`: `R_y(-beta) R_x(alpha) p - (x, y, 0)`. The wire is the
/// line x = y = 0.
pub fn forward_mm(j: Joints, p: [f64; 3]) -> [f64; 3] {
    let (sa, ca) = j.alpha_rad.sin_cos();
    let (sb, cb) = j.beta_rad.sin_cos();
    let q = [p[0], p[1] * ca - p[2] * sa, p[1] * sa + p[2] * ca];
    [q[0] * cb - q[2] * sb - j.x_mm, q[1] - j.y_mm, q[0] * sb + q[2] * cb]
}

/// Steps per mm of the X and Y lead screws: 5000 steps/rev over a 1.5 mm pitch (L2916-2920;
/// the "500/1.5" printed at L2920 is a typo for 5000/1.5, BASIC 5950).
pub const STEPS_PER_MM_XY: f64 = 5000.0 / 1.5;
/// Steps per degree of beta: 18:1 gearbox, 5000 steps/rev (BASIC 5960).
pub const STEPS_PER_DEG_BETA: f64 = 18.0 * 5000.0 / 360.0;
/// Steps per degree of alpha: 100:1 harmonic drive, 5000 steps/rev (BASIC 5970).
pub const STEPS_PER_DEG_ALPHA: f64 = 100.0 * 5000.0 / 360.0;

/// Motor targets `[M1 (X), M2 (Y), M3 (beta), M4 (alpha)]` in absolute steps.
pub type Steps = [i64; 4];

fn raw_steps(j: Joints) -> [f64; 4] {
    [
        STEPS_PER_MM_XY * j.x_mm,
        STEPS_PER_MM_XY * j.y_mm,
        -STEPS_PER_DEG_BETA * j.beta_rad.to_degrees(),
        STEPS_PER_DEG_ALPHA * j.alpha_rad.to_degrees(),
    ]
}

/// Steps as the thesis computed them: `FIX` (truncation toward zero), M3 negated after the
/// truncation (BASIC 5940-5970).
pub fn steps_thesis(j: Joints) -> Steps {
    raw_steps(j).map(|v| v.trunc() as i64)
}

/// Steps rounded to nearest (the truncation loses up to one step, always toward zero).
pub fn steps_rounded(j: Joints) -> Steps {
    raw_steps(j).map(|v| v.round() as i64)
}

/// Per-axis backlash compensation of absolute step targets. The reference direction of an
/// axis is that of its first move (from 0); while the axis moves against it, `backlash[axis]`
/// steps are added in the direction of motion; when it does not move, the previous
/// compensation is kept (no spurious move).
pub fn compensate_backlash(targets: &[Steps], backlash: [i64; 4]) -> Vec<Steps> {
    let mut out = Vec::with_capacity(targets.len());
    let mut reference = [0i64; 4];
    let mut offset = [0i64; 4];
    let mut prev = [0i64; 4];
    for t in targets {
        let mut o = [0i64; 4];
        for a in 0..4 {
            let dir = (t[a] - prev[a]).signum();
            if reference[a] == 0 {
                reference[a] = dir;
            }
            if dir != 0 {
                offset[a] = if dir == -reference[a] { dir * backlash[a] } else { 0 };
            }
            o[a] = t[a] + offset[a];
        }
        prev = *t;
        out.push(o);
    }
    out
}

/// The thesis's beta backlash rule (BASIC 5980-6050) on the beta targets `m`: the reference
/// direction is the sign of `m[0]` (or of `m[1]` when `m[0] = 0`); a move against it gets
/// 250 steps (1 deg) added in its direction. Unlike [`compensate_backlash`] it drops the
/// compensation when the axis does not move.
pub fn backlash_thesis_beta(m: &[i64]) -> Vec<i64> {
    let negative_ref =
        m.first().is_some_and(|&m1| m1 < 0 || (m1 == 0 && m.get(1).is_some_and(|&m2| m2 < 0)));
    m.iter()
        .enumerate()
        .map(|(i, &v)| {
            if i == 0 {
                v
            } else if negative_ref {
                if v > m[i - 1] {
                    v + 250
                } else {
                    v
                }
            } else if v < m[i - 1] {
                v - 250
            } else {
                v
            }
        })
        .collect()
}
