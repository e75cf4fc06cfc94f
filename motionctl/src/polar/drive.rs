//! Drive limits of the thesis's NC machine (Table 5.1): stepper pull-out torque (eq 5.17 = F.6),
//! the curvature-based speed limit, and the template digitizer's roller speed error (eq 3.3).

use super::CM_PER_IN;
use std::f64::consts::PI;

/// Table 5.1 motor and machine parameters (SI).
#[derive(Clone, Copy, Debug)]
pub struct Motor {
    pub supply_v: f64,
    pub kt_nm_per_a: f64,
    pub kv_v_per_rad_s: f64,
    /// Rotor teeth Ns (electrical rad/s = Ns * shaft rad/s).
    pub ns: f64,
    pub ra_ohm: f64,
    pub la_h: f64,
    /// Half-steps per shaft revolution (wave drive, 8 states).
    pub half_steps_per_rev: f64,
}

pub const TABLE_5_1: Motor = Motor {
    supply_v: 24.0,
    kt_nm_per_a: 0.0759,
    kv_v_per_rad_s: 0.068,
    ns: 50.0,
    ra_ohm: 6.5,
    la_h: 6.3e-4,
    half_steps_per_rev: 400.0,
};
/// Carriage mass Mc, kg, and radial torque constant K2, m (Table 5.1).
pub const MC_KG: f64 = 0.9;
pub const K2_M: f64 = 2.25e-2;
/// Radial half-steps per inch (20 rev/in lead screw, 400 half-steps/rev).
pub const R_HALF_STEPS_PER_IN: f64 = 8000.0;

impl Motor {
    /// Pull-out torque at `half_steps_per_s` (eq 5.17): 1.17632 = (4/pi) sin(3 pi / 8).
    pub fn pull_out_nm(&self, half_steps_per_s: f64) -> f64 {
        let shaft = half_steps_per_s / self.half_steps_per_rev * 2.0 * PI;
        let w = self.ns * shaft;
        let z2 = self.ra_ohm.powi(2) + (w * self.la_h).powi(2);
        let c = 4.0 / PI * (3.0 * PI / 8.0).sin();
        c * self.supply_v * self.kt_nm_per_a / z2.sqrt()
            - self.kv_v_per_rad_s * w * self.ra_ohm * self.kt_nm_per_a / (self.ns * z2)
    }
}

/// Largest tangential speed on a radius of curvature `rho_in` before the radial drive's
/// centripetal load exceeds its pull-out torque: Vt <= sqrt(rho T / (K2 Mc)), with T the pull-out
/// torque at the radial step rate of that speed (worst case: all motion radial). Fixed point
/// iteration from the speed at zero-rate torque (T falls with speed, so it converges downward).
pub fn curvature_speed_limit_in_per_s(rho_in: f64) -> f64 {
    if !rho_in.is_finite() {
        return f64::INFINITY;
    }
    let rho_m = rho_in * CM_PER_IN / 100.0;
    let mut v_m_s = (rho_m * TABLE_5_1.pull_out_nm(0.0) / (K2_M * MC_KG)).sqrt();
    for _ in 0..50 {
        let hs = v_m_s * 100.0 / CM_PER_IN * R_HALF_STEPS_PER_IN;
        let t = TABLE_5_1.pull_out_nm(hs).max(0.0);
        v_m_s = (rho_m * t / (K2_M * MC_KG)).sqrt();
    }
    v_m_s * 100.0 / CM_PER_IN
}

/// Template digitizer speed ratio v/Vt (eq 3.3, corrected): the differential drives the two
/// rollers at 2 Vt in sum, and they roll on the two faces of a template of thickness H.
/// `same_side`: the centre of curvature and roller G are on the same side of the contour.
/// Non-dimensional rho* = rho/H, Rr* = Rr/H. The thesis prints (rho* -/+ Rr*)/(2 rho* +/- 1), which
/// tends to 1/2 on a straight template; the factor 2 is missing (v/Vt must tend to 1).
pub fn template_speed_ratio(rho: f64, roller_radius: f64, thickness: f64, same_side: bool) -> f64 {
    let (p, r) = (rho / thickness, roller_radius / thickness);
    if same_side {
        2.0 * (p - r) / (2.0 * p + 1.0)
    } else {
        2.0 * (p + r) / (2.0 * p - 1.0)
    }
}

/// The thesis's printed eq 3.3 (without the factor 2), kept to show what it would give.
pub fn template_speed_ratio_as_printed(
    rho: f64,
    roller_radius: f64,
    thickness: f64,
    same_side: bool,
) -> f64 {
    template_speed_ratio(rho, roller_radius, thickness, same_side) / 2.0
}
