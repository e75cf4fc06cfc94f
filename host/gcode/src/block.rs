//! One block (line) read into words, as rs274ngc's `read_items` and its `read_<letter>`
//! functions do (interp_read.cc): values are evaluated while reading (with the parameters as
//! they were before the line), parameter assignments are collected for after the line, and
//! O-word lines are parsed by [`crate::oword::read_o`].

use crate::diag::{At, Fault, Res};
use crate::expr::{
    read_integer_unsigned, read_integer_value, read_parameter_setting, read_real_value, Cursor,
    Env, Setting,
};
use crate::messages as msg;
use crate::modal::{g, g_group, group, m_group, mgroup};
use crate::oword::OLine;

/// The words of one line.
#[derive(Clone, Debug)]
pub(crate) struct Block {
    pub x: Option<f64>,
    pub y: Option<f64>,
    pub z: Option<f64>,
    pub a: Option<f64>,
    pub b: Option<f64>,
    pub c: Option<f64>,
    pub d: Option<f64>,
    pub e: Option<f64>,
    pub f: Option<f64>,
    pub h_flag: bool,
    pub h_number: i32,
    pub i: Option<f64>,
    pub j: Option<f64>,
    pub k: Option<f64>,
    pub l_flag: bool,
    pub l_number: i32,
    pub p_flag: bool,
    /// -1 when absent (rs274 tests `p_number == -1.0` in places).
    pub p_number: f64,
    pub q_flag: bool,
    pub q_number: f64,
    pub r: Option<f64>,
    pub s: Option<f64>,
    pub t: Option<i32>,
    pub dollar: Option<f64>,
    /// Polar radius `@` and angle `^`.
    pub radius: Option<f64>,
    pub theta: Option<f64>,
    /// G-code per modal group (ten times its number), -1 when none.
    pub g_modes: [i32; group::COUNT],
    /// M-code per group, -1 when none.
    pub m_modes: [i32; mgroup::COUNT],
    pub m_count: u32,
    pub user_m: bool,
    /// The last parenthesised comment of the line, as written.
    pub comment: Option<String>,
    pub motion_to_be: i32,
    pub o: Option<OLine>,
    pub settings: Vec<Setting>,
    /// Where each word stands in the prepared line: (key, start, end). Keys are lowercase
    /// letters, or `G0 + group` / `M0 + group` for G- and M-codes.
    pub spans: Vec<(u16, usize, usize)>,
}

pub(crate) const SPAN_G: u16 = 256;
pub(crate) const SPAN_M: u16 = 512;

impl Default for Block {
    fn default() -> Self {
        Block {
            x: None,
            y: None,
            z: None,
            a: None,
            b: None,
            c: None,
            d: None,
            e: None,
            f: None,
            h_flag: false,
            h_number: -1,
            i: None,
            j: None,
            k: None,
            l_flag: false,
            l_number: -1,
            p_flag: false,
            p_number: -1.0,
            q_flag: false,
            q_number: -1.0,
            r: None,
            s: None,
            t: None,
            dollar: None,
            radius: None,
            theta: None,
            g_modes: [-1; group::COUNT],
            m_modes: [-1; mgroup::COUNT],
            m_count: 0,
            user_m: false,
            comment: None,
            motion_to_be: -1,
            o: None,
            settings: Vec::new(),
            spans: Vec::new(),
        }
    }
}

impl Block {
    pub fn axis_flag(&self) -> bool {
        self.x.is_some()
            || self.y.is_some()
            || self.z.is_some()
            || self.a.is_some()
            || self.b.is_some()
            || self.c.is_some()
    }

    pub fn polar_flag(&self) -> bool {
        self.radius.is_some() || self.theta.is_some()
    }

    /// The span of the word keyed `key` (see [`Block::spans`]).
    pub fn span(&self, key: u16) -> Option<(usize, usize)> {
        self.spans.iter().find(|s| s.0 == key).map(|s| (s.1, s.2))
    }

    /// Where an error pointing at `at` lies in the prepared line.
    pub fn locate(&self, at: At) -> Option<(usize, usize)> {
        match at {
            At::Line => None,
            At::Span(s, e) => Some((s, e)),
            At::Pos(p) => Some(
                self.spans.iter().find(|s| s.1 <= p && p < s.2).map_or((p, p + 1), |s| (s.1, s.2)),
            ),
            At::Letter(l) => self.span(l as u16),
            At::GGroup(grp) => self.span(SPAN_G + grp as u16),
            At::MGroup(grp) => self.span(SPAN_M + grp as u16),
        }
    }
}

/// What the block reader needs from the interpreter besides the parameters.
pub(crate) struct ReadCtx<'a> {
    pub call_level: usize,
    pub defining_sub: bool,
    /// The O-word name being skipped to, if any.
    pub skipping_o: Option<&'a str>,
    /// Prefix of local O-word labels: the subroutine being run or defined.
    pub sub_name: &'a str,
    pub lathe_diameter: bool,
    /// Line starts with ";py,": rs274 hands it to Python (not available: an error).
    pub raw_starts_py: bool,
}

/// Reads the prepared line `text` into a block.
pub(crate) fn read_items(text: &[u8], env: &mut Env, ctx: &ReadCtx) -> Res<Block> {
    let mut block = Block::default();
    let mut c = Cursor::new(text, 0);
    if c.peek() == b'/' {
        c.pos += 1;
    }
    if c.peek() == b'n' {
        read_n_number(&mut c)?;
    }
    // 'm98' (and 'm99' inside a subroutine) are O-word lines in rs274.
    let m_number = if c.peek() == b'm' {
        let mut probe = Cursor::new(text, c.pos + 1);
        read_integer_value(&mut probe, env).ok()
    } else {
        None
    };
    let oline =
        c.peek() == b'o' || m_number == Some(98) || (m_number == Some(99) && ctx.call_level > 0);
    if oline {
        let start = c.pos;
        let o = crate::oword::read_o(&mut c, env, ctx).map_err(|mut f| {
            f.at = At::Span(start, c.pos.max(start + 1));
            f
        })?;
        block.spans.push((b'o' as u16, start, c.pos));
        block.o = Some(o);
        if ctx.skipping_o.is_some() {
            return Ok(block);
        }
        while c.pos < text.len() {
            match c.peek() {
                b';' => c.pos = text.len(),
                b'(' => read_comment(&mut c, &mut block),
                _ => return Err(Fault::new(msg::UNEXPECTED_AFTER_OWORD, At::Pos(c.pos))),
            }
        }
        return Ok(block);
    }
    if ctx.skipping_o.is_some() {
        return Ok(block);
    }
    while c.pos < text.len() {
        read_one_item(&mut c, &mut block, env, ctx)?;
    }
    Ok(block)
}

fn read_n_number(c: &mut Cursor) -> Res<()> {
    c.pos += 1;
    read_integer_unsigned(c)?;
    if c.peek() == b'.' {
        c.pos += 1;
        read_integer_unsigned(c)?;
    }
    Ok(())
}

fn read_comment(c: &mut Cursor, block: &mut Block) {
    c.pos += 1;
    let start = c.pos;
    while c.pos < c.line.len() && c.line[c.pos] != b')' {
        c.pos += 1;
    }
    block.comment = Some(String::from_utf8_lossy(&c.line[start..c.pos]).into_owned());
    c.pos += 1;
}

fn read_one_item(c: &mut Cursor, block: &mut Block, env: &mut Env, ctx: &ReadCtx) -> Res<()> {
    let start = c.pos;
    let letter = c.peek();
    let r = read_word(c, block, env, ctx, letter);
    let end = c.pos.max(start + 1);
    match letter {
        b'(' | b';' => {}
        b'g' | b'm' if r.is_ok() => {}
        _ => block.spans.push((letter as u16, start, end)),
    }
    // A reading error points at the whole word.
    r.map_err(|mut f| {
        if matches!(f.at, At::Line | At::Pos(_)) {
            f.at = At::Span(start, end);
        }
        f
    })
}

fn read_word(
    c: &mut Cursor,
    block: &mut Block,
    env: &mut Env,
    ctx: &ReadCtx,
    letter: u8,
) -> Res<()> {
    let at = c.pos;
    let multiple = |l: u8| Err(Fault::new(msg::multiple_words(l), At::Pos(at)));
    match letter {
        b'(' => {
            read_comment(c, block);
            return Ok(());
        }
        b';' => {
            if ctx.raw_starts_py {
                let rest = String::from_utf8_lossy(&c.line[c.pos + 1..])
                    .trim_start_matches("py,")
                    .to_string();
                return Err(Fault::new(python_unavailable(&rest), At::Pos(at)));
            }
            c.pos = c.line.len();
            return Ok(());
        }
        b'#' => {
            let s = read_parameter_setting(c, env)?;
            block.settings.push(s);
            return Ok(());
        }
        b'g' => return read_g(c, block, env),
        b'm' => return read_m(c, block, env),
        _ => {}
    }
    // Value words: the letter, then a value.
    if letter == b'h' || letter == b'l' || letter == b'p' || letter == b'q' || letter == b't' {
        return read_special(c, block, env, letter);
    }
    let Some(slot) = value_slot(block, letter) else {
        return Err(Fault::new(msg::bad_character(letter), At::Pos(at)));
    };
    // '@' and '^' may repeat in rs274 (no check); the letters may not.
    if slot.is_some() && letter != b'@' && letter != b'^' {
        return multiple(letter);
    }
    c.pos += 1;
    let mut v = read_real_value(c, env)?;
    match letter {
        b'f' if v < 0.0 => return Err(Fault::new(msg::NEGATIVE_F_WORD, At::Pos(at))),
        b's' if v < 0.0 => return Err(Fault::new(msg::NEGATIVE_SPINDLE_SPEED, At::Pos(at))),
        b'x' if ctx.lathe_diameter => v /= 2.0,
        _ => {}
    }
    if let Some(slot) = value_slot(block, letter) {
        *slot = Some(v);
    }
    Ok(())
}

fn value_slot(block: &mut Block, letter: u8) -> Option<&mut Option<f64>> {
    Some(match letter {
        b'a' => &mut block.a,
        b'b' => &mut block.b,
        b'c' => &mut block.c,
        b'd' => &mut block.d,
        b'e' => &mut block.e,
        b'f' => &mut block.f,
        b'i' => &mut block.i,
        b'j' => &mut block.j,
        b'k' => &mut block.k,
        b'r' => &mut block.r,
        b's' => &mut block.s,
        b'x' => &mut block.x,
        b'y' => &mut block.y,
        b'z' => &mut block.z,
        b'$' => &mut block.dollar,
        b'@' => &mut block.radius,
        b'^' => &mut block.theta,
        _ => return None,
    })
}

/// H, L, P, Q, T: the words rs274 keeps with sentinel values.
fn read_special(c: &mut Cursor, block: &mut Block, env: &mut Env, letter: u8) -> Res<()> {
    let at = c.pos;
    let fail = |m: &str| Err(Fault::new(m, At::Pos(at)));
    c.pos += 1;
    match letter {
        b'h' => {
            if block.h_flag {
                return Err(Fault::new(msg::multiple_words(b'h'), At::Pos(at)));
            }
            let v = read_integer_value(c, env)?;
            if v < -1 {
                return fail(msg::NEGATIVE_H_WORD);
            }
            block.h_flag = true;
            block.h_number = v;
        }
        b'l' => {
            if block.l_number > -1 {
                return Err(Fault::new(msg::multiple_words(b'l'), At::Pos(at)));
            }
            let v = read_integer_value(c, env)?;
            if v < 0 {
                return fail(msg::NEGATIVE_L_WORD);
            }
            block.l_number = v;
            block.l_flag = true;
        }
        b'p' => {
            if block.p_number > -1.0 {
                return Err(Fault::new(msg::multiple_words(b'p'), At::Pos(at)));
            }
            block.p_number = read_real_value(c, env)?;
            block.p_flag = true;
        }
        b'q' => {
            if block.q_number > -1.0 {
                return Err(Fault::new(msg::multiple_words(b'q'), At::Pos(at)));
            }
            block.q_number = read_real_value(c, env)?;
            block.q_flag = true;
        }
        _ => {
            if block.t.is_some() {
                return Err(Fault::new(msg::multiple_words(b't'), At::Pos(at)));
            }
            let v = read_integer_value(c, env)?;
            if v < 0 {
                return fail(msg::NEGATIVE_TOOL_ID);
            }
            block.t = Some(v);
        }
    }
    Ok(())
}

fn read_g(c: &mut Cursor, block: &mut Block, env: &mut Env) -> Res<()> {
    let at = c.pos;
    c.pos += 1;
    let fail = |m: &str| Err(Fault::new(m, At::Pos(at)));
    let v = read_real_value(c, env)? * 10.0;
    let mut code = v.floor();
    if v - code > 0.999 {
        code = v.ceil();
    } else if v - code > 0.001 {
        return fail(msg::G_CODE_OUT_OF_RANGE);
    }
    if code > 999.0 {
        return fail(msg::G_CODE_OUT_OF_RANGE);
    }
    if code < 0.0 {
        return fail(msg::NEGATIVE_G_CODE);
    }
    let code = code as i32;
    let Some(grp) = g_group(code) else {
        return fail(msg::UNKNOWN_G_CODE);
    };
    let slot = &mut block.g_modes[grp];
    // G80 beside another motion code of the block is ignored.
    if code == g::G80 && *slot != -1 {
        return Ok(());
    }
    if *slot != -1 && *slot != g::G80 {
        return fail(msg::TWO_G_SAME_GROUP);
    }
    *slot = code;
    let key = crate::block::SPAN_G + grp as u16;
    block.spans.retain(|s| s.0 != key);
    block.spans.push((key, at, c.pos));
    Ok(())
}

fn read_m(c: &mut Cursor, block: &mut Block, env: &mut Env) -> Res<()> {
    let at = c.pos;
    c.pos += 1;
    let fail = |m: String| Err(Fault::new(m, At::Pos(at)));
    let v = read_integer_value(c, env)?;
    if v < 0 {
        return fail(msg::NEGATIVE_M_CODE.into());
    }
    if v > 199 {
        return fail(msg::m_code_greater_than_199(v));
    }
    let Some(grp) = m_group(v) else {
        return fail(msg::unknown_m_code(v));
    };
    if block.m_modes[grp] != -1 {
        return fail(msg::TWO_M_SAME_GROUP.into());
    }
    block.m_modes[grp] = v;
    block.m_count += 1;
    if (100..200).contains(&v) {
        block.user_m = true;
    }
    block.spans.push((SPAN_M + grp as u16, at, c.pos));
    Ok(())
}

/// rs274's message for `(py,...)` and `;py,...` without its Python plugin.
pub(crate) fn python_unavailable(code: &str) -> String {
    format!("py_execute({code}): Python plugin not initialized")
}
