//! Diagnostics: every error and warning names the file line, column and word, with rs274ngc's
//! wording where rs274 has one.

use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    Error,
    Warning,
}

/// What a diagnostic is about, so tools can act on it without parsing the message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An error rs274ngc reports the same way (same line, same message).
    Rs274,
    /// A grbl habit rs274 refuses but grbl (and this front end) accepts, with a warning.
    Grbl(GrblHabit),
    /// A limit of this front end (loop iterations, block size): rs274 would hang or run out.
    Limit,
    /// Valid rs274 G-code this front end does not implement (a documented difference).
    Unsupported,
}

/// The grbl habits accepted with a warning (see `/work/shared/gcode/README.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GrblHabit {
    /// A sender line in the file (`$$`, `$I`, `?`, `~`, `!`): skipped.
    SenderLine,
    /// A zero offset word outside the arc's plane (`K0` on a G17 arc): ignored.
    OutOfPlaneOffset,
    /// The file ends without `%` or M2/M30.
    NoProgramEnd,
    /// A line longer than rs274's 253 characters: read whole.
    LongLine,
}

/// One error or warning.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    pub severity: Severity,
    pub kind: Kind,
    /// 1-based line of the source (0: not tied to a line).
    pub line: u32,
    /// 1-based column of the offending word in the line as written (0: the whole line).
    pub column: u32,
    /// Byte range of the word in the line as written.
    pub span: Option<(u32, u32)>,
    /// The word as written (`G2`, `K0`, `#<depth>`), when one word is at fault.
    pub word: Option<String>,
    pub message: String,
    /// The line as written, trailing white space removed (rs274 prints this after its message).
    pub text: String,
}

impl Diagnostic {
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// `FILE:LINE:COL: error: MESSAGE (word W)` as compilers print it.
    pub fn display_with_file<'a>(&'a self, file: &'a str) -> impl fmt::Display + 'a {
        WithFile { d: self, file }
    }
}

struct WithFile<'a> {
    d: &'a Diagnostic,
    file: &'a str,
}

impl fmt::Display for WithFile<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:", self.file)?;
        self.d.fmt(f)
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sev = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        write!(f, "{}:{}: {sev}: {}", self.line, self.column.max(1), self.message)?;
        if let Some(w) = &self.word {
            write!(f, " (word {w})")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostic {}

/// Where in a block an error points, before it is mapped to a column of the line as written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum At {
    /// The whole line.
    Line,
    /// A byte index into the prepared (downcased, blank-free) line.
    Pos(usize),
    /// A byte range of the prepared line (a word).
    Span(usize, usize),
    /// The word starting with this (lowercase) letter.
    Letter(u8),
    /// The G-code of this modal group.
    GGroup(usize),
    /// The M-code of this modal group.
    MGroup(usize),
}

/// An error while reading or executing a block: the message and where it points.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Fault {
    pub msg: String,
    pub at: At,
    pub kind: Kind,
}

impl Fault {
    pub fn new(msg: impl Into<String>, at: At) -> Self {
        Fault { msg: msg.into(), at, kind: Kind::Rs274 }
    }

    pub fn line(msg: impl Into<String>) -> Self {
        Fault::new(msg, At::Line)
    }

    pub fn unsupported(msg: impl Into<String>, at: At) -> Self {
        Fault { msg: msg.into(), at, kind: Kind::Unsupported }
    }

    pub fn limit(msg: impl Into<String>, at: At) -> Self {
        Fault { msg: msg.into(), at, kind: Kind::Limit }
    }
}

pub(crate) type Res<T> = Result<T, Fault>;

/// `Err(Fault)` for the whole line, rs274's `ERS`.
pub(crate) fn fail<T>(msg: impl Into<String>) -> Res<T> {
    Err(Fault::line(msg))
}

/// rs274's `CHKS`: fail with `msg` when `cond` holds.
pub(crate) fn check(cond: bool, msg: impl Into<String>, at: At) -> Res<()> {
    if cond {
        Err(Fault::new(msg, at))
    } else {
        Ok(())
    }
}
