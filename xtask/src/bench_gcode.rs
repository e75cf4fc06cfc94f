//! `cargo xtask bench-gcode` (also part of `cargo xtask bench`): G-code planning in bounded
//! memory. Generates a 1 000 000-line 3-D surfacing file in `target/` (a raster of `G1 X Y Z`
//! steps of 0.1 mm over a smooth surface, as CAM writes a finishing pass), runs the release
//! `motionctl plan` on it (check, plan and the host model's run of every segment, streamed) and
//! measures its wall time and peak resident memory (`VmHWM` of the child, polled from
//! `/proc/<pid>/status`).
//!
//! Keys: `gcode_plan_segments_per_s` (segments read, checked and planned per wall second by
//! `plan --no-model`: the pipeline that feeds the board; best of 3 runs, one process: one
//! core), `gcode_plan_peak_rss_mb` (the largest `VmHWM` of all the runs, MiB), and
//! `gcode_plan_with_model_segments_per_s` for `plan` itself, which also runs every segment
//! through the host model of the firmware, tick by tick over the 393 million ticks the job lasts
//! (the check `run`'s first pass makes before anything moves).

use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Lines of motion in the generated file (a 1000 x 1000 raster).
pub const LINES: usize = 1_000_000;
const RUNS: usize = 3;

/// Writes the surfacing program: `rows` passes along X of `cols` points, 0.1 mm apart, Z on the
/// surface z = -2 + 1.5 sin(0.06 x) cos(0.05 y) (mm), alternating direction, at 1500 mm/min.
/// Returns the number of lines.
pub fn generate(path: &Path, cols: usize, rows: usize) -> Result<usize> {
    let f = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = std::io::BufWriter::new(f);
    let mut lines = 0usize;
    let mut text = String::with_capacity(64 * 1024);
    let head = "(3-D surfacing: a raster over z = -2 + 1.5 sin 0.06x cos 0.05y, mm)\n\
                G21 G90 G17\nG0 Z5\nG0 X0 Y0\nS10000 M3\nG1 Z0 F1500\n";
    text.push_str(head);
    lines += head.lines().count();
    for r in 0..rows {
        let y = r as f64 * 0.1;
        for k in 0..cols {
            let c = if r % 2 == 0 { k } else { cols - 1 - k };
            let x = c as f64 * 0.1;
            let z = -2.0 + 1.5 * (x * 0.06).sin() * (y * 0.05).cos();
            let _ = writeln!(text, "G1 X{x:.3} Y{y:.3} Z{z:.4}");
            lines += 1;
            if text.len() > 60 * 1024 {
                w.write_all(text.as_bytes())?;
                text.clear();
            }
        }
    }
    text.push_str("G0 Z5\nM5\nM2\n");
    lines += 3;
    w.write_all(text.as_bytes())?;
    w.flush()?;
    Ok(lines)
}

/// Peak resident memory of a running process so far, KiB (`VmHWM`).
fn vm_hwm_kib(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

struct Run {
    seconds: f64,
    peak_kib: u64,
    segments: u64,
}

/// One `motionctl plan` of `file`: wall time, peak memory and the segments it planned.
fn run_plan(motionctl: &Path, file: &Path, machine: &Path, out: &Path, model: bool) -> Result<Run> {
    let stdout = std::fs::File::create(out)?;
    let t = Instant::now();
    let mut child = Command::new(motionctl)
        .arg("plan")
        .arg(file)
        .arg("--machine")
        .arg(machine)
        .args((!model).then_some("--no-model"))
        .stdout(Stdio::from(stdout))
        .stderr(Stdio::inherit())
        .spawn()
        .with_context(|| format!("starting {}", motionctl.display()))?;
    let mut peak = 0u64;
    let status = loop {
        if let Some(k) = vm_hwm_kib(child.id()) {
            peak = peak.max(k);
        }
        if let Some(st) = child.try_wait()? {
            break st;
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let seconds = t.elapsed().as_secs_f64();
    let text = std::fs::read_to_string(out)?;
    if !status.success() {
        bail!("motionctl plan {} failed ({status}):\n{text}", file.display());
    }
    // "segments   N planned, M run by the model, U underruns"
    let line = text
        .lines()
        .find(|l| l.starts_with("segments "))
        .context("motionctl plan printed no segments line")?;
    let nums: Vec<u64> =
        line.split(|c: char| !c.is_ascii_digit()).filter_map(|w| w.parse().ok()).collect();
    let Some(&planned) = nums.first() else { bail!("unreadable segments line: {line}") };
    if model && nums.get(1) != Some(&planned) {
        bail!("the model did not run every segment: {line}");
    }
    if peak == 0 {
        bail!("could not read the peak memory of motionctl from /proc");
    }
    Ok(Run { seconds, peak_kib: peak, segments: planned })
}

/// Generates the file, builds the release motionctl and measures `plan`.
pub fn bench(root: &Path) -> Result<Vec<(&'static str, f64)>> {
    let status = crate::cargo(root).args(["build", "--release", "-p", "motionctl"]).status()?;
    if !status.success() {
        bail!("building motionctl (release) failed");
    }
    let motionctl = root.join("target/release/motionctl");
    let dir = root.join("target/bench-gcode");
    std::fs::create_dir_all(&dir)?;
    let file: PathBuf = dir.join("surfacing-1m.ngc");
    let lines = generate(&file, 1000, LINES / 1000)?;
    let bytes = std::fs::metadata(&file)?.len();
    println!("generated {} ({lines} lines, {:.1} MB)", file.display(), bytes as f64 / 1e6);
    let machine = root.join("motionctl/examples/corpus-machine.toml");
    let measure = |model: bool| -> Result<(f64, f64, f64)> {
        let what = if model { "plan" } else { "plan --no-model" };
        let mut runs = Vec::new();
        for i in 0..RUNS {
            let r = run_plan(&motionctl, &file, &machine, &dir.join("plan.txt"), model)?;
            println!(
                "  {what}, run {}: {} segments in {:.3} s ({:.0} segments/s), peak RSS {:.1} MiB",
                i + 1,
                r.segments,
                r.seconds,
                r.segments as f64 / r.seconds,
                r.peak_kib as f64 / 1024.0
            );
            runs.push(r);
        }
        let best = runs.iter().map(|r| r.seconds).fold(f64::INFINITY, f64::min);
        let peak_mib = runs.iter().map(|r| r.peak_kib).max().unwrap_or(0) as f64 / 1024.0;
        Ok((runs[0].segments as f64, best, peak_mib))
    };
    let (segments, best, peak_mib) = measure(true)?;
    let (_, best_no_model, peak_no_model_mib) = measure(false)?;
    Ok(vec![
        ("gcode_plan_segments_per_s", (segments / best_no_model).round()),
        ("gcode_plan_peak_rss_mb", (peak_mib.max(peak_no_model_mib) * 10.0).round() / 10.0),
        ("gcode_plan_file_lines", lines as f64),
        ("gcode_plan_segments", segments),
        ("gcode_plan_seconds", (best_no_model * 1000.0).round() / 1000.0),
        ("gcode_plan_with_model_segments_per_s", (segments / best).round()),
    ])
}
