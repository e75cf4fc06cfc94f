//! Shared helpers of the `grbl_*` tests: a `motionctl grbl` bridge on the simulated board (run
//! at [`SIM_SPEED`] times real time, so the files take seconds), a scratch directory, and a raw
//! session with the bridge, over TCP or its pseudo-terminal.
#![allow(dead_code)]

use std::fs::OpenOptions;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

pub fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A `motionctl grbl` process, killed when dropped.
pub struct Bridge {
    pub child: Child,
}

impl Drop for Bridge {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The simulated board's machine time per wall time: the corpus files take about 100 s of
/// machine time together.
pub const SIM_SPEED: &str = "4";

/// A bridge on `dir`/machine.toml (a copy of examples/corpus-machine.toml, made if absent: the
/// bridge writes its settings overlay beside it).
pub fn bridge(dir: &Path, endpoint: &[&str]) -> Bridge {
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
pub struct TmpDir(pub PathBuf);

impl Drop for TmpDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

pub fn tmp_dir(tag: &str) -> TmpDir {
    let d = std::env::temp_dir().join(format!("motionctl-grbl-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TmpDir(d)
}

/// What a raw session talks through: a TCP stream or the pseudo-terminal.
pub trait Port: Read + Write {}
impl<T: Read + Write> Port for T {}

/// A raw session with the bridge.
pub struct Raw {
    s: Box<dyn Port>,
    buf: Vec<u8>,
}

impl Raw {
    /// Connects to a `--listen` bridge and reads the welcome.
    pub fn connect(b: &mut Bridge) -> Raw {
        let (addr, _drain) = listen_addr(b);
        let s = TcpStream::connect(&addr).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
        Raw::welcomed(Box::new(s))
    }

    /// Opens a `--pty` bridge's port, as a sender opens a serial port, and reads the welcome.
    pub fn open_pty(port: &Path) -> Raw {
        let f = OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(nix::libc::O_NOCTTY | nix::libc::O_NONBLOCK)
            .open(port)
            .unwrap_or_else(|e| panic!("open {}: {e}", port.display()));
        Raw::welcomed(Box::new(f))
    }

    fn welcomed(s: Box<dyn Port>) -> Raw {
        let mut r = Raw { s, buf: Vec::new() };
        r.expect("");
        r.expect("Grbl 1.1h ['$' for help]");
        r
    }

    /// `$$`: the settings, in order.
    pub fn settings(&mut self) -> Vec<String> {
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

    pub fn send(&mut self, b: &[u8]) {
        self.s.write_all(b).unwrap();
    }

    /// The next line (without `\r\n`), within 10 s.
    pub fn line(&mut self) -> String {
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
                // A socket waits its read timeout first; the pseudo-terminal does not wait.
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(2))
                }
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => panic!("read: {e}"),
            }
        }
    }

    pub fn expect(&mut self, want: &str) {
        assert_eq!(self.line(), want);
    }

    pub fn status(&mut self) -> String {
        self.send(b"?");
        let l = self.line();
        assert!(l.starts_with('<') && l.ends_with('>'), "{l}");
        l
    }

    /// Polls `?` until a report passes `want` (within 10 s); that report.
    pub fn until_status(&mut self, want: impl Fn(&str) -> bool) -> String {
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
    pub fn until_idle(&mut self) -> String {
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

/// Waits for a `--pty` bridge's symlink (at most 20 s).
pub fn wait_for_port(b: &mut Bridge, port: &Path) {
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
}
