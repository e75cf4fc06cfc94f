//! Values and expressions, as rs274ngc reads them (`read_real_value`, `read_real_expression`,
//! `read_unary`, `read_parameter` in interp_read.cc, `execute_binary`/`execute_unary` in
//! interp_execute.cc): numbers, `#n`, `#<name>`, `[...]` with its precedence stack, the unary
//! functions (angles in degrees) and ATAN[a]/[b], EXISTS[#<name>].

use crate::diag::{At, Fault, Res};
use crate::messages as msg;
use crate::params::{is_readonly, Lookups, Params};

/// Deepest nesting of brackets and unary functions accepted in one value.
pub const MAX_NESTING: usize = 64;
/// Longest `#<name>` (rs274's line buffer bounds it the same way).
const MAX_NAME: usize = 255;

/// What reading a value may look at and change.
pub(crate) struct Env<'a> {
    pub params: &'a mut Params,
    pub state: &'a dyn Lookups,
    pub call_level: usize,
    /// Reading inside a subroutine definition: undefined named parameters read as 0.
    pub defining_sub: bool,
    /// Cutter radius compensation is on: #5420..#5428 may not be read.
    pub comp_on: bool,
}

/// A position in a prepared line, reading it as a C string (0 past the end).
pub(crate) struct Cursor<'a> {
    pub line: &'a [u8],
    pub pos: usize,
    depth: usize,
}

impl<'a> Cursor<'a> {
    pub fn new(line: &'a [u8], pos: usize) -> Self {
        Cursor { line, pos, depth: 0 }
    }

    pub fn peek(&self) -> u8 {
        self.at(0)
    }

    pub fn at(&self, ahead: usize) -> u8 {
        self.line.get(self.pos + ahead).copied().unwrap_or(0)
    }

    fn starts_with(&self, s: &[u8]) -> bool {
        self.line.get(self.pos..).is_some_and(|rest| rest.starts_with(s))
    }

    fn err<T>(&self, m: impl Into<String>) -> Res<T> {
        Err(Fault::new(m, At::Pos(self.pos)))
    }

    fn enter(&mut self) -> Res<()> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(Fault::limit(
                format!("expression nested more than {MAX_NESTING} deep"),
                At::Pos(self.pos),
            ));
        }
        Ok(())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    DividedBy,
    Modulo,
    Power,
    Times,
    And,
    Xor,
    Minus,
    Or,
    Plus,
    RightBracket,
    Lt,
    Eq,
    Ne,
    Le,
    Ge,
    Gt,
}

fn precedence(op: Op) -> u8 {
    match op {
        Op::RightBracket => 1,
        Op::And | Op::Xor | Op::Or => 2,
        Op::Lt | Op::Eq | Op::Ne | Op::Le | Op::Ge | Op::Gt => 3,
        Op::Minus | Op::Plus => 4,
        Op::DividedBy | Op::Modulo | Op::Times => 5,
        Op::Power => 6,
    }
}

/// rs274's TOLERANCE_EQUAL for EQ/NE.
const TOLERANCE_EQUAL: f64 = 0.0001;

fn binary(left: f64, op: Op, right: f64) -> Res<f64> {
    let b = |c: bool| if c { 1.0 } else { 0.0 };
    Ok(match op {
        Op::DividedBy => {
            if right == 0.0 {
                return Err(Fault::line(msg::DIVIDE_BY_ZERO));
            }
            left / right
        }
        Op::Modulo => {
            let m = left % right;
            if m < 0.0 {
                m + right.abs()
            } else {
                m
            }
        }
        Op::Power => {
            if left < 0.0 && right.floor() != right {
                return Err(Fault::line(msg::NEGATIVE_POWER));
            }
            left.powf(right)
        }
        Op::Times => left * right,
        Op::And => b(left != 0.0 && right != 0.0),
        Op::Xor => b((left == 0.0) != (right == 0.0)),
        Op::Minus => left - right,
        Op::Or => b(left != 0.0 || right != 0.0),
        Op::Plus => left + right,
        Op::Lt => b(left < right),
        Op::Eq => b((left - right).abs() < TOLERANCE_EQUAL),
        Op::Ne => b((left - right).abs() >= TOLERANCE_EQUAL),
        Op::Le => b(left <= right),
        Op::Ge => b(left >= right),
        Op::Gt => b(left > right),
        Op::RightBracket => return Err(Fault::line("Bug unknown operation")),
    })
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Unary {
    Abs,
    Acos,
    Asin,
    Atan,
    Cos,
    Exp,
    Fix,
    Fup,
    Ln,
    Round,
    Sin,
    Sqrt,
    Tan,
    Exists,
}

fn unary(op: Unary, x: f64) -> Res<f64> {
    use std::f64::consts::PI;
    Ok(match op {
        Unary::Abs => x.abs(),
        Unary::Acos => {
            if !(-1.0..=1.0).contains(&x) {
                return Err(Fault::line(msg::ACOS_RANGE));
            }
            x.acos() * 180.0 / PI
        }
        Unary::Asin => {
            if !(-1.0..=1.0).contains(&x) {
                return Err(Fault::line(msg::ASIN_RANGE));
            }
            x.asin() * 180.0 / PI
        }
        Unary::Cos => (x * PI / 180.0).cos(),
        Unary::Exp => x.exp(),
        Unary::Fix => x.floor(),
        Unary::Fup => x.ceil(),
        Unary::Ln => {
            if x <= 0.0 {
                return Err(Fault::line(msg::ZERO_OR_NEGATIVE_LN));
            }
            x.ln()
        }
        // C's (int) cast of x +/- 0.5: truncation toward zero, saturating here.
        Unary::Round => {
            (x + if x < 0.0 { -0.5 } else { 0.5 }).trunc().clamp(i32::MIN as f64, i32::MAX as f64)
        }
        Unary::Sin => (x * PI / 180.0).sin(),
        Unary::Sqrt => {
            if x < 0.0 {
                return Err(Fault::line(msg::NEGATIVE_SQRT));
            }
            x.sqrt()
        }
        Unary::Tan => (x * PI / 180.0).tan(),
        Unary::Exists | Unary::Atan => x,
    })
}

/// `read_real_value`: a number, parameter, expression, unary function, or a sign before one.
pub(crate) fn read_real_value(c: &mut Cursor, env: &mut Env) -> Res<f64> {
    c.enter()?;
    let r = real_value(c, env);
    c.depth -= 1;
    let v = r?;
    if v.is_nan() {
        return c.err(msg::NAN_RESULT);
    }
    if v.is_infinite() {
        return c.err(msg::INF_RESULT);
    }
    Ok(v)
}

fn real_value(c: &mut Cursor, env: &mut Env) -> Res<f64> {
    let (ch, next) = (c.peek(), c.at(1));
    if ch == 0 {
        return c.err(msg::NO_CHARACTERS_REAL_VALUE);
    }
    let signed = next != 0 && !next.is_ascii_digit() && next != b'.';
    if ch == b'[' {
        read_real_expression(c, env)
    } else if ch == b'#' {
        read_parameter(c, env, false)
    } else if ch == b'+' && signed {
        c.pos += 1;
        read_real_value(c, env)
    } else if ch == b'-' && signed {
        c.pos += 1;
        Ok(-read_real_value(c, env)?)
    } else if ch.is_ascii_lowercase() {
        read_unary(c, env)
    } else {
        read_real_number(c)
    }
}

/// `read_real_number`: signs, then digits and points, converted as C++'s stream would.
pub(crate) fn read_real_number(c: &mut Cursor) -> Res<f64> {
    let start = c.pos;
    let mut end = start;
    while matches!(c.line.get(end), Some(b'+' | b'-')) {
        end += 1;
    }
    while matches!(c.line.get(end), Some(b'0'..=b'9' | b'.')) {
        end += 1;
    }
    let s = &c.line[start..end];
    let text = String::from_utf8_lossy(s);
    // The longest prefix a stream reads: one optional sign, digits, one point, digits.
    let mut i = 0;
    if matches!(s.first(), Some(b'+' | b'-')) {
        i = 1;
    }
    let digits_start = i;
    while s.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
    }
    let mut n_digits = i - digits_start;
    if s.get(i) == Some(&b'.') {
        i += 1;
        let frac = i;
        while s.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        n_digits += i - frac;
    }
    let value = if n_digits == 0 {
        None
    } else {
        std::str::from_utf8(&s[..i])
            .ok()
            .and_then(|t| t.parse::<f64>().ok())
            .filter(|v| v.is_finite())
    };
    let Some(value) = value else {
        return c.err(format!("bad number format (conversion failed) parsing '{text}'"));
    };
    if i != s.len() {
        return c.err(format!("bad number format (trailing characters) parsing '{text}'"));
    }
    c.pos = end;
    Ok(value)
}

/// `read_real_expression`: `[` value (op value)* `]` evaluated with rs274's precedence stack.
pub(crate) fn read_real_expression(c: &mut Cursor, env: &mut Env) -> Res<f64> {
    if c.peek() != b'[' {
        return c.err("Bug function should not have been called");
    }
    c.pos += 1;
    let mut values = [0.0f64; 8];
    let mut ops = [Op::RightBracket; 8];
    values[0] = read_real_value(c, env)?;
    ops[0] = read_operation(c)?;
    let mut k = 1usize;
    while ops[0] != Op::RightBracket {
        values[k] = read_real_value(c, env)?;
        ops[k] = read_operation(c)?;
        if precedence(ops[k]) > precedence(ops[k - 1]) {
            k += 1;
            if k >= values.len() {
                return c.err("expression stack overflow");
            }
        } else {
            while precedence(ops[k]) <= precedence(ops[k - 1]) {
                values[k - 1] = binary(values[k - 1], ops[k - 1], values[k])?;
                ops[k - 1] = ops[k];
                if k > 1 && precedence(ops[k - 1]) <= precedence(ops[k - 2]) {
                    k -= 1;
                } else {
                    break;
                }
            }
        }
    }
    Ok(values[0])
}

fn read_operation(c: &mut Cursor) -> Res<Op> {
    let ch = c.peek();
    let at = c.pos;
    let fail = |m: &str| Err(Fault::new(m, At::Pos(at)));
    c.pos += 1;
    let two = |c: &mut Cursor, s: &[u8]| {
        if c.starts_with(s) {
            c.pos += s.len();
            true
        } else {
            false
        }
    };
    Ok(match ch {
        b'+' => Op::Plus,
        b'-' => Op::Minus,
        b'/' => Op::DividedBy,
        b'*' => {
            if two(c, b"*") {
                Op::Power
            } else {
                Op::Times
            }
        }
        b']' => Op::RightBracket,
        b'a' if two(c, b"nd") => Op::And,
        b'a' => return fail("Unknown operation name starting with a"),
        b'm' if two(c, b"od") => Op::Modulo,
        b'm' => return fail("Unknown operation name starting with m"),
        b'o' if two(c, b"r") => Op::Or,
        b'o' => return fail("Unknown operation name starting with o"),
        b'x' if two(c, b"or") => Op::Xor,
        b'x' => return fail("Unknown operation name starting with x"),
        b'e' if two(c, b"q") => Op::Eq,
        b'e' => return fail("Unknown operation name starting with e"),
        b'n' if two(c, b"e") => Op::Ne,
        b'n' => return fail("Unknown operation name starting with n"),
        b'g' if two(c, b"e") => Op::Ge,
        b'g' if two(c, b"t") => Op::Gt,
        b'g' => return fail("Unknown operation name starting with g"),
        b'l' if two(c, b"e") => Op::Le,
        b'l' if two(c, b"t") => Op::Lt,
        b'l' => return fail("Unknown operation name starting with l"),
        0 => return fail(msg::UNCLOSED_EXPRESSION),
        _ => return fail(msg::UNKNOWN_OPERATION),
    })
}

fn read_operation_unary(c: &mut Cursor) -> Res<Unary> {
    let ch = c.peek();
    let at = c.pos;
    c.pos += 1;
    let mut take = |s: &[u8]| {
        if c.starts_with(s) {
            c.pos += s.len();
            true
        } else {
            false
        }
    };
    let unknown = |l: char| Err(Fault::new(format!("Unknown word starting with {l}"), At::Pos(at)));
    Ok(match ch {
        b'a' if take(b"bs") => Unary::Abs,
        b'a' if take(b"cos") => Unary::Acos,
        b'a' if take(b"sin") => Unary::Asin,
        b'a' if take(b"tan") => Unary::Atan,
        b'a' => return unknown('a'),
        b'c' if take(b"os") => Unary::Cos,
        b'c' => return unknown('c'),
        b'e' if take(b"xp") => Unary::Exp,
        b'e' if take(b"xists") => Unary::Exists,
        b'e' => return unknown('e'),
        b'f' if take(b"ix") => Unary::Fix,
        b'f' if take(b"up") => Unary::Fup,
        b'f' => return unknown('f'),
        b'l' if take(b"n") => Unary::Ln,
        b'l' => return unknown('l'),
        b'r' if take(b"ound") => Unary::Round,
        b'r' => return unknown('r'),
        b's' if take(b"in") => Unary::Sin,
        b's' if take(b"qrt") => Unary::Sqrt,
        b's' => return unknown('s'),
        b't' if take(b"an") => Unary::Tan,
        b't' => return unknown('t'),
        _ => return Err(Fault::new(msg::UNKNOWN_WORD_UNARY, At::Pos(at))),
    })
}

fn read_unary(c: &mut Cursor, env: &mut Env) -> Res<f64> {
    let op = read_operation_unary(c)?;
    if c.peek() != b'[' {
        return c.err(msg::LEFT_BRACKET_MISSING_UNARY);
    }
    if op == Unary::Exists {
        c.pos += 1;
        if c.peek() != b'#' {
            return c.err(msg::EXPECTED_HASH);
        }
        let v = read_parameter(c, env, true)?;
        if c.peek() != b']' {
            return c.err(msg::EXPECTED_BRACKET);
        }
        c.pos += 1;
        return Ok(v);
    }
    let v = read_real_expression(c, env)?;
    if op == Unary::Atan {
        if c.peek() != b'/' {
            return c.err(msg::SLASH_MISSING_ATAN);
        }
        c.pos += 1;
        if c.peek() != b'[' {
            return c.err(msg::LEFT_BRACKET_MISSING_ATAN);
        }
        let v2 = read_real_expression(c, env)?;
        return Ok(v.atan2(v2) * 180.0 / std::f64::consts::PI);
    }
    unary(op, v)
}

/// `read_integer_value`: a value within 0.0001 of an integer.
pub(crate) fn read_integer_value(c: &mut Cursor, env: &mut Env) -> Res<i32> {
    let at = c.pos;
    let v = read_real_value(c, env)?;
    near_integer(v).ok_or_else(|| Fault::new(msg::NON_INTEGER_VALUE, At::Pos(at)))
}

/// rs274's integer rounding rule: floor, or ceil when within 0.0001 below the next integer.
pub(crate) fn near_integer(v: f64) -> Option<i32> {
    let f = v.floor();
    let r = if v - f > 0.9999 {
        v.ceil()
    } else if v - f > 0.0001 {
        return None;
    } else {
        f
    };
    // C's (int) conversion of an out-of-range double is undefined; saturate.
    Some(r.clamp(i32::MIN as f64, i32::MAX as f64) as i32)
}

/// `read_integer_unsigned`: digits only.
pub(crate) fn read_integer_unsigned(c: &mut Cursor) -> Res<i64> {
    let start = c.pos;
    let mut end = start;
    while c.line.get(end).is_some_and(u8::is_ascii_digit) {
        end += 1;
    }
    if end == start {
        return c.err(msg::BAD_FORMAT_UNSIGNED_INTEGER);
    }
    // sscanf("%d") of more digits than fit: keep it finite.
    let v = std::str::from_utf8(&c.line[start..end])
        .ok()
        .and_then(|s| s.parse::<i64>().ok())
        .unwrap_or(i64::MAX);
    c.pos = end;
    Ok(v)
}

/// `read_name`: `<` name `>`, the name as written (downcased outside comments already).
pub(crate) fn read_name(c: &mut Cursor) -> Res<String> {
    if c.peek() != b'<' {
        return c.err("Bug function should not have been called");
    }
    c.pos += 1;
    let start = c.pos;
    while c.pos < c.line.len() && c.pos - start < MAX_NAME {
        if c.line[c.pos] == b'>' {
            let name = String::from_utf8_lossy(&c.line[start..c.pos]).into_owned();
            c.pos += 1;
            return Ok(name);
        }
        c.pos += 1;
    }
    c.err(msg::NAMED_PARAMETER_NOT_TERMINATED)
}

/// `read_parameter`: `#n`, `##n`, `#[expr]` or `#<name>`; with `exists`, 1 or 0 for whether it
/// is defined.
pub(crate) fn read_parameter(c: &mut Cursor, env: &mut Env, exists: bool) -> Res<f64> {
    let at = c.pos;
    c.pos += 1; // the '#'
    if c.peek() == b'<' {
        let name = read_name(c)?;
        let found = env.params.find_named(&name, env.call_level, env.state);
        if exists {
            return Ok(if found.is_some() { 1.0 } else { 0.0 });
        }
        return match found {
            Some(v) => Ok(v),
            // Inside a subroutine definition names need not exist yet.
            None if env.defining_sub => Ok(0.0),
            None => Err(Fault::new(msg::named_parameter_not_defined(&name), At::Pos(at))),
        };
    }
    let index = read_integer_value(c, env)?;
    if exists {
        return Ok(if (1..crate::params::MAX_PARAMETERS as i32).contains(&index) {
            1.0
        } else {
            0.0
        });
    }
    let v = env.params.get(index).map_err(|f| Fault::new(f.msg, At::Pos(at)))?;
    if (5420..=5428).contains(&index) && env.comp_on {
        return Err(Fault::new(msg::CURRENT_POSITION_WITH_COMP, At::Pos(at)));
    }
    Ok(v)
}

/// A parameter assignment read from a line, applied after the whole line is read.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Setting {
    Numbered(usize, f64),
    Named(String, f64),
}

/// `read_parameter_setting`: `#n=value` or `#<name>=value` (the name is created now, as rs274
/// does, so the value may already refer to it).
pub(crate) fn read_parameter_setting(c: &mut Cursor, env: &mut Env) -> Res<Setting> {
    let at = c.pos;
    c.pos += 1; // the '#'
    if c.peek() == b'<' {
        let name = read_name(c)?;
        env.params.add_named(&name, env.call_level);
        if c.peek() != b'=' {
            return c.err(msg::EQUAL_SIGN_MISSING);
        }
        c.pos += 1;
        let v = read_real_value(c, env)?;
        return Ok(Setting::Named(name, v));
    }
    let index = read_integer_value(c, env)?;
    if !(1..crate::params::MAX_PARAMETERS as i32).contains(&index) {
        return Err(Fault::new(msg::PARAMETER_OUT_OF_RANGE, At::Pos(at)));
    }
    if is_readonly(index as usize) {
        return Err(Fault::new(msg::PARAMETER_READONLY, At::Pos(at)));
    }
    if c.peek() != b'=' {
        return c.err(msg::EQUAL_SIGN_MISSING);
    }
    c.pos += 1;
    let v = read_real_value(c, env)?;
    Ok(Setting::Numbered(index as usize, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Lookup;

    struct Zero;
    impl Lookups for Zero {
        fn lookup(&self, _: Lookup) -> f64 {
            0.0
        }
    }

    fn eval(s: &str) -> Res<f64> {
        let mut p = Params::default();
        let mut env = Env {
            params: &mut p,
            state: &Zero,
            call_level: 0,
            defining_sub: false,
            comp_on: false,
        };
        let mut c = Cursor::new(s.as_bytes(), 0);
        read_real_value(&mut c, &mut env)
    }

    #[test]
    fn precedence_follows_rs274() {
        assert_eq!(eval("[1+2*3]").unwrap(), 7.0);
        assert_eq!(eval("[2**3**2]").unwrap(), 64.0); // left to right, as rs274's stack does
        assert_eq!(eval("[1+2gt2]").unwrap(), 1.0);
        assert_eq!(eval("[1or0and0]").unwrap(), 0.0);
        assert_eq!(eval("[-7mod3]").unwrap(), 2.0);
        assert_eq!(eval("[1eq1.00005]").unwrap(), 1.0);
        assert_eq!(eval("atan[1]/[1]").unwrap(), 45.0);
        assert_eq!(eval("round[-2.5]").unwrap(), -3.0);
        assert_eq!(eval("--5").unwrap(), 5.0);
        assert_eq!(eval("sqrt[abs[-16]]").unwrap(), 4.0);
        assert_eq!(eval("exists[#<_vmajor>]").unwrap(), 1.0);
        assert_eq!(eval("exists[#<nope>]").unwrap(), 0.0);
    }

    #[test]
    fn errors_use_rs274_wording() {
        assert_eq!(eval("[1/0]").unwrap_err().msg, msg::DIVIDE_BY_ZERO);
        assert_eq!(eval("[1+2").unwrap_err().msg, msg::UNCLOSED_EXPRESSION);
        assert_eq!(
            eval("1..2").unwrap_err().msg,
            "bad number format (trailing characters) parsing '1..2'"
        );
        assert_eq!(eval(".").unwrap_err().msg, "bad number format (conversion failed) parsing '.'");
        assert_eq!(eval("#<x>").unwrap_err().msg, "Named parameter #<x> not defined");
        assert_eq!(eval("sqrt[-1]").unwrap_err().msg, msg::NEGATIVE_SQRT);
        assert_eq!(eval("foo[1]").unwrap_err().msg, "Unknown word starting with f");
        assert!(eval(&"[".repeat(100)).unwrap_err().msg.contains("nested"));
    }
}
