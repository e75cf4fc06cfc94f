//! Spur gear by Unwin's approximate construction (seed L3584-3817, Appendix C10; Table 6 and
//! Table 12). Each flank is a circular arc of radius CD centred at D: B lies on the radius OC at
//! one third of CA from C (A on the base circle, C on the addendum circle), BE is the tangent
//! from B to the base circle, D lies on BE at 3/4 of BE from B, so
//! `CD = 0.75 * sqrt(OB^2 - rb^2)` and `OD = sqrt(rb^2 + (BE/4)^2)`.

use super::{positive, Point2, Result, WireError};
use std::f64::consts::{PI, TAU};

/// Input of the gear program: module, pitch circle diameter and pressure angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GearSpec {
    pub module_mm: f64,
    pub pitch_diameter_mm: f64,
    pub pressure_angle_deg: f64,
}

/// The terminology printout of Table 6 (seed L3588-3605), plus the construction values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GearTerms {
    pub module_mm: f64,
    pub pitch_diameter_mm: f64,
    pub base_diameter_mm: f64,
    pub outside_diameter_mm: f64,
    pub root_diameter_mm: f64,
    pub circular_pitch_mm: f64,
    pub teeth: usize,
    pub pressure_angle_deg: f64,
    pub addendum_mm: f64,
    pub dedendum_mm: f64,
    pub top_land_width_mm: f64,
    pub whole_depth_mm: f64,
    pub working_depth_mm: f64,
    pub clearance_mm: f64,
    pub fillet_radius_mm: f64,
    pub tooth_thickness_mm: f64,
    pub space_width_mm: f64,
    /// CD, the radius of the flank arc.
    pub flank_radius_mm: f64,
    /// OD, the distance from the gear centre to a flank arc centre.
    pub flank_centre_distance_mm: f64,
}

/// Table 6 for `spec`. Errors if a parameter is not positive, the tooth count PD/m is not a
/// whole number >= 3, the pressure angle is outside (0, 45) deg, or the root circle is empty.
pub fn gear_terms(spec: GearSpec) -> Result<GearTerms> {
    let m = positive("module_mm", spec.module_mm)?;
    let pd = positive("pitch_diameter_mm", spec.pitch_diameter_mm)?;
    let pa = spec.pressure_angle_deg;
    if !(pa.is_finite() && pa > 0.0 && pa < 45.0) {
        return Err(WireError::BadParameter {
            name: "pressure_angle_deg",
            value: pa,
            reason: "must be in (0, 45) deg",
        });
    }
    let t = pd / m;
    if (t - t.round()).abs() > 1e-9 || t.round() < 3.0 {
        return Err(WireError::BadParameter {
            name: "pitch_diameter_mm",
            value: pd,
            reason: "pitch diameter / module must be a whole number of teeth >= 3",
        });
    }
    let root = pd - 2.5 * m;
    if root <= 0.0 {
        return Err(WireError::BadParameter {
            name: "module_mm",
            value: m,
            reason: "root diameter PD - 2.5 m must be > 0",
        });
    }
    let base = pd * pa.to_radians().cos();
    let (ra, rb) = ((pd + 2.0 * m) / 2.0, base / 2.0);
    let ob = ra - (ra - rb) / 3.0;
    let be = (ob * ob - rb * rb).sqrt();
    Ok(GearTerms {
        module_mm: m,
        pitch_diameter_mm: pd,
        base_diameter_mm: base,
        outside_diameter_mm: pd + 2.0 * m,
        root_diameter_mm: root,
        circular_pitch_mm: PI * m,
        teeth: t.round() as usize,
        pressure_angle_deg: pa,
        addendum_mm: m,
        dedendum_mm: 1.25 * m,
        top_land_width_mm: 0.25 * m,
        whole_depth_mm: 2.25 * m,
        working_depth_mm: 2.0 * m,
        clearance_mm: 0.25 * m,
        fillet_radius_mm: 0.3 * m,
        tooth_thickness_mm: PI * m / 2.0,
        space_width_mm: PI * m / 2.0,
        flank_radius_mm: 0.75 * be,
        flank_centre_distance_mm: (rb * rb + be * be / 16.0).sqrt(),
    })
}

/// Angle at the vertex between sides `b` and `c` of a triangle whose third side is `a`.
fn cosine_rule(a: f64, b: f64, c: f64, name: &'static str) -> Result<f64> {
    let k = (b * b + c * c - a * a) / (2.0 * b * c);
    if !(-1.0..=1.0).contains(&k) {
        return Err(WireError::BadParameter {
            name,
            value: k,
            reason: "the Unwin construction has no triangle here (flank arc misses the circle)",
        });
    }
    Ok(k.acos())
}

/// Gear profile in the order of Table 12: start at `start`, then for each tooth its B flank
/// root -> tip (`n_per_flank` steps), the tip arc (`tip_steps` equal steps), its A flank
/// tip -> root, the root arc to the next tooth (`root_steps` equal steps); back to the first
/// point, then to `start`. The first tooth's A-flank centre lies at 270 deg (BASIC 1690); the
/// thesis used `n_per_flank` = 8, `tip_steps` = 4, `root_steps` = 5 and `start` = (0, -60).
pub fn gear_profile(
    spec: GearSpec,
    n_per_flank: usize,
    tip_steps: usize,
    root_steps: usize,
    start: Point2,
) -> Result<Vec<Point2>> {
    let g = gear_terms(spec)?;
    for (name, v) in
        [("n_per_flank", n_per_flank), ("tip_steps", tip_steps), ("root_steps", root_steps)]
    {
        if v == 0 {
            return Err(WireError::BadParameter { name, value: 0.0, reason: "must be >= 1" });
        }
    }
    super::check_finite(&[start], "X", "Y")?;
    let (ra, rf, rp) =
        (g.outside_diameter_mm / 2.0, g.root_diameter_mm / 2.0, g.pitch_diameter_mm / 2.0);
    let (cd, od) = (g.flank_radius_mm, g.flank_centre_distance_mm);
    let b1 = cosine_rule(ra, od, cd, "addendum circle")?;
    let b2 = cosine_rule(rf, od, cd, "root circle")?;
    let b5 = cosine_rule(cd, rp, od, "pitch circle")?;
    let q3 = b1 - b2;
    let t = g.teeth;
    let pitch = TAU / t as f64;
    let on = |centre: f64, ang: f64| {
        Point2::new(od * centre.cos() + cd * ang.cos(), od * centre.sin() + cd * ang.sin())
    };
    // B flank of tooth k: centre at psi_b, points at psi_b + pi + (B2 .. B1).
    let psi_a0 = 1.5 * PI;
    let psi_b0 = psi_a0 + 2.0 * b5 - PI / t as f64;
    let polar = |p: Point2| p.y_mm.atan2(p.x_mm);
    let mut out = Vec::with_capacity(t * (2 * n_per_flank + tip_steps + root_steps) + 3);
    out.push(start);
    out.push(on(psi_b0, psi_b0 + PI + b2));
    for k in 0..t {
        let psi_a = psi_a0 + pitch * k as f64;
        let psi_b = psi_b0 + pitch * k as f64;
        for j in 1..=n_per_flank {
            out.push(on(psi_b, psi_b + PI + b2 + q3 * j as f64 / n_per_flank as f64));
        }
        let tip0 = *out.last().unwrap_or(&start);
        let tip1 = on(psi_a, psi_a + PI - b1);
        let (a0, da) = (polar(tip0), super::shapes::wrap_pi(polar(tip1) - polar(tip0)));
        for i in 1..tip_steps {
            let a = a0 + da * i as f64 / tip_steps as f64;
            out.push(Point2::new(ra * a.cos(), ra * a.sin()));
        }
        for j in 0..=n_per_flank {
            out.push(on(psi_a, psi_a + PI - b1 + q3 * j as f64 / n_per_flank as f64));
        }
        let root0 = *out.last().unwrap_or(&start);
        let psi_next = psi_b + pitch;
        let root1 = on(psi_next, psi_next + PI + b2);
        let (r0, dr) = (polar(root0), super::shapes::wrap_pi(polar(root1) - polar(root0)));
        for i in 1..root_steps {
            let a = r0 + dr * i as f64 / root_steps as f64;
            out.push(Point2::new(rf * a.cos(), rf * a.sin()));
        }
        out.push(if k + 1 == t { out[1] } else { root1 });
    }
    out.push(start);
    Ok(out)
}
