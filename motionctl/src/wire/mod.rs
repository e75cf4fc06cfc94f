//! Host-side geometry for the 4-axis wire manipulator (Bhatti 1991, seed
//! `004_c21767a7c5e8df0a.txt`): shape generators, top/bottom pairing, area bookkeeping, inverse
//! kinematics, joint limits, steps and backlash, and per-step joint targets for constant
//! area-rate feed.
//!
//! Machine model: a vertical hot wire is fixed; the workpiece moves through the chain
//! base -> X -> Y -> beta (about Y) -> alpha (about X) -> workpiece. The workpiece bottom face
//! (Z = 0) lies in the plane of both rotation axes. A ruled die is described by a top profile
//! (Z = `zt_mm`) and a bottom profile (Z = 0) with the same number of points; point `i` of the top
//! pairs with point `i` of the bottom and the pair is a straight ruling line (seed L2205-2213).
//!
//! Files: [`shapes`] (circle, complex, crescent, prismatic, star), [`gear`] (Unwin spur gear),
//! [`csv`] (MDI data files), [`dies`] (the dies `wire plan|run` cut), [`area`] (sector and
//! polygon areas, intermediate sections), [`ik`] (thesis and corrected inverse kinematics,
//! steps, backlash), [`limits`] (joint limits per point), [`path`] (machining area/time and
//! joint-space targets per step), [`continuous`] (the continuous constant area-rate job),
//! [`backlash`] (its lash take-up segments and a dead-band model), [`job_file`] (the wire job
//! TOML and the firmware table), [`table11`] (Table 11, thesis and corrected IK side by side).

pub mod area;
pub mod backlash;
pub mod cad;
pub mod cli;
pub mod continuous;
pub mod csv;
pub mod dies;
pub mod figure;
pub mod gear;
pub mod ik;
pub mod job_file;
pub mod limits;
pub mod path;
pub mod run;
pub mod shapes;
pub mod table11;

use thiserror::Error;

/// A point in a section plane of the workpiece, mm, origin at the workpiece centre.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Point2 {
    pub x_mm: f64,
    pub y_mm: f64,
}

impl Point2 {
    pub const fn new(x_mm: f64, y_mm: f64) -> Self {
        Self { x_mm, y_mm }
    }

    /// Distance to `other`, mm.
    pub fn dist_mm(self, other: Point2) -> f64 {
        (self.x_mm - other.x_mm).hypot(self.y_mm - other.y_mm)
    }

    /// Distance from the origin, mm.
    pub fn norm_mm(self) -> f64 {
        self.x_mm.hypot(self.y_mm)
    }
}

/// Errors of the wire geometry. Every variant names the offending input.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum WireError {
    #[error("parameter `{name}` = {value}: {reason}")]
    BadParameter { name: &'static str, value: f64, reason: &'static str },
    #[error("point index {index}: field `{field}` = {value} is not a finite number")]
    NotFinite { index: usize, field: &'static str, value: f64 },
    #[error(
        "top has {top} points but bottom has {bottom}; every top point pairs with one bottom point"
    )]
    CountMismatch { top: usize, bottom: usize },
    #[error("data file: {0}")]
    Parse(String),
    #[error("point index {index}: {field} = {value:.4} violates the limit {limit:.4} ({rule})")]
    Limit { index: usize, field: &'static str, value: f64, limit: f64, rule: &'static str },
    #[error("point index {index}: {reason}")]
    Degenerate { index: usize, reason: &'static str },
}

pub type Result<T> = std::result::Result<T, WireError>;

/// Shortest wire travel over both faces that makes a cut, mm.
pub(crate) const MIN_PATH_TRAVEL_MM: f64 = 1e-9;

/// Refuses a point sequence along which the wire never moves (every point of both faces the
/// same): it would plan no segment and a time error of 0 / 0.
pub(crate) fn check_moves(top: &[Point2], bottom: &[Point2]) -> Result<()> {
    let travel = |v: &[Point2]| {
        v.windows(2).map(|w| (w[1].x_mm - w[0].x_mm).hypot(w[1].y_mm - w[0].y_mm)).sum::<f64>()
    };
    if travel(top) + travel(bottom) > MIN_PATH_TRAVEL_MM {
        Ok(())
    } else {
        Err(WireError::Degenerate {
            index: 0,
            reason: "every point of both faces coincides with the start: the die cuts nothing",
        })
    }
}

/// Checks that `value` is a finite number greater than zero.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(WireError::BadParameter { name, value, reason: "must be a finite number > 0" })
    }
}

/// Checks that every coordinate of `points` is finite; `field` names the profile.
pub(crate) fn check_finite(points: &[Point2], x: &'static str, y: &'static str) -> Result<()> {
    for (index, p) in points.iter().enumerate() {
        if !p.x_mm.is_finite() {
            return Err(WireError::NotFinite { index, field: x, value: p.x_mm });
        }
        if !p.y_mm.is_finite() {
            return Err(WireError::NotFinite { index, field: y, value: p.y_mm });
        }
    }
    Ok(())
}

/// A ruled die: top profile at Z = `zt_mm`, bottom profile at Z = 0, paired point by point.
#[derive(Clone, Debug, PartialEq)]
pub struct Die {
    pub zt_mm: f64,
    pub top: Vec<Point2>,
    pub bottom: Vec<Point2>,
}

impl Die {
    /// Pairs `top` and `bottom`; they must have equal, non-zero point counts and finite
    /// coordinates, and `zt_mm` must be > 0.
    pub fn new(zt_mm: f64, top: Vec<Point2>, bottom: Vec<Point2>) -> Result<Self> {
        positive("zt_mm", zt_mm)?;
        if top.len() != bottom.len() || top.is_empty() {
            return Err(WireError::CountMismatch { top: top.len(), bottom: bottom.len() });
        }
        check_finite(&top, "XT", "YT")?;
        check_finite(&bottom, "XB", "YB")?;
        Ok(Self { zt_mm, top, bottom })
    }

    /// Section at height `zi_mm` (0 = bottom, `zt_mm` = top) by linear interpolation along each
    /// ruling line (seed L2771-2773, BASIC 3080-3090).
    pub fn section(&self, zi_mm: f64) -> Vec<Point2> {
        area::intermediate_section(&self.top, &self.bottom, 0.0, self.zt_mm, zi_mm)
    }
}
