//! O-word lines (rs274ngc's `read_o` in interp_read.cc): subroutines (sub, endsub, call,
//! return), conditionals (if, elseif, else, endif) and loops (do, while, endwhile, repeat,
//! endrepeat, break, continue). Running them is [`crate::flow`].

use crate::block::ReadCtx;
use crate::diag::{At, Fault, Res};
use crate::expr::{read_integer_value, read_name, read_real_expression, Cursor, Env};
use crate::messages as msg;
use crate::params::SUB_PARAMS;
use crate::state::OKind;

/// A parsed O-word line.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct OLine {
    pub kind: OKind,
    /// The label: `100` or `name` for subroutines, `<sub>#<label>` for the local labels of
    /// conditionals and loops (so subroutines may reuse numbers).
    pub name: String,
    /// Call arguments for `#1`..`#30`.
    pub args: Vec<f64>,
    /// The condition (while, if, elseif) or count (repeat) read with the line.
    pub test_value: Option<f64>,
    /// endsub/return: `Some(Some(v))` with a value, `Some(None)` without.
    pub return_value: Option<Option<f64>>,
}

const KEYWORDS: &[(&str, OKind)] = &[
    ("sub", OKind::Sub),
    ("endsub", OKind::Endsub),
    ("call", OKind::Call),
    ("do", OKind::Do),
    ("while", OKind::While),
    ("repeat", OKind::Repeat),
    ("if", OKind::If),
    ("elseif", OKind::Elseif),
    ("else", OKind::Else),
    ("endif", OKind::Endif),
    ("break", OKind::Break),
    ("continue", OKind::Continue),
    ("endwhile", OKind::Endwhile),
    ("endrepeat", OKind::Endrepeat),
    ("return", OKind::Return),
];

/// `read_o`: the O-word (or M98/M99) at the cursor.
pub(crate) fn read_o(c: &mut Cursor, env: &mut Env, ctx: &ReadCtx) -> Res<OLine> {
    let at = c.pos;
    if c.peek() == b'm' {
        return Err(Fault::unsupported(
            "Fanuc-style M98/M99 subprograms are not supported: use O-word sub/call",
            At::Pos(at),
        ));
    }
    c.pos += 1; // the 'o'
    let label =
        if c.peek() == b'<' { read_name(c)? } else { read_integer_value(c, env)?.to_string() };
    let mut kind = OKind::None;
    for &(word, k) in KEYWORDS {
        if c.line.get(c.pos..).is_some_and(|r| r.starts_with(word.as_bytes())) {
            c.pos += word.len();
            kind = k;
            break;
        }
    }
    if kind == OKind::None && matches!(c.peek(), b'(' | b';' | 0) {
        kind = OKind::Bare;
    }
    let name = match kind {
        OKind::Sub | OKind::Bare | OKind::Endsub | OKind::Call | OKind::Return => label,
        _ => format!("{}#{}", ctx.sub_name, label),
    };
    let mut o = OLine { kind, name, args: Vec::new(), test_value: None, return_value: None };
    let skipping_other = ctx.skipping_o.is_some_and(|s| s != o.name);
    match kind {
        OKind::Sub | OKind::Bare if ctx.defining_sub => {
            return Err(Fault::new(msg::NESTED_SUB_DEFINITION, At::Pos(at)));
        }
        OKind::Endsub | OKind::Return => {
            if skipping_other {
                return Ok(o);
            }
            if c.peek() == b'[' {
                o.return_value = Some(Some(read_real_expression(c, env)?));
            } else {
                o.return_value = Some(None);
            }
        }
        _ if ctx.defining_sub => o.kind = OKind::None,
        OKind::Call => {
            if ctx.skipping_o.is_some() {
                o.kind = OKind::None;
                return Ok(o);
            }
            while matches!(c.peek(), b'[' | b'(') {
                if c.peek() == b'(' {
                    while c.pos < c.line.len() && c.line[c.pos] != b')' {
                        c.pos += 1;
                    }
                    c.pos += 1;
                    continue;
                }
                if o.args.len() >= SUB_PARAMS {
                    return Err(Fault::new(msg::TOO_MANY_SUB_PARAMETERS, At::Pos(c.pos)));
                }
                o.args.push(read_real_expression(c, env)?);
            }
        }
        OKind::While | OKind::Repeat | OKind::If | OKind::Elseif => {
            if skipping_other {
                return Ok(o);
            }
            if c.peek() != b'[' {
                let what = KEYWORDS.iter().find(|k| k.1 == kind).map_or("", |k| k.0);
                return Err(Fault::new(
                    format!("Left bracket missing after '{what}'"),
                    At::Pos(c.pos),
                ));
            }
            o.test_value = Some(read_real_expression(c, env)?);
        }
        OKind::None => return Err(Fault::new(msg::UNKNOWN_COMMAND_IN_O_LINE, At::Pos(at))),
        _ => {}
    }
    Ok(o)
}
