//! Running O-word lines (rs274ngc's `convert_control_functions` and friends in
//! interp_o_word.cc): labels remember their file position, loops and calls seek back to them,
//! and skipped code is read without being run until the matching label.

use crate::core::Core;
use crate::diag::{At, Fault, Res};
use crate::messages as msg;
use crate::oword::OLine;
use crate::params::SUB_PARAMS;
use crate::source::{LineSource, SourcePos};
use crate::state::{Frame, Label, OKind};

fn kind_name(k: OKind) -> &'static str {
    match k {
        OKind::None => "none",
        OKind::Sub => "sub",
        OKind::Endsub => "endsub",
        OKind::Call => "call",
        OKind::Do => "do",
        OKind::While => "while",
        OKind::If => "if",
        OKind::Elseif => "elseif",
        OKind::Else => "else",
        OKind::Endif => "endif",
        OKind::Break => "break",
        OKind::Continue => "continue",
        OKind::Endwhile => "endwhile",
        OKind::Return => "return",
        OKind::Repeat => "repeat",
        OKind::Endrepeat => "endrepeat",
        OKind::M98 => "98",
        OKind::Bare => "",
    }
}

/// Where the current line is, for the label table and the messages.
pub(crate) struct Here<'a> {
    pub at: SourcePos,
    pub text: &'a str,
    pub file: &'a str,
}

impl Core {
    /// Runs one O-word line.
    pub(crate) fn control(&mut self, o: &OLine, here: &Here, src: &mut dyn LineSource) -> Res<()> {
        if self.s.skipping_o.as_ref().is_some_and(|s| *s != o.name) {
            return Ok(());
        }
        if self.s.skipping_to_sub.is_some() && o.kind != OKind::Sub && o.kind != OKind::Bare {
            return Ok(());
        }
        let line = self.s.line;
        match o.kind {
            OKind::None => {}
            OKind::Sub | OKind::Bare => {
                if o.kind == OKind::Bare && self.s.frames[self.s.call_level].is_call {
                    return Err(Fault::line("Fanuc 'O....' subroutine must be called with 'M98'"));
                }
                if self.s.skipping_o.is_some() {
                    self.save_label(o, here, src)?;
                    self.s.skipping_o = None;
                }
                self.s.skipping_to_sub = None;
                if o.kind == OKind::Sub && self.s.call_level == 0 {
                    if self.s.defining_sub {
                        return Err(Fault::line(msg::NESTED_SUB_DEFINITION));
                    }
                    self.save_label(o, here, src)?;
                    self.s.skipping_o = Some(o.name.clone());
                    self.s.skipping_start = line;
                    self.s.defining_sub = true;
                    self.s.sub_name = Some(o.name.clone());
                }
            }
            OKind::Endsub | OKind::Return => {
                if self.s.call_level == 0 && self.s.sub_name.is_none() {
                    return Err(Fault::line(format!(
                        "{line}: not in a subroutine definition: '{}'",
                        here.text
                    )));
                }
                self.execute_return(o, src)?;
            }
            OKind::Call => {
                self.s.call_level += 1;
                if self.s.call_level >= crate::params::CALL_LEVELS {
                    return Err(Fault::line(msg::TOO_MANY_SUB_LEVELS));
                }
                let level = self.s.call_level;
                self.s.frames[level] =
                    Frame { sub_name: Some(o.name.clone()), is_call: true, ..Frame::default() };
                self.execute_call(o, here, src)?;
            }
            OKind::Do => {
                self.s.skipping_o = None;
                if !self.s.labels.contains_key(&o.name) {
                    self.save_label(o, here, src)?;
                }
            }
            OKind::Repeat => self.repeat(o, here, src)?,
            OKind::While => self.while_(o, here, src)?,
            OKind::If => {
                match self.s.labels.get(&o.name) {
                    Some(l) if l.at.line != line => {
                        return Err(Fault::line(format!(
                            "{line}: duplicate O-word label - already defined in line {}: '{}'",
                            l.at.line, here.text
                        )))
                    }
                    Some(_) => {}
                    None => self.save_label(o, here, src)?,
                }
                if self.s.test_value != 0.0 {
                    self.s.skipping_o = None;
                    self.s.executed_if = true;
                } else {
                    self.s.skipping_o = Some(o.name.clone());
                    self.s.skipping_start = line;
                    self.s.executed_if = false;
                }
            }
            OKind::Elseif | OKind::Else | OKind::Endif => self.conditional(o, here)?,
            OKind::Break | OKind::Continue => {
                let l = self.find_label(o, here)?;
                if l.kind != OKind::While && l.kind != OKind::Do {
                    return Err(Fault::line(format!(
                        "{line}: no matching while/do label: '{}' (found '{}' in line {})",
                        here.text,
                        kind_name(l.kind),
                        l.at.line
                    )));
                }
                if o.kind == OKind::Continue {
                    if self.s.skipping_o.as_deref() == Some(o.name.as_str()) {
                        return Ok(());
                    }
                    self.s.doing_continue = true;
                } else {
                    self.s.doing_break = true;
                }
                self.s.skipping_o = Some(o.name.clone());
                self.s.skipping_start = line;
            }
            OKind::Endwhile | OKind::Endrepeat => {
                let l = self.find_label(o, here)?;
                let want = if o.kind == OKind::Endrepeat { OKind::Repeat } else { OKind::While };
                if l.kind != want {
                    return Err(Fault::line(format!(
                        "{line}: no matching label: '{}' (found '{}' in line {})",
                        here.text,
                        kind_name(l.kind),
                        l.at.line
                    )));
                }
                if self.s.skipping_o.as_deref() == Some(o.name.as_str()) {
                    self.s.skipping_o = None;
                    if self.s.doing_continue {
                        self.s.doing_continue = false;
                        self.back_to(o, src)?;
                    } else {
                        self.reset_iterations(&o.name);
                    }
                } else {
                    self.back_to(o, src)?;
                }
            }
            OKind::M98 => {
                return Err(Fault::unsupported(
                    "Fanuc-style M98/M99 subprograms are not supported",
                    At::Line,
                ))
            }
        }
        Ok(())
    }

    fn find_label(&self, o: &OLine, here: &Here) -> Res<Label> {
        self.s.labels.get(&o.name).cloned().ok_or_else(|| {
            Fault::line(format!("{}: undefined O-word label: '{}'", self.s.line, here.text))
        })
    }

    /// `control_save_offset`.
    fn save_label(&mut self, o: &OLine, here: &Here, src: &mut dyn LineSource) -> Res<()> {
        if let Some(l) = self.s.labels.get(&o.name) {
            let line = self.s.line;
            return Err(if l.at.line == line {
                Fault::line(format!(
                    "File:{} line:{line} sub: o|{}| found in illegal location",
                    here.file, o.name
                ))
            } else {
                Fault::line(format!(
                    "File:{} line:{line} redefining sub: o|{}| already defined in file:{}",
                    here.file, o.name, here.file
                ))
            });
        }
        src.pin(here.at);
        self.s.labels.insert(
            o.name.clone(),
            Label { kind: o.kind, at: here.at, repeat_count: -1, iterations: 0 },
        );
        Ok(())
    }

    /// `control_back_to`: to a known label, or skip forward to a subroutine not yet seen.
    fn back_to(&mut self, o: &OLine, src: &mut dyn LineSource) -> Res<()> {
        let limit = self.opts.limits.max_loop_iterations;
        if let Some(l) = self.s.labels.get_mut(&o.name) {
            if l.kind != OKind::Sub {
                l.iterations += 1;
                if l.iterations > limit {
                    return Err(Fault::limit(
                        format!("loop o{} ran more than {limit} times (an endless loop?)", o.name),
                        At::Line,
                    ));
                }
            }
            let at = l.at;
            src.seek(at)
                .map_err(|e| Fault::line(format!("cannot go back to line {}: {e}", at.line)))?;
            return Ok(());
        }
        self.s.skipping_o = Some(o.name.clone());
        self.s.skipping_to_sub = Some(o.name.clone());
        self.s.skipping_start = self.s.line;
        Ok(())
    }

    fn reset_iterations(&mut self, name: &str) {
        if let Some(l) = self.s.labels.get_mut(name) {
            l.iterations = 0;
        }
    }

    /// `execute_call` for an O-word subroutine.
    fn execute_call(&mut self, o: &OLine, here: &Here, src: &mut dyn LineSource) -> Res<()> {
        self.s.skipping_o = None;
        let prev = self.s.call_level - 1;
        for i in 0..SUB_PARAMS {
            self.s.frames[prev].saved_params[i] = self.params.num(i + 1);
            self.params.set_num(i + 1, o.args.get(i).copied().unwrap_or(0.0));
        }
        self.s.frames[prev].position = src.tell();
        let _ = here;
        self.back_to(o, src)
    }

    /// `execute_return`: back to the caller, or the end of a definition.
    fn execute_return(&mut self, o: &OLine, src: &mut dyn LineSource) -> Res<()> {
        if self.s.skipping_o.is_some() && o.kind == OKind::Endsub {
            self.s.skipping_o = None;
        }
        if self.s.call_level != 0 {
            let prev = self.s.call_level - 1;
            for i in 0..SUB_PARAMS {
                self.params.set_num(i + 1, self.s.frames[prev].saved_params[i]);
            }
            let back = self.s.frames[prev].position;
            src.seek(back)
                .map_err(|e| Fault::line(format!("cannot return to line {}: {e}", back.line)))?;
            self.leave_context();
            self.s.sub_name = self.s.frames[self.s.call_level].sub_name.clone();
        } else if o.kind == OKind::Endsub {
            if !self.s.defining_sub {
                return Err(Fault::line(msg::NOT_IN_SUB_DEFINITION));
            }
            self.s.skipping_o = None;
            self.s.defining_sub = false;
            self.s.sub_name = None;
        }
        Ok(())
    }

    fn leave_context(&mut self) {
        let level = self.s.call_level;
        self.params.clear_level(level);
        self.s.frames[level].sub_name = None;
        self.s.call_level -= 1;
    }

    fn repeat(&mut self, o: &OLine, here: &Here, src: &mut dyn LineSource) -> Res<()> {
        let line = self.s.line;
        match self.s.labels.get(&o.name) {
            Some(l) if l.at.line != line => {
                return Err(Fault::line(format!(
                    "{line}: duplicate O-word label: '{}' - defined in line {}",
                    here.text, l.at.line
                )))
            }
            Some(_) => {}
            None => self.save_label(o, here, src)?,
        }
        self.s.skipping_o = None;
        let test = self.s.test_value;
        if let Some(l) = self.s.labels.get_mut(&o.name) {
            if l.kind == o.kind {
                if l.repeat_count == -1 {
                    l.repeat_count =
                        test.round_ties_even().clamp(i64::MIN as f64, i64::MAX as f64) as i64;
                }
                if l.repeat_count > 0 {
                    l.repeat_count -= 1;
                } else {
                    l.repeat_count = -1;
                    l.iterations = 0;
                    self.s.skipping_o = Some(o.name.clone());
                    self.s.skipping_start = line;
                }
            }
        }
        Ok(())
    }

    fn while_(&mut self, o: &OLine, here: &Here, src: &mut dyn LineSource) -> Res<()> {
        let line = self.s.line;
        match self.s.labels.get(&o.name) {
            Some(l) if l.kind != OKind::Do && l.at.line != line => {
                return Err(Fault::line(format!(
                    "{line}: duplicate O-word label: '{}' - defined in line {}",
                    here.text, l.at.line
                )))
            }
            Some(_) => {}
            None => self.save_label(o, here, src)?,
        }
        self.s.skipping_o = None;
        let kind = self.s.labels.get(&o.name).map(|l| l.kind);
        if kind == Some(OKind::While) {
            if self.s.test_value == 0.0 {
                self.reset_iterations(&o.name);
                self.s.skipping_o = Some(o.name.clone());
                self.s.skipping_start = line;
            }
        } else if self.s.test_value != 0.0 && !self.s.doing_break {
            self.back_to(o, src)?;
        } else {
            self.reset_iterations(&o.name);
            self.s.doing_break = false;
        }
        Ok(())
    }

    fn conditional(&mut self, o: &OLine, here: &Here) -> Res<()> {
        let line = self.s.line;
        let l = self.find_label(o, here)?;
        if l.kind != OKind::If {
            let m = match o.kind {
                OKind::Endif => format!(
                    "{line}: no matching label: '{}' (found '{}' in line {}): '{}'",
                    o.name,
                    kind_name(l.kind),
                    l.at.line,
                    here.text
                ),
                _ => format!(
                    "{line}: no matching 'if' label: '{}' (found '{}' in line {})",
                    here.text,
                    kind_name(l.kind),
                    l.at.line
                ),
            };
            return Err(Fault::line(m));
        }
        let skipping_this = self.s.skipping_o.as_deref() == Some(o.name.as_str());
        match o.kind {
            OKind::Elseif => {
                if self.s.skipping_o.is_some() && !skipping_this {
                    return Ok(());
                }
                if self.s.executed_if {
                    self.s.skipping_o = Some(o.name.clone());
                    self.s.skipping_start = line;
                } else if self.s.test_value != 0.0 {
                    self.s.skipping_o = None;
                    self.s.executed_if = true;
                }
            }
            OKind::Else => {
                if self.s.executed_if {
                    self.s.skipping_o = Some(o.name.clone());
                    self.s.skipping_start = line;
                } else if skipping_this {
                    self.s.executed_if = true;
                    self.s.skipping_o = None;
                }
            }
            _ => {
                self.s.skipping_o = None;
                self.s.executed_if = true;
            }
        }
        Ok(())
    }

    /// `unwind_call`: after an error, back out of every subroutine to the main program.
    pub(crate) fn unwind(&mut self, src: &mut dyn LineSource) {
        while self.s.call_level > 0 {
            let level = self.s.call_level;
            self.params.clear_level(level);
            let prev = level - 1;
            self.s.frames[prev].sub_name = None;
            for i in 0..SUB_PARAMS {
                self.params.set_num(i + 1, self.s.frames[prev].saved_params[i]);
            }
            let back = self.s.frames[prev].position;
            let _ = src.seek(back);
            self.s.call_level -= 1;
        }
        self.s.sub_name = None;
        self.s.defining_sub = false;
        self.s.skipping_o = None;
        self.s.skipping_to_sub = None;
        self.s.labels.clear();
    }
}
