//! `cargo xtask gcode-corpus [--all] [FILE...]`: the files of the G-code corpus (written by CAM
//! programs and senders, host/gcode/tests/corpus) run one by one through `motionctl run --qemu`
//! on the link firmware in QEMU, on the corpus machine. Each must execute every segment once and
//! in order (`hash_ok`), end at the host model's position (`positions_ok`), and every status
//! report of the board must lie on the planned path (`path_ok`: within
//! `motionctl::runner::PATH_LIMIT_STEPS` per axis of the segment it was executing).
//!
//! Without `--all` the files run whose planned machine time (`motionctl plan --json`: the host
//! model's time plus dwells) is at most [`SHORT_MACHINE_S`]; `cargo xtask test` runs those of
//! at most [`TEST_MACHINE_S`].
//! With `--all` every file runs (about 45 min of machine time, 1 h 45 min of QEMU). Files the
//! planner refuses on purpose ([`REFUSED`]) are listed as refused with their first error, and do
//! not fail the run. The runs use the corpus machine at [`QEMU_TICK_HZ`] (see there). A table goes to stdout, the same rows to `target/gcode-corpus.json`, and
//! each run's output to `target/gcode-corpus/FILE.log`. Each file runs from a copy there, so the
//! run journal `motionctl run` keeps beside its file (`FILE.journal`) stays out of the corpus.

use crate::e2e::{build_motionctl, summary, wait_at_most};
use crate::firmware::{self, Board};
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub const CORPUS: &str = "host/gcode/tests/corpus";
/// The short set: files of at most this much planned machine time.
pub const SHORT_MACHINE_S: f64 = 30.0;
/// The set `cargo xtask test` runs: QEMU runs slower than the board's clock (about 2.3x at
/// [`QEMU_TICK_HZ`] on an idle 2-core machine), and the suite's time is CI's.
pub const TEST_MACHINE_S: f64 = 10.0;
/// The machine file every corpus file runs on: travel enough for all of them.
pub(crate) const MACHINE: &str = "motionctl/examples/corpus-machine.toml";
/// The tick the corpus machine runs at in QEMU. QEMU's wall time grows with the tick count:
/// `linuxcnc-g10-l2-l20.ngc` (3.4 s of machine time) took 8.5 s at 50 kHz against 15.8 s at the
/// file's 100 kHz on an idle host. The fastest axis (20 000 steps/s) still fits, one step per
/// two ticks; the machine loader checks that for every axis.
const QEMU_TICK_HZ: u32 = 50_000;
/// Where the runs' machine file (the corpus machine at [`QEMU_TICK_HZ`]) is written.
const QEMU_MACHINE: &str = "target/gcode-corpus/machine.toml";
/// Files the planner refuses on purpose, with a piece of the error saying why (LinuxCNC's rs274
/// comparison in `cargo xtask test` covers which lines): spindle-synchronised motion needs
/// spindle feedback the board does not have.
const REFUSED: [(&str, &str); 1] = [("linuxcnc-mmount-oword-canned.ngc", "G33")];
/// Wall-clock limit of one file: QEMU on a loaded host runs far slower than real time (about
/// 1/11 measured on CI); motionctl's own board-time watch stops a job that overruns first.
const WALL_PER_MACHINE_S: f64 = 20.0;
const WALL_SLACK_S: f64 = 300.0;
const JSON_OUT: &str = "target/gcode-corpus.json";
const LOG_DIR: &str = "target/gcode-corpus";

/// Which files run.
enum Select {
    /// The files of at most this many planned machine seconds.
    Short(f64),
    All,
    Named(Vec<String>),
}

enum Outcome {
    /// Planned, not run yet.
    ToRun,
    Ok,
    Failed(String),
    Refused(String),
    /// Longer than the short set: (machine seconds, the set's limit).
    NotRun(f64, f64),
}

struct Row {
    file: String,
    lines: usize,
    segments: Option<u64>,
    machine_s: Option<f64>,
    wall_s: Option<f64>,
    path_samples: Option<u64>,
    path_max_dev_steps: Option<f64>,
    outcome: Outcome,
}

/// The command: `[--all] [FILE...]`.
pub fn command(root: &Path, args: &[String]) -> Result<()> {
    let mut all = false;
    let mut named = Vec::new();
    for a in args {
        match a.as_str() {
            "--all" => all = true,
            s if s.starts_with('-') => bail!("gcode-corpus: unknown option {s} (try --all)"),
            s => named.push(s.to_string()),
        }
    }
    let select = match (all, named.is_empty()) {
        (true, false) => bail!("gcode-corpus: give --all or file names, not both"),
        (true, true) => Select::All,
        (false, true) => Select::Short(SHORT_MACHINE_S),
        (false, false) => Select::Named(named),
    };
    run(root, select)
}

/// The files of at most [`TEST_MACHINE_S`], for `cargo xtask test`.
pub fn short_set(root: &Path) -> Result<()> {
    run(root, Select::Short(TEST_MACHINE_S))
}

fn run(root: &Path, select: Select) -> Result<()> {
    let files = corpus_files(root)?;
    let chosen: Vec<String> = match &select {
        Select::Named(names) => names.iter().map(|n| pick(&files, n)).collect::<Result<_>>()?,
        _ => files.clone(),
    };
    let elf = firmware::build(root, Board::Netduinoplus2, &["link"])?;
    let bin = build_motionctl(root)?;
    std::fs::create_dir_all(root.join(LOG_DIR))?;
    qemu_machine(root)?;
    let mut rows = Vec::new();
    for file in &chosen {
        let mut row = plan(root, &bin, file)?;
        if let (Select::Short(limit), Outcome::ToRun, Some(s)) =
            (&select, &row.outcome, row.machine_s)
        {
            if s > *limit {
                row.outcome = Outcome::NotRun(s, *limit);
            }
        }
        rows.push(row);
    }
    // Shortest first: a long run cut short still leaves the quick files' results.
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by(|&a, &b| {
        rows[a].machine_s.unwrap_or(0.0).total_cmp(&rows[b].machine_s.unwrap_or(0.0))
    });
    for i in order {
        if matches!(rows[i].outcome, Outcome::ToRun) {
            run_one(root, &bin, &elf, &mut rows[i])?;
            write_json(root, &rows)?;
        }
        println!("  {}", describe(&rows[i]));
    }
    write_json(root, &rows)?;
    println!("\n{}", table(&rows));
    println!("(rows in {JSON_OUT}, each run's output in {LOG_DIR}/FILE.log)");
    let failed: Vec<&str> = rows
        .iter()
        .filter(|r| matches!(r.outcome, Outcome::Failed(_)))
        .map(|r| r.file.as_str())
        .collect();
    if !failed.is_empty() {
        bail!("{} of {} corpus files failed: {}", failed.len(), rows.len(), failed.join(", "));
    }
    Ok(())
}

/// Writes [`QEMU_MACHINE`]: [`MACHINE`] with its one `tick_hz` line set to [`QEMU_TICK_HZ`],
/// loaded back to check it is still a valid machine at that tick.
fn qemu_machine(root: &Path) -> Result<()> {
    let src = std::fs::read_to_string(root.join(MACHINE))
        .with_context(|| format!("reading {MACHINE}"))?;
    let (out, n) = with_tick(&src, QEMU_TICK_HZ);
    if n != 1 {
        bail!("{MACHINE}: expected one `tick_hz = ...` line, found {n}");
    }
    let m = motionctl::job::parse_machine_toml(&out)
        .map_err(|e| anyhow::anyhow!("{MACHINE} at {QEMU_TICK_HZ} Hz: {e}"))?;
    if m.tick_hz != QEMU_TICK_HZ {
        bail!("{MACHINE}: the tick_hz line did not set the tick (read {} Hz)", m.tick_hz);
    }
    std::fs::write(root.join(QEMU_MACHINE), out).with_context(|| format!("writing {QEMU_MACHINE}"))
}

/// `src` with every line that sets `tick_hz` set to `tick_hz`, and how many there were.
fn with_tick(src: &str, tick_hz: u32) -> (String, usize) {
    let mut n = 0;
    let mut out = String::with_capacity(src.len());
    for line in src.lines() {
        if line.trim_start().starts_with("tick_hz") && line.contains('=') {
            n += 1;
            let _ = writeln!(out, "tick_hz = {tick_hz}");
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    (out, n)
}

/// The corpus's G-code files (not its notes, nor a run journal a stopped run left), by name.
fn corpus_files(root: &Path) -> Result<Vec<String>> {
    let dir = root.join(CORPUS);
    let mut files = Vec::new();
    for e in std::fs::read_dir(&dir).with_context(|| format!("reading {}", dir.display()))? {
        let e = e?;
        let name = e.file_name().to_string_lossy().into_owned();
        if e.file_type()?.is_file() && !name.ends_with(".md") && !name.ends_with(".journal") {
            files.push(name);
        }
    }
    files.sort();
    if files.is_empty() {
        bail!("{} holds no G-code files", dir.display());
    }
    Ok(files)
}

/// A corpus file by its name or its path.
fn pick(files: &[String], given: &str) -> Result<String> {
    let name = Path::new(given).file_name().map(|n| n.to_string_lossy().into_owned());
    match name.filter(|n| files.contains(n)) {
        Some(n) => Ok(n),
        None => bail!("{given} is not a file of {CORPUS} (it has: {})", files.join(", ")),
    }
}

/// `motionctl plan --json`: the file's segments and machine time, or why it is refused.
fn plan(root: &Path, bin: &Path, file: &str) -> Result<Row> {
    let path = format!("{CORPUS}/{file}");
    let text =
        std::fs::read_to_string(root.join(&path)).with_context(|| format!("reading {path}"))?;
    let mut row = Row {
        file: file.to_string(),
        lines: text.lines().count(),
        segments: None,
        machine_s: None,
        wall_s: None,
        path_samples: None,
        path_max_dev_steps: None,
        outcome: Outcome::ToRun,
    };
    let out = Command::new(bin)
        .args(["plan", &path, "--machine", QEMU_MACHINE, "--json"])
        .current_dir(root)
        .output()
        .with_context(|| format!("could not start {}", bin.display()))?;
    let refusal = REFUSED.iter().find(|r| r.0 == file);
    if !out.status.success() {
        let first = first_error(&String::from_utf8_lossy(&out.stderr));
        row.outcome = match refusal {
            Some((_, why)) if first.contains(why) => Outcome::Refused(first),
            Some((_, why)) => Outcome::Failed(format!("refused, but not for {why}: {first}")),
            None => Outcome::Failed(format!("motionctl plan refused it: {first}")),
        };
        return Ok(row);
    }
    if let Some((_, why)) = refusal {
        row.outcome = Outcome::Failed(format!("plans, but should be refused ({why})"));
        return Ok(row);
    }
    let v: serde_json::Value = serde_json::from_slice(&out.stdout)
        .with_context(|| format!("motionctl plan --json of {file}: not JSON"))?;
    let num = |k: &str| v[k].as_f64().with_context(|| format!("plan --json of {file}: no {k}"));
    row.segments = Some(num("segments")? as u64);
    row.machine_s = Some(num("model_s")? + num("dwell_s")?);
    Ok(row)
}

/// The first error of motionctl's message: one line, the file's line and the reason.
fn first_error(stderr: &str) -> String {
    let msg = stderr
        .lines()
        .find_map(|l| l.strip_prefix("motionctl: error: "))
        .unwrap_or_else(|| stderr.lines().last().unwrap_or("(no message)"));
    // "N errors in the G-code: FILE:L:C: error: ...; FILE:L:C: error: ..."
    let first = msg.split("; ").next().unwrap_or(msg);
    let first = first.split_once("G-code: ").map_or(first, |(_, rest)| rest);
    first.strip_prefix(&format!("{CORPUS}/")).unwrap_or(first).to_string()
}

/// `motionctl run --qemu` of one planned file; its output to the log, the outcome to `row`.
fn run_one(root: &Path, bin: &Path, elf: &Path, row: &mut Row) -> Result<()> {
    let path = format!("{LOG_DIR}/{}", row.file);
    std::fs::copy(root.join(CORPUS).join(&row.file), root.join(&path))
        .with_context(|| format!("copying {} to {LOG_DIR}", row.file))?;
    let log_path = root.join(LOG_DIR).join(format!("{}.log", row.file));
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("creating {}", log_path.display()))?;
    let machine_s = row.machine_s.unwrap_or(0.0);
    let limit = Duration::from_secs_f64(machine_s * WALL_PER_MACHINE_S + WALL_SLACK_S);
    println!("  $ motionctl run {path} --machine {QEMU_MACHINE} --qemu --yes  ({machine_s:.1} s)");
    let start = Instant::now();
    let mut child = Command::new(bin)
        .args(["run", &path, "--machine", QEMU_MACHINE, "--qemu", "--yes", "--firmware"])
        .arg(elf)
        .current_dir(root)
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log)
        .spawn()
        .with_context(|| format!("could not start {}", bin.display()))?;
    let status = wait_at_most(&mut child, start, limit)?;
    row.wall_s = Some(start.elapsed().as_secs_f64());
    let out = std::fs::read_to_string(&log_path).unwrap_or_default();
    let s = summary(&out).ok();
    let get = |k: &str| s.as_ref().and_then(|s| s.get(k).copied());
    row.path_samples = get("path_samples").map(|x| x as u64);
    row.path_max_dev_steps = get("path_max_dev_steps");
    let flags = ["ok", "hash_ok", "positions_ok", "path_ok"];
    let bad: Vec<&str> = flags.iter().copied().filter(|k| get(k) != Some(1.0)).collect();
    row.outcome = match status {
        None => Outcome::Failed(format!("did not finish within {} s; stopped", limit.as_secs())),
        Some(st) if !st.success() || s.is_none() || !bad.is_empty() => {
            let why = out
                .lines()
                .rev()
                .find_map(|l| l.strip_prefix("motionctl: error: "))
                .map(str::to_string)
                .unwrap_or_else(|| format!("exit {st}; not 1: {}", bad.join(", ")));
            Outcome::Failed(why)
        }
        Some(_) if row.path_samples.unwrap_or(0) == 0 => {
            Outcome::Failed("no status report was checked against the path".into())
        }
        Some(_) => Outcome::Ok,
    };
    Ok(())
}

fn result_text(r: &Row) -> String {
    match &r.outcome {
        Outcome::ToRun => "not run yet".into(),
        Outcome::Ok => "ok".into(),
        Outcome::Failed(why) => format!("FAILED: {why}"),
        Outcome::Refused(why) => format!("refused: {why}"),
        Outcome::NotRun(s, limit) => format!("not run: {s:.0} s > {limit:.0} s (--all runs it)"),
    }
}

fn describe(r: &Row) -> String {
    format!("{}: {}", r.file, result_text(r))
}

fn table(rows: &[Row]) -> String {
    let opt = |v: Option<String>| v.unwrap_or_else(|| "-".into());
    let mut t = format!(
        "{:<40} {:>6} {:>8} {:>9} {:>8} {:>8} {:>8}  result\n",
        "file", "lines", "segments", "machine s", "wall s", "samples", "max dev"
    );
    for r in rows {
        let _ = writeln!(
            t,
            "{:<40} {:>6} {:>8} {:>9} {:>8} {:>8} {:>8}  {}",
            r.file,
            r.lines,
            opt(r.segments.map(|x| x.to_string())),
            opt(r.machine_s.map(|x| format!("{x:.1}"))),
            opt(r.wall_s.map(|x| format!("{x:.1}"))),
            opt(r.path_samples.map(|x| x.to_string())),
            opt(r.path_max_dev_steps.map(|x| format!("{x:.2}"))),
            result_text(r)
        );
    }
    t
}

/// The rows so far (those not yet run say so).
fn write_json(root: &Path, rows: &[Row]) -> Result<()> {
    let json = serde_json::Value::Array(rows.iter().map(row_json).collect());
    std::fs::write(root.join(JSON_OUT), serde_json::to_string_pretty(&json)? + "\n")
        .with_context(|| format!("writing {JSON_OUT}"))
}

fn row_json(r: &Row) -> serde_json::Value {
    let result = match r.outcome {
        Outcome::ToRun => "to_run",
        Outcome::Ok => "ok",
        Outcome::Failed(_) => "failed",
        Outcome::Refused(_) => "refused",
        Outcome::NotRun(..) => "not_run",
    };
    serde_json::json!({
        "file": r.file,
        "lines": r.lines,
        "segments": r.segments,
        "machine_s": r.machine_s,
        "wall_s": r.wall_s,
        "path_samples": r.path_samples,
        "path_max_dev_steps": r.path_max_dev_steps,
        "result": result,
        "detail": result_text(r),
    })
}

#[cfg(test)]
mod tests {
    use super::{first_error, with_tick};

    #[test]
    fn the_tick_line_is_replaced_and_counted() {
        let (out, n) =
            with_tick("[machine]\ntick_hz = 100_000  # note\n[[machine.axes]]\n", 50_000);
        assert_eq!(n, 1);
        assert_eq!(out, "[machine]\ntick_hz = 50000\n[[machine.axes]]\n");
        assert_eq!(with_tick("[machine]\n", 50_000).1, 0);
    }

    #[test]
    fn the_first_error_of_a_refused_file_is_its_line_and_reason() {
        let stderr = "motionctl: a.ngc:3: warning: message: hi\nmotionctl: error: 2 errors in \
                      the G-code: host/gcode/tests/corpus/a.ngc:314:1: error: G33/G33.1 needs \
                      spindle feedback; host/gcode/tests/corpus/a.ngc:316:1: error: other\n";
        assert_eq!(first_error(stderr), "a.ngc:314:1: error: G33/G33.1 needs spindle feedback");
        assert_eq!(first_error("motionctl: error: no such file\n"), "no such file");
    }
}
