//! Profile generators. Every generator returns a closed profile: `n + 1` points, the last equal
//! to the first (the thesis's "point N+1", seed L2253), so that top and bottom pair 1:1.

use super::{positive, Point2, Result, WireError};
use std::f64::consts::{PI, TAU};

fn count(name: &'static str, n: usize, multiple_of: usize) -> Result<usize> {
    if n == 0 || !n.is_multiple_of(multiple_of) {
        return Err(WireError::BadParameter {
            name,
            value: n as f64,
            reason: match multiple_of {
                20 => "must be a positive multiple of 20",
                4 => "must be a positive multiple of 4",
                2 => "must be a positive even number",
                _ => "must be a positive multiple of the shape's period",
            },
        });
    }
    Ok(n)
}

/// The thesis's circle arcs (BASIC 1160): (end angle in degrees, multiplier CR). The sum of the
/// multipliers is 20, one per arc of the complex shape, so the circle's points sit at the same
/// angles as the complex shape's (seed L2229).
pub const CIRCLE_ARCS_DEG_CR: [(f64, usize); 5] =
    [(120.0, 4), (140.0, 5), (260.0, 4), (280.0, 3), (360.0, 4)];

/// Top circle of the circle -> complex die (seed L2229-2303): five arcs from
/// [`CIRCLE_ARCS_DEG_CR`], arc `i` split into `NP * CR` equal steps with `NP = n / 20`.
/// `n` must be a positive multiple of 20.
pub fn circle_arcs(radius_mm: f64, n: usize) -> Result<Vec<Point2>> {
    positive("radius_mm", radius_mm)?;
    let np = count("n", n, 20)? / 20;
    let mut out = Vec::with_capacity(n + 1);
    let mut start_deg = 0.0;
    for (k, &(end_deg, cr)) in CIRCLE_ARCS_DEG_CR.iter().enumerate() {
        let steps = np * cr;
        let step_rad = (end_deg - start_deg).to_radians() / steps as f64;
        let nop = if k == CIRCLE_ARCS_DEG_CR.len() - 1 { steps + 1 } else { steps };
        for j in 0..nop {
            let sy = f64::to_radians(start_deg) + j as f64 * step_rad;
            out.push(Point2::new(radius_mm * sy.cos(), radius_mm * sy.sin()));
        }
        start_deg = end_deg;
    }
    Ok(out)
}

/// Circle of `n` equal steps starting at `start_deg` (Appendix C2/C4/C7: C4 starts at 45 deg,
/// C7 at 0 deg, the taper die's bottom at 180 deg).
pub fn circle_uniform(radius_mm: f64, n: usize, start_deg: f64) -> Result<Vec<Point2>> {
    positive("radius_mm", radius_mm)?;
    count("n", n, 1)?;
    if !start_deg.is_finite() {
        return Err(WireError::BadParameter {
            name: "start_deg",
            value: start_deg,
            reason: "must be finite",
        });
    }
    let s0 = start_deg.to_radians();
    Ok((0..=n)
        .map(|i| {
            let sy = s0 + TAU * i as f64 / n as f64;
            Point2::new(radius_mm * sy.cos(), radius_mm * sy.sin())
        })
        .collect())
}

/// Top circle of the circle -> crescent die (seed L2550-2552): `n/2` equal steps over 0..250 deg
/// (matching the crescent's outer edge) and `n/2` equal steps over 250..360 deg.
pub fn circle_for_crescent(radius_mm: f64, n: usize) -> Result<Vec<Point2>> {
    positive("radius_mm", radius_mm)?;
    let h = count("n", n, 2)? / 2;
    let mut out = Vec::with_capacity(n + 1);
    for i in 0..=n {
        let deg = if i <= h {
            250.0 * i as f64 / h as f64
        } else {
            250.0 + 110.0 * (i - h) as f64 / h as f64
        };
        let sy = f64::to_radians(deg);
        out.push(Point2::new(radius_mm * sy.cos(), radius_mm * sy.sin()));
    }
    Ok(out)
}

/// The 20 arcs of the complex shape at unit scale, each as (first, middle, last) point
/// (BASIC DATA 1720-1865, seed L2403-2426). OCR repairs, all checked against Table 8:
/// missing commas at L2406, L2409, L2418, L2419, L2422, L2423, L2424; a lost '.' in
/// "02840379" (L2407) and "-54" (L2411, first point of arc 9 = last point of arc 8); and the
/// last point of arc 17 ".034" (L2423) is 0.0348, the first point of arc 18 (with 0.034 the
/// points of Table 8 rows 66-69 are off by up to 0.016 mm; with 0.0348 by < 0.001 mm).
/// The middle point of arc 16 is not between its end points; the thesis's arc angle
/// `ATN(...)` (BASIC 2000) takes the short way from the first to the last point, so the
/// generator does the same.
pub const COMPLEX_ARCS: [[f64; 6]; 20] = [
    [1.0, 0.0, 0.8531129, 0.3387312, 0.641536, 0.546],
    [0.641536, 0.546, 0.4082422, 0.6595622, 0.2261, 0.6956],
    [0.2261, 0.6956, 0.0738449, 0.6902335, -0.0306225, 0.5793417],
    [-0.0306225, 0.5793417, -0.02690384, 0.4270375, 0.0, 0.3826],
    [0.0, 0.3826, 0.0277976, 0.333715, 0.02840379, 0.250094],
    [0.02840379, 0.2500941, -0.04309334, 0.1663128, -0.0696, 0.1565],
    [-0.0696, 0.1565, -0.166, 0.1804, -0.226, 0.2087],
    [-0.226, 0.2087, -0.4323, 0.35032, -0.54, 0.4783],
    [-0.54, 0.4783, -0.696, 0.515, -0.8, 0.4869],
    [-0.8, 0.4869, -0.978, 0.2165, -1.0, 0.0],
    [-1.0, 0.0, -0.926, -0.4149, -0.8984189, -0.4687486],
    [-0.8984189, -0.4687486, -0.831338, -0.5701419, -0.75, -0.6605],
    [-0.75, -0.6605, -0.6422, -0.7632, -0.522, -0.8],
    [-0.522, -0.8, -0.3811398, -0.7282893, -0.3478, -0.626],
    [-0.3478, -0.626, -0.333, -0.4484, -0.3478, -0.3304],
    [-0.3478, -0.3304, -0.3924, -0.504, -0.0696, -0.313],
    [-0.0696, -0.313, -0.00064, -0.414, 0.0348, -0.4869],
    [0.0348, -0.4869, 0.246, -0.663, 0.4174, -0.7304],
    [0.4174, -0.7304, 0.6938, -0.698, 0.8348, -0.5739],
    [0.8348, -0.5739, 0.976, -0.241, 1.0, 0.0],
];

/// Centre of the circle through three points, or `None` if they are collinear.
pub fn circumcentre(a: Point2, b: Point2, c: Point2) -> Option<Point2> {
    let d = 2.0
        * (a.x_mm * (b.y_mm - c.y_mm) + b.x_mm * (c.y_mm - a.y_mm) + c.x_mm * (a.y_mm - b.y_mm));
    if d.abs() < 1e-12 {
        return None;
    }
    let (a2, b2, c2) = (
        a.x_mm * a.x_mm + a.y_mm * a.y_mm,
        b.x_mm * b.x_mm + b.y_mm * b.y_mm,
        c.x_mm * c.x_mm + c.y_mm * c.y_mm,
    );
    Some(Point2::new(
        (a2 * (b.y_mm - c.y_mm) + b2 * (c.y_mm - a.y_mm) + c2 * (a.y_mm - b.y_mm)) / d,
        (a2 * (c.x_mm - b.x_mm) + b2 * (a.x_mm - c.x_mm) + c2 * (b.x_mm - a.x_mm)) / d,
    ))
}

/// Wraps an angle to (-pi, pi].
pub(crate) fn wrap_pi(a: f64) -> f64 {
    let w = a.rem_euclid(TAU);
    if w > PI {
        w - TAU
    } else {
        w
    }
}

/// Arcs through three points each: `n_per_arc` equal angular steps per arc from its first
/// point the short way to its last point, plus the closing point. `arcs` are unit-scale
/// (first, middle, last) triples multiplied by `scale_mm`.
pub fn three_point_arcs(arcs: &[[f64; 6]], scale_mm: f64, n_per_arc: usize) -> Result<Vec<Point2>> {
    positive("scale_mm", scale_mm)?;
    count("n_per_arc", n_per_arc, 1)?;
    let mut out = Vec::with_capacity(arcs.len() * n_per_arc + 1);
    for (i, a) in arcs.iter().enumerate() {
        let p = |k: usize| Point2::new(a[2 * k] * scale_mm, a[2 * k + 1] * scale_mm);
        let (f, m, s) = (p(0), p(1), p(2));
        let c = circumcentre(f, m, s)
            .ok_or(WireError::Degenerate { index: i, reason: "arc points are collinear" })?;
        let r = f.dist_mm(c);
        let a1 = (f.y_mm - c.y_mm).atan2(f.x_mm - c.x_mm);
        let sweep = wrap_pi((s.y_mm - c.y_mm).atan2(s.x_mm - c.x_mm) - a1);
        let nop = if i + 1 == arcs.len() { n_per_arc + 1 } else { n_per_arc };
        for j in 0..nop {
            let sy = a1 + sweep * j as f64 / n_per_arc as f64;
            out.push(Point2::new(r * sy.cos() + c.x_mm, r * sy.sin() + c.y_mm));
        }
    }
    Ok(out)
}

/// The 20-arc complex shape of the thesis (seed L2311-2505) at magnification `ri_mm`
/// (unit scale x `ri_mm`); `n` must be a positive multiple of 20.
pub fn complex(ri_mm: f64, n: usize) -> Result<Vec<Point2>> {
    let np = count("n", n, 20)? / 20;
    three_point_arcs(&COMPLEX_ARCS, ri_mm, np)
}

/// Crescent (seed L2550-2642): outer edge of radius `rb_mm` from 0 to 250 deg in `n/2` steps;
/// inner edge an arc centred at the midpoint C of O and L (L = midpoint of the chord from the
/// 0 deg corner A to the 250 deg corner B) through A and B, traversed back from B to A in
/// `n/2` steps. `n` must be even.
pub fn crescent(rb_mm: f64, n: usize) -> Result<Vec<Point2>> {
    positive("rb_mm", rb_mm)?;
    let h = count("n", n, 2)? / 2;
    let mut out = Vec::with_capacity(n + 1);
    for i in 0..=h {
        let sy = f64::to_radians(250.0 * i as f64 / h as f64);
        out.push(Point2::new(rb_mm * sy.cos(), rb_mm * sy.sin()));
    }
    let (a, b) = (out[0], out[h]);
    let l = Point2::new((a.x_mm + b.x_mm) / 2.0, (a.y_mm + b.y_mm) / 2.0);
    let c = Point2::new(l.x_mm / 2.0, l.y_mm / 2.0);
    let rb1 = a.dist_mm(c);
    let beta1 = (a.y_mm - c.y_mm).atan2(a.x_mm - c.x_mm);
    let mut beta = (b.y_mm - c.y_mm).atan2(b.x_mm - c.x_mm);
    if beta < beta1 {
        beta += TAU;
    }
    for k in 1..=h {
        let sy = beta - (beta - beta1) * k as f64 / h as f64;
        out.push(Point2::new(rb1 * sy.cos() + c.x_mm, rb1 * sy.sin() + c.y_mm));
    }
    Ok(out)
}

/// Rectangle `c_mm` (along X) by `d_mm` (along Y), `n/4` steps per side, starting at the corner
/// (C/2, D/2) and running counter-clockwise (Appendix C4, BASIC 1830-1970, seed L2703-2717).
/// With `thesis_int` the running coordinate is floored like the thesis's `INT()`; the
/// perimeter is unchanged (the points stay on the sides) but the spacing is uneven.
pub fn prismatic(c_mm: f64, d_mm: f64, n: usize, thesis_int: bool) -> Result<Vec<Point2>> {
    positive("c_mm", c_mm)?;
    positive("d_mm", d_mm)?;
    let n2 = count("n", n, 4)? / 4;
    let (c1, d1) = (c_mm / 2.0, d_mm / 2.0);
    let (px, py) = (c_mm / n2 as f64, d_mm / n2 as f64);
    let f = |v: f64| if thesis_int { v.floor() } else { v };
    let mut out = Vec::with_capacity(n + 1);
    for i in 0..n2 {
        out.push(Point2::new(f(c1 - px * i as f64), d1));
    }
    for i in 0..n2 {
        out.push(Point2::new(-c1, f(d1 - py * i as f64)));
    }
    for i in 0..n2 {
        out.push(Point2::new(f(-c1 + px * i as f64), -d1));
    }
    for i in 0..=n2 {
        out.push(Point2::new(c1, f(-d1 + py * i as f64)));
    }
    Ok(out)
}

/// Star with `arms` points: outer vertices at `outer_mm` (the first at 0 deg), inner vertices at
/// `inner_mm`, `n / (2 * arms)` equal steps on each edge. The thesis's own star is an 80-point
/// DATA table in Volume II (Appendix C7, BASIC 1540-1690) that is not in the seed, so this is a
/// parametric substitute, not a reproduction.
pub fn star(outer_mm: f64, inner_mm: f64, arms: usize, n: usize) -> Result<Vec<Point2>> {
    positive("outer_mm", outer_mm)?;
    positive("inner_mm", inner_mm)?;
    if arms < 2 {
        return Err(WireError::BadParameter {
            name: "arms",
            value: arms as f64,
            reason: "must be at least 2",
        });
    }
    let per_edge = count("n", n, 2 * arms)? / (2 * arms);
    let vertex = |k: usize| {
        let a = PI * k as f64 / arms as f64;
        let r = if k.is_multiple_of(2) { outer_mm } else { inner_mm };
        Point2::new(r * a.cos(), r * a.sin())
    };
    let mut out = Vec::with_capacity(n + 1);
    for k in 0..2 * arms {
        let (p, q) = (vertex(k), vertex(k + 1));
        for j in 0..per_edge {
            let t = j as f64 / per_edge as f64;
            out.push(Point2::new(p.x_mm + (q.x_mm - p.x_mm) * t, p.y_mm + (q.y_mm - p.y_mm) * t));
        }
    }
    out.push(out[0]);
    Ok(out)
}
