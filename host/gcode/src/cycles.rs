//! Canned cycles G73, G74, G81..G89 with G98/G99 and L repeats, in the XY, XZ and YZ planes
//! (rs274ngc's interp_cycles.cc, including its CYCLE_MACRO and the quirks of its G74/G84 in
//! the XZ and YZ planes).

use crate::arc::plane_axes;
use crate::block::Block;
use crate::canon::{Canon, MotionControl, Plane, Units};
use crate::core::Core;
use crate::diag::{check, fail, At, Fault, Res};
use crate::messages as msg;
use crate::modal::{g, g_name, group};
use crate::state::{FeedMode, Spindle};

const MOTION: At = At::GGroup(group::MOTION);
/// How far above the hole bottom G73/G83 rapid back in, inches.
const G83_RAPID_DELTA_IN: f64 = 0.010;

/// A cycle's geometry in the plane's axes: `aa`, `bb` in the plane, `cc` along its normal.
struct Geo {
    axes: [usize; 3],
    clear_cc: f64,
    r: f64,
}

impl Core {
    pub(crate) fn convert_cycle(&mut self, motion: i32, b: &mut Block) -> Res<()> {
        check(self.s.feed_rate == 0.0, "Cannot feed with zero feed rate", MOTION)?;
        check(
            self.s.feed_mode == FeedMode::InverseTime,
            "Cannot use inverse time feed with canned cycles",
            MOTION,
        )?;
        check(self.s.comp_on(), "Cannot use canned cycles with cutter compensation on", MOTION)?;
        if b.r.is_none() {
            if self.s.motion_mode == motion {
                b.r = Some(self.s.cycle.r);
            } else {
                return Err(Fault::new(msg::R_UNSPECIFIED_IN_CYCLE, MOTION));
            }
        }
        check(b.l_number == 0, msg::CANNOT_DO_ZERO_REPEATS, At::Letter(b'l'))?;
        if b.l_number == -1 {
            b.l_number = 1;
        }
        let plane = self.s.plane;
        if matches!(plane, Plane::UV | Plane::VW | Plane::UW) {
            return Err(Fault::unsupported(
                "canned cycles in the UV, UW and VW planes are not supported",
                MOTION,
            ));
        }
        self.cycle_in_plane(motion, b, plane)?;
        self.s.cycle.l = b.l_number;
        self.s.cycle.r = b.r.unwrap_or(0.0);
        self.s.motion_mode = motion;
        Ok(())
    }

    fn cycle_in_plane(&mut self, motion: i32, b: &mut Block, plane: Plane) -> Res<()> {
        let (axes, _) = plane_axes(plane);
        let [ia, ib, ic] = axes;
        let words = [b.x, b.y, b.z];
        let (missing, less) = match plane {
            Plane::XY => (msg::Z_UNSPECIFIED_XY_CYCLE, msg::R_LESS_THAN_Z_XY),
            Plane::YZ => (msg::X_UNSPECIFIED_YZ_CYCLE, msg::R_LESS_THAN_X_YZ),
            _ => (msg::Y_UNSPECIFIED_XZ_CYCLE, msg::R_LESS_THAN_Y_XZ),
        };
        let cc_letter = [b'x', b'y', b'z'][ic];
        let mut current_cc = self.s.cur[ic];
        if self.s.motion_mode != motion {
            check(words[ic].is_none(), missing, MOTION)?;
        }
        let cc_word = words[ic].unwrap_or(self.s.cycle.cc);
        let mut old_cc = if self.s.cycle.il_flag {
            self.s.cycle.il
        } else {
            self.s.cycle.il = current_cc;
            self.s.cycle.il_flag = true;
            current_cc
        };
        let r_word = b.r.unwrap_or(0.0);
        let (mut aa, mut bb, r, cc);
        let (mut aa_inc, mut bb_inc, mut radius_inc, mut theta_inc) = (0.0, 0.0, 0.0, 0.0);
        if self.s.absolute {
            r = r_word;
            cc = cc_word;
            if plane == Plane::XY && (b.radius.is_some() || b.theta.is_some()) {
                let radius = b.radius.unwrap_or_else(|| self.s.cur[1].hypot(self.s.cur[0]));
                let theta = b.theta.map_or_else(
                    || self.s.cur[1].atan2(self.s.cur[0]),
                    |t| t * (std::f64::consts::PI / 180.0),
                );
                aa = radius * theta.cos();
                bb = radius * theta.sin();
            } else {
                aa = words[ia].unwrap_or(self.s.cur[ia]);
                bb = words[ib].unwrap_or(self.s.cur[ib]);
            }
        } else {
            aa_inc = words[ia].unwrap_or(0.0);
            bb_inc = words[ib].unwrap_or(0.0);
            if plane == Plane::XY {
                radius_inc = b.radius.unwrap_or(0.0);
                theta_inc = b.theta.map_or(0.0, |t| t * (std::f64::consts::PI / 180.0));
            }
            r = r_word + old_cc;
            cc = r + cc_word;
            aa = self.s.cur[ia];
            bb = self.s.cur[ib];
        }
        check(r < cc, less, At::Letter(cc_letter))?;
        if old_cc < r {
            let mut p = self.s.cur;
            p[ic] = r;
            self.emit(Canon::StraightTraverse(p))?;
            old_cc = r;
            current_cc = old_cc;
        }
        let clear_cc = if self.s.retract_old_z { old_cc } else { r };
        let (save_mode, save_tol, save_cam) =
            (self.world.control, self.world.tolerance, self.world.naivecam_tolerance);
        if save_mode != MotionControl::ExactPath {
            self.emit(Canon::SetMotionControlMode {
                mode: MotionControl::ExactPath,
                tolerance: 0.0,
            })?;
        }
        let geo = Geo { axes, clear_cc, r };
        let old_mode = self.s.motion_mode;
        // The per-cycle word that persists between blocks (P dwell or Q peck).
        match motion {
            g::G82 | g::G86 | g::G88 | g::G89 => {
                let m = match motion {
                    g::G82 => msg::DWELL_P_MISSING_G82,
                    g::G86 => msg::DWELL_P_MISSING_G86,
                    g::G88 => msg::DWELL_P_MISSING_G88,
                    _ => msg::DWELL_P_MISSING_G89,
                };
                check(old_mode != motion && b.p_number == -1.0, m, MOTION)?;
                if b.p_number == -1.0 {
                    b.p_number = self.s.cycle.p;
                }
            }
            g::G74 | g::G84 => {
                if b.p_number == -1.0 {
                    b.p_number = self.s.cycle.p;
                }
                if let Some(d) = b.dollar {
                    let m = if plane == Plane::XZ {
                        "Invalid E-number in G74/G84 cycle"
                    } else {
                        "Invalid spindle ($) number in G74/G84 cycle"
                    };
                    check(!(0.0..1.0).contains(&d), m, At::Letter(b'$'))?;
                }
            }
            g::G73 | g::G83 => {
                let m = if motion == g::G73 { msg::Q_MISSING_G73 } else { msg::Q_MISSING_G83 };
                check(old_mode != motion && b.q_number == -1.0, m, MOTION)?;
                if b.q_number == -1.0 {
                    b.q_number = self.s.cycle.q;
                }
            }
            g::G87 => {
                if old_mode != g::G87 {
                    check(b.i.is_none(), msg::I_MISSING_G87, MOTION)?;
                    check(b.j.is_none(), msg::J_MISSING_G87, MOTION)?;
                    check(b.k.is_none(), msg::K_MISSING_G87, MOTION)?;
                }
                self.s.cycle.i = b.i.unwrap_or(self.s.cycle.i);
                self.s.cycle.j = b.j.unwrap_or(self.s.cycle.j);
                self.s.cycle.k = b.k.unwrap_or(self.s.cycle.k);
            }
            _ => {}
        }
        let ijk = [self.s.cycle.i, self.s.cycle.j, self.s.cycle.k];
        for repeat in (1..=b.l_number).rev() {
            aa += aa_inc;
            bb += bb_inc;
            for (inc, is_radius) in [(radius_inc, true), (theta_inc, false)] {
                if inc != 0.0 {
                    check(
                        bb == 0.0 && aa == 0.0,
                        "Incremental motion with polar coordinates is indeterminate when at the origin",
                        MOTION,
                    )?;
                    let (radius, theta) = if is_radius {
                        (bb.hypot(aa) + inc, bb.atan2(aa))
                    } else {
                        (bb.hypot(aa), bb.atan2(aa) + inc)
                    };
                    aa = radius * theta.cos();
                    bb = radius * theta.sin();
                }
            }
            if repeat == b.l_number && current_cc > r {
                self.cycle_move(false, &geo, aa, bb, current_cc)?;
                self.cycle_move(false, &geo, aa, bb, r)?;
            } else {
                self.cycle_move(false, &geo, aa, bb, clear_cc)?;
                if clear_cc > r {
                    self.cycle_move(false, &geo, aa, bb, r)?;
                }
            }
            self.one_cycle(motion, b, &geo, aa, bb, cc, ijk)?;
        }
        match motion {
            g::G82 | g::G86 | g::G88 | g::G89 | g::G74 | g::G84 => self.s.cycle.p = b.p_number,
            g::G73 | g::G83 => self.s.cycle.q = b.q_number,
            _ => {}
        }
        self.s.cur[ia] = aa;
        self.s.cur[ib] = bb;
        self.s.cur[ic] = clear_cc;
        self.s.cycle.cc = cc_word;
        if save_mode != MotionControl::ExactPath {
            self.emit(Canon::SetMotionControlMode { mode: save_mode, tolerance: save_tol })?;
            self.emit(Canon::SetNaivecamTolerance(save_cam))?;
        }
        Ok(())
    }

    /// A cycle's feed or traverse to (aa, bb, cc) in the plane's axes (cycle_feed/cycle_traverse).
    fn cycle_move(&mut self, feed: bool, geo: &Geo, aa: f64, bb: f64, cc: f64) -> Res<()> {
        let mut p = self.s.cur;
        p[geo.axes[0]] = aa;
        p[geo.axes[1]] = bb;
        p[geo.axes[2]] = cc;
        self.emit(if feed { Canon::StraightFeed(p) } else { Canon::StraightTraverse(p) })
    }

    #[allow(clippy::too_many_arguments)]
    fn one_cycle(
        &mut self,
        motion: i32,
        b: &Block,
        geo: &Geo,
        aa: f64,
        bb: f64,
        bottom: f64,
        ijk: [f64; 3],
    ) -> Res<()> {
        let clear = geo.clear_cc;
        match motion {
            g::G81 => {
                self.cycle_move(true, geo, aa, bb, bottom)?;
                self.cycle_move(false, geo, aa, bb, clear)
            }
            g::G82 => {
                self.cycle_move(true, geo, aa, bb, bottom)?;
                self.emit(Canon::Dwell(b.p_number))?;
                self.cycle_move(false, geo, aa, bb, clear)
            }
            g::G73 | g::G83 => self.peck(motion, geo, aa, bb, bottom, b.q_number),
            g::G85 => {
                self.cycle_move(true, geo, aa, bb, bottom)?;
                self.cycle_move(true, geo, aa, bb, geo.r)?;
                self.cycle_move(false, geo, aa, bb, clear)
            }
            g::G89 => {
                self.cycle_move(true, geo, aa, bb, bottom)?;
                self.emit(Canon::Dwell(b.p_number))?;
                self.cycle_move(true, geo, aa, bb, clear)
            }
            g::G86 | g::G88 | g::G87 => {
                let (start, m) = match (motion, self.s.spindle) {
                    (_, Spindle::Clockwise) => (Canon::StartSpindleClockwise(0), ""),
                    (_, Spindle::CounterClockwise) => (Canon::StartSpindleCounterclockwise(0), ""),
                    (g::G86, _) => (Canon::StopSpindleTurning(0), msg::SPINDLE_NOT_TURNING_G86),
                    (g::G88, _) => (Canon::StopSpindleTurning(0), msg::SPINDLE_NOT_TURNING_G88),
                    _ => (Canon::StopSpindleTurning(0), msg::SPINDLE_NOT_TURNING_G87),
                };
                if !m.is_empty() {
                    return fail(m);
                }
                match motion {
                    g::G86 => {
                        self.cycle_move(true, geo, aa, bb, bottom)?;
                        self.emit(Canon::Dwell(b.p_number))?;
                        self.emit(Canon::StopSpindleTurning(0))?;
                        self.cycle_move(false, geo, aa, bb, clear)?;
                        self.emit(start)
                    }
                    g::G88 => {
                        self.cycle_move(true, geo, aa, bb, bottom)?;
                        self.emit(Canon::Dwell(b.p_number))?;
                        self.emit(Canon::StopSpindleTurning(0))?;
                        self.emit(Canon::ProgramStop)?;
                        self.emit(start)
                    }
                    _ => self.back_bore(geo, aa, bb, bottom, ijk, start),
                }
            }
            _ => self.tap(motion, b, geo, aa, bb, bottom),
        }
    }

    fn peck(
        &mut self,
        motion: i32,
        geo: &Geo,
        aa: f64,
        bb: f64,
        bottom: f64,
        delta: f64,
    ) -> Res<()> {
        check(delta <= 0.0, msg::NEGATIVE_OR_ZERO_Q, At::Letter(b'q'))?;
        let rapid_delta =
            if self.s.units == Units::Mm { G83_RAPID_DELTA_IN * 25.4 } else { G83_RAPID_DELTA_IN };
        let mut depth = geo.r - delta;
        while depth > bottom {
            self.cycle_move(true, geo, aa, bb, depth)?;
            if motion == g::G83 {
                self.cycle_move(false, geo, aa, bb, geo.r)?;
            }
            self.cycle_move(false, geo, aa, bb, depth + rapid_delta)?;
            depth -= delta;
        }
        self.cycle_move(true, geo, aa, bb, bottom)?;
        self.cycle_move(false, geo, aa, bb, geo.clear_cc)
    }

    fn back_bore(
        &mut self,
        geo: &Geo,
        aa: f64,
        bb: f64,
        bottom: f64,
        ijk: [f64; 3],
        start: Canon,
    ) -> Res<()> {
        let [ia, ib, ic] = geo.axes;
        let (oa, ob) = (aa + ijk[ia], bb + ijk[ib]);
        let mut middle = ijk[ic];
        if !self.s.absolute {
            middle += bottom;
        }
        // CANON_CLOCKWISE is 2, CANON_COUNTERCLOCKWISE 3.
        let dir = if self.s.spindle == Spindle::Clockwise { 2 } else { 3 };
        let orient = Canon::OrientSpindle { spindle: 0, orientation: 0.0, mode: dir };
        self.cycle_move(false, geo, oa, ob, geo.r)?;
        self.emit(Canon::StopSpindleTurning(0))?;
        self.emit(orient.clone())?;
        self.cycle_move(false, geo, oa, ob, bottom)?;
        self.cycle_move(false, geo, aa, bb, bottom)?;
        self.emit(start.clone())?;
        self.cycle_move(true, geo, aa, bb, middle)?;
        self.cycle_move(true, geo, aa, bb, bottom)?;
        self.emit(Canon::StopSpindleTurning(0))?;
        self.emit(orient)?;
        self.cycle_move(false, geo, oa, ob, bottom)?;
        self.cycle_move(false, geo, oa, ob, geo.clear_cc)?;
        self.cycle_move(false, geo, aa, bb, geo.clear_cc)?;
        self.emit(start)
    }

    /// G74/G84 floating-chuck tapping.
    fn tap(&mut self, motion: i32, b: &Block, geo: &Geo, aa: f64, bb: f64, bottom: f64) -> Res<()> {
        match self.s.spindle {
            Spindle::Stopped => return fail(format!("Spindle not turning in {}", g_name(motion))),
            Spindle::Clockwise if motion == g::G74 => {
                return fail("Spindle turning clockwise in G74")
            }
            Spindle::CounterClockwise if motion == g::G84 => {
                return fail("Spindle turning counterclockwise in G84")
            }
            _ => {}
        }
        let (fo, so) = (self.world.feed_override, self.world.speed_override);
        // rs274 permutes the plane's axes differently for its tapping feeds in XZ and YZ.
        let tap_point = |s: &Core, cc: f64| -> [f64; 6] {
            let mut p = s.s.cur;
            let [ia, ib, ic] = geo.axes;
            match s.s.plane {
                Plane::YZ => (p[ib], p[ic], p[ia]) = (aa, bb, cc),
                Plane::XZ => (p[ic], p[ia], p[ib]) = (aa, bb, cc),
                _ => (p[ia], p[ib], p[ic]) = (aa, bb, cc),
            }
            p
        };
        let (fwd, rev) = if motion == g::G84 {
            (Canon::StartSpindleClockwise(0), Canon::StartSpindleCounterclockwise(0))
        } else {
            (Canon::StartSpindleCounterclockwise(0), Canon::StartSpindleClockwise(0))
        };
        self.emit(Canon::DisableFeedOverride)?;
        self.emit(Canon::DisableSpeedOverride(0))?;
        let down = tap_point(self, bottom);
        self.emit(Canon::StraightFeed(down))?;
        self.emit(Canon::StopSpindleTurning(0))?;
        self.emit(rev)?;
        self.emit(Canon::Dwell(b.p_number))?;
        let up = tap_point(self, geo.clear_cc);
        self.emit(Canon::StraightFeed(up))?;
        self.emit(Canon::StopSpindleTurning(0))?;
        self.emit(fwd)?;
        if fo {
            self.emit(Canon::EnableFeedOverride)?;
        }
        if so {
            self.emit(Canon::EnableSpeedOverride(0))?;
        }
        Ok(())
    }
}
