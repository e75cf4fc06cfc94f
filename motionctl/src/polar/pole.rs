//! Pole placement (Ch. 4): the area error of a contour for a machine-pole location (eq 4.2/4.3,
//! quasi-static tool path, theta unwrapped so a contour crossing theta = 0 is not mishandled),
//! the F1 surrogate (eq 4.15, XXINTT) with the ANGLE wrap pitfall fixed, and a Hooke-Jeeves search
//! (HOKJEV/HOOKE) over the pole within the work area with the pole-outside-contour constraint.
//!
//! Pole convention (Table 4.1): the machine pole O sits at (C, beta) in the contour frame (contour
//! pole O1 at the origin); the digitizer's [`super::digitize::Setup`] takes the contour pole
//! relative to the machine pole, RI = C, EPS = beta - pi. Lengths in inches.

use super::contour::Contour;
use super::work_area::WorkArea;
use super::Resolution;
use std::f64::consts::PI;

/// Square millimetres per square inch (Table 4.1 prints both).
pub const MM2_PER_IN2: f64 = 645.16;

/// Machine pole O in the contour frame, polar: distance C and angle beta.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pole {
    pub c_in: f64,
    pub beta_rad: f64,
}

impl Pole {
    /// Cartesian position of the machine pole in the contour frame.
    pub fn xy(&self) -> [f64; 2] {
        let (s, c) = self.beta_rad.sin_cos();
        [self.c_in * c, self.c_in * s]
    }

    /// From a Cartesian position (beta in [0, 2 pi)).
    pub fn from_xy(p: [f64; 2]) -> Pole {
        Pole { c_in: p[0].hypot(p[1]), beta_rad: p[1].atan2(p[0]).rem_euclid(2.0 * PI) }
    }

    /// The digitizer's (RI, EPS): contour pole relative to the machine pole.
    pub fn digitizer_pole(&self) -> (f64, f64) {
        (self.c_in, self.beta_rad - PI)
    }
}

/// Points on the contour at `n` equal parameter steps (n + 1 points, the thesis's CUREVA: equal
/// x steps for a graph, equal theta1 steps for a polar curve).
pub fn chord_points<C: Contour + ?Sized>(contour: &C, n: usize) -> Vec<[f64; 2]> {
    let (u0, u1) = contour.range();
    let n = n.max(1);
    (0..=n).map(|i| contour.jet(u0 + (u1 - u0) * i as f64 / n as f64)[0]).collect()
}

/// F1 and its parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F1 {
    /// F_dif / F_sum (minimised).
    pub f1: f64,
    pub f_dif: f64,
    pub f_sum: f64,
}

/// Below this many steps a chord counts as having none on that axis and merges into the next
/// (the listing's exact `A1 .EQ. 0.0` test, with room for rounding).
const MERGE_STEPS: f64 = 1e-9;

/// One chord's (N_R, N_theta*) in the pole frame, with the angle step `dth` (signed, wrapped).
fn chord_counts(p1: [f64; 2], p2: [f64; 2], dth: f64, res: &Resolution) -> (f64, f64) {
    let (r1, r2) = (p1[0].hypot(p1[1]), p2[0].hypot(p2[1]));
    let nr = (r2 - r1).abs() / res.dr_in;
    let mut nth = dth.abs() / res.dtheta_rad;
    if nr >= nth {
        // XXINTT: N_theta* = |u'(thU) - u'(thL)| dR / dTheta^2 with u = 1/r of the chord's line.
        // u'(th) = -sin(th - phi)/d, and sin(th - phi) = s/|P| with s the point's coordinate along
        // the line and d = |P1 x P2| / L its distance from the pole: no slope, so no 1e-60 hack
        // for vertical chords.
        let (dx, dy) = (p2[0] - p1[0], p2[1] - p1[1]);
        let len = dx.hypot(dy);
        let cross = p1[0] * p2[1] - p1[1] * p2[0];
        if len > 0.0 && cross.abs() > 0.0 {
            let s1 = (p1[0] * dx + p1[1] * dy) / len;
            let s2 = (p2[0] * dx + p2[1] * dy) / len;
            let du = (s2 / r2 - s1 / r1).abs() * len / cross.abs();
            nth = du * res.dr_in / (res.dtheta_rad * res.dtheta_rad);
        } else {
            nth = 0.0;
        }
    }
    (nr, nth)
}

/// F1 (eq 4.15, OBJECT/XXINTT) of the chord polygon `points` for the machine pole at `pole`
/// (contour frame). The angle step of a chord is the wrapped difference atan2(P1 x P2, P1 . P2),
/// so a chord crossing theta = 0 counts its few steps, not 2 pi / dTheta minus them (the listing's
/// ANGLE returns [0, 2 pi) and XXINTT subtracts the absolute values: see [`f1_as_listed`]).
pub fn f1(points: &[[f64; 2]], pole: [f64; 2], res: &Resolution) -> F1 {
    f1_with(points, pole, res, |p1, p2| (p1[0] * p2[1] - p1[1] * p2[0]).atan2(dot(p1, p2)))
}

/// F1 with the listing's angle difference | |ANGLE(P2)| - |ANGLE(P1)| | (ANGLE in [0, 2 pi)):
/// kept to show the pitfall (a chord crossing the pole's theta = 0 ray counts about 16000 angular
/// steps).
pub fn f1_as_listed(points: &[[f64; 2]], pole: [f64; 2], res: &Resolution) -> F1 {
    let angle = |p: [f64; 2]| p[1].atan2(p[0]).rem_euclid(2.0 * PI);
    f1_with(points, pole, res, |p1, p2| angle(p2) - angle(p1))
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn f1_with(
    points: &[[f64; 2]],
    pole: [f64; 2],
    res: &Resolution,
    dth: impl Fn([f64; 2], [f64; 2]) -> f64,
) -> F1 {
    let rel = |p: &[f64; 2]| [p[0] - pole[0], p[1] - pole[1]];
    let (mut f_dif, mut f_sum) = (0.0, 0.0);
    let Some(first) = points.first() else { return F1 { f1: 0.0, f_dif, f_sum } };
    let mut start = rel(first);
    for p in points.iter().skip(1) {
        let q = rel(p);
        let (nr, nth) = chord_counts(start, q, dth(start, q), res);
        if nr <= MERGE_STEPS || nth <= MERGE_STEPS {
            // The listing keeps K (the chord's start) and extends the chord to the next point.
            continue;
        }
        f_dif += (nr - nth).abs();
        f_sum += nr + nth;
        start = q;
    }
    let f1 = if f_sum > 0.0 { f_dif / f_sum } else { 1.0 };
    F1 { f1, f_dif, f_sum }
}

/// Area error (eq 4.2, eq 4.3) of a point tool following `contour` quasi-statically with the
/// machine pole at `pole`, in square inches.
///
/// The machine's grid is anchored at its home: radii k dR from the pole, angles j dTheta from
/// theta = 0. The quasi-static tool sits on an arc about the pole at the base radius B, which
/// follows the contour by truncation (B += int((r - B)/dR) dR, program CONTOUR's FINDBAS: the
/// machine radius lags the contour). Each piece between an angular grid line and the next, split
/// where B changes (the nu(i) of eq 4.3), contributes 1/2 |integral of r^2 dtheta - B^2 dtheta|.
/// The contour is followed in unwrapped theta (each sample step's angle is the wrapped difference),
/// so crossing theta = 0 or circling the pole is handled. Samples: `per_step` per resolution on
/// either axis (the listing's ISECT), r^2 integrated by trapezoids between them.
pub fn area_error_in2<C: Contour + ?Sized>(
    contour: &C,
    pole: [f64; 2],
    res: &Resolution,
    per_step: u32,
) -> f64 {
    let (u0, u1) = contour.range();
    let span = u1 - u0;
    if span.is_nan() || span <= 0.0 || per_step == 0 {
        return 0.0;
    }
    let rel = |u: f64| {
        let [p, d, _] = contour.jet(u);
        ([p[0] - pole[0], p[1] - pole[1]], d)
    };
    let (q_r, q_th) = (res.dr_in / per_step as f64, res.dtheta_rad / per_step as f64);
    let (mut x, _) = rel(u0);
    let mut r = x[0].hypot(x[1]);
    let mut th = x[1].atan2(x[0]);
    let mut u = u0;
    // A hair of slack so a contour exactly on a grid radius is on it, not one below.
    let mut base = (r / res.dr_in + 1e-9).trunc() * res.dr_in;
    let mut cell = (th / res.dtheta_rad).floor();
    let (mut acc, mut err) = (0.0, 0.0);
    let mut h = span * 1e-6;
    while u < u1 {
        let (_, d) = rel(u);
        let rr = r.max(1e-12);
        let dr = dot(x, d) / rr;
        let dth = (x[0] * d[1] - x[1] * d[0]) / (rr * rr);
        let lim =
            |rate: f64, q: f64| if rate.abs() > 1e-300 { q / rate.abs() } else { f64::INFINITY };
        h = lim(dr, q_r).min(lim(dth, q_th)).min(span * 1e-3).min(h * 4.0).max(span * 1e-12);
        let un = (u + h).min(u1);
        let (xn, _) = rel(un);
        let rn = xn[0].hypot(xn[1]);
        let thn = th + (x[0] * xn[1] - x[1] * xn[0]).atan2(dot(x, xn));
        // Walk the chord x -> xn, stopping at each angular grid line and base change.
        let (mut f, mut ra, mut tha) = (0.0f64, r, th);
        // A sample step is under a quarter resolution on each axis: a few stops at most.
        for _ in 0..8 {
            let mut next = (1.0, 0u8);
            let cell_n = (thn / res.dtheta_rad).floor();
            if cell_n != cell {
                let line =
                    if thn > th { (cell + 1.0) * res.dtheta_rad } else { cell * res.dtheta_rad };
                let g = ((line - th) / (thn - th)).clamp(f, 1.0);
                if g < next.0 {
                    next = (g, 1);
                }
            }
            for (target, kind) in [(base + res.dr_in, 2u8), (base - res.dr_in, 3u8)] {
                if (rn - target) * (r - target) <= 0.0 && rn != r {
                    let g = ((target - r) / (rn - r)).clamp(f, 1.0);
                    // Only a crossing ahead of the walk and reached by the chord counts.
                    let reached = if kind == 2 { rn >= target } else { rn <= target };
                    if reached && g < next.0 {
                        next = (g, kind);
                    }
                }
            }
            let (g, kind) = next;
            let rb = r + g * (rn - r);
            let thb = th + g * (thn - th);
            // Trapezoid in (theta, r^2): exact on an arc about the pole, O(step^3) elsewhere.
            acc += ((ra * ra + rb * rb) / 2.0 - base * base) * (thb - tha);
            match kind {
                0 => break,
                1 => {
                    err += acc.abs();
                    acc = 0.0;
                    cell += if thn > th { 1.0 } else { -1.0 };
                }
                k => {
                    err += acc.abs();
                    acc = 0.0;
                    base += if k == 2 { res.dr_in } else { -res.dr_in };
                }
            }
            if g >= 1.0 {
                break;
            }
            (f, ra, tha) = (g, rb, thb);
        }
        (u, x, r, th) = (un, xn, rn, thn);
    }
    (err + acc.abs()) / 2.0
}

/// Why a pole location is not allowed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Violation {
    /// The machine pole is inside the closed contour (winding number).
    PoleInside(i32),
    /// A contour point outside the work area.
    WorkArea { r_in: f64, theta_rad: f64 },
}

/// Samples used for the feasibility test.
pub const FEASIBILITY_SAMPLES: usize = 2000;

/// Checks the work area (about the machine pole) and, for a closed contour, that the pole is
/// outside (winding number 0), on `FEASIBILITY_SAMPLES` points of the contour.
pub fn check<C: Contour + ?Sized>(
    contour: &C,
    pole: [f64; 2],
    area: &WorkArea,
) -> Result<(), Violation> {
    let pts = chord_points(contour, FEASIBILITY_SAMPLES);
    check_points(&pts, contour.closed(), pole, area)
}

/// [`check`] on given points.
pub fn check_points(
    pts: &[[f64; 2]],
    closed: bool,
    pole: [f64; 2],
    area: &WorkArea,
) -> Result<(), Violation> {
    check_points_margin(pts, closed, pole, area, 0.0)
}

/// Margin the optimiser keeps inside the work area (inches on r, the same over 10 in on theta):
/// its feasibility test sees sample points, and the digitizer checks the path densely.
pub const SEARCH_MARGIN_IN: f64 = 0.02;

fn check_points_margin(
    pts: &[[f64; 2]],
    closed: bool,
    pole: [f64; 2],
    area: &WorkArea,
    margin_in: f64,
) -> Result<(), Violation> {
    let m_th = margin_in / 10.0;
    let rel: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] - pole[0], p[1] - pole[1]]).collect();
    if closed {
        let turn: f64 = rel
            .windows(2)
            .map(|w| (w[0][0] * w[1][1] - w[0][1] * w[1][0]).atan2(dot(w[0], w[1])))
            .sum();
        let winding = (turn / (2.0 * PI)).round() as i32;
        if winding != 0 {
            return Err(Violation::PoleInside(winding));
        }
    }
    for p in &rel {
        let (r, th) = (p[0].hypot(p[1]), p[1].atan2(p[0]));
        if r <= area.r_min_in + margin_in
            || r >= area.r_max_in - margin_in
            || th <= area.theta_min_rad + m_th
            || th >= area.theta_max_rad - m_th
        {
            return Err(Violation::WorkArea { r_in: r, theta_rad: th });
        }
    }
    Ok(())
}

/// Hooke-Jeeves settings (HOKJEV's suggested values by default).
#[derive(Clone, Copy, Debug)]
pub struct HookeJeeves {
    /// Initial exploratory move per coordinate (0.125 in).
    pub step_in: f64,
    /// Pattern move factor (ALPHA = 1.0).
    pub pattern: f64,
    /// Step reduction factor (BETA = 0.5).
    pub reduction: f64,
    /// Most function evaluations (ITMAX; the listing suggests 200, cheap now, so more).
    pub max_evals: usize,
    /// Most step reductions (NKAT = 50).
    pub max_reductions: usize,
}

impl Default for HookeJeeves {
    fn default() -> Self {
        HookeJeeves {
            step_in: 0.125,
            pattern: 1.0,
            reduction: 0.5,
            max_evals: 2000,
            max_reductions: 50,
        }
    }
}

/// Result of a search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Found {
    pub at: [f64; 2],
    pub value: f64,
    pub evals: usize,
}

/// Hooke-Jeeves direct search minimising `f` from `start` (an infeasible point should return
/// infinity: it is never accepted).
pub fn hooke_jeeves(
    mut f: impl FnMut([f64; 2]) -> f64,
    start: [f64; 2],
    hj: &HookeJeeves,
) -> Found {
    let mut evals = 1;
    let mut base = start;
    let mut best = f(base);
    let mut step = [hj.step_in; 2];
    let mut reductions = 0;
    // Exploratory moves about `p` with value `fp`.
    let explore = |p: [f64; 2],
                   fp: f64,
                   step: &[f64; 2],
                   f: &mut dyn FnMut([f64; 2]) -> f64,
                   evals: &mut usize| {
        let (mut q, mut fq) = (p, fp);
        for i in 0..2 {
            for sign in [1.0, -1.0] {
                let mut t = q;
                t[i] += sign * step[i];
                let ft = f(t);
                *evals += 1;
                if ft < fq {
                    (q, fq) = (t, ft);
                    break;
                }
            }
        }
        (q, fq)
    };
    while evals < hj.max_evals && reductions <= hj.max_reductions {
        let (new, fnew) = explore(base, best, &step, &mut f, &mut evals);
        if fnew < best {
            // Pattern moves while they keep improving.
            let (mut prev, mut cur, mut fcur) = (base, new, fnew);
            loop {
                let pat = [
                    cur[0] + hj.pattern * (cur[0] - prev[0]),
                    cur[1] + hj.pattern * (cur[1] - prev[1]),
                ];
                let fpat = f(pat);
                evals += 1;
                let (q, fq) = explore(pat, fpat, &step, &mut f, &mut evals);
                if fq < fcur && evals < hj.max_evals {
                    (prev, cur, fcur) = (cur, q, fq);
                } else {
                    break;
                }
            }
            (base, best) = (cur, fcur);
        } else {
            step = [step[0] * hj.reduction, step[1] * hj.reduction];
            reductions += 1;
        }
    }
    Found { at: base, value: best, evals }
}

/// What the pole search enforces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Constraints {
    /// The work area and the pole outside a closed contour (the thesis's stated constraints).
    WorkArea(WorkArea),
    /// Only a box of half-width `half_in` about `centre` (what HOKJEV's URK/SRK limits enforce).
    Box { centre: [f64; 2], half_in: f64 },
}

/// The optimiser's answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Optimum {
    pub pole: Pole,
    pub f1: F1,
    pub evals: usize,
}

/// Chords for F1 (the listing's N; Table 4.1 does not print it).
pub const F1_CHORDS: usize = 200;

/// Minimises F1 over the machine pole: a coarse grid of candidate poles (feasible ones only), then
/// Hooke-Jeeves from the best few (F1 is multimodal: Table 4.1 has two optima for two contours).
pub fn optimise<C: Contour + ?Sized>(
    contour: &C,
    res: &Resolution,
    constraints: Constraints,
    hj: &HookeJeeves,
) -> Option<Optimum> {
    let chords = chord_points(contour, F1_CHORDS);
    let check_pts = chord_points(contour, FEASIBILITY_SAMPLES / 4);
    let closed = contour.closed();
    let feasible = |p: [f64; 2]| match constraints {
        Constraints::WorkArea(area) => {
            check_points_margin(&check_pts, closed, p, &area, SEARCH_MARGIN_IN).is_ok()
        }
        Constraints::Box { centre, half_in } => {
            (p[0] - centre[0]).abs() <= half_in && (p[1] - centre[1]).abs() <= half_in
        }
    };
    let objective = |p: [f64; 2]| if feasible(p) { f1(&chords, p, res).f1 } else { f64::INFINITY };
    // Candidate grid: about the contour's bounding box grown by the work area's outer radius.
    let (lo, hi) = match constraints {
        Constraints::WorkArea(area) => {
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in &check_pts {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            let r = area.r_max_in;
            ([lo[0] - r, lo[1] - r], [hi[0] + r, hi[1] + r])
        }
        Constraints::Box { centre, half_in } => {
            ([centre[0] - half_in, centre[1] - half_in], [centre[0] + half_in, centre[1] + half_in])
        }
    };
    let n = 48;
    let mut cands: Vec<([f64; 2], f64)> = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let p = [
                lo[0] + (hi[0] - lo[0]) * i as f64 / n as f64,
                lo[1] + (hi[1] - lo[1]) * j as f64 / n as f64,
            ];
            let v = objective(p);
            if v.is_finite() {
                cands.push((p, v));
            }
        }
    }
    let grid_evals = (n + 1) * (n + 1);
    cands.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut best: Option<Found> = None;
    let mut evals = grid_evals;
    for &(p, _) in cands.iter().take(6) {
        let found = hooke_jeeves(objective, p, hj);
        evals += found.evals;
        if best.is_none_or(|b| found.value < b.value) {
            best = Some(found);
        }
    }
    let b = best?;
    Some(Optimum { pole: Pole::from_xy(b.at), f1: f1(&chords, b.at, res), evals })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polar::contour::{Circle, Polar};

    #[test]
    fn circle_about_the_pole_area_error_is_the_ring_to_the_grid() {
        let res = Resolution::THESIS;
        // On a grid radius: the arc is the contour, no error.
        let on = Polar::closed(Circle { a: 5.0 });
        let e0 = area_error_in2(&on, [0.0, 0.0], &res, 4);
        assert!(e0 < 1e-9, "{e0}");
        // Between grid radii by f dR: the ring between the contour and the truncated base radius.
        for f in [0.25, 0.5, 0.75] {
            let a = 5.0 + f * res.dr_in;
            let c = Polar::closed(Circle { a });
            let e = area_error_in2(&c, [0.0, 0.0], &res, 4);
            let want = PI * (a * a - 25.0);
            assert!((e / want - 1.0).abs() < 1e-6, "{f}: {e} vs {want}");
        }
    }
}
