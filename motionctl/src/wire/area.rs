//! Area bookkeeping: the thesis's sector method (seed L2245-2249, BASIC 1290-1420 and
//! 2350-2500), the exact polygon (shoelace) area, intermediate sections and reduction ratios.

use super::shapes::wrap_pi;
use super::Point2;
use std::f64::consts::TAU;

/// One row of the thesis's area printout (Tables 7-10).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectorRow {
    /// Polar angle of the point, continued across +-180 deg (0 .. 360 for a closed CCW loop
    /// that starts at 0 deg).
    pub theta_deg: f64,
    /// Mean of this and the previous point's distance from the origin ("RESULTANT").
    pub r_mean_mm: f64,
    /// `r_mean^2 * dtheta / 2`; negative where the profile turns back.
    pub sector_mm2: f64,
    /// Running sum of the sectors.
    pub total_mm2: f64,
}

/// The thesis's sector area per point. The first row has zero sector; its angle is the first
/// point's polar angle in [0, 360). Each later angle is the previous one plus the wrapped
/// change, which is the thesis's quadrant bookkeeping made continuous (the thesis's own
/// `ATN` quadrant logic agrees for all its shapes that start at 0 deg).
pub fn sector_table(points: &[Point2]) -> Vec<SectorRow> {
    let mut out: Vec<SectorRow> = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        let raw = p.y_mm.atan2(p.x_mm);
        let r = p.norm_mm();
        let row = match out.last() {
            None => SectorRow {
                theta_deg: raw.rem_euclid(TAU).to_degrees(),
                r_mean_mm: r,
                sector_mm2: 0.0,
                total_mm2: 0.0,
            },
            Some(prev) => {
                let q = points[i - 1];
                let d = wrap_pi(raw - q.y_mm.atan2(q.x_mm));
                let rm = (r + q.norm_mm()) / 2.0;
                let s = rm * rm * d / 2.0;
                SectorRow {
                    theta_deg: prev.theta_deg + d.to_degrees(),
                    r_mean_mm: rm,
                    sector_mm2: s,
                    total_mm2: prev.total_mm2 + s,
                }
            }
        };
        out.push(row);
    }
    out
}

/// Total of the thesis's sector method, mm^2.
pub fn sector_area_mm2(points: &[Point2]) -> f64 {
    sector_table(points).last().map_or(0.0, |r| r.total_mm2)
}

/// Signed shoelace area of the polygon through `points` (closed implicitly), mm^2; positive
/// for a counter-clockwise profile.
pub fn polygon_area_signed_mm2(points: &[Point2]) -> f64 {
    let n = points.len();
    (0..n)
        .map(|i| {
            let (a, b) = (points[i], points[(i + 1) % n]);
            a.x_mm * b.y_mm - b.x_mm * a.y_mm
        })
        .sum::<f64>()
        / 2.0
}

/// Exact enclosed area of the polygon through `points`, mm^2.
pub fn polygon_area_mm2(points: &[Point2]) -> f64 {
    polygon_area_signed_mm2(points).abs()
}

/// Reduction ratio of `area_mm2` against `reference_mm2`, percent (BASIC 2620).
pub fn reduction_percent(reference_mm2: f64, area_mm2: f64) -> f64 {
    (reference_mm2 - area_mm2) * 100.0 / reference_mm2
}

/// Section at height `zi_mm` of the ruling lines from `bottom` (at `zb_mm`) to `top` (at
/// `zt_mm`): `X_I = X_b + (X_t - X_b)(Z_I - Z_b)/(Z_t - Z_b)`, same for Y (seed L2771-2773).
/// Pairs beyond the shorter list are ignored.
pub fn intermediate_section(
    top: &[Point2],
    bottom: &[Point2],
    zb_mm: f64,
    zt_mm: f64,
    zi_mm: f64,
) -> Vec<Point2> {
    let f = (zi_mm - zb_mm) / (zt_mm - zb_mm);
    top.iter()
        .zip(bottom)
        .map(|(t, b)| Point2::new(b.x_mm + (t.x_mm - b.x_mm) * f, b.y_mm + (t.y_mm - b.y_mm) * f))
        .collect()
}

/// `v` truncated toward zero to `digits` significant digits: what the thesis's print
/// formatting subroutine (GOSUB 3480) leaves in a variable. The reduction ratios of Tables 8-10
/// use the top area after it went through it (BASIC 1480 `TAREA = VAL(P$)`), e.g. 1963.4 for
/// 1963.495.
pub fn truncate_significant(v: f64, digits: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let unit = 10f64.powi(v.abs().log10().floor() as i32 + 1 - digits);
    // The small bias keeps exact decimals (1963.4 / 0.1) from falling one unit short.
    (v / unit + 1e-9_f64.copysign(v)).trunc() * unit
}
