//! The streaming interpreter: reads a program line by line, as LinuxCNC's `rs274` drives its
//! interpreter (driver.cc), and yields canonical calls and diagnostics in order.
//!
//! It stops at the first error, as `rs274` does ([`Interpreter::keep_going`] continues past
//! errors instead, as `rs274 -n 0` does, for a full check).

use crate::block::Block;
use crate::canon::{Call, Canon, Units};
use crate::core::{Core, Options};
use crate::diag::{At, Diagnostic, Fault, GrblHabit, Kind, Severity};
use crate::exec::Outcome;
use crate::flow::Here;
use crate::lexer::{self, Prepared};
use crate::line::{Read, ReadError};
use crate::messages as msg;
use crate::source::{LineInfo, LineSource, SeekSource, SourcePos, StreamSource};
use crate::world::World;
use std::collections::VecDeque;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Seek};
use std::path::Path;

/// One thing the interpreter produced.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    Call(Call),
    Diagnostic(Diagnostic),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Fresh,
    Running,
    Done,
}

/// A G-code program being interpreted.
pub struct Interpreter<S> {
    core: Core,
    src: S,
    file: String,
    keep_going: bool,
    phase: Phase,
    events: VecDeque<Event>,
    buf: Vec<u8>,
    /// The first non-blank line, read while looking for a leading `%`.
    pending: Option<(LineInfo, Vec<u8>, SourcePos)>,
    last_line: (u32, String),
    errors: usize,
    ended: bool,
}

impl Interpreter<SeekSource<BufReader<File>>> {
    /// Opens a G-code file.
    pub fn open(path: &Path, opts: Options) -> io::Result<Self> {
        let f = File::open(path)?;
        Ok(Interpreter::new(SeekSource::new(BufReader::new(f)), &path.display().to_string(), opts))
    }
}

impl<R: BufRead + Seek> Interpreter<SeekSource<R>> {
    pub fn from_seekable(reader: R, file: &str, opts: Options) -> Self {
        Interpreter::new(SeekSource::new(reader), file, opts)
    }
}

impl<R: BufRead> Interpreter<StreamSource<R>> {
    /// A program from a stream that cannot seek: lines after the first O-word label are kept
    /// in memory for loops and calls; a program without labels streams in constant memory.
    pub fn from_stream(reader: R, file: &str, opts: Options) -> Self {
        Interpreter::new(StreamSource::new(reader), file, opts)
    }
}

impl<S: LineSource> Interpreter<S> {
    pub fn new(src: S, file: &str, opts: Options) -> Self {
        Interpreter {
            core: Core::new(opts),
            src,
            file: file.to_string(),
            keep_going: false,
            phase: Phase::Fresh,
            events: VecDeque::new(),
            buf: Vec::new(),
            pending: None,
            last_line: (0, String::new()),
            errors: 0,
            ended: false,
        }
    }

    /// Continue past errors to the end of the file (a full check), as `rs274 -n 0` does.
    pub fn keep_going(mut self, yes: bool) -> Self {
        self.keep_going = yes;
        self
    }

    /// The next call or diagnostic; `None` at the end.
    pub fn next_event(&mut self) -> Option<Event> {
        while self.events.is_empty() && self.phase != Phase::Done {
            self.step();
        }
        self.events.pop_front()
    }

    /// Events of the lines read so far not yet taken: [`Interpreter::next_event`] gives them
    /// without reading on. A host that runs a probe move takes the rest of the probe's line
    /// while this is true and stops there, so the next line is read (and the probe result
    /// taken in, rs274's `read_inputs`) only once it has set the board's result.
    pub fn has_queued_events(&self) -> bool {
        !self.events.is_empty()
    }

    /// Errors reported so far.
    pub fn errors(&self) -> usize {
        self.errors
    }

    /// True when the program ended with M2/M30 or its closing `%`.
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// The outside world the interpreter reads back from (probe results, tool table).
    pub fn world_mut(&mut self) -> &mut World {
        &mut self.core.world
    }

    /// The modal state now (for a sender's `$G`, a progress display).
    pub fn modal_state(&self) -> crate::state_view::ModalState {
        crate::state_view::ModalState::of(&self.core)
    }

    fn step(&mut self) {
        if self.phase == Phase::Fresh {
            self.start();
            return;
        }
        self.core.read_inputs();
        let (info, raw, at) = match self.pending.take() {
            Some(p) => p,
            None => {
                let at = self.src.tell();
                match self.src.next_line(&mut self.buf) {
                    Err(e) => {
                        self.io_error(e);
                        return;
                    }
                    Ok(None) => {
                        self.end_of_file();
                        return;
                    }
                    Ok(Some(info)) => (info, std::mem::take(&mut self.buf), at),
                }
            }
        };
        self.last_line = (info.line, String::from_utf8_lossy(lexer::trim_raw(&raw)).into_owned());
        let read = self.core.read_line(&raw, info);
        self.buf = raw;
        match read {
            Err(e) => {
                let ReadError { fault, prepared, block } = *e;
                self.fail(fault, prepared.as_ref(), block.as_ref());
            }
            Ok(Read::Blank) => self.flush(None, None),
            Ok(Read::EndFile) => {
                if let Some(name) = self.core.s.skipping_o.clone() {
                    self.fail(
                        Fault::line(format!("Failed to find sub 'O{name}' before EOF")),
                        None,
                        None,
                    );
                } else {
                    self.flush(None, None);
                }
                self.ended = true;
                self.phase = Phase::Done;
            }
            Ok(Read::Block(mut block, prepared)) => {
                let text = self.last_line.1.clone();
                let here = Here { at, text: &text, file: &self.file };
                match self.core.execute(&mut block, &here, &mut self.src) {
                    Ok(Outcome::Ok) => self.flush(Some(&prepared), Some(&block)),
                    Ok(Outcome::Exit) => {
                        self.core.unwind(&mut self.src);
                        self.after_program_end();
                        self.flush(Some(&prepared), Some(&block));
                        self.ended = true;
                        self.phase = Phase::Done;
                    }
                    Err(fault) => self.fail(fault, Some(&prepared), Some(&block)),
                }
            }
        }
    }

    /// rs274's `init` and `open`: the calls that set the machine up, and the leading `%`.
    fn start(&mut self) {
        self.phase = Phase::Running;
        let c = &mut self.core;
        let mut origin = (c.params.num(5220) + 0.0001) as i32;
        if !(1..=9).contains(&origin) {
            origin = 1;
            c.params.set_num(5220, 1.0);
        }
        c.s.origin_index = origin;
        let base = 5200 + origin as usize * 20;
        c.s.origin = c.params_pos(base);
        c.s.axis = if c.params.num(5210) != 0.0 { c.params_pos(5210) } else { [0.0; 6] };
        c.s.rotation_xy = c.params.num(base + 10);
        c.params.set_num(5599, 1.0);
        c.set_tool_parameters();
        let preamble = [
            Canon::UseLengthUnits(Units::Mm),
            Canon::SetG5xOffset { index: origin, offset: c.s.origin },
            Canon::SetG92Offset(c.s.axis),
            Canon::SetXyRotation(c.s.rotation_xy),
            Canon::SetFeedReferenceXyz,
            Canon::OnReset,
        ];
        for p in preamble {
            let _ = c.emit(p);
        }
        self.flush(None, None);
        // The first non-blank line decides whether the program is wrapped in '%' lines.
        loop {
            let at = self.src.tell();
            match self.src.next_line(&mut self.buf) {
                Err(e) => return self.io_error(e),
                Ok(None) => {
                    let m = msg::FILE_ENDED_NO_PERCENT;
                    return self.report_eof(m);
                }
                Ok(Some(info)) => {
                    if lexer::is_blank(&self.buf) {
                        self.last_line = (info.line, String::new());
                        continue;
                    }
                    if lexer::is_percent_line(&self.buf) {
                        self.core.s.percent_flag = true;
                        self.last_line =
                            (info.line, String::from_utf8_lossy(lexer::trim_raw(&self.buf)).into());
                    } else {
                        self.pending = Some((info, std::mem::take(&mut self.buf), at));
                    }
                    return;
                }
            }
        }
    }

    fn end_of_file(&mut self) {
        let s = &self.core.s;
        let m = if let Some(name) = &s.skipping_to_sub {
            format!(
                "EOF in file:{} seeking o-word: o<{}> from line: {}",
                self.file, name, s.skipping_start
            )
        } else if s.percent_flag {
            msg::FILE_ENDED_NO_PERCENT.to_string()
        } else {
            msg::FILE_ENDED_NO_PERCENT_OR_END.to_string()
        };
        self.report_eof(&m);
    }

    fn report_eof(&mut self, m: &str) {
        let habit = self.core.opts.grbl_habits
            && self.core.s.skipping_o.is_none()
            && (m == msg::FILE_ENDED_NO_PERCENT_OR_END || m == msg::FILE_ENDED_NO_PERCENT);
        let (severity, kind, message) = if habit {
            let m = format!("{m}: the program ends here (grbl needs no M2)");
            (Severity::Warning, Kind::Grbl(GrblHabit::NoProgramEnd), m)
        } else {
            (Severity::Error, Kind::Rs274, m.to_string())
        };
        if severity == Severity::Error {
            self.errors += 1;
        }
        let (line, text) = self.last_line.clone();
        self.events.push_back(Event::Diagnostic(Diagnostic {
            severity,
            kind,
            line,
            column: 0,
            span: None,
            word: None,
            message,
            text,
        }));
        self.phase = Phase::Done;
    }

    fn io_error(&mut self, e: io::Error) {
        let (line, text) = (self.last_line.0 + 1, String::new());
        self.errors += 1;
        self.events.push_back(Event::Diagnostic(Diagnostic {
            severity: Severity::Error,
            kind: Kind::Limit,
            line,
            column: 0,
            span: None,
            word: None,
            message: format!("cannot read {}: {e}", self.file),
            text,
        }));
        self.phase = Phase::Done;
    }

    /// After M2/M30 in a program that starts with `%`: is there a closing `%`?
    fn after_program_end(&mut self) {
        if !self.core.s.percent_flag {
            return;
        }
        let mut buf = Vec::new();
        loop {
            match self.src.next_line(&mut buf) {
                Ok(Some(info)) if !info.cut && !lexer::too_long(info.len_with_newline) => {
                    if lexer::is_percent_line(&buf) {
                        return;
                    }
                }
                Ok(Some(_)) => {}
                _ => break,
            }
        }
        let _ = self
            .core
            .emit(Canon::Comment("interpreter: percent sign missing from end of file".into()));
    }

    /// Moves the block's calls and warnings to the event queue.
    fn flush(&mut self, prepared: Option<&Prepared>, block: Option<&Block>) {
        while let Some(c) = self.core.out.pop_front() {
            self.events.push_back(Event::Call(c));
        }
        for w in std::mem::take(&mut self.core.warnings) {
            let d = self.diagnostic(w.fault, Severity::Warning, prepared, block);
            self.events.push_back(Event::Diagnostic(d));
        }
    }

    fn fail(&mut self, fault: Fault, prepared: Option<&Prepared>, block: Option<&Block>) {
        self.flush(prepared, block);
        let d = self.diagnostic(fault, Severity::Error, prepared, block);
        self.events.push_back(Event::Diagnostic(d));
        self.errors += 1;
        self.core.unwind(&mut self.src);
        if !self.keep_going {
            self.phase = Phase::Done;
        }
    }

    fn diagnostic(
        &self,
        f: Fault,
        severity: Severity,
        prepared: Option<&Prepared>,
        block: Option<&Block>,
    ) -> Diagnostic {
        let (line, text) = self.last_line.clone();
        let span = match (prepared, f.at) {
            (_, At::Line) | (None, _) => None,
            (Some(p), at) => {
                let range = match block {
                    Some(b) => b.locate(at),
                    None => match at {
                        At::Pos(i) => Some((i, i + 1)),
                        At::Span(s, e) => Some((s, e)),
                        _ => None,
                    },
                };
                range.map(|(s, e)| {
                    let start = p.raw_index(s);
                    let end = if e > s { p.raw_index(e - 1) + 1 } else { start + 1 };
                    (start, end.max(start + 1))
                })
            }
        };
        let raw = text.as_bytes();
        let word = span.map(|(s, e)| {
            let s = (s as usize).min(raw.len());
            let e = (e as usize).min(raw.len()).max(s);
            String::from_utf8_lossy(&raw[s..e]).trim().to_string()
        });
        let column = span.map_or(0, |(s, _)| {
            let s = (s as usize).min(raw.len());
            String::from_utf8_lossy(&raw[..s]).chars().count() as u32 + 1
        });
        Diagnostic {
            severity,
            kind: f.kind,
            line,
            column,
            span,
            word: word.filter(|w| !w.is_empty()),
            message: f.msg,
            text,
        }
    }
}

impl<S: LineSource> Iterator for Interpreter<S> {
    type Item = Event;

    fn next(&mut self) -> Option<Event> {
        self.next_event()
    }
}
