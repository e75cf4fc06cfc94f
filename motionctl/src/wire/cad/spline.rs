//! DXF SPLINE entities: the (rational) B-spline evaluated by de Boor and flattened within the
//! chord tolerance.

use super::flatten::dist_to_segment;
use super::{MAX_DEPTH, MAX_FLAT_POINTS};
use crate::wire::Point2;

/// A DXF SPLINE as points within `tol`: the (rational) B-spline of its control points, knots
/// and weights; a spline with fit points only is taken as the polyline through them.
pub(super) fn spline_points(
    s: &dxf::entities::Spline,
    tol: f64,
) -> std::result::Result<Vec<Point2>, String> {
    let ctrl: Vec<[f64; 3]> = s.control_points.iter().map(|p| [p.x, p.y, p.z]).collect();
    let all_finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if ctrl.is_empty() {
        let fit: Vec<Point2> = s.fit_points.iter().map(|p| Point2::new(p.x, p.y)).collect();
        if fit.len() < 2 {
            return Err("no control points and fewer than 2 fit points".into());
        }
        if !fit.iter().all(|p| p.x_mm.is_finite() && p.y_mm.is_finite()) {
            return Err("a fit point is not finite".into());
        }
        return Ok(fit);
    }
    if ctrl.iter().any(|p| p[2].abs() > 1e-9) {
        return Err("a control point is off the XY plane".into());
    }
    let p = usize::try_from(s.degree_of_curve).ok().filter(|&d| (1..=11).contains(&d));
    let p = p.ok_or_else(|| format!("degree {} is not 1..11", s.degree_of_curve))?;
    let n = ctrl.len();
    let knots = &s.knot_values;
    if knots.len() != n + p + 1 {
        return Err(format!(
            "{} knots for {n} control points of degree {p} (want {})",
            knots.len(),
            n + p + 1
        ));
    }
    if !all_finite(knots) || !ctrl.iter().all(|c| all_finite(c)) {
        return Err("a knot or control point is not finite".into());
    }
    if knots.windows(2).any(|w| w[1] < w[0]) {
        return Err("the knots decrease".into());
    }
    let weights: Vec<f64> = if s.weight_values.is_empty() {
        vec![1.0; n]
    } else if s.weight_values.len() == n
        && s.weight_values.iter().all(|w| w.is_finite() && *w > 0.0)
    {
        s.weight_values.clone()
    } else {
        return Err(format!(
            "{} weights for {n} control points (each finite > 0)",
            s.weight_values.len()
        ));
    };
    let (u0, u1) = (knots[p], knots[n]);
    if u1.partial_cmp(&u0) != Some(std::cmp::Ordering::Greater) {
        return Err("the knots span no parameter range".into());
    }
    let eval = |u: f64| nurbs_point(p, knots, &ctrl, &weights, u);
    let mut out = vec![eval(u0)];
    // Each non-empty knot span, split in 4, then halved until the chord is within tol of the
    // curve at the quarter points.
    for k in p..n {
        let (a, b) = (knots[k], knots[k + 1]);
        if b <= a {
            continue;
        }
        for q in 0..4 {
            let (s0, s1) = (a + (b - a) * q as f64 / 4.0, a + (b - a) * (q + 1) as f64 / 4.0);
            refine(&eval, s0, s1, eval(s0), eval(s1), tol, 0, &mut out);
            if out.len() > MAX_FLAT_POINTS {
                return Err(format!(
                    "more than {MAX_FLAT_POINTS} points: use a larger chord tolerance"
                ));
            }
        }
    }
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn refine(
    eval: &dyn Fn(f64) -> Point2,
    a: f64,
    b: f64,
    pa: Point2,
    pb: Point2,
    tol: f64,
    depth: u32,
    out: &mut Vec<Point2>,
) {
    let m = (a + b) / 2.0;
    let pm = eval(m);
    let dev = [0.25, 0.75]
        .iter()
        .map(|f| dist_to_segment(eval(a + (b - a) * f), pa, pb))
        .fold(dist_to_segment(pm, pa, pb), f64::max);
    if dev <= tol || depth >= MAX_DEPTH {
        out.push(pb);
        return;
    }
    refine(eval, a, m, pa, pm, tol, depth + 1, out);
    refine(eval, m, b, pm, pb, tol, depth + 1, out);
}

/// Point of the rational B-spline at `u` (de Boor on homogeneous coordinates).
fn nurbs_point(p: usize, knots: &[f64], ctrl: &[[f64; 3]], w: &[f64], u: f64) -> Point2 {
    let n = ctrl.len();
    // Span k with knots[k] <= u < knots[k + 1], k in p..n (u at the end uses the last span).
    let mut k = p;
    while k + 1 < n && u >= knots[k + 1] {
        k += 1;
    }
    let mut d: Vec<[f64; 3]> = (0..=p)
        .map(|j| {
            let c = ctrl[j + k - p];
            let wj = w[j + k - p];
            [c[0] * wj, c[1] * wj, wj]
        })
        .collect();
    for r in 1..=p {
        for j in (r..=p).rev() {
            let i = j + k - p;
            let den = knots[i + p + 1 - r] - knots[i];
            let alpha = if den > 0.0 { (u - knots[i]) / den } else { 0.0 };
            let prev = d[j - 1];
            for (v, q) in d[j].iter_mut().zip(prev) {
                *v = (1.0 - alpha) * q + alpha * *v;
            }
        }
    }
    let h = d[p];
    Point2::new(h[0] / h[2], h[1] / h[2])
}
