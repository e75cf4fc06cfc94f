//! G5 (cubic), G5.1 (quadratic) and G5.2/G5.3 (NURBS) splines in the XY plane (rs274ngc's
//! `convert_spline` and `convert_nurbs`). They become NURBS_FEED calls with their control
//! points; [`crate::curves`] flattens them for a planner.

use crate::block::Block;
use crate::canon::{Canon, ControlPoint, Plane};
use crate::core::Core;
use crate::diag::{check, At, Res};
use crate::messages as msg;
use crate::modal::{g, group};
use crate::state::FeedMode;

const MOTION: At = At::GGroup(group::MOTION);

/// G5.2 control points collected until G5.3.
#[derive(Clone, Debug, Default)]
pub(crate) struct Nurbs {
    pub points: Vec<ControlPoint>,
    pub order: u32,
}

impl Core {
    pub(crate) fn convert_spline(&mut self, motion: i32, b: &Block) -> Res<()> {
        check(self.s.comp_on(), "Cannot convert spline with cutter radius compensation", MOTION)?;
        match self.s.feed_mode {
            FeedMode::UnitsPerMinute => {
                check(self.s.feed_rate == 0.0, msg::CANNOT_MAKE_ARC_WITH_ZERO_FEED, MOTION)?
            }
            FeedMode::InverseTime => check(b.f.is_none(), msg::F_MISSING_INVERSE_ARC, MOTION)?,
            FeedMode::UnitsPerRevolution => {}
        }
        check(self.s.plane != Plane::XY, "Splines must be in the XY plane", MOTION)?;
        check(
            b.z.is_some() || b.a.is_some() || b.b.is_some() || b.c.is_some(),
            "Splines may not have motion in Z, A, B, or C",
            MOTION,
        )?;
        let (cx, cy) = (self.s.cur[0], self.s.cur[1]);
        let cp = |x: f64, y: f64| ControlPoint { x, y, w: 1.0 };
        // rs274 keeps one control point list for G5.2 and the splines: pending G5.2 points
        // go out with the spline.
        let mut points = std::mem::take(&mut self.nurbs.points);
        if motion == g::G5_1 {
            check(b.i.is_none() || b.j.is_none(), "Must specify both I and J with G5.1", MOTION)?;
            let (x1, y1) = (cx + b.i.unwrap_or(0.0), cy + b.j.unwrap_or(0.0));
            let end = self.find_ends(b)?;
            points.extend([cp(cx, cy), cp(x1, y1), cp(end[0], end[1])]);
            self.emit(Canon::NurbsFeed { order: 3, points })?;
            self.s.cur[0] = end[0];
            self.s.cur[1] = end[1];
        } else {
            let (x1, y1) = match (b.i, b.j) {
                (Some(i), Some(j)) => (cx + i, cy + j),
                (None, None) => (cx + self.s.cycle.i, cy + self.s.cycle.j),
                _ => {
                    return Err(crate::diag::Fault::new(
                        "Must specify both I and J, or neither",
                        MOTION,
                    ))
                }
            };
            let end = self.find_ends(b)?;
            check(!b.p_flag || !b.q_flag, "Must specify both P and Q with G5", MOTION)?;
            let (x2, y2) = (end[0] + b.p_number, end[1] + b.q_number);
            points.extend([cp(cx, cy), cp(x1, y1), cp(x2, y2), cp(end[0], end[1])]);
            self.emit(Canon::NurbsFeed { order: 4, points })?;
            self.s.cycle.i = -b.p_number;
            self.s.cycle.j = -b.q_number;
            self.s.cur[0] = end[0];
            self.s.cur[1] = end[1];
        }
        Ok(())
    }

    /// G5.2 adds control points; G5.3 ends the curve.
    pub(crate) fn convert_nurbs(&mut self, code: i32, b: &Block) -> Res<()> {
        if code == g::G5_2 {
            check(
                b.x.is_some() != b.y.is_some(),
                "You must specify both X and Y coordinates for Control Points",
                MOTION,
            )?;
            let empty = self.nurbs.points.is_empty();
            check(
                b.x.is_none() && b.y.is_none() && b.p_number > 0.0 && !empty,
                "Can specify P without X and Y only for the first control point",
                MOTION,
            )?;
            check(
                b.p_number <= 0.0 && !empty,
                "Must specify positive weight P for every Control Point",
                MOTION,
            )?;
            if self.s.feed_mode == FeedMode::UnitsPerMinute {
                check(self.s.feed_rate == 0.0, "Cannot make a NURBS with 0 feedrate", MOTION)?;
            }
            if self.s.motion_mode != code {
                self.nurbs.points.clear();
            }
            if self.nurbs.points.is_empty() {
                let w = if b.x.is_none() && b.y.is_none() && b.p_number > 0.0 {
                    b.p_number
                } else {
                    1.0
                };
                self.nurbs.points.push(ControlPoint { x: self.s.cur[0], y: self.s.cur[1], w });
                self.nurbs.order = 3;
            }
            if b.l_number > 3 {
                self.nurbs.order = b.l_number as u32;
            }
            if b.x.is_some() && b.y.is_some() {
                let end = self.find_ends(b)?;
                self.nurbs.points.push(ControlPoint { x: end[0], y: end[1], w: b.p_number });
            }
            self.s.motion_mode = code;
        } else {
            check(
                self.s.motion_mode != g::G5_2,
                "Cannot use G5.3 without G5.2 first",
                At::GGroup(group::MODAL_0),
            )?;
            let order = self.nurbs.order;
            if self.nurbs.points.len() < order as usize {
                return Err(crate::diag::Fault::new(
                    format!("You must specify a number of control points at least equal to the order L = {order}"),
                    At::GGroup(group::MODAL_0),
                ));
            }
            let points = std::mem::take(&mut self.nurbs.points);
            if let Some(last) = points.last() {
                self.s.cur[0] = last.x;
                self.s.cur[1] = last.y;
            }
            self.emit(Canon::NurbsFeed { order, points })?;
            self.s.motion_mode = -1;
        }
        Ok(())
    }
}
