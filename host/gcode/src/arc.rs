//! G2/G3 arcs (rs274ngc's `convert_arc`, `convert_arc2` in interp_convert.cc and
//! `arc_data_ijk`/`arc_data_r` in interp_arc.cc): centre and radius forms, full circles and
//! P turns, helical arcs, in G17, G18 and G19, with rs274's end-radius consistency rule.

use crate::block::Block;
use crate::canon::{Canon, Plane, Units};
use crate::core::Core;
use crate::diag::{check, At, Fault, GrblHabit, Res};
use crate::messages as msg;
use crate::modal::{g, group};
use crate::state::FeedMode;

const MOTION: At = At::GGroup(group::MOTION);

/// rs274ngc's arc tolerances (interp_internal.hh).
const RADIUS_TOLERANCE_INCH: f64 = 0.00005;
const CENTER_ARC_RADIUS_TOLERANCE_INCH: f64 = 2.0 * 0.001 * std::f64::consts::SQRT_2;
const CENTER_ARC_RADIUS_TOLERANCE_MM: f64 = 2.0 * 0.01 * std::f64::consts::SQRT_2;
const SPIRAL_RELATIVE_TOLERANCE: f64 = 0.001;
const TINY: f64 = 1e-12;

/// The plane's axes: (first, second, normal) indices into X Y Z, and their letters.
pub(crate) fn plane_axes(p: Plane) -> ([usize; 3], [char; 2]) {
    match p {
        Plane::XZ => ([2, 0, 1], ['Z', 'X']),
        Plane::YZ => ([1, 2, 0], ['Y', 'Z']),
        _ => ([0, 1, 2], ['X', 'Y']),
    }
}

/// C's `%.4g`.
pub(crate) fn fmt_g4(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let exp = v.abs().log10().floor() as i32;
    let s = format!("{:.3e}", v);
    // Round first, then decide the style on the rounded exponent, as C does.
    let (mant, e) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(exp);
    if !(-4..4).contains(&e) {
        let mant = mant.trim_end_matches('0').trim_end_matches('.');
        format!("{mant}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
    } else {
        let decimals = (3 - e).max(0) as usize;
        let f = format!("{v:.decimals$}");
        if f.contains('.') {
            f.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            f
        }
    }
}

impl Core {
    pub(crate) fn convert_arc(&mut self, motion: i32, b: &mut Block) -> Res<()> {
        check(
            self.s.arc_not_allowed,
            "The move just after exiting cutter compensation mode must be straight, not an arc",
            MOTION,
        )?;
        check(
            matches!(self.s.plane, Plane::UV | Plane::VW | Plane::UW),
            "Cannot do an arc in planes G17.1, G18.1, or G19.1",
            MOTION,
        )?;
        self.drop_out_of_plane_zero(b);
        let ijk = b.i.is_some() || b.j.is_some() || b.k.is_some();
        check(b.r.is_none() && !ijk, msg::RIJK_ALL_MISSING, MOTION)?;
        check(b.r.is_some() && ijk, msg::MIXED_RADIUS_IJK, At::Letter(b'r'))?;
        match self.s.feed_mode {
            FeedMode::UnitsPerMinute => {
                check(self.s.feed_rate == 0.0, msg::CANNOT_MAKE_ARC_WITH_ZERO_FEED, MOTION)?
            }
            FeedMode::UnitsPerRevolution => {
                check(self.s.feed_rate == 0.0, msg::CANNOT_MAKE_ARC_WITH_ZERO_FEED, MOTION)?;
                check(
                    self.s.speed == 0.0,
                    "Cannot feed with zero spindle speed in feed per rev mode",
                    MOTION,
                )?;
            }
            FeedMode::InverseTime => check(b.f.is_none(), msg::F_MISSING_INVERSE_ARC, MOTION)?,
        }
        if ijk {
            let (out, first, second, out_msg) = match self.s.plane {
                Plane::XY => (b.k, b'i', b'j', msg::K_WORD_IN_XY),
                Plane::YZ => (b.i, b'j', b'k', msg::I_WORD_IN_YZ),
                _ => (b.j, b'i', b'k', msg::J_WORD_IN_XZ),
            };
            let out_letter = [b'i', b'j', b'k']
                .into_iter()
                .find(|l| *l != first && *l != second)
                .unwrap_or(b'k');
            check(out.is_some(), out_msg, At::Letter(out_letter))?;
            for (l, other) in [(first, second), (second, first)] {
                let present = |x: u8| match x {
                    b'i' => b.i.is_some(),
                    b'j' => b.j.is_some(),
                    _ => b.k.is_some(),
                };
                if !present(l) {
                    if self.s.ijk_absolute {
                        let m = format!(
                            "{} word missing in absolute center arc",
                            (l as char).to_ascii_uppercase()
                        );
                        return Err(Fault::new(m, At::Letter(other)));
                    }
                    match l {
                        b'i' => b.i = Some(0.0),
                        b'j' => b.j = Some(0.0),
                        _ => b.k = Some(0.0),
                    }
                    break;
                }
            }
        } else {
            let missing = match self.s.plane {
                Plane::XY => {
                    b.x.is_none() && b.y.is_none() && b.radius.is_none() && b.theta.is_none()
                }
                Plane::YZ => b.y.is_none() && b.z.is_none(),
                _ => b.x.is_none() && b.z.is_none(),
            };
            let m = match self.s.plane {
                Plane::XY => msg::X_Y_MISSING_ARC_XY,
                Plane::YZ => msg::Y_Z_MISSING_ARC_YZ,
                _ => msg::X_Z_MISSING_ARC_XZ,
            };
            check(missing, m, MOTION)?;
        }
        let end = self.find_ends(b)?;
        self.s.motion_mode = motion;
        if self.s.comp_on() && self.s.comp_radius > 0.0 {
            return Err(Fault::unsupported(
                "cutter radius compensation with a non-zero radius is not supported",
                MOTION,
            ));
        }
        let ([a1, a2, a3], letters) = plane_axes(self.s.plane);
        let ijk_v = [b.i.unwrap_or(0.0), b.j.unwrap_or(0.0), b.k.unwrap_or(0.0)];
        let cur = self.s.cur;
        let turns = if b.p_flag { b.p_number.round_ties_even() as i32 } else { 1 };
        let (c1, c2) = if let Some(r) = b.r {
            self.arc_data_r(motion, (cur[a1], cur[a2]), (end[a1], end[a2]), r)?
        } else {
            self.arc_data_ijk(
                (cur[a1], cur[a2]),
                (end[a1], end[a2]),
                (ijk_v[a1], ijk_v[a2]),
                letters,
            )?
        };
        let turn = if motion == g::G2 { -turns } else { turns };
        self.inverse_time_rate_arc(
            (cur[a1], cur[a2], cur[a3]),
            (c1, c2),
            turn,
            (end[a1], end[a2], end[a3]),
            b,
        )?;
        self.emit(Canon::ArcFeed {
            first_end: end[a1],
            second_end: end[a2],
            first_axis: c1,
            second_axis: c2,
            rotation: turn,
            axis_end_point: end[a3],
            a: end[3],
            b: end[4],
            c: end[5],
        })?;
        self.s.cur = end;
        Ok(())
    }

    /// grbl accepts a zero offset word outside the arc's plane (`K0` on a G17 arc): so does this
    /// front end, with a warning, when the in-plane offsets are there.
    fn drop_out_of_plane_zero(&mut self, b: &mut Block) {
        if !self.opts.grbl_habits || b.r.is_some() {
            return;
        }
        let (out, letter, in_plane) = match self.s.plane {
            Plane::XY => (&mut b.k, b'k', b.i.is_some() || b.j.is_some()),
            Plane::YZ => (&mut b.i, b'i', b.j.is_some() || b.k.is_some()),
            Plane::XZ => (&mut b.j, b'j', b.i.is_some() || b.k.is_some()),
            _ => return,
        };
        if *out == Some(0.0) && in_plane {
            *out = None;
            let m = format!(
                "{}0 outside the arc's plane ignored (grbl ignores it; rs274 refuses it)",
                (letter as char).to_ascii_uppercase()
            );
            self.grbl_warning(GrblHabit::OutOfPlaneOffset, m, At::Letter(letter));
        }
    }

    fn arc_data_ijk(
        &self,
        cur: (f64, f64),
        end: (f64, f64),
        off: (f64, f64),
        l: [char; 2],
    ) -> Res<(f64, f64)> {
        let (cx, cy) = if self.s.ijk_absolute { off } else { (cur.0 + off.0, cur.1 + off.1) };
        let inch = self.s.units == Units::Inches;
        let radius_tolerance =
            if inch { RADIUS_TOLERANCE_INCH } else { RADIUS_TOLERANCE_INCH * 25.4 };
        let spiral_abs =
            if inch { CENTER_ARC_RADIUS_TOLERANCE_INCH } else { CENTER_ARC_RADIUS_TOLERANCE_MM };
        let r1 = (cx - cur.0).hypot(cy - cur.1);
        let r2 = (cx - end.0).hypot(cy - end.1);
        let points = format!(
            "start=({a}{:.4},{b}{:.4}) center=({a}{:.4},{b}{:.4}) end=({a}{:.4},{b}{:.4}) r1={r1:.4} r2={r2:.4}",
            cur.0,
            cur.1,
            cx,
            cy,
            end.0,
            end.1,
            a = l[0],
            b = l[1]
        );
        if r1 < radius_tolerance || r2 < radius_tolerance {
            return Err(Fault::new(format!("Zero-radius arc: {points}"), MOTION));
        }
        let abs_err = (r1 - r2).abs();
        let rel_err = abs_err / r1.max(r2);
        if abs_err > spiral_abs * 100.0
            || (rel_err > SPIRAL_RELATIVE_TOLERANCE && abs_err > spiral_abs)
        {
            return Err(Fault::new(
                format!(
                    "Radius to end of arc differs from radius to start: {points} abs_err={} rel_err={:.4}%",
                    fmt_g4(abs_err),
                    rel_err * 100.0
                ),
                MOTION,
            ));
        }
        Ok((cx, cy))
    }

    fn arc_data_r(
        &self,
        motion: i32,
        cur: (f64, f64),
        end: (f64, f64),
        radius: f64,
    ) -> Res<(f64, f64)> {
        check(end == cur, msg::CURRENT_POINT_SAME_AS_END, MOTION)?;
        let tolerance = if self.s.units == Units::Inches {
            RADIUS_TOLERANCE_INCH
        } else {
            RADIUS_TOLERANCE_INCH * 25.4
        };
        let abs_r = radius.abs();
        let (mx, my) = ((end.0 + cur.0) / 2.0, (end.1 + cur.1) / 2.0);
        let mut half = (mx - end.0).hypot(my - end.1);
        check(half - abs_r > tolerance, msg::ARC_RADIUS_TOO_SMALL, At::Letter(b'r'))?;
        if half / abs_r > 1.0 - TINY {
            half = abs_r;
        }
        let base = (end.1 - cur.1).atan2(end.0 - cur.0);
        let theta = if (motion == g::G2 && radius > 0.0) || (motion == g::G3 && radius < 0.0) {
            base - std::f64::consts::FRAC_PI_2
        } else {
            base + std::f64::consts::FRAC_PI_2
        };
        let turn2 = (half / abs_r).asin();
        let offset = abs_r * turn2.cos();
        Ok((mx + offset * theta.cos(), my + offset * theta.sin()))
    }

    fn inverse_time_rate_arc(
        &mut self,
        start: (f64, f64, f64),
        center: (f64, f64),
        turn: i32,
        end: (f64, f64, f64),
        b: &Block,
    ) -> Res<()> {
        if self.s.feed_mode != FeedMode::InverseTime {
            return Ok(());
        }
        let radius = (center.0 - start.0).hypot(center.1 - start.1);
        let theta = find_turn((start.0, start.1), center, turn, (end.0, end.1));
        let length = if end.2 == start.2 {
            radius * theta.abs()
        } else {
            (radius * theta).hypot(end.2 - start.2)
        };
        let rate = (length * b.f.unwrap_or(0.0)).max(0.1);
        self.emit(Canon::SetFeedRate(rate))?;
        self.s.feed_rate = rate;
        Ok(())
    }
}

/// rs274ngc's `find_turn`: the arc's angle, radians (negative clockwise).
pub(crate) fn find_turn(p1: (f64, f64), c: (f64, f64), turn: i32, p2: (f64, f64)) -> f64 {
    use std::f64::consts::PI;
    if turn == 0 {
        return 0.0;
    }
    let mut alpha = (p1.1 - c.1).atan2(p1.0 - c.0);
    let mut beta = (p2.1 - c.1).atan2(p2.0 - c.0);
    if turn > 0 {
        if beta <= alpha {
            beta += 2.0 * PI;
        }
        (beta - alpha) + (turn - 1) as f64 * 2.0 * PI
    } else {
        if alpha <= beta {
            alpha += 2.0 * PI;
        }
        (beta - alpha) + (turn + 1) as f64 * 2.0 * PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_g_matches_c() {
        assert_eq!(fmt_g4(0.5), "0.5");
        assert_eq!(fmt_g4(0.12345), "0.1235");
        assert_eq!(fmt_g4(1234.5), "1234");
        assert_eq!(fmt_g4(12345.0), "1.234e+04");
        assert_eq!(fmt_g4(0.00001234), "1.234e-05");
        assert_eq!(fmt_g4(3.0), "3");
    }

    #[test]
    fn turns_count_full_circles() {
        let t = find_turn((1.0, 0.0), (0.0, 0.0), 1, (1.0, 0.0));
        assert!((t - 2.0 * std::f64::consts::PI).abs() < 1e-12);
        let t = find_turn((1.0, 0.0), (0.0, 0.0), -1, (0.0, 1.0));
        assert!((t + 1.5 * std::f64::consts::PI).abs() < 1e-12);
    }
}
