//! `cargo xtask gcode-e2e`: real G-code files from the corpus (written by CAM programs and
//! senders, host/gcode/tests/corpus) run end to end: through motion-gcode, the planner and the
//! link protocol to the simulated board, and one to the link firmware in QEMU. Each run must
//! execute every segment once, in order, and end at the host model's position, which
//! `motionctl`'s planning already pinned to the program's end point. Then a power cut: the QEMU
//! board is killed in the middle of the file, and `run --resume` on a fresh board finishes the
//! job from the line its journal kept, at the program's end.

use crate::e2e::{build_motionctl, run_motionctl, summary_ints};
use anyhow::{bail, Context, Result};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const MACHINE: &str = "motionctl/examples/corpus-machine.toml";
/// Short files (a few seconds of machine time each): G10 L2/L20 offsets with G53, and a
/// helical thread mill in G91 with R-form arcs.
const ON_SIM: [&str; 2] = ["linuxcnc-g10-l2-l20.ngc", "cncjs-helical-thread-milling.gcode"];
const ON_QEMU: &str = "cncjs-helical-thread-milling.gcode";

pub fn test(root: &Path) -> Result<()> {
    let bin = build_motionctl(root)?;
    let runs = ON_SIM.iter().map(|f| (*f, "--sim")).chain([(ON_QEMU, "--qemu")]);
    for (file, board) in runs {
        let path = format!("host/gcode/tests/corpus/{file}");
        let args: Vec<String> = ["run", &path, "--machine", MACHINE, board, "--yes"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let (ok, stdout, wall) = run_motionctl(root, &bin, &args)?;
        if !ok {
            bail!("{file} on {board}: motionctl failed (output above)");
        }
        let s = summary_ints(&stdout, "motionctl-summary ")?;
        let get = |k: &str| s.get(k).copied().unwrap_or(-1);
        if get("ok") != 1 || get("hash_ok") != 1 || get("positions_ok") != 1 {
            bail!("{file} on {board}: the board's result differs from the host model: {s:?}");
        }
        println!(
            "  {file} on {board}: {} segments executed once, in order, at the programmed end; \
             {:.1} s wall",
            get("done"),
            wall.as_secs_f64()
        );
    }
    power_cut_and_resume(root, &bin)
}

/// The journal line from which the cut is made (the file's arcs are lines 12 to 15).
const CUT_AT_LINE: u64 = 12;

/// Runs the QEMU file, kills QEMU once the run's journal is at [`CUT_AT_LINE`], then resumes.
fn power_cut_and_resume(root: &Path, bin: &Path) -> Result<()> {
    let path = format!("host/gcode/tests/corpus/{ON_QEMU}");
    let journal = root.join(format!("{path}.journal"));
    let _ = std::fs::remove_file(&journal);
    let args = ["run", &path, "--machine", MACHINE, "--qemu", "--yes"];
    println!("  $ motionctl {} (QEMU killed at line {CUT_AT_LINE} or later)", args.join(" "));
    let mut child = Command::new(bin)
        .args(args)
        .current_dir(root)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .context("starting motionctl")?;
    let line_now = || -> Option<u64> {
        let text = std::fs::read_to_string(&journal).ok()?;
        let l = text.lines().find_map(|l| l.strip_prefix("line = "))?;
        l.trim().parse().ok()
    };
    let t0 = Instant::now();
    while line_now().is_none_or(|l| l < CUT_AT_LINE) {
        if child.try_wait()?.is_some() {
            bail!("power cut: the job ended before line {CUT_AT_LINE}");
        }
        if t0.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            bail!("power cut: the journal never reached line {CUT_AT_LINE}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    // The board dies: motionctl loses the link, waits for it, gives up and says how to go on.
    crate::run_status("kill QEMU", Command::new("pkill").args(["-f", "qemu-system-arm"]))?;
    let out = child.wait_with_output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    let cut_line = line_now().context("power cut: the journal is gone")?;
    if out.status.success() || !err.contains("--resume") {
        bail!("power cut: motionctl did not stop with a way to go on:\n{err}");
    }
    println!("  power cut at line {cut_line}; resuming on a fresh board");
    let args: Vec<String> =
        [&args[..], &["--resume"]].concat().iter().map(|s| s.to_string()).collect();
    let (ok, stdout, wall) = run_motionctl(root, bin, &args)?;
    if !ok {
        bail!("resume after a power cut: motionctl failed (output above)");
    }
    let s = summary_ints(&stdout, "motionctl-summary ")?;
    let get = |k: &str| s.get(k).copied().unwrap_or(-1);
    if get("ok") != 1
        || get("positions_ok") != 1
        || !stdout.contains(&format!("from line {cut_line}"))
    {
        bail!("resume after a power cut: not from line {cut_line} to the program's end: {s:?}");
    }
    if journal.exists() {
        bail!("resume after a power cut: the finished job left its journal");
    }
    println!(
        "  resumed from line {cut_line}: {} segments to the programmed end; {:.1} s wall",
        get("done"),
        wall.as_secs_f64()
    );
    Ok(())
}
