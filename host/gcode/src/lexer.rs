//! Line preparation, as rs274ngc's `read_text` and `close_and_downcase` do it: trailing white
//! space goes, blanks and tabs outside comments go (so spaces may stand anywhere, even inside a
//! number), letters outside comments are downcased, comments are checked for nesting and
//! closing. Every prepared byte remembers its column in the line as written.

use crate::messages as msg;

/// rs274's line buffer (LINELEN 255): a line of this many bytes, its newline included, is
/// "Command too long".
pub const RS274_LINE_LIMIT: usize = 254;

/// A line ready for the block reader.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Prepared {
    /// Downcased, blank-free text; comments kept as written.
    pub text: Vec<u8>,
    /// For each byte of `text`, its byte index in the line as written.
    pub cols: Vec<u32>,
}

impl Prepared {
    /// Column (byte index in the raw line) of prepared byte `i`; the end of the line past it.
    pub fn raw_index(&self, i: usize) -> u32 {
        match self.cols.get(i) {
            Some(&c) => c,
            None => self.cols.last().map_or(0, |&c| c + 1),
        }
    }
}

/// The raw line as rs274 sees it: up to the first NUL (C strings), trailing white space removed.
pub fn trim_raw(raw: &[u8]) -> &[u8] {
    let raw = match raw.iter().position(|&b| b == 0) {
        Some(n) => &raw[..n],
        None => raw,
    };
    let end = raw.iter().rposition(|b| !is_c_space(*b)).map_or(0, |i| i + 1);
    &raw[..end]
}

/// C's `isspace` in the "C" locale.
pub fn is_c_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\x0b' | b'\x0c' | b'\r')
}

/// True when the line (with its newline, if it had one) overflows rs274's line buffer.
pub fn too_long(raw_len_with_newline: usize) -> bool {
    raw_len_with_newline >= RS274_LINE_LIMIT
}

/// `close_and_downcase`: the prepared line, or the message and raw byte index of a comment
/// error.
pub fn prepare(raw: &[u8]) -> Result<Prepared, (&'static str, u32)> {
    let mut p =
        Prepared { text: Vec::with_capacity(raw.len()), cols: Vec::with_capacity(raw.len()) };
    let mut in_comment = false;
    let mut comment_start = 0u32;
    let mut semicolon = false;
    for (i, &b) in raw.iter().enumerate() {
        let i = i as u32;
        if b == b';' && !in_comment {
            semicolon = true;
        }
        if semicolon {
            p.push(b, i);
            continue;
        }
        if in_comment {
            p.push(b, i);
            if b == b')' {
                in_comment = false;
            } else if b == b'(' {
                return Err((msg::NESTED_COMMENT, i));
            }
        } else if b == b' ' || b == b'\t' || b == b'\r' || b == b'\n' {
            // Blanks go; a newline can only be the last byte (lines are split on it).
        } else if b.is_ascii_uppercase() {
            p.push(b.to_ascii_lowercase(), i);
        } else if b == b'(' {
            in_comment = true;
            comment_start = i;
            p.push(b, i);
        } else {
            p.push(b, i);
        }
    }
    if in_comment {
        return Err((msg::UNCLOSED_COMMENT, comment_start));
    }
    Ok(p)
}

impl Prepared {
    fn push(&mut self, b: u8, col: u32) {
        self.text.push(b);
        self.cols.push(col);
    }
}

/// A grbl sender line (`$$`, `$I`, `$G`, `?`, `~`, `!`): its first non-blank character is one a
/// sender handles itself.
pub fn is_sender_line(raw: &[u8]) -> bool {
    raw.iter().find(|b| !is_c_space(**b)).is_some_and(|b| matches!(b, b'$' | b'?' | b'~' | b'!'))
}

/// True for a line that is only `%` and white space.
pub fn is_percent_line(raw: &[u8]) -> bool {
    let t: Vec<u8> = raw.iter().copied().filter(|b| !is_c_space(*b)).collect();
    t == b"%"
}

/// True for a line of white space only.
pub fn is_blank(raw: &[u8]) -> bool {
    trim_raw(raw).is_empty()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(raw: &str) -> String {
        String::from_utf8(prepare(raw.as_bytes()).unwrap().text).unwrap()
    }

    #[test]
    fn blanks_go_and_letters_downcase_outside_comments() {
        assert_eq!(text("G1 X 1 . 5 (Keep Case) Y2"), "g1x1.5(Keep Case)y2");
        assert_eq!(text("g0 ; Rest Kept (as is"), "g0; Rest Kept (as is");
        let p = prepare(b"G1 X 1").unwrap();
        assert_eq!(p.cols, [0, 1, 3, 5]);
    }

    #[test]
    fn comment_errors_point_at_the_comment() {
        assert_eq!(prepare(b"G1 (a (b) c)"), Err((msg::NESTED_COMMENT, 6)));
        assert_eq!(prepare(b"G1 (open"), Err((msg::UNCLOSED_COMMENT, 3)));
    }

    #[test]
    fn raw_trimming_follows_c_strings() {
        assert_eq!(trim_raw(b"G1 X1 \r"), b"G1 X1");
        assert_eq!(trim_raw(b"G1\0X1"), b"G1");
        assert!(is_sender_line(b"  $I ; build info"));
        assert!(is_percent_line(b" % \r"));
        assert!(!is_percent_line(b"%x"));
    }
}
