//! Building the firmware, running it in QEMU and decoding its defmt log.

use anyhow::{anyhow, bail, Context, Result};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub const TARGET: &str = "thumbv7em-none-eabihf";
/// A QEMU run that takes longer than this has hung.
pub const QEMU_TIMEOUT: Duration = Duration::from_secs(120);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Board {
    Netduinoplus2,
    F405Motion,
}

impl Board {
    pub fn parse(s: &str) -> Result<Board> {
        match s {
            "netduinoplus2" => Ok(Board::Netduinoplus2),
            "f405-motion" | "f405_motion" => Ok(Board::F405Motion),
            _ => bail!("unknown board `{s}` (expected netduinoplus2 or f405-motion)"),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Board::Netduinoplus2 => "netduinoplus2",
            Board::F405Motion => "f405-motion",
        }
    }
}

/// The firmware crate's package (firmware/).
pub const PACKAGE: &str = "motion-firmware";
/// Builds a release firmware for `board`; `extra` names the binary the way `cargo xtask build`
/// flags do: `link` or `bench` pick that binary, nothing picks `demo`, and `tamper` is the
/// demo's test-only feature. The ELF is copied to `target/fw-<board>-<extra...>/firmware` (the
/// demo's to `target/fw-<board>/firmware`) so each keeps its own file.
pub fn build(root: &Path, board: Board, extra: &[&str]) -> Result<PathBuf> {
    let bin = extra.iter().copied().find(|f| matches!(*f, "link" | "bench")).unwrap_or("demo");
    let features: Vec<&str> = extra.iter().copied().filter(|f| *f == "tamper").collect();
    let mut dir = format!("target/fw-{}", board.name());
    for f in extra {
        dir.push('-');
        dir.push_str(f);
    }
    build_into(root, bin, board, &features, &dir)
}

/// [`build`] for a binary picked by name (`scenarios`), copied to
/// `target/fw-<board>-<bin>/firmware`.
pub fn build_bin(root: &Path, bin: &str, board: Board, features: &[&str]) -> Result<PathBuf> {
    build_into(root, bin, board, features, &format!("target/fw-{}-{bin}", board.name()))
}

/// The cargo features selecting `board` (the package's default board is switched off, so
/// exactly one board is on), plus `extra`.
pub fn features(board: Board, extra: &[&str]) -> String {
    let mut features = format!("board-{}", board.name());
    for f in extra {
        features.push(',');
        features.push_str(f);
    }
    features
}

/// All feature sets share one cargo target directory (`target/thumb`): cargo keys artifacts by
/// feature set, so switching boards or features never rebuilds the dependencies, only the
/// copied-out ELF would be overwritten.
pub fn build_into(
    root: &Path,
    bin: &str,
    board: Board,
    extra: &[&str],
    dir: &str,
) -> Result<PathBuf> {
    let features = features(board, extra);
    crate::run_status(
        &format!("firmware build ({bin}: {features})"),
        crate::cargo(root)
            .args(["build", "--release", "--target", TARGET, "-p", PACKAGE, "--bin", bin])
            .args([
                "--no-default-features",
                "--features",
                &features,
                "--target-dir",
                "target/thumb",
            ]),
    )?;
    let built = root.join("target/thumb").join(TARGET).join("release").join(bin);
    let dir = root.join(dir);
    std::fs::create_dir_all(&dir)?;
    let elf = dir.join("firmware");
    std::fs::copy(&built, &elf)
        .with_context(|| format!("copying {} to {}", built.display(), elf.display()))?;
    Ok(elf)
}

/// What one QEMU run printed, decoded.
pub struct Run {
    pub lines: Vec<LogLine>,
    pub wall: Duration,
}

pub struct LogLine {
    /// `None` for `println!`.
    pub level: Option<String>,
    pub text: String,
}

impl Run {
    pub fn texts(&self) -> impl Iterator<Item = &str> {
        self.lines.iter().map(|l| l.text.as_str())
    }

    pub fn print(&self, prefix: &str) {
        for l in &self.lines {
            match &l.level {
                Some(level) => println!("{prefix}{level:<5} {}", l.text),
                None => println!("{prefix}{}", l.text),
            }
        }
    }
}

/// Runs `elf` on QEMU's netduinoplus2 with `-icount shift=0` (one instruction = 1 ns of virtual
/// time, so runs are deterministic and TIM5 counts instructions), captures the semihosting
/// output and decodes it. Fails if QEMU exits non-zero or runs past [`QEMU_TIMEOUT`].
pub fn run_qemu(elf: &Path) -> Result<Run> {
    run_qemu_for(elf, QEMU_TIMEOUT)
}

/// [`run_qemu`] with its own time limit, for runs known to be long.
pub fn run_qemu_for(elf: &Path, timeout: Duration) -> Result<Run> {
    let start = Instant::now();
    let mut child = Command::new("qemu-system-arm")
        .args(["-M", "netduinoplus2", "-display", "none", "-serial", "null", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        // sleep=off: idle time (wfi) is skipped instead of waited out in real time.
        .args(["-icount", "shift=0,sleep=off"])
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .context("could not start qemu-system-arm")?;
    let mut stdout = child.stdout.take().context("qemu stdout")?;
    let mut stderr = child.stderr.take().context("qemu stderr")?;
    let out_reader = std::thread::spawn(move || {
        let mut buf = Vec::new();
        stdout.read_to_end(&mut buf).map(|_| buf)
    });
    let err_reader = std::thread::spawn(move || {
        let mut buf = String::new();
        let _ = stderr.read_to_string(&mut buf);
        buf
    });
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break Some(status);
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let wall = start.elapsed();
    let bytes = out_reader.join().map_err(|_| anyhow!("stdout reader panicked"))??;
    let stderr = err_reader.join().unwrap_or_default();
    let decoded = decode(elf, &bytes);
    let run = Run { lines: decoded.as_ref().map(|r| r.lines.clone()).unwrap_or_default(), wall };
    let fail = |why: String| -> Result<Run> {
        run.print("  fw| ");
        if !stderr.trim().is_empty() {
            eprintln!("qemu stderr:\n{}", stderr.trim());
        }
        bail!(why)
    };
    match status {
        None => fail(format!(
            "QEMU did not finish within {} s (firmware hung?); killed it",
            timeout.as_secs()
        )),
        Some(s) if !s.success() => fail(format!("the firmware failed: QEMU exited with {s}")),
        Some(_) => {
            let d = decoded?;
            if d.malformed {
                return fail("the defmt stream had malformed frames".into());
            }
            Ok(run)
        }
    }
}

struct Decoded {
    lines: Vec<LogLine>,
    malformed: bool,
}

impl Clone for LogLine {
    fn clone(&self) -> Self {
        LogLine { level: self.level.clone(), text: self.text.clone() }
    }
}

/// The text of every defmt frame in `bytes` (a firmware's raw log), decoded with `elf`'s table.
pub fn decode_text(elf: &Path, bytes: &[u8]) -> Result<Vec<String>> {
    Ok(decode(elf, bytes)?.lines.into_iter().map(|l| l.text).collect())
}

fn decode(elf: &Path, bytes: &[u8]) -> Result<Decoded> {
    let elf_bytes = std::fs::read(elf).with_context(|| format!("reading {}", elf.display()))?;
    let table = defmt_decoder::Table::parse(&elf_bytes)?
        .ok_or_else(|| anyhow!("{} has no defmt table", elf.display()))?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(bytes);
    let mut lines = Vec::new();
    let mut malformed = false;
    loop {
        match decoder.decode() {
            Ok(frame) => lines.push(LogLine {
                level: frame.level().map(|l| l.as_str().to_uppercase()),
                text: frame.display_message().to_string(),
            }),
            Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
            Err(defmt_decoder::DecodeError::Malformed) => {
                malformed = true;
                if !table.encoding().can_recover() {
                    break;
                }
            }
        }
    }
    Ok(Decoded { lines, malformed })
}
