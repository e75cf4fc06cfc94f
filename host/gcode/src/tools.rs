//! Tools (rs274ngc's `convert_tool_select`, `convert_tool_change`, M61 and `convert_setup_tool`
//! for G10 L1/L10/L11), and the #5400.. tool parameters.

use crate::block::Block;
use crate::canon::{Canon, ToolEntry};
use crate::core::Core;
use crate::diag::{check, fail, At, Res};
use crate::messages as msg;
use crate::modal::{group, mgroup};
use crate::state::{rotate, Spindle};

impl Core {
    /// T: prepare a tool.
    pub(crate) fn convert_tool_select(&mut self, t: i32) -> Res<()> {
        let idx = self.tool_index(t).map_err(|mut f| {
            f.at = At::Letter(b't');
            f
        })?;
        self.emit(Canon::SelectTool(t))?;
        self.s.selected_pocket = idx as i32;
        self.s.selected_tool = t;
        Ok(())
    }

    /// M6: change to the prepared tool.
    pub(crate) fn convert_tool_change(&mut self) -> Res<()> {
        let at = At::MGroup(mgroup::TOOL);
        check(self.s.selected_pocket < 0, msg::TXX_MISSING_FOR_M6, at)?;
        check(self.s.comp_on(), "Cannot change tools with cutter radius compensation on", at)?;
        self.emit(Canon::StartChange)?;
        self.emit(Canon::StopSpindleTurning(0))?;
        self.s.spindle = Spindle::Stopped;
        self.emit(Canon::ChangeTool(self.s.selected_pocket))?;
        self.s.current_pocket = self.s.selected_pocket;
        self.s.toolchange_flag = true;
        self.set_tool_parameters();
        Ok(())
    }

    /// M61 Q: say which tool is in the spindle, without a change.
    pub(crate) fn convert_m61(&mut self, b: &Block) -> Res<()> {
        let toolno = b.q_number.round_ties_even() as i32;
        check(
            toolno < 0,
            "Need non-negative Q-word to specify tool number with M61",
            At::MGroup(mgroup::TOOL),
        )?;
        let idx = self.tool_index(toolno)?;
        self.s.current_pocket = idx as i32;
        self.s.toolchange_flag = true;
        self.emit(Canon::ChangeToolNumber(idx as i32))?;
        self.set_tool_parameters();
        Ok(())
    }

    /// #5400..#5413 from the tool in the spindle (`set_tool_parameters`).
    pub(crate) fn set_tool_parameters(&mut self) {
        let e = self.s.tools.entries.first().copied().unwrap_or(ToolEntry::EMPTY);
        if e.toolno <= 0 {
            for i in 5400..=5413 {
                self.params.set_num(i, 0.0);
            }
            return;
        }
        self.params.set_num(5400, e.toolno as f64);
        for i in 0..9 {
            self.params.set_num(5401 + i, e.offset[i]);
        }
        self.params.set_num(5410, e.diameter);
        self.params.set_num(5411, e.frontangle);
        self.params.set_num(5412, e.backangle);
        self.params.set_num(5413, e.orientation as f64);
    }

    /// The interpreter's copy of the tool table, from outside (`load_tool_table`).
    pub(crate) fn load_tool_table(&mut self) {
        self.s.tools = self.world.tools.clone();
        self.set_tool_parameters();
    }

    /// G10 L1, L10, L11: set a tool table entry.
    pub(crate) fn convert_setup_tool(&mut self, b: &Block) -> Res<()> {
        let toolno = (b.p_number + 0.5) as i32;
        let idx = self.tool_index(toolno)?;
        let any = b.x.is_some()
            || b.y.is_some()
            || b.z.is_some()
            || b.a.is_some()
            || b.b.is_some()
            || b.c.is_some()
            || b.r.is_some()
            || b.q_flag
            || b.i.is_some()
            || b.j.is_some();
        check(!any, "G10 L1 without offsets has no effect", At::GGroup(group::MODAL_0))?;
        let mut e = self.s.tools.entries[idx];
        let words = [b.x, b.y, b.z, b.a, b.b, b.c];
        let to_user = |s: &Self, i: usize, v: f64| if i < 3 { s.s.program_to_user(v) } else { v };
        if b.l_number == 1 {
            for i in 0..6 {
                if let Some(v) = words[i] {
                    e.offset[i] = to_user(self, i, v);
                }
            }
        } else {
            let fixture = b.l_number == 11;
            let system = if fixture { 9 } else { self.s.origin_index };
            let mut t = self.current_in_system(system, false);
            if fixture && self.params.num(5210) != 0.0 {
                let g92 = self.params_pos(5210);
                for i in 0..6 {
                    t[i] += g92[i];
                }
            }
            let rot = self.params.num(5210 + system as usize * 20);
            let prog = |s: &Self, v: f64| s.s.user_to_program(v);
            match (b.x, b.y) {
                (Some(x), Some(y)) => {
                    let (mut tx, mut ty) = (t[0] - x, t[1] - y);
                    rotate(&mut tx, &mut ty, rot);
                    e.offset[0] = self.s.program_to_user(tx);
                    e.offset[1] = self.s.program_to_user(ty);
                }
                (Some(x), None) | (None, Some(x)) => {
                    let x_word = b.x.is_some();
                    let (mut ox, mut oy) = (prog(self, e.offset[0]), prog(self, e.offset[1]));
                    rotate(&mut ox, &mut oy, -rot);
                    if x_word {
                        ox = 0.0;
                    } else {
                        oy = 0.0;
                    }
                    rotate(&mut ox, &mut oy, rot);
                    let (mut tx, mut ty) = if x_word { (t[0] - x, 0.0) } else { (0.0, t[1] - x) };
                    rotate(&mut tx, &mut ty, rot);
                    e.offset[0] = self.s.program_to_user(tx + ox);
                    e.offset[1] = self.s.program_to_user(ty + oy);
                }
                (None, None) => {}
            }
            for i in 2..6 {
                if let Some(v) = words[i] {
                    e.offset[i] = to_user(self, i, t[i] - v);
                }
            }
        }
        if let Some(r) = b.r {
            e.diameter = self.s.program_to_user(r) * 2.0;
        }
        if let Some(i) = b.i {
            e.frontangle = i;
        }
        if let Some(j) = b.j {
            e.backangle = j;
        }
        if b.q_number != -1.0 {
            let q = (b.q_number + 0.5) as i32;
            check(
                (q as f64 - b.q_number).abs() >= 0.0001,
                "Q number in G10 is not an integer",
                At::Letter(b'q'),
            )?;
            if q > 9 {
                return fail("Invalid tool orientation");
            }
            e.orientation = q;
        }
        self.s.tools.entries[idx] = e;
        self.emit(Canon::SetToolTableEntry { index: idx as i32, entry: e })?;
        if self.s.current_pocket == idx as i32 {
            self.s.tools.entries[0] = e;
        }
        let spindle = self.s.tools.entries[0];
        self.params.set_num(5400, spindle.toolno.max(0) as f64);
        for i in 0..9 {
            self.params.set_num(5401 + i, spindle.offset[i]);
        }
        self.params.set_num(5410, spindle.diameter);
        self.params.set_num(5411, spindle.frontangle);
        self.params.set_num(5412, spindle.backangle);
        self.params.set_num(5413, spindle.orientation as f64);
        if self.s.current_pocket == idx as i32 {
            self.emit(Canon::SetToolTableEntry { index: 0, entry: e })?;
        }
        Ok(())
    }
}
