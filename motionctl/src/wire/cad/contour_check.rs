//! Whether a flattened contour can be a die face: finite, not degenerate, not crossing itself.

use super::{cad_err, Result, MAX_FLAT_POINTS};
use crate::wire::area::polygon_area_signed_mm2;
use crate::wire::Point2;

/// Checks a flattened closed polyline (finite, not degenerate, not self-intersecting) and makes
/// it counter-clockwise without a repeated closing point.
pub fn finish_contour(source: &str, mut pts: Vec<Point2>) -> Result<Vec<Point2>> {
    if let Some((i, p)) =
        pts.iter().enumerate().find(|(_, p)| !(p.x_mm.is_finite() && p.y_mm.is_finite()))
    {
        return Err(cad_err(
            source,
            format!("point {i} of the contour is not finite ({}, {})", p.x_mm, p.y_mm),
        ));
    }
    pts.dedup_by(|a, b| a.dist_mm(*b) <= 1e-9);
    while pts.len() > 1 && pts[0].dist_mm(pts[pts.len() - 1]) <= 1e-9 {
        pts.pop();
    }
    if pts.len() < 3 {
        return Err(cad_err(
            source,
            format!("the contour has {} distinct point(s): nothing to cut", pts.len()),
        ));
    }
    if pts.len() > MAX_FLAT_POINTS {
        return Err(cad_err(
            source,
            format!(
                "the contour flattens to {} points (most {MAX_FLAT_POINTS}): use a larger chord \
                 tolerance",
                pts.len()
            ),
        ));
    }
    if let Some((a, b, p)) = self_intersection(&pts) {
        return Err(cad_err(
            source,
            format!(
                "the contour crosses itself near ({:.3}, {:.3}) mm (edges {a} and {b})",
                p.x_mm, p.y_mm
            ),
        ));
    }
    let area = polygon_area_signed_mm2(&pts);
    let scale = pts.iter().map(|p| p.norm_mm()).fold(0.0, f64::max).max(1.0);
    if area.abs() <= 1e-9 * scale * scale {
        return Err(cad_err(source, "the contour encloses no area (degenerate)"));
    }
    if area < 0.0 {
        pts.reverse();
    }
    Ok(pts)
}

/// First crossing of two non-adjacent edges of the closed polyline `pts`: the edge indices and
/// the point. A sweep over the edges sorted by their lowest x.
pub fn self_intersection(pts: &[Point2]) -> Option<(usize, usize, Point2)> {
    let n = pts.len();
    let edge = |i: usize| (pts[i], pts[(i + 1) % n]);
    let mut order: Vec<usize> = (0..n).collect();
    let lo = |i: usize| edge(i).0.x_mm.min(edge(i).1.x_mm);
    order.sort_by(|&a, &b| lo(a).total_cmp(&lo(b)));
    for (k, &i) in order.iter().enumerate() {
        let (a0, a1) = edge(i);
        let hi = a0.x_mm.max(a1.x_mm);
        for &j in &order[k + 1..] {
            if lo(j) > hi {
                break;
            }
            let adjacent = (i + 1) % n == j || (j + 1) % n == i;
            if adjacent {
                continue;
            }
            let (b0, b1) = edge(j);
            if let Some(p) = segments_cross(a0, a1, b0, b1) {
                return Some((i.min(j), i.max(j), p));
            }
        }
    }
    None
}

fn cross(o: Point2, a: Point2, b: Point2) -> f64 {
    (a.x_mm - o.x_mm) * (b.y_mm - o.y_mm) - (a.y_mm - o.y_mm) * (b.x_mm - o.x_mm)
}

/// Where segments a0-a1 and b0-b1 meet (touching counts), if they do.
fn segments_cross(a0: Point2, a1: Point2, b0: Point2, b1: Point2) -> Option<Point2> {
    if a0.y_mm.max(a1.y_mm) < b0.y_mm.min(b1.y_mm) || b0.y_mm.max(b1.y_mm) < a0.y_mm.min(a1.y_mm) {
        return None;
    }
    let (d1, d2) = (cross(b0, b1, a0), cross(b0, b1, a1));
    let (d3, d4) = (cross(a0, a1, b0), cross(a0, a1, b1));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        let t = d1 / (d1 - d2);
        return Some(Point2::new(
            a0.x_mm + (a1.x_mm - a0.x_mm) * t,
            a0.y_mm + (a1.y_mm - a0.y_mm) * t,
        ));
    }
    // Collinear overlaps and touching ends of non-adjacent edges.
    let on = |p: Point2, q0: Point2, q1: Point2, d: f64| {
        d == 0.0
            && p.x_mm >= q0.x_mm.min(q1.x_mm)
            && p.x_mm <= q0.x_mm.max(q1.x_mm)
            && p.y_mm >= q0.y_mm.min(q1.y_mm)
            && p.y_mm <= q0.y_mm.max(q1.y_mm)
    };
    [(a0, b0, b1, d1), (a1, b0, b1, d2), (b0, a0, a1, d3), (b1, a0, a1, d4)]
        .into_iter()
        .find(|&(p, q0, q1, d)| on(p, q0, q1, d))
        .map(|(p, ..)| p)
}
