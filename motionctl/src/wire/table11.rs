//! Table 11 of the thesis (circle -> complex path, seed L4392-4483) side by side: per row the
//! thesis's IK values as the thesis prints them (alpha, beta, trapezoid area, time, running
//! totals) and beside them the corrected IK's (XB1, the motor steps rounded instead of
//! truncated, the exact ruled area). `motionctl wire table11 [--csv]` prints it.

use super::ik::{ik_exact, ik_thesis, steps_rounded, steps_thesis, Steps};
use super::path::{steps, time_s, Path};
use super::Result;
use std::fmt::Write;

/// One row: the step into path point `row` (row 1: centre -> point 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Table11Row {
    pub row: usize,
    /// Thesis IK (alpha and beta are the same in the corrected IK).
    pub alpha_deg: f64,
    pub beta_deg: f64,
    /// The thesis's trapezoid area of the step and `60 A / FR` of it.
    pub area_mm2: f64,
    pub time_s: f64,
    pub total_area_mm2: f64,
    pub total_time_s: f64,
    /// `ZB1 = YB sin(alpha)`: where it is not 0 the thesis's XB1 is wrong.
    pub zb1_mm: f64,
    pub xb1_thesis_mm: f64,
    pub xb1_corrected_mm: f64,
    /// M1..M4 as the thesis computes them (FIX truncation, its XB1) and corrected (rounded).
    pub steps_thesis: Steps,
    pub steps_corrected: Steps,
    /// Exact ruled area of the step.
    pub area_ruled_mm2: f64,
}

/// The table and its totals.
#[derive(Clone, Debug, PartialEq)]
pub struct Table11 {
    pub fr_mm2_per_min: f64,
    pub rows: Vec<Table11Row>,
    /// Thesis totals: trapezoid area and `60 A / FR`.
    pub total_area_mm2: f64,
    pub total_time_s: f64,
    /// Corrected: exact ruled area and `60 A / FR` of it.
    pub total_ruled_mm2: f64,
    pub time_ruled_s: f64,
    /// Row with the largest |XB1 corrected - XB1 thesis| and that difference, mm.
    pub max_xb1_diff: (usize, f64),
}

/// Table 11 of `path` at feed `fr_mm2_per_min`.
pub fn table11(path: &Path, fr_mm2_per_min: f64) -> Result<Table11> {
    let mut rows = Vec::with_capacity(path.top.len());
    let (mut area, mut time, mut ruled) = (0.0, 0.0, 0.0);
    let mut max_xb1_diff = (0, 0.0f64);
    for s in steps(path) {
        let i = s.index;
        let (t, b) = (path.top[i], path.bottom[i]);
        let th = ik_thesis(i, t, b, path.zt_mm)?;
        let ex = ik_exact(i, t, b, path.zt_mm)?;
        let tm = time_s(s.area_trapezoid_mm2, fr_mm2_per_min)?;
        area += s.area_trapezoid_mm2;
        time += tm;
        ruled += s.area_ruled_mm2;
        let d = (ex.x_mm - th.x_mm).abs();
        if d > max_xb1_diff.1 {
            max_xb1_diff = (i, d);
        }
        rows.push(Table11Row {
            row: i,
            alpha_deg: th.alpha_rad.to_degrees(),
            beta_deg: th.beta_rad.to_degrees(),
            area_mm2: s.area_trapezoid_mm2,
            time_s: tm,
            total_area_mm2: area,
            total_time_s: time,
            zb1_mm: b.y_mm * ex.alpha_rad.sin(),
            xb1_thesis_mm: th.x_mm,
            xb1_corrected_mm: ex.x_mm,
            steps_thesis: steps_thesis(th),
            steps_corrected: steps_rounded(ex),
            area_ruled_mm2: s.area_ruled_mm2,
        });
    }
    Ok(Table11 {
        fr_mm2_per_min,
        rows,
        total_area_mm2: area,
        total_time_s: time,
        total_ruled_mm2: ruled,
        time_ruled_s: time_s(ruled, fr_mm2_per_min)?,
        max_xb1_diff,
    })
}

/// `m:ss.sss`.
fn min_s(t: f64) -> String {
    let m = (t / 60.0).floor();
    format!("{m:.0} min {:.3} s", t - 60.0 * m)
}

/// A step count, or `=` when the corrected one is the thesis's.
fn steps_cell(th: i64, ex: i64) -> String {
    if th == ex {
        format!("{th}")
    } else {
        format!("{th}->{ex}")
    }
}

/// The table as text: the thesis's columns, then the corrected IK's (a step count that differs
/// prints as `thesis->corrected`), then the totals line.
pub fn render_text(t: &Table11) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>4} | {:>9} {:>9} {:>9} {:>9} {:>10} {:>9} | {:>8} {:>8} {:>8} {:>15} {:>14} {:>13} {:>13} {:>9}",
        "row",
        "alpha deg",
        "beta deg",
        "area mm2",
        "time s",
        "tot mm2",
        "tot s",
        "ZB1 mm",
        "XB1 th",
        "XB1 corr",
        "M1 th->corr",
        "M2",
        "M3",
        "M4",
        "ruled mm2"
    );
    for r in &t.rows {
        let (a, b) = (r.steps_thesis, r.steps_corrected);
        let _ = writeln!(
            s,
            "{:>4} | {:>9.4} {:>9.4} {:>9.3} {:>9.4} {:>10.3} {:>9.3} | {:>8.3} {:>8.3} {:>8.3} {:>15} {:>14} {:>13} {:>13} {:>9.3}",
            r.row,
            r.alpha_deg,
            r.beta_deg,
            r.area_mm2,
            r.time_s,
            r.total_area_mm2,
            r.total_time_s,
            r.zb1_mm,
            r.xb1_thesis_mm,
            r.xb1_corrected_mm,
            steps_cell(a[0], b[0]),
            steps_cell(a[1], b[1]),
            steps_cell(a[2], b[2]),
            steps_cell(a[3], b[3]),
            r.area_ruled_mm2
        );
    }
    let _ = writeln!(
        s,
        "total area {:.3} mm^2, time {:.3} s ({}) at FR {} mm^2/min (thesis IK, trapezoid areas)",
        t.total_area_mm2,
        t.total_time_s,
        min_s(t.total_time_s),
        t.fr_mm2_per_min
    );
    let _ = writeln!(
        s,
        "corrected  ruled area {:.3} mm^2, 60 A / FR {:.3} s ({}); largest XB1 difference {:.3} mm at row {}",
        t.total_ruled_mm2,
        t.time_ruled_s,
        min_s(t.time_ruled_s),
        t.max_xb1_diff.1,
        t.max_xb1_diff.0
    );
    s
}

/// The table as CSV (full precision), a header line, one line per row and a `total` line
/// (area and time columns filled, the others empty).
pub fn render_csv(t: &Table11) -> String {
    let mut s = String::from(
        "row,alpha_deg,beta_deg,area_mm2,time_s,total_area_mm2,total_time_s,zb1_mm,\
         xb1_thesis_mm,xb1_corrected_mm,m1_thesis,m1_corrected,m2_thesis,m2_corrected,\
         m3_thesis,m3_corrected,m4_thesis,m4_corrected,area_ruled_mm2\n",
    );
    for r in &t.rows {
        let (a, b) = (r.steps_thesis, r.steps_corrected);
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.row,
            r.alpha_deg,
            r.beta_deg,
            r.area_mm2,
            r.time_s,
            r.total_area_mm2,
            r.total_time_s,
            r.zb1_mm,
            r.xb1_thesis_mm,
            r.xb1_corrected_mm,
            a[0],
            b[0],
            a[1],
            b[1],
            a[2],
            b[2],
            a[3],
            b[3],
            r.area_ruled_mm2
        );
    }
    let _ = writeln!(
        s,
        "total,,,{},{},{},{},,,,,,,,,,,,{}",
        t.total_area_mm2, t.total_time_s, t.total_area_mm2, t.total_time_s, t.total_ruled_mm2
    );
    s
}
