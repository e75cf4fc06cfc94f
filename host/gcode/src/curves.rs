//! Arcs and splines as straight segments within a chord tolerance, for a planner that moves in
//! lines. The default tolerance is grbl's arc tolerance, 0.002 mm.

use crate::arc::find_turn;
use crate::canon::{ControlPoint, Pos};
use crate::frame::Motion;

/// grbl's default `$12` arc tolerance, mm.
pub const DEFAULT_CHORD_TOLERANCE_MM: f64 = 0.002;
/// Most segments one curve is cut into (a guard against absurd radii or tolerances).
pub const MAX_SEGMENTS: usize = 1 << 20;

/// The points (after the start) of a straight-segment path for `m`, each within `tol_mm` of
/// the curve; lines give their end point.
pub fn flatten(m: &Motion, tol_mm: f64) -> Vec<Pos> {
    match m {
        Motion::Arc { from, to, center, axes, turn, .. } => {
            arc(from, to, center, *axes, *turn, tol_mm)
        }
        Motion::Nurbs { from, points, order, .. } => nurbs(from, points, *order, tol_mm),
        other => vec![other.end()],
    }
}

/// Segment count so that a chord's sagitta stays within `tol` on radius `r` over `angle`.
fn segments(angle: f64, r: f64, tol: f64) -> usize {
    if r.is_nan() || r <= 0.0 || !angle.is_finite() {
        return 1;
    }
    let tol = tol.max(1e-9);
    let max_step = if tol >= r { std::f64::consts::PI } else { 2.0 * (1.0 - tol / r).acos() };
    let n = (angle.abs() / max_step).ceil();
    if n.is_finite() {
        (n as usize).clamp(1, MAX_SEGMENTS)
    } else {
        MAX_SEGMENTS
    }
}

/// A circular or helical arc (machine coordinates) as points.
pub fn arc(
    from: &Pos,
    to: &Pos,
    center: &[f64; 3],
    axes: [usize; 3],
    turn: i32,
    tol: f64,
) -> Vec<Pos> {
    let [a1, a2, a3] = axes;
    let p1 = (from[a1], from[a2]);
    let p2 = (to[a1], to[a2]);
    let c = (center[a1], center[a2]);
    let theta = find_turn(p1, c, turn, p2);
    let r1 = (p1.0 - c.0).hypot(p1.1 - c.1);
    let r2 = (p2.0 - c.0).hypot(p2.1 - c.1);
    let start_angle = (p1.1 - c.1).atan2(p1.0 - c.0);
    let n = segments(theta, r1.max(r2), tol);
    let mut out = Vec::with_capacity(n);
    for k in 1..=n {
        if k == n {
            out.push(*to);
            break;
        }
        let t = k as f64 / n as f64;
        let ang = start_angle + theta * t;
        // A spiral if the radii differ slightly (rs274 allows it within its tolerance).
        let r = r1 + (r2 - r1) * t;
        let mut p = *from;
        p[a1] = c.0 + r * ang.cos();
        p[a2] = c.1 + r * ang.sin();
        p[a3] = from[a3] + (to[a3] - from[a3]) * t;
        for i in 3..6 {
            p[i] = from[i] + (to[i] - from[i]) * t;
        }
        out.push(p);
    }
    out
}

/// LinuxCNC's knot vector for `n + 1` control points of order `k`.
fn knots(n: usize, k: usize) -> Vec<f64> {
    (0..=n + k)
        .map(|i| {
            if i < k {
                0.0
            } else if i <= n {
                (i - k + 1) as f64
            } else {
                (n + 2 - k) as f64
            }
        })
        .collect()
}

/// The curve point at parameter `u` (de Boor's algorithm on homogeneous points).
fn nurbs_point(pts: &[ControlPoint], k: usize, kn: &[f64], u: f64) -> (f64, f64) {
    let n = pts.len() - 1;
    let umax = kn[n + 1];
    let u = u.clamp(0.0, umax);
    // The knot span: kn[s] <= u < kn[s + 1], the last span for u = umax.
    let mut s = k - 1;
    while s < n && kn[s + 1] <= u {
        s += 1;
    }
    let mut d: Vec<[f64; 3]> = (0..k)
        .map(|j| {
            let p = pts[s + 1 - k + j];
            [p.x * p.w, p.y * p.w, p.w]
        })
        .collect();
    for r in 1..k {
        for j in (r..k).rev() {
            let i = s + 1 - k + j;
            let den = kn[i + k - r] - kn[i];
            let a = if den == 0.0 { 0.0 } else { (u - kn[i]) / den };
            for c in 0..3 {
                d[j][c] = (1.0 - a) * d[j - 1][c] + a * d[j][c];
            }
        }
    }
    let h = d[k - 1];
    if h[2] == 0.0 {
        (h[0], h[1])
    } else {
        (h[0] / h[2], h[1] / h[2])
    }
}

/// A NURBS in XY (machine coordinates) as points, subdivided until each chord is within `tol`.
pub fn nurbs(from: &Pos, pts: &[ControlPoint], order: u32, tol: f64) -> Vec<Pos> {
    let k = order as usize;
    if pts.len() < 2 || k < 2 || pts.len() < k {
        let mut p = *from;
        if let Some(last) = pts.last() {
            (p[0], p[1]) = (last.x, last.y);
        }
        return vec![p];
    }
    let n = pts.len() - 1;
    let kn = knots(n, k);
    let umax = kn[n + 1];
    let tol = tol.max(1e-9);
    let mut us = vec![0.0, umax];
    // Breadth-first subdivision with a cap on the point count.
    let mut i = 0;
    while i + 1 < us.len() && us.len() < MAX_SEGMENTS {
        let (u0, u1) = (us[i], us[i + 1]);
        let (p0, p1) = (nurbs_point(pts, k, &kn, u0), nurbs_point(pts, k, &kn, u1));
        let um = 0.5 * (u0 + u1);
        let pm = nurbs_point(pts, k, &kn, um);
        let (qa, qb) = (
            nurbs_point(pts, k, &kn, u0 + 0.25 * (u1 - u0)),
            nurbs_point(pts, k, &kn, u0 + 0.75 * (u1 - u0)),
        );
        let err = [pm, qa, qb].iter().map(|q| dist_to_segment(*q, p0, p1)).fold(0.0, f64::max);
        if err > tol && u1 - u0 > 1e-9 {
            us.insert(i + 1, um);
        } else {
            i += 1;
        }
    }
    us[1..]
        .iter()
        .map(|&u| {
            let (x, y) = nurbs_point(pts, k, &kn, u);
            let mut p = *from;
            (p[0], p[1]) = (x, y);
            p
        })
        .collect()
}

fn dist_to_segment(q: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 == 0.0 {
        0.0
    } else {
        (((q.0 - a.0) * dx + (q.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    };
    (q.0 - a.0 - t * dx).hypot(q.1 - a.1 - t * dy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_chords_stay_within_tolerance() {
        let from = [10.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let pts = arc(&from, &from, &[0.0, 0.0, 0.0], [0, 1, 2], 1, 0.002);
        // A full circle of radius 10 at 0.002 mm: 2*pi / (2*acos(1 - 0.0002)) = 157.1 -> 158.
        assert_eq!(pts.len(), 158);
        let mut prev = from;
        for p in &pts {
            let mid = ((prev[0] + p[0]) / 2.0).hypot((prev[1] + p[1]) / 2.0);
            assert!(10.0 - mid <= 0.002 + 1e-12);
            prev = *p;
        }
        assert_eq!(*pts.last().unwrap(), from);
    }

    #[test]
    fn helix_climbs_linearly() {
        let from = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let to = [-1.0, 0.0, 2.0, 0.0, 0.0, 0.0];
        let pts = arc(&from, &to, &[0.0, 0.0, 0.0], [0, 1, 2], 1, 0.01);
        let mid = pts[pts.len() / 2 - 1];
        assert!(mid[1] > 0.0, "counterclockwise goes through +Y");
        assert!((pts.last().unwrap()[2] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn quadratic_nurbs_is_a_bezier() {
        let cp = |x, y| ControlPoint { x, y, w: 1.0 };
        let from = [0.0; 6];
        let pts = nurbs(&from, &[cp(0.0, 0.0), cp(1.0, 2.0), cp(2.0, 0.0)], 3, 0.001);
        let last = pts.last().unwrap();
        assert!((last[0] - 2.0).abs() < 1e-12 && last[1].abs() < 1e-12);
        // The Bezier's apex is (1, 1).
        let apex = pts.iter().map(|p| p[1]).fold(0.0, f64::max);
        assert!((apex - 1.0).abs() < 0.002, "{apex}");
    }
}
