//! The run journal: while `run` streams a job it keeps `FILE.journal` beside the file with the
//! line the machine is executing (a G-code line; for a TOML job its move entry counted from 1), so that a job stopped by a board reset, a power loss,
//! a fault or Ctrl-C can go on from there (`run FILE --resume`). The journal names the file by a
//! CRC of its bytes, so a file edited since is not resumed by mistake. A job that completes
//! removes its journal.
//!
//! The line written is the oldest one with a segment not yet reported done, from the board's
//! last status (at most a status period old): resuming from it never skips what was not cut.

use anyhow::{anyhow, bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Format version of the journal file.
const VERSION: u32 = 1;
/// At most this often to the disk.
const WRITE_EVERY: Duration = Duration::from_millis(250);

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    pub version: u32,
    /// The job file, as given.
    pub job: String,
    /// CRC-32 of the job file's bytes when the run started.
    pub job_crc: u32,
    /// The G-code line executing (the first not finished); a TOML job's move from 1.
    pub line: usize,
    /// Segments the board reported done, of `segments`.
    pub segments_done: u32,
    pub segments: u32,
    /// The kind of job that wrote it when not a `run` job (G-code, TOML): `"milling"` for
    /// `milling run`, whose resume reads only its own kind.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<String>,
    /// For a job cut along one move (milling): how far along it the machine is, steps of its
    /// feed axis from the job's start (the board's last status: never ahead of the cut).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_axis_steps: Option<i64>,
}

/// `FILE.journal` for the job `FILE`.
pub fn path_for(job: &Path) -> PathBuf {
    let mut p = job.as_os_str().to_owned();
    p.push(".journal");
    PathBuf::from(p)
}

/// CRC-32 of a file's bytes (the link's CRC).
pub fn crc_of(path: &Path) -> Result<u32> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    Ok(motion::protocol::CRC32.checksum(&bytes))
}

/// Reads the journal of `job` and checks it is this file's.
pub fn read(job: &Path) -> Result<Entry> {
    let path = path_for(job);
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "no journal to resume from ({}: the job ran to its end or never ran)",
            path.display()
        )
    })?;
    let e: Entry = toml::from_str(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    if e.version != VERSION {
        bail!(
            "{}: journal version {} (this motionctl writes {VERSION})",
            path.display(),
            e.version
        );
    }
    let crc = crc_of(job)?;
    if crc != e.job_crc {
        bail!(
            "{} changed since the journal was written (CRC {crc:#010x}, journal {:#010x}): \
             resume it from a line with --resume-line if that is still right",
            job.display(),
            e.job_crc
        );
    }
    Ok(e)
}

/// As [`read`], for a `kind` job (`milling`): a journal another kind of run wrote is refused.
pub fn read_kind(job: &Path, kind: &str) -> Result<Entry> {
    let e = read(job)?;
    if e.kind.as_deref() != Some(kind) {
        bail!(
            "{}: the journal is a {} run's, not a {kind} run's: run the job the way it was \
             run, or remove the journal",
            path_for(job).display(),
            e.kind.as_deref().map_or("`motionctl run`", |k| k)
        );
    }
    Ok(e)
}

/// Keeps the journal of one run up to date.
pub struct Writer {
    path: PathBuf,
    entry: Entry,
    last: Option<Instant>,
    /// Shortest time between two writes.
    every: Duration,
    /// The first write failed: say so once, then stop trying.
    broken: bool,
}

impl Writer {
    pub fn new(job: &Path, segments: u32) -> Result<Writer> {
        Ok(Writer {
            path: path_for(job),
            entry: Entry {
                version: VERSION,
                job: job.display().to_string(),
                job_crc: crc_of(job)?,
                line: 0,
                segments_done: 0,
                segments,
                kind: None,
                feed_axis_steps: None,
            },
            last: None,
            every: WRITE_EVERY,
            broken: false,
        })
    }

    /// Writes at most once per `period` instead of [`WRITE_EVERY`] (zero: at every move, for a
    /// simulated board running many times faster than real time).
    pub fn every(mut self, period: Duration) -> Self {
        self.every = period;
        self
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The run is at `line` with `done` segments done; written if it moved and the last write
    /// is old enough. Returns a warning the first time the file cannot be written.
    pub fn update(&mut self, line: Option<usize>, done: u32) -> Option<String> {
        let line = line?;
        if self.broken || (line, done) == (self.entry.line, self.entry.segments_done) {
            return None;
        }
        if self.last.is_some_and(|t| t.elapsed() < self.every) && self.entry.line != 0 {
            return None;
        }
        self.entry.line = line;
        self.entry.segments_done = done;
        self.last = Some(Instant::now());
        match self.write() {
            Ok(()) => None,
            Err(e) => {
                self.broken = true;
                Some(format!("cannot keep the run journal ({e:#}): this run cannot be resumed"))
            }
        }
    }

    fn write(&self) -> Result<()> {
        let text = toml::to_string(&self.entry)?;
        let tmp = self.path.with_extension("journal.tmp");
        std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, &self.path)
            .with_context(|| format!("renaming to {}", self.path.display()))
    }

    /// The journal of a `kind` job (read back only by [`read_kind`]).
    pub fn of_kind(mut self, kind: &str) -> Self {
        self.entry.kind = Some(kind.to_string());
        self
    }

    /// As [`Self::update`], with the position along the job's one move (`feed_axis_steps`,
    /// from the job's start): written when the line, the segments done or the position moved.
    pub fn update_along(&mut self, line: usize, done: u32, feed_axis_steps: i64) -> Option<String> {
        let now = (line, done, Some(feed_axis_steps));
        if self.broken
            || now == (self.entry.line, self.entry.segments_done, self.entry.feed_axis_steps)
        {
            return None;
        }
        if self.last.is_some_and(|t| t.elapsed() < self.every) && self.entry.line != 0 {
            return None;
        }
        self.entry.line = line;
        self.entry.segments_done = done;
        self.entry.feed_axis_steps = Some(feed_axis_steps);
        self.last = Some(Instant::now());
        self.write_or_warn()
    }

    fn write_or_warn(&mut self) -> Option<String> {
        match self.write() {
            Ok(()) => None,
            Err(e) => {
                self.broken = true;
                Some(format!("cannot keep the run journal ({e:#}): this run cannot be resumed"))
            }
        }
    }

    /// The job completed: the journal goes.
    pub fn finished(&self) {
        let _ = std::fs::remove_file(&self.path);
    }

    /// The position along the job's one move the journal holds (none written yet: `None`).
    pub fn feed_axis_steps(&self) -> Option<i64> {
        self.entry.feed_axis_steps
    }

    /// The line the journal holds (0: none written yet).
    pub fn line(&self) -> usize {
        self.entry.line
    }
}
