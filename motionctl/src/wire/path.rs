//! Machining path: per-step areas and times (seed L2998-3098, BASIC 6270-6760; Table 11) and
//! joint-space targets for a continuous constant-area-rate interpolator.

use super::ik::{IkModel, Joints};
use super::{Point2, Result, WireError};

/// A paired path: `top[i]` at Z = `zt_mm` and `bottom[i]` at Z = 0 are visited in order.
/// Build it from a closed die with [`Path::from_home`] to start and end at a home point (the
/// thesis starts and ends 3-D dies at the centre, and the gear at (0, -60)).
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    pub zt_mm: f64,
    pub top: Vec<Point2>,
    pub bottom: Vec<Point2>,
}

impl Path {
    pub fn new(zt_mm: f64, top: Vec<Point2>, bottom: Vec<Point2>) -> Result<Self> {
        let d = super::Die::new(zt_mm, top, bottom)?;
        super::check_moves(&d.top, &d.bottom)?;
        Ok(Self { zt_mm: d.zt_mm, top: d.top, bottom: d.bottom })
    }

    /// `home`, the die's points, `home` again (on both faces).
    pub fn from_home(die: &super::Die, home: Point2) -> Result<Self> {
        let wrap = |v: &[Point2]| {
            std::iter::once(home).chain(v.iter().copied()).chain(std::iter::once(home)).collect()
        };
        Self::new(die.zt_mm, wrap(&die.top), wrap(&die.bottom))
    }
}

/// One step of the path, from point `index - 1` to point `index`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    pub index: usize,
    /// Bottom and top chord lengths RB, RT (BASIC 6280-6290).
    pub rb_mm: f64,
    pub rt_mm: f64,
    /// The thesis's machining area `(RB + RT) * ZT / 2` (BASIC 6300).
    pub area_trapezoid_mm2: f64,
    /// Exact area of the ruled (bilinear) surface between the two ruling lines.
    pub area_ruled_mm2: f64,
}

/// Seconds to machine `area_mm2` at `fr_mm2_per_min`: `60 A / FR`. The thesis's
/// `TM = S / (FR / (H * 60))` with `H = AREA / S` (BASIC 6360-6370) is the same number but
/// divides by zero when the bottom point does not move (S = 0).
pub fn time_s(area_mm2: f64, fr_mm2_per_min: f64) -> Result<f64> {
    super::positive("fr_mm2_per_min", fr_mm2_per_min)?;
    Ok(60.0 * area_mm2 / fr_mm2_per_min)
}

const GAUSS8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Area of the bilinear patch with corners b0, b1 (Z = 0) and t0, t1 (Z = zt): the surface the
/// wire sweeps when both ends move linearly. 8x8 Gauss-Legendre quadrature.
pub fn ruled_area_mm2(b0: Point2, b1: Point2, t0: Point2, t1: Point2, zt_mm: f64) -> f64 {
    let p = |q: Point2, z: f64| [q.x_mm, q.y_mm, z];
    let (b0, b1, t0, t1) = (p(b0, 0.0), p(b1, 0.0), p(t0, zt_mm), p(t1, zt_mm));
    let mut sum = 0.0;
    for (u, wu) in GAUSS8 {
        let u = (u + 1.0) / 2.0;
        for (v, wv) in GAUSS8 {
            let v = (v + 1.0) / 2.0;
            let mut du = [0.0; 3];
            let mut dv = [0.0; 3];
            for k in 0..3 {
                du[k] = (1.0 - v) * (b1[k] - b0[k]) + v * (t1[k] - t0[k]);
                dv[k] = (1.0 - u) * (t0[k] - b0[k]) + u * (t1[k] - b1[k]);
            }
            let c = [
                du[1] * dv[2] - du[2] * dv[1],
                du[2] * dv[0] - du[0] * dv[2],
                du[0] * dv[1] - du[1] * dv[0],
            ];
            sum += wu * wv * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        }
    }
    sum / 4.0
}

/// Steps 1..len of `path` (step `i` goes from point `i - 1` to point `i`).
pub fn steps(path: &Path) -> Vec<Step> {
    (1..path.top.len())
        .map(|i| {
            let (b0, b1, t0, t1) =
                (path.bottom[i - 1], path.bottom[i], path.top[i - 1], path.top[i]);
            let (rb, rt) = (b0.dist_mm(b1), t0.dist_mm(t1));
            Step {
                index: i,
                rb_mm: rb,
                rt_mm: rt,
                area_trapezoid_mm2: (rb + rt) * path.zt_mm / 2.0,
                area_ruled_mm2: ruled_area_mm2(b0, b1, t0, t1, path.zt_mm),
            }
        })
        .collect()
}

/// Totals of a path at feed `fr_mm2_per_min` with the thesis's trapezoid areas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Totals {
    pub area_mm2: f64,
    pub time_s: f64,
}

pub fn totals(path: &Path, fr_mm2_per_min: f64) -> Result<Totals> {
    let area: f64 = steps(path).iter().map(|s| s.area_trapezoid_mm2).sum();
    Ok(Totals { area_mm2: area, time_s: time_s(area, fr_mm2_per_min)? })
}

/// A joint-space target with the area swept on the way to it from the previous target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointTarget {
    pub joints: Joints,
    /// Thesis trapezoid area of the step into this target (0 for the first target).
    pub area_trapezoid_mm2: f64,
    /// Exact ruled-surface area of that step.
    pub area_ruled_mm2: f64,
}

/// Joint-space targets for every point of `path` (X, Y in mm; alpha, beta in rad) with the
/// area swept per step. A constant area-rate interpolator gives step `i` the duration
/// `60 * area / FR` seconds ([`time_s`]). Joint-space linear interpolation keeps the wire on
/// the ruling line only at the targets; subdivide the path for tighter tracking.
pub fn joint_targets(path: &Path, ik: IkModel) -> Result<Vec<JointTarget>> {
    let st = steps(path);
    (0..path.top.len())
        .map(|i| {
            let joints = ik.solve(i, path.top[i], path.bottom[i], path.zt_mm)?;
            let (a, r) = if i == 0 {
                (0.0, 0.0)
            } else {
                (st[i - 1].area_trapezoid_mm2, st[i - 1].area_ruled_mm2)
            };
            if !(a.is_finite() && r.is_finite()) {
                return Err(WireError::Degenerate { index: i, reason: "step area is not finite" });
            }
            Ok(JointTarget { joints, area_trapezoid_mm2: a, area_ruled_mm2: r })
        })
        .collect()
}
