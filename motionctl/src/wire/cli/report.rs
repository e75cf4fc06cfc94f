//! What `motionctl wire plan` reports: the IK error bound, the die's and the drawings' figures,
//! and the `--json` report.

use super::plan_args::WirePlanArgs;
use crate::wire::continuous::{self, ContinuousParams};

/// How far the wire can be from the designed ruled surface: the planner's largest
/// joint-linear deviation inside a piece plus the step quantisation margin, mm.
pub(super) struct IkBound {
    pub(super) joint_linear_mm: f64,
    pub(super) quantisation_mm: f64,
    pub(super) total_mm: f64,
}

impl IkBound {
    pub(super) fn of(job: &continuous::ContinuousJob) -> Self {
        let joint_linear_mm = job.pieces.iter().map(|p| p.deviation_mm).fold(0.0, f64::max);
        IkBound {
            joint_linear_mm,
            quantisation_mm: job.margin_mm,
            total_mm: joint_linear_mm + job.margin_mm,
        }
    }
}

/// Length of the closed polyline through `face` (a die face repeats its first point), mm.
fn face_perimeter_mm(face: &[crate::wire::Point2]) -> f64 {
    crate::wire::cad::perimeter_mm(face)
}

/// The drawn contours: each face's drawing, its flattened and resampled length and area, and
/// how far the resampled polygon cuts the drawn one.
pub(super) fn print_contour_figures(c: &crate::wire::cad::ContourPair) {
    for (name, contour, r) in [
        ("top drawing", &c.top, &c.top_resampled),
        ("bottom drawing", &c.bottom, &c.bottom_resampled),
    ] {
        crate::outln!(
            "  {name:<19} {}: {} points flattened, perimeter {:.3} mm, area {:.3} mm^2; \
             resampled perimeter {:.3} mm, at most {:.4} mm inside the drawing",
            contour.source,
            contour.points.len(),
            contour.perimeter_mm(),
            contour.area_mm2(),
            crate::wire::cad::perimeter_mm(&r.points),
            r.deviation_mm
        );
    }
}

/// The `wire plan --json` report (mm, mm^2, s, deg).
#[allow(clippy::too_many_arguments)]
pub(super) fn plan_json(
    die: &crate::wire::dies::DieJob,
    contours: Option<&crate::wire::cad::ContourPair>,
    job: &continuous::ContinuousJob,
    prm: &ContinuousParams,
    bound: &IkBound,
    host_model_s: f64,
    thesis_time_s: f64,
    plan: &WirePlanArgs,
) -> serde_json::Value {
    use crate::wire::area::{polygon_area_mm2, sector_area_mm2};
    use serde_json::json;
    let face =
        |pts: &[crate::wire::Point2],
         drawn: Option<(&crate::wire::cad::Contour, &crate::wire::cad::Resampled)>| {
            let mut f = json!({
                "polygon_area_mm2": polygon_area_mm2(pts),
                "sector_area_mm2": sector_area_mm2(pts),
                "perimeter_mm": face_perimeter_mm(pts),
            });
            if let Some((c, r)) = drawn {
                f["source"] = json!(c.source);
                f["drawn_points"] = json!(c.points.len());
                f["drawn_perimeter_mm"] = json!(c.perimeter_mm());
                f["drawn_area_mm2"] = json!(c.area_mm2());
                f["resampling_deviation_mm"] = json!(r.deviation_mm);
            }
            f
        };
    let (dt, db) = match contours {
        Some(c) => (Some((&c.top, &c.top_resampled)), Some((&c.bottom, &c.bottom_resampled))),
        None => (None, None),
    };
    json!({
        "die": die.label,
        "zt_mm": die.die.zt_mm,
        "fr_mm2_per_min": prm.fr_mm2_per_min,
        "tolerance_mm": prm.tol_mm,
        "points_per_face": die.die.top.len(),
        "start_mm": [die.start.x_mm, die.start.y_mm],
        "top": face(&die.die.top, dt),
        "bottom": face(&die.die.bottom, db),
        "segments": job.segments.len(),
        "ruled_area_mm2": job.area_ruled_mm2,
        "trapezoid_area_mm2": job.area_trapezoid_mm2,
        "cut_time_s": job.time_ruled_s,
        "thesis_time_s": thesis_time_s,
        "host_model_time_s": host_model_s,
        "ik_error_bound_mm": bound.total_mm,
        "ik_joint_linear_mm": bound.joint_linear_mm,
        "ik_quantisation_mm": bound.quantisation_mm,
        "plot": plan.drawing.plot.as_ref().map(|p| p.display().to_string()),
    })
}

/// The die's points, start and face areas (the thesis's sector method and the exact polygon).
pub(super) fn print_die_figures(die: &crate::wire::dies::DieJob) {
    use crate::wire::area::{polygon_area_mm2, sector_area_mm2};
    let (s, d) = (die.start, &die.die);
    crate::outln!(
        "  points              {} per face, from and back to ({}, {}) mm",
        d.top.len(),
        s.x_mm,
        s.y_mm
    );
    for (name, face) in [("top face", &d.top), ("bottom face", &d.bottom)] {
        crate::outln!(
            "  {name:<19} sector area {:.3} mm^2, polygon {:.3} mm^2",
            sector_area_mm2(face),
            polygon_area_mm2(face)
        );
    }
}
