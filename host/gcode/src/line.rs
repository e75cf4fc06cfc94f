//! One line, read then run (rs274ngc's `Interp::_read` and `Interp::_execute`).

use crate::block::{read_items, Block, ReadCtx};
use crate::canon::Canon;
use crate::check::{check_items, enhance_block};
use crate::core::Core;
use crate::diag::{At, Fault, GrblHabit, Res};
use crate::exec::Outcome;
use crate::expr::{Env, Setting};
use crate::flow::Here;
use crate::lexer::{self, Prepared};
use crate::messages as msg;
use crate::source::{LineInfo, LineSource};

/// What reading a line gave.
pub(crate) enum Read {
    /// Nothing to run (blank, block-deleted, a sender line).
    Blank,
    /// The closing `%`.
    EndFile,
    Block(Box<Block>, Prepared),
}

/// A read error: the fault and the prepared line it points into (if the line got that far).
pub(crate) struct ReadError {
    pub fault: Fault,
    pub prepared: Option<Prepared>,
    pub block: Option<Block>,
}

impl Core {
    /// rs274's `read_inputs`: what the machine reports after a probe, tool change or input.
    pub(crate) fn read_inputs(&mut self) {
        if self.s.probe_flag {
            self.s.cur = self.world.position();
            let p = self.world.probe_position;
            for i in 0..6 {
                self.params.set_num(5061 + i, p[i]);
            }
            for i in 5067..=5069 {
                self.params.set_num(i, 0.0);
            }
            self.params.set_num(5070, if self.world.probe_tripped() { 1.0 } else { 0.0 });
            self.s.probe_flag = false;
        }
        if self.s.toolchange_flag {
            self.s.cur = self.world.position();
            self.load_tool_table();
            self.s.toolchange_flag = false;
        }
        self.params.set_num(5600, 0.0);
        self.params.set_num(5601, 0.0);
        if self.s.input_flag {
            if self.s.input_digital {
                let v = if self.params.num(5399) != 0.0 { 1.0 } else { 0.0 };
                self.params.set_num(5399, v);
            }
            self.s.input_flag = false;
        }
    }

    /// Reads one line (`raw` without its newline).
    pub(crate) fn read_line(&mut self, raw: &[u8], info: LineInfo) -> Result<Read, Box<ReadError>> {
        let plain = |fault: Fault| Box::new(ReadError { fault, prepared: None, block: None });
        self.s.line = info.line;
        for i in 0..6 {
            self.params.set_num(5420 + i, self.s.cur[i]);
        }
        for i in 5426..=5428 {
            self.params.set_num(i, 0.0);
        }
        if lexer::too_long(info.len_with_newline) || info.cut {
            if self.opts.grbl_habits && !info.cut {
                let m = format!(
                    "line of {} characters read whole (rs274's limit is {})",
                    info.len_with_newline,
                    lexer::RS274_LINE_LIMIT - 1
                );
                self.grbl_warning(GrblHabit::LongLine, m, At::Line);
            } else {
                return Err(plain(Fault::line(msg::COMMAND_TOO_LONG)));
            }
        }
        let text = lexer::trim_raw(raw);
        if self.opts.grbl_habits && lexer::is_sender_line(text) && self.s.skipping_o.is_none() {
            let m = "sender command skipped (a sender handles it; not G-code)";
            self.grbl_warning(GrblHabit::SenderLine, m, At::Line);
            return Ok(Read::Blank);
        }
        let prepared = lexer::prepare(text).map_err(|(m, col)| {
            Box::new(ReadError {
                fault: Fault::new(m, At::Pos(0)),
                prepared: Some(Prepared { text: vec![b'('], cols: vec![col] }),
                block: None,
            })
        })?;
        if prepared.text == b"%" && self.s.percent_flag {
            self.emit(Canon::Finish).map_err(plain)?;
            return Ok(Read::EndFile);
        }
        let t = &prepared.text;
        if t.is_empty() || (t[0] == b'/' && self.opts.block_delete) {
            return Ok(Read::Blank);
        }
        let skipping = self.s.skipping_o.clone();
        let prefix = self.s.local_prefix().to_string();
        let ctx = ReadCtx {
            call_level: self.s.call_level,
            defining_sub: self.s.defining_sub,
            skipping_o: skipping.as_deref(),
            sub_name: &prefix,
            lathe_diameter: self.s.lathe_diameter,
            raw_starts_py: text.starts_with(b";py,"),
        };
        let mut env = Env {
            params: &mut self.params,
            state: &self.s,
            call_level: self.s.call_level,
            defining_sub: self.s.defining_sub,
            comp_on: self.s.comp_on(),
        };
        let mut block = match read_items(t, &mut env, &ctx) {
            Ok(b) => b,
            Err(fault) => {
                return Err(Box::new(ReadError { fault, prepared: Some(prepared), block: None }))
            }
        };
        if skipping.is_none() {
            if let Err(fault) =
                enhance_block(&mut block, &self.s).and_then(|_| check_items(&block, &self.s))
            {
                return Err(Box::new(ReadError {
                    fault,
                    prepared: Some(prepared),
                    block: Some(block),
                }));
            }
        }
        if let Some(o) = &block.o {
            if let Some(t) = o.test_value {
                self.s.test_value = t;
            }
            if let Some(r) = o.return_value {
                self.s.return_value = r.unwrap_or(0.0);
                self.s.value_returned = r.is_some();
            }
        }
        Ok(Read::Block(Box::new(block), prepared))
    }

    /// Runs a block read by [`Core::read_line`] (`_execute`).
    pub(crate) fn execute(
        &mut self,
        block: &mut Block,
        here: &Here,
        src: &mut dyn LineSource,
    ) -> Res<Outcome> {
        self.emitted = 0;
        if let Some(o) = block.o.clone() {
            self.control(&o, here, src).map_err(|mut f| {
                if f.at == At::Line {
                    f.at = At::Letter(b'o');
                }
                f
            })?;
            return Ok(Outcome::Ok);
        }
        if self.s.skipping_o.is_some() {
            return Ok(Outcome::Ok);
        }
        // All numbered assignments, then all named ones, as rs274 applies them.
        let settings = std::mem::take(&mut block.settings);
        for s in &settings {
            if let Setting::Numbered(i, v) = s {
                self.params.set_num(*i, *v);
            }
        }
        for s in &settings {
            if let Setting::Named(name, v) = s {
                self.params.store_named(name, *v, self.s.call_level)?;
            }
        }
        self.execute_block(block)
    }
}
