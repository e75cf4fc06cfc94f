//! Joint limits per point (seed L1010-1069 and BASIC 5500-5610, L2950-2972).

use super::ik::Joints;
use super::{Point2, Result, WireError};

/// Manipulator limits. [`Limits::default`] is the thesis's machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Usable X travel from the centre, +- mm (100 mm total, L69).
    pub x_travel_mm: f64,
    /// Usable Y travel from the centre, +- mm (120 mm total).
    pub y_travel_mm: f64,
    /// Pitch range at the centre, +- deg.
    pub alpha_max_deg: f64,
    /// Roll range at the centre, +- deg.
    pub beta_max_deg: f64,
    /// Hard negative roll limit (motor 4 hits the base), deg.
    pub beta_min_deg: f64,
    /// Half width of the inner frame in the frame-clearance rules, mm (17.5 in eq. (i), (ii)).
    pub frame_half_width_mm: f64,
    /// Distance from the centre to the frame along Y, mm (60 in eq. (i)).
    pub frame_y_mm: f64,
    /// Distance from the centre to the frame along X, mm (50 in eq. (ii)).
    pub frame_x_mm: f64,
    /// Above this thickness negative pitch stops at `thick_alpha_min_deg` (BASIC 5500).
    pub thick_zt_mm: f64,
    pub thick_alpha_min_deg: f64,
    /// Above this thickness negative pitch is limited by eq. (iii) (BASIC 5530).
    pub screw_zt_mm: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            x_travel_mm: 50.0,
            y_travel_mm: 60.0,
            alpha_max_deg: 70.0,
            beta_max_deg: 65.0,
            beta_min_deg: -50.0,
            frame_half_width_mm: 17.5,
            frame_y_mm: 60.0,
            frame_x_mm: 50.0,
            thick_zt_mm: 72.0,
            thick_alpha_min_deg: -30.0,
            screw_zt_mm: 50.0,
        }
    }
}

/// `90 - atan(w / (d - |off|))` in degrees: the frame-clearance angle of eq. (i)/(ii), or
/// `None` when the point is beyond the frame. The thesis's BASIC 5570 forgets the `*RD`
/// (it subtracts radians from degrees, L2961); eq. (i) at L1012 is applied here. A point right
/// at the frame (gap 0) may not tilt at all (0 deg): the gear's start point (0, -60) of
/// Table 12, cut with alpha = beta = 0.
fn frame_angle_deg(w: f64, d: f64, off: f64) -> Option<f64> {
    let gap = d - off.abs();
    (gap >= 0.0).then(|| (90.0 - (w / gap).atan().to_degrees()).max(0.0))
}

impl Limits {
    /// Checks point `index` (bottom `bottom`, thickness `zt_mm`) at joints `j`. The error names
    /// the point, the joint and the rule.
    pub fn check_point(&self, index: usize, bottom: Point2, zt_mm: f64, j: Joints) -> Result<()> {
        let err =
            |field, value, limit, rule| Err(WireError::Limit { index, field, value, limit, rule });
        let (a, b) = (j.alpha_rad.to_degrees(), j.beta_rad.to_degrees());
        if j.x_mm.abs() > self.x_travel_mm {
            return err("x_mm", j.x_mm, self.x_travel_mm, "X travel");
        }
        if j.y_mm.abs() > self.y_travel_mm {
            return err("y_mm", j.y_mm, self.y_travel_mm, "Y travel");
        }
        let a_frame = frame_angle_deg(self.frame_half_width_mm, self.frame_y_mm, bottom.y_mm)
            .ok_or(WireError::Limit {
                index,
                field: "YB_mm",
                value: bottom.y_mm,
                limit: self.frame_y_mm,
                rule: "point beyond the inner frame along Y",
            })?;
        let a_max = self.alpha_max_deg.min(a_frame);
        if a > a_max {
            return err(
                "alpha_deg",
                a,
                a_max,
                "+alpha <= min(70, 90 - atan(17.5/(60 - |YB|))) (eq. i, BASIC 5570)",
            );
        }
        if a < -a_max {
            return err(
                "alpha_deg",
                a,
                -a_max,
                "-alpha >= -min(70, 90 - atan(17.5/(60 - |YB|))) (eq. i, BASIC 5550)",
            );
        }
        if zt_mm > self.thick_zt_mm && a < self.thick_alpha_min_deg {
            return err(
                "alpha_deg",
                a,
                self.thick_alpha_min_deg,
                "ZT > 72 mm: alpha >= -30 deg (BASIC 5500)",
            );
        }
        if zt_mm > self.screw_zt_mm {
            let lim = 6.0 + (60.0 / zt_mm).atan().to_degrees() - 90.0;
            if a < lim {
                return err(
                    "alpha_deg",
                    a,
                    lim,
                    "ZT > 50 mm: alpha >= 6 + atan(60/ZT) - 90 deg (eq. iii, BASIC 5530)",
                );
            }
        }
        if b < self.beta_min_deg {
            return err("beta_deg", b, self.beta_min_deg, "beta >= -50 deg (BASIC 5590)");
        }
        let b_frame = frame_angle_deg(self.frame_half_width_mm, self.frame_x_mm, bottom.x_mm)
            .ok_or(WireError::Limit {
                index,
                field: "XB_mm",
                value: bottom.x_mm,
                limit: self.frame_x_mm,
                rule: "point beyond the inner frame along X",
            })?;
        let b_max = self.beta_max_deg.min(b_frame);
        if b > b_max {
            return err(
                "beta_deg",
                b,
                b_max,
                "+beta <= min(65, 90 - atan(17.5/(50 - |XB|))) (eq. ii, BASIC 5610)",
            );
        }
        if b < -self.beta_max_deg {
            return err("beta_deg", b, -self.beta_max_deg, "beta >= -65 deg");
        }
        Ok(())
    }

    /// Checks every point; the first violation is returned.
    pub fn check_all(&self, bottom: &[Point2], zt_mm: f64, joints: &[Joints]) -> Result<()> {
        for (i, (b, j)) in bottom.iter().zip(joints).enumerate() {
            self.check_point(i, *b, zt_mm, *j)?;
        }
        Ok(())
    }
}
