//! Where lines come from. rs274ngc runs O-word loops and subroutines by seeking back to the
//! file position of a label, so a source can tell its position and go back to one it told.
//!
//! [`SeekSource`] wraps a seekable reader (a file): nothing is held but the line being read.
//! [`StreamSource`] wraps any `BufRead` (a pipe): it keeps lines only from the first position
//! the interpreter pins (an O-word label) on, so a plain program streams in constant memory.

use std::io::{self, BufRead, Seek, SeekFrom};

/// Longest line read; longer ones are cut here and reported.
pub const MAX_LINE_BYTES: usize = 1 << 16;

/// A position in the source: the byte offset of a line start and that line's 1-based number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct SourcePos {
    pub offset: u64,
    pub line: u32,
}

/// One line as read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineInfo {
    /// 1-based line number.
    pub line: u32,
    /// Bytes of the line including its newline (what rs274's line buffer saw).
    pub len_with_newline: usize,
    /// The line was longer than [`MAX_LINE_BYTES`] and was cut.
    pub cut: bool,
}

pub trait LineSource {
    /// Reads the next line, without its newline, into `buf`; `None` at the end.
    fn next_line(&mut self, buf: &mut Vec<u8>) -> io::Result<Option<LineInfo>>;
    /// The position of the next line.
    fn tell(&self) -> SourcePos;
    /// Goes back (or forward) to a position [`LineSource::tell`] returned.
    fn seek(&mut self, pos: SourcePos) -> io::Result<()>;
    /// Says positions from `pos` on may be sought to later.
    fn pin(&mut self, _pos: SourcePos) {}
}

/// Reads one line of at most [`MAX_LINE_BYTES`] into `buf`; returns (bytes consumed, had
/// newline, cut).
fn read_capped<R: BufRead>(r: &mut R, buf: &mut Vec<u8>) -> io::Result<(usize, bool, bool)> {
    buf.clear();
    let mut consumed = 0;
    let mut cut = false;
    loop {
        let chunk = r.fill_buf()?;
        if chunk.is_empty() {
            return Ok((consumed, false, cut));
        }
        let (take, newline) = match chunk.iter().position(|&b| b == b'\n') {
            Some(i) => (i + 1, true),
            None => (chunk.len(), false),
        };
        let body = if newline { &chunk[..take - 1] } else { &chunk[..take] };
        let room = MAX_LINE_BYTES.saturating_sub(buf.len());
        if body.len() > room {
            cut = true;
        }
        buf.extend_from_slice(&body[..body.len().min(room)]);
        r.consume(take);
        consumed += take;
        if newline {
            return Ok((consumed, true, cut));
        }
    }
}

/// A seekable source (a file).
pub struct SeekSource<R> {
    inner: R,
    pos: SourcePos,
}

impl<R: BufRead + Seek> SeekSource<R> {
    pub fn new(inner: R) -> Self {
        SeekSource { inner, pos: SourcePos { offset: 0, line: 1 } }
    }
}

impl<R: BufRead + Seek> LineSource for SeekSource<R> {
    fn next_line(&mut self, buf: &mut Vec<u8>) -> io::Result<Option<LineInfo>> {
        let (n, _newline, cut) = read_capped(&mut self.inner, buf)?;
        if n == 0 {
            return Ok(None);
        }
        let info = LineInfo { line: self.pos.line, len_with_newline: n, cut };
        self.pos.offset += n as u64;
        self.pos.line += 1;
        Ok(Some(info))
    }

    fn tell(&self) -> SourcePos {
        self.pos
    }

    fn seek(&mut self, pos: SourcePos) -> io::Result<()> {
        self.inner.seek(SeekFrom::Start(pos.offset))?;
        self.pos = pos;
        Ok(())
    }
}

/// A source that cannot seek (a pipe, a line at a time): lines from the first pinned position
/// on are kept so they can be read again.
pub struct StreamSource<R> {
    inner: R,
    pos: SourcePos,
    /// Kept lines, each with its position and length with newline.
    kept: Vec<(SourcePos, usize, Vec<u8>)>,
    /// Index into `kept` of the next line to replay, when replaying.
    replay: Option<usize>,
    /// The last line read from `inner`, so the line just read can still be pinned.
    last: Option<(SourcePos, usize, Vec<u8>)>,
    keeping: bool,
}

impl<R: BufRead> StreamSource<R> {
    pub fn new(inner: R) -> Self {
        StreamSource {
            inner,
            pos: SourcePos { offset: 0, line: 1 },
            kept: Vec::new(),
            replay: None,
            last: None,
            keeping: false,
        }
    }

    /// Bytes held for replay (0 for a program without O-word labels).
    pub fn kept_bytes(&self) -> usize {
        self.kept.iter().map(|k| k.2.len()).sum()
    }
}

impl<R: BufRead> LineSource for StreamSource<R> {
    fn next_line(&mut self, buf: &mut Vec<u8>) -> io::Result<Option<LineInfo>> {
        if let Some(i) = self.replay {
            if let Some((p, n, text)) = self.kept.get(i) {
                buf.clear();
                buf.extend_from_slice(text);
                let info = LineInfo { line: p.line, len_with_newline: *n, cut: false };
                self.pos = SourcePos { offset: p.offset + *n as u64, line: p.line + 1 };
                self.replay = if i + 1 < self.kept.len() { Some(i + 1) } else { None };
                return Ok(Some(info));
            }
            self.replay = None;
        }
        let start = self.pos;
        let (n, _newline, cut) = read_capped(&mut self.inner, buf)?;
        if n == 0 {
            return Ok(None);
        }
        self.pos = SourcePos { offset: start.offset + n as u64, line: start.line + 1 };
        let entry = (start, n, buf.clone());
        if self.keeping {
            self.kept.push(entry);
        } else {
            self.last = Some(entry);
        }
        Ok(Some(LineInfo { line: start.line, len_with_newline: n, cut }))
    }

    fn tell(&self) -> SourcePos {
        self.pos
    }

    fn seek(&mut self, pos: SourcePos) -> io::Result<()> {
        if pos == self.pos {
            return Ok(());
        }
        match self.kept.iter().position(|k| k.0 == pos) {
            Some(i) => {
                self.replay = Some(i);
                self.pos = pos;
                Ok(())
            }
            None => Err(io::Error::new(
                io::ErrorKind::Unsupported,
                format!("cannot go back to line {} of a stream", pos.line),
            )),
        }
    }

    fn pin(&mut self, pos: SourcePos) {
        if self.keeping {
            return;
        }
        self.keeping = true;
        if let Some(last) = self.last.take() {
            if last.0.offset >= pos.offset {
                self.kept.push(last);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines<S: LineSource>(s: &mut S) -> Vec<(u32, String)> {
        let mut buf = Vec::new();
        let mut out = Vec::new();
        while let Some(i) = s.next_line(&mut buf).unwrap() {
            out.push((i.line, String::from_utf8(buf.clone()).unwrap()));
        }
        out
    }

    #[test]
    fn seek_source_goes_back_to_a_told_position() {
        let mut s = SeekSource::new(io::Cursor::new(b"a\nbb\r\nc".to_vec()));
        let mut buf = Vec::new();
        s.next_line(&mut buf).unwrap();
        let p = s.tell();
        assert_eq!(p, SourcePos { offset: 2, line: 2 });
        assert_eq!(lines(&mut s), [(2, "bb\r".into()), (3, "c".into())]);
        s.seek(p).unwrap();
        assert_eq!(lines(&mut s).len(), 2);
    }

    #[test]
    fn stream_source_replays_from_the_pinned_line() {
        let mut s = StreamSource::new(io::Cursor::new(b"x\ny\nz\n".to_vec()));
        let mut buf = Vec::new();
        s.next_line(&mut buf).unwrap();
        let before_y = s.tell();
        s.next_line(&mut buf).unwrap();
        s.pin(before_y);
        assert_eq!(lines(&mut s), [(3, "z".into())]);
        s.seek(before_y).unwrap();
        assert_eq!(lines(&mut s), [(2, "y".into()), (3, "z".into())]);
        assert!(s.seek(SourcePos { offset: 0, line: 1 }).is_err());
    }

    #[test]
    fn stream_source_keeps_nothing_unpinned() {
        let text = "G1 X1\n".repeat(1000);
        let mut s = StreamSource::new(io::Cursor::new(text.into_bytes()));
        assert_eq!(lines(&mut s).len(), 1000);
        assert_eq!(s.kept_bytes(), 0);
    }
}
