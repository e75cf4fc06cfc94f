//! Comments (rs274ngc's `convert_comment`): MSG, DEBUG, LOG and the other active comments,
//! with the parameter expansion DEBUG, LOG and ABORT do.

use crate::block::python_unavailable;
use crate::canon::Canon;
use crate::core::Core;
use crate::diag::{fail, Res};
use crate::messages as msg;

impl Core {
    pub(crate) fn convert_comment(&mut self, comment: &str) -> Res<()> {
        let body = comment.trim_start_matches(|c: char| c.is_ascii_whitespace());
        let lc = body.to_ascii_lowercase();
        let after = |p: &str| body[p.len()..].to_string();
        if lc.starts_with("msg,") {
            self.emit(Canon::Message(after("msg,")))
        } else if lc.starts_with("debug,") {
            let text = self.expand_params(&after("debug,"))?;
            if self.params.num(5599) > 0.0 {
                self.emit(Canon::Message(text))?;
            }
            Ok(())
        } else if lc.starts_with("print,") {
            // rs274 writes these to its own stdout, not as a canonical call.
            Ok(())
        } else if lc.starts_with("log,") {
            let text = self.expand_params(&after("log,"))?;
            self.emit(Canon::Log(text))
        } else if lc.starts_with("logopen,") {
            self.emit(Canon::LogOpen(after("logopen,")))
        } else if lc.starts_with("logappend,") {
            self.emit(Canon::LogAppend(after("logappend,")))
        } else if lc.starts_with("py,") {
            fail(python_unavailable(&after("py,")))
        } else if lc.starts_with("pyrun,") {
            fail(python_unavailable(&after("pyrun,")))
        } else if lc.starts_with("pyreload") {
            fail("pyreload: Python plugin not initialized")
        } else if lc.starts_with("abort,") {
            let text = self.expand_params(&after("abort,"))?;
            fail(text)
        } else if lc == "logclose" {
            self.emit(Canon::LogClose)
        } else {
            self.emit(Canon::Comment(body.to_string()))
        }
    }

    /// `convert_param_comment`: `#n`, `#<name>` and `%d`/`%f`/`%.Nf` formats in (debug,...).
    fn expand_params(&self, text: &str) -> Res<String> {
        let t = text.as_bytes();
        let mut out = String::new();
        let mut fmt_prec: Option<usize> = None; // None: %lf (6 places)
        let mut i = 0;
        while i < t.len() {
            match t[i] {
                b'%' => {
                    i += 1;
                    match t.get(i) {
                        Some(b'd') => {
                            fmt_prec = Some(0);
                            i += 1;
                        }
                        Some(b'f') => {
                            fmt_prec = Some(4);
                            i += 1;
                        }
                        Some(b'.') => {
                            i += 1;
                            match (t.get(i), t.get(i + 1)) {
                                (Some(d), Some(b'f')) if d.is_ascii_digit() => {
                                    fmt_prec = Some((d - b'0') as usize);
                                    i += 2;
                                }
                                _ => out.push('.'),
                            }
                        }
                        _ => out.push('%'),
                    }
                }
                b'#' => {
                    i += 1;
                    if i >= t.len() {
                        return fail(msg::NAMED_PARAMETER_NOT_TERMINATED);
                    }
                    let value = if t[i].is_ascii_digit() {
                        let start = i;
                        while i < t.len() && t[i].is_ascii_digit() {
                            i += 1;
                        }
                        let n: usize = text[start..i].parse().unwrap_or(usize::MAX);
                        (n < crate::params::MAX_PARAMETERS).then(|| self.params.num(n))
                    } else if t[i] == b'<' {
                        i += 1;
                        let mut name = String::new();
                        while i < t.len() && t[i] != b')' && t[i] != b'>' {
                            if !t[i].is_ascii_whitespace() {
                                name.push(t[i].to_ascii_lowercase() as char);
                            }
                            i += 1;
                        }
                        if t.get(i) != Some(&b'>') {
                            return fail(msg::NAMED_PARAMETER_NOT_TERMINATED);
                        }
                        i += 1;
                        self.params.find_named(&name, self.s.call_level, &self.s)
                    } else {
                        out.push('#');
                        continue;
                    };
                    match value {
                        Some(v) => {
                            let v = if (v - 0.0).abs() < 0.0001 { 0.0 } else { v };
                            let s = format!("{:.*}", fmt_prec.unwrap_or(6), v);
                            out.push_str(if s.len() >= 30 { "######" } else { &s });
                        }
                        None => out.push_str("######"),
                    }
                }
                _ => {
                    let ch = text[i..].chars().next().unwrap_or(' ');
                    out.push(ch);
                    i += ch.len_utf8();
                }
            }
        }
        Ok(out)
    }
}
