//! `--qemu`: runs the link firmware on QEMU's netduinoplus2 and connects to its UART over TCP.
//!
//! The UART is a TCP server on a free loopback port (`-serial tcp:127.0.0.1:PORT,server=on,
//! wait=on`: QEMU waits for motionctl to connect before the guest runs). `-icount shift=0,
//! sleep=off` makes virtual time deterministic (1 instruction = 1 ns) and skips idle time. The
//! emulator is killed when the [`Qemu`] is dropped: on success, on error and on Ctrl-C (the
//! runner turns Ctrl-C into an orderly stop).

use crate::transport::Tcp;
use std::fs::File;
use std::io;
use std::net::TcpListener;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Where `cargo xtask build --board netduinoplus2 --link` puts the link firmware.
pub const DEFAULT_FIRMWARE: &str = "target/fw-netduinoplus2-link/firmware";
/// How long QEMU may take to open its UART socket.
const LISTEN_TIMEOUT: Duration = Duration::from_secs(10);

/// A running QEMU; killed on drop.
pub struct Qemu {
    child: Child,
    pub port: u16,
    pub firmware: PathBuf,
    /// QEMU's stderr and the firmware's semihosting output.
    pub log: PathBuf,
}

/// Stops `qemu` (when the job ran on one) and passes the job's `result` on; an error then
/// names QEMU's log, where the firmware's side of it is.
pub fn finish<T, E: std::fmt::Display>(
    qemu: Option<Qemu>,
    result: Result<T, E>,
) -> anyhow::Result<T> {
    let log_note = qemu.as_ref().map(|q| format!(" (QEMU log: {})", q.log.display()));
    drop(qemu);
    result.map_err(|e| anyhow::anyhow!("{e}{}", log_note.unwrap_or_default()))
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The workspace root, when motionctl runs from inside it (or was built in it).
pub fn repo_root() -> Option<PathBuf> {
    let from_build = Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf);
    let cwd = std::env::current_dir().ok();
    let candidates =
        cwd.into_iter().flat_map(|d| d.ancestors().map(Path::to_path_buf).collect::<Vec<_>>());
    candidates.chain(from_build).find(|d| {
        d.join("xtask").is_dir() && d.join("motionctl").is_dir() && d.join("Cargo.toml").is_file()
    })
}

fn on_path(name: &str) -> bool {
    std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).any(|d| d.join(name).is_file()))
        .unwrap_or(false)
}

/// The firmware to run: `given`, or the default build, building it first when it is missing
/// and a repository and `cargo` are at hand. `say` reports what happens.
pub fn find_firmware(given: Option<&Path>, say: &dyn Fn(&str)) -> io::Result<PathBuf> {
    if let Some(p) = given {
        if p.is_file() {
            return Ok(p.to_path_buf());
        }
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!("firmware {} not found", p.display()),
        ));
    }
    let Some(root) = repo_root() else {
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!(
                "no link firmware: pass --firmware PATH (built by `cargo xtask build --board \
                 netduinoplus2 --link` as {DEFAULT_FIRMWARE})"
            ),
        ));
    };
    let elf = root.join(DEFAULT_FIRMWARE);
    if elf.is_file() {
        return Ok(elf);
    }
    if !on_path("cargo") {
        return Err(io::Error::new(
            io::ErrorKind::NotFound,
            format!("{} not found and cargo is not on PATH to build it", elf.display()),
        ));
    }
    say(&format!(
        "{} not found; building it: cargo xtask build --board netduinoplus2 --link",
        elf.display()
    ));
    let status = Command::new("cargo")
        .args(["xtask", "build", "--board", "netduinoplus2", "--link"])
        .current_dir(&root)
        .stdout(Stdio::inherit())
        .stderr(Stdio::inherit())
        .status()?;
    if !status.success() || !elf.is_file() {
        return Err(io::Error::other(format!(
            "building the link firmware failed ({status}); no {}",
            elf.display()
        )));
    }
    Ok(elf)
}

/// A free TCP port on 127.0.0.1 (free when asked; QEMU binds it right after).
/// A loopback TCP port free now.
pub fn free_port() -> io::Result<u16> {
    Ok(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// QEMU's netduinoplus2 running `firmware` as `motionctl --qemu` runs it: deterministic time,
/// semihosting, the UART a server on loopback `serial_port` that waits for its client, QEMU's
/// own output to `log`. `monitor_port`: QEMU's monitor on a loopback port too (a test's reset
/// button); none without. The one command line for every QEMU run of the link firmware.
pub fn link_command(
    firmware: &Path,
    serial_port: u16,
    monitor_port: Option<u16>,
    log: File,
) -> io::Result<Command> {
    let monitor =
        monitor_port.map_or("none".into(), |p| format!("tcp:127.0.0.1:{p},server=on,wait=off"));
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-M", "netduinoplus2", "-display", "none", "-monitor", &monitor])
        .args(["-icount", "shift=0,sleep=off"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-serial")
        .arg(format!("tcp:127.0.0.1:{serial_port},server=on,wait=on"))
        .arg("-kernel")
        .arg(firmware)
        // Its own process group: Ctrl-C reaches motionctl only, which aborts the board and
        // then kills QEMU.
        .process_group(0)
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log);
    Ok(cmd)
}

impl Qemu {
    /// Starts QEMU with `firmware` and connects to its UART.
    pub fn start(firmware: &Path) -> io::Result<(Qemu, Tcp)> {
        if !on_path("qemu-system-arm") {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                "qemu-system-arm is not installed (Debian/Ubuntu: apt-get install -y \
                 qemu-system-arm)",
            ));
        }
        let port = free_port()?;
        let log =
            std::env::temp_dir().join(format!("motionctl-qemu-{}-{port}.log", std::process::id()));
        let log_file = File::create(&log)?;
        let child = link_command(firmware, port, None, log_file)?
            .spawn()
            .map_err(|e| io::Error::new(e.kind(), format!("cannot start qemu-system-arm: {e}")))?;
        let mut q = Qemu { child, port, firmware: firmware.to_path_buf(), log };
        let addr = format!("127.0.0.1:{port}");
        let start = Instant::now();
        loop {
            if let Some(status) = q.child.try_wait()? {
                let text = std::fs::read_to_string(&q.log).unwrap_or_default();
                let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
                return Err(io::Error::other(format!("QEMU exited at once ({status}): {first}")));
            }
            match Tcp::connect(&addr) {
                Ok(t) => return Ok((q, t)),
                Err(e) if start.elapsed() > crate::link::patient(LISTEN_TIMEOUT) => {
                    return Err(io::Error::new(
                        e.kind(),
                        format!("QEMU did not open its UART socket {addr}: {e}"),
                    ));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        }
    }

    /// Whether the emulator is still running.
    pub fn running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
}
