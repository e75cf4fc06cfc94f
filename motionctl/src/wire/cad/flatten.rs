//! Curves to chords within a tolerance: cubic Béziers, circular arcs, LWPOLYLINE bulges.

use super::{MAX_DEPTH, MAX_FLAT_POINTS};
use crate::wire::Point2;

/// Appends the cubic Bézier p0..p3 (p0 already in `out`) within `tol`: split in halves until
/// both inner control points are within `tol` of the chord (the curve lies in their hull).
pub(super) fn flatten_cubic(out: &mut Vec<Point2>, p: [Point2; 4], tol: f64, depth: u32) {
    let d = dist_to_segment(p[1], p[0], p[3]).max(dist_to_segment(p[2], p[0], p[3]));
    if d <= tol || depth >= MAX_DEPTH {
        out.push(p[3]);
        return;
    }
    let mid = |a: Point2, b: Point2| Point2::new((a.x_mm + b.x_mm) / 2.0, (a.y_mm + b.y_mm) / 2.0);
    let (p01, p12, p23) = (mid(p[0], p[1]), mid(p[1], p[2]), mid(p[2], p[3]));
    let (p012, p123) = (mid(p01, p12), mid(p12, p23));
    let m = mid(p012, p123);
    flatten_cubic(out, [p[0], p01, p012, m], tol, depth + 1);
    flatten_cubic(out, [m, p123, p23, p[3]], tol, depth + 1);
}

/// Distance from `p` to the segment a-b, mm.
pub fn dist_to_segment(p: Point2, a: Point2, b: Point2) -> f64 {
    let (dx, dy) = (b.x_mm - a.x_mm, b.y_mm - a.y_mm);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.x_mm - a.x_mm) * dx + (p.y_mm - a.y_mm) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.dist_mm(Point2::new(a.x_mm + dx * t, a.y_mm + dy * t))
}

/// Points of the circular arc about `c` with radius `r` from angle `a0` through `sweep` (rad,
/// positive = counter-clockwise), the start excluded, chords within `tol` of the arc.
pub(super) fn arc_points(c: Point2, r: f64, a0: f64, sweep: f64, tol: f64) -> Vec<Point2> {
    // Sagitta r (1 - cos(step / 2)) <= tol.
    let step = if tol >= r { std::f64::consts::FRAC_PI_2 } else { 2.0 * (1.0 - tol / r).acos() };
    let n = ((sweep.abs() / step.max(1e-6)).ceil() as usize).clamp(1, MAX_FLAT_POINTS);
    (1..=n)
        .map(|k| {
            let a = a0 + sweep * k as f64 / n as f64;
            Point2::new(c.x_mm + r * a.cos(), c.y_mm + r * a.sin())
        })
        .collect()
}

/// Points of an LWPOLYLINE span from `a` to `b` with `bulge` = tan(included angle / 4)
/// (positive = counter-clockwise), `a` excluded.
pub(super) fn bulge_points(a: Point2, b: Point2, bulge: f64, tol: f64) -> Vec<Point2> {
    let chord = a.dist_mm(b);
    if bulge.abs() < 1e-12 || chord == 0.0 {
        return vec![b];
    }
    let theta = 4.0 * bulge.atan();
    let r = chord / (2.0 * (theta / 2.0).sin()).abs();
    // Centre: from the chord's midpoint along its left normal (for a CCW bulge below 180 deg).
    let (mx, my) = ((a.x_mm + b.x_mm) / 2.0, (a.y_mm + b.y_mm) / 2.0);
    let (ux, uy) = ((b.x_mm - a.x_mm) / chord, (b.y_mm - a.y_mm) / chord);
    // Signed distance from the midpoint to the centre along the left normal.
    let h = (chord / 2.0) / (theta / 2.0).tan();
    let c = Point2::new(mx - uy * h, my + ux * h);
    let a0 = (a.y_mm - c.y_mm).atan2(a.x_mm - c.x_mm);
    let mut pts = arc_points(c, r, a0, theta, tol);
    // The last point is b itself (no drift from the trigonometry).
    if let Some(last) = pts.last_mut() {
        *last = b;
    }
    pts
}
