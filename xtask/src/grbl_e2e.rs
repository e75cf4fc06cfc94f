//! End to end, grbl senders on QEMU: `motionctl grbl --qemu --pty` (the link firmware in QEMU
//! behind the bridge), a third-party sender library (grbl-streamer, pinned, in the venv the
//! bridge's host test made under target/) streams a short corpus file through the
//! pseudo-terminal with a feed hold and resume, a feed override, a jog and its cancel, every
//! line acknowledged, and the machine must end at the file's programmed end point; then from the
//! same port a G38.2 probe move onto the simulated surface (`--sim-probe`) must answer its
//! `[PRB:]` at the surface before its `ok`, and `$MILL=case_a_milling.toml` runs Case A as a force job (QEMU's simulated plant
//! cuts), answered with its summary and `ok`, the final X the move's; `$TURN=` a Z-slide job on
//! the simulated spindle and `$WIRE=` two segments of the circle -> complex wire job, each
//! answered with its end equal to the host model's and its checks ok. Checked here from the
//! sender's own log and the bridge's `[MSG:]` lines.

use crate::e2e::build_motionctl;
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use motion_gcode::frame::Frame;
use motion_gcode::{Event, Interpreter, Options};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const MACHINE: &str = "motionctl/examples/corpus-machine.toml";
/// A short file (about 10 s of wall time on QEMU): G10 L2/L20 origins, a rotated coordinate
/// system, G53 moves.
const FILE: &str = "host/gcode/tests/corpus/linuxcnc-g10-l2-l20.ngc";
/// The force job, relative to the bridge's `--jobs` directory.
const MILL_JOB: &str = "case_a_milling.toml";
const JOBS: &str = "motionctl/examples";
const SENDER_PIN: &str = "2.0.2";
/// Longest wait for a capability job's answer (its board time under QEMU).
const JOB_TIMEOUT: Duration = Duration::from_secs(120);
/// The turning and wire jobs (the wire job file relative to `--jobs`).
const TURN_LINE: &str = "$TURN=builtin 360 0:6.35 25.4";
const WIRE_LINE: &str = "$WIRE=wire_job.toml 1..3";
/// The simulated probe surface, and the probe move onto it from machine Z 0.
const PROBE_SURFACE: &str = "z=-3";
const PROBE_LINE: &str = "G91 G38.2 Z-10 F300";
const PROBE_Z_MM: f64 = -3.0;
/// The board latches the trip once its debounced input changes: a few steps past the surface.
const PROBE_TOLERANCE_MM: f64 = 0.05;

/// The bridge, killed (with its QEMU) when dropped.
struct Bridge(Child);

impl Drop for Bridge {
    /// SIGTERM first: motionctl stops in order and its QEMU goes with it (a SIGKILL would leave
    /// the emulator running on its own); SIGKILL only if it has not exited within the grace.
    fn drop(&mut self) {
        let _ = Command::new("kill").arg("-TERM").arg(self.0.id().to_string()).status();
        let start = Instant::now();
        while start.elapsed() < STOP_GRACE {
            if matches!(self.0.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// How long the bridge gets to stop in order.
const STOP_GRACE: Duration = Duration::from_secs(3);

/// The program's end point, machine mm (X, Y, Z), on `steps_per_mm`'s grid.
fn programmed_end(path: &Path, steps_per_mm: &[f64]) -> Result<[f64; 3]> {
    let mut frame = Frame::default();
    let mut end = [0.0; 3];
    for e in Interpreter::open(path, Options::default())? {
        if let Event::Call(c) = e {
            if let Some(m) = frame.apply(&c.canon) {
                let p = m.end();
                end = [p[0], p[1], p[2]];
            }
        }
    }
    for (v, s) in end.iter_mut().zip(steps_per_mm) {
        *v = (*v * s).round() / s;
    }
    Ok(end)
}

/// The venv's python with the pinned sender (the bridge's host test installs it there; made
/// here when this step runs alone).
fn sender_python(root: &Path) -> Result<PathBuf> {
    let venv = root.join("target/grbl-venv");
    let python = venv.join("bin/python");
    let check = format!(
        "import grbl_streamer, serial, importlib.metadata as m; \
         assert m.version('grbl-streamer') == '{SENDER_PIN}'"
    );
    let installed = || {
        Command::new(&python)
            .args(["-c", &check])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if installed() {
        return Ok(python);
    }
    crate::run_status("python3 -m venv", Command::new("python3").args(["-m", "venv"]).arg(&venv))?;
    let pin = format!("grbl-streamer=={SENDER_PIN}");
    crate::run_status(
        "pip install grbl-streamer",
        Command::new(venv.join("bin/pip")).args([
            "install",
            "--disable-pip-version-check",
            "-q",
            &pin,
            "pyserial",
        ]),
    )?;
    if !installed() {
        bail!("grbl-streamer {SENDER_PIN} did not import after pip install in {}", venv.display());
    }
    Ok(python)
}

/// The `cargo xtask test` step (also `cargo xtask grbl-e2e`).
pub fn test(root: &Path) -> Result<()> {
    let python = sender_python(root)?;
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    let dir = root.join("target/grbl-e2e");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    // A copy: the bridge keeps changed settings beside its machine file.
    let machine = dir.join("machine.toml");
    std::fs::copy(root.join(MACHINE), &machine)?;
    let port = dir.join("ttyGRBL");
    let t0 = Instant::now();
    let mut child = Command::new(&bin)
        .current_dir(root)
        .arg("grbl")
        .arg(&machine)
        .args(["--qemu", "--firmware"])
        .arg(&elf)
        .arg("--pty")
        .arg(&port)
        .args(["--jobs", JOBS])
        .args(["--sim-probe", PROBE_SURFACE])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .context("starting motionctl grbl")?;
    while !port.exists() {
        if let Some(st) = child.try_wait()? {
            bail!("motionctl grbl --qemu exited ({st}) before opening {}", port.display());
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            bail!("no pseudo-terminal at {} after 60 s", port.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let _bridge = Bridge(child);

    let m = motionctl::job::parse_machine_toml(&std::fs::read_to_string(root.join(MACHINE))?)?;
    let spm: Vec<f64> = m.axes.iter().map(|a| a.steps_per_mm).collect();
    let end = programmed_end(&root.join(FILE), &spm)?;
    let out = Command::new(&python)
        .arg(root.join("motionctl/tests/grbl_sender.py"))
        .arg(&port)
        .arg(root.join(FILE))
        .args(end.iter().map(|v| v.to_string()))
        .output()
        .context("running grbl_sender.py")?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let file_line = stdout.lines().find(|l| l.starts_with("FILE ")).unwrap_or("");
    let result = stdout.lines().find(|l| l.starts_with("RESULT ")).unwrap_or("");
    if !out.status.success() || !result.starts_with("RESULT ok=1 ") {
        bail!("the sender on QEMU failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    }
    println!("  grbl on QEMU: {file_line}; {:.1} s wall", t0.elapsed().as_secs_f64());

    let t1 = Instant::now();
    let mut tty = Port::open(&port)?;
    // From machine Z 0 down onto the surface, then back to the file's end for the jobs after.
    tty.capability("G90 G53 G0 Z0")?;
    let lines = tty.capability(PROBE_LINE)?;
    let Some(prb) = msg_in(&lines, "[PRB:").filter(|l| tripped_at_z(l, PROBE_Z_MM)) else {
        bail!("{PROBE_LINE} on QEMU: expected [PRB:x,y,{PROBE_Z_MM}:1] before ok, got {lines:#?}");
    };
    tty.capability(&format!("G90 G53 G0 X{} Y{} Z{}", end[0], end[1], end[2]))?;
    // Its `ok` is the line's acceptance: a `$` command waits for the move's end (else error:8).
    tty.wait_idle()?;
    println!("  grbl on QEMU: {PROBE_LINE}: {prb}; {:.1} s wall", t1.elapsed().as_secs_f64());
    let t1 = Instant::now();
    let lines = tty.capability(&format!("$MILL={MILL_JOB}"))?;
    let msg = |prefix: &str| msg_in(&lines, prefix);
    let job =
        motionctl::milling::job::parse(&std::fs::read_to_string(root.join(JOBS).join(MILL_JOB))?)?;
    let move_mm = job.setup.segment().steps[0] as f64 / 1e3;
    let want = format!("[MSG:MILL {MILL_JOB}: X {move_mm:.3} mm of {move_mm:.3} mm");
    if msg(&want).is_none() || msg("[MSG:MILL checks: ok").is_none() {
        bail!("$MILL={MILL_JOB} on QEMU: expected `{want}` and the checks ok, got {lines:#?}");
    }
    println!(
        "  grbl on QEMU: $MILL={MILL_JOB}: {}; {:.1} s wall",
        msg("[MSG:MILL force:").unwrap_or_default(),
        t1.elapsed().as_secs_f64()
    );

    // A Z-slide turning job (the built-in Douglass table, X 0 -> 6.35 mm at 25.4 mm/s, 360
    // rpm) and two segments of the circle -> complex wire job, from the same port.
    for (line, prefix) in [(TURN_LINE, "TURN"), (WIRE_LINE, "WIRE")] {
        let t = Instant::now();
        let lines = tty.capability(line)?;
        let ok = format!("[MSG:{prefix} checks: ok");
        let end = format!("[MSG:{prefix} end: ");
        let (Some(_), Some(end)) = (msg_in(&lines, &ok), msg_in(&lines, &end)) else {
            bail!("{line} on QEMU: expected the end and the checks ok, got {lines:#?}");
        };
        println!("  grbl on QEMU: {line}: {end}; {:.1} s wall", t.elapsed().as_secs_f64());
    }
    Ok(())
}

/// `[PRB:x,y,z:1]` with z within [`PROBE_TOLERANCE_MM`] of `z_mm`.
fn tripped_at_z(prb: &str, z_mm: f64) -> bool {
    let Some(fields) = prb.strip_prefix("[PRB:").and_then(|l| l.strip_suffix(":1]")) else {
        return false;
    };
    let z = fields.split(',').nth(2).and_then(|z| z.parse::<f64>().ok());
    z.is_some_and(|z| (z - z_mm).abs() <= PROBE_TOLERANCE_MM)
}

/// The first of `lines` that starts with `prefix`.
fn msg_in(lines: &[String], prefix: &str) -> Option<String> {
    lines.iter().find(|l| l.starts_with(prefix)).cloned()
}

/// A sender of our own on the pseudo-terminal: its lines as they come.
struct Port {
    tty: std::fs::File,
    rx: mpsc::Receiver<String>,
}

/// How long a welcome may take after opening before the port gets a soft reset: a reopen
/// right after the last sender closed can come before the bridge saw the close, so it never
/// sees a sender connecting.
const WELCOME_WAIT: Duration = Duration::from_secs(3);

impl Port {
    /// Opens the port and waits for the bridge's welcome (after a soft reset if it is late).
    fn open(port: &Path) -> Result<Port> {
        let tty = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(port)
            .with_context(|| format!("opening {}", port.display()))?;
        let mut reader = tty.try_clone()?;
        let (tx, rx) = mpsc::channel();
        // Reads until the receiver goes; a read of nothing is no data yet (the sender library
        // left the port's VMIN at 0), not the end.
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            let mut chunk = [0u8; 1024];
            loop {
                match reader.read(&mut chunk) {
                    Ok(0) => std::thread::sleep(Duration::from_millis(10)),
                    Ok(n) => buf.extend_from_slice(&chunk[..n]),
                    Err(_) => break,
                }
                while let Some(i) = buf.iter().position(|&b| b == b'\n') {
                    let line: Vec<u8> = buf.drain(..=i).collect();
                    let text = String::from_utf8_lossy(&line).trim_end().to_string();
                    if tx.send(text).is_err() {
                        return;
                    }
                }
            }
        });
        let mut p = Port { tty, rx };
        if !p.welcome(WELCOME_WAIT) {
            p.tty.write_all(b"\x18")?;
            if !p.welcome(Duration::from_secs(20)) {
                bail!("no welcome on {}, not even after a soft reset", port.display());
            }
        }
        Ok(p)
    }

    /// Reads lines until the welcome (true) or for `wait` (false).
    fn welcome(&mut self, wait: Duration) -> bool {
        let start = Instant::now();
        while let Ok(l) = self.rx.recv_timeout(wait.saturating_sub(start.elapsed())) {
            if l.starts_with("Grbl 1.1") {
                return true;
            }
        }
        false
    }

    /// Asks for status reports (`?`) until one says Idle.
    fn wait_idle(&mut self) -> Result<()> {
        let start = Instant::now();
        loop {
            self.tty.write_all(b"?")?;
            let asked = Instant::now();
            let wait = Duration::from_millis(500);
            while let Ok(l) = self.rx.recv_timeout(wait.saturating_sub(asked.elapsed())) {
                if l.starts_with("<Idle") {
                    return Ok(());
                }
            }
            if start.elapsed() > JOB_TIMEOUT {
                bail!("the machine is not Idle after {} s", JOB_TIMEOUT.as_secs());
            }
        }
    }

    /// Sends the capability command `line`; every line up to the answer, which must be `ok`.
    fn capability(&mut self, line: &str) -> Result<Vec<String>> {
        let start = Instant::now();
        writeln!(self.tty, "{line}")?;
        let mut lines = Vec::new();
        loop {
            let left = JOB_TIMEOUT.saturating_sub(start.elapsed());
            let l = self
                .rx
                .recv_timeout(left)
                .with_context(|| format!("{line}: no answer; so far {lines:#?}"))?;
            if l == "ok" {
                return Ok(lines);
            }
            if l.starts_with("error:") || l.starts_with("ALARM:") {
                bail!("{line} answered {l} after {lines:#?}");
            }
            lines.push(l);
        }
    }
}
