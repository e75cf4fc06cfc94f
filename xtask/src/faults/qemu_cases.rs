//! The cases that need the firmware: a G-code job (the corpus's helical thread mill) streamed by
//! `motionctl run --tcp` to the link firmware in QEMU through [`Proxy`], with
//!
//! - a link drop: 2 s of silence both ways mid-job;
//! - USART overrun bursts: 16 bytes to the board lost of every 1500 for the middle of the job;
//! - a reset mid-job: `system_reset` on QEMU's monitor (the firmware boots again);
//! - a power cut mid-job: QEMU killed, then a fresh one;
//! - a corrupt config record: `Sim(CorruptConfig)` flips a byte in every slot of the board's
//!   stored config (QEMU's store is RAM that survives a reset), then a reset.
//!
//! Each reset is made on a QEMU of its own (see [`Qemu::reset`]).
//!
//! Each ends as documented: the job finishes with every segment once, in order, at the host
//! model's position (the link recovered), or motionctl stops with a non-zero exit and the way on
//! (`--resume`), the board stopped (after a reset: `Idle`, not homed, with its stored config,
//! nothing moving), and `run --resume` finishes the job from the journal's line at the
//! program's end, leaving no journal. A corrupt record boots the board into `Fault` with
//! `ConfigCorrupt` on safe defaults, and the next run replaces the record, says so, and runs.

use super::proxy::Proxy;
use super::Tally;
use crate::e2e::summary_ints;
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use motionctl::qemu::{free_port, link_command};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::gcode_corpus::MACHINE;
use crate::gcode_e2e::ON_QEMU;
/// The journal line at which a reset or power cut is made (the file's arcs are lines 12 to 15).
const CUT_AT_LINE: usize = 12;
/// The journal line at which the link drops, and how long.
const DROP_AT_LINE: usize = 8;
const DROP_FOR: Duration = Duration::from_secs(2);
/// The overrun bursts: of every `OVERRUN_PERIOD_BYTES` to the board, the first
/// `OVERRUN_BURST_BYTES` are lost, from line `OVERRUN_FROM_LINE` to `OVERRUN_TO_LINE`.
const OVERRUN_PERIOD_BYTES: u64 = 1_500;
const OVERRUN_BURST_BYTES: u64 = 16;
const OVERRUN_FROM_LINE: usize = 3;
const OVERRUN_TO_LINE: usize = 14;
/// Longest a motionctl run may take.
const RUN_TIMEOUT: Duration = Duration::from_secs(180);

/// QEMU's netduinoplus2 running the link firmware, its UART and monitor on loopback TCP ports.
struct Qemu {
    child: Child,
    serial_port: u16,
    monitor_port: u16,
    /// Set by the one [`Qemu::reset`] this process may take.
    was_reset: std::cell::Cell<bool>,
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Qemu {
    fn start(elf: &Path, log: &Path) -> Result<Qemu> {
        let (serial_port, monitor_port) = (free_port()?, free_port()?);
        let log = std::fs::File::create(log)?;
        let child = link_command(elf, serial_port, Some(monitor_port), log)?
            .spawn()
            .context("starting qemu-system-arm")?;
        Ok(Qemu { child, serial_port, monitor_port, was_reset: std::cell::Cell::new(false) })
    }

    /// The board's reset button: QEMU resets the machine, the firmware boots again. Waits for
    /// the monitor's prompt after the command (a busy QEMU reads it late; closing the monitor
    /// before then can lose it).
    ///
    /// Once per QEMU process: QEMU's STM32 timer model re-arms TIM2 at "now + ARR + the virtual
    /// time of the counter's last restart", so after a reset late in a run each tick advances
    /// the virtual clock by about as much as the whole run before it. A second reset then
    /// overflows that clock within a few hundred ticks: the guest sleeps in `wfi` for good, and
    /// QEMU spins holding its global lock (no UART, no monitor), whatever the firmware does.
    fn reset(&self) -> Result<()> {
        if self.was_reset.replace(true) {
            bail!("a second reset of one QEMU process hangs QEMU's timer model: use a fresh rig");
        }
        let mut m = TcpStream::connect(("127.0.0.1", self.monitor_port)).context("QEMU monitor")?;
        m.write_all(b"system_reset\n")?;
        m.set_read_timeout(Some(Duration::from_millis(200)))?;
        let start = Instant::now();
        let mut seen = Vec::new();
        let mut buf = [0u8; 512];
        // The banner's prompt, then the one after the command.
        while seen.windows(PROMPT.len()).filter(|w| *w == PROMPT).count() < 2 {
            if start.elapsed() > MONITOR_TIMEOUT {
                bail!(
                    "QEMU's monitor did not take system_reset: {}",
                    String::from_utf8_lossy(&seen)
                );
            }
            if let Ok(n) = m.read(&mut buf) {
                seen.extend_from_slice(&buf[..n]);
            }
        }
        Ok(())
    }
}

/// QEMU's monitor prompt, and how long it may take to answer.
const PROMPT: &[u8] = b"(qemu)";
const MONITOR_TIMEOUT: Duration = Duration::from_secs(10);

/// A QEMU board behind a proxy.
struct Rig {
    qemu: Qemu,
    proxy: Proxy,
}

fn rig(elf: &Path, log: &Path) -> Result<Rig> {
    let qemu = Qemu::start(elf, log)?;
    let proxy = Proxy::start(qemu.serial_port)?;
    Ok(Rig { qemu, proxy })
}

/// A motionctl process with its output collected.
struct Running {
    child: Child,
    out: std::thread::JoinHandle<String>,
    err: Option<std::thread::JoinHandle<String>>,
    start: Instant,
}

fn collect(r: impl Read + Send + 'static) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        let mut s = String::new();
        let mut r = r;
        let _ = r.read_to_string(&mut s);
        s
    })
}

fn spawn(root: &Path, bin: &Path, args: &[String]) -> Result<Running> {
    println!("  $ motionctl {}", args.join(" "));
    let mut child = Command::new(bin)
        .args(args)
        .current_dir(root)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .context("starting motionctl")?;
    let out = collect(child.stdout.take().context("stdout")?);
    let err = collect(child.stderr.take().context("stderr")?);
    Ok(Running { child, out, err: Some(err), start: Instant::now() })
}

struct Ended {
    ok: bool,
    stdout: String,
    stderr: String,
}

impl Running {
    fn timed_out(&mut self) -> bool {
        self.start.elapsed() > RUN_TIMEOUT
    }

    fn finish(mut self) -> Result<Ended> {
        let status = loop {
            if let Some(s) = self.child.try_wait()? {
                break s;
            }
            if self.timed_out() {
                let _ = self.child.kill();
                let _ = self.child.wait();
                bail!("motionctl did not finish within {} s", RUN_TIMEOUT.as_secs());
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        let stderr = self.stderr();
        let stdout = self.out.join().unwrap_or_default();
        if stderr.contains("panicked") {
            bail!("motionctl panicked: {stderr}");
        }
        Ok(Ended { ok: status.success(), stdout, stderr })
    }

    /// What motionctl wrote to stderr (once it has ended).
    fn stderr(&mut self) -> String {
        self.err.take().and_then(|h| h.join().ok()).unwrap_or_default()
    }

    /// Waits until the journal of `job` is at `line` or later (the job is that far).
    fn wait_line(&mut self, job: &Path, line: usize) -> Result<()> {
        loop {
            if motionctl::journal::read(job).is_ok_and(|e| e.line >= line) {
                return Ok(());
            }
            if self.child.try_wait()?.is_some() {
                bail!("the job ended before line {line}: {}", self.stderr().trim());
            }
            if self.timed_out() {
                bail!("the journal never reached line {line}");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

fn run_args(job: &Path, proxy: &Proxy, extra: &[&str]) -> Vec<String> {
    let job = job.display().to_string();
    let addr = proxy.addr();
    let base = ["run", &job, "--machine", MACHINE, "--tcp", &addr, "--home", "--yes"];
    base.iter().chain(extra).map(|s| s.to_string()).collect()
}

/// The run ended with every segment once, in order, at the host model's position.
fn check_complete(e: &Ended, what: &str) -> Result<std::collections::BTreeMap<String, i64>> {
    if !e.ok {
        bail!("{what}: motionctl failed: {}", e.stderr.trim());
    }
    let s = summary_ints(&e.stdout, "motionctl-summary ")?;
    let get = |k: &str| s.get(k).copied().unwrap_or(-1);
    if get("ok") != 1 || get("hash_ok") != 1 || get("positions_ok") != 1 {
        bail!("{what}: the board's result differs from the host model: {s:?}");
    }
    Ok(s)
}

/// A run stopped by the fault: non-zero, the way on named, the journal kept; then `--resume`
/// (on `rig`) finishes the job from the journal's line at the program's end.
fn stopped_then_resumed(root: &Path, bin: &Path, rig: &Rig, job: &Path, e: &Ended) -> Result<()> {
    if e.ok || !e.stderr.contains("--resume") {
        bail!("motionctl did not stop with the way on (--resume): {}", e.stderr.trim());
    }
    let line = motionctl::journal::read(job).context("the journal after the stop")?.line;
    println!("  stopped: {}", e.stderr.lines().last().unwrap_or("").trim());
    let resumed = spawn(root, bin, &run_args(job, &rig.proxy, &["--resume"]))?.finish()?;
    let s = check_complete(&resumed, "resume")?;
    if !resumed.stdout.contains(&format!("from line {line}:")) {
        bail!("resume: not from the journal's line {line}");
    }
    if motionctl::journal::path_for(job).exists() {
        bail!("resume: the finished job left its journal");
    }
    println!("  resumed from line {line}: {} segments to the programmed end", s["done"]);
    Ok(())
}

/// `motionctl status` through `rig`: the board's state line.
fn board_status(root: &Path, bin: &Path, rig: &Rig) -> Result<String> {
    let args = ["status".to_string(), "--tcp".to_string(), rig.proxy.addr()];
    let e = spawn(root, bin, &args)?.finish()?;
    if !e.ok {
        bail!("status: {}", e.stderr.trim());
    }
    Ok(e.stdout)
}

/// Waits until the board answers `motionctl status` (a few tries): a loaded host can run QEMU
/// several times slower than the board's clock, and `status` gives up after 5 s.
fn answering(root: &Path, bin: &Path, rig: &Rig) -> Result<()> {
    const TRIES: usize = 4;
    let mut last = None;
    for _ in 0..TRIES {
        match board_status(root, bin, rig) {
            Ok(_) => return Ok(()),
            Err(e) => last = Some(e),
        }
    }
    Err(last.map_or_else(|| anyhow::anyhow!("no status"), |e| e.context("after the reset")))
}

/// The board's status twice, 300 ms apart: in `Fault` with `code`, every axis where it was
/// (nothing moves).
fn held_with(root: &Path, bin: &Path, rig: &Rig, code: &str) -> Result<()> {
    held(root, bin, rig, &["Fault", code], &[])
}

/// The board's status twice, 300 ms apart: its text has every one of `has` and none of
/// `lacks`, and every axis is where it was (nothing moves).
fn held(root: &Path, bin: &Path, rig: &Rig, has: &[&str], lacks: &[&str]) -> Result<()> {
    let first = board_status(root, bin, rig)?;
    std::thread::sleep(Duration::from_millis(300));
    let second = board_status(root, bin, rig)?;
    println!("  board: {}", second.trim().replace('\n', "; "));
    if let Some(missing) = has.iter().find(|w| !second.contains(*w)) {
        bail!("the board's status lacks {missing:?}: {second}");
    }
    if let Some(extra) = lacks.iter().find(|w| second.contains(*w)) {
        bail!("the board's status has {extra:?}: {second}");
    }
    let position = |s: &str| -> Vec<String> {
        s.lines().filter(|l| l.starts_with("axis ")).map(str::to_string).collect()
    };
    if position(&first).is_empty() || position(&first) != position(&second) {
        bail!("the board's position is not standing still: {first} then {second}");
    }
    Ok(())
}

pub fn run(root: &Path, bin: &Path, tally: &mut Tally) -> Result<()> {
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let dir = root.join("target/faults");
    std::fs::create_dir_all(&dir)?;
    let job = |name: &str| -> Result<PathBuf> {
        let p = dir.join(format!("{name}.gcode"));
        std::fs::copy(root.join("host/gcode/tests/corpus").join(ON_QEMU), &p)?;
        let _ = std::fs::remove_file(motionctl::journal::path_for(&p));
        Ok(p)
    };
    let log = |name: &str| dir.join(format!("{name}-qemu.log"));

    // Link drop: 2 s of nothing either way. Either the link comes back and the job finishes,
    // or the board latched LinkLost (10 s of its clock without a frame; the clock runs ahead of
    // the wall clock while the guest idles) and holds; the job is then finished from the
    // journal on a board homed again (a fresh QEMU: its machine has no switches, homing takes
    // it where it stands).
    let j = job("link-drop")?;
    let mut r = rig(&elf, &log("link-drop"))?;
    let result = (|| -> Result<()> {
        let mut run = spawn(root, bin, &run_args(&j, &r.proxy, &[]))?;
        run.wait_line(&j, DROP_AT_LINE)?;
        r.proxy.silence_for(DROP_FOR);
        let e = run.finish()?;
        if e.ok {
            let s = check_complete(&e, "link drop")?;
            let reconnects = s.get("reconnects").copied().unwrap_or(0);
            println!("  the link came back: {reconnects} reconnects, job complete");
            return Ok(());
        }
        held_with(root, bin, &r, "LinkLost")?;
        r = rig(&elf, &log("link-drop-2"))?;
        stopped_then_resumed(root, bin, &r, &j, &e)
    })();
    tally.record("link drop 2 s (QEMU)", 1, 1, result);
    drop(r);

    // USART overrun bursts.
    let j = job("overrun")?;
    let r = rig(&elf, &log("overrun"))?;
    let mut bursts = 0;
    let result = (|| -> Result<()> {
        let mut run = spawn(root, bin, &run_args(&j, &r.proxy, &[]))?;
        run.wait_line(&j, OVERRUN_FROM_LINE)?;
        r.proxy.overrun(OVERRUN_PERIOD_BYTES, OVERRUN_BURST_BYTES);
        let until = run.wait_line(&j, OVERRUN_TO_LINE);
        let (b, dropped) = r.proxy.calm();
        bursts = b;
        until?;
        let e = run.finish()?;
        if !e.ok {
            let board = board_status(root, bin, &r).unwrap_or_else(|e| format!("{e:#}"));
            println!("  the board after the failed run: {}", board.trim().replace('\n', "; "));
        }
        let s = check_complete(&e, "overrun bursts")?;
        let retx = s.get("retransmissions").copied().unwrap_or(0);
        println!(
            "  {b} bursts, {dropped} bytes lost to the board; {retx} retransmissions; job complete"
        );
        if b == 0 || retx == 0 {
            bail!("overrun bursts: nothing was lost ({b} bursts, {retx} retransmissions)");
        }
        Ok(())
    })();
    tally.record("USART overrun bursts (QEMU)", 1, bursts.max(1), result);
    drop(r);

    // Reset mid-job.
    let j = job("reset")?;
    let r = rig(&elf, &log("reset"))?;
    let result = (|| -> Result<()> {
        let mut run = spawn(root, bin, &run_args(&j, &r.proxy, &[]))?;
        run.wait_line(&j, CUT_AT_LINE)?;
        r.qemu.reset()?;
        let e = run.finish()?;
        // The stored config came back with the board; the homing did not.
        held(root, bin, &r, &["state      Idle (not homed)"], &["ConfigMissing", "\nfaults "])?;
        stopped_then_resumed(root, bin, &r, &j, &e)
    })();
    tally.record("reset mid-job (QEMU)", 1, 1, result);
    drop(r);

    // The stored config corrupted, then a reset: on a board of its own (see `Qemu::reset`) that
    // stored the config by running the job once.
    let r = rig(&elf, &log("corrupt-config"))?;
    let result = (|| -> Result<()> {
        let j = job("corrupt-config")?;
        let e = spawn(root, bin, &run_args(&j, &r.proxy, &[]))?.finish()?;
        check_complete(&e, "the run that stores the config")?;
        corrupt_config(&r.proxy.addr())?;
        r.qemu.reset()?;
        answering(root, bin, &r)?;
        held_with(root, bin, &r, "ConfigCorrupt")?;
        let e = spawn(root, bin, &run_args(&j, &r.proxy, &[]))?.finish()?;
        check_complete(&e, "the run after the corrupt config")?;
        if !e.stderr.contains("cleared ConfigCorrupt") {
            bail!("the run did not say it replaced the corrupt config: {}", e.stderr.trim());
        }
        println!("  the next run replaced the corrupt record and ran the job");
        Ok(())
    })();
    tally.record("config record corruption (QEMU)", 1, 1, result);
    drop(r);

    // Power cut mid-job.
    let j = job("power-cut")?;
    let mut r = rig(&elf, &log("power-cut"))?;
    let result = (|| -> Result<()> {
        let mut run = spawn(root, bin, &run_args(&j, &r.proxy, &[]))?;
        run.wait_line(&j, CUT_AT_LINE)?;
        r.qemu.child.kill()?;
        let e = run.finish()?;
        r = rig(&elf, &log("power-cut-2"))?;
        stopped_then_resumed(root, bin, &r, &j, &e)
    })();
    tally.record("power cut mid-job (QEMU)", 1, 1, result);
    drop(r);
    Ok(())
}

/// Asks the board at `addr` to corrupt its stored config records at the next boot.
fn corrupt_config(addr: &str) -> Result<()> {
    use motion::protocol::{HostConfig, RequestBody, SimRequest};
    let mut t = motionctl::transport::Tcp::connect(addr)?;
    let mut s = motionctl::link::Session::new(&mut t, HostConfig { rto_ms: 200, window: 4 });
    s.connect().map_err(|e| anyhow::anyhow!("{e}"))?;
    match s.request(RequestBody::Sim(SimRequest::CorruptConfig)) {
        Ok(Ok(_)) => Ok(()),
        Ok(Err(r)) => bail!("Sim(CorruptConfig) refused: {r:?}"),
        Err(e) => bail!("Sim(CorruptConfig): {e}"),
    }
}
