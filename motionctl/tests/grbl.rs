//! `motionctl grbl`: the grbl 1.1 bridge on the simulated board.
//!
//! - A third-party sender library (grbl-streamer, pinned, from PyPI in a venv under target/)
//!   drives the bridge through its pseudo-terminal: settings, homing, four corpus files of
//!   different dialects streamed with character counting (plain moves and arcs, arcs by R word,
//!   a canned cycle with polar increments, a helix in incremental inches), a feed hold and resume
//!   mid-file, a feed override, a jog and a jog cancel, soft resets. Every line of every file is
//!   acknowledged in the library's own log and the machine ends at each file's programmed end
//!   point (on the step grid).
//! - A raw session over TCP checks answers byte for byte: the welcome, status reports (also
//!   asked in the middle of a line), character counting, `$` commands, `error:N` for bad lines,
//!   long lines, binary noise, unknown words and codes, each without losing the valid line
//!   after it.
//! - `$N=V` on the machine's values reconfigures the board (steps/mm change the step count of a
//!   move, a travel change moves the board's own soft limit), survives a restart of the bridge
//!   through the overlay beside the machine file, and `$RST=$` restores the machine file's.
//! - `$N0`/`$N1` startup lines run after a soft reset and on connect (`>LINE:ok`), survive a
//!   restart, and an alarm from one is answered in its place.
//!
//! The simulated board runs at [`SIM_SPEED`] times real time, so the files take seconds.

use motion_gcode::frame::Frame;
use motion_gcode::{Event, Interpreter, Options};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SENDER_PIN: &str = "grbl-streamer==2.0.2";

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn corpus(name: &str) -> PathBuf {
    manifest().join("../host/gcode/tests/corpus").join(name)
}

/// The program's end point in machine mm (X, Y, Z), from the interpreter's calls.
fn programmed_end(path: &Path) -> [f64; 3] {
    let mut frame = Frame::default();
    let mut end = [0.0; 3];
    for e in Interpreter::open(path, Options::default()).unwrap() {
        if let Event::Call(c) = e {
            if let Some(m) = frame.apply(&c.canon) {
                let p = m.end();
                end = [p[0], p[1], p[2]];
            }
        }
    }
    end
}

/// A `motionctl grbl` process, killed when dropped.
struct Bridge {
    child: Child,
}

impl Drop for Bridge {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The simulated board's machine time per wall time: the corpus files take about 100 s of
/// machine time together.
const SIM_SPEED: &str = "4";

/// A bridge on `dir`/machine.toml (a copy of examples/corpus-machine.toml, made if absent: the
/// bridge writes its settings overlay beside it).
fn bridge(dir: &Path, endpoint: &[&str]) -> Bridge {
    let machine = dir.join("machine.toml");
    if !machine.exists() {
        std::fs::copy(manifest().join("examples/corpus-machine.toml"), &machine).unwrap();
    }
    let child = Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .current_dir(manifest())
        .arg("grbl")
        .arg(&machine)
        .args(["--sim", "--sim-speed", SIM_SPEED])
        .args(endpoint)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start motionctl grbl");
    Bridge { child }
}

/// A scratch directory, removed when dropped.
struct TmpDir(PathBuf);

impl Drop for TmpDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn tmp_dir(tag: &str) -> TmpDir {
    let d = std::env::temp_dir().join(format!("motionctl-grbl-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TmpDir(d)
}

/// The venv's python with the sender installed, or why not (pip offline).
fn sender_python() -> Result<PathBuf, String> {
    let target = Path::new(env!("CARGO_TARGET_TMPDIR")).parent().unwrap().to_path_buf();
    let venv = target.join("grbl-venv");
    let python = venv.join("bin/python");
    let installed = |py: &Path| {
        Command::new(py)
            .args([
                "-c",
                "import grbl_streamer, serial, importlib.metadata as m; \
                          assert m.version('grbl-streamer') == '2.0.2'",
            ])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if python.exists() && installed(&python) {
        return Ok(python);
    }
    let st = Command::new("python3")
        .args(["-m", "venv"])
        .arg(&venv)
        .status()
        .map_err(|e| format!("python3 -m venv: {e}"))?;
    if !st.success() {
        return Err("python3 -m venv failed".into());
    }
    let out = Command::new(venv.join("bin/pip"))
        .args(["install", "--disable-pip-version-check", "-q", SENDER_PIN, "pyserial"])
        .output()
        .map_err(|e| format!("pip: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "pip install {SENDER_PIN} pyserial failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    if !installed(&python) {
        return Err("grbl-streamer did not import after pip install".into());
    }
    Ok(python)
}

#[test]
fn a_third_party_sender_streams_a_corpus_file_through_the_pty() {
    let python = match sender_python() {
        Ok(p) => p,
        // `cargo xtask test` installs python3-venv; only a machine without PyPI may skip.
        Err(why) if std::env::var_os("GRBL_SENDER_OFFLINE").is_some() => {
            eprintln!("SKIPPED (GRBL_SENDER_OFFLINE): no grbl sender library ({why})");
            return;
        }
        Err(why) => panic!(
            "no grbl sender library to test with ({why}); set GRBL_SENDER_OFFLINE=1 to skip \
             this test on a machine without PyPI"
        ),
    };
    let dir = tmp_dir("pty");
    let port = dir.0.join("ttyGRBL");
    let mut b = bridge(&dir.0, &["--pty", port.to_str().unwrap()]);
    let start = Instant::now();
    while !port.exists() {
        assert!(start.elapsed() < Duration::from_secs(20), "no pty symlink at {}", port.display());
        if let Ok(Some(st)) = b.child.try_wait() {
            let mut err = String::new();
            let _ = b.child.stderr.take().unwrap().read_to_string(&mut err);
            panic!("motionctl grbl exited ({st}): {err}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    // Plain lines and arcs (bCNC), arcs by R word (SketchUcam), a canned cycle with polar
    // increments (LinuxCNC), a helix in incremental inches (cncjs).
    let files = [
        "bcnc-sample.gcode",
        "ugs-sketchucam-arc-rword.gcode",
        "linuxcnc-hole-circle-g81.ngc",
        "cncjs-helical-thread-milling.gcode",
    ];
    let machine = motionctl::job::parse_machine_toml(
        &std::fs::read_to_string(manifest().join("examples/corpus-machine.toml")).unwrap(),
    )
    .unwrap();
    let mut args = Vec::new();
    for f in files {
        let file = corpus(f);
        let end = programmed_end(&file);
        args.push(file.to_string_lossy().into_owned());
        // Where the board can stop: the end point on the axis's step grid.
        for (v, a) in end.iter().zip(&machine.axes) {
            args.push(format!("{}", (v * a.steps_per_mm).round() / a.steps_per_mm));
        }
    }
    let out = Command::new(&python)
        .arg(manifest().join("tests/grbl_sender.py"))
        .arg(&port)
        .args(&args)
        .output()
        .expect("run grbl_sender.py");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let result = stdout.lines().find(|l| l.starts_with("RESULT ")).unwrap_or("");
    assert!(
        out.status.success() && result.starts_with("RESULT ok=1 "),
        "sender failed ({}):\n{stdout}\n{stderr}",
        out.status
    );
    let per_file: Vec<&str> = stdout.lines().filter(|l| l.starts_with("FILE ")).collect();
    assert_eq!(per_file.len(), files.len(), "{stdout}");
    for (l, f) in per_file.iter().zip(files) {
        assert!(l.starts_with(&format!("FILE {f} ok=1 ")), "{l}");
    }
    eprintln!("{stdout}");
}

/// A raw TCP session with the bridge.
struct Raw {
    s: TcpStream,
    buf: Vec<u8>,
}

impl Raw {
    /// Connects to a `--listen` bridge and reads the welcome.
    fn connect(b: &mut Bridge) -> Raw {
        let (addr, _drain) = listen_addr(b);
        let s = TcpStream::connect(&addr).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
        let mut r = Raw { s, buf: Vec::new() };
        r.expect("");
        r.expect("Grbl 1.1h ['$' for help]");
        r
    }

    /// `$$`: the settings, in order.
    fn settings(&mut self) -> Vec<String> {
        self.send(b"$$\n");
        let mut settings = Vec::new();
        loop {
            let l = self.line();
            if l == "ok" {
                return settings;
            }
            settings.push(l);
        }
    }

    fn send(&mut self, b: &[u8]) {
        self.s.write_all(b).unwrap();
    }

    /// The next line (without `\r\n`), within 10 s.
    fn line(&mut self) -> String {
        let start = Instant::now();
        loop {
            if let Some(i) = self.buf.windows(2).position(|w| w == b"\r\n") {
                let l = String::from_utf8_lossy(&self.buf[..i]).into_owned();
                self.buf.drain(..i + 2);
                return l;
            }
            assert!(start.elapsed() < Duration::from_secs(10), "no line; have {:?}", self.buf);
            let mut b = [0u8; 1024];
            match self.s.read(&mut b) {
                Ok(0) => panic!("the bridge closed the connection"),
                Ok(n) => self.buf.extend_from_slice(&b[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => panic!("read: {e}"),
            }
        }
    }

    fn expect(&mut self, want: &str) {
        assert_eq!(self.line(), want);
    }

    fn status(&mut self) -> String {
        self.send(b"?");
        let l = self.line();
        assert!(l.starts_with('<') && l.ends_with('>'), "{l}");
        l
    }

    /// Polls `?` until a report passes `want` (within 10 s); that report.
    fn until_status(&mut self, want: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let st = self.status();
            if want(&st) {
                return st;
            }
            assert!(start.elapsed() < Duration::from_secs(10), "never: {st}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Polls `?` until the machine is idle; the last report.
    fn until_idle(&mut self) -> String {
        let start = Instant::now();
        loop {
            let st = self.status();
            if st.starts_with("<Idle|") {
                return st;
            }
            assert!(start.elapsed() < Duration::from_secs(30), "never idle: {st}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

fn listen_addr(b: &mut Bridge) -> (String, std::thread::JoinHandle<()>) {
    let mut err = BufReader::new(b.child.stderr.take().unwrap());
    let mut line = String::new();
    loop {
        line.clear();
        assert!(err.read_line(&mut line).unwrap() > 0, "motionctl grbl ended before listening");
        if let Some(rest) = line.trim().strip_prefix("motionctl: grbl 1.1 on TCP ") {
            let addr = rest.split_whitespace().next().unwrap().to_string();
            // Keep draining stderr so the bridge never blocks on it.
            let drain = std::thread::spawn(move || {
                let mut sink = String::new();
                let _ = err.read_to_string(&mut sink);
            });
            return (addr, drain);
        }
    }
}

#[test]
fn a_raw_session_gets_grbl_answers_byte_for_byte() {
    let dir = tmp_dir("raw");
    let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
    let mut r = Raw::connect(&mut b);
    assert_eq!(
        r.status(),
        "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000|Ov:100,100,100>"
    );

    // $ commands.
    r.send(b"$I\n");
    r.expect("[VER:1.1h.20190825:]");
    r.expect("[OPT:V,15,128]");
    r.expect("ok");
    let settings = r.settings();
    assert_eq!(settings.first().map(String::as_str), Some("$0=3"));
    for want in ["$10=3", "$100=80.000", "$102=400.000", "$112=1500.000", "$120=2000.000"] {
        assert!(settings.iter().any(|l| l == want), "{want} missing: {settings:?}");
    }
    assert_eq!(settings.last().map(String::as_str), Some("$132=200.000"));
    r.send(b"$G\n");
    r.expect("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]");
    r.expect("ok");
    r.send(b"$#\n");
    r.expect("[G54:0.000,0.000,0.000]");
    for _ in 0..8 {
        r.line();
    }
    r.expect("[TLO:0.000]");
    r.expect("[PRB:0.000,0.000,0.000:0]");
    r.expect("ok");
    r.send(b"$N\n$X\n$Z\n$110=x\n$999=1\n$24=-1\n$24=30\n");
    for want in ["$N0=", "$N1=", "ok", "ok", "error:3", "error:2", "error:3", "error:4", "ok"] {
        r.expect(want);
    }

    // Character counting: several lines in one write (under 128 bytes), one answer each, in
    // order; a bad line among them gets its error and the rest still run.
    let batch = b"G21 G90\nG1 X1..2\nQQ1\nG1 X10 Y5 F3000\nG12 X1\nG1 Y1 Y2\n\nG0 Z1\n";
    assert!(batch.len() < 128);
    r.send(batch);
    for want in ["ok", "error:2", "error:1", "ok", "error:20", "error:25", "ok", "ok"] {
        r.expect(want);
    }
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:10.000,5.000,1.000|Bf:15,128|FS:0,0|"), "{st}");

    // `?` in the middle of a line is answered at once and does not touch the line.
    r.send(b"G1 X2");
    let st = r.status();
    assert!(st.contains("|Bf:15,123|"), "5 bytes wait in the buffer: {st}");
    r.send(b"0 Y");
    r.status();
    r.send(b"7\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:20.000,7.000,1.000|"), "{st}");

    // Garbage, each followed by a valid line that must still be answered `ok` and run: a
    // 300-byte line, binary noise, a word this machine does not know (W), an unknown M code.
    let mut long = vec![b'X'; 300];
    long.push(b'\n');
    r.send(&long);
    r.expect("error:11");
    r.send(b"G0 X1\n");
    r.expect("ok");
    r.send(b"\x01\x02\x7f\xfe\xff\xc3G\x00\n");
    let l = r.line();
    assert!(l.starts_with("error:"), "{l}");
    r.send(b"G0 X2\n");
    r.expect("ok");
    r.send(b"G0 X1 W5\n");
    r.expect("error:1");
    r.send(b"G0 X3\n");
    r.expect("ok");
    r.send(b"M333\n");
    r.expect("error:20");
    r.send(b"G0 X0 Y0 Z0\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:0.000,0.000,0.000|"), "{st}");

    // Feed override bytes show in the report; 0x90 restores 100 %.
    r.send(b"\x91\x91\x94");
    let st = r.status();
    assert!(st.ends_with("|Ov:119,100,100>"), "{st}");
    r.send(b"\x90\x96");
    assert!(r.status().ends_with("|Ov:100,50,100>"));

    // Soft limits: a jog past the travel is refused; a program move past it is an alarm.
    r.send(b"$J=G91 X600 F1000\n");
    r.expect("error:15");
    r.send(b"$J=X1\n");
    r.expect("error:22");
    r.send(b"G0 X600\n");
    r.expect("ALARM:2");
    let msg = r.line();
    assert!(msg.starts_with("[MSG:"), "{msg}");
    r.expect("error:9");
    assert!(r.status().starts_with("<Alarm|"));
    r.send(b"G0 X1\n");
    r.expect("error:9");
    r.send(b"$X\n");
    r.expect("[MSG:Caution: Unlocked]");
    r.expect("ok");

    // Check mode: parsed, not run; leaving it resets.
    r.send(b"$C\n");
    r.expect("[MSG:Enabled]");
    r.expect("ok");
    r.send(b"G0 X30\n");
    r.expect("ok");
    assert!(r.status().starts_with("<Check|MPos:0.000,0.000,0.000|"));
    r.send(b"$C\n");
    r.expect("[MSG:Disabled]");
    r.expect("ok");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");

    // Feed hold before the motion starts, resume; soft reset.
    r.send(b"G1 X40 F6000\n!");
    r.expect("ok");
    std::thread::sleep(Duration::from_millis(200));
    let st = r.status();
    assert!(st.starts_with("<Hold:0|"), "{st}");
    r.send(b"~");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:40.000,0.000,0.000|"), "{st}");

    // Spindle and coolant: switched on the board in program order, reported in grbl 1.1's
    // accessory field (`A:` after `Ov:`; S clockwise, C counterclockwise, F flood, M mist; none
    // while all are off) and in `$G`.
    r.send(b"M3 S1000\nM8\n");
    r.expect("ok");
    r.expect("ok");
    let st = r.until_status(|st| st.contains("|A:"));
    assert!(st.ends_with("|Ov:100,100,100|A:SF>"), "{st}");
    r.send(b"G1 X41 F6000 M4 M7\n");
    r.expect("ok");
    let st = r.until_status(|st| st.contains("|A:C"));
    assert!(st.ends_with("|A:CFM>"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M4 M7 M8 ") && gc.ends_with(" S1000]"), "{gc}");
    r.expect("ok");
    r.send(b"M9\n");
    r.expect("ok");
    let st = r.until_status(|st| st.ends_with("|A:C>"));
    assert!(st.starts_with("<Idle|MPos:41.000,"), "the move before M9 is done: {st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M4 M9 "), "{gc}");
    r.expect("ok");
    r.send(b"M5\n");
    r.expect("ok");
    let st = r.until_status(|st| !st.contains("|A:"));
    assert!(st.ends_with("|Ov:100,100,100>"), "{st}");
    // The real-time toggles (0xA0 flood, 0xA1 mist) switch the board at once, with motion
    // queued and held (not after it), and the parser's coolant (`$G`) with it.
    r.send(b"G1 X60 F300\n!");
    r.expect("ok");
    r.until_status(|st| st.starts_with("<Hold:0|"));
    r.send(b"\xA0");
    let st = r.until_status(|st| st.contains("|A:"));
    assert!(st.starts_with("<Hold:0|MPos:41.000,") && st.ends_with("|A:F>"), "{st}");
    r.send(b"\xA1");
    let st = r.until_status(|st| st.ends_with("|A:FM>"));
    assert!(st.starts_with("<Hold:0|MPos:41.000,"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M5 M7 M8 "), "{gc}");
    r.expect("ok");
    r.send(b"\xA0");
    r.until_status(|st| st.ends_with("|A:M>"));
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M5 M7 T"), "{gc}");
    r.expect("ok");
    r.send(b"\xA1");
    let st = r.until_status(|st| !st.contains("|A:"));
    assert!(st.starts_with("<Hold:0|MPos:41.000,"), "mist off before the move: {st}");
    r.send(b"~");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:60.000,") && !st.contains("|A:"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M5 M9 "), "{gc}");
    r.expect("ok");
    // The spindle stop (0x9E): nothing outside a feed hold; in one, the board's spindle goes
    // off (`A:` without S) while the parser keeps M3, a second 0x9E switches it on again, and
    // cycle start switches a stopped spindle on and resumes the motion after its spin-up.
    r.send(b"M3 S1000\nG1 X70 F60\n");
    r.expect("ok");
    r.expect("ok");
    r.until_status(|st| st.starts_with("<Run|") && st.ends_with("|A:S>"));
    r.send(b"\x9E");
    std::thread::sleep(Duration::from_millis(200));
    let st = r.status();
    assert!(st.starts_with("<Run|") && st.ends_with("|A:S>"), "not outside a hold: {st}");
    r.send(b"!");
    r.until_status(|st| st.starts_with("<Hold:0|"));
    r.send(b"\x9E");
    let st = r.until_status(|st| !st.contains("|A:"));
    assert!(st.starts_with("<Hold:0|"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M3 M9 ") && gc.ends_with(" S1000]"), "{gc}");
    r.expect("ok");
    r.send(b"\x9E");
    let st = r.until_status(|st| st.ends_with("|A:S>"));
    assert!(st.starts_with("<Hold:0|"), "{st}");
    r.send(b"\x9E");
    let st = r.until_status(|st| !st.contains("|A:"));
    let held_at = st.split('|').nth(1).unwrap().to_string();
    r.send(b"~");
    let resumed = Instant::now();
    let st = r.until_status(|st| st.ends_with("|A:S>"));
    assert!(st.starts_with("<Hold:0|") && st.contains(&held_at), "spinning up: {st}");
    let st = r.until_status(|st| !st.contains(&held_at));
    assert!(st.starts_with("<Run|") || st.starts_with("<Idle|"), "{st}");
    let spin_up = resumed.elapsed().as_secs_f64();
    assert!(spin_up >= motionctl::gcode::resume::SPIN_UP_S, "resumed after {spin_up} s");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:70.000,") && st.ends_with("|A:S>"), "{st}");
    r.send(b"M5\n");
    r.expect("ok");
    r.until_status(|st| !st.contains("|A:"));
    // Not in alarm or check mode, as grbl.
    r.send(b"$C\n");
    r.expect("[MSG:Enabled]");
    r.expect("ok");
    r.send(b"\xA0");
    assert!(!r.status().contains("|A:"));
    r.send(b"$C\n");
    r.expect("[MSG:Disabled]");
    r.expect("ok");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");
    // A soft reset stops them, as grbl's does.
    r.send(b"M3\nM7\n");
    r.expect("ok");
    r.expect("ok");
    r.until_status(|st| st.ends_with("|A:SM>"));
    r.send(b"\x18");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");
    let st = r.status();
    assert!(!st.contains("|A:"), "{st}");
    r.send(b"G0 X40\n");
    r.expect("ok");
    r.until_idle();

    // Work offsets: $# and WCO, kept across a soft reset as grbl keeps them; G92 is not.
    r.send(b"G10 L2 P1 X5 Y-2.5\nG92 Z1\n$#\n");
    r.expect("ok");
    r.expect("ok");
    r.expect("[G54:5.000,-2.500,0.000]");
    for _ in 0..7 {
        r.line();
    }
    r.expect("[G92:0.000,0.000,-1.000]");
    for want in ["[TLO:0.000]", "[PRB:0.000,0.000,0.000:0]", "ok"] {
        r.expect(want);
    }
    let st = r.status();
    assert!(st.contains("|WCO:5.000,-2.500,-1.000|"), "{st}");
    r.send(b"\x18");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");
    let st = r.status();
    assert!(st.contains("|WCO:5.000,-2.500,0.000|"), "{st}");
    r.send(b"$G\n");
    r.expect("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]");
    r.expect("ok");
    r.send(b"G0 X0 Y0\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:5.000,-2.500,0.000|"), "{st}");
}

#[test]
fn settings_reconfigure_the_board_and_outlive_the_bridge() {
    let dir = tmp_dir("settings");
    let machine = dir.0.join("machine.toml");
    let overlay = dir.0.join("machine.grbl.toml");
    let new_machine = "[MSG:the board has the new config and must be homed: '$H' to home]";
    {
        let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
        let mut r = Raw::connect(&mut b);
        // Values the machine file refuses are refused with its words, and change nothing.
        r.send(b"$100=0\n");
        r.expect("[MSG:$100=0: machine.axes[0].steps_per_mm: must be > 0 and <= 1000000, got 0]");
        r.expect("error:52");
        r.send(b"$26=100\n");
        let m = r.line();
        assert!(m.starts_with("[MSG:$26=100: machine.switch_debounce_ms: must be"), "{m}");
        r.expect("error:52");
        assert!(!overlay.exists());

        // Steps per mm: a new config on the board (which loses its homing).
        r.send(b"$100=7.77\n");
        r.expect(new_machine);
        r.expect("ok");
        assert!(r.status().starts_with("<Alarm|"));
        r.send(b"G0 X10\n");
        r.expect("error:9");
        r.send(b"$H\n");
        r.expect("ok");
        // 10 mm at 7.77 steps/mm is 78 steps: 10.039 mm.
        r.send(b"G0 X10\n");
        r.expect("ok");
        let st = r.until_idle();
        assert!(st.starts_with("<Idle|MPos:10.039,0.000,0.000|"), "{st}");

        // Travel and max rate; with the bridge's soft limits off ($20=0), the board's own
        // limits (from the new travel: X -500..20 mm) refuse a move they allowed before.
        r.send(b"$20=0\n$130=520\n");
        r.expect("ok");
        r.expect(new_machine);
        r.expect("ok");
        r.send(b"$110=600\n$H\n");
        for want in [new_machine, "ok", "ok"] {
            r.expect(want);
        }
        r.send(b"G0 X30\n");
        r.expect("ok");
        r.expect("ALARM:3");
        r.expect("[MSG:the board refused queued motion]");
        r.send(b"$X\n");
        r.expect("[MSG:Caution: Unlocked]");
        r.expect("ok");
        let s = r.settings();
        for want in ["$20=0", "$100=7.770", "$110=600.000", "$130=520.000", "$101=80.000"] {
            assert!(s.iter().any(|l| l == want), "{want} missing: {s:?}");
        }
    }
    // The machine file is untouched; the overlay beside it has the settings.
    assert_eq!(
        std::fs::read_to_string(&machine).unwrap(),
        std::fs::read_to_string(manifest().join("examples/corpus-machine.toml")).unwrap()
    );
    let text = std::fs::read_to_string(&overlay).unwrap();
    assert!(text.contains("100 = 7.77"), "{text}");

    // A new bridge reads them back and configures the board with them.
    let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
    let mut r = Raw::connect(&mut b);
    let s = r.settings();
    for want in ["$20=0", "$100=7.770", "$110=600.000", "$130=520.000"] {
        assert!(s.iter().any(|l| l == want), "{want} missing after a restart: {s:?}");
    }
    r.send(b"G0 X10\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:10.039,0.000,0.000|"), "{st}");
    r.send(b"G0 X30\n");
    r.expect("ok");
    r.expect("ALARM:3");
    r.expect("[MSG:the board refused queued motion]");
    r.send(b"$X\n");
    r.expect("[MSG:Caution: Unlocked]");
    r.expect("ok");

    // $RST=$: the machine file's values, on the board too; the overlay goes.
    r.send(b"$RST=$\n");
    r.expect(new_machine);
    r.expect("ok");
    r.send(b"$H\n");
    r.expect("ok");
    let s = r.settings();
    for want in ["$20=1", "$100=80.000", "$110=15000.000", "$130=1000.000"] {
        assert!(s.iter().any(|l| l == want), "{want} missing after $RST=$: {s:?}");
    }
    assert!(!overlay.exists(), "{}", std::fs::read_to_string(&overlay).unwrap_or_default());
    r.send(b"G0 X30\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:30.000,0.000,0.000|"), "{st}");
}

#[test]
fn startup_lines_run_after_a_reset_and_a_restart() {
    let dir = tmp_dir("startup");
    {
        let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
        let mut r = Raw::connect(&mut b);
        // A bad line is refused when stored, with the interpreter's words.
        r.send(b"$N1=G1 X1..2\n");
        let m = r.line();
        assert!(m.starts_with("[MSG:$N1: "), "{m}");
        r.expect("error:2");
        r.send(b"$N0=G20\n$N1=G0 X2\n$N\n");
        for want in ["ok", "ok", "$N0=G20", "$N1=G0 X2", "ok"] {
            r.expect(want);
        }
        assert_eq!(r.status().split('|').nth(1), Some("MPos:0.000,0.000,0.000"), "stored only");
        // A soft reset runs them, in order, each answered as grbl answers it.
        r.send(b"\x18");
        for want in ["", "Grbl 1.1h ['$' for help]", ">G20:ok", ">G0 X2:ok"] {
            r.expect(want);
        }
        let st = r.until_idle();
        assert!(st.starts_with("<Idle|MPos:50.800,0.000,0.000|"), "2 inches: {st}");
        r.send(b"$G\n");
        let gc = r.line();
        assert!(gc.contains(" G20 "), "{gc}");
        r.expect("ok");
    }
    // Kept across a restart: the connect's welcome runs them.
    let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
    let mut r = Raw::connect(&mut b);
    r.expect(">G20:ok");
    r.expect(">G0 X2:ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:50.800,0.000,0.000|"), "{st}");
    // An error is answered in its place, and the next line still runs.
    r.send(b"$N0=G0 X600\n");
    r.expect("ok");
    r.send(b"\x18");
    for want in ["", "Grbl 1.1h ['$' for help]", "ALARM:2"] {
        r.expect(want);
    }
    let m = r.line();
    assert!(m.starts_with("[MSG:axis X target 600.000 mm is outside its travel"), "{m}");
    r.expect(">G0 X600:error:9");
    assert!(r.status().starts_with("<Alarm|MPos:50.800,"), "the alarm stops the rest");
    // $RST=* forgets them.
    r.send(b"$X\n$RST=*\n$N\n");
    for want in ["[MSG:Caution: Unlocked]", "ok", "ok", "$N0=", "$N1=", "ok"] {
        r.expect(want);
    }
    assert!(!dir.0.join("machine.grbl.toml").exists());
}

/// Lines up to the answer of a line (`ok`, `error:N`), status reports skipped: those lines,
/// then the answer.
fn until_answer(r: &mut Raw) -> (Vec<String>, String) {
    let mut lines = Vec::new();
    loop {
        let l = r.line();
        if l == "ok" || l.starts_with("error:") {
            return (lines, l);
        }
        if !l.starts_with('<') {
            lines.push(l);
        }
    }
}

/// A bridge reading capability jobs from `dir`, and a raw session on it.
fn bridge_with_jobs(dir: &Path) -> (Bridge, Raw) {
    let jobs = dir.to_str().unwrap().to_string();
    let mut b = bridge(dir, &["--listen", "127.0.0.1:0", "--jobs", &jobs]);
    let r = Raw::connect(&mut b);
    (b, r)
}

/// `!` holds a running job where it is (the report's position unchanged for `wait`), `~`
/// resumes it.
fn hold_in_place(r: &mut Raw, wait: Duration) {
    r.send(b"!");
    let held = r.until_status(|st| st.starts_with("<Hold:0|"));
    std::thread::sleep(wait);
    let still = r.status();
    assert_eq!(held.split('|').nth(1), still.split('|').nth(1), "held in place: {still}");
    r.send(b"~");
}

#[test]
fn capability_jobs_run_from_dollar_commands_and_answer_real_time_bytes() {
    use motion::polar::playback::SizeScale;
    let dir = tmp_dir("caps");
    // An open arc of the built-in limacon stream (its first 40 blocks): about 4.6 s of board
    // time at speed 1, so a hold lands inside it.
    let arc =
        motionctl::polar::run::first_blocks(motion::polar::limacon_stream::BYTES, 40).unwrap();
    std::fs::write(dir.0.join("arc.bin"), &arc).unwrap();
    let scale = SizeScale::new(3, 2).unwrap();
    let model = motionctl::polar::run::model(&arc, motion::Rate::ONE, scale).unwrap();
    let (_b, mut r) = bridge_with_jobs(&dir.0);

    r.send(b"$\n");
    let help = r.line();
    assert!(help.contains(" $MILL=job $POLAR=stream $TURN=table $WIRE=job]"), "{help}");
    r.expect("ok");
    // Refusals name why: a capability the board lacks, a missing file, a bad argument.
    r.send(b"$MILL=case_a_milling.toml\n");
    r.expect("[MSG:the board runs no milling jobs (CAP_MILLING_JOB)]");
    r.expect("error:20");
    r.send(b"$POLAR=missing.bin\n");
    let m = r.line();
    assert!(m.starts_with("[MSG:reading ") && m.contains("missing.bin"), "{m}");
    r.expect("error:61");
    r.send(b"$POLAR=arc.bin 7\n");
    let m = r.line();
    assert!(m.contains("0.25..=2"), "{m}");
    r.expect("error:3");

    // The job runs; `?` reports Run with its position, `!` holds it where it is, `~` resumes.
    r.send(b"$POLAR=arc.bin 1 3:2\n");
    let st = r.until_status(|st| st.starts_with("<Run|") && !st.contains("MPos:0.000,0.000,"));
    assert!(st.contains("|Bf:15,"), "{st}");
    hold_in_place(&mut r, Duration::from_millis(300));
    let (msgs, answer) = until_answer(&mut r);
    assert_eq!(answer, "ok", "{msgs:?}");
    let events =
        format!("[MSG:POLAR arc.bin: {} of {} events in 40 blocks,", model.events, model.events);
    assert!(msgs.iter().any(|m| m.starts_with(&events)), "{msgs:?}");
    let end = msgs.iter().find(|m| m.starts_with("[MSG:POLAR end: ")).expect("an end line");
    let (board, host) = end.trim_end_matches(']').split_once("; host model ").unwrap();
    assert_eq!(board.trim_start_matches("[MSG:POLAR end: "), host, "{end}");
    assert!(msgs
        .iter()
        .any(|m| m == "[MSG:POLAR checks: ok (every event once, the host model's end)]"));

    // The bridge's machine is back: G-code runs on it.
    r.until_idle();
    r.send(b"G0 X5 Y2\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:5.000,2.000,0.000|"), "{st}");

    // Ctrl-X aborts a job: ALARM:3, then the welcome, as a reset during a cycle in grbl.
    r.send(b"$POLAR=arc.bin\n");
    r.until_status(|st| st.starts_with("<Run|"));
    r.send(b"\x18");
    let (mut lines, mut next) = (Vec::new(), r.line());
    while next.starts_with('<') {
        next = r.line();
    }
    lines.push(next);
    for _ in 0..4 {
        lines.push(r.line());
    }
    assert_eq!(
        lines,
        [
            "ALARM:3",
            "[MSG:arc.bin: aborted by the sender]",
            "",
            "Grbl 1.1h ['$' for help]",
            "[MSG:'$H'|'$X' to unlock]"
        ],
    );
    assert!(r.status().starts_with("<Alarm|"));
}

/// As [`until_answer`], asking `?` every 200 ms meanwhile (a job may run longer than a line's
/// wait): the lines that are neither reports nor the answer, and the answer (the report asked
/// for last read too).
fn until_answer_polling(r: &mut Raw) -> (Vec<String>, String) {
    let mut lines = Vec::new();
    loop {
        r.send(b"?");
        loop {
            let l = r.line();
            if l == "ok" || l.starts_with("error:") {
                let report = r.line();
                assert!(report.starts_with('<'), "{report}");
                return (lines, l);
            }
            if l.starts_with('<') {
                break;
            }
            lines.push(l);
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn turning_and_wire_jobs_run_from_dollar_commands() {
    let dir = tmp_dir("turn-wire");
    std::fs::write(dir.0.join("wire.toml"), "version = 1\nfr_mm2_per_min = 800\n").unwrap();
    let (_b, mut r) = bridge_with_jobs(&dir.0);

    // Bad arguments, a missing file, a board without Z-slide jobs: refused, nothing moves.
    r.send(b"$TURN=builtin 360 5\n");
    let m = r.line();
    assert!(m.starts_with("[MSG:$TURN= X range must be X0:X1"), "{m}");
    r.expect("error:3");
    r.send(b"$WIRE=wire.toml 3..1\n");
    let m = r.line();
    assert!(m.contains("FROM must be below TO"), "{m}");
    r.expect("error:3");
    r.send(b"$WIRE=missing.toml\n");
    let m = r.line();
    assert!(m.starts_with("[MSG:reading ") && m.contains("missing.toml"), "{m}");
    r.expect("error:61");
    r.send(b"$TURN=builtin 360 0:12.7 25.4\n");
    r.expect("[MSG:the board runs no turning jobs (CAP_TURNING_JOB)]");
    r.expect("error:20");

    // Two segments of the circle -> complex die as a wire job: `?` reports Run with X, Y, Z,
    // A (alpha), B (beta); `!` holds it where it is, `~` resumes; the summary against the
    // host model, then ok.
    let job =
        motionctl::cli_capabilities::wire_board_job(&dir.0.join("wire.toml"), Some(1..3)).unwrap();
    r.send(b"$WIRE=wire.toml 1..3\n");
    let st = r.until_status(|st| st.starts_with("<Run|"));
    assert_eq!(st.split('|').nth(1).unwrap().split(',').count(), 5, "{st}");
    hold_in_place(&mut r, Duration::from_millis(600));
    let (msgs, answer) = until_answer_polling(&mut r);
    assert_eq!(answer, "ok", "{msgs:?}");
    let head = format!(
        "[MSG:WIRE wire.toml: {} die, 2 of its {} segments at FR 800 mm^2/min (13.33 mm^2/s);",
        job.label, job.job_segments
    );
    assert!(msgs.iter().any(|m| m.starts_with(&head)), "{head} in {msgs:?}");
    let end = msgs.iter().find(|m| m.starts_with("[MSG:WIRE end: ")).expect("an end line");
    let (board, host) = end.trim_end_matches(']').split_once("; host model ").unwrap();
    assert_eq!(board.trim_start_matches("[MSG:WIRE end: "), host, "{end}");
    assert!(msgs.iter().any(|m| m.starts_with("[MSG:WIRE checks: ok")), "{msgs:?}");
    // The bridge's machine is back (where the job left its axes' steps).
    r.until_idle();
    r.send(b"G0 X1\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:1.000,"), "{st}");
}
