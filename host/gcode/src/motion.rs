//! Straight moves, probing and G28/G30 (rs274ngc's `convert_motion`, `convert_straight`,
//! `convert_probe`, `convert_home`, and `find_ends`/`find_relative` in interp_find.cc).

use crate::block::Block;
use crate::canon::{Canon, Pos, ProbeKind};
use crate::core::Core;
use crate::diag::{check, At, Fault, Res};
use crate::messages as msg;
use crate::modal::{g, g_name, group, is_cycle};
use crate::state::{rotate, rotate_xy, FeedMode, Spindle};

const MOTION: At = At::GGroup(group::MOTION);

impl Core {
    pub(crate) fn convert_motion(&mut self, motion: i32, b: &mut Block) -> Res<()> {
        if !is_cycle(motion) {
            self.s.cycle.il_flag = false;
        }
        match motion {
            g::G0 | g::G1 | g::G33 | g::G33_1 | g::G76 => self.convert_straight(motion, b),
            g::G2 | g::G3 => self.convert_arc(motion, b),
            g::G38_2 | g::G38_3 | g::G38_4 | g::G38_5 => self.convert_probe(motion, b),
            g::G80 => {
                self.emit(Canon::Comment("interpreter: motion mode set to none".into()))?;
                self.s.motion_mode = g::G80;
                Ok(())
            }
            m if is_cycle(m) => self.convert_cycle(m, b),
            g::G5 | g::G5_1 => self.convert_spline(motion, b),
            g::G5_2 => self.convert_nurbs(motion, b),
            _ => Err(Fault::unsupported(
                format!("{} (lathe roughing cycle) is not supported", g_name(motion)),
                MOTION,
            )),
        }
    }

    /// `find_ends`: the block's end point in the active system.
    pub(crate) fn find_ends(&mut self, b: &Block) -> Res<Pos> {
        let s = &self.s;
        let mut p = [0.0; 6];
        if b.g_modes[group::MODAL_0] == g::G53 {
            check(
                b.polar_flag(),
                "Cannot use polar coordinates with G53",
                At::GGroup(group::MODAL_0),
            )?;
            let (mut cx, mut cy) = (s.cur[0] + s.axis[0], s.cur[1] + s.axis[1]);
            rotate(&mut cx, &mut cy, s.rotation_xy);
            p[0] = b.x.map_or(cx, |x| x - s.origin[0] - s.tool_offset[0]);
            p[1] = b.y.map_or(cy, |y| y - s.origin[1] - s.tool_offset[1]);
            rotate_xy(&mut p, -s.rotation_xy);
            p[0] -= s.axis[0];
            p[1] -= s.axis[1];
            p[2] = b.z.map_or(s.cur[2], |z| z - s.origin[2] - s.axis[2] - s.tool_offset[2]);
            let abc = [b.a, b.b, b.c];
            for i in 0..3 {
                p[3 + i] = abc[i].map_or(s.cur[3 + i], |v| v - s.origin[3 + i] - s.axis[3 + i]);
            }
        } else if s.absolute {
            p[0] = b.x.unwrap_or(s.cur[0]);
            p[1] = b.y.unwrap_or(s.cur[1]);
            let polar = |m: &str| {
                Fault::new(m.to_string(), At::Letter(if b.radius.is_some() { b'@' } else { b'^' }))
            };
            match (b.radius, b.theta) {
                (Some(r), Some(t)) => {
                    if b.x.is_some() || b.y.is_some() {
                        return Err(polar("Cannot specify X or Y words with polar coordinate"));
                    }
                    let t = t.to_radians_rs();
                    p[0] = r * t.cos();
                    p[1] = r * t.sin();
                }
                (Some(r), None) => {
                    if b.x.is_some() || b.y.is_some() {
                        return Err(polar("Cannot specify X or Y words with polar coordinate"));
                    }
                    if p[1] == 0.0 && p[0] == 0.0 {
                        return Err(polar(
                            "Must specify angle in polar coordinate if at the origin",
                        ));
                    }
                    let theta = p[1].atan2(p[0]);
                    p[0] = r * theta.cos();
                    p[1] = r * theta.sin();
                }
                (None, Some(t)) => {
                    if b.x.is_some() || b.y.is_some() {
                        return Err(polar("Cannot specify X or Y words with polar coordinate"));
                    }
                    let radius = p[1].hypot(p[0]);
                    let t = t.to_radians_rs();
                    p[0] = radius * t.cos();
                    p[1] = radius * t.sin();
                }
                (None, None) => {}
            }
            p[2] = b.z.unwrap_or(s.cur[2]);
            p[3] = b.a.unwrap_or(s.cur[3]);
            p[4] = b.b.unwrap_or(s.cur[4]);
            p[5] = b.c.unwrap_or(s.cur[5]);
        } else {
            p[0] = s.cur[0] + b.x.unwrap_or(0.0);
            p[1] = s.cur[1] + b.y.unwrap_or(0.0);
            let polar = |m: &str, l: u8| Fault::new(m.to_string(), At::Letter(l));
            if let Some(r) = b.radius {
                if b.x.is_some() || b.y.is_some() {
                    return Err(polar("Cannot specify X or Y words with polar coordinate", b'@'));
                }
                if p[1] == 0.0 && p[0] == 0.0 {
                    return Err(polar("Incremental motion with polar coordinates is indeterminate when at the origin", b'@'));
                }
                let theta = p[1].atan2(p[0]);
                let radius = p[1].hypot(p[0]) + r;
                p[0] = radius * theta.cos();
                p[1] = radius * theta.sin();
            }
            if let Some(t) = b.theta {
                if b.x.is_some() || b.y.is_some() {
                    return Err(polar("Cannot specify X or Y words with polar coordinate", b'^'));
                }
                if p[1] == 0.0 && p[0] == 0.0 {
                    return Err(polar(
                        "G91 motion with polar coordinates is indeterminate when at the origin",
                        b'^',
                    ));
                }
                let theta = p[1].atan2(p[0]) + t.to_radians_rs();
                let radius = p[1].hypot(p[0]);
                p[0] = radius * theta.cos();
                p[1] = radius * theta.sin();
            }
            p[2] = s.cur[2] + b.z.unwrap_or(0.0);
            p[3] = s.cur[3] + b.a.unwrap_or(0.0);
            p[4] = s.cur[4] + b.b.unwrap_or(0.0);
            p[5] = s.cur[5] + b.c.unwrap_or(0.0);
        }
        Ok(p)
    }

    /// `find_relative`: a machine-coordinate point in the active system.
    pub(crate) fn find_relative(&self, m: &Pos) -> Pos {
        let s = &self.s;
        let mut x = m[0] - s.origin[0] - s.tool_offset[0];
        let mut y = m[1] - s.origin[1] - s.tool_offset[1];
        rotate(&mut x, &mut y, -s.rotation_xy);
        x -= s.axis[0];
        y -= s.axis[1];
        let z = m[2] - s.origin[2] - s.axis[2] - s.tool_offset[2];
        let mut p = [x, y, z, 0.0, 0.0, 0.0];
        for i in 3..6 {
            p[i] = m[i] - s.origin[i] - s.axis[i];
        }
        p
    }

    fn feed_checks_g1(&self, b: &Block) -> Res<()> {
        match self.s.feed_mode {
            FeedMode::UnitsPerMinute => {
                check(self.s.feed_rate == 0.0, msg::CANNOT_DO_G1_WITH_ZERO_FEED, MOTION)
            }
            FeedMode::UnitsPerRevolution => {
                check(self.s.feed_rate == 0.0, msg::CANNOT_DO_G1_WITH_ZERO_FEED, MOTION)?;
                check(
                    self.s.speed == 0.0,
                    "Cannot feed with zero spindle speed in feed per rev mode",
                    MOTION,
                )
            }
            FeedMode::InverseTime => check(b.f.is_none(), msg::F_MISSING_INVERSE_G1, MOTION),
        }
    }

    fn convert_straight(&mut self, motion: i32, b: &Block) -> Res<()> {
        self.s.arc_not_allowed = false;
        if motion == g::G1 {
            self.feed_checks_g1(b)?;
        }
        self.s.motion_mode = motion;
        let end = self.find_ends(b)?;
        if motion == g::G1 {
            self.inverse_time_rate_straight(&end, b)?;
        }
        if self.s.comp_on() && self.s.comp_radius > 0.0 {
            return Err(Fault::unsupported(
                "cutter radius compensation with a non-zero radius is not supported",
                MOTION,
            ));
        }
        match motion {
            g::G0 => {
                self.emit(Canon::StraightTraverse(end))?;
                self.s.cur[..3].copy_from_slice(&end[..3]);
            }
            g::G1 => {
                self.emit(Canon::StraightFeed(end))?;
                self.s.cur[..3].copy_from_slice(&end[..3]);
            }
            g::G33 | g::G33_1 => {
                if let Some(d) = b.dollar {
                    let m = format!("Invalid spindle ($) number in {} move", g_name(motion));
                    check(!(0.0..1.0).contains(&d), m, At::Letter(b'$'))?;
                }
                if self.s.spindle == Spindle::Stopped {
                    return Err(Fault::new(
                        format!("Spindle not turning in {}", g_name(motion)),
                        MOTION,
                    ));
                }
                let k = b.k.unwrap_or(0.0);
                self.emit(Canon::StartSpeedFeedSynch {
                    spindle: 0,
                    feed_per_revolution: k,
                    velocity_mode: false,
                })?;
                if motion == g::G33 {
                    self.emit(Canon::StraightFeed(end))?;
                    self.emit(Canon::StopSpeedFeedSynch)?;
                    self.s.cur[..3].copy_from_slice(&end[..3]);
                } else {
                    let scale = b.i.map_or(1.0, |i| i.max(1.0));
                    self.emit(Canon::RigidTap { x: end[0], y: end[1], z: end[2], scale })?;
                    self.emit(Canon::StopSpeedFeedSynch)?;
                }
            }
            _ => return Err(Fault::unsupported("G76 (threading cycle) is not supported", MOTION)),
        }
        self.s.cur[3..].copy_from_slice(&end[3..]);
        Ok(())
    }

    /// `inverse_time_rate_straight`: in G93, F becomes a feed rate from the move's length.
    fn inverse_time_rate_straight(&mut self, end: &Pos, b: &Block) -> Res<()> {
        if self.s.feed_mode != FeedMode::InverseTime {
            return Ok(());
        }
        let c = &self.s.cur;
        let tiny = 1e-7;
        let linear = (0..3).any(|i| (c[i] - end[i]).abs() > tiny);
        let length = if linear {
            ((end[0] - c[0]).powi(2) + (end[1] - c[1]).powi(2) + (end[2] - c[2]).powi(2)).sqrt()
        } else {
            ((end[3] - c[3]).powi(2) + (end[4] - c[4]).powi(2) + (end[5] - c[5]).powi(2)).sqrt()
        };
        let rate = (length * b.f.unwrap_or(0.0)).max(0.1);
        self.emit(Canon::SetFeedRate(rate))?;
        self.s.feed_rate = rate;
        Ok(())
    }

    fn convert_probe(&mut self, code: i32, b: &Block) -> Res<()> {
        let kind = match code {
            g::G38_2 => ProbeKind::TowardError,
            g::G38_3 => ProbeKind::Toward,
            g::G38_4 => ProbeKind::AwayError,
            _ => ProbeKind::Away,
        };
        check(self.s.comp_on(), msg::CANNOT_PROBE_WITH_COMP, MOTION)?;
        check(self.s.feed_rate == 0.0, msg::CANNOT_PROBE_WITH_ZERO_FEED, MOTION)?;
        check(
            self.s.feed_mode == FeedMode::UnitsPerRevolution,
            "Cannot probe with feed per rev mode",
            MOTION,
        )?;
        let end = self.find_ends(b)?;
        check(kind.bits() & 1 == 0 && self.s.cur == end, msg::START_TOO_CLOSE_TO_PROBE, MOTION)?;
        self.emit(Canon::TurnProbeOn)?;
        self.emit(Canon::StraightProbe { end, kind })?;
        self.emit(Canon::TurnProbeOff)?;
        self.s.motion_mode = code;
        self.s.probe_flag = true;
        Ok(())
    }

    /// G28/G30: through the block's point (if any) to the stored position.
    pub(crate) fn convert_home(&mut self, code: i32, b: &Block) -> Res<()> {
        let mut end = self.find_ends(b)?;
        check(self.s.comp_on(), msg::CANNOT_USE_G28_G30_WITH_COMP, At::GGroup(group::MODAL_0))?;
        self.emit(Canon::StraightTraverse(end))?;
        self.s.cur = end;
        let base = if code == g::G28 { 5161 } else { 5181 };
        let mut stored = [0.0; 6];
        for (i, v) in stored.iter_mut().enumerate() {
            let u = self.params.num(base + i);
            *v = if i < 3 { self.s.user_to_program(u) } else { u };
        }
        let home = self.find_relative(&stored);
        let words = [b.x, b.y, b.z, b.a, b.b, b.c];
        if words.iter().all(Option::is_none) {
            end = home;
        } else {
            for i in 0..6 {
                if words[i].is_some() {
                    end[i] = home[i];
                }
            }
        }
        self.emit(Canon::StraightTraverse(end))?;
        self.s.cur = end;
        Ok(())
    }
}

/// rs274's D2R: degrees times (pi / 180).
trait ToRadiansRs {
    fn to_radians_rs(self) -> f64;
}

impl ToRadiansRs for f64 {
    fn to_radians_rs(self) -> f64 {
        self * (std::f64::consts::PI / 180.0)
    }
}
