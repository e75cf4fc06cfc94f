//! Units, coordinate systems and offsets (rs274ngc's `convert_length_units`,
//! `convert_coordinate_system`, `convert_setup` (G10 L2/L20), `convert_axis_offsets`
//! (G52, G92, G92.1..G92.3), `convert_savehome` (G28.1/G30.1), `convert_tool_length_offset`
//! (G43, G43.1, G43.2, G49) and `convert_cutter_compensation` (G40..G42.1)).

use crate::block::Block;
use crate::canon::{Canon, Plane, Pos, Units};
use crate::core::Core;
use crate::diag::{check, fail, At, Fault, Res};
use crate::messages as msg;
use crate::modal::{g, group};
use crate::state::{rotate, rotate_xy, Side};

const INCH_PER_MM: f64 = 1.0 / 25.4;

impl Core {
    /// Parameter block `base+1..=base+6` (X Y Z in user units, A B C in degrees) in program units.
    pub(crate) fn params_pos(&self, base: usize) -> Pos {
        let mut p = [0.0; 6];
        for (i, v) in p.iter_mut().enumerate() {
            let u = self.params.num(base + 1 + i);
            *v = if i < 3 { self.s.user_to_program(u) } else { u };
        }
        p
    }

    pub(crate) fn convert_length_units(&mut self, code: i32) -> Res<()> {
        let units = if code == g::G20 { Units::Inches } else { Units::Mm };
        self.emit(Canon::UseLengthUnits(units))?;
        if self.s.units != units {
            let k = if units == Units::Inches { INCH_PER_MM } else { 25.4 };
            let s = &mut self.s;
            s.units = units;
            for i in 0..3 {
                s.cur[i] *= k;
                s.axis[i] *= k;
                s.origin[i] *= k;
            }
            s.comp_radius *= k;
            // rs274 reads these back from outside; its stand-alone model does not convert them.
            s.tool_offset = self.world.tool_offset;
            s.feed_rate = self.world.feed_rate;
            s.tolerance = self.world.tolerance;
            s.naivecam_tolerance = self.world.naivecam_tolerance;
        }
        Ok(())
    }

    /// Where the current point is in coordinate system `system` (1..=9).
    pub(crate) fn current_in_system(&self, system: i32, with_tlo: bool) -> Pos {
        let s = &self.s;
        let mut p = s.cur;
        for i in 0..6 {
            p[i] += s.axis[i];
        }
        let (mut x, mut y) = (p[0], p[1]);
        rotate(&mut x, &mut y, s.rotation_xy);
        (p[0], p[1]) = (x, y);
        for i in 0..6 {
            p[i] += s.origin[i];
            if !with_tlo {
                p[i] += s.tool_offset[i];
            }
        }
        let base = 5200 + system as usize * 20;
        let sys = self.params_pos(base);
        for i in 0..6 {
            p[i] -= sys[i];
        }
        let (mut x, mut y) = (p[0], p[1]);
        rotate(&mut x, &mut y, -self.params.num(base + 10));
        (p[0], p[1]) = (x, y);
        if self.params.num(5210) != 0.0 {
            let g92 = self.params_pos(5210);
            for i in 0..6 {
                p[i] -= g92[i];
            }
        }
        p
    }

    pub(crate) fn convert_coordinate_system(&mut self, code: i32) -> Res<()> {
        check(
            self.s.comp_on(),
            "Cannot change coordinate systems with cutter radius compensation on",
            At::GGroup(group::COORD_SYSTEM),
        )?;
        let origin = match code {
            540..=590 => (code - 530) / 10,
            _ => code - 584,
        };
        if origin == self.s.origin_index {
            return self.emit(Canon::Comment(
                "interpreter: continuing to use same coordinate system".into(),
            ));
        }
        self.s.cur = self.current_in_system(origin, true);
        self.s.origin_index = origin;
        self.params.set_num(5220, origin as f64);
        let base = 5200 + origin as usize * 20;
        self.s.origin = self.params_pos(base);
        self.s.rotation_xy = self.params.num(base + 10);
        self.emit(Canon::SetG5xOffset { index: origin, offset: self.s.origin })?;
        self.emit(Canon::SetG92Offset(self.s.axis))?;
        self.emit(Canon::SetXyRotation(self.s.rotation_xy))
    }

    /// G10 L2 and G10 L20: set a coordinate system's origin.
    pub(crate) fn convert_setup(&mut self, b: &Block) -> Res<()> {
        check(
            b.i.is_some() || b.j.is_some(),
            "I J words not allowed with G10 L2",
            At::GGroup(group::MODAL_0),
        )?;
        let mut p_int = (b.p_number + 0.0001) as i32;
        if p_int == 0 {
            p_int = self.s.origin_index;
        }
        check(
            self.s.comp_on() && p_int == self.s.origin_index,
            "Cannot change the active coordinate system with cutter radius compensation on",
            At::GGroup(group::MODAL_0),
        )?;
        let l20 = b.l_number == 20;
        let c = self.current_in_system(p_int, true);
        let base = 5200 + p_int as usize * 20;
        let r = match b.r {
            Some(r) => {
                check(l20, "R not allowed in G10 L20", At::Letter(b'r'))?;
                self.params.set_num(base + 10, r);
                r
            }
            None => self.params.num(base + 10),
        };
        let (x, y);
        if l20 {
            let (mut ox, mut oy) = (c[0], c[1]);
            let (mut nx, mut ny) = (b.x.unwrap_or(c[0]), b.y.unwrap_or(c[1]));
            rotate(&mut ox, &mut oy, r);
            rotate(&mut nx, &mut ny, r);
            x = ox + self.s.user_to_program(self.params.num(base + 1)) - nx;
            y = oy + self.s.user_to_program(self.params.num(base + 2)) - ny;
            self.params.set_num(base + 1, self.s.program_to_user(x));
            self.params.set_num(base + 2, self.s.program_to_user(y));
            if p_int == self.s.origin_index {
                let s = &mut self.s;
                rotate_xy(&mut s.cur, s.rotation_xy);
                s.rotation_xy = 0.0;
            }
        } else {
            x = match b.x {
                Some(v) => {
                    self.params.set_num(base + 1, self.s.program_to_user(v));
                    v
                }
                None => self.s.user_to_program(self.params.num(base + 1)),
            };
            y = match b.y {
                Some(v) => {
                    self.params.set_num(base + 2, self.s.program_to_user(v));
                    v
                }
                None => self.s.user_to_program(self.params.num(base + 2)),
            };
        }
        let mut new = [x, y, 0.0, 0.0, 0.0, 0.0];
        let words = [b.x, b.y, b.z, b.a, b.b, b.c];
        for i in 2..6 {
            let stored = self.params.num(base + 1 + i);
            let linear = i < 3;
            let to_prog = |v: f64| if linear { self.s.user_to_program(v) } else { v };
            new[i] = match words[i] {
                Some(mut v) => {
                    if l20 {
                        v = c[i] + to_prog(stored) - v;
                    }
                    let user = if linear { self.s.program_to_user(v) } else { v };
                    self.params.set_num(base + 1 + i, user);
                    v
                }
                None => to_prog(stored),
            };
        }
        if p_int == self.s.origin_index {
            let s = &mut self.s;
            rotate_xy(&mut s.cur, s.rotation_xy);
            for i in 0..6 {
                s.cur[i] += s.origin[i];
            }
            s.origin = new;
            for i in 0..6 {
                s.cur[i] -= new[i];
            }
            self.emit(Canon::SetG5xOffset { index: p_int, offset: new })?;
            let s = &mut self.s;
            rotate_xy(&mut s.cur, -r);
            s.rotation_xy = r;
            self.emit(Canon::SetXyRotation(r))?;
        } else {
            self.emit(Canon::Comment("interpreter: setting coordinate system origin".into()))?;
        }
        Ok(())
    }

    /// G52, G92, G92.1, G92.2, G92.3.
    pub(crate) fn convert_axis_offsets(&mut self, code: i32, b: &Block) -> Res<()> {
        check(
            self.s.comp_on(),
            msg::CANNOT_CHANGE_AXIS_OFFSETS_WITH_COMP,
            At::GGroup(group::MODAL_0),
        )?;
        let words = [b.x, b.y, b.z, b.a, b.b, b.c];
        match code {
            g::G52 | g::G92 => {
                self.params.set_num(5210, 1.0);
                let s = &mut self.s;
                for i in 0..6 {
                    if let Some(v) = words[i] {
                        if code == g::G52 {
                            s.cur[i] += s.axis[i] - v;
                            s.axis[i] = v;
                        } else {
                            s.axis[i] = s.cur[i] + s.axis[i] - v;
                            s.cur[i] = v;
                        }
                    }
                }
                self.emit(Canon::SetG92Offset(self.s.axis))?;
                self.store_g92_params();
            }
            g::G92_1 | g::G92_2 => {
                self.params.set_num(5210, 0.0);
                let s = &mut self.s;
                for i in 0..6 {
                    s.cur[i] += s.axis[i];
                }
                self.emit(Canon::SetG92Offset([0.0; 6]))?;
                self.s.axis = [0.0; 6];
                if code == g::G92_1 {
                    for i in 5211..=5219 {
                        self.params.set_num(i, 0.0);
                    }
                }
            }
            _ => {
                self.params.set_num(5210, 1.0);
                let stored = self.params_pos(5210);
                let s = &mut self.s;
                for i in 0..6 {
                    s.cur[i] = s.cur[i] + s.axis[i] - stored[i];
                }
                s.axis = stored;
                self.emit(Canon::SetG92Offset(self.s.axis))?;
            }
        }
        Ok(())
    }

    fn store_g92_params(&mut self) {
        for i in 0..6 {
            let v = self.s.axis[i];
            let u = if i < 3 { self.s.program_to_user(v) } else { v };
            self.params.set_num(5211 + i, u);
        }
        for i in 5217..=5219 {
            self.params.set_num(i, 0.0);
        }
    }

    /// G28.1/G30.1: store the current machine position.
    pub(crate) fn convert_savehome(&mut self, code: i32) -> Res<()> {
        check(
            self.s.comp_on(),
            "Cannot set reference point with cutter compensation in effect",
            At::GGroup(group::MODAL_0),
        )?;
        let s = &self.s;
        let (mut x, mut y) = (s.cur[0] + s.axis[0], s.cur[1] + s.axis[1]);
        rotate(&mut x, &mut y, s.rotation_xy);
        let mut v = [0.0; 6];
        v[0] = s.program_to_user(x + s.tool_offset[0] + s.origin[0]);
        v[1] = s.program_to_user(y + s.tool_offset[1] + s.origin[1]);
        v[2] = s.program_to_user(s.cur[2] + s.tool_offset[2] + s.origin[2] + s.axis[2]);
        for i in 3..6 {
            v[i] = s.cur[i] + s.tool_offset[i] + s.origin[i] + s.axis[i];
        }
        let base = if code == g::G28_1 { 5161 } else { 5181 };
        for (i, val) in v.iter().enumerate() {
            self.params.set_num(base + i, *val);
        }
        for i in 6..9 {
            self.params.set_num(base + i, 0.0);
        }
        Ok(())
    }

    pub(crate) fn convert_tool_length_offset(&mut self, code: i32, b: &Block) -> Res<()> {
        let at = At::GGroup(group::TOOL_LENGTH);
        check(
            self.s.comp_on(),
            "Cannot change tool offset with cutter radius compensation on",
            at,
        )?;
        let words = [b.x, b.y, b.z, b.a, b.b, b.c];
        let mut offset = [0.0; 9];
        match code {
            g::G49 => {}
            g::G43 => {
                let idx = if b.h_flag {
                    self.tool_index(b.h_number)?
                } else if self.s.toolchange_flag {
                    self.s.current_pocket.max(0) as usize
                } else {
                    0
                };
                offset = self.tool_offset_of(idx);
            }
            g::G43_1 => {
                offset = self.s.tool_offset;
                for i in 0..6 {
                    if let Some(v) = words[i] {
                        offset[i] = v;
                    }
                }
            }
            _ => {
                let axes = words.iter().any(Option::is_some);
                check(b.h_flag && axes, "G43.2: Can not have both H and axis words", at)?;
                check(!b.h_flag && !axes, "G43.2: No axes specified and H word missing", at)?;
                let idx = self.tool_index(b.h_number)?;
                offset = self.s.tool_offset;
                let add = self.tool_offset_of(idx);
                for i in 0..9 {
                    if b.h_flag {
                        offset[i] += add[i];
                    } else if i < 6 {
                        offset[i] += words[i].unwrap_or(0.0);
                    }
                }
            }
        }
        self.emit(Canon::UseToolLengthOffset(offset))?;
        let s = &mut self.s;
        let (mut dx, mut dy) = (s.tool_offset[0] - offset[0], s.tool_offset[1] - offset[1]);
        rotate(&mut dx, &mut dy, -s.rotation_xy);
        s.cur[0] += dx;
        s.cur[1] += dy;
        for i in 2..6 {
            s.cur[i] += s.tool_offset[i] - offset[i];
        }
        s.tool_offset = offset;
        Ok(())
    }

    /// A tool table entry's offsets in program units.
    fn tool_offset_of(&self, idx: usize) -> [f64; 9] {
        let e = self.s.tools.entries.get(idx).copied().unwrap_or(crate::canon::ToolEntry::EMPTY);
        let mut o = [0.0; 9];
        for i in 0..9 {
            let linear = !(3..6).contains(&i);
            o[i] = if linear { self.s.user_to_program(e.offset[i]) } else { e.offset[i] };
        }
        o
    }

    /// `find_tool_index`.
    pub(crate) fn tool_index(&self, toolno: i32) -> Res<usize> {
        self.s.tools.index_of(toolno).ok_or_else(|| Fault::line(msg::tool_not_found(toolno)))
    }

    pub(crate) fn convert_cutter_compensation(&mut self, b: &Block) -> Res<()> {
        let code = b.g_modes[group::CUTTER_COMP];
        let at = At::GGroup(group::CUTTER_COMP);
        if code == g::G40 {
            self.emit(Canon::Comment("interpreter: cutter radius compensation off".into()))?;
            self.s.comp_side = Side::Off;
            return Ok(());
        }
        let mut side = if code == g::G41 || code == g::G41_1 { Side::Left } else { Side::Right };
        check(!matches!(self.s.plane, Plane::XY | Plane::XZ), msg::COMP_ONLY_XY_XZ, at)?;
        check(self.s.comp_on(), msg::CANNOT_TURN_COMP_ON_WHEN_ON, at)?;
        let gnum = code / 10;
        let mut radius;
        if code == g::G41_1 || code == g::G42_1 {
            let Some(d) = b.d else {
                return fail(format!("G{gnum}.1 with no D word"));
            };
            radius = d / 2.0;
            if b.l_number != -1 {
                check(
                    self.s.plane != Plane::XZ,
                    format!("G{gnum}.1 with L word, but plane is not G18"),
                    at,
                )?;
            }
        } else {
            let idx = match b.d {
                None => 0,
                Some(d) => {
                    let tool = (d + 0.5) as i32;
                    check(
                        (tool as f64 - d).abs() >= 0.0001,
                        format!("G{gnum} requires D word to be a whole number"),
                        At::Letter(b'd'),
                    )?;
                    check(tool < 0, msg::NEGATIVE_D_WORD, At::Letter(b'd'))?;
                    self.tool_index(tool)?
                }
            };
            let e =
                self.s.tools.entries.get(idx).copied().unwrap_or(crate::canon::ToolEntry::EMPTY);
            radius = self.s.user_to_program(e.diameter) / 2.0;
            check(
                self.s.plane != Plane::XZ && e.orientation != 0 && e.orientation != 9,
                format!("G{gnum} with lathe tool, but plane is not G18"),
                at,
            )?;
        }
        if radius < 0.0 {
            radius = -radius;
            side = if side == Side::Right { Side::Left } else { Side::Right };
        }
        if radius > 0.0 {
            return Err(Fault::unsupported(
                format!(
                    "cutter radius compensation with a non-zero radius ({radius} {}) is not supported: \
                     compensate the path in CAM",
                    if self.s.units == Units::Inches { "in" } else { "mm" }
                ),
                at,
            ));
        }
        let t = if side == Side::Right { "right" } else { "left" };
        self.emit(Canon::Comment(format!("interpreter: cutter radius compensation on {t}")))?;
        self.s.comp_radius = radius;
        self.s.comp_side = side;
        Ok(())
    }
}
