//! Pairing two faces: each contour started at the same place (the +X ray from its centroid),
//! resampled by arc length to `n` points, and the ruled die of the two.

use super::contour_check::self_intersection;
use super::flatten::dist_to_segment;
use super::{cad_err, CadError, Contour, MAX_POINTS};
use crate::wire::{Die, Point2, WireError};

/// Area centroid of the closed polygon `pts` (non-zero area).
pub fn centroid(pts: &[Point2]) -> Point2 {
    let n = pts.len();
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (p, q) = (pts[i], pts[(i + 1) % n]);
        let c = p.x_mm * q.y_mm - q.x_mm * p.y_mm;
        a += c;
        cx += (p.x_mm + q.x_mm) * c;
        cy += (p.y_mm + q.y_mm) * c;
    }
    Point2::new(cx / (3.0 * a), cy / (3.0 * a))
}

/// Where the contour starts: the outermost crossing of the ray from its centroid towards +X
/// (edge index and point); without a crossing (a centroid right of the whole contour cannot
/// happen for a closed one, but a grazing ray can miss), the point of largest x.
pub fn start_point(pts: &[Point2]) -> (usize, Point2) {
    let c = centroid(pts);
    let n = pts.len();
    let mut best: Option<(usize, Point2)> = None;
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        // Half-open in y so a vertex on the ray counts once.
        if (a.y_mm <= c.y_mm) != (b.y_mm <= c.y_mm) {
            let t = (c.y_mm - a.y_mm) / (b.y_mm - a.y_mm);
            let x = a.x_mm + (b.x_mm - a.x_mm) * t;
            if x >= c.x_mm && best.is_none_or(|(_, p)| x > p.x_mm) {
                best = Some((i, Point2::new(x, c.y_mm)));
            }
        }
    }
    best.unwrap_or_else(|| {
        let i = (0..n).max_by(|&a, &b| pts[a].x_mm.total_cmp(&pts[b].x_mm)).unwrap_or(0);
        (i, pts[i])
    })
}

/// A contour resampled for pairing.
#[derive(Clone, Debug, PartialEq)]
pub struct Resampled {
    /// `n` points, counter-clockwise, equally spaced along the contour from [`start_point`].
    pub points: Vec<Point2>,
    /// Largest distance of the flattened contour from the resampled polygon, mm (corners the
    /// samples cut).
    pub deviation_mm: f64,
}

/// Resamples the closed counter-clockwise contour `pts` to `n` points equally spaced by arc
/// length, starting at [`start_point`].
pub fn resample(pts: &[Point2], n: usize) -> Resampled {
    let (i0, s) = start_point(pts);
    let m = pts.len();
    // The loop from the start point round to it again.
    let mut ring = Vec::with_capacity(m + 2);
    ring.push(s);
    for k in 1..=m {
        ring.push(pts[(i0 + k) % m]);
    }
    ring.push(s);
    ring.dedup_by(|a, b| a.dist_mm(*b) <= 1e-12);
    let mut cum = vec![0.0];
    for w in ring.windows(2) {
        cum.push(cum[cum.len() - 1] + w[0].dist_mm(w[1]));
    }
    let total = cum[cum.len() - 1];
    let at = |d: f64, j: &mut usize| {
        while *j + 2 < cum.len() && cum[*j + 1] < d {
            *j += 1;
        }
        let seg = cum[*j + 1] - cum[*j];
        let t = if seg > 0.0 { ((d - cum[*j]) / seg).clamp(0.0, 1.0) } else { 0.0 };
        let (a, b) = (ring[*j], ring[*j + 1]);
        Point2::new(a.x_mm + (b.x_mm - a.x_mm) * t, a.y_mm + (b.y_mm - a.y_mm) * t)
    };
    let mut j = 0;
    let points: Vec<Point2> = (0..n).map(|k| at(total * k as f64 / n as f64, &mut j)).collect();
    // Each vertex of the flattened contour against the resampled chord that spans it.
    let spacing = total / n as f64;
    let mut deviation_mm = 0.0f64;
    for (v, &d) in ring.iter().zip(&cum) {
        let k = ((d / spacing).floor() as usize).min(n - 1);
        let (a, b) = (points[k], points[(k + 1) % n]);
        deviation_mm = deviation_mm.max(dist_to_segment(*v, a, b));
    }
    Resampled { points, deviation_mm }
}

/// Why two contours could not be paired: a face (named by its file) or a parameter.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PairError {
    #[error(transparent)]
    Cad(#[from] CadError),
    #[error(transparent)]
    Wire(#[from] WireError),
}

/// The two faces of a contour die.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourPair {
    pub top: Contour,
    pub bottom: Contour,
    pub top_resampled: Resampled,
    pub bottom_resampled: Resampled,
    pub die: Die,
}

/// Pairs `top` (at Z = `zt_mm`) and `bottom` (Z = 0) with `n` points each: the die's faces are
/// the resampled points and the first again (the cut closes).
pub fn pair(
    top: Contour,
    bottom: Contour,
    zt_mm: f64,
    n: usize,
) -> std::result::Result<ContourPair, PairError> {
    if !(3..=MAX_POINTS).contains(&n) {
        return Err(PairError::Wire(WireError::BadParameter {
            name: "points",
            value: n as f64,
            reason: "must be 3 .. 100000",
        }));
    }
    let (tr, br) = (resample(&top.points, n), resample(&bottom.points, n));
    // Too few points can cut across a thin part of a face.
    for (c, r) in [(&top, &tr), (&bottom, &br)] {
        if let Some((_, _, p)) = self_intersection(&r.points) {
            return Err(PairError::Cad(cad_err(
                &c.source,
                format!(
                    "resampled to {n} points the face crosses itself near ({:.3}, {:.3}) mm: use \
                     more points",
                    p.x_mm, p.y_mm
                ),
            )));
        }
    }
    let close = |v: &[Point2]| v.iter().copied().chain(v.first().copied()).collect::<Vec<_>>();
    let die = Die::new(zt_mm, close(&tr.points), close(&br.points))?;
    Ok(ContourPair { top, bottom, top_resampled: tr, bottom_resampled: br, die })
}
